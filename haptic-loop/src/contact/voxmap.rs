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
//! A Chebyshev distance transform over the block index gives every point in an outside
//! block a lower bound on its clearance (the empty blocks around it plus its distance to its
//! own block's faces), so whole pointshell clusters far from the scene are rejected with
//! one look-up.
//!
//! Signed distances come from parry (`project_point`, non-solid) against every obstacle shape,
//! so boxes, spheres and triangle meshes (oriented, for the inside test) are voxelised by the
//! same code. The union of obstacles takes the minimum of their signed distances: exact
//! outside, and inside it never understates a depth.
//!
//! The code is split by idea: `build` voxelises the scene (the distance fill, the block
//! classification and the Chebyshev block-distance transform); `query` holds the look-ups
//! of the real-time path, one point or [`LANES`](crate::contact::lanes::LANES) lanes at a
//! time; `avx2` is the lane look-up again with AVX2 gathers. This file holds the types and
//! the storage layout they share.

use nalgebra::Vector3;
use std::time::Duration;

#[cfg(target_arch = "x86_64")]
mod avx2;
mod band;
mod build;
pub mod cache;
mod query;

pub use build::{Obstacle, Surface};

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
    /// Thickness of the band an open mesh obstacle (a panel, a sheet) is rendered as,
    /// centred on its surface, in voxels (> 0): the object is kept out of it from either
    /// side. Two voxels keep a point that entered half a voxel deep (the most one step
    /// carries it, see `ContactConfig::max_travel_voxels`) on its own side.
    pub shell_voxels: f64,
}

impl Default for VoxmapConfig {
    fn default() -> Self {
        Self {
            voxel_m: 0.001,
            layers_out: 4,
            layers_in: 8,
            shell_voxels: 2.0,
        }
    }
}

/// Why a voxmap could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum VoxmapError {
    /// A parameter is out of its range.
    #[error("voxmap: {name} must be {need}, got {value}")]
    Parameter {
        /// The parameter, e.g. `voxel size`.
        name: &'static str,
        /// The range it must be in, e.g. `a positive number of metres`.
        need: &'static str,
        /// The value given.
        value: f64,
    },
    /// The stored distance layers are out of range (both named: they are checked together).
    #[error(
        "voxmap: layers_out and layers_in must be in 1..=100, got {layers_out} and {layers_in}"
    )]
    Layers {
        /// Distance layers outside asked for, voxels.
        layers_out: u32,
        /// Distance layers inside asked for, voxels.
        layers_in: u32,
    },
    /// The build was stopped (its progress's cancel flag was set).
    #[error("voxmap: build stopped")]
    Cancelled,
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
    /// Largest working memory of one mesh's narrow band, bytes (0 without meshes).
    pub peak_band_bytes: usize,
    /// When read from the cache instead of built: how long that took.
    pub loaded_in: Option<Duration>,
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
        )?;
        if let Some(t) = self.loaded_in {
            write!(f, " (loaded from the cache in {:.2} s)", t.as_secs_f64())?;
        }
        Ok(())
    }
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

impl Voxmap {
    /// A voxmap of its stored parts, built or read back, with what follows from them (the
    /// inverse voxel size, the grid's extent, the report's sizes) derived in one place. The
    /// report's times and band memory are zero: the caller says how the voxmap came about.
    fn from_parts(
        origin: Vector3<f64>,
        h: f64,
        blocks: [usize; 3],
        index: Vec<u32>,
        block_distance: Vec<u16>,
        data: Vec<i16>,
        layers_out: u32,
    ) -> Self {
        let cells = blocks.map(|b| b * B);
        let report = VoxmapReport {
            voxel_m: h,
            dims_voxels: cells,
            stored_blocks: data.len() / BLOCK_NODES,
            total_blocks: index.len(),
            memory_bytes: index.len() * 4 + block_distance.len() * 2 + data.len() * 2,
            dense_bytes: (cells[0] + 1) * (cells[1] + 1) * (cells[2] + 1) * 2,
            build_time: Duration::ZERO,
            peak_band_bytes: 0,
            loaded_in: None,
        };
        Self {
            origin,
            h,
            inv_h: 1.0 / h,
            cells_f: cells.map(|c| c as f64),
            blocks,
            index,
            block_distance,
            data,
            layers_out,
            report,
        }
    }

    /// Build facts: size, memory, time.
    pub fn report(&self) -> &VoxmapReport {
        &self.report
    }

    /// Voxel size, m.
    pub fn voxel_m(&self) -> f64 {
        self.h
    }

    /// Lower bound on the clearance of a point outside the grid's box, `d` (m) from it.
    fn off_grid_clearance(&self, d: f64) -> f64 {
        d + (f64::from(self.layers_out) - 1.0) * self.h
    }

    /// Lower bound on the clearance of a point in an outside block that lies `blocks_away`
    /// blocks (Chebyshev) from the nearest block that is not outside, `edge_cells` cells
    /// from its own block's nearest face. No surface point lies in an outside block (it
    /// would be within half a cell diagonal of one of the block's nodes, nearer than
    /// `layers_out` voxels), so none lies in the cube of outside blocks around the point's
    /// own, whose faces are `(blocks_away − 1)·B + edge_cells` cells away; past a face, a
    /// surface point is more than `layers_out − 1` voxels from it (the face's own block is
    /// outside). The bound moves with the point within its block, so the budgets of
    /// clusters checked together do not all come due together (issue 21).
    fn far_clearance(&self, blocks_away: f64, edge_cells: f64) -> f64 {
        let layers = f64::from(self.layers_out) - 1.0;
        ((blocks_away - 1.0) * B as f64 + edge_cells + layers) * self.h
    }

    /// Cells from `g` (a point's position in cells, each coordinate ≥ 0) to the nearest
    /// face of its block.
    fn edge_cells(g: [f64; 3]) -> f64 {
        g.iter()
            .map(|&x| {
                let local = x - (x / B as f64).floor() * B as f64;
                local.min(B as f64 - local)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// [`Self::edge_cells`] of a lane from its cell (`cell`, in the grid) and its position
    /// in that cell (`frac`), in `f32` as both lane look-ups compute it (same bits).
    fn lane_edge_cells(cell: [i32; 3], frac: [f32; 3]) -> f64 {
        let edge = (0..3)
            .map(|a| {
                let local = (cell[a] & (B as i32 - 1)) as f32 + frac[a];
                local.min(B as f32 - local)
            })
            .fold(f32::INFINITY, f32::min);
        f64::from(edge)
    }
}

/// Scenes and query points shared by the tests of `build`, `query` and `avx2`.
#[cfg(test)]
mod fixtures {
    use super::Voxmap;
    use crate::contact::lanes::{LANES, Lanes};
    use parry3d_f64::math::Pose;
    use parry3d_f64::shape::SharedShape;

    pub(super) fn slab() -> Vec<(Pose, SharedShape)> {
        // A 200 × 200 × 20 mm slab whose top face is z = 0.
        vec![(
            Pose::translation(0.0, 0.0, -0.01),
            SharedShape::cuboid(0.1, 0.1, 0.01),
        )]
    }

    /// Points around and inside a slab and a solid cube (stored, outside, deep-inside and
    /// off-grid cells), a few of them NaN.
    pub(super) fn lane_chunks(v: &Voxmap, seed: u64) -> Vec<[Lanes; 3]> {
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
}
