//! What the `haptic-loop` binary runs: `run` (the loop with the simulated arm) and `demo`
//! (the loop plus a planner child process, a scripted operator heading for the hole, and a
//! summary). Arguments are parsed here, validated into a [`LoopSetup`], then run.

use crate::contact::{ContactConfig, ContactModel, ContactStage, Coupling};
use crate::device_select::DeviceChoice;
use crate::guidance::GuidanceConfig;
use crate::mapping::{Mapping, MappingConfig};
use crate::relay::Relay;
use crate::rt::RtOptions;
use crate::runner::{self, LoopReport, RunnerConfig};
use crate::safety::SafetyConfig;
use crate::stats::{Percentiles, SecondSummary};
use crate::tick::{GuidanceSource, StateSink, Tick, TickConfig};
use anyhow::{Context, bail};
use clap::Args;
use devices::HapticDevice;
use devices::sim::{ScriptedUser, ScriptedUserConfig, SimulatedArm, SimulatedArmConfig, Waypoint};
use ipc_types::Guidance;
use ipc_types::services::{self, PathSubscriber, StateReader};
use nalgebra::{Isometry3, Translation3};
use planner::Scene;
use serde::Serialize;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Options of `haptic-loop run` and `haptic-loop demo`.
#[derive(Debug, Args, Clone)]
pub struct LoopArgs {
    /// IPC namespace (service names `hrrtc/<namespace>/...`); the planner must use the same.
    #[arg(long, default_value = services::DEFAULT_NAMESPACE)]
    pub namespace: String,
    /// Scene: `wall-hole` (alias `default`) or a TOML scene file.
    #[arg(long, default_value = "wall-hole")]
    pub scene: String,
    /// Tick rate, Hz (500–4000).
    #[arg(long, default_value_t = 1000.0)]
    pub rate_hz: f64,
    /// SCHED_FIFO priority of the RT thread, 1–99; 0 keeps the normal scheduler.
    #[arg(long, default_value_t = 80)]
    pub priority: u8,
    /// Pin the RT thread to this CPU.
    #[arg(long)]
    pub cpu: Option<usize>,
    /// Do not lock memory (mlockall).
    #[arg(long)]
    pub no_mlock: bool,
    /// Spin this many µs before each deadline instead of sleeping (trades CPU for jitter).
    #[arg(long, default_value_t = 0)]
    pub spin_us: u64,
    /// Scene metres per device metre.
    #[arg(long, default_value_t = 3.0)]
    pub scale: f64,
    /// Guidance fade after its time-to-live, ms.
    #[arg(long, default_value_t = 200.0)]
    pub fade_ms: f64,
    /// Speed of the simulated operator's hand, m/s at the device.
    #[arg(long, default_value_t = 0.02)]
    pub user_speed: f64,
    /// RMS amplitude of the simulated operator's tremor, m (0 = none).
    #[arg(long, default_value_t = 0.0)]
    pub tremor_m: f64,
    /// Voxel size of the contact voxmap and pointshell spacing, mm (0.25–20).
    #[arg(long, default_value_t = 1.0)]
    pub voxel_mm: f64,
    /// Render no contact: the object follows the hand through obstacles.
    #[arg(long)]
    pub no_contact: bool,
    /// Write the summary as JSON here.
    #[arg(long)]
    pub summary_json: Option<PathBuf>,
}

/// Options of `haptic-loop run`.
#[derive(Debug, Args, Clone)]
pub struct RunArgs {
    /// Loop options.
    #[command(flatten)]
    pub common: LoopArgs,
    /// Stop after this many seconds (default: until Ctrl-C / SIGTERM).
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Device selection and recording.
    #[command(flatten)]
    pub device: crate::device_select::DeviceArgs,
}

