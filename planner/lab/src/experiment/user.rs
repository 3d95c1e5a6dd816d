//! Simulated operators for the experiments, in lockstep with the planner (I-RRT §6): the
//! operator moves ε_v (weighted m) along a predetermined path per planner iteration.
//!
//! Two models:
//! - *pass-through* (I-RRT §5.2/§6: "we decided to let the user go through obstacles"):
//!   `q_user` is the path point itself, collisions or not.
//! - *contact-seeking* (our model of the H-RRT-C operator, who pushes the object against
//!   surfaces): the hand follows the path with a fixed per-run orientation error (a
//!   dexterity limit, Gaussian σ per axis); the avatar (proxy) moves to the hand when the
//!   hand's configuration is free, and otherwise only as far toward the hand as it stays
//!   free (turning first, then a share of the way), in contact, while the hand keeps
//!   pushing. The device's force holds the hand back: in contact the hand gets no
//!   farther than [`MAX_STRETCH_M`] from the proxy (the coupling's stretch at the arm's
//!   maximum force), so it waits at the obstacle instead of walking through it and
//!   reappearing behind it. In contact it reports the deepest contact's point and normal, the force
//!   `f_u = k·(hand − proxy)` (a virtual coupling of stiffness k) and the hand's motion Δp,
//!   as the haptic loop would. Feeling the contact, the operator straightens the object:
//!   each iteration in contact shrinks the orientation error by [`CORRECTION_PER_STEP`]
//!   (our assumption, the benefit of force feedback that H-RRT-C §V.B reports over a 6-D
//!   mouse; without it a simulated hand with a fixed error never enters a tight slot).

use nalgebra::{UnitQuaternion, Vector3};
use planner_core::collision::CollisionChecker;
use planner_core::sampling::{Contact, UserInput};
use planner_core::space::ConfigSpace;
use rand::{Rng, RngCore};
use rand_distr::StandardNormal;
use scene::Scene;
use scene::pose::{Se3, exp_rotation};

/// Coupling stiffness of the contact-seeking user (N/m, default 200: 1 cm of push is 2 N).
pub const COUPLING_N_PER_M: f64 = 200.0;

/// Maximum force the operator's device renders, N (the simulated arm's `max_force_n`).
pub const MAX_PUSH_N: f64 = 8.0;

/// Farthest the hand gets from the proxy while in contact, m: where the coupling's force
/// reaches [`MAX_PUSH_N`] (4 cm at the default stiffness).
pub const MAX_STRETCH_M: f64 = MAX_PUSH_N / COUPLING_N_PER_M;

/// Fraction of the orientation error the contact-seeking operator removes per iteration
/// in contact (0.01: the error halves in about 70 iterations of contact).
pub const CORRECTION_PER_STEP: f64 = 0.01;

/// A simulated operator. See the module docs.
#[derive(Clone, Debug)]
pub struct SimUser {
    keyframes: Vec<Se3>,
    arc: Vec<f64>,
    s: f64,
    eps_v: f64,
    /// Orientation error (contact-seeking model), `None` for pass-through.
    error: Option<UnitQuaternion<f64>>,
    proxy: Se3,
    prev_hand: Se3,
    /// Iterations spent in contact.
    pub contact_iterations: u64,
}

impl SimUser {
    /// A pass-through user moving `eps_v` weighted m per iteration along `keyframes`
    /// (interpolated in `space`).
    pub fn pass_through(space: &dyn ConfigSpace, keyframes: Vec<Se3>, eps_v: f64) -> Self {
        let mut arc = vec![0.0];
        for w in keyframes.windows(2) {
            let last = arc.last().copied().unwrap_or(0.0);
            arc.push(last + space.distance(&w[0], &w[1]));
        }
        let first = keyframes.first().copied().unwrap_or_else(Se3::identity);
        SimUser {
            keyframes,
            arc,
            s: 0.0,
            eps_v,
            error: None,
            proxy: first,
            prev_hand: first,
            contact_iterations: 0,
        }
    }

