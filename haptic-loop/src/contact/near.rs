//! The two passes of the contact search over the points that may be near the surface.
//!
//! 1. *Search*: the clusters and points whose motion budget is used up (see `Coherence`)
//!    are looked up in the voxmap [`LANES`] at a time ([`ShellColumns::search`]); those
//!    within reach of a surface they face are written column-wise into [`NearPoints`].
//! 2. *Force pass* ([`NearPoints::accumulate`]): penalty, braking and the implicit step's
//!    JᵀJ sums over them, without branches.
//!
//! Both are written lane by lane, each statement over all lanes and choices as selections,
//! so the compiler turns them into SIMD; they are compiled a second time for AVX2 and the
//! CPU's choice is made at run time. They compute in `f32` (twice the lanes of `f64`):
//! positions relative to the scene's origin or the centre of mass are below a metre, where
//! `f32` resolves 0.1 µm, far below the voxmap's 1/256-voxel quantisation; sums are
//! returned in `f64`.

use super::{Cluster, JtJ, Pointshell, Voxmap};
use nalgebra::{Matrix3, Vector3, Vector6};

/// Points processed together: eight `f32` fill an AVX2 register.
pub(super) const LANES: usize = 8;

/// One value per point of a chunk.
pub(super) type Lanes = [f32; LANES];

/// One value per lane. (A plain loop: `std::array::from_fn` is not always inlined, and
/// then nothing vectorises.)
#[inline(always)]
pub(super) fn lanes<T: Copy + Default>(f: impl Fn(usize) -> T) -> [T; LANES] {
    let mut out = [T::default(); LANES];
    for (l, o) in out.iter_mut().enumerate() {
        *o = f(l);
    }
    out
}

/// One value per axis.
#[inline(always)]
pub(super) fn axes<T>(f: impl Fn(usize) -> T) -> [T; 3] {
    [f(0), f(1), f(2)]
}

/// The upper triangle of a symmetric 6×6 matrix, in [`JtJ`]'s layout (the force pass
/// spells the same list out): `nn` (6), `mn` (9), `mm` (6), with J = [n; m] as indices 0..3
/// and 3..6.
#[cfg(test)]
const PAIRS: [(usize, usize); 21] = [
    (0, 0),
    (0, 1),
    (0, 2),
    (1, 1),
    (1, 2),
    (2, 2),
    (3, 0),
    (3, 1),
    (3, 2),
    (4, 0),
    (4, 1),
    (4, 2),
    (5, 0),
    (5, 1),
    (5, 2),
    (3, 3),
    (3, 4),
    (3, 5),
    (4, 4),
    (4, 5),
    (5, 5),
];

/// The pointshell as the search reads it: object-frame points (m) and inward normals as
/// `f32` columns, in the pointshell's order.
#[derive(Debug, Clone)]
pub(super) struct ShellColumns {
    point: [Vec<f32>; 3],
    normal: [Vec<f32>; 3],
}

/// Where the search runs.
#[derive(Debug, Clone, Copy)]
pub(super) struct SearchParams {
    /// Rotation of the object frame into the scene frame.
    pub rotation: Matrix3<f64>,
    /// Origin of the object frame in the scene frame, m.
    pub translation: Vector3<f64>,
    /// Centre of mass, scene frame, m: kept points are stored relative to it.
    pub com: Vector3<f64>,
    /// Points farther from the surface than this are not kept, m.
    pub reach_m: f64,
    /// The running motion total of the budgets (see `Coherence`), m.
    pub moved_m: f64,
}

/// Points within reach of the surface, found by one search: position relative to the
/// centre of mass (scene frame, m), the field's gradient there (not normalised) and the
/// signed distance (m). Holds room for every point of the shell, allocated once, so the
/// search never allocates; `candidates` is the search's own scratch.
#[derive(Debug, Clone, Default)]
pub(super) struct NearPoints {
    len: usize,
    r: [Vec<f32>; 3],
    g: [Vec<f32>; 3],
    sd: Vec<f32>,
    candidates: Vec<u32>,
}