/// Options of `haptic-loop demo`.
#[derive(Debug, Args, Clone)]
pub struct DemoArgs {
    /// Loop options.
    #[command(flatten)]
    pub common: LoopArgs,
    /// Give up (exit code 1) when the planner has not solved within this many seconds.
    #[arg(long, default_value_t = 120.0)]
    pub time_limit_s: f64,
    /// Keep running this long after the solution, so its guidance can be felt.
    #[arg(long, default_value_t = 3.0)]
    pub after_solve_s: f64,
    /// Run at least this long, so the scripted operator reaches the wall.
    #[arg(long, default_value_t = 8.0)]
    pub min_run_s: f64,
    /// Planner RNG seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The planner's sampling method (`planner serve --sampling`). The default is I-RRT's
    /// POS+CS: the scripted operator is no person and keeps pushing where its route says,
    /// so H-RRT-C's contact mode (`hrrtc`, only samples on the contact plane while in
    /// contact) would wait for it forever.
    #[arg(long, default_value = "pos+cs",
          value_parser = ["cs", "pos", "path", "pos+cs", "path+cs", "hrrtc"])]
    pub sampling: String,
}

/// The validated set-up shared by `run` and `demo`.
#[derive(Debug, Clone)]
pub struct LoopSetup {
    /// IPC namespace.
    pub namespace: String,
    /// Scene name or path as given (passed on to the planner).
    pub scene_arg: String,
    /// The scene.
    pub scene: Scene,
    /// RT thread options.
    pub runner: RunnerConfig,
    /// Tick options.
    pub tick: TickConfig,
    /// Simulated arm.
    pub arm: SimulatedArmConfig,
    /// Simulated operator.
    pub user: ScriptedUserConfig,
    /// Contact rendering parameters; `None` = contact off.
    pub contact: Option<ContactConfig>,
}

impl LoopArgs {
    /// Validates the arguments into a [`LoopSetup`].
    pub fn to_setup(&self) -> anyhow::Result<LoopSetup> {
        let scene = Scene::by_name_or_path(&self.scene)?;
        if !(self.rate_hz.is_finite() && (500.0..=4000.0).contains(&self.rate_hz)) {
            bail!("--rate-hz must be within 500–4000, got {}", self.rate_hz);
        }
        if self.priority > 99 {
            bail!(
                "--priority must be 0 (normal scheduler) or 1–99, got {}",
                self.priority
            );
        }
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        if let Some(cpu) = self.cpu
            && cpu >= cpus
        {
            bail!(
                "--cpu {cpu} does not exist: this machine has CPUs 0–{}",
                cpus - 1
            );
        }
        let pos = |name: &str, v: f64| -> anyhow::Result<f64> {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                bail!("--{name} must be a finite number > 0, got {v}")
            }
        };
        pos("scale", self.scale)?;
        pos("fade-ms", self.fade_ms)?;
        pos("user-speed", self.user_speed)?;
        if !(self.tremor_m.is_finite() && self.tremor_m >= 0.0) {
            bail!(
                "--tremor-m must be a finite number >= 0, got {}",
                self.tremor_m
            );
        }
        if self.spin_us * 1000 >= (1e9 / self.rate_hz) as u64 {
            bail!("--spin-us {} is not shorter than the period", self.spin_us);
        }
        services::validate_namespace(&self.namespace)
            .map_err(|e| anyhow::anyhow!("--namespace: {e}"))?;
        if !(self.voxel_mm.is_finite() && (0.25..=20.0).contains(&self.voxel_mm)) {
            bail!("--voxel-mm must be within 0.25–20, got {}", self.voxel_mm);
        }
        let contact =
            (!self.no_contact).then(|| ContactConfig::with_voxel_m(self.voxel_mm / 1000.0));
        let arm = SimulatedArmConfig::default();
        // Scene origin of the device: the middle of start and goal, so both are reachable.
        let mid = (scene.start.pos + scene.goal.pos) / 2.0;
        let origin = Isometry3::from_parts(Translation3::from(mid), scene.start.rot);
        let reach = ((scene.goal.pos - scene.start.pos).norm() / 2.0) / self.scale;
        if reach > arm.workspace_radius_m * 0.9 {
            bail!(
                "--scale {}: start and goal are {:.3} m from the device centre, beyond the arm's \
                 {:.3} m workspace; use --scale {:.1} or more",
                self.scale,
                reach,
                arm.workspace_radius_m,
                self.scale * reach / (arm.workspace_radius_m * 0.9)
            );
        }
        Ok(LoopSetup {
            namespace: self.namespace.clone(),
            scene_arg: self.scene.clone(),
            scene,
            runner: RunnerConfig {
                rate_hz: self.rate_hz,
                rt: RtOptions {
                    fifo_priority: (self.priority > 0).then_some(self.priority),
                    cpu: self.cpu,
                    lock_memory: !self.no_mlock,
                },
                spin_ns: self.spin_us * 1000,
                max_ticks: None,
            },
            tick: TickConfig {
                mapping: MappingConfig {
                    position_scale: self.scale,
                    origin,
                    clutch_button: Some(1),
                },
                guidance: GuidanceConfig {
                    fade_s: self.fade_ms / 1000.0,
                    ..GuidanceConfig::default()
                },
                safety: SafetyConfig::default(),
                period_s: 1.0 / self.rate_hz,
            },
            arm,
            user: ScriptedUserConfig {
                linear_speed_m_per_s: self.user_speed,
                tremor_amplitude_m: self.tremor_m,
                ..ScriptedUserConfig::default()
            },
            contact,
        })
    }
}

