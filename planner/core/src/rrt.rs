//! The planner: RRT and RRT-Connect baselines, I-RRT (operator-driven sampling, labels,
//! pseudo-forces, local trees) and H-RRT-C (authority sharing, contact sampling).
//!
//! One [`Planner::iterate_input`] call (RRT-Connect): sample `q_rand` with the configured
//! method ([`crate::sampling`]), *Extend* tree A towards it, and if A grew, *Extend* tree
//! B towards A's newest node (the "connect" step); then swap A and B. Extend is I-RRT's:
//! from the nearest node, steps of `step` until the target is reached or an edge
//! collides, adding a node per step: [`Extend::Collision`] (nothing added),
//! [`Extend::Obstacle`] (partial progress), [`Extend::Success`] (reached). With
//! [`ExtendA::Step`] tree A takes at most one step ([`Extend::Advanced`] when it did not
//! reach the sample), as OMPL's `RRTConnect` does; tree B always connects greedily.
//!
//! Local trees (I-RRT §4.2.2, Strandberg 2004), when enabled: an operator sample that
//! tree A cannot reach extends the nearest local tree instead, or roots a new one. Each
//! iteration the newest node of A (or, when A did not grow, the round-robin next local
//! tree's newest node) is offered to the local trees / main trees by a greedy Extend; a
//! local tree that reaches a main tree is grafted into it. Their number is capped.
//!
//! The single-tree RRT takes one `step` towards the sample (goal with `goal_bias`).
//!
//! The core is pure: deterministic for a seed and an input sequence, no I/O, no clock,
//! no threads.

use crate::aligned::AlignedOrientations;
use crate::authority::{Authority, AuthorityState, TrustTracker};
use crate::collision::CollisionChecker;
use crate::guidance::{Lead, PathGuide, barycenter_force};
use crate::params::{Algorithm, ExtendA, HumanMode, MachineSampler, PlannerError, PlannerParams};
use crate::sampling::{Sampling, UserInput, apply_delta, contact_sample};
use crate::space::{ConfigSpace, Space};
use crate::tree::{NodeId, Tree};
use nalgebra::Vector6;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use scene::Scene;
use scene::pose::Se3;

mod shed;

/// Result of I-RRT's Extend method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extend {
    /// The first step collided: nothing was added.
    Collision,
    /// Partial progress: nodes were added, then an edge collided before the target.
    Obstacle,
    /// The step limit was reached before the target, no edge collided
    /// ([`crate::params::ExtendA::Step`]).
    Advanced,
    /// The target was reached (it is the tree's newest node, or already was a node).
    Success,
}

/// Where a sample came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// Uniform over the space (CS, H-RRT-C machine mode, goal bias).
    Uniform,
    /// Operator-driven in free space (POS, PATH, H-RRT-C human mode).
    User,
    /// H-RRT-C HapticSampling on the contact plane.
    Contact,
    /// A machine sample of the bridge test ([`MachineSampler::BridgeTest`]).
    BridgeTest,
}

/// Bridge tests tried for one bridge sample before it falls back to a uniform one.
pub const BRIDGE_TRIES: u32 = 32;

/// H-RRT-C's human mode with [`HumanMode::Fresh`]: q_device counts as new once it moved by
/// this share of the edge resolution (0.5 mm or 0.005 rad at the defaults) from the last
/// q_device sampled.
pub const FRESH_USER_FRACTION: f64 = 0.1;

/// What one iteration did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IterReport {
    /// 1-based iteration number.
    pub iteration: u64,
    /// The sample `q_rand` (scene frame); `None` when already solved (no work done).
    pub sample: Option<Se3>,
    /// Where the sample came from.
    pub source: Source,
    /// True when the sample was operator-driven (User or Contact).
    pub from_user: bool,
    /// True when tree A (extended towards the sample) was the start tree.
    pub a_is_start: bool,
    /// Extend of tree A towards the sample.
    pub extend: Option<Extend>,
    /// Extend of tree B towards A's newest node, when A grew.
    pub connect: Option<Extend>,
    /// Nodes added to all trees.
    pub nodes_added: u32,
    /// Local trees merged into a main tree this iteration.
    pub merged: u32,
    /// The sample was new ground for the roadmap and tree A reached it: its nearest node
    /// was more than one `step` away (RRT: the tree took its step towards such a sample).
    pub novel: bool,
    /// True when the problem is solved (now or before).
    pub solved: bool,
    /// The operator's sample was in shallow collision and was pushed out to a free
    /// configuration ([`crate::PlannerParams::touch_depth_m`]), which `sample` holds.
    pub touched: bool,
}

