//! `hrrtc-ros2`: the haptic loop as a ROS 2 node on rmw_zenoh's wire (`serve`), and a ROS 2
//! arm driver as the loop's device (`device`). Exit codes: 0 stopped, 2 an error (printed on
//! stderr) or bad arguments. Stops on Ctrl-C / SIGTERM or after --duration-s.

use anyhow::Context;
use clap::{Args, Parser, Subcommand};
use hrrtc_ros2::device::{CONSERVATIVE_LIMITS, DeviceConfig};
use hrrtc_ros2::participant::SessionConfig;
use hrrtc_ros2::rmw::Distro;
use hrrtc_ros2::serve::ServeConfig;
use ipc_types::DeviceLimits;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// The haptic loop's topics on ROS 2 (rmw_zenoh's wire, no ROS install needed), and ROS 2
/// arm drivers as its devices.
///
/// With rmw_zenoh's router running (`ros2 run rmw_zenoh_cpp rmw_zenohd`), ROS 2 nodes with
/// `RMW_IMPLEMENTATION=rmw_zenoh_cpp` on this host see the node, its topics and its frames.
/// rmw_zenoh's default router is plain TCP, which this program refuses unless --insecure;
/// a graph secured with rmw_zenoh's configuration files is joined with --zenoh-config (or
/// ZENOH_SESSION_CONFIG_URI, as rmw_zenoh reads it).
#[derive(Debug, Parser)]
#[command(name = "hrrtc-ros2", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Publish the loop's state, the planner's path and roadmap and the scene on ROS 2
    /// topics and TF; take guidance (geometry_msgs/WrenchStamped) from ROS 2.
    Serve(ServeArgs),
    /// Serve a ROS 2 driver's arm to the loop over the driver bridge (`haptic-loop run
    /// --device ros2:...` starts this).
    Device(DeviceArgs),
}

/// Options both commands share.
#[derive(Debug, Args)]
struct Common {
    /// iceoryx2 namespace of the loop (its --namespace).
    #[arg(long, default_value = ipc_types::services::DEFAULT_NAMESPACE)]
    namespace: String,
    /// ROS domain id [default: $ROS_DOMAIN_ID, else 0].
    #[arg(long)]
    domain_id: Option<u32>,
    /// Zenoh endpoint to connect to (repeatable) [default: the --zenoh-config file's, else
    /// tcp/localhost:7447, rmw_zenoh's router].
    #[arg(long)]
    connect: Vec<String>,
    /// Connect nowhere (others connect to --listen).
    #[arg(long, conflicts_with = "connect")]
    no_connect: bool,
    /// Zenoh endpoint to listen on (repeatable) [default: the --zenoh-config file's, else
    /// tcp/localhost:0, as rmw_zenoh's sessions].
    #[arg(long)]
    listen: Vec<String>,
    #[command(flatten)]
    security: zenoh_session::SecurityArgs,
    /// Which rmw_zenoh to meet: jazzy, kilted (the same wire here) or humble (no type
    /// hashes).
    #[arg(long, default_value = "jazzy", value_parser = ["jazzy", "kilted", "humble"])]
    ros_distro: String,
    /// Stop after this many seconds.
    #[arg(long, allow_hyphen_values = true)]
    duration_s: Option<f64>,
    /// Write what was sent, received and rejected as JSON here at the end.
    #[arg(long)]
    summary_json: Option<PathBuf>,
}

impl Common {
    fn session(&self) -> anyhow::Result<SessionConfig> {
        let domain = match self.domain_id {
            Some(d) => d,
            None => match std::env::var("ROS_DOMAIN_ID") {
                Ok(v) if !v.is_empty() => v
                    .parse()
                    .with_context(|| format!("ROS_DOMAIN_ID {v:?}: not a domain id"))?,
                _ => 0,
            },
        };
        let mut security = self.security.security("");
        // rmw_zenoh's own variable for a session's Zenoh file, when no flag names one.
        if security.zenoh_config.is_none()
            && let Some(uri) = std::env::var_os("ZENOH_SESSION_CONFIG_URI")
            && !uri.is_empty()
        {
            security.zenoh_config = Some(uri.into());
        }
        Ok(SessionConfig {
            domain,
            connect: if self.no_connect {
                Some(Vec::new())
            } else {
                (!self.connect.is_empty()).then(|| self.connect.clone())
            },
            listen: (!self.listen.is_empty()).then(|| self.listen.clone()),
            distro: Distro::parse(&self.ros_distro).unwrap_or_default(),
            security,
        })
    }