impl LoopSetup {
    /// Builds the contact stage (voxmap, pointshell, coupling) when contact is on, and logs
    /// its size and build time.
    pub fn contact_stage(
        &self,
        spec: &devices::DeviceSpec,
    ) -> anyhow::Result<Option<ContactStage>> {
        let Some(config) = self.contact else {
            return Ok(None);
        };
        config.validate().map_err(|e| anyhow::anyhow!(e))?;
        let model = ContactModel::from_scene(&self.scene, &config.voxmap)
            .map_err(|e| anyhow::anyhow!("scene '{}': {e}", self.scene.name))?;
        tracing::info!("contact: {}", model.describe());
        let coupling = Coupling::from_spec(
            spec,
            self.tick.mapping.position_scale,
            config.coupling_fraction,
        );
        Ok(Some(ContactStage::new(Arc::new(model), config, coupling)))
    }
}

/// The scripted operator of the demo, scene frame: from the start to the wall 12 cm beside
/// the hole, pushing 2 cm into it (contact stops the object; the hand feels the wall), back
/// out, to 10 cm before the hole, a pause to line up, straight through the hole's centre, to
/// the goal, then hold. The S does not fit through the hole in its start orientation, so
/// with contact on the object stays in front of the wall until the planner's guidance
/// turns it; the planner uses the operator's configuration as a hint (I-RRT §5, where "the
/// user [may] go through obstacles").
pub fn demo_route(scene: &Scene) -> Vec<(Isometry3<f64>, f64)> {
    let start = scene.start.to_isometry();
    let goal = scene.goal.to_isometry();
    let toward = |x: f64| {
        let mut p = start;
        p.translation.vector.x = x;
        p.translation.vector.y = 0.0;
        p.translation.vector.z = 0.0;
        p
    };
    let beside = |x: f64| {
        let mut p = toward(x);
        p.translation.vector.y = 0.12;
        p
    };
    vec![
        (start, 0.5),
        (beside(-0.1), 0.0),
        (beside(-0.04), 1.0),
        (beside(-0.1), 0.0),
        (toward(-0.1), 1.0),
        (toward(0.1), 0.0),
        (goal, 0.0),
    ]
}

