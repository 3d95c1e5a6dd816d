//! Building the voxmap: the grid around the obstacles, the signed distances of the blocks
//! near their surface (sampled on every core), the block index, and the Chebyshev
//! distance transform over it that bounds the clearance of the empty blocks. Runs at
//! start-up, never on the real-time path.

use super::band::{Band, Grid, Limits, REGION_UNITS_PER_BLOCK, Side};
use super::{
    B, BLOCK_NODES, FIRST, INSIDE, MAX_BYTES, N, OUTSIDE, Q, Voxmap, VoxmapConfig, VoxmapError,
};
use crate::contact::mesh::Mesh;
use nalgebra::Vector3;
use parry3d_f64::bounding_volume::{Aabb, BoundingVolume};
use parry3d_f64::math::{Pose, Vector as PVec};
use parry3d_f64::shape::SharedShape;
use scene::MeshData;
use scene::progress::Progress;
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

fn pvec(v: &Vector3<f64>) -> PVec {
    PVec::new(v.x, v.y, v.z)
}

fn nvec(v: PVec) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

/// An obstacle as the voxmap sees it, in the scene frame.
#[derive(Clone)]
pub enum Obstacle {
    /// A parry shape (a box, a ball, …), solid, sampled with parry near its surface.
    Shape {
        /// Pose in the scene frame.
        pose: Pose,
        /// The shape in its own frame.
        shape: SharedShape,
    },
    /// A triangle mesh, voxelised through its narrow band (no parry structure needed).
    Mesh {
        /// Pose in the scene frame.
        pose: Pose,
        /// Vertices (m, its own frame) and triangles.
        mesh: Arc<MeshData>,
        /// Solid (closed, wound outward) or an open shell.
        surface: Surface,
    },
}

impl Obstacle {
    /// `shape` at `pose`: a triangle mesh becomes [`Obstacle::Mesh`] (solid), anything
    /// else [`Obstacle::Shape`].
    pub fn from_shape(pose: Pose, shape: &SharedShape) -> Self {
        match shape.as_trimesh() {
            Some(t) => Obstacle::Mesh {
                pose,
                mesh: Arc::new(MeshData {
                    source: "parry TriMesh".to_owned(),
                    vertices_m: t.vertices().iter().map(|v| nvec(*v)).collect(),
                    triangles: t.indices().to_vec(),
                    repair: None,
                }),
                surface: Surface::Solid,
            },
            None => Obstacle::Shape {
                pose,
                shape: shape.clone(),
            },
        }
    }

    /// Its bounding box in the scene frame, loosened by `by_m`.
    fn aabb(&self, by_m: f64) -> Aabb {
        match self {
            Obstacle::Shape { pose, shape } => shape.compute_aabb(pose).loosened(by_m),
            Obstacle::Mesh {
                pose,
                mesh,
                surface,
            } => {
                let (lo, hi) = mesh.vertices_m.iter().fold(
                    (PVec::splat(f64::INFINITY), PVec::splat(f64::NEG_INFINITY)),
                    |(lo, hi), v| {
                        let p = pose.transform_point(pvec(v));
                        (lo.min(p), hi.max(p))
                    },
                );
                let shell = match surface {
                    Surface::Solid => 0.0,
                    Surface::Shell { thickness_m } => 0.5 * thickness_m,
                };
                Aabb::new(lo, hi).loosened(by_m + shell)
            }
        }
    }
}

impl std::fmt::Debug for Obstacle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Obstacle::Shape { pose, shape } => f
                .debug_struct("Shape")
                .field("pose", pose)
                .field("kind", &shape.shape_type())
                .finish(),
            Obstacle::Mesh {
                pose,
                mesh,
                surface,
            } => f
                .debug_struct("Mesh")
                .field("pose", pose)
                .field("source", &mesh.source)
                .field("triangles", &mesh.triangles.len())
                .field("surface", surface)
                .finish(),
        }
    }
}

/// What an obstacle's surface bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Surface {
    /// A closed surface: distances are negative inside.
    Solid,
    /// An open mesh (a panel, a sheet): the object is kept out of a band of
    /// `thickness_m` centred on the surface, which has no inside.
    Shell {
        /// Thickness of the band, m (> 0).
        thickness_m: f64,
    },
}

/// Signed distance from `p` to one shape (negative inside).
fn signed_distance(pose: &Pose, shape: &SharedShape, p: PVec) -> f64 {
    let proj = shape.project_point(pose, p, false);
    let d = (proj.point - p).length();
    if proj.is_inside { -d } else { d }
}

/// The voxmap's grid: origin (m), cells and blocks per axis.
#[derive(Debug, Clone, Copy)]
struct Layout {
    origin: Vector3<f64>,
    h: f64,
    blocks: [usize; 3],
}

impl Layout {
    fn block_index(&self, b: [usize; 3]) -> usize {
        b[0] + self.blocks[0] * (b[1] + self.blocks[1] * b[2])
    }

