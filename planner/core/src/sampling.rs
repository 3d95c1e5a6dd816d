//! Samplers of I-RRT and H-RRT-C: what the operator gives the planner each iteration, the
//! sampling methods, and H-RRT-C's HapticSampling ellipse (Algorithm 1).
//!
//! Methods (I-RRT §4.2.2 "Sampling method", §6; H-RRT-C Algorithm 2):
//! - `CS`: uniform over the bounded space (no operator).
//! - `POS`: Gaussian (σ) around `q_user ⊕ F_r`, `F_r = α·F_u + (1−α)·F_a`, with `F_u` the
//!   operator's motion since the previous iteration: the sampling anticipates a fast
//!   operator and drifts towards the roadmap's suggestion for a still one.
//! - `PATH`: Gaussian (σ) around a uniformly chosen configuration of the operator's
//!   travelled path.
//! - `+CS`: "one sampling of three is chosen with the uniform method" (I-RRT §6, β = 3):
//!   we read β as one uniform sample in β, so the operator-driven share is `1 − 1/β`.
//! - H-RRT-C free mode: with probability α (authority) a uniform sample ("machine mode"),
//!   else `q_device` itself ("human mode"; with [`crate::params::HumanMode::Fresh`], the
//!   default, a q_device already sampled gives a PATH sample near the operator's travelled
//!   path instead).
//! - H-RRT-C contact mode, while the haptic loop reports contact: [`haptic_ellipse`]
//!   (only, as Algorithm 2; with [`ContactParams::shared_authority`] a share α of machine
//!   samples as in free space).

use crate::space::ConfigSpace;
use nalgebra::{Vector3, Vector6};
use rand::{Rng, RngCore};
use rand_distr::StandardNormal;
use scene::pose::{Se3, exp_rotation};
use std::f64::consts::{FRAC_PI_2, PI};

/// How operator input turns into samples. See the module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sampling {
    /// `CS`: uniform only (automatic planning).
    Uniform,
    /// `POS` (β = None) or `POS+CS` (one uniform sample in β).
    Pos {
        /// One sample in β is uniform (I-RRT: 3); `None` for pure POS.
        beta: Option<f64>,
    },
    /// `PATH` or `PATH+CS`.
    Path {
        /// One sample in β is uniform; `None` for pure PATH.
        beta: Option<f64>,
    },
    /// H-RRT-C (Algorithm 2): authority sharing in free space, HapticSampling in contact.
    Hrrtc {
        /// Probability of a machine (uniform) sample in free space, in [0, 1].
        alpha: f64,
    },
}

impl Sampling {
    /// Parses `cs`, `pos`, `pos+cs`, `path`, `path+cs`, `hrrtc` with the given β and α.
    pub fn parse(name: &str, beta: f64, alpha: f64) -> Option<Sampling> {
        Some(match name {
            "cs" | "uniform" => Sampling::Uniform,
            "pos" => Sampling::Pos { beta: None },
            "pos+cs" => Sampling::Pos { beta: Some(beta) },
            "path" => Sampling::Path { beta: None },
            "path+cs" => Sampling::Path { beta: Some(beta) },
            "hrrtc" | "h-rrt-c" => Sampling::Hrrtc { alpha },
            _ => return None,
        })
    }

    /// Short name as accepted by [`Sampling::parse`].
    pub fn name(&self) -> &'static str {
        match self {
            Sampling::Uniform => "cs",
            Sampling::Pos { beta: None } => "pos",
            Sampling::Pos { beta: Some(_) } => "pos+cs",
            Sampling::Path { beta: None } => "path",
            Sampling::Path { beta: Some(_) } => "path+cs",
            Sampling::Hrrtc { .. } => "hrrtc",
        }
    }

    /// Probability that a sample is operator-driven when an operator is present.
    pub fn user_share(&self) -> f64 {
        match *self {
            Sampling::Uniform => 0.0,
            Sampling::Pos { beta } | Sampling::Path { beta } => beta.map_or(1.0, |b| 1.0 - 1.0 / b),
            Sampling::Hrrtc { alpha } => 1.0 - alpha,
        }
    }

    /// Checks β (finite, >= 1) and α (in [0, 1]).
    pub fn validate(&self) -> Result<(), SamplingError> {
        match *self {
            Sampling::Pos { beta: Some(b) } | Sampling::Path { beta: Some(b) }
                if !(b.is_finite() && b >= 1.0) =>
            {
                Err(SamplingError::Beta(b))
            }
            Sampling::Hrrtc { alpha } if !(0.0..=1.0).contains(&alpha) => {
                Err(SamplingError::Alpha(alpha))
            }
            _ => Ok(()),
        }
    }
}