/// Planner statistics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    /// Iterations run.
    pub iterations: u64,
    /// Nodes in all trees.
    pub nodes: usize,
    /// Number of trees (start, goal and local).
    pub trees: usize,
    /// Geometric collision checks performed.
    pub collision_checks: u64,
    /// Clearance (distance) queries of certified edge checks.
    pub clearance_queries: u64,
    /// Smallest distance label in the start tree (weighted m); 0 once solved.
    pub best_distance_to_goal: f64,
    /// Local trees merged so far.
    pub merges: u64,
    /// Operator samples in shallow collision pushed out and used (touch retraction).
    pub touched: u64,
    /// Of those, the ones a tree reached: added as nodes.
    pub touched_nodes: u64,
    /// Waypoints of the raw solution path that are such nodes.
    pub touched_on_path: usize,
}

/// Push-outs one touch retraction tries: each moves the object along the deepest
/// contact's normal by its depth and a margin; several contacts (a slot's two walls) take
/// a few.
const TOUCH_PUSHES: u32 = 4;

/// Clearance a push-out adds beyond the depth (m): free by a margin, not touching.
const TOUCH_MARGIN_M: f64 = 5e-5;

const START: usize = 0;
const GOAL: usize = 1;

/// The planner for one scene. See the module docs.
pub struct Planner {
    space: Space,
    checker: CollisionChecker,
    params: PlannerParams,
    /// Candidate orientations of aligned machine samples (empty when they are off).
    aligned: AlignedOrientations,
    rng: ChaCha8Rng,
    /// `[start tree, goal tree, local trees…]`.
    trees: Vec<Tree>,
    /// Stable id of each tree in `trees` (0 start, 1 goal, local trees from 2, never
    /// reused; a tree thinned by [`Planner::shed`] takes a new one): lets a viewer follow
    /// trees while local trees come and go.
    tree_ids: Vec<u32>,
    /// The iteration in which each tree in `trees` last grew (for [`Planner::shed`]).
    grown: Vec<u64>,
    next_tree_id: u32,
    goal: Se3,
    a: usize,
    iterations: u64,
    merges: u64,
    /// Operator samples pushed out of a shallow collision ([`Self::touch_retract`]), the
    /// newest ones ([`Planner::shed`] drops old ones).
    touched: Vec<Se3>,
    /// All of them, counted.
    touched_count: u64,
    /// Of those, the ones a tree reached.
    touched_nodes: u64,
    /// Raw solution waypoints among them, counted when solved.
    touched_on_path: usize,
    /// Round-robin cursor over local trees.
    local_cursor: usize,
    /// The operator's previous configuration (for F_u).
    prev_user: Option<Se3>,
    /// The last q_device H-RRT-C's human mode sampled.
    last_human: Option<Se3>,
    /// The adaptive authority's memory of the operator's progress.
    trust: TrustTracker,
    /// The operator's travelled path (PATH sampling), one entry per `step / 4` moved.
    user_path: Vec<Se3>,
    raw_solution: Option<Vec<Se3>>,
    solution: Option<Vec<Se3>>,
    guide: Option<PathGuide>,
    scratch: Vec<(NodeId, f64)>,
}

impl Planner {
    /// Validates `params` and `scene` (including collision-free start and goal) and roots
    /// the two trees. `seed` fixes the random sequence.
    pub fn new(scene: &Scene, params: PlannerParams, seed: u64) -> Result<Self, PlannerError> {
        params.validate()?;
        scene.validate(&scene.name)?;
        let checker = CollisionChecker::with_params(scene, params.weights, params.edge_resolution)
            .with_edge_check(params.edge_check);
        Self::build(scene, params, seed, checker)
    }

