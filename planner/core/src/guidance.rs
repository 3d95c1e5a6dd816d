//! The attractive pseudo-force F_a of I-RRT (Compute_Barycenter / Compute_FAlgo), and the
//! path-following guidance used once a solution exists.
//!
//! F_a is a 6-vector `(Δp (m), Δr (rad))` in the scene frame, as produced by
//! [`ConfigSpace::delta`]: `Δr` is a rotation vector. The haptic side scales it
//! (`F_s = k·F_a`, I-RRT eq. 3) into a wrench.
//!
//! Barycenter weighting (our choice; I-RRT only says the node labels are the weights):
//! `w_i = freedom_i / (ε + distance_label_i)`, where `distance_label_i` is the node's
//! weighted distance to the goal, `ε` (weighted m, default one extension step) bounds the
//! weight of nodes at the goal, and `freedom_i ∈ (0, 1]` (see `Labels::freedom`) falls as
//! extensions from the node collide. Nodes nearer the goal and in open space pull harder.
//! The barycenter is taken in the tangent space at `q_user`:
//! `F_a = Σ w_i·delta(q_user, q_i) / Σ w_i = delta(q_user, B)`.

use crate::space::ConfigSpace;
use crate::tree::{NodeId, Tree};
use nalgebra::Vector6;
use scene::pose::Se3;

/// F_a from the `p` nodes of `tree` nearest to `q_user` (see the module docs).
/// `scratch` is reused for the neighbour list. Zero when the weights vanish.
pub fn barycenter_force(
    space: &dyn ConfigSpace,
    tree: &Tree,
    q_user: &Se3,
    p: usize,
    epsilon: f64,
    scratch: &mut Vec<(NodeId, f64)>,
) -> Vector6<f64> {
    tree.k_nearest_into(space, q_user, p, scratch);
    let mut sum = Vector6::zeros();
    let mut total = 0.0;
    for &(id, _) in scratch.iter() {
        let labels = &tree.node(id).labels;
        let w = labels.freedom() / (epsilon + labels.distance_to_goal.max(0.0));
        if w.is_finite() && w > 0.0 {
            sum += w * space.delta(q_user, &tree.node(id).config);
            total += w;
        }
    }
    if total > 0.0 {
        sum / total
    } else {
        Vector6::zeros()
    }
}

/// A solution path resampled densely, with cumulative arc length, for path following.
#[derive(Clone, Debug)]
pub struct PathGuide {
    points: Vec<Se3>,
    arc: Vec<f64>,
}

impl PathGuide {
    /// Resamples `path` (waypoints, start → goal) every `resolution` weighted m (> 0).
    pub fn new(space: &dyn ConfigSpace, path: &[Se3], resolution: f64) -> Self {
        let mut points = Vec::new();
        let mut arc = Vec::new();
        if let Some(first) = path.first() {
            points.push(*first);
            arc.push(0.0);
        }
        for w in path.windows(2) {
            let d = space.distance(&w[0], &w[1]);
            let n = (d / resolution).ceil().max(1.0) as usize;
            let s0 = arc.last().copied().unwrap_or(0.0);
            for k in 1..=n {
                let t = k as f64 / n as f64;
                points.push(if k == n {
                    w[1]
                } else {
                    space.interpolate(&w[0], &w[1], t)
                });
                arc.push(s0 + d * t);
            }
        }
        PathGuide { points, arc }
    }

    /// Total length (weighted m).
    pub fn length(&self) -> f64 {
        self.arc.last().copied().unwrap_or(0.0)
    }