/// Why a [`Sampling`] is out of range ([`Sampling::validate`]).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum SamplingError {
    /// β of a +CS method is below 1 or not finite (one sample in β is uniform).
    #[error("beta must be finite and >= 1, got {0}")]
    Beta(f64),
    /// α of H-RRT-C is outside [0, 1] (it is a probability).
    #[error("alpha must be in [0, 1], got {0}")]
    Alpha(f64),
}

/// Contact state as the haptic loop reports it (scene frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// Contact point on the obstacle surface (m).
    pub point_m: Vector3<f64>,
    /// Unit normal n_c of the first contact, pointing out of the obstacle.
    pub normal: Vector3<f64>,
    /// Operator force f_u (N).
    pub force_n: Vector3<f64>,
    /// Δp, the object's recent displacement (m).
    pub displacement_m: Vector3<f64>,
    /// The object's configuration held at the surface (the proxy), scene frame.
    pub proxy: Se3,
}

/// What the operator gives the planner for one iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UserInput {
    /// q_user / q_device (scene frame).
    pub q_user: Se3,
    /// Contact, when the haptic loop reports it.
    pub contact: Option<Contact>,
    /// When the operator was at `q_user`, s, on any clock that does not run backwards
    /// (the planner process: the haptic state's stamp). The core reads no clock: only the
    /// adaptive authority ([`crate::authority`]) uses it, and an input sequence whose
    /// times never advance (0, as [`UserInput::free`] gives) never looks stuck to it.
    pub time_s: f64,
}

impl UserInput {
    /// Free-space input at `q`, at time 0.
    pub fn free(q: Se3) -> Self {
        UserInput {
            q_user: q,
            contact: None,
            time_s: 0.0,
        }
    }

    /// The same input at `time_s` (s).
    pub fn at(self, time_s: f64) -> Self {
        UserInput { time_s, ..self }
    }
}

/// Tuning of HapticSampling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactParams {
    /// Ellipse area per newton of ‖f_u‖ (m²/N, default 5e-4: 10 N gives a disk of 40 mm
    /// radius).
    pub area_per_newton_m2: f64,
    /// Largest ellipse semi-axis (m, default 0.2): keeps a hard push bounded.
    pub max_semi_axis_m: f64,
    /// Standard deviation of the orientation change of contact samples (rad, default 0.1):
    /// "the orientation of the object is variable".
    pub rotation_sigma_rad: f64,
    /// Offset of samples along n_c, out of the surface (m, default 0.002): the proxy
    /// touches, so samples on the plane itself would mostly collide.
    pub normal_offset_m: f64,
    /// Keep H-RRT-C's authority sharing in contact too: with probability α a machine
    /// sample instead of HapticSampling (default false: Algorithm 2 as the paper writes
    /// it, where contact mode samples only the ellipse, so an operator who stays in contact
    /// stops the machine's exploration).
    pub shared_authority: bool,
}

impl Default for ContactParams {
    fn default() -> Self {
        ContactParams {
            area_per_newton_m2: 5e-4,
            max_semi_axis_m: 0.2,
            rotation_sigma_rad: 0.1,
            normal_offset_m: 0.002,
            shared_authority: false,
        }
    }
}

/// The ellipse of H-RRT-C Algorithm 1 on the contact plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipse {
    /// Centre: the contact point (m).
    pub centre_m: Vector3<f64>,
    /// Unit major-axis direction, tangent to the plane (along Δt when the object moves).
    pub major_dir: Vector3<f64>,
    /// Unit minor-axis direction, tangent, `n_c × major_dir`.
    pub minor_dir: Vector3<f64>,
    /// Semi-axes (m).
    pub semi_major_m: f64,
    /// Semi-minor axis (m).
    pub semi_minor_m: f64,
    /// ϕ, the angle between f_u and the inward normal −n_c, clamped to [0, π/2] (rad).
    pub phi_rad: f64,
}

/// A unit tangent of the plane with normal `n` (unit): deterministic, for when no motion
/// or tangential force gives a direction.
fn any_tangent(n: &Vector3<f64>) -> Vector3<f64> {
    let a = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    (a - n * n.dot(&a)).normalize()
}

