//! The force pass: penalty, braking and the implicit step's JᵀJ sums over the points the
//! search found within reach of the surface.
//!
//! The search ([`super::ContactStage`]'s `sum_contacts`) is branchy and scalar: motion
//! budgets, a voxmap look-up per point. What it finds is written here column-wise (one array
//! per coordinate), and the force pass then runs over [`LANES`] points at a time without
//! branches, each statement over all lanes, so the compiler turns it into SIMD. In flat
//! contact thousands of points reach this pass every tick; it is about half of the per-point
//! work. On x86-64 CPUs with AVX2 the same code is compiled a second time for AVX2 and
//! chosen at run time.

use super::{Cluster, JtJ, Pointshell, Voxmap};
use nalgebra::{Matrix3, Vector3, Vector6};

/// Points processed together.
pub(super) const LANES: usize = 4;

/// One value per point of a chunk.
pub(super) type Lanes = [f64; LANES];

/// The upper triangle of a symmetric 6×6 matrix, in [`JtJ`]'s layout (the force pass
/// spells the same list out): `nn` (6), `mn` (9),
/// `mm` (6), with J = [n; m] as indices 0..3 and 3..6.
#[cfg(test)]
const PAIRS: [(usize, usize); 21] = [
    // nn: upper triangle of n nᵀ, row-major.
    (0, 0),
    (0, 1),
    (0, 2),
    (1, 1),
    (1, 2),
    (2, 2),
    // mn: m nᵀ, row-major.
    (3, 0),
    (3, 1),
    (3, 2),
    (4, 0),
    (4, 1),
    (4, 2),
    (5, 0),
    (5, 1),
    (5, 2),
    // mm: upper triangle of m mᵀ, row-major.
    (3, 3),
    (3, 4),
    (3, 5),
    (4, 4),
    (4, 5),
    (5, 5),
];

/// Points within reach of the surface, found by one search: position (scene frame, m),
/// the field's gradient there (not normalised) and the signed distance (m). Holds room for
/// every point of the shell, allocated once, so pushing never allocates.
#[derive(Debug, Clone, Default)]
pub(super) struct NearPoints {
    len: usize,
    p: [Vec<f64>; 3],
    g: [Vec<f64>; 3],
    sd: Vec<f64>,
}

/// The pointshell laid out for the search: object-frame points and inward normals as
/// columns, each cluster padded to whole chunks of [`LANES`] (padding lanes are not
/// `valid`), so a chunk never mixes clusters.
#[derive(Debug, Clone)]
pub(super) struct ShellColumns {
    point: [Vec<f64>; 3],
    normal: [Vec<f64>; 3],
    valid: Vec<bool>,
    /// Per cluster, its chunks: `first..end` in units of LANES.
    chunks: Vec<(u32, u32)>,
}

/// Where the search runs: the object's pose and the reach of the layers.
#[derive(Debug, Clone, Copy)]
pub(super) struct SearchParams {
    /// Rotation of the object frame into the scene frame.
    pub rotation: Matrix3<f64>,
    /// Origin of the object frame in the scene frame, m.
    pub translation: Vector3<f64>,
    /// Points farther from the surface than this are not kept, m.
    pub reach_m: f64,
}

impl ShellColumns {
    pub(super) fn new(shell: &Pointshell) -> Self {
        let mut out = Self {
            point: Default::default(),
            normal: Default::default(),
            valid: Vec::new(),
            chunks: Vec::with_capacity(shell.clusters().len()),
        };
        for cl in shell.clusters() {
            let first = (out.valid.len() / LANES) as u32;
            for i in cl.start as usize..cl.end as usize {
                for a in 0..3 {
                    out.point[a].push(shell.points()[i][a]);
                    out.normal[a].push(shell.normals()[i][a]);
                }
                out.valid.push(true);
            }
            while !out.valid.len().is_multiple_of(LANES) {
                for a in 0..3 {
                    out.point[a].push(cl.centre[a]);
                    out.normal[a].push(0.0);
                }
                out.valid.push(false);
            }
            out.chunks.push((first, (out.valid.len() / LANES) as u32));
        }
        out
    }

