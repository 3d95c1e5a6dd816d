//! The planner process: IPC and timing around the pure [`Planner`] core. [`run`] opens the
//! services, starts the receiver thread and runs the main loop until told to stop; what it
//! did comes back as a [`ShellReport`]. Set-up failures are a [`ShellError`]; once running,
//! nothing fails: what cannot be sent is logged and skipped.
//!
//! Threads:
//! - *receiver*: polls the [`ipc_types::HapticState`] blackboard phase-locked to the loop's ticks
//!   ([`pacing::StatePacer`]: about one absolute-deadline wake-up per tick, just before
//!   the state is written, then a short spin until it is; `state_poll_hz` until it has locked on), counts every new tick it
//!   sees (and those it skipped, from sequence gaps), and keeps the newest operator pose for
//!   the planning thread. Polling rather than an event: the haptic loop must not call
//!   `notify()` from its RT thread (see `ipc_types::services`).
//! - *main*: runs planner iterations as fast as they go and, independently of their speed,
//!   publishes [`Guidance`] at `guidance_rate_hz`, the [`ipc_types::Path`] once solved, and roadmap
//!   increments for viewers ([`ipc_types::Roadmap`], filled by
//!   [`feed::RoadmapFeed`]: O(1024) nodes per sample whatever the roadmap's
//!   size) at `roadmap_rate_hz`. Never waits for the haptic loop or a viewer: a roadmap
//!   sample that cannot be loaned is skipped, and a full viewer queue overflows safely.

/// How long after a state is read the planner publishes guidance (when one is due): the
/// receiver reads nine states in ten within this of their write (`ipc-latency`).
const GUIDANCE_AFTER_STATE: Duration = Duration::from_micros(50);

pub mod convert;
mod error;
pub mod feed;
#[doc(hidden)]
pub mod test_trees;
pub use ipc_types::pacing;
mod receiver;

pub use error::ShellError;
use planner_core::memory::{MemoryBound, MemoryGuard, MemoryReport, Shed};
use planner_core::no_way::{self, NoWay};
use planner_core::portfolio::{Portfolio, PortfolioParams, PortfolioReport};
use planner_core::{IterReport, Planner, PlannerParams, Scene, Se3, Source};

use convert::{operator_pose, to_wire_path, user_input};
use feed::{FeedInfo, RoadmapFeed};
use ipc_types::services::{self, GuidanceNotifier, Publisher};
use ipc_types::{Guidance, GuidanceMode, Header};
use receiver::{Operator, lock, receive_states};
use serde::Serialize;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Everything the planner process needs, validated.
#[derive(Debug, Clone)]
pub struct ShellConfig {
    /// IPC namespace shared with the haptic loop.
    pub namespace: String,
    /// The scene to plan in.
    pub scene: Scene,
    /// Core parameters.
    pub params: PlannerParams,
    /// RNG seed.
    pub seed: u64,
    /// Guidance publish rate, Hz.
    pub guidance_rate_hz: f64,
    /// k for the translational part of F_s, N/m (before a solution).
    pub gain_n_per_m: f64,
    /// k for the rotational part of F_s, N·m/rad (before a solution).
    pub gain_nm_per_rad: f64,
    /// Once solved, the force the path's guidance saturates at, N: its samples carry
    /// `k = lead_force_n / params.lead_saturation_m` ([`make_guidance`]).
    pub lead_force_n: f64,
    /// Once solved, the torque the path's guidance saturates at, N·m: `k =
    /// lead_torque_nm / params.lead_saturation_rad`.
    pub lead_torque_nm: f64,
    /// Time-to-live written into each guidance sample, s.
    pub ttl_s: f64,
    /// How often the receiver thread polls the haptic state before it has locked onto the
    /// loop's ticks, and while no new state comes, Hz.
    pub state_poll_hz: f64,
    /// Longest time the receiver spins for a predicted state after waking before it, µs
    /// (0: never spins; see [`pacing`]).
    pub state_spin_us: f64,
    /// SCHED_FIFO priority of the state receiver thread (0: the normal scheduler).
    pub state_priority: u8,
    /// A haptic state older than this counts as "no operator", s.
    pub state_timeout_s: f64,
    /// Grow the trees also without an operator; otherwise idle until one appears.
    pub plan_without_operator: bool,
    /// Stop after this long (`None` = until SIGINT/SIGTERM).
    pub duration_s: Option<f64>,
    /// Roadmap increments published per second for viewers; 0 publishes none.
    pub roadmap_rate_hz: f64,
    /// The narrow-passage methods taking turns ([`planner_core::portfolio`]); `None`: one planner
    /// with `params`' machine sampler.
    pub portfolio: Option<PortfolioParams>,
    /// Keep the process's heap under this bound ([`planner_core::memory`]); `None`: no
    /// bound (the process installs no heap meter, e.g. a test).
    pub memory: Option<MemoryBound>,
}