    fn duration(&self) -> anyhow::Result<Option<f64>> {
        if let Some(d) = self.duration_s {
            anyhow::ensure!(
                d.is_finite() && d > 0.0,
                "--duration-s {d}: must be positive"
            );
        }
        Ok(self.duration_s)
    }
}

#[derive(Debug, Args)]
struct ServeArgs {
    #[command(flatten)]
    common: Common,
    /// The node's ROS namespace; frames are named under it (`hrrtc/scene`, ...).
    #[arg(long, default_value = "/hrrtc")]
    ros_namespace: String,
    /// The node's name.
    #[arg(long, default_value = "hrrtc_gateway")]
    node_name: String,
    /// The loop's scene (its --scene: a built-in name or a TOML file), for the scene markers
    /// and the start and goal frames; `none` for neither.
    #[arg(long, default_value = "wall-hole")]
    scene: String,
    /// Hang the scene frame from this TF frame (an identity on /tf_static), e.g. `world`.
    #[arg(long)]
    parent_frame: Option<String>,
    /// Publish every n-th tick (1: every tick, the loop's rate).
    #[arg(long, default_value_t = 1)]
    state_decimation: u32,
    /// Poll period of the state blackboard, µs, before locking onto a real-time loop's ticks.
    #[arg(long, default_value_t = 100)]
    state_poll_us: u64,
    /// Longest the state thread spins after waking just before a predicted state, µs: it
    /// then reads the state within ~1 µs of its write, for about the spread of its wake-ups
    /// in CPU per tick; 0: it only sleeps (reading each state its wake-up latency after the
    /// write). Only for a loop with a real-time thread.
    #[arg(long, default_value_t = 100.0, allow_hyphen_values = true)]
    state_spin_us: f64,
    /// SCHED_FIFO priority of the thread that reads the state and publishes the tick topics
    /// (below the loop's 80), so that it wakes on time on a busy host; 0 keeps the normal
    /// scheduler; without permission it is kept too, with a warning.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u8).range(0..=98))]
    state_priority: u8,
    /// Rate of the roadmap and path markers, Hz.
    #[arg(long, default_value_t = 2.0, allow_hyphen_values = true)]
    marker_rate_hz: f64,
    /// Time-to-live of guidance from ROS 2, ms: the loop fades it out after this.
    #[arg(long, default_value_t = 100.0, allow_hyphen_values = true)]
    guidance_ttl_ms: f64,
    /// Draw meshes of more triangles as their bounding boxes.
    #[arg(long, default_value_t = 100_000)]
    max_mesh_triangles: usize,
}