    /// [`Planner::new`] with a checker of `scene`'s parts built before, e.g. by
    /// [`CollisionChecker::sharing_parts`] (so a big mesh's trees are not built again); it
    /// takes `params`' edge resolution, weights and edge check.
    pub fn with_checker(
        scene: &Scene,
        params: PlannerParams,
        seed: u64,
        checker: &CollisionChecker,
    ) -> Result<Self, PlannerError> {
        params.validate()?;
        scene.validate(&scene.name)?;
        let checker = checker
            .sharing_parts(scene, params.weights, params.edge_resolution)
            .with_edge_check(params.edge_check);
        Self::build(scene, params, seed, checker)
    }

    fn build(
        scene: &Scene,
        params: PlannerParams,
        seed: u64,
        checker: CollisionChecker,
    ) -> Result<Self, PlannerError> {
        if !checker.is_free(&scene.start) {
            return Err(PlannerError::StartInCollision(scene.name.clone()));
        }
        if !checker.is_free(&scene.goal) {
            return Err(PlannerError::GoalInCollision(scene.name.clone()));
        }
        let space = Space::for_scene(scene, params.weights);
        let d = space.distance(&scene.start, &scene.goal);
        let aligned = if params.aligned_share > 0.0 {
            AlignedOrientations::of(scene)
        } else {
            AlignedOrientations::default()
        };
        Ok(Planner {
            aligned,
            trees: vec![Tree::new(scene.start, d), Tree::new(scene.goal, 0.0)],
            tree_ids: vec![0, 1],
            grown: vec![0, 0],
            next_tree_id: 2,
            space,
            checker,
            params,
            rng: ChaCha8Rng::seed_from_u64(seed),
            goal: scene.goal,
            a: START,
            iterations: 0,
            merges: 0,
            touched: Vec::new(),
            touched_count: 0,
            touched_nodes: 0,
            touched_on_path: 0,
            local_cursor: 0,
            prev_user: None,
            last_human: None,
            trust: TrustTracker::default(),
            user_path: Vec::new(),
            raw_solution: None,
            solution: None,
            guide: None,
            scratch: Vec::new(),
        })
    }

    /// One iteration with an operator in free space at `user` (scene frame), or none.
    /// Non-finite input is ignored.
    pub fn iterate(&mut self, user: Option<&Se3>) -> IterReport {
        let input = user.map(|q| UserInput::free(*q));
        self.iterate_input(input.as_ref())
    }

    /// One iteration with the operator's full input (configuration and contact state).
    /// Does nothing once solved.
    pub fn iterate_input(&mut self, input: Option<&UserInput>) -> IterReport {
        self.iterations += 1;
        let mut report = IterReport {
            iteration: self.iterations,
            sample: None,
            source: Source::Uniform,
            from_user: false,
            a_is_start: self.a == START,
            extend: None,
            connect: None,
            nodes_added: 0,
            merged: 0,
            novel: false,
            solved: self.solved(),
            touched: false,
        };
        if report.solved {
            return report;
        }
        let input = input.filter(|u| u.q_user.is_finite()).map(|u| UserInput {
            q_user: self.space.project(&u.q_user),
            ..*u
        });
        if let Some(u) = &input {
            self.track_user(&u.q_user);
            if let Some(rule) = self.adaptive() {
                self.trust
                    .observe(&rule, &self.space, &u.q_user, &self.goal, u.time_s);
            }
        }
        let (mut q_rand, source, present) = self.sample(input.as_ref());
        if source == Source::User
            && let Some(q) = self.touch_retract(&q_rand)
        {
            q_rand = q;
            report.touched = true;
            self.touched.push(q);
            self.touched_count += 1;
        }
        report.sample = Some(q_rand);
        report.source = source;
        report.from_user = matches!(source, Source::User | Source::Contact);
        match self.params.algorithm {
            Algorithm::Rrt => self.rrt_step(&q_rand, &mut report),
            Algorithm::RrtConnect => self.connect_step(&q_rand, source, &mut report),
        }
        if report.touched && report.extend == Some(Extend::Success) {
            self.touched_nodes += 1;
        }
        if let Some(rule) = self.adaptive()
            && present
            && (report.novel || report.merged > 0 || report.solved)
        {
            self.trust.fruit(&rule);
        }
        if let Some(u) = &input {
            self.prev_user = Some(u.q_user);
        }
        report
    }