/// What a planner run did; written as JSON by `--json`.
#[derive(Debug, Clone, Serialize, Default)]
pub struct ShellReport {
    /// Seconds the process ran.
    pub run_s: f64,
    /// The `planner_id` its guidance carried.
    pub planner_id: u32,
    /// A solution was found.
    pub solved: bool,
    /// Seconds from start to solution.
    pub time_to_solve_s: Option<f64>,
    /// Planner iterations.
    pub iterations: u64,
    /// Nodes in all trees.
    pub nodes: u64,
    /// Collision checks.
    pub collision_checks: u64,
    /// Waypoints of the published path (0 if unsolved).
    pub path_waypoints: u64,
    /// Distinct haptic states received.
    pub states_received: u64,
    /// Haptic states the loop published that this process did not see (sequence gaps).
    pub states_skipped: u64,
    /// Received states per second, between the first and the last one received.
    pub state_rate_hz: f64,
    /// Guidance samples published.
    pub guidance_published: u64,
    /// Haptic states rejected as invalid (non-finite or non-unit pose).
    pub states_rejected: u64,
    /// Times a new haptic loop (restarted after a crash) was found and followed.
    pub loops_followed: u64,
    /// Seconds spent idle for want of an operator (no fresh haptic state).
    pub idle_s: f64,
    /// Publish → receive of each new haptic state: the loop's stamp just before its
    /// blackboard write (`published_ns`) → the receiver thread's read that first saw it, µs.
    /// Includes the receiver's own wake-up latency.
    pub state_latency_us: ipc_types::latency::Percentiles,
    /// Age of each new haptic state when the receiver first saw it: its header stamp (the
    /// loop's tick wake-up) → that read, µs: [`Self::state_latency_us`] plus the tick's
    /// compute before publishing.
    pub state_age_us: ipc_types::latency::Percentiles,
    /// Roadmap increments published.
    pub roadmap_published: u64,
    /// Roadmap increments skipped because no sample could be loaned.
    pub roadmap_skipped: u64,
    /// H-RRT-C's authority (`fixed` or `adaptive`).
    pub authority: String,
    /// Times the adaptive authority took every sample from a stuck operator (its trust
    /// fell to 0).
    pub authority_takeovers: u64,
    /// Times it gave the operator its share back after it had started taking it.
    pub authority_restores: u64,
    /// Operator samples in shallow collision pushed out to a free configuration and used
    /// (touch retraction, `PlannerParams::touch_depth_m`).
    pub touched: u64,
    /// Of those, the ones a tree reached (added as nodes).
    pub touched_nodes: u64,
    /// Waypoints of the raw solution path that are such nodes.
    pub touched_on_path: u64,
    /// Mean time the main thread spent on one roadmap increment (loan, fill, send), µs.
    pub roadmap_publish_mean_us: f64,
    /// Longest time the main thread spent on one roadmap increment, µs.
    pub roadmap_publish_max_us: f64,
    /// The iterations until the solution by where their sample came from.
    pub samples: SampleTally,
    /// With a portfolio: what each method did, and which one solved.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub portfolio: Option<PortfolioReport>,
    /// Longest planner iteration or portfolio turn, ms: guidance and roadmap publishing
    /// wait for it.
    pub longest_turn_ms: f64,
    /// Under a memory bound: the heap's baseline, peak and end, and what was shed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub memory: Option<MemoryReport>,
    /// Longest shed, ms (guidance waits for it too).
    pub longest_shed_ms: f64,
    /// Proved at start: there is no way from the start to the goal
    /// ([`planner_core::no_way`]); the message names the ball and the obstacles around
    /// the region the start can reach. The planner then does not plan, and its guidance
    /// says so ([`GuidanceMode::NO_WAY`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub no_way: Option<String>,
}

/// The planner the shell runs: one, or a portfolio whose main planner holds the roadmap
/// the operator feels and the solution, whichever method found it.
enum Engine {
    Single(Box<Planner>),
    Portfolio(Box<Portfolio>),
}

impl Engine {
    fn new(config: &ShellConfig) -> Result<Self, planner_core::PlannerError> {
        let (scene, params, seed) = (&config.scene, config.params.clone(), config.seed);
        Ok(match &config.portfolio {
            Some(p) => Engine::Portfolio(Box::new(Portfolio::new(scene, params, p.clone(), seed)?)),
            None => Engine::Single(Box::new(Planner::new(scene, params, seed)?)),
        })
    }

    /// The planner whose roadmap, guidance and solution the operator gets.
    fn main(&self) -> &Planner {
        match self {
            Engine::Single(p) => p,
            Engine::Portfolio(p) => p.main(),
        }
    }

    /// One iteration, or one portfolio turn: the main planner's report, if it iterated.
    fn iterate(&mut self, input: Option<&planner_core::UserInput>) -> Option<IterReport> {
        match self {
            Engine::Single(p) => Some(p.iterate_input(input)),
            Engine::Portfolio(p) => p.turn(input),
        }
    }

    /// Sheds about `fraction` of the nodes ([`Planner::shed`], [`Portfolio::shed`]).
    fn shed(&mut self, fraction: f64) -> Shed {
        match self {
            Engine::Single(p) => p.shed(fraction),
            Engine::Portfolio(p) => p.shed(fraction),
        }
    }

    fn report(&self) -> Option<PortfolioReport> {
        match self {
            Engine::Single(_) => None,
            Engine::Portfolio(p) => Some(p.report()),
        }
    }
}