/// The simulated arm with the scripted operator following `route` (scene frame).
pub fn simulated_arm(
    setup: &LoopSetup,
    route: &[(Isometry3<f64>, f64)],
) -> anyhow::Result<SimulatedArm> {
    let mapping = Mapping::new(&setup.tick.mapping);
    let waypoints = route
        .iter()
        .map(|(p, dwell)| Waypoint::new(mapping.to_device(p)).with_dwell(*dwell));
    let user = ScriptedUser::new(setup.user, waypoints)
        .map_err(|e| anyhow::anyhow!("simulated operator: {e}"))?;
    SimulatedArm::with_user(setup.arm.clone(), user)
        .map_err(|e| anyhow::anyhow!("simulated arm: {e}"))
}

/// The summary printed at the end and written by `--summary-json`.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// The planner published a solution (demo), or `false` for `run`.
    pub solved: bool,
    /// Seconds from start to the first guidance sample that reported a solution.
    pub time_to_solve_s: Option<f64>,
    /// Waypoints of the received solution path.
    pub path_waypoints: u64,
    /// Weighted length of the received path.
    pub path_length: Option<f64>,
    /// Seconds the loop ran.
    pub run_s: f64,
    /// Ticks done.
    pub ticks: u64,
    /// Deadlines missed.
    pub deadline_misses: u64,
    /// Heap allocations per tick on the RT thread (`null` if not measured).
    pub allocations_per_tick: Option<f64>,
    /// Wake-up latency, µs.
    pub wake_latency_us: Percentiles,
    /// The loop's full report.
    pub loop_report: LoopReport,
    /// Planner iterations at the end (from its last guidance sample).
    pub planner_iterations: u64,
    /// Planner nodes at the end.
    pub planner_nodes: u64,
    /// Contact rendering figures; `null` when contact was off.
    pub contact: Option<ContactSummary>,
}

/// What contact rendering did during a run.
#[derive(Debug, Clone, Serialize)]
pub struct ContactSummary {
    /// Time spent in contact, s.
    pub contact_s: f64,
    /// Deepest penetration of the proxy into the scene, mm.
    pub max_penetration_mm: f64,
    /// Voxel size, mm.
    pub voxel_mm: f64,
    /// Pointshell points.
    pub points: usize,
    /// Voxmap memory, MB.
    pub voxmap_mb: f64,
    /// Voxmap build time, s.
    pub voxmap_build_s: f64,
}

impl ContactSummary {
    fn of<D: HapticDevice, G: GuidanceSource, S: StateSink>(
        tick: &Tick<D, G, S>,
        period_s: f64,
    ) -> Option<Self> {
        let model = tick.contact()?.model();
        let report = model.voxmap().report();
        Some(Self {
            contact_s: tick.contact_ticks() as f64 * period_s,
            max_penetration_mm: tick.max_penetration_m() * 1e3,
            voxel_mm: report.voxel_m * 1e3,
            points: model.pointshell().len(),
            voxmap_mb: report.memory_bytes as f64 / 1e6,
            voxmap_build_s: report.build_time.as_secs_f64(),
        })
    }
}

impl Summary {
    /// The summary of a run: `report` from the loop, `guidance` the newest planner sample,
    /// `solved_at` when a solution was first seen, `path` = (waypoints, length) received.
    fn new(
        report: LoopReport,
        run_s: f64,
        guidance: &Guidance,
        solved: bool,
        solved_at: Option<Duration>,
        path: Option<(u64, f64)>,
        contact: Option<ContactSummary>,
    ) -> Self {
        Self {
            solved,
            time_to_solve_s: solved_at.map(|d| d.as_secs_f64()),
            path_waypoints: path.map_or(0, |p| p.0),
            path_length: path.map(|p| p.1),
            run_s,
            ticks: report.ticks,
            deadline_misses: report.deadline_misses,
            allocations_per_tick: report.allocations_per_tick,
            wake_latency_us: report.wake_latency_us,
            planner_iterations: guidance.iterations,
            planner_nodes: guidance.nodes,
            loop_report: report,
            contact,
        }
    }
}