/// H-RRT-C Algorithm 1, lines 2–6: the sampling ellipse from the contact state.
///
/// - ϕ = angle(f_u, −n_c) (eq. 1; we measure it from the *inward* normal so that pushing
///   straight into the surface gives ϕ = 0 and a disk, as the paper describes), clamped
///   to [0, π/2].
/// - axis ratios ba = exp(2ϕ), sa = 1/ba (eq. 2); area = `area_per_newton_m2`·‖f_u‖, so
///   the semi-axes are `r·ba` and `r·sa` with `π r² = area` (ba·sa = 1).
/// - major axis along Δt = Δp − (Δp·n_c) n_c (eq. 3 orients it by θ = angle(Δt, t_c));
///   without motion, along the tangential part of f_u; without either, any tangent.
///
/// Returns `None` when the normal is not a finite non-zero vector.
pub fn haptic_ellipse(c: &Contact, p: &ContactParams) -> Option<Ellipse> {
    let n = c.normal.try_normalize(1e-12)?;
    let f = if c.force_n.iter().all(|v| v.is_finite()) {
        c.force_n
    } else {
        Vector3::zeros()
    };
    let fnorm = f.norm();
    let phi = if fnorm > 1e-12 {
        (-f.dot(&n) / fnorm).clamp(-1.0, 1.0).acos().min(FRAC_PI_2)
    } else {
        0.0
    };
    let ba = (2.0 * phi).exp();
    let r = (p.area_per_newton_m2 * fnorm / PI).sqrt();
    let tangential = |v: &Vector3<f64>| v - n * v.dot(&n);
    let dt = tangential(&c.displacement_m);
    let major = dt
        .try_normalize(1e-12)
        .or_else(|| tangential(&f).try_normalize(1e-9))
        .unwrap_or_else(|| any_tangent(&n));
    Some(Ellipse {
        centre_m: c.point_m,
        major_dir: major,
        minor_dir: n.cross(&major),
        semi_major_m: (r * ba).min(p.max_semi_axis_m),
        semi_minor_m: (r / ba).min(p.max_semi_axis_m),
        phi_rad: phi,
    })
}

impl Ellipse {
    /// A point uniformly distributed inside the ellipse (m).
    pub fn sample_point(&self, rng: &mut dyn RngCore) -> Vector3<f64> {
        let (u, v): (f64, f64) = (rng.random(), rng.random());
        let (r, a) = (u.sqrt(), 2.0 * PI * v);
        self.centre_m
            + self.major_dir * (self.semi_major_m * r * a.cos())
            + self.minor_dir * (self.semi_minor_m * r * a.sin())
    }
}

/// H-RRT-C ContactShooter (Algorithm 1, line 7): the proxy configuration slid within the
/// contact plane by a uniform ellipse offset, lifted by `normal_offset_m` along n_c and
/// turned by a Gaussian rotation (σ = `rotation_sigma_rad` per axis), projected into
/// `space`. `None` when the contact has no usable normal.
pub fn contact_sample(
    space: &dyn ConfigSpace,
    c: &Contact,
    p: &ContactParams,
    rng: &mut dyn RngCore,
) -> Option<Se3> {
    let e = haptic_ellipse(c, p)?;
    let n = c.normal.normalize();
    let offset = e.sample_point(rng) - e.centre_m + n * p.normal_offset_m;
    let w = Vector3::new(
        rng.sample::<f64, _>(StandardNormal),
        rng.sample::<f64, _>(StandardNormal),
        rng.sample::<f64, _>(StandardNormal),
    ) * p.rotation_sigma_rad;
    let q = Se3::new(c.proxy.pos + offset, exp_rotation(&w) * c.proxy.rot);
    Some(space.project(&q))
}

