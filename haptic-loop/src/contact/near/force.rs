//! Step 3 of the contact search, the force pass ([`force_chunk`]): for the points of one
//! chunk within reach of a surface they face, penalty, braking and the implicit step's JᵀJ
//! sums, each point's terms times its weight, without branches; [`Accumulators::reduce`]
//! sums the lanes into the step's [`Totals`]. [`super::avx2`] has the same pass in AVX2
//! registers.

use super::super::jtj::JtJ;
use super::super::lanes::{LANES, Lanes, axes, lanes};
use nalgebra::{Vector3, Vector6};

/// What the force pass needs besides the points.
#[derive(Debug, Clone, Copy)]
pub(in crate::contact) struct PassParams {
    /// Centre of mass, scene frame, m.
    pub(in crate::contact) com: Vector3<f64>,
    /// Velocity of the centre of mass, m/s.
    pub(in crate::contact) velocity: Vector3<f64>,
    /// Angular velocity, rad/s.
    pub(in crate::contact) angular_velocity: Vector3<f64>,
    /// Penalty stiffness per point, N/m.
    pub(in crate::contact) point_stiffness_n_per_m: f64,
    /// Contact damping per penetrating point, N·s/m.
    pub(in crate::contact) contact_damping_n_s_per_m: f64,
    /// Braking per approaching point at full weight, N·s/m.
    pub(in crate::contact) braking_n_s_per_m: f64,
    /// Thickness of the proximity layer, m.
    pub(in crate::contact) proximity_m: f64,
    /// Release distance of the contact flag, m.
    pub(in crate::contact) release_m: f64,
}

/// The sums of one force pass.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub(in crate::contact) struct Totals {
    /// Generalised force about the centre of mass: [force; torque] (N; N·m).
    pub(in crate::contact) wrench: Vector6<f64>,
    /// Σ JJᵀ over penetrating points: the contact stiffness is `k_p` times it.
    pub(in crate::contact) contact_jj: JtJ,
    /// Σ b JJᵀ over penetrating (contact damping) and approaching (braking) points: the
    /// contact damping matrix, N·s/m.
    pub(in crate::contact) damping_jj: JtJ,
    /// Penetrating points, counted in the level-0 points they stand for.
    pub(in crate::contact) contacts: u32,
    /// Braking points, counted the same way.
    pub(in crate::contact) braking_points: u32,
    pub(in crate::contact) within_release: bool,
    /// Σ d·(surface point), m², with d the depth.
    pub(in crate::contact) weighted_point: Vector3<f64>,
    /// Σ d, m.
    pub(in crate::contact) weight: f64,
    /// Σ d·n.
    pub(in crate::contact) normal_sum: Vector3<f64>,
    /// Deepest penetration, m.
    pub(in crate::contact) max_depth: f64,
}

impl Totals {
    /// `(1 − t)·self + t·other`: the blend of two levels' sums while the rendered level
    /// changes. Counts are blended and rounded, the release test holds for either, the
    /// deepest penetration is the deeper.
    pub(in crate::contact) fn lerp(&self, other: &Self, t: f64) -> Self {
        let mix = |a: f64, b: f64| a + t * (b - a);
        let count = |a: u32, b: u32| mix(f64::from(a), f64::from(b)).round() as u32;
        Self {
            wrench: self.wrench + (other.wrench - self.wrench) * t,
            contact_jj: self.contact_jj.lerp(&other.contact_jj, t),
            damping_jj: self.damping_jj.lerp(&other.damping_jj, t),
            contacts: count(self.contacts, other.contacts),
            braking_points: count(self.braking_points, other.braking_points),
            within_release: self.within_release || other.within_release,
            weighted_point: self.weighted_point + (other.weighted_point - self.weighted_point) * t,
            weight: mix(self.weight, other.weight),
            normal_sum: self.normal_sum + (other.normal_sum - self.normal_sum) * t,
            max_depth: self.max_depth.max(other.max_depth),
        }
    }
}

/// Per-lane running sums of the force pass, one `T` holding [`LANES`] of each: [`Lanes`]
/// here ([`Accumulators`]), an AVX2 register in [`avx2`].
#[derive(Clone, Copy)]
pub(super) struct Sums<T> {
    pub(super) wrench: [T; 6],
    /// Σ JJᵀ over penetrating points.
    pub(super) k: [T; 21],
    /// Σ w JJᵀ over braking points, w the braking weight.
    pub(super) b: [T; 21],
    pub(super) point: [T; 3],
    pub(super) normal: [T; 3],
    pub(super) weight: T,
    pub(super) max_depth: T,
    pub(super) contacts: T,
    pub(super) braking: T,
    pub(super) release: T,
}

/// The force pass's sums, lane by lane.
pub(super) type Accumulators = Sums<Lanes>;

impl<T: Copy> Sums<T> {
    /// Every sum `v`.
    pub(super) fn splat(v: T) -> Self {
        Self {
            wrench: [v; 6],
            k: [v; 21],
            b: [v; 21],
            point: [v; 3],
            normal: [v; 3],
            weight: v,
            max_depth: v,
            contacts: v,
            braking: v,
            release: v,
        }
    }

