//! Small-step retraction (Saha & Latombe, "Finding narrow passages with probabilistic
//! roadmap planners: the small-step retraction method", Autonomous Robots 19, 2005): a
//! passage too narrow to sample is widened by thinning the object, planned through at
//! that size, and the path is then carried back to the real object in small steps.
//!
//! Stages: plan with the object shrunk to `scales[0]` (each part about its own centre, so
//! a shrunk part lies inside the real one); then, for each further scale up to 1, *repair*
//! the previous stage's path: walk it at the edge resolution, keep every configuration the
//! larger object can take, *retract* the others to a free configuration nearby (a random
//! descent of the penetration depth from it, small Gaussian steps taken when they go less
//! deep, until one lands free and joined to the path), and join consecutive kept
//! configurations by a free edge or, where the edge collides, by a small RRT-Connect
//! between them (`repair_iterations`). A repair that cannot retract or join is tried
//! again from the same path (`stage_retries`), then the work starts over from a new
//! thinned plan with the next seed; so does a thinned plan not solved within
//! `plan_iterations` (RRT run times are heavy tailed). The final stage uses the real object and
//! the configured edge check, so the path is as valid as any other planner's.
//!
//! Chosen where the paper leaves it open: the object is shrunk uniformly about each part's
//! centre (the paper thins links along their medial axes); retraction is a random descent
//! of parry's deepest penetration (the paper's is a random search of the same kind);
//! stages grow in the steps given.
//!
//! Like [`crate::rrt`], deterministic for a seed: [`ThinnedPlanner::step`] does a bounded
//! piece of work so that a caller can hold it to a wall-clock limit.

use crate::collision::CollisionChecker;
use crate::params::{PlannerError, PlannerParams};
use crate::rrt::Planner;
use crate::sampling::UserInput;
use crate::space::{ConfigSpace, Space};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use scene::pose::Se3;
use scene::{MeshData, Part, Primitive, Scene, bounding_box};
use std::sync::Arc;

/// Tuning of the small-step retraction.
#[derive(Clone, Debug, PartialEq)]
pub struct ThinningParams {
    /// Object scales of the stages before the real object, increasing, each in (0, 1)
    /// (default 0.3, 0.55, 0.8).
    pub scales: Vec<f64>,
    /// Steps of the random descent that retracts one configuration (default 400), each
    /// of per-axis σ a quarter of the edge resolution (weighted m).
    pub retract_tries: u32,
    /// Iterations of the RRT-Connect that joins two retracted configurations whose edge
    /// collides (default 5 000). It plans within [`JOIN_MARGIN_M`] of the two.
    pub repair_iterations: u64,
    /// A thinned plan not solved after this many iterations starts over with the next
    /// seed (default 600 000, about 12 s on the bug trap here): RRT run times are heavy
    /// tailed, and restarts cut the tail (Wedge & Branicky, "On heavy-tailed runtimes and
    /// restarts in rapidly-exploring random trees", AAAI workshop 2008).
    pub plan_iterations: u64,
    /// Times a repair that failed is tried again from the same path before a new thinned
    /// plan (default 3): a failed join is often bad luck, a path of the wrong kind (one
    /// the thin object takes and the real one cannot) fails every time.
    pub stage_retries: u32,
}

/// A join's RRT-Connect samples reference points within this margin (m) of the box
/// spanned by the two configurations it joins.
pub const JOIN_MARGIN_M: f64 = 0.04;

impl Default for ThinningParams {
    fn default() -> Self {
        ThinningParams {
            scales: vec![0.3, 0.55, 0.8],
            retract_tries: 400,
            repair_iterations: 5_000,
            plan_iterations: 600_000,
            stage_retries: 3,
        }
    }
}

impl ThinningParams {
    /// Stages from `first` up in steps of `step` below 1 (e.g. 0.45, 0.05: 0.45, 0.5, …,
    /// 0.95), the other fields at their defaults; checked.
    pub fn from_first(first: f64, step: f64) -> Result<Self, PlannerError> {
        if !(step.is_finite() && step > 0.0 && step < 1.0) {
            return Err(PlannerError::InvalidParam {
                name: "thinning.step",
                reason: format!("must be in (0, 1), got {step}"),
            });
        }
        if !(first.is_finite() && first > 0.0 && first < 1.0) {
            return Err(PlannerError::InvalidParam {
                name: "thinning.scales",
                reason: format!("the first scale must be in (0, 1), got {first}"),
            });
        }
        // Rounded to 1e-9 so that 0.45 + 11 × 0.05 lands on 1 and is not a stage.
        let scales = (0..)
            .map(|i| ((first + f64::from(i) * step) * 1e9).round() / 1e9)
            .take_while(|s| *s < 1.0)
            .collect();
        let t = ThinningParams {
            scales,
            ..ThinningParams::default()
        };
        t.validate()?;
        Ok(t)
    }

