//! Steps 2 and 3 of the search ([`ShellColumns::chunks`]) in AVX2 registers.
//!
//! The lane-by-lane code is the reference: this is the same arithmetic, operation for
//! operation and in the same order, so it gives the same bits (tested). What differs is
//! only how it reaches the machine: the columns, the block index and the voxmap's nodes are
//! loaded with gathers, and every value lives in a `__m256` instead of an `[f32; 8]` that
//! the compiler kept in memory (three instructions per operation, measured with callgrind).

use super::{AWAY_COS, Accumulators, Chunks, ShellColumns};
use crate::contact::lanes::LANES;
use crate::contact::voxmap::Voxmap;
use std::arch::x86_64::*;

/// The force pass's running sums in registers.
type Sums = super::Sums<__m256>;

/// [`ShellColumns::chunks`] in AVX2.
///
/// # Safety
///
/// The CPU has AVX2. (The candidates index the shell's points: `ShellColumns::new`
/// checks that its clusters do.)
#[target_feature(enable = "avx2")]
pub(super) fn chunks(
    shell: &ShellColumns,
    c: &Chunks,
    point_budgets: &mut [f64],
    vox: &Voxmap,
) -> (Accumulators, u32) {
    let k = c.search;
    let moved = k.moved_m;
    // The budget stores below go unchecked: candidates index the shell's points.
    assert_eq!(
        point_budgets.len(),
        shell.point[0].len(),
        "one budget per point"
    );
    let set = _mm256_set1_ps;
    let (add, sub, mul) = (_mm256_add_ps, _mm256_sub_ps, _mm256_mul_ps);
    let zero = _mm256_setzero_ps();
    let r: [[__m256; 3]; 3] =
        std::array::from_fn(|a| std::array::from_fn(|b| set(k.rotation[(a, b)] as f32)));
    let t: [__m256; 3] = std::array::from_fn(|a| set(k.translation[a] as f32));
    let com: [__m256; 3] = std::array::from_fn(|a| set(c.com[a]));
    let reach = set(k.reach_m as f32);
    let lane_index = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let mut sums = Sums::splat(zero);
    let mut kept = 0;
    for (chunk, idx) in c.candidates.chunks_exact(LANES).enumerate() {
        // SAFETY: `idx` holds LANES u32, each indexing the shell's columns (see above).
        let (x, nl) = unsafe {
            let offsets = _mm256_loadu_si256(idx.as_ptr().cast());
            let column = |col: &[f32]| _mm256_i32gather_ps::<4>(col.as_ptr(), offsets);
            (
                [
                    column(&shell.point[0]),
                    column(&shell.point[1]),
                    column(&shell.point[2]),
                ],
                [
                    column(&shell.normal[0]),
                    column(&shell.normal[1]),
                    column(&shell.normal[2]),
                ],
            )
        };
        let rotate = |v: &[__m256; 3], a: usize| {
            add(
                add(mul(r[a][0], v[0]), mul(r[a][1], v[1])),
                mul(r[a][2], v[2]),
            )
        };
        let p = [0, 1, 2].map(|a| add(rotate(&x, a), t[a]));
        let n = [0, 1, 2].map(|a| rotate(&nl, a));
        let s = vox.sample_m256(p);
        let g = s.gradient;
        let dot = |u: &[__m256; 3], v: &[__m256; 3]| {
            add(add(mul(u[0], v[0]), mul(u[1], v[1])), mul(u[2], v[2]))
        };
        let g2 = dot(&g, &g);
        let facing = dot(&n, &g);
        let real = _mm256_castsi256_ps(_mm256_cmpgt_epi32(
            _mm256_set1_epi32((c.count - chunk * LANES).min(LANES) as i32),
            lane_index,
        ));
        let and = _mm256_and_ps;
        let keep = and(
            and(
                and(s.stored, _mm256_cmp_ps::<_CMP_LT_OQ>(s.distance_m, reach)),
                and(
                    _mm256_cmp_ps::<_CMP_GE_OQ>(g2, set(1e-18)),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(
                        add(facing, mul(set(AWAY_COS), _mm256_sqrt_ps(g2))),
                        zero,
                    ),
                ),
            ),
            real,
        );
        // SAFETY: as the columns' gathers above; the staggers have one entry per point.
        let stagger = unsafe {
            let offsets = _mm256_loadu_si256(idx.as_ptr().cast());
            _mm256_i32gather_ps::<4>(shell.stagger.as_ptr(), offsets)
        };
        let ahead = mul(
            _mm256_blendv_ps(
                sub(s.clearance_m, reach),
                sub(s.distance_m, reach),
                s.stored,
            ),
            stagger,
        );
        // moved + ahead in f64, then stored lane by lane (AVX2 has no scatter).
        let mut budget = [0.0f64; LANES];
        // SAFETY: `budget` holds LANES f64; every index is a point's (checked above).
        unsafe {
            let moved = _mm256_set1_pd(moved);
            let low = _mm256_cvtps_pd(_mm256_castps256_ps128(ahead));
            let high = _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(ahead));
            _mm256_storeu_pd(budget.as_mut_ptr(), _mm256_add_pd(moved, low));
            _mm256_storeu_pd(budget.as_mut_ptr().add(4), _mm256_add_pd(moved, high));
            for l in 0..LANES {
                *point_budgets.get_unchecked_mut(idx[l] as usize) = budget[l];
            }
        }
        let mask = _mm256_movemask_ps(keep);
        if mask != 0 {
            kept += mask.count_ones();
            // Lanes not kept: beyond every layer with a unit gradient (see `chunks`).
            let rel = [0, 1, 2].map(|a| and(keep, sub(p[a], com[a])));
            let unit = [set(1.0), zero, zero];
            let g = [0, 1, 2].map(|a| _mm256_blendv_ps(unit[a], g[a], keep));
            let sd = _mm256_blendv_ps(set(f32::INFINITY), s.distance_m, keep);
            // SAFETY: as the columns' gathers above; the weights have one entry per point.
            let wt = unsafe {
                let offsets = _mm256_loadu_si256(idx.as_ptr().cast());
                _mm256_i32gather_ps::<4>(c.weight.as_ptr(), offsets)
            };
            force_chunk(&mut sums, &rel, &g, sd, wt, &c.force);
        }
    }
    (unload(&sums), kept)
}

