//! What the harness binaries share: the real haptic loop on the simulated arm in the
//! hardest steady contact case, and a planner child process; and the soak of the product's
//! processes ([`soak`]).

pub mod soak;

use crate::BenchError;
use devices::DeviceSpec;
use devices::sim::{ScriptedUser, ScriptedUserConfig, SimulatedArm, SimulatedArmConfig, Waypoint};
use haptic_loop::contact::{ContactConfig, ContactModel, ContactStage, Coupling};
use haptic_loop::guidance::GuidanceConfig;
use haptic_loop::mapping::MappingConfig;
use haptic_loop::relay::{Relay, RelayOutput};
use haptic_loop::rt::RtOptions;
use haptic_loop::runner::{self, LoopHandle, RunnerConfig};
use haptic_loop::safety::SafetyConfig;
use haptic_loop::tick::{Tick, TickConfig};
use ipc_types::services::{self, StateWriter};
use nalgebra::{Isometry3, Translation3};
use parry3d_f64::math::Pose;
use parry3d_f64::shape::SharedShape;
use scene::Scene;
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A planner child process, stopped (SIGTERM, then SIGKILL) on drop.
#[derive(Debug)]
pub struct PlannerChild(pub Child);

impl PlannerChild {
    /// Starts `planner serve` on namespace `ns` from the binary next to the running one.
    pub fn spawn(ns: &str) -> Result<Self, BenchError> {
        Self::spawn_with(ns, &[])
    }

    /// [`PlannerChild::spawn`] with more `planner serve` arguments.
    pub fn spawn_with(ns: &str, extra: &[String]) -> Result<Self, BenchError> {
        Self::spawn_on(ns, "wall-hole", extra)
    }

    /// `planner serve` on namespace `ns` and `scene` (a built-in name or a scene file) with
    /// more arguments, from the binary next to the running one.
    pub fn spawn_on(ns: &str, scene: &str, extra: &[String]) -> Result<Self, BenchError> {
        let exe = std::env::current_exe().map_err(|error| BenchError::Start {
            what: "the planner (no path of this executable)".into(),
            error,
        })?;
        let planner = exe.with_file_name("planner");
        if !planner.exists() {
            return Err(BenchError::NoPlanner(planner));
        }
        let child = Command::new(&planner)
            .args(["serve", "--namespace", ns, "--scene", scene])
            .args(extra)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|error| BenchError::Start {
                what: planner.display().to_string(),
                error,
            })?;
        Ok(Self(child))
    }

    /// Sends `signal` to the process.
    pub fn signal(&self, signal: i32) {
        // SAFETY: kill(2) on a child we spawned and have not reaped.
        unsafe { libc::kill(self.0.id() as libc::pid_t, signal) };
    }
}

impl PlannerChild {
    /// Stops the process: SIGTERM (it writes its report), SIGKILL after 5 s.
    pub fn stop(&mut self) {
        self.signal(libc::SIGCONT);
        self.signal(libc::SIGTERM);
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline && matches!(self.0.try_wait(), Ok(None)) {
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl Drop for PlannerChild {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            self.stop();
        }
    }
}

/// How to run [`wall_loop`].
#[derive(Debug, Clone, Copy)]
pub struct WallLoop {
    /// Tick rate, Hz.
    pub rate_hz: f64,
    /// RT thread options.
    pub rt: RtOptions,
    /// Ticks to run.
    pub ticks: u64,
    /// Voxel size, m; `None` renders no contact.
    pub voxel_m: Option<f64>,
}

/// The loop with its IPC ends; keep it alive while the loop runs.
pub struct RunningLoop {
    /// The RT thread.
    pub handle: LoopHandle<SimulatedArm, RelayOutput, StateWriter>,
    /// Guidance relay.
    pub relay: Relay,
    /// This process's iceoryx2 node.
    pub node: iceoryx2::node::Node<services::Ipc>,
}

impl std::fmt::Debug for RunningLoop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunningLoop").finish_non_exhaustive()
    }
}

/// The simulated arm whose operator pushes the wall-hole scene's S against the wall beside
/// the hole and slides it back and forth for `seconds` (the hardest steady contact case),
/// the tick configuration at `rate_hz`, and the contact stage at `voxel_m` (`None`: no
/// contact).
pub fn wall_setup(
    rate_hz: f64,
    seconds: f64,
    voxel_m: Option<f64>,
) -> Result<(SimulatedArm, TickConfig, Option<ContactStage>), BenchError> {
    let scene = Scene::wall_with_hole();
    let origin = Isometry3::from_parts(Translation3::new(-0.08, 0.15, 0.1), scene.start.rot);
    let mut route = vec![device(0.0, 0.0, 0.0)];
    for _ in 0..((seconds / 8.0).ceil() as usize).max(1) {
        route.extend([
            device(0.06, 0.05, 0.0),
            device(0.06, -0.05, 0.0),
            device(0.0, 0.0, 0.0),
        ]);
    }
    let (arm, config, spec) = scripted_arm(route, origin, rate_hz)?;
    let contact = match voxel_m {
        Some(voxel_m) => {
            let contact = ContactConfig::with_voxel_m(voxel_m);
            let model = ContactModel::from_scene(&scene, &contact.voxmap)?;
            eprintln!("{}", model.describe());
            let coupling = Coupling::from_spec(&spec, 1.0, contact.coupling_fraction);
            Some(ContactStage::new(Arc::new(model), contact, coupling))
        }
        None => None,
    };
    Ok((arm, config, contact))
}

