//! A portfolio of the narrow-passage methods with the operator, in one planner: the
//! operator's samples and uniform machine samples (H-RRT-C), the bridge test, samples
//! turned square to an obstacle, and small-step retraction, taking turns on one core.
//!
//! Why one process and turns: the haptic loop needs the other core of a 2-core machine,
//! and no single method wins everywhere (uniform sampling solves open scenes fastest;
//! only thinning, or the operator, passes the bug trap's slots). Where cores allow, several
//! planner processes can serve one loop as OR-parallel planners, each with its own
//! portfolio and seed (the loop renders the best one's guidance).
//!
//! - The *main* planner ([`Planner`]) holds the roadmap the operator feels. Each of its
//!   iterations samples the operator as its sampling method says (H-RRT-C: q_device, or
//!   contact samples, in 1 − α); its machine samples come from the method whose turn it
//!   is: [`Method::Uniform`], [`Method::BridgeTest`] (every machine sample a bridge test)
//!   or [`Method::Aligned`] (every machine sample square to an obstacle).
//! - [`Method::Thinning`] runs a [`ThinnedPlanner`] for a slice of
//!   [`PortfolioParams::slice_checks`] collision checks a turn. Its thinned plan samples
//!   the operator too: a configuration free for the real object is free for a thinned
//!   object whose parts lie inside the real ones ([`crate::retraction::shrinks_inside`]),
//!   so where the operator passes a slot, so can the thinned plan. Its path, once carried
//!   to the real object, becomes the main planner's solution
//!   ([`Planner::adopt_solution`]), and the operator is guided along it.
//!
//! **Sharing the time** (a bandit that matches probabilities to measured rates): each
//! method keeps a reward and a cost, both forgotten at the same rate as it spends its own
//! checks (a window of about [`PortfolioParams::memory_checks`] checks). The cost of a turn
//! is its collision checks and clearance queries (what the time goes on; counted, so the
//! sharing is deterministic for a seed and an input sequence, with no clock). The reward
//! is what the tally counts: a machine sample's new ground (1, [`IterReport::novel`])
//! and its nodes (0.1 each, at most 1), local trees merged (1 each); thinning's new ground
//! in its thinned plans, and [`STAGE_REWARD`] for each stage it finishes. A method's share
//! of the checks is [`PortfolioParams::floor`] plus the rest in proportion to its reward
//! per check; the next turn goes to a method drawn with probability proportional to its
//! share over its mean cost per turn. Methods start from one optimistic turn of reward
//! [`PRIOR_REWARD`], so each is tried early. Iterations that drew the operator's sample
//! are the operator's: they count for no method (the operator's share is α's business).
//!
//! Deterministic for a seed and an input sequence, like [`crate::rrt`].

use crate::params::{MachineSampler, PlannerError, PlannerParams};
use crate::retraction::{ThinnedPlanner, ThinningParams, shrinks_inside};
use crate::rrt::{IterReport, Planner};
use crate::sampling::UserInput;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use scene::Scene;
use serde::Serialize;

/// A method of the portfolio.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Method {
    /// Uniform machine samples.
    Uniform,
    /// Machine samples by the bridge test ([`MachineSampler::BridgeTest`], share 1).
    BridgeTest,
    /// Machine samples turned square to an obstacle ([`crate::aligned`], share 1).
    Aligned,
    /// Small-step retraction ([`crate::retraction`]), seeded by the operator.
    Thinning,
}

impl Method {
    /// Every method, in report order.
    pub const ALL: [Method; 4] = [
        Method::Uniform,
        Method::BridgeTest,
        Method::Aligned,
        Method::Thinning,
    ];