    /// The search: every cluster whose motion budget in `budgets` is used up (`moved`
    /// passed it) is checked against the voxmap's clearance, its budget renewed, and if it
    /// may be within reach, its points are looked up ([`Self::search_cluster`]). Returns
    /// the points looked up.
    pub(super) fn search(
        &self,
        clusters: &[Cluster],
        budgets: &mut [f64],
        moved: f64,
        k: &SearchParams,
        vox: &Voxmap,
        near: &mut NearPoints,
    ) -> u32 {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { self.search_avx2(clusters, budgets, moved, k, vox, near) };
        }
        self.search_impl(clusters, budgets, moved, k, vox, near)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn search_avx2(
        &self,
        clusters: &[Cluster],
        budgets: &mut [f64],
        moved: f64,
        k: &SearchParams,
        vox: &Voxmap,
        near: &mut NearPoints,
    ) -> u32 {
        self.search_impl(clusters, budgets, moved, k, vox, near)
    }

    #[inline(always)]
    fn search_impl(
        &self,
        clusters: &[Cluster],
        budgets: &mut [f64],
        moved: f64,
        k: &SearchParams,
        vox: &Voxmap,
        near: &mut NearPoints,
    ) -> u32 {
        let mut tested = 0;
        for (c, (cl, budget)) in clusters.iter().zip(budgets.iter_mut()).enumerate() {
            if moved < *budget {
                continue;
            }
            let centre = k.rotation * cl.centre + k.translation;
            let slack = vox.clearance(&centre) - cl.radius_m - k.reach_m;
            *budget = moved + slack;
            if slack <= 0.0 {
                tested += self.search_cluster(c, k, vox, near);
            }
        }
        tested
    }