    /// `q`, an operator sample, pushed out of a shallow collision (no deeper than
    /// [`crate::PlannerParams::touch_depth_m`]) to a free configuration nearby: moved along
    /// the deepest contact's normal by its depth and [`TOUCH_MARGIN_M`], up to
    /// [`TOUCH_PUSHES`] times. `None` when `q` is free already, deeper, or not freed so.
    fn touch_retract(&self, q: &Se3) -> Option<Se3> {
        let limit = self.params.touch_depth_m;
        if limit <= 0.0 || self.checker.is_free(q) {
            return None;
        }
        let mut at = *q;
        for _ in 0..TOUCH_PUSHES {
            let (_, normal, depth) = self.checker.deepest_contact(&at)?;
            if depth > limit || !normal.iter().all(|x| x.is_finite()) {
                return None;
            }
            at = self.space.project(&Se3::new(
                at.pos + normal * (depth + TOUCH_MARGIN_M),
                at.rot,
            ));
            if self.checker.is_free(&at) {
                // Near the sample: within the depth limit for each push.
                return Some(at);
            }
        }
        None
    }

    /// The adaptive authority's rule, when H-RRT-C runs with it.
    fn adaptive(&self) -> Option<crate::authority::AdaptiveAuthority> {
        match (self.params.sampling, self.params.authority) {
            (Sampling::Hrrtc { .. }, Authority::Adaptive(rule)) => Some(rule),
            _ => None,
        }
    }

    /// H-RRT-C's authority now: the operator's trust and the machine shares in free space
    /// and in contact ([`crate::authority`]). With another sampling method: trust 1 and
    /// the method's own machine share.
    pub fn authority(&self) -> AuthorityState {
        let shared = self.params.contact.shared_authority;
        match self.params.sampling {
            Sampling::Hrrtc { alpha } => self.trust.state(&self.params.authority, alpha, shared),
            other => {
                let m = 1.0 - other.user_share();
                self.trust.state(&Authority::Fixed, m, true)
            }
        }
    }

    fn track_user(&mut self, q: &Se3) {
        let far = self
            .user_path
            .last()
            .is_none_or(|l| self.space.distance(l, q) >= 0.25 * self.params.step);
        if far {
            self.user_path.push(*q);
        }
    }

    /// `q_rand`, its source, and whether it is the operator's present input (a contact
    /// sample or q_device itself, not a stand-in near its travelled path). See
    /// [`crate::sampling`] and [`crate::authority`].
    fn sample(&mut self, input: Option<&UserInput>) -> (Se3, Source, bool) {
        let sampling = self.params.sampling;
        if self.params.algorithm == Algorithm::Rrt
            && self.rng.random::<f64>() < self.params.goal_bias
        {
            return (self.goal, Source::Uniform, false);
        }
        let machine = |p: &mut Self| {
            let (q, s) = p.machine_sample();
            (q, s, false)
        };
        let Some(u) = input else {
            return machine(self);
        };
        let authority = self.authority();
        if let (Sampling::Hrrtc { .. }, Some(c)) = (sampling, &u.contact) {
            // Contact mode (Algorithm 2, line 3): HapticSampling; a machine share with
            // shared authority (α) or adaptive authority (growing while the operator is
            // stuck). No draw without either, as Algorithm 2.
            let m = authority.machine_share_contact;
            let shared = self.params.contact.shared_authority;
            if (shared || m > 0.0) && self.rng.random::<f64>() < m {
                return machine(self);
            }
            if let Some(q) = contact_sample(&self.space, c, &self.params.contact, &mut self.rng) {
                return (q, Source::Contact, true);
            }
        }
        let user_share = match sampling {
            Sampling::Hrrtc { .. } => 1.0 - authority.machine_share_free,
            other => other.user_share(),
        };
        if self.rng.random::<f64>() >= user_share {
            return machine(self);
        }
        let sigma = self.params.user_sigma;
        let mut present = false;
        let q = match sampling {
            // Its user share is 0: the draw above always returns a machine sample.
            Sampling::Uniform => return machine(self),
            Sampling::Pos { .. } => {
                let prev = self.prev_user.unwrap_or(u.q_user);
                let fr = self.resulting_force(&prev, &u.q_user);
                let centre = apply_delta(&self.space, &u.q_user, &fr);
                self.space.sample_near(&centre, sigma, &mut self.rng)
            }
            Sampling::Path { .. } => self.near_user_path(&u.q_user, sigma),
            Sampling::Hrrtc { .. } => {
                let fresh = self.last_human.is_none_or(|last| {
                    self.space.distance(&last, &u.q_user)
                        >= FRESH_USER_FRACTION * self.params.edge_resolution
                });
                match self.params.human_mode {
                    HumanMode::Fresh if !fresh => self.near_user_path(&u.q_user, sigma),
                    _ => {
                        self.last_human = Some(u.q_user);
                        present = true;
                        u.q_user
                    }
                }
            }
        };
        (q, Source::User, present)
    }