    /// Name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Method::Uniform => "uniform",
            Method::BridgeTest => "bridge-test",
            Method::Aligned => "aligned",
            Method::Thinning => "thinning",
        }
    }

    /// The method of a name, `None` for an unknown one.
    pub fn parse(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// Reward of one finished thinning stage (a thinned plan solved, or its path carried one
/// scale further): worth this many samples on new ground.
pub const STAGE_REWARD: f64 = 10.0;

/// Reward of a method's optimistic first turn.
pub const PRIOR_REWARD: f64 = 1.0;

/// Tuning of the portfolio.
#[derive(Clone, Debug, PartialEq)]
pub struct PortfolioParams {
    /// The methods that take turns (at least one, none twice).
    pub methods: Vec<Method>,
    /// Least share of the checks each method gets, in [0, 1 / methods) (default 0.2, a
    /// fifth each of four: the reward, new ground a check, undervalues thinning, whose
    /// worth is a stage finished; on ten live seeds 0.2 solved twist-windows 10 of 10
    /// against 8 of 10 at 0.05, the bug trap as fast; docs/experiments.md): a method that
    /// gave nothing lately still gets tried, as the roadmap changes.
    pub floor: f64,
    /// How many of its own checks a method's rate remembers (default 50 000, a second or
    /// two of work): older rewards and costs fade by e^(−checks / memory).
    pub memory_checks: f64,
    /// Checks of one thinning turn (default 500: a few milliseconds).
    pub slice_checks: u64,
    /// Reward of a node a machine sample added (default 0.1; a sample's nodes earn at
    /// most 1).
    pub node_reward: f64,
    /// The thinned plan's authority over the operator's samples, with H-RRT-C: `None`
    /// keeps the planner's own (the paper's fixed α by default); an adaptive one gives
    /// the machine a growing share while the operator makes no progress, so an operator
    /// stuck at an opening does not hold the thinned plan there.
    pub thinning_authority: Option<crate::authority::Authority>,
    /// σ of the bridge test's second end, weighted m (default 0.01).
    pub bridge_sigma: f64,
    /// The small-step retraction's stages (default from 0.45 in steps of 0.05, the bug
    /// trap's best offline: docs/guide/planner-and-scenes.md).
    pub thinning: ThinningParams,
}

impl Default for PortfolioParams {
    fn default() -> Self {
        PortfolioParams {
            methods: Method::ALL.to_vec(),
            floor: 0.2,
            memory_checks: 50_000.0,
            slice_checks: 500,
            node_reward: 0.1,
            thinning_authority: None,
            bridge_sigma: 0.01,
            thinning: ThinningParams::from_first(0.45, 0.05).expect("valid stages"),
        }
    }
}

impl PortfolioParams {
    /// Checks the fields; the error names the first bad one.
    pub fn validate(&self) -> Result<(), PlannerError> {
        let bad = |name, reason: String| Err(PlannerError::InvalidParam { name, reason });
        if self.methods.is_empty() {
            return bad("portfolio.methods", "needs at least one method".into());
        }
        for (i, m) in self.methods.iter().enumerate() {
            if self.methods[..i].contains(m) {
                return bad("portfolio.methods", format!("{} is listed twice", m.name()));
            }
        }
        let n = self.methods.len() as f64;
        if !(self.floor.is_finite() && self.floor >= 0.0 && self.floor * n < 1.0) {
            return bad(
                "portfolio.floor",
                format!("must be in [0, 1/{n}) for {n} methods, got {}", self.floor),
            );
        }
        if !(self.memory_checks.is_finite() && self.memory_checks > 0.0) {
            return bad(
                "portfolio.memory_checks",
                format!("must be > 0, got {}", self.memory_checks),
            );
        }
        if !(self.node_reward.is_finite() && self.node_reward >= 0.0) {
            return bad(
                "portfolio.node_reward",
                format!("must be >= 0, got {}", self.node_reward),
            );
        }
        if self.slice_checks == 0 {
            return bad("portfolio.slice_checks", "must be > 0".into());
        }
        if !(self.bridge_sigma.is_finite() && self.bridge_sigma > 0.0) {
            return bad(
                "portfolio.bridge_sigma",
                format!("must be > 0, got {}", self.bridge_sigma),
            );
        }
        self.thinning.validate()
    }
}

/// What one method did so far.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MethodTally {
    /// Turns it took.
    pub turns: u64,
    /// Iterations of its turns whose sample was a machine sample (thinning: its steps).
    pub iterations: u64,
    /// Collision checks and clearance queries of those.
    pub checks: u64,
    /// Nodes they added (thinning: to its own planners).
    pub nodes_added: u64,
    /// Their samples on new ground.
    pub novel: u64,
    /// Reward earned ([`crate::portfolio`]'s rule).
    pub reward: f64,
}