/// [`super::force_chunk`] in registers.
#[target_feature(enable = "avx2")]
#[inline]
fn force_chunk(
    acc: &mut Sums,
    r: &[__m256; 3],
    g: &[__m256; 3],
    sd: __m256,
    wt: __m256,
    k: &super::ForceConsts,
) {
    let set = _mm256_set1_ps;
    let (add, sub, mul) = (_mm256_add_ps, _mm256_sub_ps, _mm256_mul_ps);
    let zero = _mm256_setzero_ps();
    let one = set(1.0);
    let [gx, gy, gz] = *g;
    let inv = _mm256_div_ps(
        one,
        _mm256_sqrt_ps(add(add(mul(gx, gx), mul(gy, gy)), mul(gz, gz))),
    );
    let n = [mul(gx, inv), mul(gy, inv), mul(gz, inv)];
    let m = [
        sub(mul(r[1], n[2]), mul(r[2], n[1])),
        sub(mul(r[2], n[0]), mul(r[0], n[2])),
        sub(mul(r[0], n[1]), mul(r[1], n[0])),
    ];
    let (v, w) = (k.v, k.w);
    let vn = add(
        add(
            add(
                add(
                    add(mul(set(v.x), n[0]), mul(set(v.y), n[1])),
                    mul(set(v.z), n[2]),
                ),
                mul(set(w.x), m[0]),
            ),
            mul(set(w.y), m[1]),
        ),
        mul(set(w.z), m[2]),
    );
    let penetrating = _mm256_cmp_ps::<_CMP_LT_OQ>(sd, zero);
    let in_contact = _mm256_and_ps(penetrating, wt);
    // -sd exactly: the sign bit flipped.
    let depth = _mm256_and_ps(penetrating, _mm256_xor_ps(sd, set(-0.0)));
    let weighted_depth = mul(in_contact, depth);
    let push = mul(
        in_contact,
        _mm256_max_ps(sub(mul(set(k.kp), depth), mul(set(k.bc), vn)), zero),
    );
    let braking = _mm256_and_ps(
        _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GE_OQ>(sd, zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(sd, set(k.prox)),
        ),
        _mm256_cmp_ps::<_CMP_LT_OQ>(vn, zero),
    );
    let brake_w = _mm256_and_ps(braking, mul(wt, sub(one, _mm256_div_ps(sd, set(k.prox)))));
    let f = sub(push, mul(mul(set(k.bb), brake_w), vn));
    let j = [n[0], n[1], n[2], m[0], m[1], m[2]];
    for (s, ja) in acc.wrench.iter_mut().zip(&j) {
        *s = add(*s, mul(f, *ja));
    }
    // Σ w JJᵀ, pair by pair (see `jj_pairs`).
    macro_rules! jj {
        ($sum:expr, $w:expr; $($i:literal: $a:literal $b:literal),*) => {$(
            $sum[$i] = add($sum[$i], mul($w, mul(j[$a], j[$b])));
        )*};
    }
    jj_pairs!(jj!(acc.k, in_contact));
    // In steady contact most chunks brake nowhere: skip their zero braking sums.
    let brakes = _mm256_cmp_ps::<_CMP_GT_OQ>(brake_w, zero);
    if _mm256_movemask_ps(brakes) != 0 {
        jj_pairs!(jj!(acc.b, brake_w));
    }
    for a in 0..3 {
        acc.point[a] = add(
            acc.point[a],
            mul(weighted_depth, add(r[a], mul(depth, n[a]))),
        );
        acc.normal[a] = add(acc.normal[a], mul(weighted_depth, n[a]));
    }
    acc.weight = add(acc.weight, weighted_depth);
    acc.max_depth = _mm256_max_ps(depth, acc.max_depth);
    acc.contacts = add(acc.contacts, in_contact);
    acc.braking = add(acc.braking, _mm256_and_ps(brakes, wt));
    let releasing = _mm256_cmp_ps::<_CMP_LT_OQ>(sd, set(k.release));
    acc.release = add(acc.release, _mm256_and_ps(releasing, one));
}

/// The sums as [`Accumulators`], for the shared reduction.
#[target_feature(enable = "avx2")]
fn unload(s: &Sums) -> Accumulators {
    s.map(|v| {
        let mut x = [0.0; LANES];
        // SAFETY: `x` holds LANES f32.
        unsafe { _mm256_storeu_ps(x.as_mut_ptr(), *v) };
        x
    })
}
