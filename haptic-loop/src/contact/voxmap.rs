//! The voxmap: a sparse, sampled signed-distance field of the static scene.
//!
//! Grid nodes sit at `origin + h·(i, j, k)` in the scene frame (h = voxel size, m). Each
//! node stores the signed distance from the node to the obstacles' surface, positive outside,
//! in units of h/256 as an `i16` (±127 voxels, quantisation 1/256 voxel). These are the
//! distance layers of McNeely et al. 2006, kept continuous instead of integer so that the
//! force grows smoothly with depth: a query interpolates the 8 nodes around it (trilinear),
//! and the gradient of that interpolant is the surface normal.
//!
//! Storage is sparse: nodes are grouped into blocks of 8×8×8 cells, each stored with its
//! far faces (9×9×9 nodes) so that an interpolation never crosses a block. Only blocks
//! holding a node within `layers_out` voxels outside or `layers_in` voxels inside the
//! surface are stored; the others are marked *outside* or *inside* in a dense block index.
//! A Chebyshev distance transform over the block index gives every outside block a lower
//! bound on its clearance, so whole pointshell clusters far from the scene are rejected with
//! one look-up.
//!
//! Signed distances come from parry (`project_point`, non-solid) against every obstacle shape,
//! so boxes, spheres and triangle meshes (oriented, for the inside test) are voxelised by the
//! same code. The union of obstacles takes the minimum of their signed distances: exact
//! outside, and inside it never understates a depth.

use super::lanes::{LANES, Lanes, axes, lanes};
use nalgebra::Vector3;
use parry3d_f64::bounding_volume::{Aabb, BoundingVolume};
use parry3d_f64::math::{Pose, Vector as PVec};
use parry3d_f64::shape::SharedShape;
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// Cells per block edge.
const B: usize = 8;
/// Nodes per block edge (the block's cells plus its far faces).
const N: usize = B + 1;
/// Nodes per stored block.
const BLOCK_NODES: usize = N * N * N;
/// Quantisation: stored units per voxel.
const Q: f64 = 256.0;
/// Block index code: no node of the block within `layers_out` of the surface, outside.
const OUTSIDE: u32 = 0;
/// Block index code: every node deeper than `layers_in` inside an obstacle.
const INSIDE: u32 = 1;
/// First index of a stored block (index − FIRST = position in `data` / BLOCK_NODES).
const FIRST: u32 = 2;

/// How to build a voxmap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoxmapConfig {
    /// Edge of a voxel (grid spacing), m. > 0.
    pub voxel_m: f64,
    /// Distance layers stored outside the surface, in voxels (≥ 1): the proximity layer
    /// and the clearance bound live here.
    pub layers_out: u32,
    /// Distance layers stored inside the surface, in voxels (≥ 1): the deepest penetration
    /// that still gets a force direction.
    pub layers_in: u32,
}

impl Default for VoxmapConfig {
    fn default() -> Self {
        Self {
            voxel_m: 0.001,
            layers_out: 4,
            layers_in: 8,
        }
    }
}

/// Why a voxmap could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum VoxmapError {
    /// A parameter is out of range.
    #[error("voxmap: {0}")]
    Config(String),
    /// The grid would exceed the memory budget.
    #[error(
        "voxmap: {what} would need {needed_mb:.0} MB at {voxel_mm} mm voxels (limit {limit_mb:.0} MB); use larger voxels"
    )]
    TooLarge {
        /// Which part of the voxmap.
        what: &'static str,
        /// Needed, MB.
        needed_mb: f64,
        /// The limit, MB.
        limit_mb: f64,
        /// Voxel size asked for, mm.
        voxel_mm: f64,
    },
}

/// Memory limit of one voxmap (block index plus stored blocks), bytes. It also keeps every
/// block and node index below 2^31, which the AVX2 look-up's 32-bit offsets rely on.
pub const MAX_BYTES: usize = 1 << 30;
const _: () = assert!(MAX_BYTES / 2 <= i32::MAX as usize);

/// Facts about a built voxmap, for the start-up report.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoxmapReport {
    /// Voxel size, m.
    pub voxel_m: f64,
    /// Grid size in voxels (x, y, z).
    pub dims_voxels: [usize; 3],
    /// Blocks stored (near the surface).
    pub stored_blocks: usize,
    /// Blocks in the index.
    pub total_blocks: usize,
    /// Heap memory held, bytes.
    pub memory_bytes: usize,
    /// What a dense grid of the same nodes would need as `i16`, bytes.
    pub dense_bytes: usize,
    /// Wall-clock build time.
    pub build_time: Duration,
}

impl std::fmt::Display for VoxmapReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "voxmap {}×{}×{} voxels of {} mm: {} of {} blocks stored, {:.1} MB (dense {:.1} MB), built in {:.2} s",
            self.dims_voxels[0],
            self.dims_voxels[1],
            self.dims_voxels[2],
            self.voxel_m * 1e3,
            self.stored_blocks,
            self.total_blocks,
            self.memory_bytes as f64 / 1e6,
            self.dense_bytes as f64 / 1e6,
            self.build_time.as_secs_f64()
        )
    }
}

