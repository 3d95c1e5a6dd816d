//! The command line of `haptic-loop`, and its validation into a [`LoopSetup`]. The only
//! place that knows the flags.

use anyhow::{Context, bail};
use clap::Args;
use devices::sim::{OperatorConfig, ScriptedUserConfig, SimulatedArmConfig};
use haptic_loop::contact::{ContactConfig, Resolution};
use haptic_loop::device_choice::{DeviceChoice, DeviceOptions};
use haptic_loop::guidance::GuidanceConfig;
use haptic_loop::rt::RtOptions;
use haptic_loop::runner::RunnerConfig;
use haptic_loop::safety::SafetyConfig;
use haptic_loop::session::LoopSetup;
use haptic_loop::session::scenario::{self, DEFAULT_SCALE, SimOperator, WORKSPACE_SHARE};
use haptic_loop::tick::TickConfig;
use ipc_types::services;
use scene::Scene;
use std::path::PathBuf;
use std::str::FromStr;
use std::time::Duration;

/// Options of `haptic-loop run` and `haptic-loop demo`.
#[derive(Debug, Args, Clone)]
pub struct LoopArgs {
    /// IPC namespace (service names `hrrtc/<namespace>/...`); the planner must use the same.
    #[arg(long, default_value = services::DEFAULT_NAMESPACE)]
    pub namespace: String,
    /// Scene: a built-in name (`wall-hole` alias `default`, `maze`, `tunnels`,
    /// `crossing-planes`, `silencer`, ...) or a TOML scene file.
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
    /// CPU wake-up latency to request from the kernel while the loop runs, µs (PM QoS,
    /// /dev/cpu_dma_latency): 0 keeps idle CPUs polling instead of halting, as cyclictest
    /// does; on a VM this removes the hypervisor's wake-up delay from the loop.
    #[arg(long, default_value_t = 0)]
    pub cpu_latency_us: u32,
    /// Make no CPU wake-up latency request (saves power; idle CPUs may wake late).
    #[arg(long)]
    pub no_cpu_latency_request: bool,
    /// Spin this many µs before each deadline instead of sleeping (trades CPU for jitter).
    #[arg(long, default_value_t = 0)]
    pub spin_us: u64,
    /// Scene metres per device metre [default: 3, or the smallest scale (to 0.1) that
    /// fits the operator's route (start, route steps, goal) into the device's workspace].
    #[arg(long)]
    pub scale: Option<f64>,
    /// Guidance fade after its time-to-live, ms.
    #[arg(long, default_value_t = 200.0)]
    pub fade_ms: f64,
    /// Render no guidance force (F_s bounded to zero; the planner still plans and its
    /// solution is still reported).
    #[arg(long)]
    pub no_guidance: bool,
    /// Who holds a simulated device: `expert` or `novice` (an operator that follows the
    /// scene's route and reacts to what it feels: see docs/guide/simulated-operator.md),
    /// `newcomer` (one who does not know the way: it never reads the route, plans its own
    /// coarse way and follows felt guidance), or `scripted` (the wall-hole demo's timed
    /// path, which reacts to nothing) [default: demo: expert, newcomer on a scene without a
    /// route; run: scripted].
    #[arg(long, value_parser = ["expert", "novice", "newcomer", "scripted"])]
    pub operator: Option<String>,
    /// Seed of the simulated operator's random choices [default: demo's --seed, else 1].
    #[arg(long)]
    pub operator_seed: Option<u64>,
    /// Speed of the scripted operator's hand, m/s at the device.
    #[arg(long, default_value_t = 0.02)]
    pub user_speed: f64,
    /// RMS amplitude of the scripted operator's tremor, m (0 = none).
    #[arg(long, default_value_t = 0.0)]
    pub tremor_m: f64,
    /// Voxel size of the contact voxmap and pointshell spacing, mm (0.25–20).
    #[arg(long, default_value_t = 1.0)]
    pub voxel_mm: f64,
    /// Render no contact: the object follows the hand through obstacles.
    #[arg(long)]
    pub no_contact: bool,
    /// Build the voxmap every time instead of reading it from (and writing it to) the
    /// cache folder.
    #[arg(long)]
    pub no_voxmap_cache: bool,
    /// Where built voxmaps are kept, keyed by the scene's content, voxel size and layers
    /// [default: $XDG_CACHE_HOME/hrrtc/voxmaps, or ~/.cache/hrrtc/voxmaps].
    #[arg(long, value_name = "DIR", conflicts_with = "no_voxmap_cache")]
    pub voxmap_cache_dir: Option<PathBuf>,
    /// Contact point budget: points near the surface the contact stage may look at per
    /// millisecond of tick period; past it, contact is rendered from a coarser level of
    /// detail of the object's points (down to 4 mm spacing). It also sets the tick's caps
    /// on contact work (ARCHITECTURE.md, "The bounded tick").
    #[arg(long, default_value_t = Resolution::DEFAULT_POINTS_PER_MS)]
    pub contact_points_per_ms: f64,
    /// Render contact always at this level of detail (0 = every point, each level about
    /// twice the spacing of the one before), whatever it costs, instead of the budget.
    #[arg(long, conflicts_with = "contact_points_per_ms")]
    pub contact_level: Option<u8>,
    /// Write the summary as JSON here.
    #[arg(long)]
    pub summary_json: Option<PathBuf>,
}