    /// F_a along the path: `delta(q_user, L)` where `L` is the path point `lookahead`
    /// weighted m further along the path than the path point nearest to `q_user`
    /// (clamped at the goal). Off the path it pulls back and forward at once; at the goal
    /// it pulls onto the goal. Zero for an empty path.
    pub fn force(&self, space: &dyn ConfigSpace, q_user: &Se3, lookahead: f64) -> Vector6<f64> {
        let mut best = (0, f64::INFINITY);
        for (i, q) in self.points.iter().enumerate() {
            let d = space.distance(q, q_user);
            if d < best.1 {
                best = (i, d);
            }
        }
        let Some(&s) = self.arc.get(best.0) else {
            return Vector6::zeros();
        };
        let target = s + lookahead.max(0.0);
        let j = self
            .arc
            .partition_point(|&a| a < target)
            .min(self.points.len() - 1);
        space.delta(q_user, &self.points[j])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::space::{Se3Space, Weights};
    use nalgebra::{UnitQuaternion, Vector3};
    use scene::Scene;

    fn space() -> Se3Space {
        Se3Space::new(Scene::wall_with_hole().bounds, Weights::default())
    }

    #[test]
    fn force_points_to_nearby_nodes() {
        let s = space();
        // Root and four nodes around x = 0.1; equal labels: a plain mean.
        let mut t = Tree::new(Se3::from_xyz(0.1, 0.0, 0.0), 0.5);
        for (y, z) in [(0.01, 0.0), (-0.01, 0.0), (0.0, 0.01), (0.0, -0.01)] {
            t.add(NodeId(0), Se3::from_xyz(0.1, y, z), 0.5);
        }
        t.add(NodeId(0), Se3::from_xyz(-0.2, 0.0, 0.0), 0.5); // far: not among the 5
        let mut scratch = Vec::new();
        let f = barycenter_force(&s, &t, &Se3::identity(), 5, 0.05, &mut scratch);
        assert!(
            (f - Vector6::new(0.1, 0.0, 0.0, 0.0, 0.0, 0.0)).norm() < 1e-12,
            "{f}"
        );
        // From the other side the force flips sign.
        let f2 = barycenter_force(&s, &t, &Se3::from_xyz(0.2, 0.0, 0.0), 5, 0.05, &mut scratch);
        assert!((f2.x + 0.1).abs() < 1e-12);
    }

    #[test]
    fn labels_weight_the_barycenter() {
        let s = space();
        // Two nodes at y = ±0.1; the +y one is nearer the goal, the −y one collided.
        let mut t = Tree::new(Se3::from_xyz(0.0, 0.1, 0.0), 0.05);
        let b = t.add(NodeId(0), Se3::from_xyz(0.0, -0.1, 0.0), 0.05);
        let mut scratch = Vec::new();
        let q = Se3::identity();
        let even = barycenter_force(&s, &t, &q, 5, 0.05, &mut scratch);
        assert!(even.norm() < 1e-12);
        t.labels_mut(NodeId(0)).distance_to_goal = 0.0; // weight 1/0.05 vs 1/0.1
        let f = barycenter_force(&s, &t, &q, 5, 0.05, &mut scratch);
        assert!((f.y - 0.1 / 3.0).abs() < 1e-12, "{f}");
        t.labels_mut(NodeId(0)).distance_to_goal = 0.05;
        let l = t.labels_mut(b);
        l.extension_attempts = 3;
        l.collisions = 3; // freedom 1/4
        let f = barycenter_force(&s, &t, &q, 5, 0.05, &mut scratch);
        assert!((f.y - 0.1 * 3.0 / 5.0).abs() < 1e-12, "{f}");
    }

    #[test]
    fn rotation_part_is_the_rotation_vector() {
        let s = space();
        let rot = UnitQuaternion::from_euler_angles(0.0, 0.0, 0.2);
        let t = Tree::new(Se3::new(Vector3::zeros(), rot), 0.1);
        let f = barycenter_force(&s, &t, &Se3::identity(), 5, 0.05, &mut Vec::new());
        assert!((f - Vector6::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.2)).norm() < 1e-12);
    }

    #[test]
    fn path_guide_leads_forward() {
        let s = space();
        let path = [
            Se3::from_xyz(-0.2, 0.0, 0.0),
            Se3::from_xyz(0.0, 0.0, 0.0),
            Se3::from_xyz(0.0, 0.2, 0.0),
        ];
        let g = PathGuide::new(&s, &path, 0.01);
        assert!((g.length() - 0.4).abs() < 1e-12);
        // On the path at x = −0.1: pulled 0.05 forward along +x.
        let f = g.force(&s, &Se3::from_xyz(-0.1, 0.0, 0.0), 0.05);
        assert!(
            (f - Vector6::new(0.05, 0.0, 0.0, 0.0, 0.0, 0.0)).norm() < 1e-9,
            "{f}"
        );
        // Beside the path: pulled back towards it and forward.
        let f = g.force(&s, &Se3::from_xyz(-0.1, 0.0, 0.03), 0.05);
        assert!(f.x > 0.0 && f.z < 0.0);
        // Near the corner the lookahead turns the corner.
        let f = g.force(&s, &Se3::from_xyz(0.0, 0.0, 0.0), 0.05);
        assert!((f.y - 0.05).abs() < 1e-9 && f.x.abs() < 1e-9);
        // At the goal: stays at the goal.
        assert!(g.force(&s, &path[2], 0.05).norm() < 1e-12);
    }
}
