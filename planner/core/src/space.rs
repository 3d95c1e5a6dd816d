//! Configuration space of a free-flying rigid object: SE(3) with the weighted distance of
//! I-RRT eq. 2, interpolation, sampling, steering and 6-vector differences.
//!
//! The weighted distance between `a` and `b` is
//! `d = sqrt(w_t·|p_b − p_a|² + w_r·θ²)`, with `θ ∈ [0, π]` the angle of `a.rot⁻¹·b.rot`.
//! `d` is in "weighted metres". Defaults: `w_t = 1` (per m²) and `w_r = 0.01` m²/rad²,
//! i.e. one radian weighs like 0.1 m, the characteristic radius of the I-RRT object
//! (its farthest point is 0.087 m from the reference point). With `w_r = r²` and every
//! object point within `r` of the reference point, no point moves farther than
//! `|Δp| + r·θ ≤ √2·d`: resolutions stated as weighted distances bound point motion.
//!
//! The planar (x, y, θ) space is [`PlanarSpace`], whose configurations are `Se3` with
//! fixed z and rotations about z; [`Space`] is whichever of the two a scene asks for.

use nalgebra::{Quaternion, UnitQuaternion, Vector3, Vector6};
use rand::{Rng, RngCore};
use rand_distr::StandardNormal;
use scene::Bounds;
use scene::pose::{Se3, angle_between, exp_rotation, rotation_vector};
use std::f64::consts::{PI, TAU};

mod planar;
pub use planar::{PlanarSpace, Space, wrap_angle};

/// Weights of the distance (I-RRT eq. 2, generalised to SE(3)), and how its translation
/// and rotation terms combine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weights {
    /// Weight of squared translation (1/m² · weighted m², default 1).
    pub translation: f64,
    /// Weight of squared rotation angle (weighted m² per rad², default 0.01 = (0.1 m)²).
    pub rotation: f64,
    /// Euclidean (I-RRT eq. 2, default) or sum of the two terms (OMPL's compound spaces).
    pub combine: Combine,
}

/// How the weighted translation and rotation terms make one distance.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Combine {
    /// `sqrt(w_t·|Δp|² + w_r·θ²)`: I-RRT eq. 2.
    #[default]
    Euclidean,
    /// `√w_t·|Δp| + √w_r·θ`: the weighted sum OMPL's SE(2)/SE(3) spaces use. Never
    /// shorter than the Euclidean combination, so the Euclidean lower bounds of the
    /// nearest-neighbour index hold for it too; it makes mixed moves (translation and
    /// rotation together) longer, so steps and nearest nodes favour matching orientation.
    Sum,
}

impl Default for Weights {
    fn default() -> Self {
        Weights {
            translation: 1.0,
            rotation: 0.01,
            combine: Combine::Euclidean,
        }
    }
}

impl Weights {
    /// The distance (weighted m) from the weighted squared translation `t2` = w_t·|Δp|²
    /// and the rotation angle `theta_rad`.
    pub fn combine_terms(&self, t2: f64, theta_rad: f64) -> f64 {
        match self.combine {
            Combine::Euclidean => (t2 + self.rotation * theta_rad * theta_rad).sqrt(),
            Combine::Sum => t2.sqrt() + self.rotation.sqrt() * theta_rad.abs(),
        }
    }
}

/// What the planner needs from a configuration space. Configurations are [`Se3`];
/// lower-dimensional spaces constrain which `Se3` they produce.
pub trait ConfigSpace {
    /// Weighted distance (weighted m), symmetric, zero on equal configurations.
    fn distance(&self, a: &Se3, b: &Se3) -> f64;
    /// The configuration at fraction `t ∈ [0, 1]` along the geodesic from `a` to `b`.
    fn interpolate(&self, a: &Se3, b: &Se3, t: f64) -> Se3;
    /// A uniformly distributed configuration.
    fn sample_uniform(&self, rng: &mut dyn RngCore) -> Se3;
    /// A Gaussian sample around `centre`; `sigma` is the per-axis standard deviation in
    /// weighted m (translation σ/√w_t in m, rotation σ/√w_r in rad), kept in bounds.
    fn sample_near(&self, centre: &Se3, sigma: f64, rng: &mut dyn RngCore) -> Se3;
    /// True when the reference point lies in the bounds.
    fn contains(&self, q: &Se3) -> bool;
    /// `(Δp (m), Δr (rad))`, scene frame: `Δp = to.pos − from.pos` and `Δr` the rotation
    /// vector of `from.rot⁻¹·to.rot` expressed in the scene frame. Pseudo-forces use it.
    fn delta(&self, from: &Se3, to: &Se3) -> Vector6<f64>;