/// Iterations by where their sample came from ([`planner_core::Source`]), and what they added:
/// how much of the trees each kind of sample grew (H-RRT-C's shares at work).
#[derive(Debug, Clone, Copy, Serialize, Default, PartialEq)]
pub struct SampleTally {
    /// Samples without the operator: uniform (with the goal bias) and bridge tests.
    pub machine: SourceTally,
    /// The operator's in free space (q_device, or a stand-in near its travelled path).
    pub operator: SourceTally,
    /// HapticSampling on the contact plane.
    pub contact: SourceTally,
}

/// What the iterations of one kind of sample did.
#[derive(Debug, Clone, Copy, Serialize, Default, PartialEq)]
pub struct SourceTally {
    /// Iterations that drew such a sample.
    pub iterations: u64,
    /// Nodes they added to all trees (the extend towards the sample and the connect).
    pub nodes_added: u64,
    /// Iterations that added no node: the first step towards the sample collided, or
    /// the sample already was a node of tree A and B's connect added none.
    pub barren: u64,
    /// Iterations whose sample was new ground that a tree reached ([`IterReport::novel`]).
    pub novel: u64,
}

impl SampleTally {
    /// Counts one iteration; one that did no work (already solved) is not counted.
    pub fn add(&mut self, r: &IterReport) {
        if r.sample.is_none() {
            return;
        }
        let t = match r.source {
            Source::Uniform | Source::BridgeTest => &mut self.machine,
            Source::User => &mut self.operator,
            Source::Contact => &mut self.contact,
        };
        t.iterations += 1;
        t.nodes_added += u64::from(r.nodes_added);
        t.barren += u64::from(r.nodes_added == 0);
        t.novel += u64::from(r.novel);
    }

    /// Shares of the iterations (machine, operator, contact), each in [0, 1].
    pub fn shares(&self) -> [f64; 3] {
        let all = (self.machine.iterations + self.operator.iterations + self.contact.iterations)
            .max(1) as f64;
        [
            self.machine.iterations as f64 / all,
            self.operator.iterations as f64 / all,
            self.contact.iterations as f64 / all,
        ]
    }
}

/// Runs the planner process until `stop` is set or the duration elapses.
pub fn run(config: &ShellConfig, stop: Arc<AtomicBool>) -> Result<ShellReport, ShellError> {
    run_with_guidance_out(config, stop, &|_| {})
}

/// As [`run`], and hands each guidance sample to `out` too, from the planning thread just
/// before it is published locally (`planner serve --bridge-connect` puts it on Zenoh
/// there).
pub fn run_with_guidance_out(
    config: &ShellConfig,
    stop: Arc<AtomicBool>,
    out: &dyn Fn(&Guidance),
) -> Result<ShellReport, ShellError> {
    let mut shell = Shell::start(config, stop)?;
    while shell.running() {
        shell.cycle(out);
    }
    Ok(shell.finish())
}

/// The services a running planner publishes on, and the node that owns them.
struct Ports {
    node: iceoryx2::node::Node<services::Ipc>,
    guidance: Publisher<Guidance>,
    guidance_event: GuidanceNotifier,
    path: Publisher<ipc_types::Path>,
    /// `None` when no roadmap is published (`roadmap_rate_hz` 0).
    roadmap: Option<Publisher<ipc_types::Roadmap>>,
}

/// When the main thread's periodic steps are next due.
struct Schedule {
    started: Instant,
    guidance_period: Duration,
    next_guidance: Instant,
    roadmap_period: Duration,
    next_roadmap: Instant,
    last_connection_update: Instant,
}

/// A running planner process: the engine, its ports, the receiver thread, and what the
/// main thread counts. [`Shell::start`] sets it up, [`Shell::cycle`] is one pass of the
/// main thread, [`Shell::finish`] stops the receiver and writes the report.
struct Shell<'a> {
    config: &'a ShellConfig,
    stop: Arc<AtomicBool>,
    engine: Engine,
    ports: Ports,
    operator: Arc<Mutex<Operator>>,
    receiver: std::thread::JoinHandle<receiver::StateLatency>,
    feed: RoadmapFeed,
    schedule: Schedule,
    pid: u32,
    guidance_seq: u64,
    path_seq: u64,
    roadmap_publish_total_us: f64,
    announced_operator: bool,
    authority_log: AuthorityLog,
    /// The memory bound, armed once the services are open.
    memory: Option<MemoryGuard>,
    report: ShellReport,
}

