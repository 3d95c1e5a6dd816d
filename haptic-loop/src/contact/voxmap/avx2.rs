//! The lane look-up ([`Voxmap::sample_lanes`]) in AVX2 registers, for the contact search's
//! AVX2 path (`near::avx2`): the block index and the node pairs are loaded with gathers,
//! and the interpolation is the same operations in the same order as the lane-by-lane
//! code, so it gives the same bits (tested).

#[cfg(test)]
use super::query::LaneCorners;
use super::{B, BLOCK_NODES, FIRST, INSIDE, N, OUTSIDE, PAIR_OFFSETS, Q, Voxmap};
use crate::contact::lanes::LANES;
#[cfg(test)]
use crate::contact::lanes::{Lanes, axes};
use std::arch::x86_64::*;

/// [`LaneCorners`](super::query::LaneCorners) in AVX2 registers (`stored` all ones or zero
/// per lane).
#[derive(Clone, Copy)]
struct CornersM256 {
    stored: __m256i,
    frac: [__m256; 3],
    c: [__m256; 8],
    clearance_m: __m256,
}

/// [`LaneSamples`](super::query::LaneSamples) in AVX2 registers (`stored` a mask: all ones
/// or zero per lane).
#[derive(Clone, Copy)]
pub(in crate::contact) struct SamplesM256 {
    pub stored: __m256,
    pub distance_m: __m256,
    pub gradient: [__m256; 3],
    pub clearance_m: __m256,
}

impl Voxmap {
    /// [`Self::corners`] through [`Self::corners_m256`], for the test that compares them.
    #[cfg(test)]
    #[target_feature(enable = "avx2")]
    fn corners_avx2(&self, p: &[Lanes; 3]) -> LaneCorners {
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
    /// Every block and node index fits an `i32` ([`MAX_BYTES`](super::MAX_BYTES)); a pair
    /// read at a cell's node stays within its block (see [`Self::corners`]).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn corners_m256(&self, p: [__m256; 3]) -> CornersM256 {
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
            let mut cells = [[0i32; LANES]; 3];
            let mut fracs = [[0.0f32; LANES]; 3];
            let mut clearance = [0.0f32; LANES];
            // SAFETY: `blocks` and each of `cells` hold LANES i32, each of `fracs` LANES f32.
            unsafe {
                _mm256_storeu_si256(blocks.as_mut_ptr().cast(), b);
                for a in 0..3 {
                    _mm256_storeu_si256(cells[a].as_mut_ptr().cast(), cell[a]);
                    _mm256_storeu_ps(fracs[a].as_mut_ptr(), frac[a]);
                }
            }
            while far != 0 {
                let l = far.trailing_zeros() as usize;
                let distance = self.block_distance[blocks[l] as usize];
                let edge = Self::lane_edge_cells(
                    [cells[0][l], cells[1][l], cells[2][l]],
                    [fracs[0][l], fracs[1][l], fracs[2][l]],
                );
                clearance[l] = self.far_clearance(f64::from(distance), edge) as f32;
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
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in crate::contact) fn sample_m256(&self, p: [__m256; 3]) -> SamplesM256 {
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
}

#[cfg(test)]
mod tests {
    use super::super::VoxmapConfig;
    use super::super::fixtures::{lane_chunks, slab};
    use super::*;
    use parry3d_f64::math::Pose;
    use parry3d_f64::shape::SharedShape;

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
}