/// A method's forgetting rate estimate and its totals.
#[derive(Clone, Copy, Debug)]
struct Arm {
    method: Method,
    /// Faded reward and cost (checks).
    reward: f64,
    cost: f64,
    /// Faded turns (for the mean cost of a turn).
    turns: f64,
    tally: MethodTally,
}

impl Arm {
    fn new(method: Method, prior_cost: f64) -> Self {
        Arm {
            method,
            reward: PRIOR_REWARD,
            cost: prior_cost,
            turns: 1.0,
            tally: MethodTally::default(),
        }
    }

    fn record(&mut self, reward: f64, checks: u64, memory: f64) {
        let fade = (-(checks as f64) / memory).exp();
        self.reward = self.reward * fade + reward;
        self.cost = self.cost * fade + checks as f64;
        self.turns = self.turns * fade + 1.0;
        self.tally.turns += 1;
        self.tally.checks += checks;
        self.tally.reward += reward;
    }

    /// Reward per check (the cost never falls below one check).
    fn rate(&self) -> f64 {
        self.reward / self.cost.max(1.0)
    }

    fn mean_turn_cost(&self) -> f64 {
        (self.cost / self.turns.max(1e-9)).max(1.0)
    }
}

/// The portfolio planner. See the module docs.
pub struct Portfolio {
    main: Planner,
    thinning: Option<ThinnedPlanner>,
    params: PortfolioParams,
    arms: Vec<Arm>,
    rng: ChaCha8Rng,
    /// Which method found the solution.
    solved_by: Option<Method>,
    /// Whether every part of the object shrinks inside itself (the operator's
    /// configurations are then free for every thinned stage).
    operator_seeds_thinning: bool,
    thinning_error: Option<String>,
}