    /// I-RRT PATH: a Gaussian (σ `sigma`) around a uniformly chosen point of the operator's
    /// travelled path (`q_user` while it has none).
    fn near_user_path(&mut self, q_user: &Se3, sigma: f64) -> Se3 {
        let i = self.rng.random_range(0..self.user_path.len().max(1));
        let centre = self.user_path.get(i).copied().unwrap_or(*q_user);
        self.space.sample_near(&centre, sigma, &mut self.rng)
    }

    /// A sample without the operator, by [`PlannerParams::machine_sampler`].
    fn machine_sample(&mut self) -> (Se3, Source) {
        let MachineSampler::BridgeTest { share, sigma } = self.params.machine_sampler else {
            return (self.free_sample(), Source::Uniform);
        };
        if self.rng.random::<f64>() < share {
            for _ in 0..BRIDGE_TRIES {
                let q1 = self.free_sample();
                if self.checker.is_free(&q1) {
                    continue;
                }
                let q2 = self.space.sample_near(&q1, sigma, &mut self.rng);
                if self.checker.is_free(&q2) {
                    continue;
                }
                let mid = self.space.interpolate(&q1, &q2, 0.5);
                if self.checker.is_free(&mid) {
                    return (mid, Source::BridgeTest);
                }
            }
        }
        (self.free_sample(), Source::Uniform)
    }

    /// A uniform configuration whose orientation is, with probability
    /// [`PlannerParams::aligned_share`], square to an obstacle instead.
    fn free_sample(&mut self) -> Se3 {
        let q = self.space.sample_uniform(&mut self.rng);
        if self.params.aligned_share > 0.0 && self.rng.random::<f64>() < self.params.aligned_share {
            let rot = self
                .aligned
                .sample(self.params.aligned_jitter_rad, &mut self.rng);
            return self.space.project(&Se3 { rot, ..q });
        }
        q
    }

    /// Single-tree RRT: one step from the nearest start-tree node.
    fn rrt_step(&mut self, q_rand: &Se3, report: &mut IterReport) {
        let (near, d) = self.trees[START].nearest(&self.space, q_rand);
        let from = self.trees[START].node(near).config;
        let next = self.space.steer(&from, q_rand, self.params.step);
        let ok = d > 0.0 && self.checker.edge_free_from(&from, &next);
        let labels = self.trees[START].labels_mut(near);
        labels.extension_attempts += 1;
        labels.collisions += u32::from(!ok);
        if !ok {
            report.extend = Some(Extend::Collision);
            return;
        }
        labels.covered_distance += d.min(self.params.step);
        let to_goal = self.space.distance(&next, &self.goal);
        let id = self.trees[START].add(near, next, to_goal);
        report.nodes_added = 1;
        report.novel = d > self.params.step;
        report.extend = Some(if next == *q_rand {
            Extend::Success
        } else {
            Extend::Obstacle
        });
        if to_goal <= self.params.step && self.checker.edge_free_from(&next, &self.goal) {
            let mut path = self.trees[START].path_to_root(id);
            path.reverse();
            path.push(self.goal);
            self.finish(path);
            report.solved = true;
        }
    }