    /// `Some(distance(a, b))` when it is below `bound`, else `None` (weighted m). Lets
    /// nearest-neighbour scans skip the costly part of the metric; the default computes
    /// the full distance.
    fn distance_below(&self, a: &Se3, b: &Se3, bound: f64) -> Option<f64> {
        let d = self.distance(a, b);
        (d < bound).then_some(d)
    }

    /// A point of R^7 for `q` whose Euclidean distances bound the metric from below:
    /// `distance(a, b) ≥ min(|embed(a) − embed(b)|, |embed(a) − embed_mirror(b)|)` (the
    /// second term only where `embed_mirror` is `Some`). Nearest-neighbour indexes
    /// ([`crate::tree`]) prune with it. `None` (the default) disables the index.
    fn embed(&self, q: &Se3) -> Option<Embedded> {
        let _ = q;
        None
    }

    /// The second image of `q` in an embedding where a configuration has two (SE(3):
    /// `q` and `−q` are the same rotation); `None` (the default) when it has one.
    fn embed_mirror(&self, q: &Se3) -> Option<Embedded> {
        let _ = q;
        None
    }

    /// How the embedding's coordinates split into the metric's two terms, for a tighter
    /// bound (see [`EmbedTerms`]). The default, one Euclidean group, is always valid for
    /// an embedding as `embed` states.
    fn embed_terms(&self) -> EmbedTerms {
        EmbedTerms::EUCLIDEAN
    }

    /// The configuration of this space nearest to `q` (identity for SE(3); the planar
    /// space drops z and tilts). Used on operator poses, which are full 6-D.
    fn project(&self, q: &Se3) -> Se3 {
        *q
    }

    /// Moves from `from` towards `to` by at most `step` (weighted m); returns `to` itself
    /// when it is within `step`.
    fn steer(&self, from: &Se3, to: &Se3, step: f64) -> Se3 {
        let d = self.distance(from, to);
        if d <= step {
            *to
        } else {
            self.interpolate(from, to, step / d)
        }
    }
}

/// Dimension of the embedding of [`ConfigSpace::embed`].
pub const EMBED_DIM: usize = 7;

/// How the coordinates of [`ConfigSpace::embed`] bound the metric's two terms:
/// coordinates `..split` bound the translation term and `split..` the rotation term, each
/// by its own Euclidean distance, and the metric combines the terms as `combine` does.
/// For [`Combine::Sum`] the sum of the two distances is a lower bound up to √2 above the
/// plain Euclidean one, which is what lets the k-d tree prune as well as for Euclidean.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EmbedTerms {
    /// First coordinate of the rotation term.
    pub split: usize,
    /// How the metric combines the two terms.
    pub combine: Combine,
}

impl EmbedTerms {
    /// One Euclidean group over every coordinate.
    pub const EUCLIDEAN: EmbedTerms = EmbedTerms {
        split: EMBED_DIM,
        combine: Combine::Euclidean,
    };
}

/// A point of the embedding of [`ConfigSpace::embed`] (weighted m per coordinate).
pub type Embedded = [f64; EMBED_DIM];

/// Weighted length (I-RRT eq. 2 metric) of the polyline through `path`.
pub fn path_length(space: &dyn ConfigSpace, path: &[Se3]) -> f64 {
    path.windows(2).map(|w| space.distance(&w[0], &w[1])).sum()
}

/// Points along one geodesic, with the per-edge work (relative rotation, angles) done
/// once: [`Geodesic::at`] costs a lerp and one `sin_cos`. Built by [`Space::geodesic`];
/// both spaces' `interpolate` go through it, so the two agree exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geodesic {
    a: Vector3<f64>,
    b: Vector3<f64>,
    rot: GeodesicRot,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum GeodesicRot {
    /// `a.rot · exp(t·rel)`, `rel` the rotation vector of `a.rot⁻¹·b.rot` (rad).
    Se3 {
        base: UnitQuaternion<f64>,
        rel: Vector3<f64>,
    },
    /// `Rz(theta_a + t·dt) · tilt` at height `z` (rad, m).
    Planar {
        theta_a: f64,
        dt: f64,
        tilt: UnitQuaternion<f64>,
        z: f64,
    },
}