    fn block_coords(&self, b: usize) -> [usize; 3] {
        [
            b % self.blocks[0],
            (b / self.blocks[0]) % self.blocks[1],
            b / (self.blocks[0] * self.blocks[1]),
        ]
    }

    fn block_min(&self, b: [usize; 3]) -> Vector3<f64> {
        self.origin + Vector3::new(b[0] as f64, b[1] as f64, b[2] as f64) * (B as f64 * self.h)
    }

    /// The blocks (inclusive ranges per axis) an axis-aligned box overlaps.
    fn blocks_over(&self, aabb: &Aabb) -> Option<([usize; 3], [usize; 3])> {
        let size = B as f64 * self.h;
        let mut lo = [0; 3];
        let mut hi = [0; 3];
        for a in 0..3 {
            let l = ((aabb.mins[a] - self.origin[a]) / size).floor();
            let u = ((aabb.maxs[a] - self.origin[a]) / size).floor();
            if !(l.is_finite() && u.is_finite()) || u < 0.0 || l >= self.blocks[a] as f64 {
                return None;
            }
            lo[a] = l.max(0.0) as usize;
            hi[a] = (u as usize).min(self.blocks[a] - 1);
        }
        Some((lo, hi))
    }
}

/// The nodes of every block that some obstacle may reach, as they are merged, obstacle
/// by obstacle, by the minimum of signed distances (see the module docs of `voxmap`).
struct Merge {
    /// Per block: [`OUTSIDE`] (no obstacle within reach so far), [`INSIDE`] (deep inside
    /// one), or `FIRST + k` for `nodes[k]`.
    index: Vec<u32>,
    nodes: Vec<[i16; BLOCK_NODES]>,
}

impl Merge {
    /// Obstacle says block `b` lies deep inside it.
    fn inside(&mut self, b: usize) {
        self.index[b] = INSIDE;
    }

    /// Obstacle's quantised nodes of block `b`.
    fn nodes(&mut self, b: usize, q: &[i16; BLOCK_NODES]) {
        match self.index[b] {
            INSIDE => {}
            OUTSIDE => {
                self.index[b] = FIRST + self.nodes.len() as u32;
                self.nodes.push(*q);
            }
            slot => {
                let mine = &mut self.nodes[(slot - FIRST) as usize];
                for (m, v) in mine.iter_mut().zip(q) {
                    *m = (*m).min(*v);
                }
            }
        }
    }
}

/// Quantises a signed distance `d` (m) at voxel size `h`, clamped to ±`cap_m`.
///
/// Node values are known only out to the build's reach (obstacles farther than that from
/// a block are not sampled for it), so they are clamped there: a stored value is never
/// above the true distance, which the contact search's motion budgets rely on. A cell with
/// a corner at the reach ((max layers + 1) voxels) has all corners beyond the outside
/// layers less a cell diagonal, past any force, so the clamp changes no force.
#[inline]
fn quantise(d: f64, h: f64, cap_m: f64) -> i16 {
    (d.clamp(-cap_m, cap_m) / h * Q)
        .round()
        .clamp(-32767.0, 32767.0) as i16
}

impl Voxmap {
    /// Voxelises `shapes` (pose in the scene frame, shape), all solid. Uses every core the
    /// machine has; an empty scene gives a voxmap where everything is far.
    pub fn build(
        shapes: &[(Pose, SharedShape)],
        config: &VoxmapConfig,
    ) -> Result<Self, VoxmapError> {
        let obstacles: Vec<Obstacle> = shapes
            .iter()
            .map(|(pose, shape)| Obstacle::from_shape(*pose, shape))
            .collect();
        Self::build_obstacles(&obstacles, config, &Progress::default())
    }