/// [`Voxmap::sample_lanes`]' answer: per lane, the field where the point lies within the
/// stored layers (`stored`); distance and gradient are zero elsewhere.
#[derive(Debug, Clone, Copy)]
pub(super) struct LaneSamples {
    /// All bits set where the point lies in a stored block (within the stored layers),
    /// 0 elsewhere: a SIMD mask.
    pub stored: [i32; LANES],
    /// Signed distance, m (negative inside).
    pub distance_m: Lanes,
    /// Gradient of the signed distance.
    pub gradient: [Lanes; 3],
    /// Where not `stored`: a lower bound of the distance to the surface, m (0 if unknown).
    pub clearance_m: Lanes,
}

/// What [`Voxmap::sample_lanes`] reads from the grid: per lane, the cell's eight corner
/// nodes (corner index = i + 2j + 4k, in stored units; 0 where not stored), the position
/// within the cell, the `stored` mask and the clearance of [`LaneSamples`].
#[derive(Debug, Clone, Copy, PartialEq)]
struct LaneCorners {
    stored: [i32; LANES],
    frac: [Lanes; 3],
    c: [Lanes; 8],
    clearance_m: Lanes,
}

/// [`LaneCorners`] in AVX2 registers (`stored` all ones or zero per lane).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct CornersM256 {
    stored: std::arch::x86_64::__m256i,
    frac: [std::arch::x86_64::__m256; 3],
    c: [std::arch::x86_64::__m256; 8],
    clearance_m: std::arch::x86_64::__m256,
}

/// [`LaneSamples`] in AVX2 registers (`stored` a mask: all ones or zero per lane).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(super) struct SamplesM256 {
    pub stored: std::arch::x86_64::__m256,
    pub distance_m: std::arch::x86_64::__m256,
    pub gradient: [std::arch::x86_64::__m256; 3],
    pub clearance_m: std::arch::x86_64::__m256,
}

/// Offsets from a cell's lowest node to the first node of each pair of x-neighbours among
/// its corners (corners 2m and 2m + 1 are adjacent in memory).
const PAIR_OFFSETS: [usize; 4] = [0, N, N * N, N * N + N];

/// One query of the field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sample {
    /// Farther than the stored layers outside; the surface is at least `clearance_m` away.
    Far {
        /// Lower bound of the distance to the surface, m.
        clearance_m: f64,
    },
    /// Deeper inside than the stored layers: no direction known.
    Deep,
    /// Within the stored layers.
    Near {
        /// Signed distance, m (negative inside).
        distance_m: f64,
        /// Gradient of the signed distance (unit length on flat surfaces; zero only where
        /// the field is flat, e.g. midway inside a thin plate).
        gradient: Vector3<f64>,
    },
}

/// The sampled signed-distance field of the static scene. Immutable after build; queries
/// neither allocate nor lock.
#[derive(Debug, Clone)]
pub struct Voxmap {
    origin: Vector3<f64>,
    h: f64,
    inv_h: f64,
    /// Cells in the grid per axis (a multiple of B), as floats: the per-query bounds test compares against these (a `usize` to
    /// `f64` conversion is a dozen instructions on x86-64).
    cells_f: [f64; 3],
    blocks: [usize; 3],
    index: Vec<u32>,
    /// Chebyshev distance, in blocks, from each block to the nearest non-outside block.
    block_distance: Vec<u16>,
    data: Vec<i16>,
    layers_out: u32,
    report: VoxmapReport,
}

fn pvec(v: &Vector3<f64>) -> PVec {
    PVec::new(v.x, v.y, v.z)
}

fn nvec(v: PVec) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

/// Signed distance from `p` to one shape (negative inside).
fn signed_distance(pose: &Pose, shape: &SharedShape, p: PVec) -> f64 {
    let proj = shape.project_point(pose, p, false);
    let d = (proj.point - p).length();
    if proj.is_inside { -d } else { d }
}