fn print_summary(s: &Summary) {
    let w = &s.wake_latency_us;
    let c = &s.loop_report.compute_us;
    println!("── summary ─────────────────────────────────────────────");
    match s.time_to_solve_s {
        Some(t) => println!(
            "solved:            yes, after {t:.2} s ({} waypoints, length {:.3})",
            s.path_waypoints,
            s.path_length.unwrap_or(f64::NAN)
        ),
        None => println!("solved:            no"),
    }
    println!(
        "planner:           {} iterations, {} nodes",
        s.planner_iterations, s.planner_nodes
    );
    println!("ticks:             {} in {:.1} s", s.ticks, s.run_s);
    println!(
        "wake latency µs:   p50 {:.1}  p99 {:.1}  p99.9 {:.1}  max {:.1}",
        w.p50, w.p99, w.p999, w.max
    );
    println!(
        "compute µs:        p50 {:.1}  p99 {:.1}  p99.9 {:.1}  max {:.1}",
        c.p50, c.p99, c.p999, c.max
    );
    println!("deadline misses:   {}", s.deadline_misses);
    match &s.contact {
        Some(c) => println!(
            "contact:           {:.2} s in contact, max penetration {:.3} mm ({} points, {} mm voxels)",
            c.contact_s, c.max_penetration_mm, c.points, c.voxel_mm
        ),
        None => println!("contact:           off"),
    }
    match s.allocations_per_tick {
        Some(a) => println!(
            "allocations/tick:  {a} ({} on the RT thread)",
            s.loop_report.rt_allocations.unwrap_or(0)
        ),
        None => println!("allocations/tick:  not measured (counting allocator not installed)"),
    }
    println!(
        "real-time:         SCHED_FIFO {}, pinned {}, memory locked {}",
        s.loop_report.fifo, s.loop_report.pinned, s.loop_report.memory_locked
    );
}

fn install_stop_handler() -> anyhow::Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    ctrlc::set_handler(move || s.store(true, Ordering::Release))
        .context("cannot install the SIGINT/SIGTERM handler")?;
    Ok(stop)
}

/// What the main thread watches: the planner's guidance and path.
struct Watch {
    relay: Relay,
    path: PathSubscriber,
    /// Keeps this process's iceoryx2 node alive as long as its ports.
    _node: iceoryx2::node::Node<services::Ipc>,
}

impl Watch {
    /// `(waypoints, weighted length)` of the newest path received, if any arrived.
    fn newest_path(&self) -> Option<(u64, f64)> {
        let mut newest = None;
        while let Ok(Some(sample)) = self.path.receive() {
            newest = Some((sample.len, sample.length));
        }
        newest
    }
}

/// What the stats thread reads for its progress line.
struct Progress {
    guidance: Arc<Mutex<Guidance>>,
    state: StateReader,
}

impl Progress {
    fn line(&self, s: &SecondSummary) -> String {
        let g = *self.guidance.lock().unwrap_or_else(|p| p.into_inner());
        let st = *self.state.get();
        let f = st.guidance_wrench.force_n;
        let fs = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
        let planner = if g.header.sequence == 0 {
            "planner: not yet".to_string()
        } else {
            format!(
                "planner: {} nodes, {} trees, solved {}",
                g.nodes,
                g.trees,
                if g.solved == 1 { "yes" } else { "no" }
            )
        };
        format!(
            "[{:>5.1} s] {planner} | F_s {fs:.2} N ({}) | loop: {} ticks/s, wake p99 {:.0} µs, misses {}, fault {}",
            s.elapsed_s,
            st.guidance_freshness.name(),
            s.ticks,
            s.wake_p99_us,
            s.deadline_misses_total,
            st.fault.name()
        )
    }
}