    /// Voxelises `obstacles`, reporting progress to and stopping on `control` (a stage
    /// named `voxmap`, in units of triangles seeded, band nodes refined and blocks sampled).
    ///
    /// Primitives are sampled with parry at the nodes of the blocks near their surface
    /// (a block whose centre is farther from it than the block's half diagonal plus the
    /// layers is wholly outside or inside: one query decides it). Triangle meshes go
    /// through their narrow band (`band`), whose cost follows the surface area, not the
    /// box. The obstacles are merged by the minimum of their signed distances.
    pub fn build_obstacles(
        obstacles: &[Obstacle],
        config: &VoxmapConfig,
        control: &Progress,
    ) -> Result<Self, VoxmapError> {
        let started = Instant::now();
        let h = config.voxel_m;
        if !(h.is_finite() && h > 0.0) {
            return Err(VoxmapError::Parameter {
                name: "voxel size",
                need: "a positive number of metres",
                value: h,
            });
        }
        if config.layers_out < 1
            || config.layers_in < 1
            || config.layers_out.max(config.layers_in) > 100
        {
            return Err(VoxmapError::Layers {
                layers_out: config.layers_out,
                layers_in: config.layers_in,
            });
        }
        for o in obstacles {
            if let Obstacle::Mesh {
                surface: Surface::Shell { thickness_m },
                ..
            } = *o
                && !(thickness_m.is_finite() && thickness_m > 0.0)
            {
                return Err(VoxmapError::Parameter {
                    name: "shell thickness",
                    need: "a positive number of metres",
                    value: thickness_m,
                });
            }
        }
        let reach = reach(config);
        let aabbs: Vec<Aabb> = obstacles.iter().map(|o| o.aabb(reach)).collect();
        let (origin, cells) = match aabbs.iter().copied().reduce(|a, b| a.merged(&b)) {
            Some(all) => {
                let ext = all.maxs - all.mins;
                let cells = [ext.x, ext.y, ext.z].map(|e| {
                    let c = (e / h).ceil().max(1.0);
                    (c as usize).div_ceil(B) * B
                });
                (nvec(all.mins), cells)
            }
            None => (Vector3::zeros(), [B; 3]),
        };
        let blocks = cells.map(|c| c / B);
        let total_blocks = blocks[0]
            .checked_mul(blocks[1])
            .and_then(|n| n.checked_mul(blocks[2]))
            .unwrap_or(usize::MAX);
        let index_bytes = total_blocks.saturating_mul(6);
        if index_bytes > MAX_BYTES {
            return Err(VoxmapError::TooLarge {
                what: "the block index",
                needed_mb: index_bytes as f64 / 1e6,
                limit_mb: MAX_BYTES as f64 / 1e6,
                voxel_mm: h * 1e3,
            });
        }
        let layout = Layout { origin, h, blocks };
        let mut merge = Merge {
            index: vec![OUTSIDE; total_blocks],
            nodes: Vec::new(),
        };

        let (meshes, primitives): (Vec<usize>, Vec<usize>) =
            (0..obstacles.len()).partition(|&i| matches!(obstacles[i], Obstacle::Mesh { .. }));
        let mesh_work: u64 = meshes
            .iter()
            .map(|&i| match &obstacles[i] {
                Obstacle::Mesh { mesh, .. } => {
                    band_units(mesh, config) + layout.blocks_over(&aabbs[i]).map_or(0, finish_units)
                }
                Obstacle::Shape { .. } => 0,
            })
            .sum();
        let primitive_work: u64 = primitives
            .iter()
            .filter_map(|&i| layout.blocks_over(&aabbs[i]))
            .map(|(lo, hi)| (0..3).map(|a| (hi[a] - lo[a] + 1) as u64).product::<u64>())
            .sum();
        // The block index's classification and distance transform last: a unit a block.
        control.stage("voxmap", mesh_work + primitive_work + total_blocks as u64);

        let mut peak_band_bytes = 0;
        for &i in &meshes {
            let band_bytes = add_mesh(
                &layout,
                &obstacles[i],
                &aabbs[i],
                config,
                control,
                &mut merge,
            )?;
            peak_band_bytes = peak_band_bytes.max(band_bytes);
        }
        add_primitives(
            &layout,
            obstacles,
            &aabbs,
            &primitives,
            config,
            control,
            &mut merge,
        )?;

        // Classify the merged blocks and keep those within the layers.
        let out_q = (f64::from(config.layers_out) * Q) as i32;
        let in_q = -(f64::from(config.layers_in) * Q) as i32;
        let Merge { mut index, nodes } = merge;
        let mut stored = 0usize;
        for code in index.iter_mut() {
            if *code < FIRST {
                continue;
            }
            let q = &nodes[(*code - FIRST) as usize];
            let all_out = q.iter().all(|&v| i32::from(v) >= out_q);
            let all_in = q.iter().all(|&v| i32::from(v) <= in_q);
            *code = if all_out {
                OUTSIDE
            } else if all_in {
                INSIDE
            } else {
                stored += 1;
                *code
            };
        }
        let data_bytes = stored * BLOCK_NODES * 2;
        if data_bytes + index_bytes > MAX_BYTES {
            return Err(VoxmapError::TooLarge {
                what: "the stored blocks",
                needed_mb: (data_bytes + index_bytes) as f64 / 1e6,
                limit_mb: MAX_BYTES as f64 / 1e6,
                voxel_mm: h * 1e3,
            });
        }
        // Stored blocks in block order, so that the layout does not depend on the order
        // obstacles were merged in.
        let mut data = Vec::with_capacity(stored * BLOCK_NODES);
        for code in index.iter_mut() {
            if *code >= FIRST {
                let slot = FIRST + (data.len() / BLOCK_NODES) as u32;
                data.extend_from_slice(&nodes[(*code - FIRST) as usize]);
                *code = slot;
            }
        }
        drop(nodes);
        let block_distance = chebyshev_distance(&index, blocks);
        control.add(total_blocks as u64);

        let mut voxmap = Self::from_parts(
            origin,
            h,
            blocks,
            index,
            block_distance,
            data,
            config.layers_out,
        );
        voxmap.report.build_time = started.elapsed();
        voxmap.report.peak_band_bytes = peak_band_bytes;
        Ok(voxmap)
    }
}

