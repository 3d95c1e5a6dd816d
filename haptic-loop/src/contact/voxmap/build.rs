//! Building the voxmap: the grid around the obstacles, the signed distances of the blocks
//! near their surface (sampled on every core), the block index, and the Chebyshev
//! distance transform over it that bounds the clearance of the empty blocks. Runs at
//! start-up, never on the real-time path.

use super::{
    B, BLOCK_NODES, FIRST, INSIDE, MAX_BYTES, N, OUTSIDE, Q, Voxmap, VoxmapConfig, VoxmapError,
    VoxmapReport,
};
use nalgebra::Vector3;
use parry3d_f64::bounding_volume::{Aabb, BoundingVolume};
use parry3d_f64::math::{Pose, Vector as PVec};
use parry3d_f64::shape::SharedShape;
use std::collections::VecDeque;
use std::time::Instant;

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
    fn empty_scene_is_far_everywhere() {
        let v = Voxmap::build(&[], &VoxmapConfig::default()).unwrap();
        assert!(matches!(
            v.sample(&Vector3::new(0.3, 0.0, 0.0)),
            Sample::Far { .. }
        ));
    }
}