impl ShellColumns {
    pub(super) fn new(shell: &Pointshell) -> Self {
        let column = |v: &[Vector3<f64>], a: usize| v.iter().map(|p| p[a] as f32).collect();
        Self {
            point: std::array::from_fn(|a| column(shell.points(), a)),
            normal: std::array::from_fn(|a| column(shell.normals(), a)),
        }
    }

    /// The search: each cluster whose budget in `cluster_budgets` is used up is checked
    /// against the voxmap's clearance and its budget renewed; the points of those that may
    /// be within reach whose own budget (`point_budgets`) is used up are looked up in the
    /// voxmap, their budgets renewed, and those within reach of a surface they face are
    /// written to `near` (cleared first). Returns the points looked up.
    pub(super) fn search(
        &self,
        clusters: &[Cluster],
        cluster_budgets: &mut [f64],
        point_budgets: &mut [f64],
        k: &SearchParams,
        vox: &Voxmap,
        near: &mut NearPoints,
    ) -> u32 {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe {
                self.search_avx2(clusters, cluster_budgets, point_budgets, k, vox, near)
            };
        }
        self.search_impl(clusters, cluster_budgets, point_budgets, k, vox, near)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn search_avx2(
        &self,
        clusters: &[Cluster],
        cluster_budgets: &mut [f64],
        point_budgets: &mut [f64],
        k: &SearchParams,
        vox: &Voxmap,
        near: &mut NearPoints,
    ) -> u32 {
        self.search_impl(clusters, cluster_budgets, point_budgets, k, vox, near)
    }

    #[inline(always)]
    fn search_impl(
        &self,
        clusters: &[Cluster],
        cluster_budgets: &mut [f64],
        point_budgets: &mut [f64],
        k: &SearchParams,
        vox: &Voxmap,
        near: &mut NearPoints,
    ) -> u32 {
        let moved = k.moved_m;
        // Candidates: points of clusters that may be in reach, whose budget is used up.
        let mut count = 0;
        for (cl, budget) in clusters.iter().zip(cluster_budgets.iter_mut()) {
            if moved < *budget {
                continue;
            }
            let centre = k.rotation * cl.centre + k.translation;
            let slack = vox.clearance(&centre) - cl.radius_m - k.reach_m;
            *budget = moved + slack;
            if slack > 0.0 {
                continue;
            }
            for i in cl.start..cl.end {
                if moved >= point_budgets[i as usize] {
                    near.candidates[count] = i;
                    count += 1;
                }
            }
        }
        // Pad the last chunk with copies of a real candidate, ignored below.
        let padded = count.div_ceil(LANES) * LANES;
        let filler = near.candidates.first().copied().unwrap_or(0);
        near.candidates[count..padded].fill(filler);

        near.len = 0;
        let r = k.rotation.map(|x| x as f32);
        let t = k.translation.map(|x| x as f32);
        let com = k.com.map(|x| x as f32);
        let reach = k.reach_m as f32;
        for start in (0..padded).step_by(LANES) {
            let idx: [usize; LANES] = lanes(|l| near.candidates[start + l] as usize);
            let x: [Lanes; 3] = axes(|a| lanes(|l| self.point[a][idx[l]]));
            let nl: [Lanes; 3] = axes(|a| lanes(|l| self.normal[a][idx[l]]));
            let rotate = |v: &[Lanes; 3], a: usize| {
                lanes(|l| r[(a, 0)] * v[0][l] + r[(a, 1)] * v[1][l] + r[(a, 2)] * v[2][l])
            };
            let p: [Lanes; 3] = axes(|a| {
                let rx = rotate(&x, a);
                lanes(|l| rx[l] + t[a])
            });
            let n: [Lanes; 3] = axes(|a| rotate(&nl, a));
            let s = vox.sample_lanes(&p);
            let g = &s.gradient;
            let g2 = lanes(|l| g[0][l] * g[0][l] + g[1][l] * g[1][l] + g[2][l] * g[2][l]);
            let facing = lanes(|l| n[0][l] * g[0][l] + n[1][l] * g[1][l] + n[2][l] * g[2][l]);
            for l in 0..LANES.min(count - start) {
                // The budget: the distance the point can move before it may be in reach.
                let (ahead, keep) = if s.stored[l] {
                    let sd = s.distance_m[l];
                    // Within reach; a direction (the field is flat midway inside a thin
                    // plate); facing the surface (see the module docs of `contact`).
                    (sd - reach, sd < reach && g2[l] >= 1e-18 && facing[l] >= 0.0)
                } else {
                    (s.clearance_m[l] - reach, false)
                };
                point_budgets[idx[l]] = moved + f64::from(ahead);
                if keep {
                    let i = near.len;
                    for a in 0..3 {
                        near.r[a][i] = p[a][l] - com[a];
                        near.g[a][i] = g[a][l];
                    }
                    near.sd[i] = s.distance_m[l];
                    near.len = i + 1;
                }
            }
        }
        count as u32
    }
}