/// About the work of a mesh's band, in [`Progress`] units: its triangles (seeded) and the
/// nodes within its layers (each refined once, about).
fn band_units(mesh: &MeshData, config: &VoxmapConfig) -> u64 {
    let area: f64 = mesh
        .triangles
        .iter()
        .filter_map(|t| {
            let [a, b, c] = t.map(|i| mesh.vertices_m.get(i as usize));
            Some(0.5 * (b? - a?).cross(&(c? - a?)).norm())
        })
        .sum();
    let layers = f64::from(config.layers_out + config.layers_in + 4);
    let nodes = area / (config.voxel_m * config.voxel_m) * layers;
    mesh.triangles.len() as u64 + nodes.min(1e15) as u64
}

const MERGE_UNITS_PER_BLOCK: u64 = 2;

/// The units of a mesh's finishing stages over the voxmap blocks `lo..=hi` of its box
/// (its band's grid has a block more per axis).
fn finish_units((lo, hi): ([usize; 3], [usize; 3])) -> u64 {
    let n = |a: usize| (hi[a] - lo[a] + 1) as u64;
    let band_blocks = (n(0) + 1) * (n(1) + 1) * (n(2) + 1);
    REGION_UNITS_PER_BLOCK * band_blocks + MERGE_UNITS_PER_BLOCK * n(0) * n(1) * n(2)
}

/// How far from an obstacle its distances are sampled, m: a voxel past the deepest layer.
fn reach(config: &VoxmapConfig) -> f64 {
    f64::from(config.layers_out.max(config.layers_in) + 1) * config.voxel_m
}

/// Merges one mesh obstacle through its narrow band; returns the band's memory, bytes.
fn add_mesh(
    layout: &Layout,
    obstacle: &Obstacle,
    aabb: &Aabb,
    config: &VoxmapConfig,
    control: &Progress,
    merge: &mut Merge,
) -> Result<usize, VoxmapError> {
    let Obstacle::Mesh {
        pose,
        mesh: data,
        surface,
    } = obstacle
    else {
        return Ok(0);
    };
    let Some((lo, hi)) = layout.blocks_over(aabb) else {
        return Ok(0);
    };
    let h = layout.h;
    let vertices: Vec<Vector3<f64>> = data
        .vertices_m
        .iter()
        .map(|v| nvec(pose.transform_point(pvec(v))))
        .collect();
    let prep = Instant::now();
    let mesh = Mesh::new_spatial(&vertices, &data.triangles);
    drop(vertices);
    tracing::debug!("mesh topology: {:.2} s", prep.elapsed().as_secs_f64());
    let side = match *surface {
        Surface::Solid => Side::Solid,
        Surface::Shell { thickness_m } => Side::Shell {
            half_thickness_m: 0.5 * thickness_m,
        },
    };
    let grid = Grid {
        origin: layout.block_min(lo),
        h,
        nodes: [0, 1, 2].map(|a| (hi[a] - lo[a] + 1) * B + 1),
    };
    // Nodes out to two voxels past each side's layers are exact (the band's far values are
    // then a voxel past the layers, lower bounds as every stored value must be); the rest
    // only need a sign.
    let shell = match side {
        Side::Solid => 0.0,
        Side::Shell { half_thickness_m } => half_thickness_m,
    };
    let reach_m = reach(config);
    let limits = Limits {
        out_m: f64::from(config.layers_out + 2) * h + shell,
        in_m: f64::from(config.layers_in + 2) * h,
    };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let band = Band::compute(&mesh, grid, side, limits, threads, control)
        .map_err(|_| VoxmapError::Cancelled)?;
    // The nodes the estimate counted and the spread did not turn: counted now, so that the
    // finishing stages start where the estimate expected them.
    let expected_turns = band_units(data, config).saturating_sub(data.triangles.len() as u64);
    control.add(expected_turns.saturating_sub(band.turns));
    let merging = Instant::now();
    let mut q = [0i16; BLOCK_NODES];
    for bz in lo[2]..=hi[2] {
        if control.cancelled() {
            return Err(VoxmapError::Cancelled);
        }
        control.add(MERGE_UNITS_PER_BLOCK * ((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1)) as u64);
        for by in lo[1]..=hi[1] {
            for bx in lo[0]..=hi[0] {
                let b = layout.block_index([bx, by, bz]);
                if merge.index[b] == INSIDE {
                    continue;
                }
                let first = [(bx - lo[0]) * B, (by - lo[1]) * B, (bz - lo[2]) * B];
                let last = first.map(|x| x + B);
                if !band.touches(first, last) {
                    // One region: wholly inside or outside this mesh.
                    if band.value(first) < 0.0 {
                        merge.inside(b);
                    }
                    continue;
                }
                for (n, node) in q.iter_mut().enumerate() {
                    let (i, j, k) = (n % N, (n / N) % N, n / (N * N));
                    let v = band.value([first[0] + i, first[1] + j, first[2] + k]);
                    *node = quantise(f64::from(v), h, reach_m);
                }
                merge.nodes(b, &q);
            }
        }
    }
    tracing::debug!("band merged: {:.2} s", merging.elapsed().as_secs_f64());
    Ok(band.memory_bytes())
}