/// Device options of `haptic-loop run`.
#[derive(Debug, Args, Clone)]
pub struct DeviceArgs {
    /// Device: sim (simulated arm), sim-spacemouse (simulated SpaceMouse), spacemouse, dhd,
    /// openhaptics, driver (an external driver process), ros2:pose=TOPIC,wrench=TOPIC[,KEY=VALUE...] (a ROS 2 driver's arm,
    /// served by the hrrtc-ros2 executable beside this one; keys in docs/guide/ros2.md) or
    /// replay:FILE.
    #[arg(long, default_value = "sim", value_parser = DeviceChoice::from_str)]
    pub device: DeviceChoice,
    /// Vendor library for dhd / openhaptics (default: $HRRTC_DHD_LIB / $HRRTC_HD_LIB, else
    /// libdhd.so / libHD.so on the loader path).
    #[arg(long)]
    pub device_lib: Option<PathBuf>,
    /// Record device states and commanded wrenches to this MCAP file.
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// The hrrtc-ros2 executable for --device ros2:... [default: beside this executable].
    #[arg(long)]
    pub ros2_exe: Option<PathBuf>,
}

impl DeviceArgs {
    /// The library's device options.
    pub fn options(&self) -> DeviceOptions {
        DeviceOptions {
            device: self.device.clone(),
            device_lib: self.device_lib.clone(),
            record: self.record.clone(),
        }
    }
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
    pub device: DeviceArgs,
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
    /// Run at least this long.
    #[arg(long, default_value_t = 0.0)]
    pub min_run_s: f64,
    /// After the planner solved, keep going until the object has also reached the goal
    /// (or the time limit): measures the operator's time to reach it.
    #[arg(long)]
    pub until_goal: bool,
    /// Seed of the planner and of the simulated operator.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The planner's sampling method (`planner serve --sampling`): H-RRT-C (`hrrtc`),
    /// I-RRT's `pos+cs`, `path`, ..., or `cs` (automatic: the operator is ignored).
    #[arg(long, default_value = "hrrtc",
          value_parser = ["cs", "pos", "path", "pos+cs", "path+cs", "hrrtc"])]
    pub sampling: String,
    /// H-RRT-C's authority α: the share of machine samples (`planner serve --alpha`; by
    /// default they come from its portfolio of narrow-passage methods; `--planner-args
    /// "--portfolio off"` runs the papers' single planner with uniform ones).
    #[arg(long)]
    pub alpha: Option<f64>,
    /// Device held by the simulated operator: the arm (`sim`) or a SpaceMouse
    /// (`sim-spacemouse`).
    #[arg(long, default_value = "sim", value_parser = ["sim", "sim-spacemouse"])]
    pub device: String,
    /// More `planner serve` options, as one string (e.g. "--local-trees --edges discrete").
    #[arg(long, allow_hyphen_values = true)]
    pub planner_args: Option<String>,
    /// The planner executable [default: `planner` beside this executable].
    #[arg(long)]
    pub planner_exe: Option<PathBuf>,
    /// Start no planner: the simulated operator alone, with no guidance and nothing to
    /// solve. The session runs to --time-limit-s, or with --until-goal until the object
    /// reaches the goal; the exit code is then 0 when it did, 1 when not.
    #[arg(long, conflicts_with_all = ["alpha", "planner_args", "planner_exe"])]
    pub no_planner: bool,
}