    /// Checks the fields; the error names the first bad one.
    pub fn validate(&self) -> Result<(), PlannerError> {
        let bad = |name, reason: String| Err(PlannerError::InvalidParam { name, reason });
        if self.scales.is_empty() {
            return bad("thinning.scales", "needs at least one scale below 1".into());
        }
        let mut prev = 0.0;
        for &s in &self.scales {
            if !(s.is_finite() && s > prev && s < 1.0) {
                return bad(
                    "thinning.scales",
                    format!("must increase within (0, 1), got {:?}", self.scales),
                );
            }
            prev = s;
        }
        if self.retract_tries == 0 {
            return bad("thinning.retract_tries", "must be > 0".into());
        }
        if self.repair_iterations == 0 {
            return bad("thinning.repair_iterations", "must be > 0".into());
        }
        if self.plan_iterations == 0 {
            return bad("thinning.plan_iterations", "must be > 0".into());
        }
        Ok(())
    }
}

/// `scene` with every part of the moving object shrunk by `scale` about its own centre
/// (a box's and a sphere's centre, a mesh's bounding-box centre).
pub fn thinned(scene: &Scene, scale: f64) -> Scene {
    let mut out = scene.clone();
    out.name = format!("{} (object × {scale})", scene.name);
    for part in &mut out.moving_object {
        *part = shrink(part, scale);
    }
    out
}

/// Largest mesh (vertices × triangles) [`shrinks_inside`] tests for convexity.
const CONVEXITY_TEST_MAX: usize = 50_000_000;

/// True when `part` shrunk by `scale` about its own centre (as [`thinned`] does) is known
/// to lie inside the real part, so that a configuration free for the real object is free
/// for the thinned one: boxes and spheres always; a mesh when it is closed and outward and
/// convex (every vertex and the centre behind every triangle's plane, to 1e-9 of its size),
/// tested up to [`CONVEXITY_TEST_MAX`] vertex–triangle pairs. False for the others: a
/// non-convex part shrunk about its box's centre can poke out of itself (an L shrinks
/// towards a point outside it), so the operator's configurations are only candidates for
/// the thinned plan, which checks every sample.
pub fn shrinks_inside(part: &Part, scale: f64) -> bool {
    if !(scale > 0.0 && scale <= 1.0) {
        return false;
    }
    let Primitive::Mesh { mesh } = &part.primitive else {
        return true;
    };
    let v = &mesh.vertices_m;
    if v.is_empty()
        || v.len().saturating_mul(mesh.triangles.len()) > CONVEXITY_TEST_MAX
        || !matches!(mesh.surface(), scene::repair::Surface::ClosedOutward)
    {
        return false;
    }
    let (lo, hi) = bounding_box(v);
    let centre = (lo + hi) * 0.5;
    let tol = 1e-9 * (hi - lo).norm();
    mesh.triangles.iter().all(|t| {
        let [a, b, c] = t.map(|i| v[i as usize]);
        let n = (b - a).cross(&(c - a));
        let len = n.norm();
        if len == 0.0 {
            return true; // no plane: nothing to be behind
        }
        let n = n / len;
        let behind = |p: &Vector3<f64>| n.dot(&(p - a)) <= tol;
        behind(&centre) && v.iter().all(behind)
    })
}

fn shrink(part: &Part, s: f64) -> Part {
    let primitive = match &part.primitive {
        Primitive::Box { half_extents_m } => Primitive::Box {
            half_extents_m: half_extents_m * s,
        },
        Primitive::Sphere { radius_m } => Primitive::Sphere {
            radius_m: radius_m * s,
        },
        Primitive::Mesh { mesh } => {
            let (lo, hi) = bounding_box(&mesh.vertices_m);
            let c = (lo + hi) * 0.5;
            Primitive::Mesh {
                mesh: Arc::new(MeshData {
                    source: format!("{} × {s}", mesh.source),
                    vertices_m: mesh.vertices_m.iter().map(|v| c + (v - c) * s).collect(),
                    triangles: mesh.triangles.clone(),
                    // Scaling about a point changes neither topology nor winding.
                    repair: mesh.repair.clone(),
                }),
            }
        }
    };
    Part {
        primitive,
        pose: part.pose,
    }
}