/// What the force pass needs besides the points.
#[derive(Debug, Clone, Copy)]
pub(super) struct PassParams {
    /// Centre of mass, scene frame, m.
    pub com: Vector3<f64>,
    /// Velocity of the centre of mass, m/s.
    pub velocity: Vector3<f64>,
    /// Angular velocity, rad/s.
    pub angular_velocity: Vector3<f64>,
    /// Penalty stiffness per point, N/m.
    pub point_stiffness_n_per_m: f64,
    /// Contact damping per penetrating point, N·s/m.
    pub contact_damping_n_s_per_m: f64,
    /// Braking per approaching point at full weight, N·s/m.
    pub braking_n_s_per_m: f64,
    /// Thickness of the proximity layer, m.
    pub proximity_m: f64,
    /// Release distance of the contact flag, m.
    pub release_m: f64,
}

/// The sums of one force pass.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub(super) struct Totals {
    /// Generalised force about the centre of mass: [force; torque] (N; N·m).
    pub wrench: Vector6<f64>,
    /// Σ JJᵀ over penetrating points: the contact stiffness is `k_p` times it.
    pub contact_jj: JtJ,
    /// Σ b JJᵀ over penetrating (contact damping) and approaching (braking) points: the
    /// contact damping matrix, N·s/m.
    pub damping_jj: JtJ,
    pub contacts: u32,
    pub braking_points: u32,
    pub within_release: bool,
    /// Σ d·(surface point), m², with d the depth.
    pub weighted_point: Vector3<f64>,
    /// Σ d, m.
    pub weight: f64,
    /// Σ d·n.
    pub normal_sum: Vector3<f64>,
    /// Deepest penetration, m.
    pub max_depth: f64,
}

/// Per-lane running sums of the force pass.
#[derive(Clone, Copy)]
struct Accumulators {
    wrench: [Lanes; 6],
    /// Σ JJᵀ over penetrating points.
    k: [Lanes; 21],
    /// Σ w JJᵀ over braking points, w the braking weight.
    b: [Lanes; 21],
    point: [Lanes; 3],
    normal: [Lanes; 3],
    weight: Lanes,
    max_depth: Lanes,
    contacts: Lanes,
    braking: Lanes,
    release: Lanes,
}

impl NearPoints {
    /// Room for `points` points.
    pub(super) fn with_capacity(points: usize) -> Self {
        let padded = points.div_ceil(LANES) * LANES;
        let column = || vec![0.0; padded];
        Self {
            len: 0,
            r: std::array::from_fn(|_| column()),
            g: std::array::from_fn(|_| column()),
            sd: column(),
            candidates: vec![0; padded],
        }
    }

    /// Points found by the last search.
    pub(super) fn len(&self) -> usize {
        self.len
    }

    /// Adds a point at `r` from the centre of mass (for tests of the force pass).
    #[cfg(test)]
    fn push(&mut self, r: &Vector3<f64>, gradient: &Vector3<f64>, sd: f64) {
        let i = self.len;
        for a in 0..3 {
            self.r[a][i] = r[a] as f32;
            self.g[a][i] = gradient[a] as f32;
        }
        self.sd[i] = sd as f32;
        self.len = i + 1;
    }