impl<'a> Shell<'a> {
    /// Builds the planner, then opens the services and starts the state receiver. The
    /// planner comes first (collision trees of big meshes take seconds): until the node
    /// exists, a signal ends the process at once (`ipc_types::startup`).
    fn start(config: &'a ShellConfig, stop: Arc<AtomicBool>) -> Result<Self, ShellError> {
        let started = Instant::now();
        let engine = Engine::new(config)?;
        if let Some(p) = &config.portfolio {
            let names: Vec<_> = p.methods.iter().map(|m| m.name()).collect();
            tracing::info!("portfolio: {} taking turns", names.join(", "));
        }
        tracing::debug!("planner built in {:.2} s", started.elapsed().as_secs_f64());
        let no_way = prove_no_way(config, &engine, &stop);
        let (node, cleaned) = services::create_node(&format!("planner_{}", std::process::id()))?;
        if cleaned > 0 {
            tracing::info!("removed resources of {cleaned} dead iceoryx2 node(s)");
        }
        let ns = &config.namespace;
        let roadmap = if config.roadmap_rate_hz > 0.0 {
            Some(services::publisher::<ipc_types::Roadmap>(&node, ns)?)
        } else {
            None
        };
        let ports = Ports {
            guidance: services::publisher::<Guidance>(&node, ns)?,
            guidance_event: services::guidance_notifier(&node, ns)?,
            path: services::publisher::<ipc_types::Path>(&node, ns)?,
            roadmap,
            node,
        };
        let operator = Arc::new(Mutex::new(Operator::default()));
        let receiver = spawn_receiver(config, &ports, operator.clone(), stop.clone())?;
        let planner_id = new_planner_id();
        tracing::info!("planner id {planner_id:08x}");
        // Armed last: the baseline holds the planner, the services and the receiver.
        let memory = config.memory.map(MemoryGuard::new).transpose()?;
        if let Some(g) = &memory {
            tracing::info!(
                "memory bound {} MiB, {:.1} MiB of heap at start",
                g.bound_bytes() >> 20,
                g.baseline_bytes() as f64 / (1 << 20) as f64
            );
        }
        let now = Instant::now();
        Ok(Shell {
            memory,
            config,
            stop,
            engine,
            ports,
            operator,
            receiver,
            feed: RoadmapFeed::new(),
            schedule: Schedule {
                started,
                guidance_period: Duration::from_secs_f64(1.0 / config.guidance_rate_hz),
                next_guidance: now,
                roadmap_period: Duration::from_secs_f64(1.0 / config.roadmap_rate_hz.max(1e-3)),
                next_roadmap: now,
                last_connection_update: now,
            },
            pid: std::process::id(),
            guidance_seq: 0,
            path_seq: 0,
            roadmap_publish_total_us: 0.0,
            announced_operator: false,
            authority_log: AuthorityLog::default(),
            report: ShellReport {
                planner_id,
                no_way,
                authority: config.params.authority.name().to_owned(),
                ..ShellReport::default()
            },
        })
    }

    /// Until stopped, or the configured duration is up.
    fn running(&self) -> bool {
        let elapsed = self.schedule.started.elapsed().as_secs_f64();
        !self.stop.load(Ordering::Acquire) && !self.config.duration_s.is_some_and(|d| elapsed >= d)
    }

    /// One pass of the main thread: see who is at the arm, plan (or wait), and publish
    /// what is due. Nothing here fails: what cannot be sent is logged and skipped.
    fn cycle(&mut self, out: &dyn Fn(&Guidance)) {
        let (op, fresh) = self.operator();
        self.announce(fresh);
        self.plan_or_wait(&op, fresh);
        let now = Instant::now();
        self.publish_guidance_when_due(now, out);
        self.publish_roadmap_when_due(now);
        self.refresh_connections();
    }

    /// The newest operator state, and whether it is fresh.
    fn operator(&self) -> (Operator, bool) {
        let op = *lock(&self.operator);
        let fresh = op
            .fresh_seen_at(Instant::now(), self.config.state_timeout_s)
            .is_some();
        (op, fresh)
    }

    /// Says when a haptic loop appears or goes.
    fn announce(&mut self, fresh: bool) {
        if fresh == self.announced_operator {
            return;
        }
        if fresh {
            tracing::info!("haptic loop present: following the operator");
        } else if self.config.plan_without_operator {
            tracing::info!("no fresh haptic state: planning without the operator");
        } else {
            tracing::info!("no fresh haptic state: idle until a haptic loop appears");
        }
        self.announced_operator = fresh;
    }

    /// One planner iteration or portfolio turn with the operator's input; with no operator
    /// to plan with (and `plan_without_operator` off), or once solved, a sleep until the
    /// next guidance is due.
    fn plan_or_wait(&mut self, op: &Operator, fresh: bool) {
        if !fresh && !self.config.plan_without_operator {
            let t0 = Instant::now();
            self.sleep_until_guidance_is_due();
            self.report.idle_s += t0.elapsed().as_secs_f64();
            return;
        }
        if self.engine.main().solved() || self.report.no_way.is_some() {
            self.sleep_until_guidance_is_due();
            return;
        }
        if !self.within_memory_bound() {
            self.sleep_until_guidance_is_due();
            return;
        }
        let input = op.state.filter(|_| fresh).and_then(|s| user_input(&s));
        let t0 = Instant::now();
        let r = self.engine.iterate(input.as_ref());
        // Guidance waits for the turn in progress: its longest is the planner's worst
        // delay of a guidance sample.
        let turn_ms = t0.elapsed().as_secs_f64() * 1e3;
        self.report.longest_turn_ms = self.report.longest_turn_ms.max(turn_ms);
        if let Some(r) = r {
            self.report.samples.add(&r);
        }
        self.authority_log.update(&self.engine.main().authority());
        if self.engine.main().solved() {
            self.publish_solution();
        }
    }