/// Options of `haptic-loop devices`.
#[derive(Debug, Args, Clone)]
pub struct DevicesArgs {
    /// Namespace in which to look for an external driver.
    #[arg(long, default_value = services::DEFAULT_NAMESPACE)]
    pub namespace: String,
    /// Vendor library to probe for dhd / openhaptics (as for `run --device-lib`).
    #[arg(long)]
    pub device_lib: Option<PathBuf>,
}

/// `--namespace`, checked.
pub fn namespace(ns: &str) -> anyhow::Result<()> {
    services::validate_namespace(ns).map_err(|e| anyhow::anyhow!("--namespace: {e}"))
}

fn positive(name: &str, v: f64) -> anyhow::Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        bail!("--{name} must be a finite number > 0, got {v}")
    }
}

fn non_negative(name: &str, v: f64) -> anyhow::Result<f64> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        bail!("--{name} must be a finite number >= 0, got {v}")
    }
}

/// A duration in seconds from `--name`, which must be finite and > 0.
pub fn seconds(name: &str, v: f64) -> anyhow::Result<Duration> {
    positive(name, v).map(Duration::from_secs_f64)
}

/// A duration in seconds from `--name`, which must be finite and >= 0.
pub fn seconds_or_zero(name: &str, v: f64) -> anyhow::Result<Duration> {
    non_negative(name, v).map(Duration::from_secs_f64)
}