    /// Each sum through `f`.
    pub(super) fn map<U>(&self, mut f: impl FnMut(&T) -> U) -> Sums<U> {
        Sums {
            wrench: self.wrench.each_ref().map(&mut f),
            k: self.k.each_ref().map(&mut f),
            b: self.b.each_ref().map(&mut f),
            point: self.point.each_ref().map(&mut f),
            normal: self.normal.each_ref().map(&mut f),
            weight: f(&self.weight),
            max_depth: f(&self.max_depth),
            contacts: f(&self.contacts),
            braking: f(&self.braking),
            release: f(&self.release),
        }
    }
}

impl Default for Accumulators {
    fn default() -> Self {
        Self::splat([0.0; LANES])
    }
}

/// [`PassParams`] as the force pass uses them.
#[derive(Debug, Clone, Copy)]
pub(super) struct ForceConsts {
    pub(super) kp: f32,
    pub(super) bc: f32,
    pub(super) bb: f32,
    pub(super) prox: f32,
    pub(super) release: f32,
    pub(super) v: Vector3<f32>,
    pub(super) w: Vector3<f32>,
}

impl ForceConsts {
    pub(super) fn new(k: &PassParams) -> Self {
        Self {
            kp: k.point_stiffness_n_per_m as f32,
            bc: k.contact_damping_n_s_per_m as f32,
            bb: k.braking_n_s_per_m as f32,
            prox: k.proximity_m as f32,
            release: k.release_m as f32,
            v: k.velocity.map(|x| x as f32),
            w: k.angular_velocity.map(|x| x as f32),
        }
    }
}

/// The force pass over one chunk: points at `r` from the centre of mass (m) with field
/// gradient `g`, signed distance `sd` (m) and weight `wt` (level-0 points) add their
/// penalty, braking and JJᵀ sums, each times its weight, to `acc`. Every statement works on
/// all lanes and choices are selections, so there are no branches; a lane with `sd` = +∞
/// and a unit gradient adds nothing. (Weight 1 multiplies exactly: level 0 gives the bits
/// of an unweighted pass.)
#[inline(always)]
pub(super) fn force_chunk(
    acc: &mut Accumulators,
    r: &[Lanes; 3],
    g: &[Lanes; 3],
    sd: &Lanes,
    wt: &Lanes,
    k: &ForceConsts,
) {
    let ForceConsts {
        kp,
        bc,
        bb,
        prox,
        release,
        v,
        w,
    } = *k;
    let [gx, gy, gz] = g;
    let inv = lanes(|l| 1.0 / (gx[l] * gx[l] + gy[l] * gy[l] + gz[l] * gz[l]).sqrt());
    let n = axes(|a| lanes(|l| g[a][l] * inv[l]));
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
    // The weight where the point penetrates, else 0.
    let in_contact = lanes(|l| if sd[l] < 0.0 { wt[l] } else { 0.0 });
    let depth = lanes(|l| if sd[l] < 0.0 { -sd[l] } else { 0.0 });
    let weighted_depth = lanes(|l| in_contact[l] * depth[l]);
    // Damping never pulls the point into the surface. (The implicit step keeps its
    // damping term also for a clamped point: numerical damping.)
    let push = lanes(|l| in_contact[l] * (kp * depth[l] - bc * vn[l]).max(0.0));
    // Pre-contact braking: opposes approach only, fading in over the layer.
    let brake_w = lanes(|l| {
        if sd[l] >= 0.0 && sd[l] < prox && vn[l] < 0.0 {
            wt[l] * (1.0 - sd[l] / prox)
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
    // Σ w JJᵀ, pair by pair (see `jj_pairs`).
    macro_rules! jj {
        ($sum:expr, $w:expr; $($i:literal: $a:literal $b:literal),*) => {$(
            for l in 0..LANES {
                $sum[$i][l] += $w[l] * (j[$a][l] * j[$b][l]);
            }
        )*};
    }
    jj_pairs!(jj!(acc.k, in_contact));
    // In steady contact most chunks brake nowhere: skip their zero braking sums.
    if brake_w.iter().any(|&b| b > 0.0) {
        jj_pairs!(jj!(acc.b, brake_w));
    }
    for a in 0..3 {
        for l in 0..LANES {
            // The point projected on the surface (relative to the centre of mass),
            // weighted by depth.
            acc.point[a][l] += weighted_depth[l] * (r[a][l] + depth[l] * n[a][l]);
            acc.normal[a][l] += weighted_depth[l] * n[a][l];
        }
    }
    for l in 0..LANES {
        acc.weight[l] += weighted_depth[l];
        acc.max_depth[l] = acc.max_depth[l].max(depth[l]);
        acc.contacts[l] += in_contact[l];
        acc.braking[l] += if brake_w[l] > 0.0 { wt[l] } else { 0.0 };
        acc.release[l] += if sd[l] < release { 1.0 } else { 0.0 };
    }
}

impl Accumulators {
    /// Sums the lanes (in `f64`): the centre of mass turns positions relative to it back
    /// into scene coordinates; the damping matrix is the contact damping times the contact
    /// sum plus the braking times the braking sum (N·s/m).
    pub(super) fn reduce(&self, k: &PassParams) -> Totals {
        let (com, contact_damping, braking) =
            (&k.com, k.contact_damping_n_s_per_m, k.braking_n_s_per_m);
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
            // Counts in level-0 points (sums of whole weights) below 2^24, exact in f32.
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