    /// Checks the heap against the bound and sheds when asked to; false when the heap is
    /// at the bound with nothing left to shed (the planner then stops growing).
    fn within_memory_bound(&mut self) -> bool {
        let Some(guard) = &mut self.memory else {
            return true;
        };
        let engine = &mut self.engine;
        let mut took_ms = None;
        let keep = guard.keep(|f| {
            let t0 = Instant::now();
            let s = engine.shed(f);
            took_ms = Some(t0.elapsed().as_secs_f64() * 1e3);
            s
        });
        if let Some(ms) = took_ms {
            self.report.longest_shed_ms = self.report.longest_shed_ms.max(ms);
            let d = guard.dropped();
            tracing::info!(
                "memory: heap past {:.0} % of the {} MiB bound: shed in {ms:.0} ms, {} nodes dropped so far ({} sheds)",
                planner_core::memory::SHED_AT * 100.0,
                guard.bound_bytes() >> 20,
                d.nodes,
                d.sheds
            );
        }
        if !keep && guard.report().full_stops == 1 {
            tracing::warn!(
                "the heap is at the memory bound and nothing more can be shed: the trees stop growing"
            );
        }
        keep
    }

    fn sleep_until_guidance_is_due(&self) {
        let now = Instant::now();
        std::thread::sleep(self.schedule.next_guidance.saturating_duration_since(now));
    }

    /// The path, once, when the planner has just solved; and a log line saying so.
    fn publish_solution(&mut self) {
        let t = self.schedule.started.elapsed().as_secs_f64();
        self.report.time_to_solve_s = Some(t);
        let planner = self.engine.main();
        if let Some(sol) = planner.solution() {
            self.path_seq += 1;
            let path = to_wire_path(sol, planner, self.path_seq, self.pid);
            self.report.path_waypoints = path.len;
            if let Err(e) = self.ports.path.send_copy(path) {
                tracing::warn!("cannot publish path: {e:?}");
            }
        }
        let s = planner.stats();
        let by = match &self.engine {
            Engine::Portfolio(p) => p
                .solved_by()
                .map(|m| format!(" on a {} turn", m.name()))
                .unwrap_or_default(),
            Engine::Single(_) => String::new(),
        };
        tracing::info!(
            "solved after {t:.2} s{by}: {} iterations, {} nodes, {} waypoints",
            s.iterations,
            s.nodes,
            self.report.path_waypoints
        );
    }

    /// Guidance for the newest state (not the one the iteration started with), when due.
    fn publish_guidance_when_due(&mut self, now: Instant, out: &dyn Fn(&Guidance)) {
        let sched = &mut self.schedule;
        if now < sched.next_guidance {
            return;
        }
        let op = *lock(&self.operator);
        let seen_at = op.fresh_seen_at(now, self.config.state_timeout_s);
        let q_user = op
            .state
            .filter(|_| seen_at.is_some())
            .and_then(|s| operator_pose(&s));
        sched.next_guidance = match seen_at {
            // Phase-locked to the loop's ticks: a little after a state comes, so that
            // each sample is computed from a tick's state as soon as it is read and
            // reaches the next tick with most of a period to spare for the relay. (A
            // free-running timer keeps whatever phase it started with, as the guidance
            // period is a whole number of ticks: just before a tick, the relay misses
            // it and the sample is rendered a tick later.)
            Some(t) => t + sched.guidance_period + GUIDANCE_AFTER_STATE,
            None => sched.next_guidance + sched.guidance_period,
        };
        if sched.next_guidance < now {
            sched.next_guidance = now + sched.guidance_period;
        }
        self.guidance_seq += 1;
        let mut g = make_guidance(
            self.config,
            self.engine.main(),
            q_user.as_ref(),
            &op,
            self.guidance_seq,
            self.pid,
            self.report.planner_id,
        );
        if self.report.no_way.is_some() {
            g.mode = GuidanceMode::NO_WAY;
            g.attractive = [0.0; 6];
        }
        out(&g);
        publish_guidance(&self.ports.guidance, &self.ports.guidance_event, g);
        self.report.guidance_published += 1;
    }

    /// A roadmap increment for viewers, when due.
    fn publish_roadmap_when_due(&mut self, now: Instant) {
        let Some(rp) = &self.ports.roadmap else {
            return;
        };
        if now < self.schedule.next_roadmap {
            return;
        }
        self.schedule.next_roadmap = now + self.schedule.roadmap_period;
        let t0 = Instant::now();
        let sent = publish_roadmap(rp, &mut self.feed, self.engine.main(), self.pid);
        let us = t0.elapsed().as_secs_f64() * 1e6;
        self.roadmap_publish_total_us += us;
        self.report.roadmap_publish_max_us = self.report.roadmap_publish_max_us.max(us);
        if sent {
            self.report.roadmap_published += 1;
        } else {
            self.report.roadmap_skipped += 1;
        }
    }

    /// Every 200 ms: delivers the path history to subscribers that joined late.
    fn refresh_connections(&mut self) {
        if self.schedule.last_connection_update.elapsed() > Duration::from_millis(200) {
            use iceoryx2::port::update_connections::UpdateConnections;
            let _ = self.ports.path.update_connections();
            self.schedule.last_connection_update = Instant::now();
        }
    }

