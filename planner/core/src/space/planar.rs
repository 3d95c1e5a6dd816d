//! The planar configuration space (x, y, θ) of I-RRT §5.2 and §6, and [`Space`], the
//! space a scene asks for.
//!
//! Configurations stay [`Se3`] so that trees, collision and the wire need no second pose
//! type: a planar configuration has `z = z_m` and rotation `Rz(θ)·tilt`, where `tilt` is
//! the start's orientation (usually identity). The distance is I-RRT eq. 2 in its planar
//! form, `d = sqrt(w_t·(Δx² + Δy²) + w_r·Δθ²)`, with Δθ wrapped into [−π, π].

use super::{ConfigSpace, EmbedTerms, Embedded, Se3Space, Weights};
use nalgebra::{UnitQuaternion, Vector3, Vector6};
use rand::{Rng, RngCore};
use rand_distr::StandardNormal;
use scene::pose::Se3;
use scene::{Bounds, Scene, SpaceKind};
use std::f64::consts::PI;

/// (x, y, θ) over the bounds' x–y rectangle.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarSpace {
    /// Bounds of the reference point (m); only x and y are sampled.
    pub bounds: Bounds,
    /// Distance weights.
    pub weights: Weights,
    /// Height of every configuration (m).
    pub z_m: f64,
    /// Orientation at θ = 0.
    pub tilt: UnitQuaternion<f64>,
}

/// `a` wrapped into [−π, π] (rad).
pub fn wrap_angle(a: f64) -> f64 {
    let w = (a + PI).rem_euclid(2.0 * PI) - PI;
    if w == -PI { PI } else { w }
}

impl PlanarSpace {
    /// A planar space at the height and tilt of `start`.
    pub fn new(bounds: Bounds, weights: Weights, start: &Se3) -> Self {
        PlanarSpace {
            bounds,
            weights,
            z_m: start.pos.z,
            tilt: start.rot,
        }
    }

    /// θ of `q` (rad, in [−π, π]): the angle about scene z of `q.rot · tilt⁻¹`.
    pub fn theta(&self, q: &Se3) -> f64 {
        let (w, k) = self.half_angle(q);
        wrap_angle(2.0 * k.atan2(w))
    }

    /// `(w, k)` of `q.rot · tilt⁻¹`: for a rotation by θ about z, `(cos θ/2, sin θ/2)`.
    fn half_angle(&self, q: &Se3) -> (f64, f64) {
        if self.tilt == UnitQuaternion::identity() {
            return (q.rot.w, q.rot.k);
        }
        let r = q.rot * self.tilt.inverse();
        (r.w, r.k)
    }

    /// θ(b) − θ(a) wrapped into [−π, π] (rad), with one `atan2`: the angle of the
    /// relative half-angle rotation `(w_a·w_b + k_a·k_b, w_a·k_b − k_a·w_b)`.
    pub fn delta_theta(&self, a: &Se3, b: &Se3) -> f64 {
        let ((wa, ka), (wb, kb)) = (self.half_angle(a), self.half_angle(b));
        let (w, k) = (wa * wb + ka * kb, wa * kb - ka * wb);
        // The half angle on the w ≥ 0 side is the short way round, in [−π/2, π/2].
        let (w, k) = if w < 0.0 { (-w, -k) } else { (w, k) };
        2.0 * k.atan2(w)
    }

    /// The planar geodesic from `a` to `b`: straight (x, y), θ the short way round.
    pub fn geodesic(&self, a: &Se3, b: &Se3) -> super::Geodesic {
        super::Geodesic::planar(a, b, self.theta(a), self.delta_theta(a, b), self)
    }

    /// The configuration at `(x, y)` (m) and `theta` (rad).
    pub fn config(&self, x: f64, y: f64, theta: f64) -> Se3 {
        Se3::new(
            Vector3::new(x, y, self.z_m),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), theta) * self.tilt,
        )
    }

    fn clamp_xy(&self, x: f64, y: f64) -> (f64, f64) {
        let (lo, hi) = (&self.bounds.min_m, &self.bounds.max_m);
        (x.clamp(lo.x, hi.x), y.clamp(lo.y, hi.y))
    }
}

