//! The narrow band of one triangle mesh: signed distances at the grid nodes near its
//! surface, and the sign of every other region, at a cost that follows the surface area
//! (in voxels) and not the volume of the mesh's box. The approach of OpenVDB's
//! mesh-to-volume and of closest-point transforms (Mauch 2003):
//!
//! 1. **Seed**: every node of each triangle's box (rounded out to nodes, so the two node
//!    layers on either side of the surface) takes the nearest of the triangles whose boxes
//!    hold it.
//! 2. **Propagate**, breadth first: a node hands its closest triangle to its six
//!    neighbours, which keep it if it is nearer than what they have; each node, when its
//!    turn comes, first walks from its triangle to nearer neighbouring triangles
//!    ([`Mesh::descend`]), so candidates one or two triangles off (triangles smaller than
//!    a voxel) are corrected. Nodes farther than `limit` from the surface stop the spread.
//! 3. **Sign**: a node's sign is that of `p − closest` against the pseudo-normal of the
//!    feature (face, edge or vertex) holding its closest point, exact on a closed,
//!    outward-wound surface. A shell (an open mesh) has no inside: its value is the
//!    distance less half the shell's thickness.
//! 4. **Regions**: nodes the band did not reach, and whole blocks it did not enter, take
//!    the sign of the band next to them by a flood fill over nodes and blocks (a region
//!    out of reach cannot touch the surface, so it touches band nodes of one sign only).
//!
//! Distances are exact for the triangle a node ends on; the walk makes that the closest
//! triangle wherever the surface is smooth at the scale of the distance (tested against
//! exact point–mesh distances).

use super::B;
use crate::contact::mesh::{Mesh, Walk};
use nalgebra::Vector3;
use scene::progress::Progress;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};

/// `Progress` units a band block takes in a mesh's finishing stages, after the spread:
/// the sign of the regions beyond the band (`Band::compute`), then reading the band into
/// the voxmap's blocks (`build::add_mesh`). Weighed by their time against the spread's units
/// (about 2 µs and 1 µs a block at 1 mm on 2 cores, where the spread does about 0.6 µs a
/// unit), so that the bar's share and time left count them: without them it sat at
/// 98 %, "about 0 s left", for the last seconds of a big mesh's build.
pub(super) const REGION_UNITS_PER_BLOCK: u64 = 4;

/// Nodes per band block (8³: each block owns the nodes at its cells' lowest corners).
const OWN: usize = B * B * B;
/// No band block here.
const ABSENT: u32 = u32::MAX;

/// What the surface of a mesh bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Side {
    /// A closed, outward-wound surface: negative inside.
    Solid,
    /// An open surface rendered as a shell: the object is kept out of the band of
    /// `half_thickness_m` on either side of it.
    Shell {
        /// Half the shell's thickness, m.
        half_thickness_m: f64,
    },
}

/// The grid the band is computed on: nodes `origin + h·(i, j, k)` for `i < nodes[0]`, …
#[derive(Debug, Clone, Copy)]
pub(super) struct Grid {
    pub(super) origin: Vector3<f64>,
    pub(super) h: f64,
    /// Nodes per axis (cells + 1).
    pub(super) nodes: [usize; 3],
}

/// The band was stopped (its cancel flag was set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Cancelled;

/// How far from the surface the band's nodes are exact, on either side (m): nodes farther
/// than this stop the spread, and those it never reached take the far value of their side.
#[derive(Debug, Clone, Copy)]
pub(super) struct Limits {
    /// Outside (and for a shell, either side), m.
    pub(super) out_m: f64,
    /// Inside a solid, m.
    pub(super) in_m: f64,
}

/// One mesh's signed distances near its surface and the sign of every region beyond.
pub(super) struct Band {
    grid: Grid,
    /// Band blocks per axis (own nodes: 8 per block, so the grid's last node layer too).
    blocks: [usize; 3],
    /// Per band block: its slot in `values`, or [`ABSENT`].
    slot: Vec<u32>,
    /// Per slot, signed distance of each own node, m (NaN until known).
    values: Vec<[f32; OWN]>,
    /// Per band block with no slot: −1 inside, +1 outside, 0 unknown (outside).
    region: Vec<i8>,
    /// The values of nodes out of the band's reach, m: outside, inside (negative).
    far_m: [f32; 2],
    /// Turns the spread took on every slab (margins counted in each), for progress.
    pub(super) turns: u64,
}