    /// Stops the receiver and reports what the process did.
    fn finish(self) -> ShellReport {
        self.stop.store(true, Ordering::Release);
        let mut report = self.report;
        if let Ok(latency) = self.receiver.join() {
            report.state_latency_us = latency.transport.percentiles_us();
            report.state_age_us = latency.age.percentiles_us();
        }
        let op = *lock(&self.operator);
        let planner = self.engine.main();
        let s = planner.stats();
        report.portfolio = self.engine.report();
        report.memory = self.memory.as_ref().map(MemoryGuard::report);
        report.run_s = self.schedule.started.elapsed().as_secs_f64();
        let attempts = report.roadmap_published + report.roadmap_skipped;
        if attempts > 0 {
            report.roadmap_publish_mean_us = self.roadmap_publish_total_us / attempts as f64;
        }
        report.solved = planner.solved();
        report.authority_takeovers = self.authority_log.takeovers;
        report.authority_restores = planner.authority().restores;
        report.iterations = s.iterations;
        report.nodes = s.nodes as u64;
        report.touched = s.touched;
        report.touched_nodes = s.touched_nodes;
        report.touched_on_path = s.touched_on_path as u64;
        report.collision_checks = s.collision_checks;
        report.states_received = op.received;
        report.states_skipped = op.skipped;
        report.states_rejected = op.rejected;
        report.loops_followed = op.loop_generations;
        report.state_rate_hz = match (op.first_at, op.last_at) {
            (Some(a), Some(b)) if b > a => (op.received - 1) as f64 / (b - a).as_secs_f64(),
            _ => 0.0,
        };
        report
    }
}

/// The sound check for "no way through" ([`planner_core::no_way`]), before the first
/// iteration: the proof's message when there is certainly none.
fn prove_no_way(config: &ShellConfig, engine: &Engine, stop: &AtomicBool) -> Option<String> {
    let started = Instant::now();
    let verdict = no_way::prove_with(&config.scene, engine.main().checker(), &|| {
        stop.load(Ordering::Acquire)
    });
    let took_s = started.elapsed().as_secs_f64();
    match verdict {
        NoWay::Certain(proof) => {
            tracing::warn!("{proof} (checked in {took_s:.2} s)");
            Some(proof.to_string())
        }
        other => {
            tracing::info!("{other} (checked in {took_s:.2} s)");
            None
        }
    }
}

/// Starts the thread that receives the haptic state into `operator` (at SCHED_FIFO
/// `state_priority` when it may).
fn spawn_receiver(
    config: &ShellConfig,
    ports: &Ports,
    operator: Arc<Mutex<Operator>>,
    stop: Arc<AtomicBool>,
) -> Result<std::thread::JoinHandle<receiver::StateLatency>, ShellError> {
    let state_source = services::StateFollower::open(&ports.node, &config.namespace)?;
    let poll_ns = (1e9 / config.state_poll_hz) as u64;
    let spin_ns = (config.state_spin_us * 1e3) as u64;
    let priority = config.state_priority;
    std::thread::Builder::new()
        .name("planner-rx".into())
        .spawn(move || {
            if priority > 0
                && let Err(e) = ipc_types::set_thread_fifo_priority(priority)
            {
                tracing::warn!("state receiver: {e}; it keeps the normal scheduler");
            }
            receive_states(state_source, operator, &stop, poll_ns, spin_ns)
        })
        .map_err(|source| ShellError::Thread {
            thread: "state receiver (planner-rx)",
            source,
        })
}

/// A random non-zero identity for this planner's guidance ([`Guidance::planner_id`]). The
/// standard library's hash seeds are random per process, so no random-number crate is
/// needed for one number; the pid and the clock are mixed in so two processes started in
/// the same instant differ even if the seeds did not.
fn new_planner_id() -> u32 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u32(std::process::id());
    h.write_u64(ipc_types::monotonic_ns());
    let v = h.finish();
    ((v >> 32) as u32 ^ v as u32).max(1)
}

/// Logs the adaptive authority's turns: when it has taken every sample from a stuck
/// operator, and when the operator's share comes back.
#[derive(Default)]
struct AuthorityLog {
    taken: bool,
    takeovers: u64,
}

impl AuthorityLog {
    fn update(&mut self, a: &planner_core::AuthorityState) {
        if !self.taken && a.trust == 0.0 {
            self.taken = true;
            self.takeovers += 1;
            tracing::info!(
                "authority: no progress for {:.1} s: machine share {:.2} in contact, {:.2} in free space",
                a.stagnant_s,
                a.machine_share_contact,
                a.machine_share_free
            );
        } else if self.taken && a.trust == 1.0 {
            self.taken = false;
            tracing::info!(
                "authority: the operator progresses: machine share back to {:.2} in contact, {:.2} in free space",
                a.machine_share_contact,
                a.machine_share_free
            );
        }
    }
}