/// Runs the loop until `done` says so; returns the loop report and run time.
fn run_loop(
    setup: &LoopSetup,
    (device, choice): (Box<dyn devices::HapticDevice>, &DeviceChoice),
    contact: Option<ContactStage>,
    stop: &AtomicBool,
    mut done: impl FnMut(&Watch) -> bool,
) -> anyhow::Result<(LoopReport, f64, Watch, Option<ContactSummary>)> {
    let (node, cleaned) = services::create_node(&format!("haptic_loop_{}", std::process::id()))?;
    if cleaned > 0 {
        tracing::info!("removed resources of {cleaned} dead iceoryx2 node(s)");
    }
    let state_writer = services::state_writer(&node, &setup.namespace)
        .context("is another haptic loop running on this namespace?")?;
    let (relay, guidance_source) = Relay::spawn(&setup.namespace, Duration::from_millis(1))?;
    let progress = Progress {
        guidance: relay.observer(),
        state: services::state_reader(&node, &setup.namespace)?,
    };
    let watch = Watch {
        relay,
        path: services::path_subscriber(&node, &setup.namespace)?,
        _node: node,
    };
    let mut tick = Tick::new(device, &setup.tick, guidance_source, state_writer)
        .map_err(|e| choice.open_error(e))?;
    if let Some(stage) = contact {
        tick = tick.with_contact(stage);
    }
    let started = Instant::now();
    let handle = runner::spawn(tick, setup.runner, move |s| {
        tracing::info!("{}", progress.line(s));
    })?;
    while !stop.load(Ordering::Acquire) && !handle.is_finished() && !done(&watch) {
        std::thread::sleep(Duration::from_millis(20));
    }
    let (tick, report) = handle.join();
    let run_s = started.elapsed().as_secs_f64();
    let contact = ContactSummary::of(&tick, setup.tick.period_s);
    Ok((report, run_s, watch, contact))
}

fn finish(summary: &Summary, json: Option<&PathBuf>) -> anyhow::Result<()> {
    print_summary(summary);
    if let Some(p) = json {
        let text = serde_json::to_string_pretty(summary)?;
        std::fs::write(p, text + "\n").with_context(|| format!("cannot write {}", p.display()))?;
    }
    Ok(())
}

/// `haptic-loop run`: the loop with the simulated arm, no planner of its own.
pub fn run(args: &RunArgs) -> anyhow::Result<i32> {
    let setup = args.common.to_setup()?;
    let mut device = crate::device_select::build(&args.device, &setup.namespace, || {
        Ok(Box::new(simulated_arm(&setup, &demo_route(&setup.scene))?))
    })?;
    // Open now: a backend's limits are final only once open, and the contact coupling is
    // sized from them. `Tick::new` opens it again, which the device trait allows.
    device
        .open()
        .map_err(|e| args.device.device.open_error(e))?;
    // Build the voxmap before anything starts: it takes seconds at fine voxel sizes.
    let contact = setup.contact_stage(device.spec())?;
    let stop = install_stop_handler()?;
    let duration = args
        .duration_s
        .map(|d| {
            if d.is_finite() && d > 0.0 {
                Ok(Duration::from_secs_f64(d))
            } else {
                bail!("--duration-s must be a finite number > 0, got {d}")
            }
        })
        .transpose()?;
    tracing::info!(
        "haptic loop at {} Hz on {}, namespace '{}', scene '{}'",
        setup.runner.rate_hz,
        args.device.device.name(),
        setup.namespace,
        setup.scene.name
    );
    let started = Instant::now();
    let (report, run_s, watch, contact) = run_loop(
        &setup,
        (device, &args.device.device),
        contact,
        &stop,
        |_| duration.is_some_and(|d| started.elapsed() >= d),
    )?;
    let g = watch.relay.newest();
    let summary = Summary::new(report, run_s, &g, g.solved == 1, None, None, contact);
    finish(&summary, args.common.summary_json.as_ref())?;
    Ok(0)
}