/// Work of one stage.
enum Stage {
    /// Planning with the thinnest object.
    Plan(Box<Planner>),
    /// Carrying `from` (a path of the previous scale) to `scales[k]`.
    Repair(Box<Repair>),
    /// The path of the real object.
    Done(Vec<Se3>),
}

/// Carrying one path to a larger object.
struct Repair {
    /// Index into the stage scales (the last is the real object).
    k: usize,
    /// The previous stage's path, kept for a retry.
    from: Vec<Se3>,
    /// Tries of this stage so far, this one included.
    attempt: u32,
    scene: Scene,
    checker: CollisionChecker,
    /// The previous path, walked at the edge resolution.
    walk: Vec<Se3>,
    /// Next index of `walk` to take.
    next: usize,
    /// The repaired path so far (free for this scale, joined by free edges).
    out: Vec<Se3>,
    /// A join in progress: the RRT-Connect from `out`'s last configuration to this one.
    join: Option<(Box<Planner>, Se3)>,
    /// A retraction in progress, one descent step per [`ThinnedPlanner::step`] (a step
    /// is a penetration query, costly between CAD meshes: a whole descent in one step
    /// overran a 60 s limit by 4 s).
    descent: Option<Descent>,
}

/// The state of the random descent ([`descend`]) for one configuration of the walk.
struct Descent {
    /// The configuration of the walk being retracted, and whether it is free itself (its
    /// edge from `last` is what collides).
    q: Se3,
    q_free: bool,
    /// The repaired path's last configuration, the one to join.
    last: Se3,
    /// Where the descent stands and its penetration depth (m).
    at: Se3,
    depth: f64,
    /// The first free configuration met that was not joined to `last`.
    first_free: Option<Se3>,
    tries_left: u32,
}

/// Counts of the work done, over all stages and restarts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ThinningStats {
    /// Planner iterations (thinned plans and joins).
    pub iterations: u64,
    /// Nodes grown by those planners.
    pub nodes: u64,
    /// Collision checks.
    pub collision_checks: u64,
    /// Clearance queries (certified edges).
    pub clearance_queries: u64,
    /// Configurations retracted.
    pub retracted: u64,
    /// Joins planned by RRT-Connect.
    pub joins: u64,
    /// Repairs tried again from the same path.
    pub retries: u64,
    /// Repairs that failed every try, each followed by a new thinned plan.
    pub restarts: u64,
    /// Thinned plans given up after `plan_iterations`, each followed by a new one.
    pub replans: u64,
    /// Samples of the thinned plans that were new ground a tree reached
    /// ([`crate::IterReport::novel`]).
    pub novel: u64,
    /// Stages finished: thinned plans solved and repairs carried through.
    pub stages: u64,
}

impl ThinningStats {
    /// Adds a planner's counts.
    fn add_planner(&mut self, p: &Planner) {
        let s = p.stats();
        self.iterations += s.iterations;
        self.nodes += s.nodes as u64;
        self.collision_checks += s.collision_checks;
        self.clearance_queries += s.clearance_queries;
    }

    /// Adds the checks of a repair's own checker.
    fn add_checker(&mut self, c: &CollisionChecker) {
        self.collision_checks += c.collision_checks();
        self.clearance_queries += c.clearance_queries();
    }
}

/// Automatic planning by small-step retraction. See the module docs.
pub struct ThinnedPlanner {
    scene: Scene,
    params: PlannerParams,
    thinning: ThinningParams,
    /// Scales of the stages, the last 1.
    scales: Vec<f64>,
    seed: u64,
    /// A checker of the real object and the obstacles: the last stage's, and the one
    /// whose obstacle trees every stage shares ([`CollisionChecker::sharing_obstacles`]).
    real: CollisionChecker,
    /// Each thinned stage's scene and a checker of it, built once: the plans, repairs and
    /// joins of a stage share its parts' shapes and trees
    /// ([`CollisionChecker::sharing_parts`]).
    parts: Vec<Option<(Scene, CollisionChecker)>>,
    /// Seeds used so far (each thinned plan and join takes the next).
    seeds_used: u64,
    stage: Stage,
    stats: ThinningStats,
    rng: ChaCha8Rng,
}