impl LoopArgs {
    /// Validates the arguments into a [`LoopSetup`]; `operator` and `operator_seed` are the
    /// command's defaults for `--operator` and `--operator-seed`.
    pub fn to_setup(&self, operator: &str, operator_seed: u64) -> anyhow::Result<LoopSetup> {
        let scene = scene::progress::showing(&format!("reading scene {}", self.scene), || {
            Scene::by_name_or_path(&self.scene)
        })?;
        for (warning, line) in scene.mesh_notes() {
            if warning {
                tracing::warn!("{line}");
            } else {
                tracing::info!("{line}");
            }
        }
        if !(self.rate_hz.is_finite() && (500.0..=4000.0).contains(&self.rate_hz)) {
            bail!("--rate-hz must be within 500–4000, got {}", self.rate_hz);
        }
        if self.priority > 99 {
            bail!(
                "--priority must be 0 (normal scheduler) or 1–99, got {}",
                self.priority
            );
        }
        if let Some(cpu) = self.cpu {
            let allowed =
                haptic_loop::rt::allowed_cpus().context("cannot read the CPU affinity")?;
            if !allowed.contains(&cpu) {
                bail!("--cpu {cpu} is not a CPU this process may run on (allowed: {allowed:?})");
            }
        }
        positive("fade-ms", self.fade_ms)?;
        positive("user-speed", self.user_speed)?;
        non_negative("tremor-m", self.tremor_m)?;
        if self.spin_us * 1000 >= (1e9 / self.rate_hz) as u64 {
            bail!("--spin-us {} is not shorter than the period", self.spin_us);
        }
        namespace(&self.namespace)?;
        if !(self.voxel_mm.is_finite() && (0.25..=20.0).contains(&self.voxel_mm)) {
            bail!("--voxel-mm must be within 0.25–20, got {}", self.voxel_mm);
        }
        let (resolution, flag) = match self.contact_level {
            Some(l) => (Resolution::Level(l), "--contact-level"),
            None => (
                Resolution::budget(self.contact_points_per_ms),
                "--contact-points-per-ms",
            ),
        };
        resolution
            .validate()
            .map_err(|e| anyhow::anyhow!("{flag}: {e}"))?;
        let contact = (!self.no_contact).then(|| ContactConfig {
            resolution,
            ..ContactConfig::with_voxel_m(self.voxel_mm / 1000.0)
        });
        let arm = SimulatedArmConfig::default();
        let radius = arm.workspace_radius_m;
        let scale = match self.scale {
            None => scenario::fitting_scale(&scene, radius),
            Some(s) => {
                positive("scale", s)?;
                let reach = scenario::device_reach_m(&scene, s);
                if reach > radius * WORKSPACE_SHARE {
                    bail!(
                        "--scale {s}: the operator's route reaches {reach:.3} m from the device \
                         centre, beyond the device's {radius:.3} m workspace; use --scale {:.1} \
                         or more (or leave --scale out to get the smallest that fits)",
                        (scenario::smallest_fitting_scale(&scene, radius) * 10.0).ceil() / 10.0
                    );
                }
                s
            }
        };
        if scale != DEFAULT_SCALE && self.scale.is_none() {
            tracing::info!(
                "scale {scale}: the smallest (to 0.1) that fits scene '{}' into the arm's workspace",
                scene.name
            );
        }
        let operator = match self.operator.as_deref().unwrap_or_else(|| {
            if operator == "scripted" || !scene.route.is_empty() {
                return operator;
            }
            tracing::info!(
                "scene '{}' has no [[route]]: the simulated operator is the newcomer, who \
                 does not know the way (--operator expert heads straight for the goal)",
                scene.name
            );
            "newcomer"
        }) {
            "scripted" => SimOperator::Scripted(ScriptedUserConfig {
                linear_speed_m_per_s: self.user_speed,
                tremor_amplitude_m: self.tremor_m,
                ..ScriptedUserConfig::default()
            }),
            name => SimOperator::Reacting(OperatorConfig {
                seed: self.operator_seed.unwrap_or(operator_seed),
                ..OperatorConfig::preset(name)
                    .with_context(|| format!("--operator: unknown preset {name:?}"))?
            }),
        };
        Ok(LoopSetup {
            namespace: self.namespace.clone(),
            scene_arg: self.scene.clone(),
            runner: RunnerConfig {
                rate_hz: self.rate_hz,
                rt: RtOptions {
                    fifo_priority: (self.priority > 0).then_some(self.priority),
                    cpu: self.cpu,
                    lock_memory: !self.no_mlock,
                    cpu_latency_us: (!self.no_cpu_latency_request).then_some(self.cpu_latency_us),
                },
                spin_ns: self.spin_us * 1000,
                max_ticks: None,
            },
            tick: TickConfig {
                mapping: scenario::mapping_config(&scene, scale),
                guidance: GuidanceConfig {
                    fade_s: self.fade_ms / 1000.0,
                    ..if self.no_guidance {
                        GuidanceConfig::none()
                    } else {
                        GuidanceConfig::default()
                    }
                },
                safety: SafetyConfig::default(),
                period_s: 1.0 / self.rate_hz,
            },
            scene,
            arm,
            voxmap_cache: match (&self.voxmap_cache_dir, self.no_voxmap_cache) {
                (_, true) => None,
                (Some(dir), false) => Some(dir.clone()),
                (None, false) => haptic_loop::contact::voxmap_cache::default_dir(),
            },
            operator,
            contact,
        })
    }
}

/// Writes `value` as pretty JSON to `path`.
pub fn write_json(path: &std::path::Path, value: &impl serde::Serialize) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    std::fs::write(path, text + "\n").with_context(|| format!("cannot write {}", path.display()))
}