/// `q ⊕ v`: translated by `v[0..3]` (m) and rotated by the rotation vector `v[3..6]`
/// (rad, scene frame), then projected into `space` (the inverse of
/// [`ConfigSpace::delta`]).
pub fn apply_delta(space: &dyn ConfigSpace, q: &Se3, v: &Vector6<f64>) -> Se3 {
    let dp = Vector3::new(v[0], v[1], v[2]);
    let dr = Vector3::new(v[3], v[4], v[5]);
    space.project(&Se3::new(q.pos + dp, exp_rotation(&dr) * q.rot))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::space::{Se3Space, Weights};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use scene::Scene;

    fn contact(force: [f64; 3], disp: [f64; 3]) -> Contact {
        Contact {
            point_m: Vector3::new(0.0, 0.0, 0.0),
            normal: Vector3::z(),
            force_n: Vector3::from(force),
            displacement_m: Vector3::from(disp),
            proxy: Se3::from_xyz(0.0, 0.0, 0.05),
        }
    }

    #[test]
    fn ellipse_follows_force_angle_and_motion() {
        let p = ContactParams::default();
        // Pushing straight in: a disk of area 5e-4·10 m².
        let e = haptic_ellipse(&contact([0.0, 0.0, -10.0], [0.0, 0.0, 0.0]), &p).expect("e");
        assert!(e.phi_rad.abs() < 1e-12);
        assert!((e.semi_major_m - e.semi_minor_m).abs() < 1e-12);
        assert!((PI * e.semi_major_m * e.semi_minor_m - 5e-3).abs() < 1e-12);
        // Twice the force, twice the area.
        let e2 = haptic_ellipse(&contact([0.0, 0.0, -20.0], [0.0, 0.0, 0.0]), &p).expect("e");
        assert!(
            (e2.semi_major_m * e2.semi_minor_m / (e.semi_major_m * e.semi_minor_m) - 2.0).abs()
                < 1e-9
        );
        // 45° push: ba = e^(π/2), area unchanged, major axis along the motion's tangent part.
        let e = haptic_ellipse(&contact([5.0, 0.0, -5.0], [0.0, 0.001, -0.003]), &p).expect("e");
        assert!((e.phi_rad - PI / 4.0).abs() < 1e-12);
        assert!((e.semi_major_m / e.semi_minor_m - (PI).exp()).abs() < 1e-9);
        assert!((e.major_dir - Vector3::y()).norm() < 1e-12);
        assert!(e.minor_dir.dot(&Vector3::z()).abs() < 1e-12);
        // No motion: along the tangential force.
        let e = haptic_ellipse(&contact([5.0, 0.0, -5.0], [0.0, 0.0, 0.0]), &p).expect("e");
        assert!((e.major_dir - Vector3::x()).norm() < 1e-12);
        // Bad normal: none.
        let mut c = contact([0.0, 0.0, -1.0], [0.0; 3]);
        c.normal = Vector3::zeros();
        assert!(haptic_ellipse(&c, &p).is_none());
    }

    #[test]
    fn contact_samples_stay_in_the_lifted_ellipse() {
        let s = Se3Space::new(Scene::wall_with_hole().bounds, Weights::default());
        let p = ContactParams::default();
        let c = contact([4.0, 0.0, -4.0], [0.002, 0.0, 0.0]);
        let e = haptic_ellipse(&c, &p).expect("e");
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let (mut max_x, mut max_y): (f64, f64) = (0.0, 0.0);
        for _ in 0..500 {
            let q = contact_sample(&s, &c, &p, &mut rng).expect("sample");
            let off = q.pos - c.proxy.pos;
            assert!((off.z - p.normal_offset_m).abs() < 1e-12);
            let (u, v) = (off.x / e.semi_major_m, off.y / e.semi_minor_m);
            assert!(u * u + v * v <= 1.0 + 1e-9);
            max_x = max_x.max(off.x.abs());
            max_y = max_y.max(off.y.abs());
        }
        // Elongated along x (the motion), narrow across.
        assert!(max_x > 0.8 * e.semi_major_m && max_y < e.semi_minor_m + 1e-12);
        assert!(max_x > 10.0 * max_y, "{max_x} {max_y}");
    }

    #[test]
    fn names_shares_and_validation() {
        for n in ["cs", "pos", "pos+cs", "path", "path+cs", "hrrtc"] {
            assert_eq!(Sampling::parse(n, 3.0, 0.1).expect(n).name(), n);
        }
        assert!(Sampling::parse("nope", 3.0, 0.1).is_none());
        assert!(
            (Sampling::parse("pos+cs", 3.0, 0.0).expect("p").user_share() - 2.0 / 3.0).abs()
                < 1e-12
        );
        assert_eq!(Sampling::Pos { beta: None }.user_share(), 1.0);
        assert!((Sampling::Hrrtc { alpha: 0.2 }.user_share() - 0.8).abs() < 1e-12);
        assert!(Sampling::Hrrtc { alpha: 1.5 }.validate().is_err());
        assert!(Sampling::Path { beta: Some(0.5) }.validate().is_err());
    }
}