impl Geodesic {
    /// The SE(3) geodesic: straight position, rotation about the fixed axis of
    /// `a.rot⁻¹·b.rot`.
    pub fn se3(a: &Se3, b: &Se3) -> Self {
        Geodesic {
            a: a.pos,
            b: b.pos,
            rot: GeodesicRot::Se3 {
                base: a.rot,
                rel: rotation_vector(&(a.rot.inverse() * b.rot)),
            },
        }
    }

    fn planar(a: &Se3, b: &Se3, theta_a: f64, dt: f64, space: &PlanarSpace) -> Self {
        Geodesic {
            a: a.pos,
            b: b.pos,
            rot: GeodesicRot::Planar {
                theta_a,
                dt,
                tilt: space.tilt,
                z: space.z_m,
            },
        }
    }

    /// Upper bound on how far any point within `radius_m` of the reference point moves
    /// (m) per unit of `t`: `|b − a| + radius_m·θ`, θ the total rotation angle (rad). Both
    /// parts are traversed at constant rate (straight position, a fixed rotation axis), and
    /// a point at distance r from the axis through the reference point moves at most
    /// `r·Δθ`, so between `t0` and `t1` no point moves more than `|t1 − t0|` times this.
    pub fn sweep_m(&self, radius_m: f64) -> f64 {
        let theta = match &self.rot {
            GeodesicRot::Se3 { rel, .. } => rel.norm(),
            GeodesicRot::Planar { dt, .. } => dt.abs(),
        };
        (self.b - self.a).norm() + radius_m * theta
    }

    /// The configuration at fraction `t ∈ [0, 1]`.
    pub fn at(&self, t: f64) -> Se3 {
        let pos = self.a.lerp(&self.b, t);
        match &self.rot {
            GeodesicRot::Se3 { base, rel } => Se3 {
                pos,
                rot: base * exp_rotation(&(rel * t)),
            },
            GeodesicRot::Planar {
                theta_a,
                dt,
                tilt,
                z,
            } => {
                // θ_a and t·dt are in [−π, π]: one turn at most brings the sum back
                // (as `wrap_angle` would, without its `fmod`).
                let th = theta_a + t * dt;
                let th = if th > PI {
                    th - TAU
                } else if th <= -PI {
                    th + TAU
                } else {
                    th
                };
                let half = 0.5 * th;
                let (s, c) = half.sin_cos();
                let rz = UnitQuaternion::new_unchecked(Quaternion::new(c, 0.0, 0.0, s));
                Se3::new(Vector3::new(pos.x, pos.y, *z), rz * tilt)
            }
        }
    }
}

/// SE(3) with a box for the reference point. See the module docs for the metric.
#[derive(Clone, Debug, PartialEq)]
pub struct Se3Space {
    /// Bounds of the reference point (m, scene frame).
    pub bounds: Bounds,
    /// Distance weights.
    pub weights: Weights,
}

impl Se3Space {
    /// A space over `bounds` with `weights`.
    pub fn new(bounds: Bounds, weights: Weights) -> Self {
        Se3Space { bounds, weights }
    }

    fn clamp(&self, p: Vector3<f64>) -> Vector3<f64> {
        p.zip_zip_map(&self.bounds.min_m, &self.bounds.max_m, |v, lo, hi| {
            v.clamp(lo, hi)
        })
    }
}

/// A uniformly distributed rotation (Shoemake 1992, "Uniform random rotations").
pub fn uniform_rotation(rng: &mut dyn RngCore) -> UnitQuaternion<f64> {
    let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
    let tau = std::f64::consts::TAU;
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    UnitQuaternion::from_quaternion(Quaternion::new(
        b * (tau * u3).cos(),
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
    ))
}

fn normal3(rng: &mut dyn RngCore) -> Vector3<f64> {
    Vector3::new(
        rng.sample(StandardNormal),
        rng.sample(StandardNormal),
        rng.sample(StandardNormal),
    )
}