impl Voxmap {
    /// Voxelises `shapes` (pose in the scene frame, shape). Uses every core the machine has;
    /// an empty scene gives a voxmap where everything is far.
    pub fn build(
        shapes: &[(Pose, SharedShape)],
        config: &VoxmapConfig,
    ) -> Result<Self, VoxmapError> {
        let started = Instant::now();
        let h = config.voxel_m;
        if !(h.is_finite() && h > 0.0) {
            return Err(VoxmapError::Config(format!(
                "voxel size must be a positive number of metres, got {h}"
            )));
        }
        if config.layers_out < 1
            || config.layers_in < 1
            || config.layers_out.max(config.layers_in) > 100
        {
            return Err(VoxmapError::Config(format!(
                "layers_out and layers_in must be in 1..=100, got {} and {}",
                config.layers_out, config.layers_in
            )));
        }
        let reach = f64::from(config.layers_out.max(config.layers_in) + 1) * h;
        let aabbs: Vec<Aabb> = shapes
            .iter()
            .map(|(pose, s)| s.compute_aabb(pose).loosened(reach))
            .collect();
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

        // Candidate blocks: those overlapping some obstacle's loosened box. The others are
        // farther than `reach` from every obstacle, hence outside.
        let block_aabb = |b: [usize; 3]| {
            let lo = origin + Vector3::new(b[0] as f64, b[1] as f64, b[2] as f64) * (B as f64 * h);
            let hi = lo + Vector3::repeat(B as f64 * h);
            Aabb::new(pvec(&lo), pvec(&hi))
        };
        let mut candidates: Vec<(usize, Vec<u32>)> = Vec::new();
        for bz in 0..blocks[2] {
            for by in 0..blocks[1] {
                for bx in 0..blocks[0] {
                    let bb = block_aabb([bx, by, bz]);
                    let near: Vec<u32> = (0..shapes.len() as u32)
                        .filter(|&i| aabbs[i as usize].intersects(&bb))
                        .collect();
                    if !near.is_empty() {
                        candidates.push((bx + blocks[0] * (by + blocks[1] * bz), near));
                    }
                }
            }
        }

        // Sample the candidates on all cores, then classify each block.
        let out_q = (f64::from(config.layers_out) * Q) as i32;
        let in_q = -(f64::from(config.layers_in) * Q) as i32;
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        let chunk = candidates.len().div_ceil(threads).max(1);
        let sampled: Vec<Vec<(usize, u32, Vec<i16>)>> = std::thread::scope(|scope| {
            let workers: Vec<_> = candidates
                .chunks(chunk)
                .map(|part| {
                    scope.spawn(move || {
                        part.iter()
                            .map(|(b, near)| {
                                let bi = [
                                    b % blocks[0],
                                    (b / blocks[0]) % blocks[1],
                                    b / (blocks[0] * blocks[1]),
                                ];
                                let base = origin
                                    + Vector3::new(bi[0] as f64, bi[1] as f64, bi[2] as f64)
                                        * (B as f64 * h);
                                let mut nodes = vec![0i16; BLOCK_NODES];
                                let (mut all_out, mut all_in) = (true, true);
                                for (n, node) in nodes.iter_mut().enumerate() {
                                    let (i, j, k) = (n % N, (n / N) % N, n / (N * N));
                                    let p = base + Vector3::new(i as f64, j as f64, k as f64) * h;
                                    let d = near
                                        .iter()
                                        .map(|&s| {
                                            let (pose, shape) = &shapes[s as usize];
                                            signed_distance(pose, shape, pvec(&p))
                                        })
                                        .fold(f64::INFINITY, f64::min);
                                    let q = (d / h * Q).round().clamp(-32767.0, 32767.0) as i32;
                                    all_out &= q >= out_q;
                                    all_in &= q <= in_q;
                                    *node = q as i16;
                                }
                                let code = if all_out {
                                    OUTSIDE
                                } else if all_in {
                                    INSIDE
                                } else {
                                    FIRST
                                };
                                (*b, code, if code == FIRST { nodes } else { Vec::new() })
                            })
                            .collect()
                    })
                })
                .collect();
            workers
                .into_iter()
                .map(|w| w.join().expect("voxmap worker panicked"))
                .collect()
        });

        let mut index = vec![OUTSIDE; total_blocks];
        let stored = sampled
            .iter()
            .flatten()
            .filter(|(_, c, _)| *c == FIRST)
            .count();
        let data_bytes = stored * BLOCK_NODES * 2;
        if data_bytes + index_bytes > MAX_BYTES {
            return Err(VoxmapError::TooLarge {
                what: "the stored blocks",
                needed_mb: (data_bytes + index_bytes) as f64 / 1e6,
                limit_mb: MAX_BYTES as f64 / 1e6,
                voxel_mm: h * 1e3,
            });
        }
        let mut data = Vec::with_capacity(stored * BLOCK_NODES);
        for (b, code, nodes) in sampled.into_iter().flatten() {
            index[b] = if code == FIRST {
                let slot = FIRST + (data.len() / BLOCK_NODES) as u32;
                data.extend_from_slice(&nodes);
                slot
            } else {
                code
            };
        }
        let block_distance = chebyshev_distance(&index, blocks);

        let memory_bytes = index.len() * 4 + block_distance.len() * 2 + data.len() * 2;
        let dense_bytes = (cells[0] + 1) * (cells[1] + 1) * (cells[2] + 1) * 2;
        Ok(Self {
            origin,
            h,
            inv_h: 1.0 / h,
            cells_f: cells.map(|c| c as f64),
            blocks,
            index,
            block_distance,
            data,
            layers_out: config.layers_out,
            report: VoxmapReport {
                voxel_m: h,
                dims_voxels: cells,
                stored_blocks: stored,
                total_blocks,
                memory_bytes,
                dense_bytes,
                build_time: started.elapsed(),
            },
        })
    }

    /// Build facts: size, memory, time.
    pub fn report(&self) -> &VoxmapReport {
        &self.report
    }

    /// Voxel size, m.
    pub fn voxel_m(&self) -> f64 {
        self.h
    }

    /// Lower bound on the clearance of a point whose block is outside: the stored layers
    /// (minus one voxel of interpolation slack) or the empty blocks between, whichever is
    /// larger.
    fn far_clearance(&self, blocks_away: f64) -> f64 {
        let layers = (f64::from(self.layers_out) - 1.0) * self.h;
        layers.max((blocks_away - 1.0) * B as f64 * self.h)
    }