/// The guidance sample of this moment. Before a solution F_a is I-RRT's barycenter with
/// the gains `gain_n_per_m` and `gain_nm_per_rad`; after it, the lead along the path
/// ([`planner_core::guidance::PathGuide::force`]), whose pull and turn saturate at the core's
/// `lead_saturation_m` and `lead_saturation_rad`, with the gains that render those as
/// `lead_force_n` and `lead_torque_nm`.
fn make_guidance(
    config: &ShellConfig,
    planner: &Planner,
    q_user: Option<&Se3>,
    op: &Operator,
    seq: u64,
    pid: u32,
    planner_id: u32,
) -> Guidance {
    let s = planner.stats();
    let (attractive, mode) = match q_user {
        Some(q) => {
            let fa = planner.attractive_force(q);
            let mode = if planner.solved() {
                GuidanceMode::PATH
            } else {
                GuidanceMode::ROADMAP
            };
            (fa.into(), mode)
        }
        None => ([0.0; 6], GuidanceMode::NONE),
    };
    let (gain_n_per_m, gain_nm_per_rad) = if planner.solved() {
        lead_gains(config)
    } else {
        (config.gain_n_per_m, config.gain_nm_per_rad)
    };
    Guidance {
        header: Header::new(seq, ipc_types::monotonic_ns(), pid),
        attractive,
        gain_n_per_m,
        gain_nm_per_rad,
        time_to_live_ns: (config.ttl_s * 1e9) as u64,
        state_sequence: op.state.map_or(0, |s| s.header.sequence),
        mode,
        solved: u32::from(planner.solved()),
        iterations: s.iterations,
        nodes: s.nodes as u64,
        trees: s.trees as u32,
        planner_id,
        distance_to_goal: s.best_distance_to_goal,
        collision_checks: s.collision_checks,
    }
}

/// The gains of the path's guidance: N/m and N·m/rad that render the core's saturated
/// pull and turn as `lead_force_n` and `lead_torque_nm`.
pub fn lead_gains(config: &ShellConfig) -> (f64, f64) {
    let p = &config.params;
    (
        config.lead_force_n / p.lead_saturation_m,
        config.lead_torque_nm / p.lead_saturation_rad,
    )
}

/// Fills a loaned sample in place and sends it; false (and a debug log) when no sample
/// could be loaned or sent: skipped, never waited for.
fn publish_roadmap(
    publisher: &Publisher<ipc_types::Roadmap>,
    feed: &mut RoadmapFeed,
    planner: &Planner,
    pid: u32,
) -> bool {
    let mut sample = match publisher.loan() {
        Ok(s) => s,
        Err(e) => {
            tracing::debug!("roadmap sample skipped: {e:?}");
            return false;
        }
    };
    let info = FeedInfo {
        iterations: planner.stats().iterations,
        solved: planner.solved(),
        pid,
        timestamp_ns: ipc_types::monotonic_ns(),
    };
    feed.fill(
        planner.trees(),
        planner.tree_ids(),
        info,
        sample.payload_mut(),
    );
    match sample.send() {
        Ok(_) => true,
        Err(e) => {
            tracing::debug!("roadmap sample not sent: {e:?}");
            false
        }
    }
}

