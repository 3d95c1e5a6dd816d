//! The look-ups of the real-time path, run every tick: the field at one point
//! ([`Voxmap::sample`], [`Voxmap::clearance`]) and at [`LANES`] points lane by lane
//! ([`Voxmap::sample_lanes`], the reference the AVX2 look-up in `avx2` matches bit for
//! bit). Neither allocates nor locks.

use super::{B, BLOCK_NODES, FIRST, INSIDE, N, OUTSIDE, PAIR_OFFSETS, Q, Sample, Voxmap};
use crate::contact::lanes::{LANES, Lanes, axes, lanes};
use nalgebra::Vector3;

/// [`Voxmap::sample_lanes`]' answer: per lane, the field where the point lies within the
/// stored layers (`stored`); distance and gradient are zero elsewhere.
#[derive(Debug, Clone, Copy)]
pub(in crate::contact) struct LaneSamples {
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
pub(super) struct LaneCorners {
    pub stored: [i32; LANES],
    pub frac: [Lanes; 3],
    pub c: [Lanes; 8],
    pub clearance_m: Lanes,
}

impl Voxmap {
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
                clearance_m: self.off_grid_clearance(d),
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
                clearance_m: self.far_clearance(
                    f64::from(self.block_distance[b]),
                    Self::edge_cells([g.x, g.y, g.z]),
                ),
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
    pub(in crate::contact) fn sample_lanes(&self, p: &[Lanes; 3]) -> LaneSamples {
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
    pub(super) fn corners(&self, p: &[Lanes; 3]) -> LaneCorners {
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
                let edge = Self::lane_edge_cells(
                    [cell[0][l], cell[1][l], cell[2][l]],
                    [frac[0][l], frac[1][l], frac[2][l]],
                );
                clearance_m[l] = self.far_clearance(f64::from(self.block_distance[b]), edge) as f32;
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

#[cfg(test)]
mod tests {
    use super::super::VoxmapConfig;
    use super::super::fixtures::{lane_chunks, slab};
    use super::*;
    use parry3d_f64::math::Pose;
    use parry3d_f64::shape::SharedShape;

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

    #[test]
    fn the_far_clearance_never_overstates_the_distance_and_moves_within_a_block() {
        use rand::{Rng, SeedableRng};
        // Exact distance to a box of half extents `he` centred at `c`.
        let exact = |p: &Vector3<f64>, c: Vector3<f64>, he: Vector3<f64>| {
            (p - c).abs().zip_map(&he, |d, h| (d - h).max(0.0)).norm()
        };
        let boxes = [
            (Vector3::new(0.0, 0.0, -0.01), Vector3::new(0.1, 0.1, 0.01)),
            (Vector3::zeros(), Vector3::new(0.05, 0.05, 0.05)),
        ];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
        for (c, he) in boxes {
            let scene = vec![(
                Pose::translation(c.x, c.y, c.z),
                SharedShape::cuboid(he.x, he.y, he.z),
            )];
            let v = Voxmap::build(&scene, &VoxmapConfig::default()).unwrap();
            // Far samples in blocks next to the surface's blocks, and how many of them get
            // more than the layers' bound (all the old bound gave them).
            let (mut far, mut next, mut next_beyond) = (0, 0, 0);
            let mut tightest = 0.0f64;
            for _ in 0..50_000 {
                let g: Vector3<f64> = Vector3::from_fn(|a, _| {
                    rng.random::<f64>() * v.cells_f[a] * 1.1 - 0.05 * v.cells_f[a]
                });
                let p = v.origin + g * v.h;
                let d = exact(&p, c, he);
                if let Sample::Far { clearance_m } = v.sample(&p) {
                    far += 1;
                    assert!(
                        clearance_m <= d + 1e-12,
                        "{p:?}: clearance {clearance_m} > {d}"
                    );
                    tightest = tightest.max(clearance_m / d);
                    let on_grid = (0..3).all(|a| g[a] >= 0.0 && g[a] < v.cells_f[a]);
                    if on_grid {
                        let [ix, iy, iz] = [0, 1, 2].map(|a| g[a] as usize / B);
                        let b = ix + v.blocks[0] * (iy + v.blocks[1] * iz);
                        if v.block_distance[b] == 1 {
                            next += 1;
                            next_beyond += usize::from(clearance_m > f64::from(v.layers_out) * v.h);
                        }
                    }
                }
                // The lanes give the same bound (f32 positions).
                let q = p.map(|x| x as f32);
                let s = v.sample_lanes(&std::array::from_fn(|a| [q[a]; LANES]));
                if s.stored[0] == 0 && s.clearance_m[0] > 0.0 {
                    assert!(f64::from(s.clearance_m[0]) <= d + 1e-6, "{p:?}");
                }
            }
            assert!(far > 10_000, "{far} far samples");
            assert!(
                next > 200 && next_beyond * 3 > next,
                "{next_beyond} of {next} next to the surface's blocks beyond the layers"
            );
            assert!(tightest > 0.5, "tightest bound / distance {tightest}");
        }
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
}