    fn connect_step(&mut self, q_rand: &Se3, source: Source, report: &mut IterReport) {
        let (a, b) = (self.a, 1 - self.a);
        let max_a = match self.params.extend_a {
            ExtendA::Greedy => u32::MAX,
            ExtendA::Step => 1,
        };
        let (ext, last_a, added_a, gap) = self.extend_at_most(a, q_rand, max_a);
        report.extend = Some(ext);
        report.nodes_added = added_a;
        report.novel = ext == Extend::Success && added_a > 0 && gap > self.params.step;
        let mut offer: Option<NodeId> = None;
        if ext != Extend::Collision {
            let target = self.trees[a].node(last_a).config;
            offer = Some(last_a);
            let (con, last_b, added_b) = self.extend(b, &target);
            report.connect = Some(con);
            report.nodes_added += added_b;
            if con == Extend::Success {
                self.build_solution(a, last_a, last_b);
                report.solved = true;
                self.a = b;
                return;
            }
        }
        if self.params.local_trees {
            // Operator and bridge samples that the main trees missed root local trees
            // (narrow passages, as in Strandberg's local trees, ICRA 2004).
            let user_missed = source != Source::Uniform && ext != Extend::Success;
            if user_missed && self.checker.is_free(q_rand) {
                report.nodes_added += self.grow_local(q_rand);
            }
            report.merged += self.link_locals(offer, report);
        }
        self.a = b;
    }

    /// Extends the local tree nearest to `q` (within a few steps) towards it, or roots a
    /// new local tree at `q` (free). Returns nodes added.
    fn grow_local(&mut self, q: &Se3) -> u32 {
        let reach = 4.0 * self.params.step;
        let mut best: Option<(usize, f64)> = None;
        for t in 2..self.trees.len() {
            let (_, d) = self.trees[t].nearest(&self.space, q);
            if d < reach && best.is_none_or(|(_, e)| d < e) {
                best = Some((t, d));
            }
        }
        if let Some((t, _)) = best {
            let (e, _, added) = self.extend(t, q);
            if e != Extend::Collision {
                return added;
            }
        }
        if self.trees.len() - 2 >= self.params.max_local_trees {
            // Drop the oldest-made local tree: bounded work, and recent operator input
            // matters most.
            self.remove_tree(2);
        }
        let d = self.space.distance(q, &self.goal);
        self.trees.push(Tree::new(*q, d));
        let id = self.new_tree_id();
        self.tree_ids.push(id);
        self.grown.push(self.iterations);
        1
    }

    /// A stable id no tree had before (≥ 2).
    fn new_tree_id(&mut self) -> u32 {
        let id = self.next_tree_id;
        self.next_tree_id = self.next_tree_id.wrapping_add(1).max(2);
        id
    }

    /// Removes tree `t` (a local tree) with its id and growth record.
    fn remove_tree(&mut self, t: usize) -> Tree {
        self.tree_ids.remove(t);
        self.grown.remove(t);
        self.trees.remove(t)
    }

    /// Offers `offer` (A's newest node) to every local tree, and one local tree's newest
    /// node (round robin) to both main trees; grafts a local tree that connects.
    /// Returns the number of merges.
    fn link_locals(&mut self, offer: Option<NodeId>, report: &mut IterReport) -> u32 {
        let mut merged = 0;
        if let Some(at_a) = offer {
            let a = self.a;
            let q = self.trees[a].node(at_a).config;
            let mut t = 2;
            while t < self.trees.len() {
                let (e, last, added) = self.extend(t, &q);
                report.nodes_added += added;
                if e == Extend::Success {
                    // `last` has the configuration of A's node `at_a`.
                    self.merge(t, last, a, at_a);
                    merged += 1;
                } else {
                    t += 1;
                }
            }
        }
        if self.trees.len() > 2 {
            let t = 2 + self.local_cursor % (self.trees.len() - 2);
            self.local_cursor = self.local_cursor.wrapping_add(1);
            let tip = self.trees[t].nodes().last().map(|n| n.config);
            if let Some(tip) = tip {
                for main in [START, GOAL] {
                    let (e, last, added) = self.extend(main, &tip);
                    report.nodes_added += added;
                    if e == Extend::Success {
                        let local_tip = NodeId(self.trees[t].len() as u32 - 1);
                        self.merge(t, local_tip, main, last);
                        merged += 1;
                        break;
                    }
                }
            }
        }
        self.merges += u64::from(merged);
        merged
    }