impl ConfigSpace for PlanarSpace {
    fn distance(&self, a: &Se3, b: &Se3) -> f64 {
        let (dx, dy) = (b.pos.x - a.pos.x, b.pos.y - a.pos.y);
        let dt = self.delta_theta(a, b);
        self.weights
            .combine_terms(self.weights.translation * (dx * dx + dy * dy), dt)
    }

    fn distance_below(&self, a: &Se3, b: &Se3, bound: f64) -> Option<f64> {
        // The translation term alone is a lower bound: skip the two angles (atan2 each)
        // when it suffices, as most candidates of a nearest-neighbour search do.
        let (dx, dy) = (b.pos.x - a.pos.x, b.pos.y - a.pos.y);
        if self.weights.translation * (dx * dx + dy * dy) >= bound * bound {
            return None;
        }
        let d = self.distance(a, b);
        (d < bound).then_some(d)
    }

    fn interpolate(&self, a: &Se3, b: &Se3, t: f64) -> Se3 {
        self.geodesic(a, b).at(t)
    }

    fn sample_uniform(&self, rng: &mut dyn RngCore) -> Se3 {
        let (lo, hi) = (&self.bounds.min_m, &self.bounds.max_m);
        let (u, v, w): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
        self.config(
            lo.x + u * (hi.x - lo.x),
            lo.y + v * (hi.y - lo.y),
            -PI + w * 2.0 * PI,
        )
    }

    fn sample_near(&self, centre: &Se3, sigma: f64, rng: &mut dyn RngCore) -> Se3 {
        let st = sigma / self.weights.translation.sqrt();
        let sr = sigma / self.weights.rotation.sqrt();
        let (nx, ny, nt): (f64, f64, f64) = (
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
        );
        let (x, y) = self.clamp_xy(centre.pos.x + st * nx, centre.pos.y + st * ny);
        self.config(x, y, wrap_angle(self.theta(centre) + sr * nt))
    }

    fn contains(&self, q: &Se3) -> bool {
        self.bounds
            .contains(&Vector3::new(q.pos.x, q.pos.y, self.z_m))
    }

    fn delta(&self, from: &Se3, to: &Se3) -> Vector6<f64> {
        let dt = self.delta_theta(from, to);
        Vector6::new(
            to.pos.x - from.pos.x,
            to.pos.y - from.pos.y,
            0.0,
            0.0,
            0.0,
            dt,
        )
    }

    fn project(&self, q: &Se3) -> Se3 {
        self.config(q.pos.x, q.pos.y, self.theta(q))
    }

    fn embed(&self, q: &Se3) -> Option<Embedded> {
        // (√w_t·x, √w_t·y, √w_r·cos θ, √w_r·sin θ): the chord 2·sin(|Δθ|/2) of the unit
        // circle is at most the wrapped |Δθ|, and z is the same for every configuration.
        // cos θ and sin θ straight from the quaternion (w, k) = (cos θ/2, sin θ/2) of
        // `theta`, normalised as its atan2 is: no trigonometry.
        let (t, r) = (
            self.weights.translation.sqrt(),
            self.weights.rotation.sqrt(),
        );
        let (w, k) = self.half_angle(q);
        let n = w * w + k * k;
        let (c, s) = if n > 0.0 {
            ((w * w - k * k) / n, 2.0 * w * k / n)
        } else {
            (1.0, 0.0)
        };
        Some([t * q.pos.x, t * q.pos.y, r * c, r * s, 0.0, 0.0, 0.0])
    }

    fn embed_terms(&self) -> EmbedTerms {
        EmbedTerms {
            split: 2,
            combine: self.weights.combine,
        }
    }
}

/// The configuration space of a scene: SE(3) or planar.
#[derive(Clone, Debug, PartialEq)]
pub enum Space {
    /// Free-flying rigid object.
    Se3(Se3Space),
    /// Planar (x, y, θ).
    Planar(PlanarSpace),
}

impl Space {
    /// The space `scene.space` asks for, with `weights`.
    pub fn for_scene(scene: &Scene, weights: Weights) -> Self {
        match scene.space {
            SpaceKind::Se3 => Space::Se3(Se3Space::new(scene.bounds, weights)),
            SpaceKind::Planar => {
                Space::Planar(PlanarSpace::new(scene.bounds, weights, &scene.start))
            }
        }
    }