impl Portfolio {
    /// Builds the main planner (`params`, whose machine sampler the turns override) and,
    /// when [`Method::Thinning`] is listed, the small-step retraction with the same
    /// parameters and another seed. Errors name the scene or the first bad parameter.
    pub fn new(
        scene: &Scene,
        params: PlannerParams,
        portfolio: PortfolioParams,
        seed: u64,
    ) -> Result<Self, PlannerError> {
        portfolio.validate()?;
        let aligned = portfolio.methods.contains(&Method::Aligned);
        let main_params = PlannerParams {
            // Builds the aligned candidates once; each turn sets the share it wants.
            aligned_share: if aligned { 1.0 } else { params.aligned_share },
            ..params.clone()
        };
        let mut main = Planner::new(scene, main_params, seed)?;
        main.set_machine_sampler(MachineSampler::Uniform, 0.0);
        let thinning = if portfolio.methods.contains(&Method::Thinning) {
            let mut params = params;
            if let (Some(a), crate::sampling::Sampling::Hrrtc { .. }) =
                (portfolio.thinning_authority, params.sampling)
            {
                params.authority = a;
            }
            Some(ThinnedPlanner::with_checker(
                scene,
                params,
                portfolio.thinning.clone(),
                seed ^ 0x7468_696e,
                main.checker(),
            )?)
        } else {
            None
        };
        let first = portfolio.thinning.scales[0];
        let operator_seeds_thinning = scene.moving_object.iter().all(|p| shrinks_inside(p, first));
        let arms = portfolio
            .methods
            .iter()
            .map(|&m| {
                let prior = match m {
                    Method::Thinning => portfolio.slice_checks as f64,
                    _ => 10.0,
                };
                Arm::new(m, prior)
            })
            .collect();
        Ok(Portfolio {
            main,
            thinning,
            params: portfolio,
            arms,
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x706f_7274),
            solved_by: None,
            operator_seeds_thinning,
            thinning_error: None,
        })
    }

    /// One turn with the operator's input (or none): a main-planner iteration with the
    /// drawn method's machine sampler, or a slice of thinning. Returns the main
    /// iteration's report, `None` after a thinning turn. Does nothing once solved.
    ///
    /// A thinned plan that cannot be built (its scene is checked when the portfolio is
    /// made, so only a thinned non-convex part that collides at the start or goal of a
    /// join could do it) ends thinning for good: its error is kept for the report
    /// ([`Portfolio::thinning_error`]) and the other methods go on.
    pub fn turn(&mut self, input: Option<&UserInput>) -> Option<IterReport> {
        if self.solved() {
            return None;
        }
        if self.arms.is_empty() {
            // Thinning was the only method and failed: the main planner goes on alone.
            self.main.set_machine_sampler(MachineSampler::Uniform, 0.0);
            return Some(self.main.iterate_input(input));
        }
        let i = self.draw();
        let method = self.arms[i].method;
        if method == Method::Thinning {
            if let Err(e) = self.thinning_turn(i, input) {
                self.thinning = None;
                self.thinning_error = Some(e.to_string());
                self.arms.remove(i);
            }
            return None;
        }
        let (sampler, aligned) = match method {
            Method::BridgeTest => (
                MachineSampler::BridgeTest {
                    share: 1.0,
                    sigma: self.params.bridge_sigma,
                },
                0.0,
            ),
            Method::Aligned => (MachineSampler::Uniform, 1.0),
            _ => (MachineSampler::Uniform, 0.0),
        };
        self.main.set_machine_sampler(sampler, aligned);
        let before = checks_of(&self.main);
        let report = self.main.iterate_input(input);
        if !report.from_user && report.sample.is_some() {
            let checks = checks_of(&self.main) - before;
            let nodes = f64::from(report.nodes_added);
            let reward = f64::from(u8::from(report.novel))
                + (self.params.node_reward * nodes).min(1.0)
                + f64::from(report.merged);
            let memory = self.params.memory_checks;
            let arm = &mut self.arms[i];
            arm.record(reward, checks, memory);
            arm.tally.iterations += 1;
            arm.tally.nodes_added += u64::from(report.nodes_added);
            arm.tally.novel += u64::from(report.novel);
        }
        if report.solved && self.solved_by.is_none() {
            self.solved_by = Some(method);
        }
        Some(report)
    }

    /// Why thinning stopped taking turns, if it failed.
    pub fn thinning_error(&self) -> Option<&str> {
        self.thinning_error.as_deref()
    }

    fn thinning_turn(&mut self, i: usize, input: Option<&UserInput>) -> Result<(), PlannerError> {
        let Some(thin) = &mut self.thinning else {
            return Ok(());
        };
        let before = thin.stats();
        let checks_before = thin.checks();
        let mut steps = 0u64;
        loop {
            thin.step_with(input)?;
            steps += 1;
            if thin.solved() || thin.checks() - checks_before >= self.params.slice_checks {
                break;
            }
        }
        let after = thin.stats();
        let novel = after.novel - before.novel;
        let stages = after.stages - before.stages;
        let reward = novel as f64 + STAGE_REWARD * stages as f64;
        let memory = self.params.memory_checks;
        let arm = &mut self.arms[i];
        arm.record(reward, thin.checks() - checks_before, memory);
        arm.tally.iterations += steps;
        arm.tally.nodes_added += after.nodes.saturating_sub(before.nodes);
        arm.tally.novel += novel;
        if let Some(path) = thin.solution() {
            let path = path.to_vec();
            self.main.adopt_solution(&path);
            if self.main.solved() && self.solved_by.is_none() {
                self.solved_by = Some(Method::Thinning);
            }
        }
        Ok(())
    }

    /// The index of the method whose turn it is: drawn with probability proportional
    /// to its share of the checks over its mean cost per turn. Called every iteration:
    /// allocates nothing.
    fn draw(&mut self) -> usize {
        let u = self.rng.random::<f64>();
        let rates: f64 = self.arms.iter().map(Arm::rate).sum();
        let weight = |a: &Arm| self.share(a, rates) / a.mean_turn_cost();
        let total: f64 = self.arms.iter().map(weight).sum();
        let mut x = u * total;
        for (i, a) in self.arms.iter().enumerate() {
            let w = weight(a);
            if x < w {
                return i;
            }
            x -= w;
        }
        self.arms.len() - 1
    }

    /// `arm`'s share of the checks: the floor plus the rest by its part of `rates`, the
    /// sum of every method's reward per check.
    fn share(&self, arm: &Arm, rates: f64) -> f64 {
        let n = self.arms.len() as f64;
        let floor = self.params.floor;
        if rates > 0.0 {
            floor + (1.0 - n * floor) * arm.rate() / rates
        } else {
            1.0 / n
        }
    }

    /// Each method's share of the checks now: the floor plus the rest by reward per
    /// check. Same order as [`PortfolioParams::methods`].
    pub fn shares(&self) -> Vec<f64> {
        let rates: f64 = self.arms.iter().map(Arm::rate).sum();
        self.arms.iter().map(|a| self.share(a, rates)).collect()
    }

    /// What each method did, same order as [`PortfolioParams::methods`].
    pub fn tallies(&self) -> Vec<(Method, MethodTally)> {
        self.arms.iter().map(|a| (a.method, a.tally)).collect()
    }

    /// The method whose work solved the problem (the turn's method for the main
    /// planner, even when the operator's sample made the last connection).
    pub fn solved_by(&self) -> Option<Method> {
        self.solved_by
    }

    /// True when every part of the moving object lies inside itself once thinned, so the
    /// operator's configurations are free for the thinned plans.
    pub fn operator_seeds_thinning(&self) -> bool {
        self.operator_seeds_thinning
    }

    /// Sheds about `fraction` of the nodes of the main planner and of thinning's current
    /// plan ([`Planner::shed`], [`ThinnedPlanner::shed`]).
    pub fn shed(&mut self, fraction: f64) -> crate::memory::Shed {
        let mut out = self.main.shed(fraction);
        if let Some(t) = &mut self.thinning {
            out.add(&t.shed(fraction));
        }
        out
    }

    /// True once solved (by the main planner or by thinning).
    pub fn solved(&self) -> bool {
        self.main.solved()
    }

    /// The main planner: its roadmap, guidance and solution.
    pub fn main(&self) -> &Planner {
        &self.main
    }

    /// The small-step retraction, when it takes part.
    pub fn thinning(&self) -> Option<&ThinnedPlanner> {
        self.thinning.as_ref()
    }

    /// The parameters in use.
    pub fn params(&self) -> &PortfolioParams {
        &self.params
    }
}