impl ThinnedPlanner {
    /// Validates the parameters and the scene (start and goal free for the real object,
    /// hence for shrunk boxes and spheres; a shrunk non-convex mesh that collides there
    /// is an error naming the thinned scene) and starts the thinned plan.
    pub fn new(
        scene: &Scene,
        params: PlannerParams,
        thinning: ThinningParams,
        seed: u64,
    ) -> Result<Self, PlannerError> {
        thinning.validate()?;
        // Checks the real problem first, so that its errors name the real object.
        let real = Planner::new(scene, params.clone(), seed)?;
        Self::start(scene, params, thinning, seed, real.checker())
    }

    /// [`ThinnedPlanner::new`] with a checker of `scene` built before (a portfolio's main
    /// planner's), whose trees it shares instead of building them again.
    pub fn with_checker(
        scene: &Scene,
        params: PlannerParams,
        thinning: ThinningParams,
        seed: u64,
        checker: &CollisionChecker,
    ) -> Result<Self, PlannerError> {
        thinning.validate()?;
        let real = Planner::with_checker(scene, params.clone(), seed, checker)?;
        Self::start(scene, params, thinning, seed, real.checker())
    }

    fn start(
        scene: &Scene,
        params: PlannerParams,
        thinning: ThinningParams,
        seed: u64,
        real: &CollisionChecker,
    ) -> Result<Self, PlannerError> {
        let mut scales = thinning.scales.clone();
        scales.push(1.0);
        let mut me = ThinnedPlanner {
            real: real.sharing_parts(scene, params.weights, params.edge_resolution),
            parts: thinning.scales.iter().map(|_| None).collect(),
            scene: scene.clone(),
            params,
            thinning,
            scales,
            seed,
            seeds_used: 0,
            stage: Stage::Done(Vec::new()),
            stats: ThinningStats::default(),
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x5353_5200),
        };
        me.stage = Stage::Plan(Box::new(me.thin_plan()?));
        Ok(me)
    }

    fn next_seed(&mut self) -> u64 {
        self.seeds_used += 1;
        self.seed
            .wrapping_add(self.seeds_used.wrapping_mul(0x9E37_79B9))
    }

    fn thin_plan(&mut self) -> Result<Planner, PlannerError> {
        let seed = self.next_seed();
        let params = self.params.clone();
        let (scene, checker) = self.stage_parts(0);
        Planner::with_checker(scene, params, seed, checker)
    }

    /// Stage `k`'s scene (the object at `scales[k]`) and a checker of its parts, the
    /// thinned object's built the first time, the obstacles' shared.
    fn stage_parts(&mut self, k: usize) -> (&Scene, &CollisionChecker) {
        let Some(slot) = self.parts.get_mut(k) else {
            return (&self.scene, &self.real);
        };
        let (scene, scale, p, real) = (&self.scene, self.scales[k], &self.params, &self.real);
        let (s, c) = slot.get_or_insert_with(|| {
            let s = thinned(scene, scale);
            let c = real.sharing_obstacles(&s, p.weights, p.edge_resolution);
            (s, c)
        });
        (s, c)
    }

    /// True once the real object's path is found.
    pub fn solved(&self) -> bool {
        matches!(&self.stage, Stage::Done(p) if !p.is_empty())
    }

    /// The real object's path, start → goal, once solved.
    pub fn solution(&self) -> Option<&[Se3]> {
        match &self.stage {
            Stage::Done(p) if !p.is_empty() => Some(p),
            _ => None,
        }
    }

    /// The object scale being worked on now (1 for the real object).
    pub fn scale(&self) -> f64 {
        match &self.stage {
            Stage::Plan(_) => self.scales[0],
            Stage::Repair(r) => self.scales[r.k],
            Stage::Done(_) => 1.0,
        }
    }

    /// Sheds about `fraction` of the current thinned plan's or join's nodes
    /// ([`Planner::shed`]); the paths of finished stages are kept whole.
    pub fn shed(&mut self, fraction: f64) -> crate::memory::Shed {
        match &mut self.stage {
            Stage::Plan(p) => p.shed(fraction),
            Stage::Repair(r) => r
                .join
                .as_mut()
                .map(|(p, _)| p.shed(fraction))
                .unwrap_or_default(),
            Stage::Done(_) => crate::memory::Shed::default(),
        }
    }

    /// Work counts, including the planners still running.
    pub fn stats(&self) -> ThinningStats {
        let mut s = self.stats;
        match &self.stage {
            Stage::Plan(p) => s.add_planner(p),
            Stage::Repair(r) => {
                if let Some((p, _)) = &r.join {
                    s.add_planner(p);
                }
                s.add_checker(&r.checker);
            }
            Stage::Done(_) => {}
        }
        s
    }

    /// Collision checks and clearance queries so far, the running planners' and the
    /// repair's included: the sum [`Self::stats`] gives, without its scan of the trees
    /// (a portfolio reads it after every step).
    pub fn checks(&self) -> u64 {
        let of = |c: &CollisionChecker| c.collision_checks() + c.clearance_queries();
        let done = self.stats.collision_checks + self.stats.clearance_queries;
        done + match &self.stage {
            Stage::Plan(p) => of(p.checker()),
            Stage::Repair(r) => {
                of(&r.checker) + r.join.as_ref().map_or(0, |(p, _)| of(p.checker()))
            }
            Stage::Done(_) => 0,
        }
    }

    /// One bounded piece of work: a planner iteration, or one configuration of a repair.
    /// Does nothing once solved.
    pub fn step(&mut self) -> Result<(), PlannerError> {
        self.step_with(None)
    }

    /// [`ThinnedPlanner::step`] with the operator's input: the thinned plan samples it as
    /// its sampling method says (H-RRT-C: q_device in 1 − α of the samples). Only its
    /// configuration is passed on: the contact the loop reports is the real object's,
    /// and a configuration free for the real object is free for a thinned one whose parts
    /// lie inside the real ones ([`shrinks_inside`]), so the operator's passage through a
    /// slot is a passage for the thinned plan too. Repairs and joins plan without it.
    pub fn step_with(&mut self, input: Option<&UserInput>) -> Result<(), PlannerError> {
        let stage = std::mem::replace(&mut self.stage, Stage::Done(Vec::new()));
        self.stage = match stage {
            Stage::Plan(mut p) => {
                let free = input.map(|u| UserInput {
                    contact: None,
                    ..*u
                });
                let report = p.iterate_input(free.as_ref());
                self.stats.novel += u64::from(report.novel);
                match p.solution() {
                    Some(path) => {
                        let path = path.to_vec();
                        self.stats.add_planner(&p);
                        self.stats.stages += 1;
                        Stage::Repair(Box::new(self.repair(1, path, 1)))
                    }
                    None if p.stats().iterations >= self.thinning.plan_iterations => {
                        self.stats.add_planner(&p);
                        self.stats.replans += 1;
                        Stage::Plan(Box::new(self.thin_plan()?))
                    }
                    None => Stage::Plan(p),
                }
            }
            Stage::Repair(mut r) => match self.repair_step(&mut r)? {
                RepairStep::Working => Stage::Repair(r),
                RepairStep::Failed if r.attempt <= self.thinning.stage_retries => {
                    self.stats.retries += 1;
                    self.stats.add_checker(&r.checker);
                    let Repair {
                        k, from, attempt, ..
                    } = *r;
                    Stage::Repair(Box::new(self.repair(k, from, attempt + 1)))
                }
                RepairStep::Failed => {
                    self.stats.restarts += 1;
                    self.stats.add_checker(&r.checker);
                    Stage::Plan(Box::new(self.thin_plan()?))
                }
                RepairStep::Finished => {
                    let path = crate::path::shortcut(
                        &r.checker,
                        &r.out,
                        self.params.shortcut_attempts,
                        &mut self.rng,
                    );
                    self.stats.add_checker(&r.checker);
                    self.stats.stages += 1;
                    if r.k + 1 < self.scales.len() {
                        Stage::Repair(Box::new(self.repair(r.k + 1, path, 1)))
                    } else {
                        Stage::Done(path)
                    }
                }
            },
            done @ Stage::Done(_) => done,
        };
        Ok(())
    }

    /// Starts carrying `path` to `scales[k]` (try `attempt`).
    fn repair(&mut self, k: usize, path: Vec<Se3>, attempt: u32) -> Repair {
        let (weights, resolution, edge_check) = (
            self.params.weights,
            self.params.edge_resolution,
            self.params.edge_check,
        );
        let (scene, base) = self.stage_parts(k);
        let checker = base
            .sharing_parts(scene, weights, resolution)
            .with_edge_check(edge_check);
        let scene = scene.clone();
        let space = Space::for_scene(&scene, self.params.weights);
        let walk = walk(&space, &path, self.params.edge_resolution);
        Repair {
            k,
            from: path,
            attempt,
            out: vec![walk[0]],
            next: 1,
            walk,
            scene,
            checker,
            join: None,
            descent: None,
        }
    }

    fn repair_step(&mut self, r: &mut Repair) -> Result<RepairStep, PlannerError> {
        if let Some((mut p, to)) = r.join.take() {
            p.iterate(None);
            if let Some(path) = p.solution() {
                r.out.extend_from_slice(&path[1..]);
                self.stats.add_planner(&p);
                debug_assert_eq!(r.out.last(), Some(&to));
            } else if p.stats().iterations >= self.thinning.repair_iterations {
                self.stats.add_planner(&p);
                return Ok(RepairStep::Failed);
            } else {
                r.join = Some((p, to));
            }
            return Ok(RepairStep::Working);
        }
        if let Some(mut d) = r.descent.take() {
            let Some(found) = descend(
                &r.checker,
                &mut d,
                self.params.edge_resolution,
                &mut self.rng,
            ) else {
                r.descent = Some(d);
                return Ok(RepairStep::Working);
            };
            let last = d.last;
            let to = match found {
                Retracted::Joined(c) => {
                    r.out.push(c);
                    return Ok(RepairStep::Working);
                }
                Retracted::Free(c) if !d.q_free => c,
                _ if d.q_free => d.q,
                _ => return Ok(RepairStep::Failed),
            };
            return self.start_join(r, last, to);
        }
        if r.next >= r.walk.len() {
            return Ok(RepairStep::Finished);
        }
        let q = r.walk[r.next];
        r.next += 1;
        let last = *r.out.last().expect("starts with the start");
        let free = r.checker.is_free(&q);
        if free && r.checker.edge_free(&last, &q) {
            r.out.push(q);
            return Ok(RepairStep::Working);
        }
        self.stats.retracted += 1;
        r.descent = Some(Descent {
            q,
            q_free: free,
            last,
            at: q,
            depth: r.checker.penetration_m(&q),
            first_free: None,
            tries_left: self.thinning.retract_tries,
        });
        Ok(RepairStep::Working)
    }

    /// Starts the RRT-Connect that joins `last` to `to` near the two.
    fn start_join(
        &mut self,
        r: &mut Repair,
        last: Se3,
        to: Se3,
    ) -> Result<RepairStep, PlannerError> {
        let mut scene = r.scene.clone();
        scene.start = last;
        scene.goal = to;
        // The operator's route is not part of a join (and may lie outside its bounds).
        scene.route.clear();
        let margin = nalgebra::Vector3::repeat(JOIN_MARGIN_M);
        scene.bounds = scene::Bounds {
            min_m: (last.pos.inf(&to.pos) - margin).sup(&r.scene.bounds.min_m),
            max_m: (last.pos.sup(&to.pos) + margin).inf(&r.scene.bounds.max_m),
        };
        self.stats.joins += 1;
        let seed = self.next_seed();
        let params = PlannerParams {
            shortcut_attempts: 0,
            ..self.params.clone()
        };
        let join = Planner::with_checker(&scene, params, seed, &r.checker)?;
        r.join = Some((Box::new(join), to));
        Ok(RepairStep::Working)
    }
}