/// Sends `g` and wakes the loop's relay thread, which then hands it to the next tick.
fn publish_guidance(publisher: &Publisher<Guidance>, event: &GuidanceNotifier, g: Guidance) {
    if let Err(e) = publisher.send_copy(g) {
        tracing::warn!("cannot publish guidance: {e:?}");
        return;
    }
    // Without the wake-up the relay still polls: a failed notification only costs latency.
    if let Err(e) = event.notify() {
        tracing::debug!("cannot notify the guidance event: {e:?}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(scene: Scene) -> ShellConfig {
        ShellConfig {
            namespace: "test".into(),
            scene,
            params: PlannerParams::default(),
            seed: 1,
            guidance_rate_hz: 100.0,
            gain_n_per_m: 20.0,
            gain_nm_per_rad: 0.05,
            lead_force_n: 2.0,
            lead_torque_nm: 0.1,
            ttl_s: 0.1,
            state_poll_hz: 2000.0,
            state_spin_us: 0.0,
            state_priority: 0,
            state_timeout_s: 0.5,
            plan_without_operator: false,
            duration_s: None,
            roadmap_rate_hz: 0.0,
            portfolio: None,
            memory: None,
        }
    }

    #[test]
    fn the_tally_counts_each_iteration_by_its_samples_source() {
        use nalgebra::Vector3;
        use planner_core::{Contact, Sampling, UserInput};
        let scene = Scene::wall_with_hole();
        let params = PlannerParams {
            sampling: Sampling::Hrrtc { alpha: 0.3 },
            ..PlannerParams::default()
        };
        let mut planner = Planner::new(&scene, params, 1).expect("planner");
        let mut tally = SampleTally::default();
        // In free space: α = 0.3 machine samples, the rest the operator's.
        let free = UserInput::free(Se3::from_xyz(-0.1, 0.1, 0.0));
        for _ in 0..1000 {
            tally.add(&planner.iterate_input(Some(&free)));
        }
        // In contact (the paper's fixed rule): HapticSampling only.
        let contact = UserInput {
            contact: Some(Contact {
                point_m: Vector3::new(-0.01, 0.0, 0.0),
                normal: -Vector3::x(),
                force_n: Vector3::new(5.0, 0.0, 2.0),
                displacement_m: Vector3::new(0.0, 0.0, 0.001),
                proxy: Se3::from_xyz(-0.0605, 0.0, 0.0),
            }),
            ..UserInput::free(Se3::from_xyz(-0.05, 0.0, 0.0))
        };
        for _ in 0..1000 {
            if planner.solved() {
                break;
            }
            tally.add(&planner.iterate_input(Some(&contact)));
        }
        let s = planner.stats();
        let t = &tally;
        let sum = |f: fn(&SourceTally) -> u64| f(&t.machine) + f(&t.operator) + f(&t.contact);
        assert_eq!(sum(|k| k.iterations), s.iterations);
        // Every node but the two roots came from some iteration.
        assert_eq!(sum(|k| k.nodes_added), s.nodes as u64 - 2);
        assert!(
            (250..350).contains(&t.machine.iterations),
            "{}",
            t.machine.iterations
        );
        assert!(t.operator.iterations > 600, "{t:?}");
        assert!(t.contact.iterations > 0, "{t:?}");
        for k in [&t.machine, &t.operator, &t.contact] {
            assert!(k.novel <= k.iterations && k.barren <= k.iterations, "{k:?}");
        }
        let shares = t.shares();
        assert!(
            (shares.iter().sum::<f64>() - 1.0).abs() < 1e-12,
            "{shares:?}"
        );
        // An iteration that did nothing (already solved: no sample) is not counted.
        let mut idle = planner.iterate_input(Some(&free));
        idle.sample = None;
        let before = *t;
        tally.add(&idle);
        assert_eq!(tally, before);
    }

    #[test]
    fn a_portfolio_engine_solves_through_its_main_planner_and_reports_its_methods() {
        let mut c = config(Scene::wall_with_square_hole(0.3));
        assert!(Engine::new(&c).expect("engine").report().is_none());
        c.portfolio = Some(PortfolioParams::default());
        let mut engine = Engine::new(&c).expect("engine");
        let mut tally = SampleTally::default();
        let op = planner_core::UserInput::free(Se3::from_xyz(-0.1, 0.05, 0.0));
        for _ in 0..200_000 {
            if engine.main().solved() {
                break;
            }
            if let Some(r) = engine.iterate(Some(&op)) {
                tally.add(&r);
            }
        }
        assert!(engine.main().solved());
        let report = engine.report().expect("a portfolio report");
        let methods: Vec<_> = report.methods.iter().map(|m| m.method.as_str()).collect();
        assert_eq!(methods, ["uniform", "bridge-test", "aligned", "thinning"]);
        assert!(report.solved_by.is_some());
        // The main planner's iterations are the tally's, whoever's turn they were.
        let t = &tally;
        assert_eq!(
            t.machine.iterations + t.operator.iterations + t.contact.iterations,
            engine.main().stats().iterations
        );
        // Guidance comes from the main planner's path.
        let op = Operator::default();
        let g = make_guidance(&c, engine.main(), Some(&c.scene.start), &op, 1, 1, 7);
        assert_eq!(g.mode, GuidanceMode::PATH);
    }

    /// The force and torque the loop renders from `g` (before its device bound), N, N·m.
    fn rendered(g: &Guidance) -> (f64, f64) {
        let a = &g.attractive;
        let f = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() * g.gain_n_per_m;
        let t = (a[3] * a[3] + a[4] * a[4] + a[5] * a[5]).sqrt() * g.gain_nm_per_rad;
        (f, t)
    }

    #[test]
    fn the_paths_guidance_saturates_at_the_lead_force_and_torque() {
        let c = config(Scene::wall_with_square_hole(0.3));
        let mut planner = Planner::new(&c.scene, c.params.clone(), c.seed).expect("planner");
        let op = Operator::default();
        let start = c.scene.start;
        let g = make_guidance(&c, &planner, Some(&start), &op, 1, 1, 7);
        assert_eq!((g.gain_n_per_m, g.gain_nm_per_rad), (20.0, 0.05));
        assert_eq!(g.mode, GuidanceMode::ROADMAP);
        for _ in 0..5000 {
            if planner.iterate(None).solved {
                break;
            }
        }
        assert!(planner.solved());
        let g = make_guidance(&c, &planner, Some(&start), &op, 2, 1, 7);
        assert_eq!(g.mode, GuidanceMode::PATH);
        assert_eq!((g.gain_n_per_m, g.gain_nm_per_rad), (40.0, 0.2));
        assert_eq!(lead_gains(&c), (40.0, 0.2));
        // At the start the carrot is 0.1 weighted m ahead: the pull is at its saturation
        // unless the path turns there, and neither part ever exceeds its lead level.
        let (f, t) = rendered(&g);
        assert!(
            f > 0.0 && f <= 2.0 + 1e-9 && t <= 0.1 + 1e-9,
            "{f} N, {t} N·m"
        );
        // 4 cm behind the start on the line to the goal, the pull saturates at 2 N.
        let behind = Se3::from_xyz(start.pos.x - 0.04, start.pos.y, start.pos.z);
        let g = make_guidance(&c, &planner, Some(&behind), &op, 3, 1, 7);
        let (f, _) = rendered(&g);
        assert!((f - 2.0).abs() < 1e-9, "{f} N");
    }
}