/// A cube whose pointshell has about `points` points at `voxel_m`, held 5 mm above a plate
/// (top face z = 0), that the simulated operator presses face-down onto the plate with the
/// arm's maximum force and slides back and forth by ±3 cm for `seconds`: a whole face in
/// contact, the "≥ 10 000 points" case for the full tick.
pub fn cube_setup(
    points: usize,
    rate_hz: f64,
    seconds: f64,
    voxel_m: f64,
) -> Result<(SimulatedArm, TickConfig, ContactStage), BenchError> {
    let half = 0.5 * voxel_m * (points as f64 / 6.0).sqrt();
    let plate = [(
        Pose::translation(0.0, 0.0, -0.01),
        SharedShape::cuboid(half + 0.06, half + 0.06, 0.01),
    )];
    let cube = [(Pose::IDENTITY, SharedShape::cuboid(half, half, half))];
    let origin = Isometry3::translation(0.0, 0.0, half + 0.005);
    // The device target 2 cm below the plate's top: the coupling saturates at the arm's
    // maximum force while the proxy rests on the plate.
    let mut route = vec![device(0.0, 0.0, 0.0), device(0.0, 0.0, -0.02)];
    for _ in 0..((seconds / 4.0).ceil() as usize).max(1) {
        route.extend([device(0.03, 0.0, -0.02), device(-0.03, 0.0, -0.02)]);
    }
    let (arm, config, spec) = scripted_arm(route, origin, rate_hz)?;
    let stage = ContactStage::from_shapes(
        &plate,
        &cube,
        ContactConfig::with_voxel_m(voxel_m),
        &spec,
        config.mapping.position_scale,
    )?;
    eprintln!("{}", stage.model().describe());
    Ok((arm, config, stage))
}

/// A device waypoint at (x, y, z), m, in the device base frame.
fn device(x: f64, y: f64, z: f64) -> Waypoint {
    Waypoint::new(Isometry3::translation(x, y, z))
}

/// The simulated arm whose scripted operator follows `route` at 5 cm/s with up to the arm's
/// maximum force, and a tick at `rate_hz` mapping the device 1:1 onto `origin`.
pub(crate) fn scripted_arm(
    route: Vec<Waypoint>,
    origin: Isometry3<f64>,
    rate_hz: f64,
) -> Result<(SimulatedArm, TickConfig, DeviceSpec), BenchError> {
    let arm_config = SimulatedArmConfig::default();
    let spec = arm_config.spec();
    let user = ScriptedUser::new(
        ScriptedUserConfig {
            max_force_n: spec.limits.max_force_n,
            linear_speed_m_per_s: 0.05,
            ..ScriptedUserConfig::default()
        },
        route,
    )?;
    let arm = SimulatedArm::with_user(arm_config, user)?;
    let config = TickConfig {
        mapping: MappingConfig {
            position_scale: 1.0,
            origin,
            clutch_button: None,
        },
        guidance: GuidanceConfig::default(),
        safety: SafetyConfig::default(),
        period_s: 1.0 / rate_hz,
    };
    Ok((arm, config, spec))
}

/// Starts the real haptic loop of [`wall_setup`] on namespace `ns`, with IPC.
pub fn wall_loop(ns: &str, run: &WallLoop) -> Result<RunningLoop, BenchError> {
    let (node, _) = services::create_node(&format!("harness_loop_{}", std::process::id()))?;
    let writer = services::state_writer(&node, ns)?;
    let (relay, guidance) = Relay::spawn(ns, Relay::LOOP_POLL)?;
    let (arm, config, contact) =
        wall_setup(run.rate_hz, run.ticks as f64 / run.rate_hz, run.voxel_m)?;
    let mut tick = Tick::new(arm, &config, guidance, writer)?;
    if let Some(stage) = contact {
        tick = tick.with_contact(stage);
    }
    let handle = runner::spawn(
        tick,
        RunnerConfig {
            rate_hz: run.rate_hz,
            rt: run.rt,
            spin_ns: 0,
            max_ticks: Some(run.ticks),
        },
        |_| {},
    )
    .map_err(|error| BenchError::Start {
        what: "the real-time loop thread".into(),
        error,
    })?;
    Ok(RunningLoop {
        handle,
        relay,
        node,
    })
}