    /// A contact-seeking user whose orientation error is drawn from `rng` (σ in rad per
    /// axis).
    pub fn contact_seeking(
        space: &dyn ConfigSpace,
        keyframes: Vec<Se3>,
        eps_v: f64,
        error_sigma_rad: f64,
        rng: &mut dyn RngCore,
    ) -> Self {
        let mut u = Self::pass_through(space, keyframes, eps_v);
        let w = Vector3::new(
            rng.sample::<f64, _>(StandardNormal),
            rng.sample::<f64, _>(StandardNormal),
            rng.sample::<f64, _>(StandardNormal),
        ) * error_sigma_rad;
        u.error = Some(exp_rotation(&w));
        u
    }

    /// The path point at arc length `s` (weighted m), clamped to the ends.
    fn at(&self, space: &dyn ConfigSpace, s: f64) -> Se3 {
        let n = self.keyframes.len();
        if n == 0 {
            return Se3::identity();
        }
        let i = self.arc.partition_point(|&a| a <= s).clamp(1, n.max(2) - 1);
        if n == 1 {
            return self.keyframes[0];
        }
        let (a, b) = (self.arc[i - 1], self.arc[i]);
        let t = if b > a {
            ((s - a) / (b - a)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        space.interpolate(&self.keyframes[i - 1], &self.keyframes[i], t)
    }

    /// Advances one iteration and returns the input the planner sees.
    pub fn step(&mut self, space: &dyn ConfigSpace, checker: &CollisionChecker) -> UserInput {
        let Some(err) = self.error else {
            self.s += self.eps_v;
            return UserInput::free(self.at(space, self.s));
        };
        let hand_at = |s: f64| {
            let on_path = self.at(space, s);
            space.project(&Se3::new(on_path.pos, err * on_path.rot))
        };
        let mut hand = hand_at(self.s + self.eps_v);
        if !checker.is_free(&hand) && (hand.pos - self.proxy.pos).norm() > MAX_STRETCH_M {
            // Held back by the device: the hand stays where it is (it may still turn).
            hand = hand_at(self.s);
        } else {
            self.s += self.eps_v;
        }
        let dp = hand.pos - self.prev_hand.pos;
        self.prev_hand = hand;
        if checker.is_free(&hand) {
            self.proxy = hand;
            return UserInput::free(hand);
        }
        self.follow(space, checker, &hand);
        let contact = checker
            .deepest_contact(&hand)
            .map(|(point, normal, _)| Contact {
                point_m: point,
                normal,
                force_n: COUPLING_N_PER_M * (hand.pos - self.proxy.pos),
                displacement_m: dp,
                proxy: self.proxy,
            });
        if contact.is_some() {
            self.contact_iterations += 1;
            self.error = Some(err.slerp(&UnitQuaternion::identity(), CORRECTION_PER_STEP));
        }
        UserInput {
            contact,
            ..UserInput::free(self.proxy)
        }
    }

    /// Moves the proxy toward a hand that is in collision as far as it stays free, like the
    /// haptic loop's proxy: first it turns to the hand's orientation where it is, then it
    /// takes the largest of 1/2, 1/4, … 1/64 of the way to the hand that is free.
    fn follow(&mut self, space: &dyn ConfigSpace, checker: &CollisionChecker, hand: &Se3) {
        let turned = Se3::new(self.proxy.pos, hand.rot);
        if checker.is_free(&turned) {
            self.proxy = turned;
        }
        let mut t = 0.5;
        for _ in 0..6 {
            let q = space.interpolate(&self.proxy, hand, t);
            if checker.is_free(&q) {
                self.proxy = q;
                return;
            }
            t *= 0.5;
        }
    }

    /// Arc length travelled (weighted m) and the path's total length.
    pub fn progress(&self) -> (f64, f64) {
        (self.s, self.arc.last().copied().unwrap_or(0.0))
    }
}

/// The predetermined operator path of a scene: start, its route's steps, goal (scene
/// frame; see [`Scene::operator_route`]). The lockstep operators ignore the route's press
/// forces and dwells.
pub fn keyframes(scene: &Scene) -> Vec<Se3> {
    scene.operator_route().iter().map(|s| s.pose).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use planner_core::space::{Space, Weights};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn operator_paths_are_free_densely_and_run_start_to_goal() {
        for name in scene::BUILTIN_NAMES {
            let scene = Scene::builtin(name).expect("scene");
            let c = CollisionChecker::new(&scene);
            let k = keyframes(&scene);
            let space = Space::for_scene(&scene, Weights::default());
            assert!(space.distance(&k[0], &scene.start) < 1e-9, "{name} start");
            assert!(
                space.distance(&k[k.len() - 1], &scene.goal) < 1e-9,
                "{name} goal"
            );
            for (i, w) in k.windows(2).enumerate() {
                assert!(c.edge_free(&w[0], &w[1]), "{name}: segment {i} collides");
            }
        }
    }

    #[test]
    fn users_advance_eps_per_iteration_and_report_contact() {
        let scene = Scene::crossing_planes();
        let c = CollisionChecker::new(&scene);
        let space = Space::for_scene(&scene, Weights::default());
        let k = keyframes(&scene);
        let mut u = SimUser::pass_through(&space, k.clone(), 0.01);
        let a = u.step(&space, &c).q_user;
        let b = u.step(&space, &c).q_user;
        assert!((space.distance(&a, &b) - 0.01).abs() < 1e-9);
        // A 0.3 rad error cannot pass the 14 mm slit: contact with a normal and a push.
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut u = SimUser::contact_seeking(&space, k, 0.002, 0.3, &mut rng);
        let mut contacts = 0;
        for _ in 0..400 {
            let inp = u.step(&space, &c);
            if let Some(ct) = inp.contact {
                contacts += 1;
                assert!((ct.normal.norm() - 1.0).abs() < 1e-9);
                assert!(c.is_free(&inp.q_user) && inp.q_user == ct.proxy);
            }
        }
        assert!(contacts > 0 && u.contact_iterations == contacts);
    }

    #[test]
    fn the_device_holds_the_hand_at_the_slit_until_the_object_is_straight() {
        let scene = Scene::crossing_planes();
        let c = CollisionChecker::new(&scene);
        let space = Space::for_scene(&scene, Weights::default());
        let k = keyframes(&scene);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut u = SimUser::contact_seeking(&space, k, 0.002, 0.3, &mut rng);
        // The first slabs' front face is at x = −0.25 m; the slit ends at x = −0.08 m.
        let mut first_contact_x = None;
        let mut passed = false;
        for _ in 0..3000 {
            let inp = u.step(&space, &c);
            assert!(c.is_free(&inp.q_user));
            if let Some(ct) = inp.contact {
                first_contact_x.get_or_insert(ct.proxy.pos.x);
                // Pushing: the hand is ahead of the proxy by at most the stretch at the
                // device's maximum force.
                assert!(
                    ct.force_n.norm() <= MAX_PUSH_N + 1e-9,
                    "{}",
                    ct.force_n.norm()
                );
            }
            // The proxy never jumps through the slabs: it enters the slit straight.
            if inp.q_user.pos.x > -0.25 && inp.q_user.pos.x < -0.08 {
                let tilt = inp.q_user.rot.angle_to(&UnitQuaternion::identity());
                assert!(tilt < 0.06, "in the slit {tilt} rad off");
            }
            passed |= inp.q_user.pos.x > -0.05;
        }
        let x0 = first_contact_x.expect("0.3 rad off cannot enter the slit at once");
        assert!(x0 < -0.25 + 1e-3, "first contact at x = {x0}");
        assert!(passed, "the straightened object passed the slit");
    }
}