    /// The field at `p` (scene frame, m). O(1), no allocation.
    #[inline(always)]
    pub fn sample(&self, p: &Vector3<f64>) -> Sample {
        let g = (p - self.origin) * self.inv_h;
        let inside_grid = g.x >= 0.0
            && g.y >= 0.0
            && g.z >= 0.0
            && g.x < self.cells_f[0]
            && g.y < self.cells_f[1]
            && g.z < self.cells_f[2];
        if !inside_grid {
            // The surface lies at least `reach` inside the grid box.
            let d = (0..3)
                .map(|a| {
                    let lo = -g[a];
                    let hi = g[a] - self.cells_f[a];
                    lo.max(hi).max(0.0)
                })
                .fold(0.0_f64, |s, x| s + x * x)
                .sqrt()
                * self.h;
            return Sample::Far {
                clearance_m: d + self.far_clearance(0.0),
            };
        }
        // In range (checked above), so truncation is the floor; `as u32` of a value in
        // [0, cells) is exact and cheaper than a saturating `as usize`.
        let (ix, iy, iz) = (
            g.x as u32 as usize,
            g.y as u32 as usize,
            g.z as u32 as usize,
        );
        let b = ix / B + self.blocks[0] * (iy / B + self.blocks[1] * (iz / B));
        let slot = self.index[b];
        if slot == OUTSIDE {
            return Sample::Far {
                clearance_m: self.far_clearance(f64::from(self.block_distance[b])),
            };
        }
        if slot == INSIDE {
            return Sample::Deep;
        }
        let base = (slot - FIRST) as usize * BLOCK_NODES;
        // A fixed-size view: every index below is < BLOCK_NODES by construction (local
        // coordinates ≤ 8), which lets the compiler drop the bounds checks.
        let block: &[i16; BLOCK_NODES] = self.data[base..base + BLOCK_NODES]
            .try_into()
            .expect("blocks are BLOCK_NODES long");
        let (lx, ly, lz) = (ix % B, iy % B, iz % B);
        let at = |i: usize, j: usize, k: usize| {
            f64::from(block[(lx + i) + N * ((ly + j) + N * (lz + k))])
        };
        let (fx, fy, fz) = (g.x - ix as f64, g.y - iy as f64, g.z - iz as f64);
        let (c000, c100, c010, c110) = (at(0, 0, 0), at(1, 0, 0), at(0, 1, 0), at(1, 1, 0));
        let (c001, c101, c011, c111) = (at(0, 0, 1), at(1, 0, 1), at(0, 1, 1), at(1, 1, 1));
        // Interpolate along x, then y, then z; keep the partial derivatives.
        let c00 = c000 + (c100 - c000) * fx;
        let c10 = c010 + (c110 - c010) * fx;
        let c01 = c001 + (c101 - c001) * fx;
        let c11 = c011 + (c111 - c011) * fx;
        let c0 = c00 + (c10 - c00) * fy;
        let c1 = c01 + (c11 - c01) * fy;
        let value = c0 + (c1 - c0) * fz;
        let dx0 = (c100 - c000) + ((c110 - c010) - (c100 - c000)) * fy;
        let dx1 = (c101 - c001) + ((c111 - c011) - (c101 - c001)) * fy;
        let dx = dx0 + (dx1 - dx0) * fz;
        let dy = (c10 - c00) + ((c11 - c01) - (c10 - c00)) * fz;
        let dz = c1 - c0;
        // Stored units are h/256 per node step of h: gradient in (h/256)/h = 1/256.
        Sample::Near {
            distance_m: value * self.h / Q,
            gradient: Vector3::new(dx, dy, dz) / Q,
        }
    }

    /// The field at [`LANES`] points at once (scene frame, m), for the contact search: per
    /// lane, whether the point lies within the stored layers, and there its signed distance
    /// (m) and gradient; elsewhere a lower bound of its clearance (0 when unknown: deep
    /// inside, or outside the grid). The same interpolation as [`Self::sample`] in `f32`,
    /// written lane by lane so the arithmetic runs in SIMD registers; only the block
    /// look-up and the node loads are per lane ([`Self::sample_m256`] gathers them).
    #[inline(always)]
    pub(super) fn sample_lanes(&self, p: &[Lanes; 3]) -> LaneSamples {
        let k = self.corners(p);
        let LaneCorners {
            stored,
            frac: [fx, fy, fz],
            c,
            clearance_m,
        } = k;
        let lerp = |a: &Lanes, b: &Lanes, f: &Lanes| lanes(|l| a[l] + (b[l] - a[l]) * f[l]);
        let c00 = lerp(&c[0], &c[1], &fx);
        let c10 = lerp(&c[2], &c[3], &fx);
        let c01 = lerp(&c[4], &c[5], &fx);
        let c11 = lerp(&c[6], &c[7], &fx);
        let c0 = lerp(&c00, &c10, &fy);
        let c1 = lerp(&c01, &c11, &fy);
        let value = lerp(&c0, &c1, &fz);
        let dx0 = lerp(
            &lanes(|l| c[1][l] - c[0][l]),
            &lanes(|l| c[3][l] - c[2][l]),
            &fy,
        );
        let dx1 = lerp(
            &lanes(|l| c[5][l] - c[4][l]),
            &lanes(|l| c[7][l] - c[6][l]),
            &fy,
        );
        let dx = lerp(&dx0, &dx1, &fz);
        let dy = lerp(
            &lanes(|l| c10[l] - c00[l]),
            &lanes(|l| c11[l] - c01[l]),
            &fz,
        );
        let dz = lanes(|l| c1[l] - c0[l]);
        // Stored units are h/256 per node step of h (see `sample`).
        let scale = (self.h / Q) as f32;
        let per_unit = (1.0 / Q) as f32;
        LaneSamples {
            stored,
            distance_m: lanes(|l| value[l] * scale),
            gradient: [
                lanes(|l| dx[l] * per_unit),
                lanes(|l| dy[l] * per_unit),
                lanes(|l| dz[l] * per_unit),
            ],
            clearance_m,
        }
    }

