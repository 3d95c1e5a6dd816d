//! RRT-Connect (Kuffner & LaValle 2000) with a start and a goal tree, the I-RRT Extend
//! method and node labels, and the attractive pseudo-force F_a.
//!
//! One [`Planner::iterate`] call: sample `q_rand` (uniform, or with probability
//! `user_bias` a Gaussian around the user's configuration), *Extend* tree A towards it,
//! and if A grew, *Extend* tree B towards A's newest node (the "connect" step); then swap
//! A and B. Extend is I-RRT's: from the nearest node, steps of `step` until the target is
//! reached or an edge collides, adding a node per step:
//! [`Extend::Collision`] (nothing added), [`Extend::Obstacle`] (partial progress),
//! [`Extend::Success`] (reached). Both trees thus grow greedily ("RRT-ConCon").
//!
//! The core is pure: deterministic for a seed and an input sequence, no I/O, no clock,
//! no threads. Work per iteration is bounded by the bounds' diameter over `step` edges.

use crate::collision::CollisionChecker;
use crate::guidance::{PathGuide, barycenter_force};
use crate::params::{PlannerError, PlannerParams};
use crate::pose::Se3;
use crate::scene::Scene;
use crate::space::{ConfigSpace, Space};
use crate::tree::{NodeId, Tree};
use nalgebra::Vector6;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Result of I-RRT's Extend method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extend {
    /// The first step collided: nothing was added.
    Collision,
    /// Partial progress: nodes were added, then an edge collided before the target.
    Obstacle,
    /// The target was reached (it is the tree's newest node, or already was a node).
    Success,
}

/// What one iteration did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IterReport {
    /// 1-based iteration number.
    pub iteration: u64,
    /// The sample `q_rand` (scene frame); `None` when already solved (no work done).
    pub sample: Option<Se3>,
    /// True when the sample came from the Gaussian around the user.
    pub from_user: bool,
    /// True when tree A (extended towards the sample) was the start tree.
    pub a_is_start: bool,
    /// Extend of tree A towards the sample.
    pub extend: Option<Extend>,
    /// Extend of tree B towards A's newest node, when A grew.
    pub connect: Option<Extend>,
    /// Nodes added to both trees.
    pub nodes_added: u32,
    /// True when the problem is solved (now or before).
    pub solved: bool,
}

/// Planner statistics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    /// Iterations run.
    pub iterations: u64,
    /// Nodes in all trees.
    pub nodes: usize,
    /// Number of trees.
    pub trees: usize,
    /// Geometric collision checks performed.
    pub collision_checks: u64,
    /// Smallest distance label in the start tree (weighted m); 0 once solved.
    pub best_distance_to_goal: f64,
}

const START: usize = 0;
const GOAL: usize = 1;

/// RRT-Connect planner for one scene. See the module docs.
pub struct Planner {
    space: Space,
    checker: CollisionChecker,
    params: PlannerParams,
    rng: ChaCha8Rng,
    /// `[start tree, goal tree]`.
    trees: [Tree; 2],
    goal: Se3,
    a: usize,
    iterations: u64,
    solution: Option<Vec<Se3>>,
    guide: Option<PathGuide>,
}

impl Planner {
    /// Validates `params` and `scene` (including collision-free start and goal) and roots
    /// the two trees. `seed` fixes the random sequence.
    pub fn new(scene: &Scene, params: PlannerParams, seed: u64) -> Result<Self, PlannerError> {
        params.validate()?;
        scene.validate(&scene.name)?;
        let checker = CollisionChecker::with_params(scene, params.weights, params.edge_resolution);
        if !checker.is_free(&scene.start) {
            return Err(PlannerError::StartInCollision(scene.name.clone()));
        }
        if !checker.is_free(&scene.goal) {
            return Err(PlannerError::GoalInCollision(scene.name.clone()));
        }
        let space = Space::for_scene(scene, params.weights);
        let d = space.distance(&scene.start, &scene.goal);
        Ok(Planner {
            trees: [Tree::new(scene.start, d), Tree::new(scene.goal, 0.0)],
            space,
            checker,
            params,
            rng: ChaCha8Rng::seed_from_u64(seed),
            goal: scene.goal,
            a: START,
            iterations: 0,
            solution: None,
            guide: None,
        })
    }

    /// One RRT-Connect iteration. `user` is the user's configuration (scene frame), used
    /// by the biased sampler (`params.user_bias`); non-finite input is ignored. Does
    /// nothing once solved.
    pub fn iterate(&mut self, user: Option<&Se3>) -> IterReport {
        self.iterations += 1;
        let mut report = IterReport {
            iteration: self.iterations,
            sample: None,
            from_user: false,
            a_is_start: self.a == START,
            extend: None,
            connect: None,
            nodes_added: 0,
            solved: self.solved(),
        };
        if report.solved {
            return report;
        }
        let (q_rand, from_user) = self.sample(user);
        report.sample = Some(q_rand);
        report.from_user = from_user;
        let (a, b) = (self.a, 1 - self.a);
        let (ext, last_a, added_a) = self.extend(a, &q_rand);
        report.extend = Some(ext);
        report.nodes_added = added_a;
        if ext != Extend::Collision {
            let target = self.trees[a].node(last_a).config;
            let (con, last_b, added_b) = self.extend(b, &target);
            report.connect = Some(con);
            report.nodes_added += added_b;
            if con == Extend::Success {
                self.build_solution(a, last_a, last_b);
                report.solved = true;
            }
        }
        self.a = b;
        report
    }

