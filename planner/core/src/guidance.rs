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

/// Whether the object can move in a straight line from the first configuration to the
/// second (for guidance: see [`crate::CollisionChecker::reachable_from_contact`]).
pub type Reach<'a> = dyn Fn(&Se3, &Se3) -> bool + 'a;

/// F_a from the `p` nodes of `tree` nearest to `q_user` (see the module docs).
/// `scratch` is reused for the neighbour list. With `reach`, only the neighbours that
/// `reach(q_user, node)` says can be reached in a straight line count (the force rendered
/// to the operator: never towards nodes behind a wall); without, all of them (I-RRT's
/// F_a, as its POS sampler uses it). Zero when the weights vanish.
pub fn barycenter_force(
    space: &dyn ConfigSpace,
    tree: &Tree,
    q_user: &Se3,
    p: usize,
    epsilon: f64,
    scratch: &mut Vec<(NodeId, f64)>,
    reach: Option<&Reach<'_>>,
) -> Vector6<f64> {
    tree.k_nearest_into(space, q_user, p, scratch);
    let mut sum = Vector6::zeros();
    let mut total = 0.0;
    for &(id, _) in scratch.iter() {
        if reach.is_some_and(|r| !r(q_user, &tree.node(id).config)) {
            continue;
        }
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

    /// F_a along the path: towards `L`, the path point `lookahead` weighted m further
    /// along the path than the anchor (clamped at the goal, and drawn back towards the
    /// anchor while `L` itself cannot be reached), with a length of at most `lookahead`:
    /// `delta(q_user, L)`, scaled down when longer. Zero for an empty path, and zero when
    /// no candidate anchor can be reached: guidance never pulls through a wall.
    ///
    /// The anchor is the furthest-along path point, among the candidates, that
    /// `reach(q_user, point)` says can be reached in a straight line. The candidates are
    /// the local minima of the distance along the path within [`GUIDANCE_RADIUS`] (each
    /// stretch that passes by the operator offers its nearest point) and the goal, tried
    /// furthest along first, at most [`MAX_ANCHOR_TRIES`] of them.
    ///
    /// Why (our choice; the papers only say the force follows the path): the point nearest
    /// in configuration space can lie beyond an obstacle (the path goes round a wall the
    /// operator is pressed against), and a pull towards it holds a yielding operator
    /// against the wall; and an operator who has left the path for a free shortcut (it
    /// found its own way round) must not be pulled back to where the path was. The bounded
    /// length keeps guidance a hint of one step whatever the distance. A stretch whose
    /// nearest point is occluded is passed over even if some other point of it could be
    /// reached: conservative, never through a wall.
    pub fn force(
        &self,
        space: &dyn ConfigSpace,
        q_user: &Se3,
        lookahead: f64,
        reach: &Reach<'_>,
    ) -> Vector6<f64> {
        let lookahead = lookahead.max(0.0);
        let d: Vec<f64> = self
            .points
            .iter()
            .map(|q| space.distance(q, q_user))
            .collect();
        let n = d.len();
        let near = |i: usize| d[i] <= GUIDANCE_RADIUS; // false for NaN
        let mut candidates: Vec<usize> = (0..n)
            .filter(|&i| {
                near(i)
                    && (i == 0 || d[i] <= d[i - 1] || d[i - 1].is_nan())
                    && (i + 1 == n || d[i] < d[i + 1] || d[i + 1].is_nan())
            })
            .collect();
        if n > 0 && near(n - 1) && candidates.last() != Some(&(n - 1)) {
            candidates.push(n - 1);
        }
        // Furthest along first (the points are in path order).
        let anchor = candidates
            .into_iter()
            .rev()
            .take(MAX_ANCHOR_TRIES)
            .find(|&i| reach(q_user, &self.points[i]));
        let Some(i) = anchor else {
            return Vector6::zeros();
        };
        let target = self.arc[i] + lookahead;
        let mut j = self
            .arc
            // 1 nm of slack: arc lengths summed in floating point land just short.
            .partition_point(|&a| a < target - 1e-9)
            .min(n - 1);
        // Back towards the anchor (reachable) by halves until the target is reachable too.
        while j > i && !reach(q_user, &self.points[j]) {
            j = i + (j - i) / 2;
        }
        let delta = space.delta(q_user, &self.points[j]);
        let length = space.distance(q_user, &self.points[j]);
        if length > lookahead {
            delta * (lookahead / length)
        } else {
            delta
        }
    }
}

/// Candidate anchors (stretches of the path) [`PathGuide::force`] checks for reachability
/// before it gives up.
pub const MAX_ANCHOR_TRIES: usize = 8;

/// Path guidance looks for the path within this distance of the operator (weighted m: 25 cm
/// or 2.5 rad; five default lookaheads). Farther away it gives no pull: whether a far
/// point can be reached costs a check per edge resolution of the way, and pulling towards
/// a path that far is no longer a hint about the next step.
pub const GUIDANCE_RADIUS: f64 = 0.25;

/// How far from the operator's pose (weighted m) the reachability check of path guidance
/// starts: a proxy in contact touches or penetrates the surface (up to 1.5 mm at 1 mm
/// voxels in the live sessions), so the first 3 mm of the way to a path point are not
/// checked. Thinner than any wall of the built-in scenes, so a point behind a wall stays
/// unreachable.
pub const GUIDANCE_CONTACT_SKIP: f64 = 0.003;

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
        let f = barycenter_force(&s, &t, &Se3::identity(), 5, 0.05, &mut scratch, None);
        assert!(
            (f - Vector6::new(0.1, 0.0, 0.0, 0.0, 0.0, 0.0)).norm() < 1e-12,
            "{f}"
        );
        // From the other side the force flips sign.
        let f2 = barycenter_force(
            &s,
            &t,
            &Se3::from_xyz(0.2, 0.0, 0.0),
            5,
            0.05,
            &mut scratch,
            None,
        );
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
        let even = barycenter_force(&s, &t, &q, 5, 0.05, &mut scratch, None);
        assert!(even.norm() < 1e-12);
        t.labels_mut(NodeId(0)).distance_to_goal = 0.0; // weight 1/0.05 vs 1/0.1
        let f = barycenter_force(&s, &t, &q, 5, 0.05, &mut scratch, None);
        assert!((f.y - 0.1 / 3.0).abs() < 1e-12, "{f}");
        t.labels_mut(NodeId(0)).distance_to_goal = 0.05;
        let l = t.labels_mut(b);
        l.extension_attempts = 3;
        l.collisions = 3; // freedom 1/4
        let f = barycenter_force(&s, &t, &q, 5, 0.05, &mut scratch, None);
        assert!((f.y - 0.1 * 3.0 / 5.0).abs() < 1e-12, "{f}");
    }

    #[test]
    fn the_rendered_barycenter_leaves_out_nodes_it_cannot_reach() {
        let s = space();
        // Nodes at y = ±0.1; a wall between the operator and the +y one.
        let mut t = Tree::new(Se3::from_xyz(0.0, 0.1, 0.0), 0.05);
        t.add(NodeId(0), Se3::from_xyz(0.0, -0.1, 0.0), 0.05);
        let mut scratch = Vec::new();
        let q = Se3::identity();
        let not_up = |_: &Se3, b: &Se3| b.pos.y < 0.0;
        let f = barycenter_force(&s, &t, &q, 5, 0.05, &mut scratch, Some(&not_up));
        assert!(
            (f - Vector6::new(0.0, -0.1, 0.0, 0.0, 0.0, 0.0)).norm() < 1e-12,
            "{f}"
        );
        let none = |_: &Se3, _: &Se3| false;
        let f = barycenter_force(&s, &t, &q, 5, 0.05, &mut scratch, Some(&none));
        assert_eq!(f, Vector6::zeros());
    }

    #[test]
    fn rotation_part_is_the_rotation_vector() {
        let s = space();
        let rot = UnitQuaternion::from_euler_angles(0.0, 0.0, 0.2);
        let t = Tree::new(Se3::new(Vector3::zeros(), rot), 0.1);
        let f = barycenter_force(&s, &t, &Se3::identity(), 5, 0.05, &mut Vec::new(), None);
        assert!((f - Vector6::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.2)).norm() < 1e-12);
    }

    #[test]
    fn path_guide_leads_forward() {
        let s = space();
        let path = [
            Se3::from_xyz(-0.4, 0.0, 0.0),
            Se3::from_xyz(0.0, 0.0, 0.0),
            Se3::from_xyz(0.0, 0.4, 0.0),
        ];
        let g = PathGuide::new(&s, &path, 0.01);
        let free = |_: &Se3, _: &Se3| true;
        assert!((g.length() - 0.8).abs() < 1e-12);
        // On the path at x = −0.3, the corner and the goal out of reach: pulled 0.05
        // forward along +x.
        let f = g.force(&s, &Se3::from_xyz(-0.3, 0.0, 0.0), 0.05, &free);
        assert!(
            (f - Vector6::new(0.05, 0.0, 0.0, 0.0, 0.0, 0.0)).norm() < 1e-9,
            "{f}"
        );
        // Beside the path: pulled back towards it and forward, one lookahead long.
        let f = g.force(&s, &Se3::from_xyz(-0.3, 0.0, 0.03), 0.05, &free);
        assert!(
            f.x > 0.0 && f.z < 0.0 && (f.norm() - 0.05).abs() < 1e-9,
            "{f}"
        );
        // Near the corner the lookahead turns the corner.
        let f = g.force(&s, &Se3::from_xyz(0.0, 0.0, 0.0), 0.05, &free);
        assert!((f.y - 0.05).abs() < 1e-9 && f.x.abs() < 1e-9);
        // In free space the way to the second leg is a shortcut across the corner: from
        // (−0.1, 0.05, 0) the second leg's nearest point (0, 0.05) is 0.1 away, the goal
        // 0.36 away is beyond the radius; the pull aims a lookahead past (0, 0.05).
        let f = g.force(&s, &Se3::from_xyz(-0.1, 0.05, 0.0), 0.05, &free);
        assert!(
            f.x > 0.0 && f.y > 0.0 && (f.norm() - 0.05).abs() < 1e-9,
            "{f}"
        );
        // At the goal: stays at the goal; near it, pulled onto it by the distance left.
        assert!(g.force(&s, &path[2], 0.05, &free).norm() < 1e-12);
        let f = g.force(&s, &Se3::from_xyz(0.0, 0.39, 0.0), 0.05, &free);
        assert!(
            (f - Vector6::new(0.0, 0.01, 0.0, 0.0, 0.0, 0.0)).norm() < 1e-9,
            "{f}"
        );
        // Far from the path (beyond GUIDANCE_RADIUS): no pull.
        assert_eq!(
            g.force(&s, &Se3::from_xyz(-0.3, 0.0, 0.3), 0.05, &free),
            Vector6::zeros()
        );
    }

    #[test]
    fn path_guide_never_pulls_through_a_wall() {
        let s = space();
        // A U round a wall at x ∈ [0, 0.02], y < 0.25: up the left side, over, and down the
        // right side to end at x = 0.1.
        let path = [
            Se3::from_xyz(-0.2, 0.0, 0.0),
            Se3::from_xyz(-0.2, 0.3, 0.0),
            Se3::from_xyz(0.1, 0.3, 0.0),
            Se3::from_xyz(0.1, 0.0, 0.0),
        ];
        let g = PathGuide::new(&s, &path, 0.001);
        // Straight segments that cross the wall's slab below its top are blocked.
        let wall = |a: &Se3, b: &Se3| {
            let (pa, pb) = (a.pos, b.pos);
            (0..=100).all(|k| {
                let p = pa + (pb - pa) * (k as f64 / 100.0);
                !(p.x >= 0.0 && p.x <= 0.02 && p.y < 0.25)
            })
        };
        let unit = |f: Vector6<f64>| f / f.norm();
        // Pressed against the wall's left face: the right leg's nearest point, (0.1, 0, 0)
        // at 0.11 m and the goal, is behind the wall. Without reachability the pull goes
        // into the wall.
        let user = Se3::from_xyz(-0.01, 0.0, 0.0);
        let blind = g.force(&s, &user, 0.05, &|_: &Se3, _: &Se3| true);
        assert!((blind - Vector6::new(0.05, 0.0, 0.0, 0.0, 0.0, 0.0)).norm() < 1e-9);
        // With it: the anchor is the left leg's nearest point (−0.2, 0), the target one
        // lookahead up it: away from the wall and along the path.
        let f = g.force(&s, &user, 0.05, &wall);
        let towards = Vector6::new(-0.19, 0.05, 0.0, 0.0, 0.0, 0.0);
        assert!((unit(f) - unit(towards)).norm() < 0.01, "{f}");
        assert!((f.norm() - 0.05).abs() < 1e-9);
        // Above the wall the right leg is reachable: the pull cuts the corner onto it (to
        // the point a lookahead past its nearest (0.1, 0.28), within a resampling step).
        let f = g.force(&s, &Se3::from_xyz(0.06, 0.28, 0.0), 0.05, &wall);
        let towards = Vector6::new(0.04, -0.05, 0.0, 0.0, 0.0, 0.0);
        assert!((unit(f) - unit(towards)).norm() < 0.03, "{f}");
        // Nothing reachable: no pull at all.
        let f = g.force(&s, &user, 0.05, &|_: &Se3, _: &Se3| false);
        assert_eq!(f, Vector6::zeros());
    }
}
