//! The attractive pseudo-force F_a of I-RRT (Compute_Barycenter / Compute_FAlgo) before a
//! solution exists, and the guidance that leads the operator along the solution path once
//! one does ([`PathGuide::force`]: a spring towards a carrot ahead on the path, force and
//! torque, saturating at [`Lead`]'s caps).
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
use nalgebra::{Vector3, Vector6};
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

    /// The path point the guidance leads to from `q_user` (its index), or `None` when
    /// the operator is farther than [`GUIDANCE_RADIUS`] from the path or can reach none
    /// of it in a straight line. See [`PathGuide::force`].
    pub fn carrot(
        &self,
        space: &dyn ConfigSpace,
        q_user: &Se3,
        lookahead: f64,
        reach: &Reach<'_>,
    ) -> Option<usize> {
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
            .iter()
            .rev()
            .take(MAX_ANCHOR_TRIES)
            .copied()
            .find(|&i| reach(q_user, &self.points[i]));
        let Some(i) = anchor else {
            // Nothing near can be reached straight (pressed against a wall, the path's
            // nearest stretch beyond it or at an orientation that cannot turn there): back
            // along the path from its nearest point to where the operator can go.
            let nearest = candidates
                .iter()
                .copied()
                .min_by(|&a, &b| d[a].total_cmp(&d[b]))?;
            return self.back_off(q_user, nearest, reach);
        };
        let target = self.arc[i] + lookahead;
        let mut j = self
            .arc
            // 1 nm of slack: arc lengths summed in floating point land just short.
            .partition_point(|&a| a < target - 1e-9)
            .min(n - 1);
        // Back towards the anchor (reachable) by halves until the carrot is reachable too.
        while j > i && !reach(q_user, &self.points[j]) {
            j = i + (j - i) / 2;
        }
        Some(j)
    }

    /// The furthest reachable path point before `nearest` (unreachable): points
    /// [`BACK_OFF_FIRST`] · 2^k weighted m back along the path (k < [`BACK_OFF_TRIES`]),
    /// then [`BACK_OFF_REFINE`] halvings between the first reachable one and `nearest`.
    fn back_off(&self, q_user: &Se3, nearest: usize, reach: &Reach<'_>) -> Option<usize> {
        let index_at = |s: f64| self.arc.partition_point(|&a| a < s - 1e-9);
        let mut hi = nearest;
        let mut lo = None;
        for k in 0..BACK_OFF_TRIES {
            let s = self.arc[nearest] - BACK_OFF_FIRST * f64::from(1u32 << k);
            let j = index_at(s.max(0.0)).min(hi);
            if j < hi && reach(q_user, &self.points[j]) {
                lo = Some(j);
                break;
            }
            hi = j;
            if s <= 0.0 {
                break;
            }
        }
        let mut lo = lo?;
        let mut hi = hi.max(lo);
        for _ in 0..BACK_OFF_REFINE {
            let mid = lo + (hi - lo) / 2;
            if mid == lo {
                break;
            }
            if reach(q_user, &self.points[mid]) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Some(lo)
    }

    /// F_a after a solution: the guidance that leads the operator along the path.
    ///
    /// - **Carrot** ([`PathGuide::carrot`]): the anchor is the furthest-along path point,
    ///   among the candidates, that `reach(q_user, point)` says can be reached in a
    ///   straight line; the candidates are the local minima of the (weighted) distance
    ///   along the path within [`GUIDANCE_RADIUS`] (each stretch that passes by the
    ///   operator offers its nearest point) and the goal, tried furthest along first, at
    ///   most [`MAX_ANCHOR_TRIES`] of them. The carrot is `lead.lookahead` weighted m
    ///   further along the path than the anchor (clamped at the goal), drawn back towards
    ///   the anchor by halves while it cannot be reached. When no candidate can be
    ///   reached (the operator pressed against a wall, the path going on beyond it or at
    ///   an orientation that cannot turn where the operator is), the carrot is the
    ///   furthest reachable path point *before* the nearest candidate: the way back to
    ///   where the path can be followed. As the operator follows, its nearest point moves
    ///   along the path and the carrot with it.
    /// - **Pull** (force part, m): towards the carrot's position, `Δp` of
    ///   `delta(q_user, carrot)`, its length capped at `lead.saturation_m`.
    /// - **Turn** (torque part, rad): the rotation vector from the operator's orientation to
    ///   the carrot's (scene frame), its angle capped at `lead.saturation_rad`.
    ///
    /// The haptic loop renders `k·F_a`; the planner publishes the path's guidance with
    /// gains that make the caps a stated force and torque (`planner serve --lead-force-n`,
    /// `--lead-torque-nm`), so the guidance is a spring towards the carrot that
    /// saturates there. Zero for an empty path, far from it, or when nothing of it can be
    /// reached: guidance never pulls through a wall.
    ///
    /// Why (our choice; the papers only say the force follows the path): the path point
    /// nearest in configuration space can lie beyond an obstacle (the path goes round a
    /// wall the operator is pressed against), and a pull towards it holds a yielding
    /// operator against the wall; an operator who has left the path for a free shortcut
    /// must not be pulled back to where the path was; and a stuck operator must feel
    /// enough to be led (the earlier guidance was capped at one lookahead of the weighted
    /// metric: at most 1 N at k = 20 N/m, less when part of it was rotation, and
    /// 0.05 N·m/rad·θ of torque).
    pub fn force(
        &self,
        space: &dyn ConfigSpace,
        q_user: &Se3,
        lead: &Lead,
        reach: &Reach<'_>,
    ) -> Vector6<f64> {
        let Some(j) = self.carrot(space, q_user, lead.lookahead, reach) else {
            return Vector6::zeros();
        };
        let delta = space.delta(q_user, &self.points[j]);
        let cap = |v: Vector3<f64>, max: f64| {
            let n = v.norm();
            if n > max && n > 0.0 { v * (max / n) } else { v }
        };
        let p = cap(delta.fixed_rows::<3>(0).into(), lead.saturation_m.max(0.0));
        let r = cap(
            delta.fixed_rows::<3>(3).into(),
            lead.saturation_rad.max(0.0),
        );
        Vector6::new(p.x, p.y, p.z, r.x, r.y, r.z)
    }

    /// The resampled path points (start → goal).
    pub fn points(&self) -> &[Se3] {
        &self.points
    }

    /// Arc length of each point from the start (weighted m).
    pub fn arc(&self) -> &[f64] {
        &self.arc
    }
}