    /// The points' positions in cells (`g`, relative to the grid's origin).
    #[inline(always)]
    fn cell_coordinates(&self, p: &[Lanes; 3]) -> [Lanes; 3] {
        let inv_h = self.inv_h as f32;
        let origin = self.origin.map(|o| o as f32);
        axes(|a| lanes(|l| (p[a][l] - origin[a]) * inv_h))
    }

    /// The cells' corner nodes, lane by lane (see [`Self::sample_lanes`]).
    #[inline(always)]
    fn corners(&self, p: &[Lanes; 3]) -> LaneCorners {
        let cells = self.cells_f.map(|c| c as f32);
        let g = self.cell_coordinates(p);
        let inside: [bool; LANES] = lanes(|l| {
            let [x, y, z] = [g[0][l], g[1][l], g[2][l]];
            // `&`, not `&&`: no branch per comparison, so the lanes stay in SIMD registers.
            (x >= 0.0) & (y >= 0.0) & (z >= 0.0) & (x < cells[0]) & (y < cells[1]) & (z < cells[2])
        });
        // Clamped into the grid so that the conversion and the look-ups below are valid
        // for every lane; lanes outside are dropped by `inside`.
        // Comparisons rather than `max`/`min`, whose NaN rules cost extra instructions; a
        // NaN coordinate becomes 0 here (`inside` drops it).
        let cell: [[i32; LANES]; 3] = axes(|a| {
            let top = cells[a] - 1.0;
            lanes(|l| {
                let x = g[a][l];
                let x = if x >= 0.0 { x } else { 0.0 };
                let x = if x > top { top } else { x };
                // SAFETY: x is finite and within [0, cells − 1], which fits an i32 (the
                // grid has far fewer than 2^31 cells per axis). The checked `as` would
                // keep this conversion out of SIMD registers.
                unsafe { x.to_int_unchecked::<i32>() }
            })
        });
        let frac: [Lanes; 3] = axes(|a| lanes(|l| g[a][l] - cell[a][l] as f32));
        let mut stored = [0; LANES];
        let mut clearance_m = [0.0; LANES];
        // Node values at the cell's corners, corner index = i + 2j + 4k, loaded as four
        // pairs of x-neighbours (corners 2m and 2m + 1 are adjacent in memory).
        let mut pairs = [[0u32; LANES]; 4];
        for l in 0..LANES {
            let (ix, iy, iz) = (
                cell[0][l] as usize,
                cell[1][l] as usize,
                cell[2][l] as usize,
            );
            let b = ix / B + self.blocks[0] * (iy / B + self.blocks[1] * (iz / B));
            let slot = self.index[b];
            if !inside[l] {
                continue;
            }
            if slot == OUTSIDE {
                clearance_m[l] = self.far_clearance(f64::from(self.block_distance[b])) as f32;
                continue;
            }
            let Some(block) = slot.checked_sub(FIRST).and_then(|s| {
                let start = s as usize * BLOCK_NODES;
                self.data
                    .get(start..start + BLOCK_NODES)
                    .and_then(|b| <&[i16; BLOCK_NODES]>::try_from(b).ok())
            }) else {
                continue; // INSIDE: deep, no direction
            };
            stored[l] = -1;
            // The cell's lowest node; its far corner (+1 along each axis) is within the
            // block because local coordinates are ≤ B − 1.
            let at = (ix % B) + N * ((iy % B) + N * (iz % B));
            let pair = |offset: usize| {
                u32::from(block[at + offset] as u16)
                    | u32::from(block[at + offset + 1] as u16) << 16
            };
            for (m, offset) in PAIR_OFFSETS.iter().enumerate() {
                pairs[m][l] = pair(*offset);
            }
        }
        let mut c = [[0.0; LANES]; 8];
        for (m, pair) in pairs.iter().enumerate() {
            c[2 * m] = lanes(|l| f32::from(pair[l] as u16 as i16));
            c[2 * m + 1] = lanes(|l| f32::from((pair[l] >> 16) as u16 as i16));
        }
        LaneCorners {
            stored,
            frac,
            c,
            clearance_m,
        }
    }

