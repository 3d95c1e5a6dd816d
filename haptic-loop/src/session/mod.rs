//! A loop session: what `haptic-loop run` and `demo` do between parsing their arguments and
//! printing the summary. Build the contact stage from a validated [`LoopSetup`], open the
//! loop's IPC ports, start the RT thread, watch the planner's guidance and path from the
//! calling thread until told to stop, then hand back the loop's report.
//!
//! Starting or stopping other processes is the binary's business, not this module's.

pub mod scenario;
pub mod summary;

use crate::Error;
use crate::contact::{ContactConfig, ContactModel, ContactStage, Coupling};
use crate::relay::Relay;
use crate::runner::{self, LoopReport, RunnerConfig};
use crate::stats::SecondSummary;
use crate::tick::{Tick, TickConfig};
use devices::sim::SimulatedArmConfig;
use devices::{DeviceSpec, HapticDevice};
use ipc_types::Guidance;
use ipc_types::services::{self, ServiceError, StateReader, Subscriber};
use scene::Scene;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub use summary::{ContactSummary, OperatorSummary, Summary};

/// The validated set-up of a session.
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
    /// Who holds a simulated device.
    pub operator: scenario::SimOperator,
    /// Contact rendering parameters; `None` = contact off.
    pub contact: Option<ContactConfig>,
    /// Where built voxmaps are kept (`contact::voxmap_cache`); `None`: always build.
    pub voxmap_cache: Option<std::path::PathBuf>,
}

impl LoopSetup {
    /// Builds the contact stage (voxmap, pointshell, coupling sized from `spec`) when
    /// contact is on, and logs its size and build time. Takes seconds at fine voxel sizes
    /// and for big meshes (less when the voxmap is in the cache): call it before anything
    /// starts. Reports to `progress` and stops when its cancel flag is set.
    pub fn contact_stage(
        &self,
        spec: &DeviceSpec,
        progress: &crate::contact::Progress,
    ) -> Result<Option<ContactStage>, Error> {
        let Some(config) = self.contact else {
            return Ok(None);
        };
        let contact_error = |source| Error::Contact {
            scene: self.scene.name.clone(),
            error: Box::new(source),
        };
        config.validate().map_err(contact_error)?;
        let model = ContactModel::from_scene_with(
            &self.scene,
            &config.voxmap,
            progress,
            self.voxmap_cache.as_deref(),
        )
        .map_err(contact_error)?;
        tracing::info!("contact: {}", model.describe());
        let coupling = Coupling::from_spec(
            spec,
            self.tick.mapping.position_scale,
            config.coupling_fraction,
        );
        Ok(Some(ContactStage::new(Arc::new(model), config, coupling)))
    }
}

/// What the calling thread sees of the planner during a session: the newest guidance (from
/// the relay), the newest path, and when a solution was first reported.
pub struct Watch {
    relay: Relay,
    path_subscriber: Subscriber<ipc_types::Path>,
    path: Option<(u64, f64)>,
    solved_at: Option<Duration>,
    /// When the followed planner first said there is no way through.
    no_way_at: Option<Duration>,
    state: StateReader,
    goal: crate::tick::GoalZone,
    at_goal_at: Option<Duration>,
    /// Keeps this process's iceoryx2 node alive as long as its ports.
    _node: iceoryx2::node::Node<services::Ipc>,
}

impl Watch {
    /// Takes in what arrived since the last call; `elapsed` is the session's age.
    fn poll(&mut self, elapsed: Duration) {
        while let Ok(Some(sample)) = self.path_subscriber.receive() {
            self.path = Some((sample.len, sample.length));
        }
        if self.solved_at.is_none() && self.relay.newest().solved == 1 {
            self.solved_at = Some(elapsed);
            tracing::info!("planner solved after {:.2} s", elapsed.as_secs_f64());
        }
        if self.no_way_at.is_none() && self.relay.newest().mode == ipc_types::GuidanceMode::NO_WAY {
            self.no_way_at = Some(elapsed);
            tracing::warn!(
                "no way through: the planner proved that the object cannot pass from the start to the goal (its log names the ball and the obstacles)"
            );
        }
        if self.at_goal_at.is_none() {
            let s = self.state.get();
            if s.header.sequence > 0
                && let Some(object) = ipc_types::convert::isometry(&s.proxy_pose)
                && self.goal.contains(&object)
            {
                self.at_goal_at = Some(elapsed);
                tracing::info!(
                    "the object reached the goal after {:.2} s",
                    elapsed.as_secs_f64()
                );
            }
        }
    }

    /// Session age at which the object was first seen at the goal (polled every 20 ms; the
    /// summary's `time_to_goal_s` is the tick-exact figure).
    pub fn at_goal_at(&self) -> Option<Duration> {
        self.at_goal_at
    }

    /// The newest guidance sample received (all zero before the first).
    pub fn newest_guidance(&self) -> Guidance {
        self.relay.newest()
    }

    /// Times the relay moved from one planner's guidance to another's.
    pub fn planner_switches(&self) -> u64 {
        self.relay.planner_switches()
    }