/// How the path's guidance leads ([`PathGuide::force`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lead {
    /// How far along the path the carrot runs ahead of the operator's anchor, weighted m.
    pub lookahead: f64,
    /// Length of the pull's displacement at which it saturates, m.
    pub saturation_m: f64,
    /// Angle of the turn at which it saturates, rad.
    pub saturation_rad: f64,
}

/// Candidate anchors (stretches of the path) [`PathGuide::carrot`] checks for
/// reachability before it backs off along the path.
pub const MAX_ANCHOR_TRIES: usize = 8;

/// Backing off from an unreachable path: the first step back along the path, weighted m.
pub const BACK_OFF_FIRST: f64 = 0.01;

/// Backing off: steps back tried, each twice the one before (0.01 to 0.32 weighted m).
pub const BACK_OFF_TRIES: u32 = 6;

/// Backing off: halvings towards the unreachable point once a reachable one is found.
pub const BACK_OFF_REFINE: u32 = 3;

/// Path guidance looks for the path within this distance of the operator (weighted m: 25 cm
/// or 2.5 rad). Farther away it gives no pull: whether a far point can be reached costs a
/// check per edge resolution of the way, and pulling towards a path that far is no longer
/// a hint about the next step.
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
    use crate::space::Se3Space;
    use crate::space::tests::space;
    use nalgebra::{UnitQuaternion, Vector3};

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

    const LEAD: Lead = Lead {
        lookahead: 0.1,
        saturation_m: 0.05,
        saturation_rad: 0.5,
    };

    fn rot_z(x: f64, y: f64, angle: f64) -> Se3 {
        Se3::new(
            Vector3::new(x, y, 0.0),
            UnitQuaternion::from_euler_angles(0.0, 0.0, angle),
        )
    }

    /// Along x, a turn of 1 rad about z in place, then along y.
    fn turning_path(s: &Se3Space) -> PathGuide {
        let path = [
            rot_z(-0.4, 0.0, 0.0),
            rot_z(0.0, 0.0, 0.0),
            rot_z(0.0, 0.0, 1.0),
            rot_z(0.0, 0.4, 1.0),
        ];
        PathGuide::new(s, &path, 0.001)
    }

    fn free(_: &Se3, _: &Se3) -> bool {
        true
    }

    fn close(a: Vector6<f64>, b: Vector6<f64>, tol: f64) -> bool {
        (a - b).norm() < tol
    }

    #[test]
    fn the_lead_pulls_to_a_carrot_ahead_and_saturates() {
        let s = space();
        let g = turning_path(&s);
        assert!((g.length() - 0.9).abs() < 1e-12);
        // On the first leg at x = −0.3: the carrot is 0.1 further, at x = −0.2; the pull
        // (0.1 m) saturates at 5 cm, no turn.
        let f = g.force(&s, &rot_z(-0.3, 0.0, 0.0), &LEAD, &free);
        assert!(
            close(f, Vector6::new(0.05, 0.0, 0.0, 0.0, 0.0, 0.0), 1e-9),
            "{f}"
        );
        // Beside the path, 3 cm off in z: towards the carrot (forward and back onto the
        // path), saturated.
        let f = g.force(&s, &Se3::from_xyz(-0.3, 0.0, 0.03), &LEAD, &free);
        let towards = Vector3::new(0.1, 0.0, -0.03).normalize() * 0.05;
        assert!((f.fixed_rows::<3>(0) - towards).norm() < 1e-6, "{f}");
        // Near the goal the carrot is the goal: linear below the saturation, zero there.
        let f = g.force(&s, &rot_z(0.0, 0.37, 1.0), &LEAD, &free);
        assert!(
            close(f, Vector6::new(0.0, 0.03, 0.0, 0.0, 0.0, 0.0), 1e-9),
            "{f}"
        );
        assert!(g.force(&s, &rot_z(0.0, 0.4, 1.0), &LEAD, &free).norm() < 1e-12);
        // Far from the path (beyond GUIDANCE_RADIUS): no pull.
        assert_eq!(
            g.force(&s, &Se3::from_xyz(-0.3, 0.0, 0.3), &LEAD, &free),
            Vector6::zeros()
        );
    }

    #[test]
    fn the_lead_turns_towards_the_paths_orientation() {
        let s = space();
        let g = turning_path(&s);
        // 5 cm before the turn: the carrot is half-way through it (0.5 rad): pull 5 cm
        // forward and turn 0.5 rad about +z, both at their saturation.
        let f = g.force(&s, &rot_z(-0.05, 0.0, 0.0), &LEAD, &free);
        assert!(
            close(f, Vector6::new(0.05, 0.0, 0.0, 0.0, 0.0, 0.5), 1e-6),
            "{f}"
        );
        // Turned 0.2 rad at the corner: the carrot is 0.02 m up the last leg at 1 rad; the
        // pull (2 cm) is below its saturation, the turn (0.8 rad) saturates at 0.5 rad.
        let f = g.force(&s, &rot_z(0.0, 0.0, 0.2), &LEAD, &free);
        assert!(
            close(f, Vector6::new(0.0, 0.02, 0.0, 0.0, 0.0, 0.5), 1e-6),
            "{f}"
        );
        // Turned the wrong way (−0.3 rad): the turn still points to +z, the path's way.
        let f = g.force(&s, &rot_z(-0.05, 0.0, -0.3), &LEAD, &free);
        assert!(f[5] > 0.49 && f[3].abs() < 1e-9 && f[4].abs() < 1e-9, "{f}");
    }

    #[test]
    fn the_carrot_advances_with_the_operator() {
        let s = space();
        let g = turning_path(&s);
        let mut last = 0;
        for k in 0..7 {
            let x = -0.38 + 0.04 * f64::from(k);
            let j = g
                .carrot(&s, &rot_z(x, 0.0, 0.0), LEAD.lookahead, &free)
                .expect("j");
            // One lookahead ahead of the operator's own arc length (x + 0.4).
            assert!(
                (g.arc()[j] - (x + 0.4) - 0.1).abs() < 0.0011,
                "{x}: {}",
                g.arc()[j]
            );
            assert!(j > last, "{x}");
            last = j;
        }
    }

    #[test]
    fn the_lead_never_pulls_through_a_wall() {
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
        let blind = g.force(&s, &user, &LEAD, &free);
        assert!(close(
            blind,
            Vector6::new(0.05, 0.0, 0.0, 0.0, 0.0, 0.0),
            1e-9
        ));
        // With it: the anchor is the left leg's nearest point (−0.2, 0), the carrot 0.1 up
        // it: away from the wall and along the path, saturated.
        let f = g.force(&s, &user, &LEAD, &wall);
        let towards = Vector6::new(-0.19, 0.1, 0.0, 0.0, 0.0, 0.0);
        assert!((unit(f) - unit(towards)).norm() < 0.01, "{f}");
        assert!((f.norm() - 0.05).abs() < 1e-9);
        // Above the wall the right leg is reachable: the pull cuts the corner onto it, to
        // the point 0.1 past its nearest (0.1, 0.28), within a resampling step.
        let f = g.force(&s, &Se3::from_xyz(0.06, 0.28, 0.0), &LEAD, &wall);
        let towards = Vector6::new(0.04, -0.1, 0.0, 0.0, 0.0, 0.0);
        assert!((unit(f) - unit(towards)).norm() < 0.03, "{f}");
        // Nothing reachable: no pull at all.
        let none = |_: &Se3, _: &Se3| false;
        assert_eq!(g.force(&s, &user, &LEAD, &none), Vector6::zeros());
    }

    #[test]
    fn an_operator_who_cannot_reach_the_path_ahead_is_led_back_along_it() {
        let s = space();
        let g = PathGuide::new(
            &s,
            &[Se3::from_xyz(-0.4, 0.0, 0.0), Se3::from_xyz(0.4, 0.0, 0.0)],
            0.001,
        );
        // Only path points at x ≤ −0.15 can be reached from the operator at x = −0.05 (its
        // nearest path point and everything ahead cannot; the goal is beyond the radius).
        let behind = |_: &Se3, b: &Se3| b.pos.x <= -0.15;
        let user = Se3::from_xyz(-0.05, 0.0, 0.0);
        let j = g
            .carrot(&s, &user, LEAD.lookahead, &behind)
            .expect("a way back");
        let x = g.points()[j].pos.x;
        assert!((-0.17..=-0.15).contains(&x), "{x}");
        let f = g.force(&s, &user, &LEAD, &behind);
        assert!(
            close(f, Vector6::new(-0.05, 0.0, 0.0, 0.0, 0.0, 0.0), 1e-9),
            "{f}"
        );
        // Farther back than the probes reach (0.32 weighted m): nothing.
        let far_behind = |_: &Se3, b: &Se3| b.pos.x <= -0.38;
        assert!(g.carrot(&s, &user, LEAD.lookahead, &far_behind).is_none());
    }
}