/// What a portfolio's methods did ([`planner_core::portfolio::MethodTally`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct PortfolioReport {
    /// Every part of the object lies inside itself when thinned: the operator's
    /// configurations are free for the thinned plans.
    pub operator_seeds_thinning: bool,
    /// Why thinning stopped taking turns, if it failed.
    pub thinning_error: Option<String>,
    /// The method whose turn solved it.
    pub solved_by: Option<String>,
    /// Each method's turns, machine iterations, checks, nodes added, new ground, reward
    /// and share of the checks at the end.
    pub methods: Vec<MethodReport>,
}

/// One method of [`PortfolioReport`].
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct MethodReport {
    /// `uniform`, `bridge-test`, `aligned` or `thinning`.
    pub method: String,
    /// Turns taken.
    pub turns: u64,
    /// Iterations with a machine sample (thinning: steps).
    pub iterations: u64,
    /// Collision checks and clearance queries.
    pub checks: u64,
    /// Nodes added.
    pub nodes_added: u64,
    /// Samples on new ground.
    pub novel: u64,
    /// Share of the checks it was given at the end.
    pub share: f64,
}

impl std::fmt::Display for MethodReport {
    /// One line: turns, iterations, checks, nodes, new ground and share.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} {} turns, {} iterations, {} checks, {} nodes, {} on new ground, share {:.2}",
            self.method,
            self.turns,
            self.iterations,
            self.checks,
            self.nodes_added,
            self.novel,
            self.share
        )
    }
}

impl Portfolio {
    /// What each method did so far, and which one solved.
    pub fn report(&self) -> PortfolioReport {
        let p = self;
        let shares = p.shares();
        PortfolioReport {
            operator_seeds_thinning: p.operator_seeds_thinning(),
            thinning_error: p.thinning_error.clone(),
            solved_by: p.solved_by().map(|m| m.name().to_owned()),
            methods: p
                .tallies()
                .into_iter()
                .zip(shares)
                .map(|((m, t), share)| MethodReport {
                    method: m.name().to_owned(),
                    turns: t.turns,
                    iterations: t.iterations,
                    checks: t.checks,
                    nodes_added: t.nodes_added,
                    novel: t.novel,
                    share,
                })
                .collect(),
        }
    }
}