impl Band {
    /// Computes the band of `mesh` on `grid` out to `limits` from the surface, on
    /// `threads` threads (slabs of the grid along its longest axis, each spreading over
    /// its own slab and a margin wider than the limits, so that every node's closest
    /// triangle reaches it within its thread). `progress` hears of every few thousand
    /// triangles and nodes, and its cancel flag is polled as often.
    pub(super) fn compute(
        mesh: &Mesh,
        grid: Grid,
        side: Side,
        limits: Limits,
        threads: usize,
        progress: &Progress,
    ) -> Result<Band, Cancelled> {
        let started = std::time::Instant::now();
        let blocks = grid.nodes.map(|n| n.div_ceil(B));
        let axis = (0..3).max_by_key(|&a| grid.nodes[a]).unwrap_or(0);
        // Node margin of a slab: the spread's path from a triangle to a node within the
        // limit stays within √3 × the limit of the node (6-neighbour steps along it).
        let reach_nodes =
            ((limits.out_m.max(limits.in_m) / grid.h) * 3f64.sqrt()).ceil() as usize + 2;
        let slabs = threads
            .max(1)
            .min(blocks[axis] / (2 * reach_nodes.div_ceil(B)).max(1))
            .max(1);
        let per = blocks[axis].div_ceil(slabs);
        // Each slab looks at every triangle once; the estimate counted them once in all.
        progress.add_total(mesh.len() as u64 * (slabs as u64 - 1));
        let parts: Vec<Result<Part, Cancelled>> = std::thread::scope(|scope| {
            let workers: Vec<_> = (0..slabs)
                .map(|k| {
                    let (core_lo, core_hi) = ((k * per).min(blocks[axis]), ((k + 1) * per).min(blocks[axis]));
                    scope.spawn(move || {
                        // Extended block range along `axis`.
                        let margin = reach_nodes.div_ceil(B);
                        let (lo, hi) = (core_lo.saturating_sub(margin), (core_hi + margin).min(blocks[axis]));
                        let mut sub = grid;
                        sub.origin[axis] += (lo * B) as f64 * grid.h;
                        sub.nodes[axis] = ((hi * B) + 1).min(grid.nodes[axis]) - lo * B;
                        let mut work = Work::new(mesh, sub, side, limits);
                        let t0 = std::time::Instant::now();
                        work.seed(progress)?;
                        let seeded = work.queue.len();
                        let t1 = std::time::Instant::now();
                        let pops = work.propagate(progress)?;
                        let nodes = work
                            .dist
                            .iter()
                            .flatten()
                            .filter(|d| !d.is_nan())
                            .count();
                        let c = work.counts;
                        let per = |x: u64| x as f64 / nodes.max(1) as f64;
                        tracing::debug!(
                            "slab {k}: seed {:.2} s ({seeded} nodes, {} distances), spread {:.2} s ({pops} turns, {nodes} nodes, {} blocks); per node: {:.2} turns, {:.2} rings walked ({:.1} distances), {:.2} ridge checks ({:.2} walks), {:.1} offered distances, {:.1} distances in all",
                            (t1 - t0).as_secs_f64(),
                            c.seed,
                            t1.elapsed().as_secs_f64(),
                            work.dist.len(),
                            per(pops),
                            per(c.rings),
                            per(c.ring_distances),
                            per(c.ridge),
                            per(c.ridge_walks),
                            per(c.offered),
                            per(c.seed + c.ring_distances + c.ridge + c.offered),
                        );
                        Ok(Part {
                            work_blocks: work.blocks,
                            slot: work.slot,
                            dist: work.dist,
                            turns: pops,
                            offset: lo,
                            core: (core_lo, core_hi),
                        })
                    })
                })
                .collect();
            workers
                .into_iter()
                .map(|w| w.join().unwrap_or(Err(Cancelled)))
                .collect()
        });
        let spread = started.elapsed().as_secs_f64();
        let mut band = Band {
            grid,
            blocks,
            slot: vec![ABSENT; blocks[0] * blocks[1] * blocks[2]],
            values: Vec::new(),
            region: vec![0; blocks[0] * blocks[1] * blocks[2]],
            // Unreached nodes lie farther than the limit less a voxel from the surface (a
            // nearer one would have a neighbour within the limit, which spreads).
            far_m: match side {
                Side::Solid => [
                    (limits.out_m - grid.h) as f32,
                    -(limits.in_m - grid.h) as f32,
                ],
                Side::Shell { half_thickness_m } => {
                    let far = (limits.out_m - grid.h - half_thickness_m) as f32;
                    [far, far]
                }
            },
            turns: 0,
        };
        for part in parts {
            let part = part?;
            band.turns += part.turns;
            for (b, &s) in part.slot.iter().enumerate() {
                if s == ABSENT {
                    continue;
                }
                let mut c = block_base(b, part.work_blocks).map(|x| x / B);
                c[axis] += part.offset;
                if c[axis] < part.core.0 || c[axis] >= part.core.1 {
                    continue;
                }
                let g = c[0] + blocks[0] * (c[1] + blocks[1] * c[2]);
                band.slot[g] = band.values.len() as u32;
                band.values.push(part.dist[s as usize]);
            }
        }
        if let Side::Shell { half_thickness_m } = side {
            let t = half_thickness_m as f32;
            for v in band.values.iter_mut().flatten() {
                *v -= t;
            }
        }
        let merged = started.elapsed().as_secs_f64();
        if side == Side::Solid {
            band.fill_regions(&progress.cancel)?;
        }
        // Counted whatever the side, as `build` expects them.
        progress.add(REGION_UNITS_PER_BLOCK * band.slot.len() as u64);
        tracing::debug!(
            "band of {} triangles on {slabs} thread(s): {} blocks; spread {spread:.2} s, merge {:.2} s, regions {:.2} s",
            mesh.len(),
            band.values.len(),
            merged - spread,
            started.elapsed().as_secs_f64() - merged
        );
        Ok(band)
    }