/// `haptic-loop demo`: the loop, a planner child process, and a summary. Exit code 0 when
/// solved within the time limit, 1 when not.
pub fn demo(args: &DemoArgs) -> anyhow::Result<i32> {
    let setup = args.common.to_setup()?;
    // Build the voxmap before anything starts: it takes seconds at fine voxel sizes.
    let contact = setup.contact_stage(&setup.arm.spec())?;
    if !(args.time_limit_s.is_finite() && args.time_limit_s > 0.0) {
        bail!(
            "--time-limit-s must be a finite number > 0, got {}",
            args.time_limit_s
        );
    }
    if !(args.after_solve_s.is_finite() && args.after_solve_s >= 0.0) {
        bail!(
            "--after-solve-s must be a finite number >= 0, got {}",
            args.after_solve_s
        );
    }
    if !(args.min_run_s.is_finite() && args.min_run_s >= 0.0) {
        bail!(
            "--min-run-s must be a finite number >= 0, got {}",
            args.min_run_s
        );
    }
    let stop = install_stop_handler()?;
    let exe = std::env::current_exe().context("cannot find the haptic-loop executable")?;
    let mut child = std::process::Command::new(&exe)
        .args([
            "planner",
            "serve",
            "--namespace",
            &setup.namespace,
            "--scene",
            &setup.scene_arg,
        ])
        .args(["--seed", &args.seed.to_string()])
        .args(["--sampling", &args.sampling])
        .spawn()
        .with_context(|| {
            format!(
                "cannot start the planner process ({} planner serve)",
                exe.display()
            )
        })?;
    tracing::info!(
        "demo: haptic loop at {} Hz on the simulated arm, planner pid {}, scene '{}', time limit {} s",
        setup.runner.rate_hz,
        child.id(),
        setup.scene.name,
        args.time_limit_s
    );

    let started = Instant::now();
    let limit = Duration::from_secs_f64(args.time_limit_s);
    let after = Duration::from_secs_f64(args.after_solve_s);
    let min_run = Duration::from_secs_f64(args.min_run_s);
    let mut solved_at: Option<Duration> = None;
    let mut path: Option<(u64, f64)> = None;
    let mut child_exited = None;
    let arm: Box<dyn devices::HapticDevice> =
        Box::new(simulated_arm(&setup, &demo_route(&setup.scene))?);
    let result = run_loop(&setup, (arm, &DeviceChoice::Sim), contact, &stop, |watch| {
        let elapsed = started.elapsed();
        if let Some(p) = watch.newest_path() {
            path = Some(p);
        }
        if solved_at.is_none() && watch.relay.newest().solved == 1 {
            solved_at = Some(elapsed);
            tracing::info!("demo: planner solved after {:.2} s", elapsed.as_secs_f64());
        }
        if child_exited.is_none()
            && let Ok(Some(status)) = child.try_wait()
        {
            tracing::warn!(
                "demo: planner process exited ({status}); the loop goes on without guidance"
            );
            child_exited = Some(status);
        }
        match solved_at {
            Some(t) => elapsed >= (t + after).max(min_run),
            None => elapsed >= limit,
        }
    });

    // Stop the planner: SIGTERM, then wait; SIGKILL if it does not go.
    if child_exited.is_none() {
        let pid = child.id() as libc::pid_t;
        // SAFETY: kill(2) with a pid we spawned and still own (not yet reaped).
        unsafe { libc::kill(pid, libc::SIGTERM) };
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline && matches!(child.try_wait(), Ok(None)) {
            std::thread::sleep(Duration::from_millis(20));
        }
        if matches!(child.try_wait(), Ok(None)) {
            let _ = child.kill();
        }
        let _ = child.wait();
    }
    let (report, run_s, watch, contact) = result?;

    let g = watch.relay.newest();
    if let Some(p) = watch.newest_path() {
        path = Some(p);
    }
    let summary = Summary::new(
        report,
        run_s,
        &g,
        solved_at.is_some(),
        solved_at,
        path,
        contact,
    );
    finish(&summary, args.common.summary_json.as_ref())?;
    if stop.load(Ordering::Acquire) && !summary.solved {
        return Ok(130);
    }
    Ok(if summary.solved { 0 } else { 1 })
}