    /// [`Self::corners`] through [`Self::corners_m256`], for the test that compares them.
    #[cfg(all(test, target_arch = "x86_64"))]
    #[target_feature(enable = "avx2")]
    fn corners_avx2(&self, p: &[Lanes; 3]) -> LaneCorners {
        use std::arch::x86_64::*;
        // SAFETY: every array written or read holds LANES 32-bit values.
        unsafe {
            let k = self.corners_m256(axes(|a| _mm256_loadu_ps(p[a].as_ptr())));
            let mut out = LaneCorners {
                stored: [0; LANES],
                frac: [[0.0; LANES]; 3],
                c: [[0.0; LANES]; 8],
                clearance_m: [0.0; LANES],
            };
            _mm256_storeu_si256(out.stored.as_mut_ptr().cast(), k.stored);
            for (o, v) in out.frac.iter_mut().zip(&k.frac) {
                _mm256_storeu_ps(o.as_mut_ptr(), *v);
            }
            for (o, v) in out.c.iter_mut().zip(&k.c) {
                _mm256_storeu_ps(o.as_mut_ptr(), *v);
            }
            _mm256_storeu_ps(out.clearance_m.as_mut_ptr(), k.clearance_m);
            out
        }
    }

    /// [`Self::corners`] with AVX2 gathers, in registers: the block index and the node
    /// pairs are loaded eight lanes at a time instead of through per-lane loads and stores.
    /// Same bits as [`Self::corners`].
    ///
    /// Every block and node index fits an `i32` ([`MAX_BYTES`]); a pair read at a cell's
    /// node stays within its block (see [`Self::corners`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    fn corners_m256(&self, p: [std::arch::x86_64::__m256; 3]) -> CornersM256 {
        use std::arch::x86_64::*;
        const {
            assert!(
                B == 8,
                "block coordinates are cell >> 3, local ones cell & 7"
            )
        };
        let zero = _mm256_setzero_ps();
        let mut inside = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
        let mut cell = [_mm256_setzero_si256(); 3];
        let mut frac = [zero; 3];
        for a in 0..3 {
            // The same operations as `cell_coordinates`.
            let x = _mm256_mul_ps(
                _mm256_sub_ps(p[a], _mm256_set1_ps(self.origin[a] as f32)),
                _mm256_set1_ps(self.inv_h as f32),
            );
            let cells = _mm256_set1_ps(self.cells_f[a] as f32);
            inside = _mm256_and_ps(inside, _mm256_cmp_ps::<_CMP_GE_OQ>(x, zero));
            inside = _mm256_and_ps(inside, _mm256_cmp_ps::<_CMP_LT_OQ>(x, cells));
            // max(NaN, 0) is 0; the clamped value converts exactly as `corners`' does.
            let top = _mm256_set1_ps(self.cells_f[a] as f32 - 1.0);
            let clamped = _mm256_min_ps(_mm256_max_ps(x, zero), top);
            cell[a] = _mm256_cvttps_epi32(clamped);
            frac[a] = _mm256_sub_ps(x, _mm256_cvtepi32_ps(cell[a]));
        }
        let inside = _mm256_castps_si256(inside);
        let block = |a: usize| _mm256_srli_epi32::<3>(cell[a]);
        let local = |a: usize| _mm256_and_si256(cell[a], _mm256_set1_epi32(B as i32 - 1));
        let times = |x: __m256i, n: usize| _mm256_mullo_epi32(x, _mm256_set1_epi32(n as i32));
        let b = _mm256_add_epi32(
            block(0),
            times(
                _mm256_add_epi32(block(1), times(block(2), self.blocks[1])),
                self.blocks[0],
            ),
        );
        // SAFETY: the cells are clamped into the grid, so every `b` indexes `index`.
        let slot = unsafe { _mm256_i32gather_epi32::<4>(self.index.as_ptr().cast(), b) };
        let stored = _mm256_and_si256(
            inside,
            _mm256_cmpgt_epi32(slot, _mm256_set1_epi32(INSIDE as i32)),
        );
        let outside = _mm256_and_si256(
            inside,
            _mm256_cmpeq_epi32(slot, _mm256_set1_epi32(OUTSIDE as i32)),
        );
        let mut far = _mm256_movemask_ps(_mm256_castsi256_ps(outside)) as u32;
        let mut clearance_m = zero;
        if far != 0 {
            // Rare within a contact: scalar.
            let mut blocks = [0i32; LANES];
            let mut clearance = [0.0f32; LANES];
            // SAFETY: `blocks` holds LANES i32.
            unsafe { _mm256_storeu_si256(blocks.as_mut_ptr().cast(), b) };
            while far != 0 {
                let l = far.trailing_zeros() as usize;
                let distance = self.block_distance[blocks[l] as usize];
                clearance[l] = self.far_clearance(f64::from(distance)) as f32;
                far &= far - 1;
            }
            // SAFETY: `clearance` holds LANES f32.
            clearance_m = unsafe { _mm256_loadu_ps(clearance.as_ptr()) };
        }
        let at = _mm256_add_epi32(
            local(0),
            times(_mm256_add_epi32(local(1), times(local(2), N)), N),
        );
        let first = times(
            _mm256_sub_epi32(slot, _mm256_set1_epi32(FIRST as i32)),
            BLOCK_NODES,
        );
        // Lanes not stored read nothing (masked) and get zeros, as in `corners`.
        let node = _mm256_and_si256(stored, _mm256_add_epi32(first, at));
        let mut c = [zero; 8];
        for (m, offset) in PAIR_OFFSETS.iter().enumerate() {
            let offsets = _mm256_add_epi32(node, _mm256_set1_epi32(*offset as i32));
            // SAFETY: stored lanes read two `i16` of their own block (scale 2 = one node),
            // the others nothing.
            let pair = unsafe {
                _mm256_mask_i32gather_epi32::<2>(
                    _mm256_setzero_si256(),
                    self.data.as_ptr().cast(),
                    offsets,
                    stored,
                )
            };
            let low = _mm256_srai_epi32::<16>(_mm256_slli_epi32::<16>(pair));
            let high = _mm256_srai_epi32::<16>(pair);
            c[2 * m] = _mm256_cvtepi32_ps(low);
            c[2 * m + 1] = _mm256_cvtepi32_ps(high);
        }
        CornersM256 {
            stored,
            frac,
            c,
            clearance_m,
        }
    }

    /// [`Self::sample_lanes`] in AVX2 registers: the same operations in the same order,
    /// so the same bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) fn sample_m256(&self, p: [std::arch::x86_64::__m256; 3]) -> SamplesM256 {
        use std::arch::x86_64::*;
        let CornersM256 {
            stored,
            frac: [fx, fy, fz],
            c,
            clearance_m,
        } = self.corners_m256(p);
        let (add, sub, mul) = (_mm256_add_ps, _mm256_sub_ps, _mm256_mul_ps);
        let lerp = |a: __m256, b: __m256, f: __m256| add(a, mul(sub(b, a), f));
        let c00 = lerp(c[0], c[1], fx);
        let c10 = lerp(c[2], c[3], fx);
        let c01 = lerp(c[4], c[5], fx);
        let c11 = lerp(c[6], c[7], fx);
        let c0 = lerp(c00, c10, fy);
        let c1 = lerp(c01, c11, fy);
        let value = lerp(c0, c1, fz);
        let dx0 = lerp(sub(c[1], c[0]), sub(c[3], c[2]), fy);
        let dx1 = lerp(sub(c[5], c[4]), sub(c[7], c[6]), fy);
        let dx = lerp(dx0, dx1, fz);
        let dy = lerp(sub(c10, c00), sub(c11, c01), fz);
        let dz = sub(c1, c0);
        let scale = _mm256_set1_ps((self.h / Q) as f32);
        let per_unit = _mm256_set1_ps((1.0 / Q) as f32);
        SamplesM256 {
            stored: _mm256_castsi256_ps(stored),
            distance_m: mul(value, scale),
            gradient: [mul(dx, per_unit), mul(dy, per_unit), mul(dz, per_unit)],
            clearance_m,
        }
    }

    /// Lower bound of the distance from `p` to the surface when `p` is outside, 0 when it
    /// is within the stored layers or inside (m).
    #[inline]
    pub fn clearance(&self, p: &Vector3<f64>) -> f64 {
        match self.sample(p) {
            Sample::Far { clearance_m } => clearance_m,
            Sample::Near { distance_m, .. } => distance_m.max(0.0),
            Sample::Deep => 0.0,
        }
    }
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
    use super::*;

    fn slab() -> Vec<(Pose, SharedShape)> {
        // A 200 × 200 × 20 mm slab whose top face is z = 0.
        vec![(
            Pose::translation(0.0, 0.0, -0.01),
            SharedShape::cuboid(0.1, 0.1, 0.01),
        )]
    }

    #[test]
    fn distance_and_normal_of_a_flat_face() {
        let v = Voxmap::build(&slab(), &VoxmapConfig::default()).unwrap();
        for z_mm in [-6.5, -2.0, -0.3, 0.0, 0.7, 2.5] {
            let p = Vector3::new(0.0123, -0.0371, z_mm * 1e-3);
            match v.sample(&p) {
                Sample::Near {
                    distance_m,
                    gradient,
                } => {
                    assert!(
                        (distance_m - z_mm * 1e-3).abs() < 1e-5,
                        "z {z_mm} mm: {distance_m}"
                    );
                    assert!((gradient - Vector3::z()).norm() < 1e-3, "{gradient:?}");
                }
                other => panic!("z {z_mm} mm: {other:?}"),
            }
        }
        // Above the layers: far, with a clearance that never overstates the distance.
        for z_mm in [5.0, 12.0, 40.0, 300.0] {
            let p = Vector3::new(0.0, 0.0, z_mm * 1e-3);
            let c = v.clearance(&p);
            assert!(c <= z_mm * 1e-3 + 1e-12, "z {z_mm} mm: clearance {c}");
            assert!(c >= 0.002, "z {z_mm} mm: clearance {c}");
        }
    }

    /// Points around and inside a slab and a solid cube (stored, outside, deep-inside and
    /// off-grid cells), a few of them NaN.
    fn lane_chunks(v: &Voxmap, seed: u64) -> Vec<[Lanes; 3]> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let (lo, cells) = (v.origin, v.cells_f);
        let mut chunk = || {
            let mut p = [[0.0; LANES]; 3];
            for (a, axis) in p.iter_mut().enumerate() {
                for x in axis.iter_mut() {
                    let span = cells[a] * v.h;
                    *x = if rng.random_bool(0.01) {
                        f32::NAN
                    } else {
                        (lo[a] + rng.random_range(-0.1..1.1) * span) as f32
                    };
                }
            }
            p
        };
        (0..500).map(|_| chunk()).collect()
    }

    #[test]
    fn the_lane_look_up_agrees_with_the_point_look_up() {
        let cube = vec![(Pose::IDENTITY, SharedShape::cuboid(0.05, 0.05, 0.05))];
        for scene in [slab(), cube] {
            let v = Voxmap::build(&scene, &VoxmapConfig::default()).unwrap();
            let (mut near, mut far) = (0, 0);
            for p in lane_chunks(&v, 3) {
                let s = v.sample_lanes(&p);
                for l in 0..LANES {
                    let q = Vector3::new(p[0][l], p[1][l], p[2][l]).map(f64::from);
                    match v.sample(&q) {
                        Sample::Near {
                            distance_m,
                            gradient,
                        } => {
                            near += 1;
                            assert_eq!(s.stored[l], -1, "{q:?}");
                            // f32 positions: 0.1 µm; the gradient's f32 rounding.
                            assert!((f64::from(s.distance_m[l]) - distance_m).abs() < 1e-6);
                            let g = Vector3::from(s.gradient.map(|g| g[l])).map(f64::from);
                            assert!((g - gradient).norm() < 1e-3, "{g:?} vs {gradient:?}");
                        }
                        Sample::Far { clearance_m } if q.iter().all(|x| x.is_finite()) => {
                            far += 1;
                            assert_eq!(s.stored[l], 0);
                            // Off the grid the lanes know nothing (0); on it, the same bound.
                            let c = f64::from(s.clearance_m[l]);
                            assert!(
                                c == 0.0 || (c - clearance_m).abs() < 1e-6,
                                "{c} vs {clearance_m}"
                            );
                        }
                        _ => assert_eq!((s.stored[l], s.clearance_m[l]), (0, 0.0), "{q:?}"),
                    }
                }
            }
            assert!(near > 100 && far > 100, "{near} near, {far} far");
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_look_up_and_interpolation_give_the_same_bits() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("no AVX2 on this CPU: nothing to compare");
            return;
        }
        let cube = vec![(Pose::IDENTITY, SharedShape::cuboid(0.05, 0.05, 0.05))];
        for scene in [slab(), cube] {
            let v = Voxmap::build(&scene, &VoxmapConfig::default()).unwrap();
            for p in lane_chunks(&v, 4) {
                let plain = v.corners(&p);
                // SAFETY: the CPU has AVX2, checked above.
                let gathered = unsafe { v.corners_avx2(&p) };
                let bits = |k: &LaneCorners| {
                    let f = |x: &Lanes| x.map(f32::to_bits);
                    (
                        k.stored,
                        k.frac.map(|x| f(&x)),
                        k.c.map(|x| f(&x)),
                        f(&k.clearance_m),
                    )
                };
                assert_eq!(bits(&plain), bits(&gathered), "{p:?}");
                // And the interpolation after it.
                let s = v.sample_lanes(&p);
                // SAFETY: as above; every array holds LANES f32.
                let fast = unsafe {
                    use std::arch::x86_64::*;
                    let f = v.sample_m256(axes(|a| _mm256_loadu_ps(p[a].as_ptr())));
                    let out = |x: __m256| {
                        let mut o = [0.0f32; LANES];
                        _mm256_storeu_ps(o.as_mut_ptr(), x);
                        o.map(f32::to_bits)
                    };
                    (
                        out(f.stored).map(|b| b as i32),
                        out(f.distance_m),
                        f.gradient.map(out),
                        out(f.clearance_m),
                    )
                };
                let f = |x: &Lanes| x.map(f32::to_bits);
                let plain = (
                    s.stored,
                    f(&s.distance_m),
                    s.gradient.each_ref().map(f),
                    f(&s.clearance_m),
                );
                assert_eq!(plain, fast, "{p:?}");
            }
        }
    }

    #[test]
    fn interpolation_is_continuous_across_blocks() {
        let v = Voxmap::build(&slab(), &VoxmapConfig::default()).unwrap();
        // March across several block boundaries at a fixed height above an edge region.
        let mut last = None;
        for i in 0..2000 {
            let p = Vector3::new(0.095 + i as f64 * 5e-6, 0.0, 0.001);
            if let Sample::Near { distance_m, .. } = v.sample(&p) {
                if let Some(prev) = last {
                    let jump: f64 = distance_m - prev;
                    assert!(jump.abs() < 1e-5, "jump {jump} at x {}", p.x);
                }
                last = Some(distance_m);
            }
        }
        assert!(last.is_some());
    }

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
    fn empty_scene_is_far_everywhere() {
        let v = Voxmap::build(&[], &VoxmapConfig::default()).unwrap();
        assert!(matches!(
            v.sample(&Vector3::new(0.3, 0.0, 0.0)),
            Sample::Far { .. }
        ));
    }
}