impl ConfigSpace for Se3Space {
    fn distance(&self, a: &Se3, b: &Se3) -> f64 {
        let dp2 = (b.pos - a.pos).norm_squared();
        let th = angle_between(&a.rot, &b.rot);
        self.weights
            .combine_terms(self.weights.translation * dp2, th)
    }

    fn distance_below(&self, a: &Se3, b: &Se3, bound: f64) -> Option<f64> {
        // The translation term alone is a lower bound: skip the angle when it suffices.
        let t2 = self.weights.translation * (b.pos - a.pos).norm_squared();
        if t2 >= bound * bound {
            return None;
        }
        let th = angle_between(&a.rot, &b.rot);
        let d = self.weights.combine_terms(t2, th);
        (d < bound).then_some(d)
    }

    fn embed(&self, q: &Se3) -> Option<Embedded> {
        // (√w_t·p, 2·√w_r·q) with q on the w ≥ 0 hemisphere. For unit quaternions at
        // angle θ (rad) the nearer of ±q is at chord 2·sin(θ/4) ≤ θ/2, so the rotation
        // part is at most √w_r·θ; with `embed_mirror` (−q) the query sees both images.
        let (t, r) = (
            self.weights.translation.sqrt(),
            2.0 * self.weights.rotation.sqrt(),
        );
        let c = q.rot.coords;
        let r = if c.w < 0.0 { -r } else { r };
        Some([
            t * q.pos.x,
            t * q.pos.y,
            t * q.pos.z,
            r * c.w,
            r * c.x,
            r * c.y,
            r * c.z,
        ])
    }

    fn embed_mirror(&self, q: &Se3) -> Option<Embedded> {
        let mut e = self.embed(q)?;
        e[3..].iter_mut().for_each(|v| *v = -*v);
        Some(e)
    }

    fn embed_terms(&self) -> EmbedTerms {
        EmbedTerms {
            split: 3,
            combine: self.weights.combine,
        }
    }

    fn interpolate(&self, a: &Se3, b: &Se3, t: f64) -> Se3 {
        Geodesic::se3(a, b).at(t)
    }

    fn sample_uniform(&self, rng: &mut dyn RngCore) -> Se3 {
        let (lo, hi) = (&self.bounds.min_m, &self.bounds.max_m);
        let mut pos = Vector3::zeros();
        for i in 0..3 {
            let u: f64 = rng.random();
            pos[i] = lo[i] + u * (hi[i] - lo[i]);
        }
        Se3 {
            pos,
            rot: uniform_rotation(rng),
        }
    }

    fn sample_near(&self, centre: &Se3, sigma: f64, rng: &mut dyn RngCore) -> Se3 {
        let st = sigma / self.weights.translation.sqrt();
        let sr = sigma / self.weights.rotation.sqrt();
        let dp = normal3(rng) * st;
        let dr = normal3(rng) * sr;
        Se3 {
            pos: self.clamp(centre.pos + dp),
            rot: exp_rotation(&dr) * centre.rot,
        }
    }

    fn contains(&self, q: &Se3) -> bool {
        self.bounds.contains(&q.pos)
    }