    /// Grafts local tree `t` (its node `at_local`) into main tree `main` at `at_main`,
    /// and removes it.
    fn merge(&mut self, t: usize, at_local: NodeId, main: usize, at_main: NodeId) {
        let local = self.remove_tree(t);
        self.grown[main] = self.iterations;
        let (space, goal) = (&self.space, self.goal);
        self.trees[main].graft(at_main, &local, at_local, |q| space.distance(q, &goal));
    }

    /// I-RRT Extend of tree `t` towards `target`: returns the outcome, the last node
    /// reached (the nearest node on Collision) and the number of nodes added. Updates the
    /// nearest node's collision-label counters.
    fn extend(&mut self, t: usize, target: &Se3) -> (Extend, NodeId, u32) {
        let (e, last, added, _) = self.extend_at_most(t, target, u32::MAX);
        (e, last, added)
    }

    /// [`Planner::extend`] adding at most `max_nodes` nodes (≥ 1): stops with
    /// [`Extend::Advanced`] at the limit. Also returns the distance from the tree's nearest
    /// node to `target` before it grew (weighted m).
    fn extend_at_most(
        &mut self,
        t: usize,
        target: &Se3,
        max_nodes: u32,
    ) -> (Extend, NodeId, u32, f64) {
        let (near, gap) = self.trees[t].nearest(&self.space, target);
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
            if added >= max_nodes {
                break Extend::Advanced;
            }
        };
        let labels = self.trees[t].labels_mut(near);
        labels.extension_attempts += 1;
        labels.collisions += u32::from(outcome == Extend::Collision);
        labels.covered_distance += covered;
        if added > 0 {
            self.grown[t] = self.iterations;
        }
        (outcome, cur, added, gap)
    }

    /// Joins the two trees at `la` (tree `a`) and `lb` (tree `b`, same configuration).
    fn build_solution(&mut self, a: usize, la: NodeId, lb: NodeId) {
        let mut path = self.trees[a].path_to_root(la);
        path.reverse(); // root_a … la
        path.extend(self.trees[1 - a].path_to_root(lb).into_iter().skip(1)); // … root_b
        if a == GOAL {
            path.reverse();
        }
        self.finish(path);
    }

    /// Stores the raw path, its shortcut version, and the path guide.
    fn finish(&mut self, raw: Vec<Se3>) {
        let smooth = crate::path::shortcut(
            &self.checker,
            &raw,
            self.params.shortcut_attempts,
            &mut self.rng,
        );
        let resolution = 0.2 * self.params.step;
        self.touched_on_path = raw.iter().filter(|q| self.touched.contains(q)).count();
        self.guide = Some(PathGuide::new(&self.space, &smooth, resolution));
        self.raw_solution = Some(raw);
        self.solution = Some(smooth);
    }

    /// Takes `path` (start → goal, consecutive configurations joined by edges free at this
    /// planner's edge check, e.g. a small-step retraction's final stage) as the solution:
    /// smoothed and guided along as a path of its own. Ignored when already solved or when
    /// it does not run from this problem's start to its goal.
    pub fn adopt_solution(&mut self, path: &[Se3]) {
        let ends = (path.first(), path.last());
        if self.solved()
            || ends
                != (
                    Some(&self.trees[START].node(NodeId(0)).config),
                    Some(&self.goal),
                )
        {
            return;
        }
        self.finish(path.to_vec());
    }

    /// Sets how machine samples are drawn from the next iteration on: the sampler and
    /// the share of them turned square to an obstacle (clamped to [0, 1]; without
    /// candidates, [`crate::aligned::AlignedOrientations::of`] found none or the planner
    /// was built with `aligned_share` 0, aligned draws are uniform). A portfolio
    /// ([`crate::portfolio`]) switches between them turn by turn.
    pub fn set_machine_sampler(&mut self, sampler: MachineSampler, aligned_share: f64) {
        self.params.machine_sampler = sampler;
        self.params.aligned_share = aligned_share.clamp(0.0, 1.0);
    }

    /// True once a start–goal path exists.
    pub fn solved(&self) -> bool {
        self.solution.is_some()
    }

    /// The solution waypoints after shortcut smoothing, start → goal (scene frame);
    /// consecutive waypoints are joined by collision-free edges validated at
    /// `edge_resolution`. Edges may be longer than `step`.
    pub fn solution(&self) -> Option<&[Se3]> {
        self.solution.as_deref()
    }

    /// The solution as the trees hold it (before smoothing): edges of at most `step`.
    pub fn raw_solution(&self) -> Option<&[Se3]> {
        self.raw_solution.as_deref()
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
            clearance_queries: self.checker.clearance_queries(),
            best_distance_to_goal: best,
            merges: self.merges,
            touched: self.touched_count,
            touched_nodes: self.touched_nodes,
            touched_on_path: self.touched_on_path,
        }
    }

    /// I-RRT's attractive pseudo-force F_a at `q_user` (scene frame), a 6-vector
    /// `(Δp (m), Δr (rad))`. Before a solution: towards the label-weighted barycenter of the
    /// `p` nodes nearest to `q_user`, all from the tree holding the single nearest node
    /// ("all the neighbours should remain in the same connected component", I-RRT §5.1;
    /// local trees count), leaving out those `q_user` cannot reach in a straight line (our
    /// choice for the force the operator feels: a pull through a wall holds an operator
    /// who yields to it against the wall; I-RRT's POS sampler keeps the paper's F_a).
    /// After: along the solution path, from the furthest-along path stretch near `q_user`
    /// that it can reach in a straight line ([`PathGuide::force`]). The reachability checks
    /// count in [`Stats::collision_checks`].
    pub fn attractive_force(&self, q_user: &Se3) -> Vector6<f64> {
        let mut scratch = Vec::with_capacity(self.params.neighbours);
        self.attractive_force_with(q_user, &mut scratch, true)
    }

    /// F_a at `q_user`; `rendered`: for the operator (only towards nodes it can reach in a
    /// straight line), else I-RRT's own F_a for its POS sampler.
    fn attractive_force_with(
        &self,
        q_user: &Se3,
        scratch: &mut Vec<(NodeId, f64)>,
        rendered: bool,
    ) -> Vector6<f64> {
        if !q_user.is_finite() {
            return Vector6::zeros();
        }
        let q = self.space.project(q_user);
        let reach = |a: &Se3, b: &Se3| {
            self.checker
                .reachable_from_contact(a, b, crate::guidance::GUIDANCE_CONTACT_SKIP)
        };
        if let Some(guide) = &self.guide {
            let lead = Lead {
                lookahead: self.params.lookahead,
                saturation_m: self.params.lead_saturation_m,
                saturation_rad: self.params.lead_saturation_rad,
            };
            return guide.force(&self.space, &q, &lead, &reach);
        }
        let mut best = (START, f64::INFINITY);
        for (i, t) in self.trees.iter().enumerate() {
            let (_, d) = t.nearest(&self.space, &q);
            if d < best.1 {
                best = (i, d);
            }
        }
        barycenter_force(
            &self.space,
            &self.trees[best.0],
            &q,
            self.params.neighbours,
            self.params.label_epsilon,
            scratch,
            rendered.then_some(&reach as &crate::guidance::Reach<'_>),
        )
    }

    /// `F_r = α·F_u + (1−α)·F_a` (I-RRT eq. 1) for an operator who moved from `prev` to
    /// `q_user` since the previous iteration.
    pub fn resulting_force(&mut self, prev: &Se3, q_user: &Se3) -> Vector6<f64> {
        let mut scratch = std::mem::take(&mut self.scratch);
        let fa = self.attractive_force_with(q_user, &mut scratch, false);
        self.scratch = scratch;
        let fu = self.space.delta(prev, q_user);
        let a = self.params.fr_alpha;
        a * fu + (1.0 - a) * fa
    }

    /// `[start tree, goal tree, local trees…]`.
    pub fn trees(&self) -> &[Tree] {
        &self.trees
    }

    /// Stable id of each tree of [`Planner::trees`], same order: 0 start, 1 goal, local
    /// trees from 2 upwards in creation order, never reused.
    pub fn tree_ids(&self) -> &[u32] {
        &self.tree_ids
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

    /// The operator's travelled path as PATH sampling sees it.
    pub fn user_path(&self) -> &[Se3] {
        &self.user_path
    }
}

#[cfg(test)]
mod tests;