    /// The signed distance at node (i, j, k), m: exact in the band, ± the far value
    /// beyond it.
    pub(super) fn value(&self, n: [usize; 3]) -> f32 {
        let b = self.block_of(n);
        match self.slot[b] {
            ABSENT => self.far_m[usize::from(self.region[b] < 0)],
            s => {
                let v = self.values[s as usize][local(n)];
                if v.is_nan() { self.far_m[0] } else { v }
            }
        }
    }

    /// Whether any of the band blocks holding nodes `lo..=hi` (a voxmap block's nodes)
    /// holds computed values; if not, every node there has one value, [`Self::value`] of
    /// any of them.
    pub(super) fn touches(&self, lo: [usize; 3], hi: [usize; 3]) -> bool {
        let (a, z) = (lo.map(|x| x / B), hi.map(|x| x / B));
        for bz in a[2]..=z[2].min(self.blocks[2] - 1) {
            for by in a[1]..=z[1].min(self.blocks[1] - 1) {
                for bx in a[0]..=z[0].min(self.blocks[0] - 1) {
                    if self.slot[bx + self.blocks[0] * (by + self.blocks[1] * bz)] != ABSENT {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// Heap bytes held.
    pub(super) fn memory_bytes(&self) -> usize {
        self.slot.len() * 4 + self.region.len() + self.values.len() * OWN * 4
    }

    fn block_of(&self, n: [usize; 3]) -> usize {
        n[0] / B + self.blocks[0] * (n[1] / B + self.blocks[1] * (n[2] / B))
    }

    /// Gives the nodes out of the band's reach, and the blocks it never entered, the sign
    /// of the band next to them (see the module docs).
    fn fill_regions(&mut self, cancel: &AtomicBool) -> Result<(), Cancelled> {
        #[derive(Clone, Copy)]
        enum Item {
            Node([usize; 3], f32),
            Block(usize, i8),
        }
        let blocks = self.blocks;
        let nodes = self.grid.nodes;
        let mut queue = VecDeque::new();
        // Seeds: known nodes next to an unknown node or an absent block.
        for (b, &s) in self.slot.iter().enumerate() {
            if s == ABSENT {
                continue;
            }
            let base = block_base(b, blocks);
            for l in 0..OWN {
                let v = self.values[s as usize][l];
                if v.is_nan() {
                    continue;
                }
                let n = [
                    base[0] + l % B,
                    base[1] + (l / B) % B,
                    base[2] + l / (B * B),
                ];
                let unknown_next = neighbours(n, nodes).any(|m| {
                    let mb = self.block_of(m);
                    match self.slot[mb] {
                        ABSENT => self.region[mb] == 0,
                        ms => self.values[ms as usize][local(m)].is_nan(),
                    }
                });
                if unknown_next {
                    queue.push_back(Item::Node(n, v.signum()));
                }
            }
        }
        let far = self.far_m;
        let far_of = |sign: f32| far[usize::from(sign < 0.0)];
        let mut popped = 0u32;
        while let Some(item) = queue.pop_front() {
            popped = popped.wrapping_add(1);
            if popped.is_multiple_of(4096) && cancel.load(Ordering::Relaxed) {
                return Err(Cancelled);
            }
            match item {
                Item::Node(n, sign) => {
                    for m in neighbours(n, nodes) {
                        let mb = self.block_of(m);
                        match self.slot[mb] {
                            ABSENT => {
                                if self.region[mb] == 0 {
                                    self.region[mb] = sign as i8;
                                    queue.push_back(Item::Block(mb, sign as i8));
                                }
                            }
                            ms => {
                                let v = &mut self.values[ms as usize][local(m)];
                                if v.is_nan() {
                                    *v = far_of(sign);
                                    queue.push_back(Item::Node(m, sign));
                                }
                            }
                        }
                    }
                }
                Item::Block(b, sign) => {
                    let base = block_base(b, blocks);
                    for axis in 0..3 {
                        for dir in [-1i64, 1] {
                            let mut nb = base.map(|x| x / B);
                            let c = nb[axis] as i64 + dir;
                            if c < 0 || c >= blocks[axis] as i64 {
                                continue;
                            }
                            nb[axis] = c as usize;
                            let b2 = nb[0] + blocks[0] * (nb[1] + blocks[1] * nb[2]);
                            match self.slot[b2] {
                                ABSENT => {
                                    if self.region[b2] == 0 {
                                        self.region[b2] = sign;
                                        queue.push_back(Item::Block(b2, sign));
                                    }
                                }
                                s2 => {
                                    // The face of block b2 that touches block b.
                                    let layer = if dir > 0 { 0 } else { B - 1 };
                                    let b2_base = block_base(b2, blocks);
                                    for u in 0..B {
                                        for w in 0..B {
                                            let mut l = [0usize; 3];
                                            l[axis] = layer;
                                            l[(axis + 1) % 3] = u;
                                            l[(axis + 2) % 3] = w;
                                            let m = [
                                                b2_base[0] + l[0],
                                                b2_base[1] + l[1],
                                                b2_base[2] + l[2],
                                            ];
                                            if m.iter().zip(&nodes).any(|(x, n)| x >= n) {
                                                continue;
                                            }
                                            let v = &mut self.values[s2 as usize][local(m)];
                                            if v.is_nan() {
                                                *v = far_of(f32::from(sign));
                                                queue.push_back(Item::Node(m, f32::from(sign)));
                                            }
                                        }
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

impl Grid {
    /// The position of node `n`, m.
    #[inline]
    pub(super) fn position(&self, n: [usize; 3]) -> Vector3<f64> {
        self.origin + Vector3::new(n[0] as f64, n[1] as f64, n[2] as f64) * self.h
    }
}

/// Index of node `n` among its band block's own nodes.
#[inline]
fn local(n: [usize; 3]) -> usize {
    n[0] % B + B * (n[1] % B + B * (n[2] % B))
}

/// The lowest node of band block `b`.
fn block_base(b: usize, blocks: [usize; 3]) -> [usize; 3] {
    [
        (b % blocks[0]) * B,
        ((b / blocks[0]) % blocks[1]) * B,
        (b / (blocks[0] * blocks[1])) * B,
    ]
}

/// The six neighbours of node `n` within the grid.
fn neighbours(n: [usize; 3], nodes: [usize; 3]) -> impl Iterator<Item = [usize; 3]> {
    (0..6).filter_map(move |d| {
        let axis = d / 2;
        let mut m = n;
        if d % 2 == 0 {
            m[axis] = m[axis].checked_sub(1)?;
        } else {
            m[axis] += 1;
            if m[axis] >= nodes[axis] {
                return None;
            }
        }
        Some(m)
    })
}

/// One slab's band blocks, to be merged into the [`Band`].
struct Part {
    turns: u64,
    work_blocks: [usize; 3],
    slot: Vec<u32>,
    dist: Vec<[f32; OWN]>,
    /// The slab's first block along the split axis, in the whole grid's blocks.
    offset: usize,
    /// The blocks along the split axis this slab answers for.
    core: (usize, usize),
}

/// What one slab's band did, for the debug log: triangle distances computed by stage, and
/// the walks over 1-rings.
#[derive(Debug, Default, Clone, Copy)]
struct Counts {
    /// Distances computed seeding.
    seed: u64,
    /// Rings walked ([`Mesh::descend`]'s rounds) and distances computed walking them.
    rings: u64,
    ring_distances: u64,
    /// Neighbours' triangles looked at off the ring (the ridge check), and walks from them.
    ridge: u64,
    ridge_walks: u64,
    /// Distances computed handing a node's triangle to its neighbours (not to those that
    /// hold it already).
    offered: u64,
}

/// The band's working state on one slab: distances (unsigned until a node's turn signs
/// it), closest triangles, and the queue of nodes to refine and hand on.
struct Work<'m> {
    mesh: &'m Mesh,
    grid: Grid,
    side: Side,
    limits: Limits,
    blocks: [usize; 3],
    slot: Vec<u32>,
    /// Distance per own node, m (NaN: not reached); signed once the node had its turn.
    dist: Vec<[f32; OWN]>,
    /// Closest triangle per own node.
    tri: Vec<[u32; OWN]>,
    /// Per own node, whether it waits in `queue` (one bit each).
    queued: Vec<[u64; OWN / 64]>,
    queue: VecDeque<[u32; 3]>,
    counts: Counts,
}

impl<'m> Work<'m> {
    fn new(mesh: &'m Mesh, grid: Grid, side: Side, limits: Limits) -> Self {
        let blocks = grid.nodes.map(|n| n.div_ceil(B));
        // About the blocks the band will fill (its area in block faces, times its
        // thickness in blocks plus the blocks it cuts), reserved at once: growing these by
        // doubling copied and zeroed a tenth of the build's time.
        let block_m = B as f64 * grid.h;
        let thickness = (limits.out_m + limits.in_m) / block_m + 2.0;
        let expected = (mesh.area_m2() / (block_m * block_m) * thickness * 1.2) as usize;
        let expected = expected.min(blocks[0] * blocks[1] * blocks[2]);
        Work {
            mesh,
            grid,
            side,
            limits,
            blocks,
            slot: vec![ABSENT; blocks[0] * blocks[1] * blocks[2]],
            dist: Vec::with_capacity(expected),
            tri: Vec::with_capacity(expected),
            queued: Vec::with_capacity(expected),
            queue: VecDeque::new(),
            counts: Counts::default(),
        }
    }

    /// The slot of node `n`'s band block, allocated on first use.
    fn slot_of(&mut self, n: [usize; 3]) -> usize {
        let b = n[0] / B + self.blocks[0] * (n[1] / B + self.blocks[1] * (n[2] / B));
        if self.slot[b] == ABSENT {
            self.slot[b] = self.dist.len() as u32;
            self.dist.push([f32::NAN; OWN]);
            self.tri.push([0; OWN]);
            self.queued.push([0; OWN / 64]);
        }
        self.slot[b] as usize
    }

    /// Offers triangle `t` at distance `d()` to node `n`; queues the node (once) when it
    /// takes it. A node that holds `t` already holds its distance, which is not less:
    /// `d` is not computed then.
    #[inline]
    fn offer(&mut self, n: [usize; 3], t: u32, d: impl FnOnce() -> f32) {
        let s = self.slot_of(n);
        let l = local(n);
        let old = self.dist[s][l];
        if !old.is_nan() && self.tri[s][l] == t {
            return;
        }
        let d = d();
        if old.is_nan() || d < old.abs() {
            self.dist[s][l] = d;
            self.tri[s][l] = t;
            let (word, bit) = (l / 64, 1u64 << (l % 64));
            if self.queued[s][word] & bit == 0 {
                self.queued[s][word] |= bit;
                self.queue.push_back(n.map(|x| x as u32));
            }
        }
    }

    fn seed(&mut self, progress: &Progress) -> Result<(), Cancelled> {
        let g = self.grid;
        let last = g.nodes.map(|n| n as f64 - 1.0);
        let (lo_g, hi_g) = (g.origin, g.position(g.nodes.map(|n| n - 1)));
        for t in 0..self.mesh.len() as u32 {
            if t.is_multiple_of(8192) && t > 0 {
                if progress.cancelled() {
                    return Err(Cancelled);
                }
                progress.add(8192);
            }
            let c = self.mesh.corners(t);
            let lo = c[0].inf(&c[1]).inf(&c[2]);
            let hi = c[0].sup(&c[1]).sup(&c[2]);
            if (0..3).any(|a| hi[a] < lo_g[a] - g.h || lo[a] > hi_g[a] + g.h) {
                continue; // another slab's
            }
            let to_node = |v: f64, a: usize, up: bool| {
                let x = (v - g.origin[a]) / g.h;
                let x = if up { x.ceil() } else { x.floor() };
                x.clamp(0.0, last[a]) as usize
            };
            let (a, z) = (
                [0, 1, 2].map(|i| to_node(lo[i], i, false)),
                [0, 1, 2].map(|i| to_node(hi[i], i, true)),
            );
            // Only the nodes next to the triangle's plane: along its most normal axis `w`,
            // each column of the box gets the nodes within a voxel and a half of where the
            // plane crosses it (a big tilted triangle's box is a volume; its plane is not).
            let normal = (c[1] - c[0]).cross(&(c[2] - c[0]));
            let w = normal.iamax();
            let (u, v) = ((w + 1) % 3, (w + 2) % 3);
            for ju in a[u]..=z[u] {
                for jv in a[v]..=z[v] {
                    let mut n = [0usize; 3];
                    n[u] = ju;
                    n[v] = jv;
                    let p = g.position(n);
                    // The plane's w at this column, in node units.
                    let pw = c[0][w]
                        - (normal[u] * (p[u] - c[0][u]) + normal[v] * (p[v] - c[0][v])) / normal[w];
                    let x = (pw - g.origin[w]) / g.h;
                    let from = (x - 1.5).floor().max(a[w] as f64) as usize;
                    let to = ((x + 1.5).ceil().min(z[w] as f64)).max(from as f64) as usize;
                    for k in from..=to.min(z[w]) {
                        n[w] = k;
                        let at = self.mesh.closest(t, &g.position(n));
                        self.counts.seed += 1;
                        self.offer(n, t, || at.distance2.sqrt() as f32);
                    }
                }
            }
        }
        progress.add(self.mesh.len() as u64 % 8192);
        Ok(())
    }

    /// Returns the turns taken (nodes refined and handed on, a node again after it
    /// improved).
    fn propagate(&mut self, progress: &Progress) -> Result<u64, Cancelled> {
        let g = self.grid;
        let mut turns = 0u64;
        while let Some(n) = self.queue.pop_front() {
            turns += 1;
            if turns.is_multiple_of(8192) {
                if progress.cancelled() {
                    return Err(Cancelled);
                }
                progress.add(8192);
            }
            let n = n.map(|x| x as usize);
            let p = g.position(n);
            let s = self.slot_of(n);
            let l = local(n);
            self.queued[s][l / 64] &= !(1u64 << (l % 64));
            let t0 = self.tri[s][l];
            let main = self
                .mesh
                .walk(&p, t0, self.mesh.closest(t0, &p), None)
                .expect("a walk without a stop ends");
            self.count_walk(&main);
            let (mut t, mut at) = (main.t, main.at);
            // Near a ridge of the distance (two parts of the surface about as near, on the
            // concave side), the walk from the nearest offer can end in the wrong basin:
            // walk also from a neighbour's triangle that is about as near and not next to
            // the one found.
            let slack = 0.25 * g.h;
            for m in neighbours(n, g.nodes) {
                let b = m[0] / B + self.blocks[0] * (m[1] / B + self.blocks[1] * (m[2] / B));
                let ms = self.slot[b];
                if ms == ABSENT || self.dist[ms as usize][local(m)].is_nan() {
                    continue;
                }
                let tm = self.tri[ms as usize][local(m)];
                // From a triangle the first walk stood on, a walk goes its way again.
                if tm == t || main.stood_on(tm) || self.mesh.in_ring(t, tm) {
                    continue;
                }
                let c = self.mesh.closest(tm, &p);
                self.counts.ridge += 1;
                let reach = at.distance2.sqrt() + slack;
                if c.distance2 < reach * reach {
                    self.counts.ridge_walks += 1;
                    if let Some(w) = self.mesh.walk(&p, tm, c, Some(&main)) {
                        self.count_walk(&w);
                        if w.at.distance2 < at.distance2 {
                            (t, at) = (w.t, w.at);
                        }
                    }
                }
            }
            let d = at.distance2.sqrt();
            // Signed now, from the pseudo-normal of the feature holding the closest point.
            let inside = self.side == Side::Solid
                && (p - at.point).dot(&self.mesh.pseudo_normal(t, at.feature)) < 0.0;
            self.dist[s][l] = if inside { -d } else { d } as f32;
            self.tri[s][l] = t;
            let limit = if inside {
                self.limits.in_m
            } else {
                self.limits.out_m
            };
            if d > limit {
                continue;
            }
            let mesh = self.mesh;
            for m in neighbours(n, g.nodes) {
                let mut computed = false;
                self.offer(m, t, || {
                    computed = true;
                    mesh.closest(t, &g.position(m)).distance2.sqrt() as f32
                });
                self.counts.offered += u64::from(computed);
            }
        }
        progress.add(turns % 8192);
        Ok(turns)
    }

    /// Counts a walk's rings and distances (and the distance of its start).
    #[inline]
    fn count_walk(&mut self, w: &Walk) {
        self.counts.rings += w.stood as u64;
        self.counts.ring_distances += 1 + u64::from(w.distances);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_cancel() -> Progress {
        Progress::default()
    }

    /// A unit-ish cube (side 40 mm) at 2 mm nodes.
    fn cube_band(side: Side) -> (Band, Grid) {
        cube_band_on(side, 1)
    }

    fn cube_band_on(side: Side, threads: usize) -> (Band, Grid) {
        let (v, t) = crate::contact::mesh::tests::cube();
        let v: Vec<_> = v.iter().map(|p| p * 0.04).collect();
        let mesh = Mesh::new(&v, &t);
        let grid = Grid {
            origin: Vector3::repeat(-0.03),
            h: 0.002,
            nodes: [51, 51, 51],
        };
        let limits = Limits {
            out_m: 0.012,
            in_m: 0.012,
        };
        let band = Band::compute(&mesh, grid, side, limits, threads, &no_cancel()).unwrap();
        (band, grid)
    }

    fn exact_cube(p: &Vector3<f64>) -> f64 {
        // Signed distance to the box [0, 0.04]³.
        let q = p.map(|x| (x - 0.02).abs() - 0.02);
        let outside = q.map(|x| x.max(0.0)).norm();
        let inside = q.max().min(0.0);
        outside + inside
    }

    #[test]
    fn a_cube_band_is_exact_and_regions_take_the_right_sign() {
        let (band, grid) = cube_band(Side::Solid);
        let mut checked = 0;
        for k in 0..51 {
            for j in 0..51 {
                for i in 0..51 {
                    let n = [i, j, k];
                    let exact = exact_cube(&grid.position(n));
                    let got = f64::from(band.value(n));
                    if exact.abs() < 0.010 {
                        assert!((got - exact).abs() < 1e-6, "{n:?}: {got} vs {exact}");
                        checked += 1;
                    } else {
                        assert_eq!(got.signum(), exact.signum(), "{n:?}: {got} vs {exact}");
                        assert!(got.abs() <= exact.abs() + 1e-6, "{n:?}: {got} vs {exact}");
                    }
                }
            }
        }
        assert!(checked > 10_000);
        // The cube's centre (20 mm deep) is beyond the band: inside by the fill.
        assert!(band.value([25, 25, 25]) < 0.0);
        assert!(band.value([0, 0, 0]) > 0.0);
    }

    #[test]
    fn triangles_in_spatial_order_give_the_same_band_bit_for_bit() {
        use rand::SeedableRng;
        use rand::seq::SliceRandom;
        let m = scene::MeshData::bumpy_sphere("s", 0.05, 30, 60);
        let mut t = m.triangles.clone();
        t.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(2));
        let grid = Grid {
            origin: Vector3::repeat(-0.07),
            h: 0.002,
            nodes: [71, 71, 71],
        };
        let limits = Limits {
            out_m: 0.01,
            in_m: 0.01,
        };
        let band =
            |mesh: &Mesh| Band::compute(mesh, grid, Side::Solid, limits, 2, &no_cancel()).unwrap();
        let plain = band(&Mesh::new(&m.vertices_m, &t));
        let spatial = band(&Mesh::new_spatial(&m.vertices_m, &t));
        for k in 0..71 {
            for j in 0..71 {
                for i in 0..71 {
                    let n = [i, j, k];
                    assert_eq!(
                        plain.value(n).to_bits(),
                        spatial.value(n).to_bits(),
                        "{n:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn slabs_on_several_threads_give_the_same_band() {
        let (one, grid) = cube_band_on(Side::Solid, 1);
        let (three, _) = cube_band_on(Side::Solid, 3);
        for k in 0..51 {
            for j in 0..51 {
                for i in 0..51 {
                    assert_eq!(
                        one.value([i, j, k]),
                        three.value([i, j, k]),
                        "{:?}",
                        grid.position([i, j, k])
                    );
                }
            }
        }
    }

    #[test]
    fn a_shell_has_no_inside() {
        let (band, grid) = cube_band(Side::Shell {
            half_thickness_m: 0.001,
        });
        // The centre, a corner of the grid (both beyond the band) and a node 10 mm in.
        for n in [[25, 25, 25], [0, 0, 0], [20, 20, 22]] {
            let exact = exact_cube(&grid.position(n)).abs() - 0.001;
            let got = f64::from(band.value(n));
            assert!(got > 0.0, "{n:?}");
            assert!(got <= exact + 1e-6, "{n:?}: {got} vs {exact}");
        }
        assert!((f64::from(band.value([20, 20, 22])) - 0.009).abs() < 1e-6);
        // On the surface: inside the shell's band.
        assert!((f64::from(band.value([15, 20, 20])) + 0.001).abs() < 1e-6);
    }

    #[test]
    fn a_set_cancel_flag_stops_the_band() {
        let (v, t) = crate::contact::mesh::tests::cube();
        let mesh = Mesh::new(&v, &t);
        let grid = Grid {
            origin: Vector3::repeat(-0.5),
            h: 0.01,
            nodes: [201, 201, 201],
        };
        let cancel = Progress::default();
        cancel.cancel.store(true, Ordering::Relaxed);
        let limits = Limits {
            out_m: 0.05,
            in_m: 0.05,
        };
        assert!(Band::compute(&mesh, grid, Side::Solid, limits, 2, &cancel).is_err());
    }
}