#[derive(Debug, Args)]
struct DeviceArgs {
    #[command(flatten)]
    common: Common,
    /// The driver's end-effector pose (geometry_msgs/PoseStamped, base frame).
    #[arg(long)]
    pose_topic: String,
    /// Where to send the wrench command (geometry_msgs/WrenchStamped).
    #[arg(long)]
    wrench_topic: String,
    /// The driver's velocity (geometry_msgs/TwistStamped) [default: from the poses].
    #[arg(long)]
    twist_topic: Option<String>,
    /// The driver's buttons (sensor_msgs/Joy).
    #[arg(long)]
    joy_topic: Option<String>,
    /// The wrench's frame_id [default: the poses' frame_id].
    #[arg(long)]
    wrench_frame: Option<String>,
    /// The arm's maximum force, N.
    #[arg(long, default_value_t = CONSERVATIVE_LIMITS.max_force_n, allow_hyphen_values = true)]
    max_force_n: f64,
    /// The arm's maximum torque, N·m (0: no torque output).
    #[arg(long, default_value_t = CONSERVATIVE_LIMITS.max_torque_nm, allow_hyphen_values = true)]
    max_torque_nm: f64,
    /// The arm's maximum stable stiffness at 1 kHz, N/m.
    #[arg(long, default_value_t = CONSERVATIVE_LIMITS.max_stiffness_n_per_m, allow_hyphen_values = true)]
    stiffness_n_per_m: f64,
    /// The arm's maximum stable rotational stiffness, N·m/rad.
    #[arg(long, default_value_t = CONSERVATIVE_LIMITS.max_rot_stiffness_nm_per_rad, allow_hyphen_values = true)]
    rot_stiffness_nm_per_rad: f64,
    /// The arm's maximum stable damping, N·s/m.
    #[arg(long, default_value_t = CONSERVATIVE_LIMITS.max_damping_n_s_per_m, allow_hyphen_values = true)]
    damping_n_s_per_m: f64,
    /// Radius of the arm's workspace about its base, m.
    #[arg(long, default_value_t = CONSERVATIVE_LIMITS.workspace_radius_m, allow_hyphen_values = true)]
    workspace_radius_m: f64,
    /// Number of buttons (≤ 32).
    #[arg(long, default_value_t = 0)]
    buttons: u32,
    /// The arm senses no orientation.
    #[arg(long)]
    no_orientation: bool,
    /// The device's name for the loop [default: "ROS 2 <pose topic>"].
    #[arg(long)]
    name: Option<String>,
    /// Send zero force when the loop's commands are older than this, ms.
    #[arg(long, default_value_t = 20.0, allow_hyphen_values = true)]
    command_timeout_ms: f64,
    /// Time constant of the velocity filter (poses' finite differences), ms.
    #[arg(long, default_value_t = 10.0, allow_hyphen_values = true)]
    velocity_filter_ms: f64,
    /// The node's ROS namespace.
    #[arg(long, default_value = "/")]
    ros_namespace: String,
    /// The node's name.
    #[arg(long, default_value = "hrrtc_device")]
    node_name: String,
}

fn main() -> std::process::ExitCode {
    ipc_types::startup::init_logging_with(
        "info,zenoh=warn,zenoh_ext=warn",
        zenoh_session::refusal_counter(),
    );
    let cli = Cli::parse();
    let result = stop_on_signal().and_then(|stop| match cli.command {
        Command::Serve(a) => serve(a, stop),
        Command::Device(a) => device(a, stop),
    });
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hrrtc-ros2: error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}

/// The flag SIGINT / SIGTERM set (`ipc_types::startup::stop_on_signal`).
fn stop_on_signal() -> anyhow::Result<Arc<AtomicBool>> {
    ipc_types::startup::stop_on_signal("hrrtc-ros2")
        .context("installing the Ctrl-C / SIGTERM handler")
}