    /// Bounds of the reference point (m, scene frame).
    pub fn bounds(&self) -> &Bounds {
        match self {
            Space::Se3(s) => &s.bounds,
            Space::Planar(s) => &s.bounds,
        }
    }

    /// The geodesic from `a` to `b` ([`ConfigSpace::interpolate`] at any `t`, with the
    /// per-edge work done once: edge validation samples many points of one edge).
    pub fn geodesic(&self, a: &Se3, b: &Se3) -> super::Geodesic {
        match self {
            Space::Se3(_) => super::Geodesic::se3(a, b),
            Space::Planar(s) => s.geodesic(a, b),
        }
    }

    fn inner(&self) -> &dyn ConfigSpace {
        match self {
            Space::Se3(s) => s,
            Space::Planar(s) => s,
        }
    }
}

impl ConfigSpace for Space {
    fn distance(&self, a: &Se3, b: &Se3) -> f64 {
        self.inner().distance(a, b)
    }
    fn interpolate(&self, a: &Se3, b: &Se3, t: f64) -> Se3 {
        self.inner().interpolate(a, b, t)
    }
    fn sample_uniform(&self, rng: &mut dyn RngCore) -> Se3 {
        self.inner().sample_uniform(rng)
    }
    fn sample_near(&self, centre: &Se3, sigma: f64, rng: &mut dyn RngCore) -> Se3 {
        self.inner().sample_near(centre, sigma, rng)
    }
    fn contains(&self, q: &Se3) -> bool {
        self.inner().contains(q)
    }
    fn delta(&self, from: &Se3, to: &Se3) -> Vector6<f64> {
        self.inner().delta(from, to)
    }
    fn distance_below(&self, a: &Se3, b: &Se3, bound: f64) -> Option<f64> {
        self.inner().distance_below(a, b, bound)
    }
    fn project(&self, q: &Se3) -> Se3 {
        self.inner().project(q)
    }
    fn embed(&self, q: &Se3) -> Option<Embedded> {
        self.inner().embed(q)
    }
    fn embed_mirror(&self, q: &Se3) -> Option<Embedded> {
        self.inner().embed_mirror(q)
    }
    fn embed_terms(&self) -> EmbedTerms {
        self.inner().embed_terms()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn space() -> PlanarSpace {
        let s = Scene::maze();
        PlanarSpace::new(s.bounds, Weights::default(), &s.start)
    }

    #[test]
    fn theta_round_trips_and_wraps() {
        let s = space();
        for th in [-3.0, -1.0, 0.0, 0.5, 3.1] {
            assert!((s.theta(&s.config(0.1, 0.2, th)) - th).abs() < 1e-12);
        }
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-0.5 - 2.0 * PI) + 0.5).abs() < 1e-12);
        // Across ±π the short way round.
        let (a, b) = (s.config(0.0, 0.0, 3.0), s.config(0.0, 0.0, -3.0));
        let d = s.distance(&a, &b);
        assert!((d - 0.1 * (2.0 * PI - 6.0)).abs() < 1e-9, "{d}");
        let m = s.interpolate(&a, &b, 0.5);
        assert!((s.theta(&m).abs() - PI).abs() < 1e-9);
    }

    #[test]
    fn samples_are_planar_in_bounds_and_seeded() {
        let s = space();
        let (mut r1, mut r2) = (ChaCha8Rng::seed_from_u64(3), ChaCha8Rng::seed_from_u64(3));
        for _ in 0..200 {
            let (u, v) = (s.sample_uniform(&mut r1), s.sample_uniform(&mut r2));
            assert_eq!(u, v);
            assert!(s.contains(&u) && u.pos.z == s.z_m);
            let axis = (u.rot * s.tilt.inverse()).axis();
            assert!(axis.is_none_or(|a| a.z.abs() > 1.0 - 1e-9));
            let n = s.sample_near(&u, 0.05, &mut r1);
            assert_eq!(n, s.sample_near(&v, 0.05, &mut r2));
            assert!(s.contains(&n) && n.pos.z == s.z_m);
            assert!(s.distance(&s.project(&n), &n) < 1e-12);
        }
    }

    #[test]
    fn delta_and_metric() {
        let s = space();
        let a = s.config(0.0, 0.0, 0.0);
        let b = s.config(0.3, 0.4, 1.0);
        assert!((s.distance(&a, &b) - (0.25f64 + 0.01).sqrt()).abs() < 1e-12);
        let d = s.delta(&a, &b);
        assert!((d - Vector6::new(0.3, 0.4, 0.0, 0.0, 0.0, 1.0)).norm() < 1e-12);
        // Out-of-plane parts of a pose are ignored by project.
        let off = Se3::from_rpy(Vector3::new(0.1, 0.1, 0.3), 0.2, 0.0, 0.5);
        let p = s.project(&off);
        assert!(p.pos.z == s.z_m && (s.theta(&p) - 0.5).abs() < 0.05);
    }

    #[test]
    fn geodesic_matches_the_theta_formula() {
        // Reference: the interpolation by θ as first written (two atan2 per call).
        let s = space();
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let tilted = PlanarSpace::new(
            s.bounds,
            Weights::default(),
            &Se3::from_rpy(Vector3::new(0.0, 0.0, 0.02), 0.3, -0.2, 0.0),
        );
        for sp in [&s, &tilted] {
            for i in 0..500 {
                let a = sp.sample_uniform(&mut rng);
                let b = if i % 2 == 0 {
                    sp.sample_uniform(&mut rng)
                } else {
                    sp.config(
                        a.pos.x + 0.01,
                        a.pos.y,
                        wrap_angle(sp.theta(&a) + PI - 1e-6),
                    )
                };
                let (ta, tb) = (sp.theta(&a), sp.theta(&b));
                let dt = wrap_angle(tb - ta);
                let ddt = sp.delta_theta(&a, &b);
                assert!(
                    (ddt - dt).abs() < 1e-9 || (ddt.abs() - PI).abs() < 1e-9,
                    "{ddt} {dt}"
                );
                let g = sp.geodesic(&a, &b);
                assert!(sp.distance(&g.at(0.0), &a) < 1e-12);
                assert!(sp.distance(&g.at(1.0), &b) < 1e-9);
                for t in [0.1, 0.5, 0.77] {
                    let p = a.pos.lerp(&b.pos, t);
                    let want = sp.config(p.x, p.y, wrap_angle(ta + t * dt));
                    let got = sp.interpolate(&a, &b, t);
                    assert_eq!(got, g.at(t));
                    assert!(sp.distance(&got, &want) < 1e-9, "t = {t}");
                    assert!(got.pos.z == sp.z_m);
                    // Constant speed: the distance from a is t of the whole.
                    let d = sp.distance(&a, &b);
                    assert!((sp.distance(&a, &got) - t * d).abs() < 1e-9);
                }
            }
        }
    }

    #[test]
    fn embedding_bounds_the_metric_from_below() {
        let s = space();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let e = |q: &Se3| s.embed(q).expect("planar embeds");
        let mut tight = 0;
        for i in 0..2000 {
            let a = s.sample_uniform(&mut rng);
            // Near pairs too, and pairs across θ = ±π.
            let b = match i % 3 {
                0 => s.sample_uniform(&mut rng),
                1 => s.sample_near(&a, 0.01, &mut rng),
                _ => s.config(a.pos.x, a.pos.y, wrap_angle(s.theta(&a) + PI - 1e-3)),
            };
            let d = s.distance(&a, &b);
            let lb = e(&a)
                .iter()
                .zip(e(&b))
                .map(|(x, y)| (x - y) * (x - y))
                .sum::<f64>()
                .sqrt();
            assert!(lb <= d * (1.0 + 1e-12) + 1e-15, "{lb} > {d}");
            tight += usize::from(lb > 0.9 * d);
            let (c, sn) = (e(&a)[2] / 0.1, e(&a)[3] / 0.1);
            let th = s.theta(&a);
            assert!((c - th.cos()).abs() < 1e-12 && (sn - th.sin()).abs() < 1e-12);
        }
        // Not vacuous: most random pairs are bounded within 10 %.
        assert!(tight > 1000, "{tight}");
        assert_eq!(s.embed_mirror(&s.config(0.0, 0.0, 1.0)), None);
    }
}