/// Merges the primitive obstacles `which`, sampling near-surface blocks on every core.
fn add_primitives(
    layout: &Layout,
    obstacles: &[Obstacle],
    aabbs: &[Aabb],
    which: &[usize],
    config: &VoxmapConfig,
    control: &Progress,
    merge: &mut Merge,
) -> Result<(), VoxmapError> {
    let h = layout.h;
    // Candidate blocks: those overlapping some obstacle's loosened box. The others are
    // farther than `reach` from every primitive, hence outside of them.
    let mut candidates: Vec<(usize, Vec<u32>)> = Vec::new();
    let mut near_of: std::collections::HashMap<usize, Vec<u32>> = Default::default();
    for &i in which {
        let Some((lo, hi)) = layout.blocks_over(&aabbs[i]) else {
            continue;
        };
        for bz in lo[2]..=hi[2] {
            for by in lo[1]..=hi[1] {
                for bx in lo[0]..=hi[0] {
                    near_of
                        .entry(layout.block_index([bx, by, bz]))
                        .or_default()
                        .push(i as u32);
                }
            }
        }
    }
    candidates.extend(near_of);
    candidates.sort_unstable_by_key(|(b, _)| *b);
    let reach_m = reach(config);
    let in_m = f64::from(config.layers_in) * h;
    // A block's nodes lie within its half diagonal of its centre, and signed distances
    // change by at most the distance moved.
    let half_diagonal = 3f64.sqrt() * 0.5 * B as f64 * h;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = candidates.len().div_ceil(threads).max(1);
    enum Verdict {
        Outside,
        Inside,
        Nodes(Box<[i16; BLOCK_NODES]>),
    }
    let sampled: Vec<Result<Vec<(usize, Verdict)>, VoxmapError>> = std::thread::scope(|scope| {
        let workers: Vec<_> = candidates
            .chunks(chunk)
            .map(|part| {
                scope.spawn(move || {
                    let mut out = Vec::with_capacity(part.len());
                    for (count, (b, near)) in part.iter().enumerate() {
                        if count % 64 == 0 {
                            if control.cancelled() {
                                return Err(VoxmapError::Cancelled);
                            }
                            control.add(64.min((part.len() - count) as u64));
                        }
                        let base = layout.block_min(layout.block_coords(*b));
                        let centre = base + Vector3::repeat(0.5 * B as f64 * h);
                        let mut verdict = Verdict::Outside;
                        let mut nodes: Option<Box<[i16; BLOCK_NODES]>> = None;
                        for &s in near {
                            let Obstacle::Shape { pose, shape } = &obstacles[s as usize] else {
                                continue;
                            };
                            let dc = signed_distance(pose, shape, pvec(&centre));
                            if dc - half_diagonal >= reach_m {
                                // Out of reach of every node: as if its box were not near.
                                continue;
                            }
                            if dc + half_diagonal <= -in_m {
                                verdict = Verdict::Inside;
                                nodes = None;
                                break;
                            }
                            let q = nodes.get_or_insert_with(|| Box::new([i16::MAX; BLOCK_NODES]));
                            for (n, node) in q.iter_mut().enumerate() {
                                let (i, j, k) = (n % N, (n / N) % N, n / (N * N));
                                let p = base + Vector3::new(i as f64, j as f64, k as f64) * h;
                                let d = signed_distance(pose, shape, pvec(&p));
                                *node = (*node).min(quantise(d, h, reach_m));
                            }
                        }
                        if let Some(q) = nodes {
                            verdict = Verdict::Nodes(q);
                        }
                        out.push((*b, verdict));
                    }
                    Ok(out)
                })
            })
            .collect();
        workers
            .into_iter()
            .map(|w| w.join().expect("voxmap worker panicked"))
            .collect()
    });
    for part in sampled {
        for (b, verdict) in part? {
            match verdict {
                Verdict::Outside => {}
                Verdict::Inside => merge.inside(b),
                Verdict::Nodes(q) => merge.nodes(b, &q),
            }
        }
    }
    Ok(())
}