fn write_json(path: Option<&PathBuf>, value: &impl serde::Serialize) -> anyhow::Result<()> {
    if let Some(p) = path {
        std::fs::write(p, serde_json::to_string_pretty(value)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

/// `hrrtc-ros2 serve`'s `oom_score_adj`: as the bridge's (300), the kernel's OOM killer
/// takes it after the planner (500) and before the other processes of the host (0) and the
/// loop (-900): a dead gateway costs ROS 2 its view and its guidance, which fades out in
/// the loop as a dead planner's does. `device` keeps the value it inherits (the loop's,
/// when the loop starts it): killing it faults the loop.
const SERVE_OOM_SCORE_ADJ: i32 = 300;

fn serve(a: ServeArgs, stop: Arc<AtomicBool>) -> anyhow::Result<()> {
    let oom = ipc_types::startup::raise_oom_score_adj(SERVE_OOM_SCORE_ADJ);
    tracing::info!("oom_score_adj {oom}");
    anyhow::ensure!(
        a.guidance_ttl_ms.is_finite() && a.guidance_ttl_ms > 0.0,
        "--guidance-ttl-ms {}: must be positive",
        a.guidance_ttl_ms
    );
    let scene = if a.scene == "none" {
        None
    } else {
        Some(Arc::new(
            scene::Scene::by_name_or_path(&a.scene)
                .with_context(|| format!("--scene {}", a.scene))?,
        ))
    };
    let config = ServeConfig {
        ros_namespace: a.ros_namespace,
        node_name: a.node_name,
        session: a.common.session()?,
        scene,
        parent_frame: a.parent_frame,
        state_decimation: a.state_decimation,
        state_poll_us: a.state_poll_us,
        state_spin_us: a.state_spin_us,
        state_priority: a.state_priority,
        marker_rate_hz: a.marker_rate_hz,
        guidance_ttl_s: a.guidance_ttl_ms / 1e3,
        max_mesh_triangles: a.max_mesh_triangles,
        duration_s: a.common.duration()?,
        ..ServeConfig::new(&a.common.namespace)
    };
    let report = hrrtc_ros2::serve::run(&config, stop)?;
    let rejected: u64 = report.guidance.rejected.values().sum();
    println!(
        "hrrtc-ros2 serve ran {:.1} s: {} ticks seen, {} published; {} paths; guidance: \
         {} received, {} delivered, {} rejected {:?}; links: {}",
        report.seconds,
        report.ticks_seen,
        report.ticks_published,
        report.paths,
        report.guidance.received,
        report.guidance.delivered,
        rejected,
        report.guidance.rejected,
        config.session.security.describe()
    );
    println!("  kept out: {}", zenoh_session::Refusals::now());
    println!("  oom_score_adj: {oom}");
    let summary = ipc_types::startup::WithOomScoreAdj {
        report: &report,
        oom_score_adj: &oom,
    };
    write_json(a.common.summary_json.as_ref(), &summary)
}

/// A driver process: its `oom_score_adj` stays as inherited (see [`SERVE_OOM_SCORE_ADJ`]).
fn device(a: DeviceArgs, stop: Arc<AtomicBool>) -> anyhow::Result<()> {
    for (name, v) in [
        ("--command-timeout-ms", a.command_timeout_ms),
        ("--velocity-filter-ms", a.velocity_filter_ms),
    ] {
        anyhow::ensure!(v.is_finite() && v >= 0.0, "{name} {v}: must be ≥ 0");
    }
    let mut config = DeviceConfig::new(&a.common.namespace, &a.pose_topic, &a.wrench_topic);
    config = DeviceConfig {
        ros_namespace: a.ros_namespace,
        node_name: a.node_name,
        session: a.common.session()?,
        twist_topic: a.twist_topic,
        joy_topic: a.joy_topic,
        wrench_frame: a.wrench_frame,
        limits: DeviceLimits {
            max_force_n: a.max_force_n,
            max_torque_nm: a.max_torque_nm,
            max_stiffness_n_per_m: a.stiffness_n_per_m,
            max_rot_stiffness_nm_per_rad: a.rot_stiffness_nm_per_rad,
            max_damping_n_s_per_m: a.damping_n_s_per_m,
            // The driver's state does not carry it (the loop adds no rotational damping).
            max_rot_damping_nm_s_per_rad: 0.0,
            workspace_radius_m: a.workspace_radius_m,
        },
        orientation_input: !a.no_orientation,
        buttons: a.buttons,
        name: a.name.unwrap_or(config.name),
        command_timeout_s: a.command_timeout_ms / 1e3,
        velocity_filter_s: a.velocity_filter_ms / 1e3,
        duration_s: a.common.duration()?,
        ..config
    };
    let report = hrrtc_ros2::device::run(&config, stop)?;
    let rejected: u64 = report.poses_rejected.values().sum();
    println!(
        "hrrtc-ros2 device ran {:.1} s: poses {} received, {} accepted, {} rejected {:?} \
         ({} faults sent); commands {}, wrenches {} ({} zero); links: {}",
        report.seconds,
        report.poses_received,
        report.poses_accepted,
        rejected,
        report.poses_rejected,
        report.faults_sent,
        report.commands,
        report.wrenches,
        report.zero_wrenches,
        config.session.security.describe()
    );
    println!("  kept out: {}", zenoh_session::Refusals::now());
    write_json(a.common.summary_json.as_ref(), &report)
}