    fn sample(&mut self, user: Option<&Se3>) -> (Se3, bool) {
        if let Some(u) = user.filter(|u| u.is_finite() && self.params.user_bias > 0.0)
            && self.rng.random::<f64>() < self.params.user_bias
        {
            return (
                self.space
                    .sample_near(u, self.params.user_sigma, &mut self.rng),
                true,
            );
        }
        (self.space.sample_uniform(&mut self.rng), false)
    }

    /// I-RRT Extend of tree `t` towards `target`: returns the outcome, the last node
    /// reached (the nearest node on Collision) and the number of nodes added. Updates the
    /// nearest node's collision-label counters.
    fn extend(&mut self, t: usize, target: &Se3) -> (Extend, NodeId, u32) {
        let (near, _) = self.trees[t].nearest(&self.space, target);
        let (mut cur, mut added, mut covered) = (near, 0u32, 0.0);
        let outcome = loop {
            let from = self.trees[t].node(cur).config;
            let d = self.space.distance(&from, target);
            if d == 0.0 {
                break Extend::Success;
            }
            let reached = d <= self.params.step;
            let next = if reached {
                *target
            } else {
                self.space.interpolate(&from, target, self.params.step / d)
            };
            if !self.checker.edge_free_from(&from, &next) {
                break if added == 0 {
                    Extend::Collision
                } else {
                    Extend::Obstacle
                };
            }
            let to_goal = self.space.distance(&next, &self.goal);
            cur = self.trees[t].add(cur, next, to_goal);
            added += 1;
            covered += d.min(self.params.step);
            if reached {
                break Extend::Success;
            }
        };
        let labels = self.trees[t].labels_mut(near);
        labels.extension_attempts += 1;
        labels.collisions += u32::from(outcome == Extend::Collision);
        labels.covered_distance += covered;
        (outcome, cur, added)
    }

    /// Joins the two trees at `la` (tree `a`) and `lb` (tree `b`, same configuration).
    fn build_solution(&mut self, a: usize, la: NodeId, lb: NodeId) {
        let mut path = self.trees[a].path_to_root(la);
        path.reverse(); // root_a … la
        path.extend(self.trees[1 - a].path_to_root(lb).into_iter().skip(1)); // … root_b
        if a == GOAL {
            path.reverse();
        }
        let resolution = 0.2 * self.params.step;
        self.guide = Some(PathGuide::new(&self.space, &path, resolution));
        self.solution = Some(path);
    }

    /// True once a start–goal path exists.
    pub fn solved(&self) -> bool {
        self.solution.is_some()
    }

    /// The solution waypoints, start → goal (scene frame); consecutive waypoints are
    /// joined by collision-free edges (validated at `edge_resolution`).
    pub fn solution(&self) -> Option<&[Se3]> {
        self.solution.as_deref()
    }

    /// Statistics so far.
    pub fn stats(&self) -> Stats {
        let best = if self.solved() {
            0.0
        } else {
            self.trees[START]
                .nodes()
                .iter()
                .map(|n| n.labels.distance_to_goal)
                .fold(f64::INFINITY, f64::min)
        };
        Stats {
            iterations: self.iterations,
            nodes: self.trees.iter().map(Tree::len).sum(),
            trees: self.trees.len(),
            collision_checks: self.checker.collision_checks(),
            best_distance_to_goal: best,
        }
    }

    /// I-RRT's attractive pseudo-force F_a at `q_user` (scene frame), a 6-vector
    /// `(Δp (m), Δr (rad))`. Before a solution: towards the label-weighted barycenter of the
    /// `p` nodes nearest to `q_user`, all from the tree holding the single nearest node
    /// (see [`crate::guidance`]). After: along the solution path, `lookahead` beyond the
    /// path point nearest to `q_user`.
    pub fn attractive_force(&self, q_user: &Se3) -> Vector6<f64> {
        if !q_user.is_finite() {
            return Vector6::zeros();
        }
        if let Some(guide) = &self.guide {
            return guide.force(&self.space, q_user, self.params.lookahead);
        }
        let (_, ds) = self.trees[START].nearest(&self.space, q_user);
        let (_, dg) = self.trees[GOAL].nearest(&self.space, q_user);
        let tree = &self.trees[if dg < ds { GOAL } else { START }];
        let mut scratch = Vec::with_capacity(self.params.neighbours);
        barycenter_force(
            &self.space,
            tree,
            q_user,
            self.params.neighbours,
            self.params.label_epsilon,
            &mut scratch,
        )
    }

    /// `[start tree, goal tree]`.
    pub fn trees(&self) -> &[Tree] {
        &self.trees
    }

    /// The configuration space (metric, bounds).
    pub fn space(&self) -> &Space {
        &self.space
    }

    /// The collision checker (for validating paths).
    pub fn checker(&self) -> &CollisionChecker {
        &self.checker
    }

    /// The parameters in use.
    pub fn params(&self) -> &PlannerParams {
        &self.params
    }
}

#[cfg(test)]
mod tests;