/// `p`'s collision checks and clearance queries so far (its checker's counts: O(1), where
/// [`Planner::stats`] also scans the start tree).
fn checks_of(p: &Planner) -> u64 {
    let c = p.checker();
    c.collision_checks() + c.clearance_queries()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::CollisionChecker;
    use crate::sampling::Sampling;
    use crate::space::{ConfigSpace, Space};
    use nalgebra::Vector3;
    use scene::pose::Se3;
    use scene::{MeshData, Part, Primitive};
    use std::sync::Arc;

    /// The default portfolio on `scene` with default planner parameters.
    fn default_portfolio(scene: &Scene, seed: u64) -> Portfolio {
        Portfolio::new(
            scene,
            PlannerParams::default(),
            PortfolioParams::default(),
            seed,
        )
        .expect("portfolio")
    }

    /// Every edge of `path` free for the real object, checked 0.2 mm or 0.002 rad apart.
    fn assert_free(scene: &Scene, path: &[Se3]) {
        let checker = CollisionChecker::new(scene);
        let space = Space::for_scene(scene, PlannerParams::default().weights);
        for pair in path.windows(2) {
            let n = (space.distance(&pair[0], &pair[1]) / 0.0002)
                .ceil()
                .max(1.0) as usize;
            for i in 0..=n {
                let q = space.interpolate(&pair[0], &pair[1], i as f64 / n as f64);
                assert!(checker.is_free(&q), "collides at {q:?}");
            }
        }
    }

    #[test]
    fn every_method_takes_turns_and_the_tallies_add_up() {
        let scene = Scene::wall_with_square_hole(0.3);
        let mut p = default_portfolio(&scene, 3);
        let mut turns = 0u64;
        while !p.solved() && turns < 200_000 {
            p.turn(None);
            turns += 1;
        }
        assert!(p.solved(), "a wide hole is solved");
        let path = p.main().solution().expect("a path");
        assert_eq!(path.first(), Some(&scene.start));
        assert_eq!(path.last(), Some(&scene.goal));
        assert_free(&scene, path);
        let tallies = p.tallies();
        assert_eq!(
            tallies.iter().map(|(_, t)| t.turns).sum::<u64>(),
            turns,
            "{tallies:?}"
        );
        // Without an operator every main iteration is a machine sample of its turn.
        let main_turns: u64 = tallies
            .iter()
            .filter(|(m, _)| *m != Method::Thinning)
            .map(|(_, t)| t.iterations)
            .sum();
        assert_eq!(main_turns, p.main().stats().iterations);
        let s = p.main().stats();
        let main_checks: u64 = tallies
            .iter()
            .filter(|(m, _)| *m != Method::Thinning)
            .map(|(_, t)| t.checks)
            .sum();
        // The shortcut's checks after the solution belong to no turn.
        assert!(main_checks <= s.collision_checks + s.clearance_queries);
        let report = p.report();
        assert_eq!(report.methods.len(), 4);
        assert!(report.solved_by.is_some());
        assert!(
            report.operator_seeds_thinning,
            "a box shrinks inside itself"
        );
        let shares: f64 = p.shares().iter().sum();
        assert!((shares - 1.0).abs() < 1e-12, "{shares}");
    }

    #[test]
    fn thinning_alone_solves_a_slot_and_its_path_is_the_main_planners() {
        let scene = crate::retraction::tests::slot_scene();
        let params = PortfolioParams {
            methods: vec![Method::Thinning],
            thinning: ThinningParams::from_first(0.5, 0.1).expect("valid"),
            ..PortfolioParams::default()
        };
        let mut p = Portfolio::new(&scene, PlannerParams::default(), params, 4).expect("portfolio");
        let mut turns = 0;
        while !p.solved() && turns < 20_000 {
            assert!(
                p.turn(None).is_none(),
                "no main iteration without its methods"
            );
            turns += 1;
        }
        assert!(p.solved(), "not solved in {turns} turns");
        assert_eq!(p.solved_by(), Some(Method::Thinning));
        assert_eq!(p.main().stats().iterations, 0);
        let path = p.main().solution().expect("adopted");
        assert_eq!(path.first(), Some(&scene.start));
        assert_eq!(path.last(), Some(&scene.goal));
        assert_free(&scene, path);
        // The operator is led along it.
        let fa = p.main().attractive_force(&scene.start);
        assert!(fa.norm() > 0.0);
    }

    #[test]
    fn the_operators_passage_seeds_the_thinned_plan() {
        // α = 0: the thinned plan samples only the operator, who carries the bar through
        // the hole lengthwise; no machine sample could find it.
        let scene = crate::retraction::tests::slot_scene();
        let params = PlannerParams {
            sampling: Sampling::Hrrtc { alpha: 0.0 },
            ..PlannerParams::default()
        };
        let thinning = ThinningParams::from_first(0.5, 0.1).expect("valid");
        let mut thin = ThinnedPlanner::new(&scene, params, thinning, 5).expect("thinned");
        let along = Se3::from_xyz;
        let way = [
            scene.start,
            along(-0.1, 0.0, 0.0),
            along(0.0, 0.0, 0.0),
            along(0.1, 0.0, 0.0),
            scene.goal,
        ];
        let space = Space::for_scene(&scene, PlannerParams::default().weights);
        let mut steps = 0;
        'walk: for pair in way.windows(2) {
            for i in 0..=200 {
                let q = space.interpolate(&pair[0], &pair[1], f64::from(i) / 200.0);
                thin.step_with(Some(&UserInput::free(q))).expect("step");
                steps += 1;
                if thin.scale() > 0.5 {
                    break 'walk;
                }
            }
        }
        assert!(
            thin.scale() > 0.5,
            "the thinned plan is solved by the operator's passage ({steps} steps): {:?}",
            thin.stats()
        );
        // Without the operator (the same sampling, no input) it is not, in as many steps.
        let thinning = ThinningParams::from_first(0.5, 0.1).expect("valid");
        let params = PlannerParams {
            sampling: Sampling::Hrrtc { alpha: 0.0 },
            ..PlannerParams::default()
        };
        let mut alone = ThinnedPlanner::new(&scene, params, thinning, 5).expect("thinned");
        for _ in 0..steps {
            alone.step().expect("step");
        }
        assert_eq!(alone.scale(), 0.5, "{:?}", alone.stats());
    }

    #[test]
    fn shares_follow_reward_per_check_above_the_floor() {
        let scene = Scene::wall_with_square_hole(0.3);
        let mut p = Portfolio::new(
            &scene,
            PlannerParams::default(),
            PortfolioParams {
                floor: 0.05,
                ..PortfolioParams::default()
            },
            1,
        )
        .expect("portfolio");
        // Uniform gives 3 per 100 checks, bridge 1, aligned 0, thinning 1 per 100.
        for (arm, (reward, cost)) in
            p.arms
                .iter_mut()
                .zip([(3.0, 100.0), (1.0, 100.0), (0.0, 100.0), (2.0, 200.0)])
        {
            arm.reward = reward;
            arm.cost = cost;
            arm.turns = 1.0;
        }
        let s = p.shares();
        let rest = 1.0 - 4.0 * 0.05;
        let want = [
            0.05 + rest * 0.6,
            0.05 + rest * 0.2,
            0.05,
            0.05 + rest * 0.2,
        ];
        for (a, b) in s.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{s:?} against {want:?}");
        }
        // Turns are drawn by share over the cost of a turn: thinning's turns cost twice.
        let mut n = [0u32; 4];
        for _ in 0..40_000 {
            n[p.draw()] += 1;
        }
        let w: Vec<f64> = want
            .iter()
            .zip([100.0, 100.0, 100.0, 200.0])
            .map(|(s, c)| s / c)
            .collect();
        let total: f64 = w.iter().sum();
        for (k, wk) in n.iter().zip(&w) {
            let expect = 40_000.0 * wk / total;
            assert!(
                (f64::from(*k) - expect).abs() < 5.0 * expect.sqrt() + 1.0,
                "{n:?} against {w:?}"
            );
        }
    }

    #[test]
    fn a_method_forgets_old_rewards_as_it_spends_checks() {
        let mut arm = Arm::new(Method::Uniform, 10.0);
        arm.record(100.0, 10, 1000.0);
        let early = arm.rate();
        for _ in 0..1000 {
            arm.record(0.0, 10, 1000.0);
        }
        assert!(arm.rate() < 1e-3 * early, "{} against {early}", arm.rate());
        assert_eq!(arm.tally.turns, 1001);
        assert_eq!(arm.tally.checks, 10_010);
        assert_eq!(arm.tally.reward, 100.0);
    }

    #[test]
    fn same_seed_same_turns() {
        let scene = Scene::wall_with_square_hole(0.1);
        let run = || {
            let mut p = default_portfolio(&scene, 9);
            for _ in 0..3000 {
                p.turn(Some(&UserInput::free(Se3::from_xyz(-0.1, 0.02, 0.0))));
            }
            (p.main().stats(), p.tallies())
        };
        assert_eq!(run(), run());
    }

    #[test]
    fn bad_portfolios_are_named() {
        let bad = |p: PortfolioParams| match p.validate() {
            Err(PlannerError::InvalidParam { name, .. }) => name,
            other => panic!("{other:?}"),
        };
        let d = PortfolioParams::default;
        assert_eq!(
            bad(PortfolioParams {
                methods: vec![],
                ..d()
            }),
            "portfolio.methods"
        );
        assert_eq!(
            bad(PortfolioParams {
                methods: vec![Method::Uniform, Method::Uniform],
                ..d()
            }),
            "portfolio.methods"
        );
        assert_eq!(
            bad(PortfolioParams { floor: 0.25, ..d() }),
            "portfolio.floor"
        );
        assert_eq!(
            bad(PortfolioParams {
                memory_checks: 0.0,
                ..d()
            }),
            "portfolio.memory_checks"
        );
        assert_eq!(
            bad(PortfolioParams {
                slice_checks: 0,
                ..d()
            }),
            "portfolio.slice_checks"
        );
        assert_eq!(
            bad(PortfolioParams {
                bridge_sigma: f64::NAN,
                ..d()
            }),
            "portfolio.bridge_sigma"
        );
        for m in Method::ALL {
            assert_eq!(Method::parse(m.name()), Some(m));
        }
        assert_eq!(Method::parse("rrt"), None);
    }

    #[test]
    fn a_part_shrinks_inside_itself_when_convex() {
        let at = Se3::from_xyz(0.0, 0.0, 0.0);
        let mesh = |m: MeshData| Part {
            primitive: Primitive::Mesh { mesh: Arc::new(m) },
            pose: at,
        };
        assert!(shrinks_inside(
            &Part::axis_box([0.01, 0.02, 0.03], [0.0; 3]),
            0.5
        ));
        assert!(shrinks_inside(
            &Part {
                primitive: Primitive::Sphere { radius_m: 0.01 },
                pose: at
            },
            0.5
        ));
        assert!(shrinks_inside(
            &mesh(MeshData::cuboid("box", [0.02, 0.01, 0.005])),
            0.5
        ));
        // A box with a corner pushed in, past its neighbours' faces: closed, not convex.
        let mut dented = MeshData::cuboid("dented", [0.02, 0.02, 0.02]);
        dented.vertices_m[0] *= 0.5;
        dented.repair = None;
        assert!(matches!(
            dented.surface(),
            scene::repair::Surface::ClosedOutward
        ));
        assert!(!shrinks_inside(&mesh(dented), 0.5));
        // An open sheet has no inside to lie in.
        let sheet = MeshData {
            source: "sheet".into(),
            vertices_m: vec![Vector3::zeros(), Vector3::x() * 0.01, Vector3::y() * 0.01],
            triangles: vec![[0, 1, 2]],
            repair: None,
        };
        assert!(!shrinks_inside(&mesh(sheet), 0.5));
    }

    #[test]
    fn a_solution_adopted_must_join_this_start_to_this_goal() {
        let scene = Scene::wall_with_square_hole(0.3);
        let mut p = Planner::new(&scene, PlannerParams::default(), 1).expect("planner");
        p.adopt_solution(&[scene.start, Se3::from_xyz(0.0, 0.0, 0.5)]);
        assert!(!p.solved());
        p.adopt_solution(&[]);
        assert!(!p.solved());
        let mid = Se3::from_xyz(0.0, 0.0, 0.0);
        p.adopt_solution(&[scene.start, mid, scene.goal]);
        assert!(p.solved());
        assert_eq!(p.raw_solution(), Some(&[scene.start, mid, scene.goal][..]));
    }
}