    /// Looks up every point of cluster `cluster` in the voxmap and pushes those within
    /// reach of a surface they face onto `near`. Returns the points looked up.
    #[inline(always)]
    pub(super) fn search_cluster(
        &self,
        cluster: usize,
        k: &SearchParams,
        vox: &Voxmap,
        near: &mut NearPoints,
    ) -> u32 {
        let (first, end) = self.chunks[cluster];
        let mut tested = 0;
        let r = &k.rotation;
        for chunk in first as usize..end as usize {
            let o = chunk * LANES;
            let col = |c: &Vec<f64>| -> Lanes { c[o..o + LANES].try_into().expect("LANES long") };
            let x = [
                col(&self.point[0]),
                col(&self.point[1]),
                col(&self.point[2]),
            ];
            let nl = [
                col(&self.normal[0]),
                col(&self.normal[1]),
                col(&self.normal[2]),
            ];
            let valid: [bool; LANES] = self.valid[o..o + LANES].try_into().expect("LANES long");
            let rotate = |v: &[Lanes; 3], a: usize| {
                lanes(|l| r[(a, 0)] * v[0][l] + r[(a, 1)] * v[1][l] + r[(a, 2)] * v[2][l])
            };
            let p: [Lanes; 3] =
                std::array::from_fn(|a| lanes(|l| rotate(&x, a)[l] + k.translation[a]));
            let n: [Lanes; 3] = std::array::from_fn(|a| rotate(&nl, a));
            let s = vox.sample_lanes(&p);
            let g = &s.gradient;
            let g2 = lanes(|l| g[0][l] * g[0][l] + g[1][l] * g[1][l] + g[2][l] * g[2][l]);
            let facing = lanes(|l| n[0][l] * g[0][l] + n[1][l] * g[1][l] + n[2][l] * g[2][l]);
            for l in 0..LANES {
                tested += u32::from(valid[l]);
                // Within reach; a direction (the field is flat midway inside a thin plate);
                // and facing the surface (see the module docs of `contact`).
                if valid[l]
                    && s.stored[l]
                    && s.distance_m[l] < k.reach_m
                    && g2[l] >= 1e-18
                    && facing[l] >= 0.0
                {
                    near.push(
                        &Vector3::new(p[0][l], p[1][l], p[2][l]),
                        &Vector3::new(g[0][l], g[1][l], g[2][l]),
                        s.distance_m[l],
                    );
                }
            }
        }
        tested
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
    k: [Lanes; 21],
    d: [Lanes; 21],
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
            p: [column(), column(), column()],
            g: [column(), column(), column()],
            sd: column(),
        }
    }

    /// Forget the points of the last search.
    #[inline]
    pub(super) fn clear(&mut self) {
        self.len = 0;
    }

    /// Points pushed since [`Self::clear`].
    pub(super) fn len(&self) -> usize {
        self.len
    }

    /// Adds a point. At most as many points as the capacity (each shell point once).
    #[inline]
    pub(super) fn push(&mut self, p: &Vector3<f64>, gradient: &Vector3<f64>, sd: f64) {
        let i = self.len;
        for a in 0..3 {
            self.p[a][i] = p[a];
            self.g[a][i] = gradient[a];
        }
        self.sd[i] = sd;
        self.len = i + 1;
    }

    /// The force pass over the points pushed since [`Self::clear`].
    pub(super) fn accumulate(&mut self, k: &PassParams) -> Totals {
        // Fill the last partial chunk with points that contribute nothing: beyond every
        // layer (all selections below are false), with a finite unit gradient.
        let end = self.len.div_ceil(LANES) * LANES;
        for i in self.len..end {
            for a in 0..3 {
                self.p[a][i] = k.com[a];
                self.g[a][i] = if a == 0 { 1.0 } else { 0.0 };
            }
            self.sd[i] = f64::INFINITY;
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
            d: [zero; 21],
            point: [zero; 3],
            normal: [zero; 3],
            weight: zero,
            max_depth: zero,
            contacts: zero,
            braking: zero,
            release: zero,
        };
        let (kp, bc, bb) = (
            k.point_stiffness_n_per_m,
            k.contact_damping_n_s_per_m,
            k.braking_n_s_per_m,
        );
        let (v, w, com) = (k.velocity, k.angular_velocity, k.com);
        for o in (0..end).step_by(LANES) {
            let col = |c: &Vec<f64>| -> Lanes { c[o..o + LANES].try_into().expect("LANES long") };
            let (px, py, pz) = (col(&self.p[0]), col(&self.p[1]), col(&self.p[2]));
            let (gx, gy, gz) = (col(&self.g[0]), col(&self.g[1]), col(&self.g[2]));
            let sd = col(&self.sd);
            let inv = lanes(|l| 1.0 / (gx[l] * gx[l] + gy[l] * gy[l] + gz[l] * gz[l]).sqrt());
            let n = [
                lanes(|l| gx[l] * inv[l]),
                lanes(|l| gy[l] * inv[l]),
                lanes(|l| gz[l] * inv[l]),
            ];
            let r = [
                lanes(|l| px[l] - com.x),
                lanes(|l| py[l] - com.y),
                lanes(|l| pz[l] - com.z),
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
                if sd[l] >= 0.0 && sd[l] < k.proximity_m && vn[l] < 0.0 {
                    1.0 - sd[l] / k.proximity_m
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
            let damping_w = lanes(|l| bc * in_contact[l] + bb * brake_w[l]);
            // Spelled out pair by pair (constant indices) so that every product stays in
            // registers; a loop over `PAIRS` is left rolled and indexes memory.
            macro_rules! jj {
                ($($i:literal: $a:literal $b:literal),*) => {$(
                    for l in 0..LANES {
                        let jj = j[$a][l] * j[$b][l];
                        acc.k[$i][l] += in_contact[l] * jj;
                        acc.d[$i][l] += damping_w[l] * jj;
                    }
                )*};
            }
            jj!(0: 0 0, 1: 0 1, 2: 0 2, 3: 1 1, 4: 1 2, 5: 2 2,
                6: 3 0, 7: 3 1, 8: 3 2, 9: 4 0, 10: 4 1, 11: 4 2, 12: 5 0, 13: 5 1, 14: 5 2,
                15: 3 3, 16: 3 4, 17: 3 5, 18: 4 4, 19: 4 5, 20: 5 5);
            let p = [px, py, pz];
            for a in 0..3 {
                for l in 0..LANES {
                    // The point projected on the surface, weighted by depth.
                    acc.point[a][l] += depth[l] * (p[a][l] + depth[l] * n[a][l]);
                    acc.normal[a][l] += depth[l] * n[a][l];
                }
            }
            for l in 0..LANES {
                acc.weight[l] += depth[l];
                acc.max_depth[l] = acc.max_depth[l].max(depth[l]);
                acc.contacts[l] += in_contact[l];
                acc.braking[l] += if brake_w[l] > 0.0 { 1.0 } else { 0.0 };
                acc.release[l] += if sd[l] < k.release_m { 1.0 } else { 0.0 };
            }
        }
        acc.reduce()
    }
}

/// One value per lane.
#[inline(always)]
pub(super) fn lanes(f: impl Fn(usize) -> f64) -> Lanes {
    std::array::from_fn(f)
}

impl Accumulators {
    /// Sums the lanes.
    fn reduce(&self) -> Totals {
        let sum = |x: &Lanes| x.iter().sum::<f64>();
        let jtj = |x: &[Lanes; 21]| {
            let mut out = JtJ::default();
            for i in 0..6 {
                out.nn[i] = sum(&x[i]);
                out.mm[i] = sum(&x[15 + i]);
            }
            for i in 0..9 {
                out.mn[i] = sum(&x[6 + i]);
            }
            out
        };
        let vec3 = |x: &[Lanes; 3]| Vector3::new(sum(&x[0]), sum(&x[1]), sum(&x[2]));
        Totals {
            wrench: Vector6::from_fn(|a, _| sum(&self.wrench[a])),
            contact_jj: jtj(&self.k),
            damping_jj: jtj(&self.d),
            // Counts of at most a few million, exact in f64.
            contacts: sum(&self.contacts) as u32,
            braking_points: sum(&self.braking) as u32,
            within_release: sum(&self.release) > 0.0,
            weighted_point: vec3(&self.point),
            weight: sum(&self.weight),
            normal_sum: vec3(&self.normal),
            max_depth: self.max_depth.iter().fold(0.0, |m, &x| m.max(x)),
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
            com: Vector3::new(0.01, -0.02, 0.03),
            velocity: Vector3::new(0.05, -0.1, 0.02),
            angular_velocity: Vector3::new(0.3, 0.1, -0.2),
            point_stiffness_n_per_m: 2000.0,
            contact_damping_n_s_per_m: 0.5,
            braking_n_s_per_m: 0.2,
            proximity_m: 0.002,
            release_m: 0.0005,
        };
        // 11 points (not a multiple of LANES): penetrating, braking, receding, far.
        let points: Vec<_> = (0..11)
            .map(|i| {
                let f = f64::from(i);
                let p = Vector3::new(0.01 * f.sin(), 0.02 * f.cos(), 0.005 * f);
                let g = Vector3::new(0.3 + 0.1 * f, 1.0 - 0.05 * f, (0.7 * f).sin());
                let sd = -0.001 + 0.0003 * f;
                (p, g, sd)
            })
            .collect();
        let mut near = NearPoints::with_capacity(points.len());
        // Twice: a second search must not see the first one's points.
        for _ in 0..2 {
            near.clear();
            for (p, g, sd) in &points {
                near.push(p, g, *sd);
            }
            let got = near.accumulate(&k);
            let want = reference(&points, &k);
            assert_eq!(got.contacts, want.contacts);
            assert_eq!(got.braking_points, want.braking_points);
            assert!(want.contacts > 0 && want.braking_points > 0);
            assert_eq!(got.within_release, want.within_release);
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * (1.0 + b.abs());
            for i in 0..6 {
                assert!(close(got.wrench[i], want.wrench[i]), "wrench {i}");
                assert!(close(got.contact_jj.nn[i], want.contact_jj.nn[i]));
                assert!(close(got.damping_jj.mm[i], want.damping_jj.mm[i]));
            }
            for i in 0..9 {
                assert!(close(got.contact_jj.mn[i], want.contact_jj.mn[i]));
                assert!(close(got.damping_jj.mn[i], want.damping_jj.mn[i]));
            }
            for a in 0..3 {
                assert!(close(got.weighted_point[a], want.weighted_point[a]));
                assert!(close(got.normal_sum[a], want.normal_sum[a]));
            }
            assert!(close(got.weight, want.weight));
            assert!(close(got.max_depth, want.max_depth));
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