    fn delta(&self, from: &Se3, to: &Se3) -> Vector6<f64> {
        let dp = to.pos - from.pos;
        let dr = from.rot * rotation_vector(&(from.rot.inverse() * to.rot));
        Vector6::new(dp.x, dp.y, dp.z, dr.x, dr.y, dr.z)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use scene::Scene;

    /// The wall-with-hole scene's SE(3) space with the default weights: the tests' space.
    pub(crate) fn space() -> Se3Space {
        Se3Space::new(Scene::wall_with_hole().bounds, Weights::default())
    }

    #[test]
    fn sweep_bounds_how_far_object_points_move() {
        // Between any two fractions of an edge, no point within r of the reference point
        // moves more than |t1 − t0|·sweep_m(r); and the bound is nearly reached.
        let bounds = Bounds {
            min_m: Vector3::repeat(-1.0),
            max_m: Vector3::repeat(1.0),
        };
        let spaces = [
            Space::Se3(Se3Space::new(bounds, Weights::default())),
            Space::Planar(PlanarSpace::new(
                bounds,
                Weights::default(),
                &Se3::new(
                    Vector3::new(0.0, 0.0, 0.1),
                    UnitQuaternion::from_euler_angles(0.3, 0.2, 0.0),
                ),
            )),
        ];
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let r = 0.3;
        for space in &spaces {
            let mut tightest: f64 = 0.0;
            for _ in 0..300 {
                let (a, b) = (
                    space.sample_uniform(&mut rng),
                    space.sample_uniform(&mut rng),
                );
                let g = space.geodesic(&a, &b);
                let (t0, t1): (f64, f64) = (rng.random(), rng.random());
                let p = Vector3::new(rng.random(), rng.random(), rng.random()).normalize() * r;
                let (q0, q1) = (g.at(t0), g.at(t1));
                let moved = (q1.transform_point(&p) - q0.transform_point(&p)).norm();
                let bound = (t1 - t0).abs() * g.sweep_m(r);
                assert!(moved <= bound + 1e-12, "{moved} > {bound}");
                tightest = tightest.max(moved / bound);
            }
            assert!(tightest > 0.5, "{tightest}");
        }
    }

    #[test]
    fn metric_properties() {
        let s = space();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for _ in 0..200 {
            let (a, b, c) = (
                s.sample_uniform(&mut rng),
                s.sample_uniform(&mut rng),
                s.sample_uniform(&mut rng),
            );
            assert_eq!(s.distance(&a, &a), 0.0);
            let d = s.distance(&a, &b);
            assert_eq!(s.distance_below(&a, &b, d + 1e-9), Some(d));
            assert_eq!(s.distance_below(&a, &b, d), None);
            assert!((s.distance(&a, &b) - s.distance(&b, &a)).abs() < 1e-12);
            // Both parts are metrics, so their weighted l2 combination is one too.
            assert!(s.distance(&a, &c) <= s.distance(&a, &b) + s.distance(&b, &c) + 1e-12);
            assert!(s.distance(&a, &b) <= (0.6f64.powi(2) + 0.5 + 0.01 * PI * PI).sqrt());
        }
    }

    #[test]
    fn rotation_weighting() {
        let s = space();
        let a = Se3::identity();
        let rot = Se3::new(
            Vector3::zeros(),
            UnitQuaternion::from_euler_angles(0.0, 0.0, 1.0),
        );
        // One radian weighs like 0.1 m.
        assert!((s.distance(&a, &rot) - 0.1).abs() < 1e-12);
        assert!((s.distance(&a, &Se3::from_xyz(0.1, 0.0, 0.0)) - 0.1).abs() < 1e-12);
        // Angles are folded into [0, π]: 1.5π about z is 0.5π.
        let far = Se3::new(
            Vector3::zeros(),
            UnitQuaternion::from_euler_angles(0.0, 0.0, 1.5 * PI),
        );
        assert!((s.distance(&a, &far) - 0.05 * PI).abs() < 1e-9);
        let both = Se3::new(Vector3::new(0.3, 0.0, 0.4), rot.rot);
        assert!((s.distance(&a, &both) - (0.25f64 + 0.01).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn interpolation_endpoints_and_midpoint() {
        let s = space();
        let a = Se3::from_rpy(Vector3::new(-0.1, 0.0, 0.2), 0.3, 0.2, -1.0);
        let b = Se3::from_rpy(Vector3::new(0.1, 0.1, -0.2), -0.5, 1.0, 2.5);
        assert!(s.distance(&s.interpolate(&a, &b, 0.0), &a) < 1e-12);
        assert!(s.distance(&s.interpolate(&a, &b, 1.0), &b) < 1e-9);
        let m = s.interpolate(&a, &b, 0.5);
        let (da, db) = (s.distance(&a, &m), s.distance(&m, &b));
        assert!((da - db).abs() < 1e-9 && (da + db - s.distance(&a, &b)).abs() < 1e-9);
        let st = s.steer(&a, &b, 0.05);
        assert!((s.distance(&a, &st) - 0.05).abs() < 1e-9);
        assert_eq!(s.steer(&a, &st, 1.0), st);
    }

    #[test]
    fn delta_is_scene_frame_rotation_vector() {
        let s = space();
        let from = Se3::new(
            Vector3::new(0.1, 0.0, 0.0),
            UnitQuaternion::from_euler_angles(0.0, 0.0, 0.5 * PI),
        );
        // Rotating further about scene x, applied in the scene frame.
        let extra = UnitQuaternion::from_euler_angles(0.2, 0.0, 0.0);
        let to = Se3::new(Vector3::new(0.1, 0.2, 0.0), extra * from.rot);
        let d = s.delta(&from, &to);
        assert!(
            (d - Vector6::new(0.0, 0.2, 0.0, 0.2, 0.0, 0.0)).norm() < 1e-12,
            "{d}"
        );
    }

    #[test]
    fn embedding_bounds_the_metric_from_below() {
        let s = space();
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let d2 = |x: &Embedded, y: &Embedded| {
            x.iter().zip(y).map(|(u, v)| (u - v) * (u - v)).sum::<f64>()
        };
        let mut tight = 0;
        for i in 0..2000 {
            let a = s.sample_uniform(&mut rng);
            let mut b = match i % 3 {
                0 => s.sample_uniform(&mut rng),
                1 => s.sample_near(&a, 0.01, &mut rng),
                // Almost the opposite rotation, a small move away.
                _ => Se3::new(
                    a.pos,
                    a.rot * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), PI - 1e-3),
                ),
            };
            if i % 2 == 0 {
                // The same rotation given by the other quaternion.
                b.rot = UnitQuaternion::new_unchecked(-b.rot.into_inner());
            }
            let d = s.distance(&a, &b);
            let ea = s.embed(&a).expect("SE(3) embeds");
            let lb2 = d2(&ea, &s.embed(&b).unwrap()).min(d2(&ea, &s.embed_mirror(&b).unwrap()));
            assert!(
                lb2.sqrt() <= d * (1.0 + 1e-12) + 1e-15,
                "{} > {d}",
                lb2.sqrt()
            );
            tight += usize::from(lb2.sqrt() > 0.9 * d);
            // The stored image is canonical: ±q embed alike.
            let neg = Se3::new(a.pos, UnitQuaternion::new_unchecked(-a.rot.into_inner()));
            assert_eq!(s.embed(&neg), s.embed(&a));
        }
        assert!(tight > 1000, "{tight}");
    }

    #[test]
    fn the_sum_metric_adds_the_weighted_terms() {
        let euclid = space();
        let sum = Se3Space::new(
            euclid.bounds,
            Weights {
                combine: Combine::Sum,
                ..Weights::default()
            },
        );
        let a = Se3::from_xyz(0.0, 0.0, 0.0);
        // 0.3 m and 0.4 rad: sum 0.3 + 0.1·0.4 = 0.34, Euclidean √(0.09 + 0.0016).
        let b = Se3::new(
            Vector3::new(0.3, 0.0, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.4),
        );
        assert!((sum.distance(&a, &b) - 0.34).abs() < 1e-12);
        assert!((euclid.distance(&a, &b) - 0.0916f64.sqrt()).abs() < 1e-12);
        // Pure moves weigh the same in both.
        let c = Se3::from_xyz(0.0, 0.2, 0.1);
        assert!((sum.distance(&a, &c) - euclid.distance(&a, &c)).abs() < 1e-15);
        assert_eq!(sum.distance_below(&a, &b, 0.35), Some(sum.distance(&a, &b)));
        assert_eq!(sum.distance_below(&a, &b, 0.33), None);
        // Never shorter than Euclidean, so the embedding still bounds it from below.
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for _ in 0..500 {
            let (p, q) = (sum.sample_uniform(&mut rng), sum.sample_uniform(&mut rng));
            assert!(sum.distance(&p, &q) >= euclid.distance(&p, &q));
        }
    }

    #[test]
    fn samples_stay_in_bounds_and_are_seeded() {
        let s = space();
        let (mut r1, mut r2) = (ChaCha8Rng::seed_from_u64(7), ChaCha8Rng::seed_from_u64(7));
        let c = Se3::from_xyz(0.29, 0.0, 0.0);
        for _ in 0..100 {
            let (u, v) = (s.sample_uniform(&mut r1), s.sample_uniform(&mut r2));
            assert_eq!(u, v);
            assert!(s.contains(&u));
            assert!((u.rot.norm() - 1.0).abs() < 1e-12);
            let (n1, n2) = (
                s.sample_near(&c, 0.05, &mut r1),
                s.sample_near(&c, 0.05, &mut r2),
            );
            assert_eq!(n1, n2);
            assert!(s.contains(&n1));
        }
    }
}