/// Chebyshev (26-neighbour) distance in blocks from each block to the nearest block that is
/// not `OUTSIDE`, saturating at `u16::MAX` (also when there is none).
fn chebyshev_distance(index: &[u32], blocks: [usize; 3]) -> Vec<u16> {
    let mut dist = vec![u16::MAX; index.len()];
    let mut queue = VecDeque::new();
    for (b, &code) in index.iter().enumerate() {
        if code != OUTSIDE {
            dist[b] = 0;
            queue.push_back(b);
        }
    }
    while let Some(b) = queue.pop_front() {
        let (x, y, z) = (
            b % blocks[0],
            (b / blocks[0]) % blocks[1],
            b / (blocks[0] * blocks[1]),
        );
        let next = dist[b].saturating_add(1);
        for dz in -1i64..=1 {
            for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let (nx, ny, nz) = (x as i64 + dx, y as i64 + dy, z as i64 + dz);
                    if nx < 0
                        || ny < 0
                        || nz < 0
                        || nx >= blocks[0] as i64
                        || ny >= blocks[1] as i64
                        || nz >= blocks[2] as i64
                    {
                        continue;
                    }
                    let n = nx as usize + blocks[0] * (ny as usize + blocks[1] * nz as usize);
                    if dist[n] > next {
                        dist[n] = next;
                        queue.push_back(n);
                    }
                }
            }
        }
    }
    dist
}

#[cfg(test)]
mod tests {
    use super::super::Sample;
    use super::super::fixtures::slab;
    use super::*;

    #[test]
    fn sparse_storage_and_report() {
        // A solid 300 mm cube at 4 mm voxels: its interior is not stored.
        let cube = vec![(Pose::IDENTITY, SharedShape::cuboid(0.15, 0.15, 0.15))];
        let config = VoxmapConfig {
            voxel_m: 0.004,
            ..VoxmapConfig::default()
        };
        let v = Voxmap::build(&cube, &config).unwrap();
        let r = v.report();
        assert!(r.stored_blocks > 0 && r.stored_blocks < r.total_blocks);
        assert!(r.memory_bytes < r.dense_bytes);
        assert!(r.to_string().contains("MB"));
    }

    #[test]
    fn bad_config_is_an_error() {
        let c = VoxmapConfig {
            voxel_m: 0.0,
            ..VoxmapConfig::default()
        };
        assert!(Voxmap::build(&slab(), &c).is_err());
        let c = VoxmapConfig {
            voxel_m: f64::NAN,
            ..VoxmapConfig::default()
        };
        assert!(Voxmap::build(&slab(), &c).is_err());
        let c = VoxmapConfig {
            layers_in: 0,
            ..VoxmapConfig::default()
        };
        assert!(Voxmap::build(&slab(), &c).is_err());
        let c = VoxmapConfig {
            voxel_m: 1e-7,
            ..VoxmapConfig::default()
        };
        assert!(matches!(
            Voxmap::build(&slab(), &c),
            Err(VoxmapError::TooLarge { .. })
        ));
    }

    #[test]
    fn bad_config_errors_name_the_parameter_and_value() {
        let c = VoxmapConfig {
            voxel_m: -0.5,
            ..VoxmapConfig::default()
        };
        let e = Voxmap::build(&slab(), &c).unwrap_err();
        assert_eq!(
            e,
            VoxmapError::Parameter {
                name: "voxel size",
                need: "a positive number of metres",
                value: -0.5
            }
        );
        assert_eq!(
            e.to_string(),
            "voxmap: voxel size must be a positive number of metres, got -0.5"
        );
        let c = VoxmapConfig {
            layers_out: 101,
            ..VoxmapConfig::default()
        };
        let e = Voxmap::build(&slab(), &c).unwrap_err();
        assert_eq!(
            e,
            VoxmapError::Layers {
                layers_out: 101,
                layers_in: 8
            }
        );
        assert_eq!(
            e.to_string(),
            "voxmap: layers_out and layers_in must be in 1..=100, got 101 and 8"
        );
    }

    #[test]
    fn the_progress_count_goes_on_through_the_finishing_stages() {
        // A mesh whose band the estimate overstates (a coarse sphere, few nodes): what the
        // count reaches beyond the band's own units is the finishing stages'.
        let mesh = Arc::new(MeshData::icosphere("ball", 0.05, 3, scene::Bumps::None));
        let obstacles = [Obstacle::Mesh {
            pose: Pose::IDENTITY,
            mesh: mesh.clone(),
            surface: Surface::Solid,
        }];
        let config = VoxmapConfig {
            voxel_m: 0.004,
            ..VoxmapConfig::default()
        };
        let p = Progress::default();
        let v = Voxmap::build_obstacles(&obstacles, &config, &p).unwrap();
        let (stage, done, total) = p.read();
        assert_eq!(stage, "voxmap");
        let blocks = v.index.len() as u64;
        let (lo, hi) = ([0; 3], v.blocks.map(|b| b - 1));
        let finishing = finish_units((lo, hi)) + blocks;
        assert!(total >= band_units(&mesh, &config) + finishing, "{total}");
        // Counted to the end: the bar is full only when the voxmap is.
        assert_eq!(done, total);
    }

