//! Obstacle-aligned orientations for machine samples: a narrow passage that is narrow in
//! orientation (a slot the object passes only square to it) is almost never hit by a
//! uniform rotation, but man-made scenes are built from parts whose faces are parallel.
//! Following the rotation growth of obstacle-based RRT (Rodriguez, Tang, Lien & Amato,
//! "An obstacle-based rapidly-exploring random tree", ICRA 2006), which turns the object
//! so that its edges line up with an obstacle's, a sample may take an orientation that
//! puts one of the object's part frames square to one of the obstacles' frames (any of
//! the 24 ways a frame can be turned onto another's axes), with a small Gaussian jitter.
//!
//! Frames used: a box's own axes; a mesh's modelling frame (the part's pose: CAD parts
//! are modelled square to their main faces; a mesh's principal axes would be swayed by
//! its tessellation); spheres have none.

use crate::space::uniform_rotation;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use rand::{Rng, RngCore};
use rand_distr::StandardNormal;
use scene::pose::{angle_between, exp_rotation};
use scene::{Part, Primitive, Scene};

/// Two candidate orientations closer than this (rad) are one.
const SAME_RAD: f64 = 1e-6;

/// The object orientations (scene frame) that put an object part's frame square to an
/// obstacle part's frame, without repeats.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AlignedOrientations {
    candidates: Vec<UnitQuaternion<f64>>,
}

impl AlignedOrientations {
    /// Every `O·g·P⁻¹` for obstacle frames `O`, object part frames `P` (relative to the
    /// object's reference frame) and the 24 rotations `g` of the cube. Empty when the
    /// scene has no framed obstacle or object part (spheres only).
    pub fn of(scene: &Scene) -> Self {
        let obstacle_frames: Vec<_> = scene.obstacles.iter().filter_map(frame).collect();
        let part_frames: Vec<_> = scene.moving_object.iter().filter_map(frame).collect();
        let cube = cube_rotations();
        let mut candidates: Vec<UnitQuaternion<f64>> = Vec::new();
        let known = |cs: &[UnitQuaternion<f64>], q: &UnitQuaternion<f64>| {
            cs.iter().any(|c| angle_between(c, q) < SAME_RAD)
        };
        for o in &obstacle_frames {
            for p in &part_frames {
                // A frame square to one already seen gives the same 24 candidates: skip
                // it (keeps many parallel obstacles cheap).
                if known(&candidates, &(o * p.inverse())) {
                    continue;
                }
                for g in &cube {
                    let q = o * g * p.inverse();
                    if !known(&candidates, &q) {
                        candidates.push(q);
                    }
                }
            }
        }
        AlignedOrientations { candidates }
    }

    /// The distinct candidate orientations.
    pub fn candidates(&self) -> &[UnitQuaternion<f64>] {
        &self.candidates
    }

    /// A candidate chosen uniformly, turned by a rotation vector of per-axis σ
    /// `jitter_rad`; a uniform rotation when there is no candidate.
    pub fn sample(&self, jitter_rad: f64, rng: &mut dyn RngCore) -> UnitQuaternion<f64> {
        if self.candidates.is_empty() {
            return uniform_rotation(rng);
        }
        let c = self.candidates[rng.random_range(0..self.candidates.len())];
        let n = Vector3::new(
            rng.sample::<f64, _>(StandardNormal),
            rng.sample::<f64, _>(StandardNormal),
            rng.sample::<f64, _>(StandardNormal),
        );
        exp_rotation(&(n * jitter_rad)) * c
    }
}

/// The frame a part's faces are square to, if it has one.
fn frame(part: &Part) -> Option<UnitQuaternion<f64>> {
    match part.primitive {
        Primitive::Box { .. } | Primitive::Mesh { .. } => Some(part.pose.rot),
        Primitive::Sphere { .. } => None,
    }
}

/// The 24 proper rotations that map the coordinate axes onto themselves (signed
/// permutation matrices of determinant +1).
fn cube_rotations() -> Vec<UnitQuaternion<f64>> {
    const PERMS: [[usize; 3]; 6] = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut out = Vec::with_capacity(24);
    for perm in PERMS {
        for signs in 0..8u32 {
            let mut m = Matrix3::zeros();
            for (row, &col) in perm.iter().enumerate() {
                m[(row, col)] = if signs & (1 << row) == 0 { 1.0 } else { -1.0 };
            }
            if m.determinant() > 0.0 {
                let r = Rotation3::from_matrix_unchecked(m);
                out.push(UnitQuaternion::from_rotation_matrix(&r));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn the_cube_has_24_distinct_rotations_that_keep_the_axes() {
        let g = cube_rotations();
        assert_eq!(g.len(), 24);
        for (i, a) in g.iter().enumerate() {
            for b in &g[i + 1..] {
                assert!(angle_between(a, b) > 0.5, "repeated rotation");
            }
            // Every axis goes onto an axis.
            for axis in [Vector3::x(), Vector3::y(), Vector3::z()] {
                let v = a * axis;
                let on_axis = v.iter().filter(|c| (c.abs() - 1.0).abs() < 1e-12).count();
                assert_eq!(on_axis, 1, "{v:?}");
            }
        }
    }

    #[test]
    fn an_axis_aligned_scene_gives_the_cube_and_a_rolled_plate_adds_its_own() {
        // Wall-hole: every obstacle and the object are axis aligned.
        let wall = AlignedOrientations::of(&Scene::wall_with_hole());
        assert_eq!(wall.candidates().len(), 24);
        // The bug trap's mouth plates are rolled 60° about x: 24 more, each square to them.
        let trap = Scene::bug_trap();
        let aligned = AlignedOrientations::of(&trap);
        assert_eq!(aligned.candidates().len(), 48);
        let roll = UnitQuaternion::from_euler_angles(std::f64::consts::FRAC_PI_3, 0.0, 0.0);
        assert!(
            aligned
                .candidates()
                .iter()
                .any(|c| angle_between(c, &roll) < 1e-9),
            "the rolled slot's own orientation is a candidate"
        );
    }

    #[test]
    fn samples_lie_near_a_candidate_by_about_the_jitter() {
        let aligned = AlignedOrientations::of(&Scene::bug_trap());
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let jitter = 0.01;
        let mut angles: Vec<f64> = (0..2000)
            .map(|_| {
                let q = aligned.sample(jitter, &mut rng);
                aligned
                    .candidates()
                    .iter()
                    .map(|c| angle_between(c, &q))
                    .fold(f64::INFINITY, f64::min)
            })
            .collect();
        angles.sort_by(f64::total_cmp);
        // |n|·σ with n a 3-D standard normal: median √(χ²₃ median) ≈ 1.54 σ.
        let median = angles[angles.len() / 2];
        assert!((median / jitter - 1.54).abs() < 0.1, "median {median}");
        assert!(angles[angles.len() - 1] < 6.0 * jitter);
        // No candidates (spheres only): a uniform rotation, so far from the identity's
        // neighbourhood most of the time.
        let none = AlignedOrientations::default();
        let far = (0..200)
            .filter(|_| {
                angle_between(&none.sample(jitter, &mut rng), &UnitQuaternion::identity()) > 0.5
            })
            .count();
        assert!(far > 180, "{far}");
    }
}