    /// `(waypoints, weighted length)` of the newest path received.
    pub fn path(&self) -> Option<(u64, f64)> {
        self.path
    }

    /// Session age at which the followed planner first said there is no way through
    /// ([`ipc_types::GuidanceMode::NO_WAY`]).
    pub fn no_way_at(&self) -> Option<Duration> {
        self.no_way_at
    }

    /// Session age at which guidance first reported a solution.
    pub fn solved_at(&self) -> Option<Duration> {
        self.solved_at
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
        let [x, y, z] = st.proxy_pose.position_m;
        let touching = if st.contact == ipc_types::ContactCode::CONTACT {
            ", in contact"
        } else {
            ""
        };
        format!(
            "[{:>5.1} s] {planner} | object ({x:.3}, {y:.3}, {z:.3}) m{touching} | F_s {fs:.2} N ({}) | loop: {} ticks/s, wake p99 {:.0} µs, cpu max {:.0} µs, misses {} ({} overruns), fault {}",
            s.elapsed_s,
            st.guidance_freshness.name(),
            s.ticks,
            s.wake_p99_us,
            s.compute_cpu_max_us,
            s.deadline_misses_total,
            s.overruns_total,
            st.fault.name()
        )
    }
}

/// How a session ended.
pub struct SessionEnd {
    /// The loop's report.
    pub report: LoopReport,
    /// Seconds the loop ran.
    pub run_s: f64,
    /// What was seen of the planner.
    pub watch: Watch,
    /// Contact figures; `None` when contact was off.
    pub contact: Option<ContactSummary>,
    /// Seconds from the loop's start until the object first reached the goal zone.
    pub time_to_goal_s: Option<f64>,
    /// Largest change of the commanded force between consecutive ticks, N.
    pub max_force_step_n: f64,
}

impl SessionEnd {
    /// The session's summary.
    pub fn summary(&self) -> Summary {
        let mut s = Summary::new(
            self.report.clone(),
            self.run_s,
            &self.watch,
            self.contact.clone(),
        );
        s.time_to_goal_s = self.time_to_goal_s;
        s.max_force_step_n = self.max_force_step_n;
        s
    }
}

/// Runs the loop on `device` (named `device_name` in messages; `open_error` turns its open
/// failure into an error that says what to check) until `stop` is set, the loop ends, or
/// `done(watch, session age)` returns true; it is asked every 20 ms.
pub fn run(
    setup: &LoopSetup,
    device: Box<dyn HapticDevice>,
    open_error: impl FnOnce(devices::DeviceError) -> Error,
    contact: Option<ContactStage>,
    stop: &AtomicBool,
    mut done: impl FnMut(&Watch, Duration) -> bool,
) -> Result<SessionEnd, Error> {
    let (node, cleaned) = services::create_node(&format!("haptic_loop_{}", std::process::id()))?;
    if cleaned > 0 {
        tracing::info!("removed resources of {cleaned} dead iceoryx2 node(s)");
    }
    let state_writer =
        services::state_writer(&node, &setup.namespace).map_err(|source| match source {
            ServiceError::WriterTaken { .. } => Error::StateTaken {
                namespace: setup.namespace.clone(),
                error: source,
            },
            other => Error::Ipc(other),
        })?;
    let (relay, guidance_source) = Relay::spawn(&setup.namespace, Relay::LOOP_POLL)?;
    let progress = Progress {
        guidance: relay.observer(),
        state: services::state_reader(&node, &setup.namespace)?,
    };
    let mut watch = Watch {
        relay,
        path_subscriber: services::subscriber::<ipc_types::Path>(&node, &setup.namespace)?,
        path: None,
        solved_at: None,
        no_way_at: None,
        state: services::state_reader(&node, &setup.namespace)?,
        goal: scenario::goal_zone(&setup.scene),
        at_goal_at: None,
        _node: node,
    };
    let mut tick =
        Tick::new(device, &setup.tick, guidance_source, state_writer).map_err(open_error)?;
    if let Some(stage) = contact {
        tick = tick.with_contact(stage);
    }
    tick = tick.with_goal(scenario::goal_zone(&setup.scene));
    let started = Instant::now();
    let handle = runner::spawn(tick, setup.runner, move |s| {
        tracing::info!("{}", progress.line(s));
    })
    .map_err(|e| Error::Thread {
        thread: "real-time loop",
        reason: e.to_string(),
    })?;
    while !stop.load(Ordering::Acquire) && !handle.is_finished() {
        let elapsed = started.elapsed();
        watch.poll(elapsed);
        if done(&watch, elapsed) {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let (tick, report) = handle.join();
    let run_s = started.elapsed().as_secs_f64();
    watch.poll(started.elapsed());
    let contact = ContactSummary::of(&tick, setup.tick.period_s);
    Ok(SessionEnd {
        report,
        run_s,
        watch,
        contact,
        time_to_goal_s: tick.time_to_goal_s(),
        max_force_step_n: tick.max_force_step_n(),
    })
}