    #[test]
    fn empty_scene_is_far_everywhere() {
        let v = Voxmap::build(&[], &VoxmapConfig::default()).unwrap();
        assert!(matches!(
            v.sample(&Vector3::new(0.3, 0.0, 0.0)),
            Sample::Far { .. }
        ));
    }
}

/// The build against a reference: every node of every block near an obstacle sampled with
/// parry (the build before issue 36, whose cost followed the volume of the obstacles'
/// boxes), node by node.
#[cfg(test)]
mod reference {
    use super::super::Sample;
    use super::*;

    /// A block's nodes, quantised.
    type Nodes = Box<[i16; BLOCK_NODES]>;

    /// Parry's signed distance of every node of every block overlapping an obstacle's
    /// loosened box, minimum over the obstacles near the block, quantised and clamped as
    /// the build does, and the blocks classified as it does: the block codes (OUTSIDE,
    /// INSIDE, FIRST for stored) and the stored nodes.
    pub(super) fn build(
        v: &Voxmap,
        shapes: &[(Pose, SharedShape)],
        config: &VoxmapConfig,
    ) -> (Vec<u32>, Vec<Option<Nodes>>) {
        let h = config.voxel_m;
        let reach_m = reach(config);
        let layout = Layout {
            origin: v.origin,
            h,
            blocks: v.blocks,
        };
        let aabbs: Vec<Aabb> = shapes
            .iter()
            .map(|(p, s)| s.compute_aabb(p).loosened(reach_m))
            .collect();
        let out_q = (f64::from(config.layers_out) * Q) as i32;
        let in_q = -(f64::from(config.layers_in) * Q) as i32;
        let total = v.index.len();
        let mut codes = vec![OUTSIDE; total];
        let mut nodes: Vec<Option<Nodes>> = (0..total).map(|_| None).collect();
        for b in 0..total {
            let bi = layout.block_coords(b);
            let base = layout.block_min(bi);
            let bb = Aabb::new(pvec(&base), pvec(&(base + Vector3::repeat(B as f64 * h))));
            let near: Vec<usize> = (0..shapes.len())
                .filter(|&i| aabbs[i].intersects(&bb))
                .collect();
            if near.is_empty() {
                continue;
            }
            let mut q = Box::new([0i16; BLOCK_NODES]);
            for (n, node) in q.iter_mut().enumerate() {
                let (i, j, k) = (n % N, (n / N) % N, n / (N * N));
                let p = base + Vector3::new(i as f64, j as f64, k as f64) * h;
                let d = near
                    .iter()
                    .map(|&s| signed_distance(&shapes[s].0, &shapes[s].1, pvec(&p)))
                    .fold(f64::INFINITY, f64::min);
                *node = quantise(d, h, reach_m);
            }
            codes[b] = if q.iter().all(|&x| i32::from(x) >= out_q) {
                OUTSIDE
            } else if q.iter().all(|&x| i32::from(x) <= in_q) {
                INSIDE
            } else {
                nodes[b] = Some(q);
                FIRST
            };
        }
        (codes, nodes)
    }

    /// Compares the build `v` with the reference node by node: returns the largest
    /// difference in stored units over nodes stored in both, the blocks classified apart
    /// (after allowing `tol` units at the class boundaries), the blocks compared, and where
    /// the first nodes off by more than `tol` lie.
    pub(super) fn compare(
        v: &Voxmap,
        shapes: &[(Pose, SharedShape)],
        config: &VoxmapConfig,
        tol: i32,
    ) -> (i32, usize, usize, Vec<String>) {
        let (codes, nodes) = build(v, shapes, config);
        let layout = Layout {
            origin: v.origin,
            h: v.h,
            blocks: v.blocks,
        };
        let mut worst_at = Vec::new();
        let out_q = (f64::from(config.layers_out) * Q) as i32;
        let in_q = -(f64::from(config.layers_in) * Q) as i32;
        // A mesh's values are exact a voxel past each side's layers and clamped there.
        let (far_out, far_in) = (out_q + Q as i32, in_q - Q as i32);
        let clamp = |x: i16| i32::from(x).clamp(far_in, far_out);
        let (mut worst, mut apart, mut compared) = (0, 0, 0);
        for b in 0..codes.len() {
            let mine = v.index[b];
            let stored = |slot: u32| {
                let base = (slot - FIRST) as usize * BLOCK_NODES;
                &v.data[base..base + BLOCK_NODES]
            };
            match (mine, codes[b], &nodes[b]) {
                (m, r, _) if m < FIRST && m == r => {}
                (m, _, Some(q)) if m >= FIRST => {
                    compared += 1;
                    for (n, (a, r)) in stored(m).iter().zip(q.iter()).enumerate() {
                        let d = (clamp(*a) - clamp(*r)).abs();
                        if d > tol && worst_at.len() < 5 {
                            let (i, j, k) = (n % N, (n / N) % N, n / (N * N));
                            let bi = layout.block_coords(b);
                            let p = layout.block_min(bi)
                                + Vector3::new(i as f64, j as f64, k as f64) * v.h;
                            worst_at.push(format!("{p:.4?}: {a} vs {r}"));
                        }
                        worst = worst.max(d);
                    }
                }
                // Stored on one side only: the other side's nodes must sit at the class
                // boundary within the tolerance.
                (m, r, q) => {
                    let values: Vec<i32> = if m >= FIRST {
                        stored(m).iter().map(|&x| i32::from(x)).collect()
                    } else if let Some(q) = q {
                        q.iter().map(|&x| i32::from(x)).collect()
                    } else {
                        Vec::new()
                    };
                    let class = if m >= FIRST { r } else { m };
                    let near_boundary = match class {
                        OUTSIDE => values.iter().all(|&x| x >= out_q - tol),
                        INSIDE => values.iter().all(|&x| x <= in_q + tol),
                        _ => false,
                    };
                    if !near_boundary {
                        apart += 1;
                    }
                }
            }
        }
        (worst, apart, compared, worst_at)
    }