enum RepairStep {
    Working,
    Failed,
    Finished,
}

/// `path` with configurations inserted so that consecutive ones are at most `resolution`
/// apart (weighted m).
fn walk(space: &Space, path: &[Se3], resolution: f64) -> Vec<Se3> {
    let mut out = vec![path[0]];
    for pair in path.windows(2) {
        let n = (space.distance(&pair[0], &pair[1]) / resolution)
            .ceil()
            .max(1.0) as usize;
        for i in 1..n {
            out.push(space.interpolate(&pair[0], &pair[1], i as f64 / n as f64));
        }
        // The waypoint itself, not its interpolated twin (start and goal stay exact).
        out.push(pair[1]);
    }
    out
}

/// What [`descend`] found near a configuration.
enum Retracted {
    /// A free configuration joined to the previous one by a free edge.
    Joined(Se3),
    /// Only a free configuration, not joined.
    Free(Se3),
    /// Nothing free.
    None,
}

/// One step of the search for a free configuration near `d.q` that continues the path
/// from `d.last`, by a random descent of the penetration depth: a Gaussian step of per-axis
/// σ `resolution / 4` (weighted m) from where the descent stands, taken when it goes less
/// deep. `Some` once done: the first free configuration joined to `last` by a free edge,
/// else (after `tries_left` steps) the first free one, else nothing.
fn descend(
    checker: &CollisionChecker,
    d: &mut Descent,
    resolution: f64,
    rng: &mut ChaCha8Rng,
) -> Option<Retracted> {
    if d.tries_left == 0 {
        return Some(d.first_free.map_or(Retracted::None, Retracted::Free));
    }
    d.tries_left -= 1;
    let c = checker.space().sample_near(&d.at, 0.25 * resolution, rng);
    if checker.is_free(&c) {
        if checker.edge_free(&d.last, &c) {
            return Some(Retracted::Joined(c));
        }
        d.first_free.get_or_insert(c);
    } else {
        let depth = checker.penetration_m(&c);
        if depth < d.depth {
            (d.at, d.depth) = (c, depth);
        }
    }
    None
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};

    #[test]
    fn a_thinned_part_lies_inside_the_real_one() {
        let mesh = Arc::new(MeshData::cuboid("test box", [0.02, 0.01, 0.005]));
        let mut scene = Scene::bug_trap();
        scene.moving_object = vec![
            Part::axis_box([0.04, 0.018, 0.005], [0.01, 0.0, 0.0]),
            Part {
                primitive: Primitive::Sphere { radius_m: 0.01 },
                pose: Se3::from_xyz(0.0, 0.03, 0.0),
            },
            Part {
                primitive: Primitive::Mesh { mesh: mesh.clone() },
                pose: Se3::from_xyz(0.0, 0.0, 0.02),
            },
        ];
        let thin = thinned(&scene, 0.5);
        assert_eq!(
            thin.obstacles, scene.obstacles,
            "obstacles stay as they are"
        );
        let Primitive::Box { half_extents_m } = thin.moving_object[0].primitive else {
            panic!("a box stays a box");
        };
        assert_eq!(half_extents_m, Vector3::new(0.02, 0.009, 0.0025));
        assert_eq!(thin.moving_object[0].pose, scene.moving_object[0].pose);
        assert_eq!(
            thin.moving_object[1].primitive,
            Primitive::Sphere { radius_m: 0.005 }
        );
        let Primitive::Mesh { mesh: m } = &thin.moving_object[2].primitive else {
            panic!("a mesh stays a mesh");
        };
        for (v, w) in m.vertices_m.iter().zip(&mesh.vertices_m) {
            assert!(
                (v - w * 0.5).norm() < 1e-15,
                "about its centre: {v:?} {w:?}"
            );
        }
        assert_eq!(m.triangles, mesh.triangles);
    }

    #[test]
    fn stages_run_from_the_first_scale_below_one_and_are_checked() {
        let t = ThinningParams::from_first(0.45, 0.05).expect("valid");
        assert_eq!(t.scales.len(), 11);
        assert_eq!(t.scales[0], 0.45);
        assert_eq!(t.scales[10], 0.95);
        assert!(t.validate().is_ok());
        for (scales, tries, joins) in [
            (vec![], 400, 5_000),
            (vec![0.5, 0.5], 400, 5_000),
            (vec![0.5, 1.0], 400, 5_000),
            (vec![f64::NAN], 400, 5_000),
            (vec![0.5], 0, 5_000),
            (vec![0.5], 400, 0),
        ] {
            let t = ThinningParams {
                scales: scales.clone(),
                retract_tries: tries,
                repair_iterations: joins,
                plan_iterations: 600_000,
                stage_retries: 3,
            };
            assert!(
                matches!(t.validate(), Err(PlannerError::InvalidParam { .. })),
                "{scales:?} {tries} {joins}"
            );
        }
        for (first, step) in [
            (1.2, 0.05),
            (0.0, 0.05),
            (0.5, -0.1),
            (0.5, 1.0),
            (f64::NAN, 0.1),
        ] {
            assert!(
                ThinningParams::from_first(first, step).is_err(),
                "{first} {step}"
            );
        }
    }

    /// A 60 × 20 × 20 mm bar that must pass a 24 mm square hole in a 20 mm wall lengthwise,
    /// from and to orientations across it, in a 160 mm square channel.
    pub(crate) fn slot_scene() -> Scene {
        let mut scene = Scene::wall_with_square_hole(0.024);
        scene.name = "slot".into();
        scene.moving_object = vec![Part::axis_box([0.03, 0.01, 0.01], [0.0, 0.0, 0.0])];
        scene.route.clear();
        scene.bounds = scene::Bounds {
            min_m: Vector3::new(-0.25, -0.08, -0.08),
            max_m: Vector3::new(0.25, 0.08, 0.08),
        };
        let quarter = std::f64::consts::FRAC_PI_2;
        scene.start = Se3 {
            pos: Vector3::new(-0.2, 0.05, 0.03),
            rot: UnitQuaternion::from_euler_angles(0.0, 0.0, quarter),
        };
        scene.goal = Se3 {
            pos: Vector3::new(0.2, -0.05, -0.03),
            rot: UnitQuaternion::from_euler_angles(0.0, quarter, 0.0),
        };
        scene
    }

    #[test]
    fn a_path_planned_thin_is_carried_to_the_real_object_free_everywhere() {
        let scene = slot_scene();
        let thinning = ThinningParams::from_first(0.5, 0.1).expect("valid");
        let mut p =
            ThinnedPlanner::new(&scene, PlannerParams::default(), thinning, 4).expect("planner");
        let mut steps = 0;
        while !p.solved() && steps < 400_000 {
            p.step().expect("step");
            steps += 1;
        }
        assert!(p.solved(), "not solved in {steps} steps: {:?}", p.stats());
        assert_eq!(p.scale(), 1.0);
        let path = p.solution().expect("a path");
        assert_eq!(path.first(), Some(&scene.start));
        assert_eq!(path.last(), Some(&scene.goal));
        // An independent dense re-check with the real object: 0.2 mm or 0.002 rad apart.
        let checker = CollisionChecker::new(&scene);
        let space = Space::for_scene(&scene, PlannerParams::default().weights);
        for pair in path.windows(2) {
            for q in walk(&space, pair, 0.0002) {
                assert!(checker.is_free(&q), "collides at {q:?}");
            }
        }
        // The path threads the hole: it crosses the wall's plane within the hole.
        let crossing = path
            .windows(2)
            .find(|w| w[0].pos.x < 0.0 && w[1].pos.x >= 0.0)
            .expect("crosses the wall");
        let t = -crossing[0].pos.x / (crossing[1].pos.x - crossing[0].pos.x);
        let at = crossing[0].pos.lerp(&crossing[1].pos, t);
        assert!(at.y.abs() < 0.012 && at.z.abs() < 0.012, "{at:?}");
        let s = p.stats();
        assert!(s.retracted > 0, "the real object needed retraction: {s:?}");
    }

    #[test]
    fn its_check_count_is_the_stats_sum_at_every_stage() {
        let scene = slot_scene();
        let thinning = ThinningParams::from_first(0.5, 0.1).expect("valid");
        let mut p =
            ThinnedPlanner::new(&scene, PlannerParams::default(), thinning, 4).expect("planner");
        let mut scales = Vec::new();
        while !p.solved() {
            p.step().expect("step");
            let s = p.stats();
            assert_eq!(
                p.checks(),
                s.collision_checks + s.clearance_queries,
                "{s:?}"
            );
            if scales.last() != Some(&p.scale()) {
                scales.push(p.scale());
            }
        }
        assert!(
            scales.len() >= 3,
            "plan, repairs and the real object: {scales:?}"
        );
        assert!(p.stats().joins > 0, "a join ran: {:?}", p.stats());
    }

    #[test]
    fn a_thinned_plan_out_of_iterations_starts_over() {
        let thinning = ThinningParams {
            plan_iterations: 3,
            ..ThinningParams::from_first(0.5, 0.1).expect("valid")
        };
        let mut p = ThinnedPlanner::new(&slot_scene(), PlannerParams::default(), thinning, 2)
            .expect("planner");
        for _ in 0..30 {
            p.step().expect("step");
        }
        // Every third iteration ends a plan unless one solved within three iterations.
        let s = p.stats();
        assert!(s.replans >= 9, "{s:?}");
        assert_eq!(s.iterations, 30, "{s:?}");
    }

    #[test]
    fn a_problem_with_a_colliding_start_is_refused_for_the_real_object() {
        let mut scene = slot_scene();
        scene.start = Se3::from_xyz(0.0, 0.05, 0.0); // inside the wall
        assert!(matches!(
            ThinnedPlanner::new(
                &scene,
                PlannerParams::default(),
                ThinningParams::default(),
                1
            ),
            Err(PlannerError::StartInCollision(_))
        ));
    }
}