    /// The force pass over the points of the last search.
    pub(super) fn accumulate(&mut self, k: &PassParams) -> Totals {
        // Fill the last partial chunk with points that contribute nothing: beyond every
        // layer (all selections below are false), with a finite unit gradient.
        let end = self.len.div_ceil(LANES) * LANES;
        for i in self.len..end {
            for a in 0..3 {
                self.r[a][i] = 0.0;
                self.g[a][i] = if a == 0 { 1.0 } else { 0.0 };
            }
            self.sd[i] = f32::INFINITY;
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { self.accumulate_avx2(k, end) };
        }
        self.accumulate_lanes(k, end)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn accumulate_avx2(&self, k: &PassParams, end: usize) -> Totals {
        self.accumulate_lanes(k, end)
    }

    /// The pass proper, over `0..end` (a multiple of [`LANES`]). Every statement works on
    /// all lanes, and choices are selections, so the loop body has no branches.
    #[inline(always)]
    fn accumulate_lanes(&self, k: &PassParams, end: usize) -> Totals {
        let zero = [0.0; LANES];
        let mut acc = Accumulators {
            wrench: [zero; 6],
            k: [zero; 21],
            b: [zero; 21],
            point: [zero; 3],
            normal: [zero; 3],
            weight: zero,
            max_depth: zero,
            contacts: zero,
            braking: zero,
            release: zero,
        };
        let (kp, bc, bb) = (
            k.point_stiffness_n_per_m as f32,
            k.contact_damping_n_s_per_m as f32,
            k.braking_n_s_per_m as f32,
        );
        let (prox, release) = (k.proximity_m as f32, k.release_m as f32);
        let v = k.velocity.map(|x| x as f32);
        let w = k.angular_velocity.map(|x| x as f32);
        for o in (0..end).step_by(LANES) {
            let col = |c: &Vec<f32>| -> Lanes { c[o..o + LANES].try_into().expect("LANES long") };
            let r = [col(&self.r[0]), col(&self.r[1]), col(&self.r[2])];
            let (gx, gy, gz) = (col(&self.g[0]), col(&self.g[1]), col(&self.g[2]));
            let sd = col(&self.sd);
            let inv = lanes(|l| 1.0 / (gx[l] * gx[l] + gy[l] * gy[l] + gz[l] * gz[l]).sqrt());
            let n = [
                lanes(|l| gx[l] * inv[l]),
                lanes(|l| gy[l] * inv[l]),
                lanes(|l| gz[l] * inv[l]),
            ];
            // m = r × n: the moment arm of a unit force along n.
            let m = [
                lanes(|l| r[1][l] * n[2][l] - r[2][l] * n[1][l]),
                lanes(|l| r[2][l] * n[0][l] - r[0][l] * n[2][l]),
                lanes(|l| r[0][l] * n[1][l] - r[1][l] * n[0][l]),
            ];
            // Normal velocity of the point: v·n + (ω × r)·n = v·n + ω·(r × n).
            let vn = lanes(|l| {
                v.x * n[0][l]
                    + v.y * n[1][l]
                    + v.z * n[2][l]
                    + w.x * m[0][l]
                    + w.y * m[1][l]
                    + w.z * m[2][l]
            });
            let in_contact = lanes(|l| if sd[l] < 0.0 { 1.0 } else { 0.0 });
            let depth = lanes(|l| if sd[l] < 0.0 { -sd[l] } else { 0.0 });
            // Damping never pulls the point into the surface. (The implicit step keeps its
            // damping term also for a clamped point: numerical damping.)
            let push = lanes(|l| in_contact[l] * (kp * depth[l] - bc * vn[l]).max(0.0));
            // Pre-contact braking: opposes approach only, fading in over the layer.
            let brake_w = lanes(|l| {
                if sd[l] >= 0.0 && sd[l] < prox && vn[l] < 0.0 {
                    1.0 - sd[l] / prox
                } else {
                    0.0
                }
            });
            let f = lanes(|l| push[l] - bb * brake_w[l] * vn[l]);
            let j = [n[0], n[1], n[2], m[0], m[1], m[2]];
            for (a, ja) in j.iter().enumerate() {
                for l in 0..LANES {
                    acc.wrench[a][l] += f[l] * ja[l];
                }
            }
            // Σ w JJᵀ, spelled out pair by pair (constant indices) so that every product
            // stays in registers; a loop over `PAIRS` is left rolled and indexes memory.
            macro_rules! jj {
                ($sum:expr, $w:expr) => {
                    jj!($sum, $w; 0: 0 0, 1: 0 1, 2: 0 2, 3: 1 1, 4: 1 2, 5: 2 2,
                        6: 3 0, 7: 3 1, 8: 3 2, 9: 4 0, 10: 4 1, 11: 4 2,
                        12: 5 0, 13: 5 1, 14: 5 2,
                        15: 3 3, 16: 3 4, 17: 3 5, 18: 4 4, 19: 4 5, 20: 5 5)
                };
                ($sum:expr, $w:expr; $($i:literal: $a:literal $b:literal),*) => {$(
                    for l in 0..LANES {
                        $sum[$i][l] += $w[l] * (j[$a][l] * j[$b][l]);
                    }
                )*};
            }
            jj!(acc.k, in_contact);
            // In steady contact most chunks brake nowhere: skip their zero braking sums.
            if brake_w.iter().any(|&b| b > 0.0) {
                jj!(acc.b, brake_w);
            }
            for a in 0..3 {
                for l in 0..LANES {
                    // The point projected on the surface (relative to the centre of mass),
                    // weighted by depth.
                    acc.point[a][l] += depth[l] * (r[a][l] + depth[l] * n[a][l]);
                    acc.normal[a][l] += depth[l] * n[a][l];
                }
            }
            for l in 0..LANES {
                acc.weight[l] += depth[l];
                acc.max_depth[l] = acc.max_depth[l].max(depth[l]);
                acc.contacts[l] += in_contact[l];
                acc.braking[l] += if brake_w[l] > 0.0 { 1.0 } else { 0.0 };
                acc.release[l] += if sd[l] < release { 1.0 } else { 0.0 };
            }
        }
        acc.reduce(&k.com, k.contact_damping_n_s_per_m, k.braking_n_s_per_m)
    }
}

impl Accumulators {
    /// Sums the lanes (in `f64`); `com` turns positions relative to the centre of mass back
    /// into scene coordinates; the damping matrix is `contact_damping` times the contact
    /// sum plus `braking` times the braking sum (N·s/m).
    fn reduce(&self, com: &Vector3<f64>, contact_damping: f64, braking: f64) -> Totals {
        let sum = |x: &Lanes| x.iter().map(|&v| f64::from(v)).sum::<f64>();
        // wk·Σ(contact) + wb·Σ(braking), as JtJ.
        let jtj = |wk: f64, wb: f64| {
            let s = |i: usize| wk * sum(&self.k[i]) + wb * sum(&self.b[i]);
            JtJ {
                nn: std::array::from_fn(s),
                mn: std::array::from_fn(|i| s(6 + i)),
                mm: std::array::from_fn(|i| s(15 + i)),
            }
        };
        let vec3 = |x: &[Lanes; 3]| Vector3::new(sum(&x[0]), sum(&x[1]), sum(&x[2]));
        let weight = sum(&self.weight);
        Totals {
            wrench: Vector6::from_fn(|a, _| sum(&self.wrench[a])),
            contact_jj: jtj(1.0, 0.0),
            damping_jj: jtj(contact_damping, braking),
            // Counts below 2^24, exact in f32.
            contacts: sum(&self.contacts) as u32,
            braking_points: sum(&self.braking) as u32,
            within_release: sum(&self.release) > 0.0,
            weighted_point: vec3(&self.point) + com * weight,
            weight,
            normal_sum: vec3(&self.normal),
            max_depth: self.max_depth.iter().fold(0.0, |m, &x| m.max(f64::from(x))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same sums point by point, written the obvious way.
    fn reference(points: &[(Vector3<f64>, Vector3<f64>, f64)], k: &PassParams) -> Totals {
        let mut t = Totals::default();
        for (p, g, sd) in points {
            let n = g.normalize();
            let m = (p - k.com).cross(&n);
            let vn = k.velocity.dot(&n) + k.angular_velocity.dot(&m);
            let jv = Vector6::new(n.x, n.y, n.z, m.x, m.y, m.z);
            let add = |jj: &mut JtJ, w: f64| {
                let full = jv * jv.transpose() * w;
                for (i, &(a, b)) in PAIRS.iter().enumerate() {
                    match i {
                        0..6 => jj.nn[i] += full[(a, b)],
                        6..15 => jj.mn[i - 6] += full[(a, b)],
                        _ => jj.mm[i - 15] += full[(a, b)],
                    }
                }
            };
            if *sd < 0.0 {
                let d = -sd;
                let push =
                    (k.point_stiffness_n_per_m * d - k.contact_damping_n_s_per_m * vn).max(0.0);
                t.wrench += jv * push;
                add(&mut t.contact_jj, 1.0);
                add(&mut t.damping_jj, k.contact_damping_n_s_per_m);
                t.contacts += 1;
                t.weighted_point += d * (p + d * n);
                t.weight += d;
                t.normal_sum += d * n;
                t.max_depth = t.max_depth.max(d);
            } else if *sd < k.proximity_m && vn < 0.0 {
                let w = 1.0 - sd / k.proximity_m;
                t.wrench += jv * (-k.braking_n_s_per_m * w * vn);
                add(&mut t.damping_jj, k.braking_n_s_per_m * w);
                t.braking_points += 1;
            }
            t.within_release |= *sd < k.release_m;
        }
        t
    }

    #[test]
    fn lanes_agree_with_the_point_by_point_sums() {
        let k = PassParams {
            com: Vector3::new(0.21, -0.12, 0.33),
            velocity: Vector3::new(0.05, -0.1, 0.02),
            angular_velocity: Vector3::new(0.3, 0.1, -0.2),
            point_stiffness_n_per_m: 2000.0,
            contact_damping_n_s_per_m: 0.5,
            braking_n_s_per_m: 0.2,
            proximity_m: 0.002,
            release_m: 0.0005,
        };
        // 19 points (not a multiple of LANES): penetrating, braking, receding, far.
        let points: Vec<_> = (0..19)
            .map(|i| {
                let f = f64::from(i);
                let p = k.com + Vector3::new(0.01 * f.sin(), 0.02 * f.cos(), 0.003 * f - 0.03);
                let g = Vector3::new(0.3 + 0.1 * f, 1.0 - 0.05 * f, (0.7 * f).sin());
                let sd = -0.001 + 0.00017 * f;
                (p, g, sd)
            })
            .collect();
        let mut near = NearPoints::with_capacity(points.len());
        // Twice: a second pass must not see the first one's points.
        for _ in 0..2 {
            near.len = 0;
            for (p, g, sd) in &points {
                near.push(&(p - k.com), g, *sd);
            }
            let got = near.accumulate(&k);
            let want = reference(&points, &k);
            assert_eq!(got.contacts, want.contacts);
            assert_eq!(got.braking_points, want.braking_points);
            assert!(want.contacts > 0 && want.braking_points > 0);
            assert_eq!(got.within_release, want.within_release);
            // f32 arithmetic: relative to the size of each quantity.
            let check = |what: &str, got: &[f64], want: &[f64]| {
                let scale = want.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
                assert!(scale > 0.0, "{what} is all zero");
                for (g, w) in got.iter().zip(want) {
                    assert!((g - w).abs() <= 1e-5 * scale, "{what}: {got:?} vs {want:?}");
                }
            };
            check("wrench", got.wrench.as_slice(), want.wrench.as_slice());
            for (name, g, w) in [
                ("contact JJ", &got.contact_jj, &want.contact_jj),
                ("damping JJ", &got.damping_jj, &want.damping_jj),
            ] {
                check(name, &[g.nn, g.mm].concat(), &[w.nn, w.mm].concat());
                check(name, &g.mn, &w.mn);
            }
            check(
                "weighted point",
                got.weighted_point.as_slice(),
                want.weighted_point.as_slice(),
            );
            check(
                "normal sum",
                got.normal_sum.as_slice(),
                want.normal_sum.as_slice(),
            );
            check("weight", &[got.weight], &[want.weight]);
            check("max depth", &[got.max_depth], &[want.max_depth]);
        }
    }

    #[test]
    fn nothing_near_sums_to_zero() {
        let mut near = NearPoints::with_capacity(3);
        let k = PassParams {
            com: Vector3::zeros(),
            velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
            point_stiffness_n_per_m: 1.0,
            contact_damping_n_s_per_m: 1.0,
            braking_n_s_per_m: 1.0,
            proximity_m: 1.0,
            release_m: 1.0,
        };
        assert_eq!(near.accumulate(&k), Totals::default());
    }
}