    fn part_shapes(scene: &scene::Scene) -> Vec<(Pose, SharedShape)> {
        scene::shapes::part_shapes(&scene.obstacles)
    }

    #[test]
    fn every_built_in_scene_gives_the_reference_nodes() {
        let config = VoxmapConfig {
            voxel_m: 0.002,
            ..VoxmapConfig::default()
        };
        for name in scene::BUILTIN_NAMES {
            let s = scene::Scene::builtin(name).unwrap();
            let shapes = part_shapes(&s);
            let v = Voxmap::build(&shapes, &config).unwrap();
            let (worst, apart, compared, at) = compare(&v, &shapes, &config, 0);
            assert_eq!(
                (worst, apart),
                (0, 0),
                "{name}: {compared} blocks compared; {at:?}"
            );
            assert_eq!(compared > 0, !s.obstacles.is_empty(), "{name}");
        }
    }

    /// A bumpy sphere (not convex: bumps of ±10 %) and a closed box mesh overlapping it.
    fn meshes() -> Vec<(Pose, SharedShape)> {
        let sphere = MeshData::bumpy_sphere("sphere", 0.05, 40, 80);
        let cube = MeshData::cuboid("cube", [0.03, 0.02, 0.04]);
        let shape = |m: &MeshData, at: [f64; 3]| {
            let part = scene::Part {
                primitive: scene::Primitive::Mesh {
                    mesh: Arc::new(m.clone()),
                },
                pose: scene::Se3::from_xyz(at[0], at[1], at[2]),
            };
            (
                scene::shapes::to_parry(&part.pose),
                scene::shapes::part_shape(&part),
            )
        };
        vec![
            shape(&sphere, [0.0, 0.0, 0.0]),
            shape(&cube, [0.05, 0.01, -0.02]),
        ]
    }

    #[test]
    fn mesh_distances_agree_with_exact_point_mesh_distances_to_the_quantisation() {
        let config = VoxmapConfig {
            voxel_m: 0.002,
            ..VoxmapConfig::default()
        };
        let shapes = meshes();
        let v = Voxmap::build(&shapes, &config).unwrap();
        // One stored unit is h/256; f32 band values round once more.
        let (worst, apart, compared, at) = compare(&v, &shapes, &config, 1);
        assert!(compared > 300, "{compared}");
        assert!(
            worst <= 1,
            "largest difference {worst} units (h/256): {at:?}"
        );
        assert_eq!(apart, 0);
    }

    #[test]
    fn inside_and_outside_are_right_on_random_points() {
        use rand::{Rng, SeedableRng};
        let config = VoxmapConfig {
            voxel_m: 0.002,
            ..VoxmapConfig::default()
        };
        let shapes = meshes();
        let v = Voxmap::build(&shapes, &config).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut counted = [0; 2];
        for _ in 0..20_000 {
            let p = Vector3::from_fn(|_, _| rng.random_range(-0.08..0.1));
            let inside = shapes
                .iter()
                .any(|(pose, s)| s.contains_point(pose, pvec(&p)));
            let d = shapes
                .iter()
                .map(|(pose, s)| signed_distance(pose, s, pvec(&p)))
                .fold(f64::INFINITY, f64::min);
            if d.abs() < 0.5 * config.voxel_m {
                continue; // the interpolation's own error, not a sign
            }
            let said_inside = match v.sample(&p) {
                Sample::Far { .. } => false,
                Sample::Deep => true,
                Sample::Near { distance_m, .. } => distance_m < 0.0,
            };
            assert_eq!(said_inside, inside, "{p:?} at {d} m");
            counted[usize::from(inside)] += 1;
        }
        assert!(counted[0] > 1000 && counted[1] > 1000, "{counted:?}");
    }
}
