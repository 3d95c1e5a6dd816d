//! `hrrtc-ros2 device`: an arm driven by a ROS 2 driver, served to the haptic loop through
//! the driver bridge (`ipc_types::DriverState` / `DriverCommand`, the `driver/state` and
//! `driver/command` services that `haptic-loop run --device driver` reads and writes). The
//! loop's RT thread stays on iceoryx2; `haptic-loop run --device ros2:...` starts this
//! process beside itself.
//!
//! - **In**: the driver's pose topic (`geometry_msgs/msg/PoseStamped`, the end effector in
//!   the arm's base frame, m), optionally its velocity (`geometry_msgs/msg/TwistStamped`,
//!   base frame; without it the velocity is the pose's finite difference, low-pass filtered
//!   with `velocity_filter_s`) and its buttons (`sensor_msgs/msg/Joy`, `buttons[i] != 0` is
//!   bit i). Each valid pose becomes one `DriverState` stamped with its arrival time, so the
//!   loop sees the driver go stale when its samples stop (20 ms). A pose sample that is
//!   malformed (not a whole CDR PoseStamped, no attachment), not finite, not a unit
//!   quaternion (within 10⁻³; renormalised when within), or absurd (more than 100 m from the
//!   base) is counted, logged and answered at once with a `FAULT` state, and the states of
//!   the valid poses that follow say `FAULT` too for [`FAULT_HOLD_NS`], so the loop, which
//!   reads only the newest state each tick, sees the fault and latches zero force even when
//!   a good pose follows within the tick; forces come back through the loop's ramp after.
//!   Samples of another type on the topic are counted and logged only.
//! - **Out**: each new `DriverCommand` becomes a `geometry_msgs/msg/WrenchStamped` on the
//!   driver's wrench topic (force N, torque N·m about the end effector, base frame: the pose
//!   topic's `frame_id` unless `wrench_frame` is given), saturated to the limits given here;
//!   an `OFF` or invalid command is sent as zero. When no command arrives for
//!   `command_timeout_s` (a stopped loop), zero is sent, then every 100 ms while it lasts,
//!   and once more at exit. The driver must still have its own watchdog.
//!
//! The arm's limits (force, torque, stiffness, damping, workspace) are not on any standard
//! topic: they are given here and announced to the loop in each `DriverState`.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use ipc_types::services;
use ipc_types::{DeviceLimits, DriverCommand, DriverState, DriverStatus, Header, OutputCode};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::Serialize;
use zenoh::Wait;

use crate::GatewayError;
use crate::clock::Clocks;
use crate::msgs::{self, Joy, Message, PoseStamped, TwistStamped, WrenchStamped};
use crate::participant::{Participant, RosError, RosPublisher, SessionConfig, Subscription};
use crate::rejections::{Rejected, Rejections};
use crate::rmw::{self, Attachment, Qos};

/// Farthest accepted end-effector position from the base, m.
pub const MAX_REACH_M: f64 = 100.0;
/// How long a bad pose keeps the device in `FAULT` (50 ms: several ticks of the loop at
/// 0.5–4 kHz), ns.
pub const FAULT_HOLD_NS: u64 = 50_000_000;
/// Period of zero wrenches while the loop's commands are stale.
pub const ZERO_REPEAT: Duration = Duration::from_millis(100);

/// The arm's limits until it is measured, the gateway's defaults: 3 N, no torque,
/// 1000 N/m, 5 N·s/m, a 5 cm workspace.
pub const CONSERVATIVE_LIMITS: DeviceLimits = DeviceLimits {
    max_force_n: 3.0,
    max_torque_nm: 0.0,
    max_stiffness_n_per_m: 1000.0,
    max_rot_stiffness_nm_per_rad: 0.0,
    max_damping_n_s_per_m: 5.0,
    max_rot_damping_nm_s_per_rad: 0.0,
    workspace_radius_m: 0.05,
};

/// What the device gateway does.
#[derive(Debug, Clone)]
pub struct DeviceConfig {
    /// The loop's iceoryx2 namespace.
    pub namespace: String,
    /// The node's ROS namespace.
    pub ros_namespace: String,
    /// The node's name.
    pub node_name: String,
    /// Zenoh and ROS domain settings.
    pub session: SessionConfig,
    /// The driver's pose topic (absolute).
    pub pose_topic: String,
    /// The driver's wrench command topic (absolute).
    pub wrench_topic: String,
    /// The driver's velocity topic, if any.
    pub twist_topic: Option<String>,
    /// The driver's buttons topic, if any.
    pub joy_topic: Option<String>,
    /// The wrench's frame (default: the poses' `frame_id`).
    pub wrench_frame: Option<String>,
    /// The arm's limits, announced to the loop (all but the rotational damping limit,
    /// which the driver's state does not carry).
    pub limits: DeviceLimits,
    /// The arm senses orientation.
    pub orientation_input: bool,
    /// Buttons (≤ 32).
    pub buttons: u32,
    /// The device's name for the loop (≤ 32 bytes).
    pub name: String,
    /// Commands older than this are replaced by zero force, s.
    pub command_timeout_s: f64,
    /// Time constant of the velocity filter (finite differences), s.
    pub velocity_filter_s: f64,
    /// Stop after this long, s.
    pub duration_s: Option<f64>,
}

impl DeviceConfig {
    /// Defaults: node `/hrrtc_device`, limits [`CONSERVATIVE_LIMITS`] with orientation
    /// input and no buttons, commands stale after
    /// 20 ms, velocity filtered over 10 ms.
    pub fn new(namespace: &str, pose_topic: &str, wrench_topic: &str) -> Self {
        DeviceConfig {
            namespace: namespace.to_owned(),
            ros_namespace: "/".into(),
            node_name: "hrrtc_device".into(),
            session: SessionConfig::default(),
            pose_topic: pose_topic.to_owned(),
            wrench_topic: wrench_topic.to_owned(),
            twist_topic: None,
            joy_topic: None,
            wrench_frame: None,
            limits: CONSERVATIVE_LIMITS,
            orientation_input: true,
            buttons: 0,
            name: format!("ROS 2 {pose_topic}"),
            command_timeout_s: 0.02,
            velocity_filter_s: 0.01,
            duration_s: None,
        }
    }
}

/// Why a pose sample was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PoseRejection {
    /// Another type on the topic (counted only; not a reading of this arm).
    #[error("wrong type: key {0}")]
    WrongType(String),
    /// No or a bad attachment.
    #[error(transparent)]
    Attachment(#[from] rmw::AttachmentError),
    /// Not a PoseStamped.
    #[error("not a PoseStamped: {0}")]
    Cdr(#[from] crate::cdr::CdrError),
    /// NaN or infinite.
    #[error("pose is not finite")]
    NonFinite,
    /// Not a unit quaternion.
    #[error("orientation quaternion of norm {norm}: not a unit quaternion")]
    NotUnit {
        /// Its norm.
        norm: f64,
    },
    /// Beyond any arm's reach.
    #[error("position {distance_m:.3e} m from the base: beyond {MAX_REACH_M} m")]
    Absurd {
        /// Its distance from the base.
        distance_m: f64,
    },
}

impl Rejected for PoseRejection {
    const WHAT: &'static str = "pose sample";
    const KINDS: &'static [&'static str] = &[
        "wrong_type",
        "attachment",
        "cdr",
        "non_finite",
        "not_unit",
        "absurd",
    ];

    fn kind(&self) -> &'static str {
        match self {
            PoseRejection::WrongType(_) => "wrong_type",
            PoseRejection::Attachment(_) => "attachment",
            PoseRejection::Cdr(_) => "cdr",
            PoseRejection::NonFinite => "non_finite",
            PoseRejection::NotUnit { .. } => "not_unit",
            PoseRejection::Absurd { .. } => "absurd",
        }
    }
}

/// Checks a pose and turns successive poses into a velocity (finite differences through a
/// first-order low-pass filter of time constant `tau_s`).
#[derive(Debug, Clone)]
pub struct PoseTracker {
    tau_s: f64,
    last: Option<(i64, Vector3<f64>, UnitQuaternion<f64>)>,
    linear: Vector3<f64>,
    angular: Vector3<f64>,
}

impl PoseTracker {
    /// A tracker filtering over `tau_s`.
    pub fn new(tau_s: f64) -> Self {
        PoseTracker {
            tau_s,
            last: None,
            linear: Vector3::zeros(),
            angular: Vector3::zeros(),
        }
    }

    /// The checked pose (quaternion renormalised) of a sample taken at `t_ns` (any
    /// monotonic clock), and the filtered velocity (m/s, rad/s, base frame).
    pub fn update(
        &mut self,
        p: &msgs::Pose,
        t_ns: i64,
    ) -> Result<(ipc_types::Pose, ipc_types::Twist), PoseRejection> {
        if !p
            .position
            .iter()
            .chain(&p.orientation)
            .all(|v| v.is_finite())
        {
            return Err(PoseRejection::NonFinite);
        }
        let pos = Vector3::from(p.position);
        if pos.norm() > MAX_REACH_M {
            return Err(PoseRejection::Absurd {
                distance_m: pos.norm(),
            });
        }
        let [x, y, z, w] = p.orientation;
        let q = Quaternion::new(w, x, y, z);
        let norm = q.norm();
        if (norm - 1.0).abs() > 1e-3 {
            return Err(PoseRejection::NotUnit { norm });
        }
        let rot = UnitQuaternion::from_quaternion(q);
        if let Some((t0, p0, r0)) = self.last {
            let dt = (t_ns - t0) as f64 * 1e-9;
            if dt > 0.0 && dt <= 0.1 {
                let v = (pos - p0) / dt;
                let omega = (rot * r0.inverse()).scaled_axis() / dt;
                let a = dt / (self.tau_s + dt);
                self.linear += (v - self.linear) * a;
                self.angular += (omega - self.angular) * a;
            } else if dt > 0.1 {
                // A gap: the old pose says nothing about the velocity now.
                self.linear = Vector3::zeros();
                self.angular = Vector3::zeros();
            }
        }
        if self.last.is_none_or(|(t0, _, _)| t_ns > t0) {
            self.last = Some((t_ns, pos, rot));
        }
        let c = rot.coords;
        Ok((
            ipc_types::Pose {
                position_m: p.position,
                orientation_xyzw: [c.x, c.y, c.z, c.w],
            },
            ipc_types::convert::twist(&self.linear, &self.angular),
        ))
    }
}

/// The wrench to send for `command` (its validity and code checked), saturated to `limits`.
pub fn wrench_for(command: &DriverCommand, limits: &DeviceLimits) -> msgs::Wrench {
    if command.validate().is_err() || command.output != OutputCode::ON {
        return msgs::Wrench::default();
    }
    let clamp = |v: [f64; 3], max: f64| {
        let v = Vector3::from(v);
        let n = v.norm();
        if n > max {
            (v * (max / n)).into()
        } else {
            v.into()
        }
    };
    msgs::Wrench {
        force: clamp(command.wrench.force_n, limits.max_force_n),
        torque: clamp(command.wrench.torque_nm, limits.max_torque_nm),
    }
}

/// What the device gateway did.
#[derive(Debug, Clone, Default, Serialize)]
pub struct DeviceReport {
    /// Seconds run.
    pub seconds: f64,
    /// Pose samples that arrived.
    pub poses_received: u64,
    /// Poses handed to the loop.
    pub poses_accepted: u64,
    /// Rejected poses by kind.
    pub poses_rejected: std::collections::BTreeMap<&'static str, u64>,
    /// `FAULT` states sent.
    pub faults_sent: u64,
    /// Twist samples used.
    pub twists: u64,
    /// Joy samples used.
    pub joys: u64,
    /// Twist or Joy samples rejected.
    pub aux_rejected: u64,
    /// Commands read from the loop.
    pub commands: u64,
    /// Wrenches published.
    pub wrenches: u64,
    /// Of which zero for stale, off or invalid commands.
    pub zero_wrenches: u64,
}

#[derive(Debug, Default)]
struct Counters {
    poses_received: AtomicU64,
    poses_accepted: AtomicU64,
    rejected: Rejections<PoseRejection>,
    faults_sent: AtomicU64,
    twists: AtomicU64,
    joys: AtomicU64,
    aux_rejected: AtomicU64,
    commands: AtomicU64,
    wrenches: AtomicU64,
    zero_wrenches: AtomicU64,
}

/// State shared by the pose, twist and joy callbacks.
struct Shared {
    tracker: PoseTracker,
    twist: Option<ipc_types::Twist>,
    buttons: u32,
    sequence: u64,
    last_good: ipc_types::Pose,
    /// Until when good poses are still reported as `FAULT` (after a bad one), ns.
    fault_until_ns: u64,
    frame: String,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

fn validate(c: &DeviceConfig) -> Result<(), GatewayError> {
    services::validate_namespace(&c.namespace)?;
    rmw::validate_absolute("namespace", &c.ros_namespace).map_err(RosError::from)?;
    rmw::validate_node_name(&c.node_name).map_err(RosError::from)?;
    for t in [&c.pose_topic, &c.wrench_topic]
        .into_iter()
        .chain(&c.twist_topic)
        .chain(&c.joy_topic)
    {
        rmw::validate_absolute("topic", t).map_err(RosError::from)?;
    }
    c.limits
        .validate()
        .map_err(|e| GatewayError::Config(format!("the arm's limit {e}")))?;
    for (name, v, positive) in [
        ("command timeout (s)", c.command_timeout_s, true),
        ("velocity filter (s)", c.velocity_filter_s, false),
    ] {
        let ok = v.is_finite() && if positive { v > 0.0 } else { v >= 0.0 };
        if !ok {
            return Err(GatewayError::Config(format!(
                "{name} {v}: must be a finite number {}",
                if positive { "> 0" } else { "≥ 0" }
            )));
        }
    }
    if c.buttons > 32 {
        return Err(GatewayError::Config(format!(
            "{} buttons: at most 32",
            c.buttons
        )));
    }
    Ok(())
}

/// A `DriverState` announcing the arm with `limits`.
fn driver_state(
    config: &DeviceConfig,
    sequence: u64,
    stamp_ns: u64,
    pose: ipc_types::Pose,
    twist: ipc_types::Twist,
    buttons: u32,
    status: DriverStatus,
) -> DriverState {
    let mut s = DriverState {
        header: Header::new(sequence, stamp_ns, std::process::id()),
        pose,
        twist,
        buttons,
        status,
        button_count: config.buttons,
        orientation_input: u32::from(config.orientation_input),
        ..DriverState::default()
    }
    .with_limits(&config.limits);
    s.set_name(&config.name);
    s
}

/// Runs the device gateway until `stop` is set (or `config.duration_s` passes).
pub fn run(config: &DeviceConfig, stop: Arc<AtomicBool>) -> Result<DeviceReport, GatewayError> {
    let mut gateway = DeviceGateway::start(config)?;
    while !stop.load(Ordering::Acquire)
        && config
            .duration_s
            .is_none_or(|d| gateway.started.elapsed().as_secs_f64() < d)
    {
        gateway.cycle();
        std::thread::sleep(Duration::from_micros(250));
    }
    Ok(gateway.finish())
}

/// A running device gateway. Its set-up ([`DeviceGateway::start`]) declares the ROS 2
/// side, whose callbacks turn the driver's poses (and twists, buttons) into the loop's
/// `DriverState`; its cycle ([`DeviceGateway::cycle`]) turns the loop's newest command
/// into a `WrenchStamped` (on this thread: the iceoryx2 subscriber is not `Send`).
struct DeviceGateway<'a> {
    config: &'a DeviceConfig,
    started: Instant,
    counters: Arc<Counters>,
    shared: Arc<Mutex<Shared>>,
    participant: Participant,
    /// The pose, twist and joy subscriptions with their endpoint tokens.
    subscriptions: Vec<Subscription>,
    wrenches: RosPublisher<WrenchStamped>,
    commands: services::Subscriber<DriverCommand>,
    _nodes: (
        iceoryx2::node::Node<services::IpcThreadsafe>,
        iceoryx2::node::Node<services::Ipc>,
    ),
    last_command_id: (u64, u32),
    last_command: Instant,
    next_zero: Instant,
    next_log: Instant,
}

impl<'a> DeviceGateway<'a> {
    /// Checks the configuration, opens the participant and the loop's driver services, and
    /// declares the subscriptions and the wrench publisher.
    fn start(config: &'a DeviceConfig) -> Result<Self, GatewayError> {
        validate(config)?;
        let started = Instant::now();
        let participant =
            Participant::open(&config.session, &config.ros_namespace, &config.node_name)?;
        let counters = Arc::new(Counters::default());
        let pid = std::process::id();
        let (node, _) =
            services::create_node_in::<services::IpcThreadsafe>(&format!("ros2_device_{pid}"))?;
        let states = Arc::new(services::publisher_in::<
            services::IpcThreadsafe,
            DriverState,
        >(&node, &config.namespace)?);
        let shared = Arc::new(Mutex::new(Shared {
            tracker: PoseTracker::new(config.velocity_filter_s),
            twist: None,
            buttons: 0,
            sequence: 0,
            last_good: ipc_types::Pose::IDENTITY,
            fault_until_ns: 0,
            frame: config.wrench_frame.clone().unwrap_or_default(),
        }));
        let (pose, pose_topic, pose_key) =
            subscribe_poses(&participant, config, &counters, &shared, states)?;
        let mut subscriptions = vec![pose];
        if let Some(t) = &config.twist_topic {
            subscriptions.push(subscribe_twists(&participant, t, &counters, &shared)?);
        }
        if let Some(t) = &config.joy_topic {
            subscriptions.push(subscribe_buttons(&participant, t, &counters, &shared)?);
        }
        let wrenches =
            participant.publisher::<WrenchStamped>(&config.wrench_topic, Qos::volatile(1), true)?;
        tracing::info!(
            "ROS 2 device: {} → the loop's namespace '{}' → {} ({} key {}, {})",
            pose_topic,
            config.namespace,
            wrenches.topic(),
            if participant.links().listen.is_empty() {
                "no listen endpoint".to_owned()
            } else {
                format!("listening on {:?}", participant.links().listen)
            },
            pose_key,
            participant.node().token()
        );
        let (cmd_node, _) = services::create_node(&format!("ros2_device_cmd_{pid}"))?;
        let commands = services::subscriber::<DriverCommand>(&cmd_node, &config.namespace)?;
        let now = Instant::now();
        Ok(DeviceGateway {
            config,
            started,
            counters,
            shared,
            participant,
            subscriptions,
            wrenches,
            commands,
            _nodes: (node, cmd_node),
            last_command_id: (0, 0),
            last_command: now,
            next_zero: now,
            next_log: now + Duration::from_secs(5),
        })
    }

    /// One pass: the newest command to the arm, or zero while commands are stale; and a
    /// log line every 5 s.
    fn cycle(&mut self) {
        self.forward_command();
        self.log_progress();
    }

    /// The loop's newest command as a wrench within the limits; when none came for
    /// `command_timeout_s`, a zero wrench every [`ZERO_REPEAT`].
    fn forward_command(&mut self) {
        let mut newest = None;
        while let Ok(Some(c)) = self.commands.receive() {
            newest = Some(*c);
        }
        match newest {
            Some(c) if (c.header.sequence, c.header.writer_pid) != self.last_command_id => {
                self.last_command_id = (c.header.sequence, c.header.writer_pid);
                self.last_command = Instant::now();
                self.counters.commands.fetch_add(1, Ordering::Relaxed);
                self.publish(wrench_for(&c, &self.config.limits));
            }
            _ => {
                let now = Instant::now();
                let timeout = Duration::from_secs_f64(self.config.command_timeout_s);
                if now.duration_since(self.last_command) > timeout && now >= self.next_zero {
                    self.publish(msgs::Wrench::default());
                    self.next_zero = now + ZERO_REPEAT;
                }
            }
        }
    }

    /// `w` to the arm, in the frame of its poses (or the configured one).
    fn publish(&self, w: msgs::Wrench) {
        let frame = lock(&self.shared).frame.clone();
        let clocks = Clocks::now();
        let msg = WrenchStamped {
            header: msgs::Header {
                stamp: clocks.to_ros(clocks.monotonic_ns),
                frame_id: frame,
            },
            wrench: w,
        };
        self.wrenches.publish(&msg, clocks.realtime_ns);
        self.counters.wrenches.fetch_add(1, Ordering::Relaxed);
        if w == msgs::Wrench::default() {
            self.counters.zero_wrenches.fetch_add(1, Ordering::Relaxed);
        }
    }

    fn log_progress(&mut self) {
        if Instant::now() < self.next_log {
            return;
        }
        self.next_log += Duration::from_secs(5);
        let c = &self.counters;
        tracing::info!(
            "poses received {}, accepted {}; commands {}, wrenches {} ({} zero)",
            c.poses_received.load(Ordering::Relaxed),
            c.poses_accepted.load(Ordering::Relaxed),
            c.commands.load(Ordering::Relaxed),
            c.wrenches.load(Ordering::Relaxed),
            c.zero_wrenches.load(Ordering::Relaxed)
        );
    }

    /// Leaves the arm with no force, closes the ROS 2 side and reports.
    fn finish(self) -> DeviceReport {
        self.publish(msgs::Wrench::default());
        let report = self.counters.report(self.started.elapsed().as_secs_f64());
        drop(self.subscriptions);
        drop(self.wrenches);
        self.participant.close();
        report
    }
}

impl Counters {
    fn report(&self, seconds: f64) -> DeviceReport {
        let n = |c: &AtomicU64| c.load(Ordering::Relaxed);
        DeviceReport {
            seconds,
            poses_received: n(&self.poses_received),
            poses_accepted: n(&self.poses_accepted),
            poses_rejected: self.rejected.counts(),
            faults_sent: n(&self.faults_sent),
            twists: n(&self.twists),
            joys: n(&self.joys),
            aux_rejected: n(&self.aux_rejected),
            commands: n(&self.commands),
            wrenches: n(&self.wrenches),
            zero_wrenches: n(&self.zero_wrenches),
        }
    }
}

impl Shared {
    /// The loop's `DriverState` for a pose sample on `key` that arrived at `now` (ns), or
    /// `None` for a sample of another type, which is only counted: a good pose gives the
    /// arm's state (`FAULT` still while a bad one is recent), a bad one the last good pose
    /// held, at rest, as `FAULT`.
    fn state_for_pose(
        &mut self,
        config: &DeviceConfig,
        counters: &Counters,
        sample: (&str, &str, &[u8], Option<&[u8]>),
        now: u64,
    ) -> Option<DriverState> {
        let (key, pose_key, payload, attachment) = sample;
        let result = (|| {
            if key != pose_key {
                return Err(PoseRejection::WrongType(key.to_owned()));
            }
            Attachment::decode(attachment)?;
            let p = PoseStamped::decode(payload)?;
            // The samples' own stamps time the velocity when the driver sets them.
            let t = if p.header.stamp == msgs::Time::default() {
                now as i64
            } else {
                p.header.stamp.as_ns()
            };
            let (pose, twist) = self.tracker.update(&p.pose, t)?;
            Ok((p.header.frame_id, pose, twist))
        })();
        match result {
            Ok((frame, pose, twist)) => {
                self.sequence += 1;
                counters.poses_accepted.fetch_add(1, Ordering::Relaxed);
                if config.wrench_frame.is_none() {
                    self.frame = frame;
                }
                self.last_good = pose;
                let twist = self.twist.unwrap_or(twist);
                let status = if now < self.fault_until_ns {
                    DriverStatus::FAULT
                } else {
                    DriverStatus::OK
                };
                Some(driver_state(
                    config,
                    self.sequence,
                    now,
                    pose,
                    twist,
                    self.buttons,
                    status,
                ))
            }
            Err(e) => {
                counters.rejected.count(&e, key);
                if matches!(e, PoseRejection::WrongType(_)) {
                    return None;
                }
                self.sequence += 1;
                counters.faults_sent.fetch_add(1, Ordering::Relaxed);
                self.fault_until_ns = now + FAULT_HOLD_NS;
                Some(driver_state(
                    config,
                    self.sequence,
                    now,
                    self.last_good,
                    ipc_types::Twist::default(),
                    self.buttons,
                    DriverStatus::FAULT,
                ))
            }
        }
    }
}

/// Every sample on the pose topic's keys (of any type, so that a wrong type is named)
/// becomes a `DriverState` for the loop, from Zenoh's callback. Returns the subscription,
/// the topic and its key.
fn subscribe_poses(
    participant: &Participant,
    config: &DeviceConfig,
    counters: &Arc<Counters>,
    shared: &Arc<Mutex<Shared>>,
    states: Arc<iceoryx2::port::publisher::Publisher<services::IpcThreadsafe, DriverState, ()>>,
) -> Result<(Subscription, String, String), GatewayError> {
    let (pose_topic, pose_key, token) =
        participant.subscription_token::<PoseStamped>(&config.pose_topic, Qos::volatile(1))?;
    let keys = rmw::topic_key_any_type(config.session.domain, &pose_topic);
    let (counters, shared, config, key_wanted) = (
        counters.clone(),
        shared.clone(),
        config.clone(),
        pose_key.clone(),
    );
    let sub = participant
        .session()
        .declare_subscriber(keys.clone())
        .callback(move |sample| {
            let now = ipc_types::monotonic_ns();
            counters.poses_received.fetch_add(1, Ordering::Relaxed);
            let payload = sample.payload().to_bytes();
            let attachment = sample.attachment().map(|a| a.to_bytes());
            let key = sample.key_expr().as_str();
            let parts = (
                key,
                key_wanted.as_str(),
                &payload[..],
                attachment.as_deref(),
            );
            let state = lock(&shared).state_for_pose(&config, &counters, parts, now);
            if let Some(state) = state
                && let Err(e) = states.send_copy(state)
            {
                tracing::warn!("cannot hand the arm's state to the loop: {e:?}");
            }
        })
        .wait()
        .map_err(crate::participant::declare_error(&keys))?;
    Ok(((sub, token), pose_topic, pose_key))
}

/// The driver's velocities, used instead of the ones filtered from its poses while good.
fn subscribe_twists(
    participant: &Participant,
    topic: &str,
    counters: &Arc<Counters>,
    shared: &Arc<Mutex<Shared>>,
) -> Result<Subscription, GatewayError> {
    let (counters, shared) = (counters.clone(), shared.clone());
    subscribe::<TwistStamped>(participant, topic, move |tw| match tw {
        Some(tw) if tw.linear.iter().chain(&tw.angular).all(|v| v.is_finite()) => {
            counters.twists.fetch_add(1, Ordering::Relaxed);
            lock(&shared).twist = Some(ipc_types::Twist {
                linear_m_s: tw.linear,
                angular_rad_s: tw.angular,
            });
        }
        _ => {
            counters.aux_rejected.fetch_add(1, Ordering::Relaxed);
            // A bad velocity is no velocity: back to the poses' own.
            lock(&shared).twist = None;
        }
    })
}

/// The arm's buttons from a `sensor_msgs/Joy` topic (the first 32).
fn subscribe_buttons(
    participant: &Participant,
    topic: &str,
    counters: &Arc<Counters>,
    shared: &Arc<Mutex<Shared>>,
) -> Result<Subscription, GatewayError> {
    let (counters, shared) = (counters.clone(), shared.clone());
    subscribe::<Joy>(participant, topic, move |j| match j {
        Some(j) => {
            counters.joys.fetch_add(1, Ordering::Relaxed);
            lock(&shared).buttons = j.button_mask();
        }
        None => {
            counters.aux_rejected.fetch_add(1, Ordering::Relaxed);
        }
    })
}

/// A subscription to `topic` whose samples reach `on_sample` from Zenoh's callback as the
/// message, or `None` when its attachment or payload does not decode.
fn subscribe<M: Message>(
    participant: &Participant,
    topic: &str,
    on_sample: impl Fn(Option<M>) + Send + Sync + 'static,
) -> Result<Subscription, GatewayError> {
    let (_, key, token) = participant.subscription_token::<M>(topic, Qos::volatile(1))?;
    let sub = participant
        .session()
        .declare_subscriber(key.clone())
        .callback(move |sample| {
            let attachment = sample.attachment().map(|a| a.to_bytes());
            let ok = Attachment::decode(attachment.as_deref()).is_ok();
            let message = M::decode(&sample.payload().to_bytes()).ok();
            on_sample(message.filter(|_| ok));
        })
        .wait()
        .map_err(crate::participant::declare_error(&key))?;
    Ok((sub, token))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The button and velocity subscriptions: a good sample sets the shared state, a
    /// payload that does not decode (or an unfinite velocity) is counted as rejected and,
    /// for velocities, drops back to the poses' own.
    #[test]
    fn buttons_and_velocities_arrive_and_bad_ones_are_rejected() {
        let session = SessionConfig::insecure(vec!["tcp/127.0.0.1:0".into()], Vec::new());
        let participant = Participant::open(&session, "/", "aux_test").expect("participant");
        let counters = Arc::new(Counters::default());
        let shared = Arc::new(Mutex::new(Shared {
            tracker: PoseTracker::new(0.0),
            twist: None,
            buttons: 0,
            sequence: 0,
            last_good: ipc_types::Pose::IDENTITY,
            fault_until_ns: 0,
            frame: String::new(),
        }));
        let _joy = subscribe_buttons(&participant, "/joy", &counters, &shared).expect("joy");
        let _twist = subscribe_twists(&participant, "/twist", &counters, &shared).expect("twist");
        let joy = participant
            .publisher::<Joy>("/joy", Qos::volatile(1), true)
            .expect("joy publisher");
        let twist = participant
            .publisher::<TwistStamped>("/twist", Qos::volatile(1), true)
            .expect("twist publisher");
        let wait = |what: &str, done: &dyn Fn() -> bool| {
            let until = Instant::now() + Duration::from_secs(10);
            while !done() {
                assert!(Instant::now() < until, "{what} never arrived");
                std::thread::sleep(Duration::from_millis(5));
            }
        };
        let n = |c: &AtomicU64| c.load(Ordering::Relaxed);
        joy.publish(
            &Joy {
                header: msgs::Header::default(),
                axes: vec![],
                buttons: vec![1, 0, 1],
            },
            0,
        );
        wait("the buttons", &|| n(&counters.joys) == 1);
        assert_eq!(lock(&shared).buttons, 0b101);
        twist.publish(
            &TwistStamped {
                header: msgs::Header::default(),
                linear: [0.1, 0.0, 0.0],
                angular: [0.0, 0.0, 0.2],
            },
            0,
        );
        wait("the velocity", &|| n(&counters.twists) == 1);
        assert_eq!(
            lock(&shared).twist.map(|t| t.linear_m_s),
            Some([0.1, 0.0, 0.0])
        );
        twist.publish(
            &TwistStamped {
                header: msgs::Header::default(),
                linear: [f64::NAN, 0.0, 0.0],
                angular: [0.0; 3],
            },
            0,
        );
        wait("the bad velocity", &|| n(&counters.aux_rejected) == 1);
        assert!(lock(&shared).twist.is_none(), "back to the poses' own");
        joy.publish_payload(vec![1, 2, 3], 0);
        wait("the bad buttons", &|| n(&counters.aux_rejected) == 2);
        assert_eq!(lock(&shared).buttons, 0b101, "a bad sample changes nothing");
    }

    fn pose(x: f64, q: [f64; 4]) -> msgs::Pose {
        msgs::Pose {
            position: [x, 0.0, 0.0],
            orientation: q,
        }
    }

    const ID: [f64; 4] = [0.0, 0.0, 0.0, 1.0];

    #[test]
    fn poses_are_checked_and_differentiated() {
        let mut t = PoseTracker::new(0.0);
        let (p, v) = t.update(&pose(0.0, ID), 0).unwrap();
        assert_eq!(p.orientation_xyzw, ID);
        assert_eq!(v.linear_m_s, [0.0; 3]);
        // 1 mm in 1 ms: 1 m/s (no filtering at tau 0).
        let (_, v) = t.update(&pose(0.001, ID), 1_000_000).unwrap();
        assert!((v.linear_m_s[0] - 1.0).abs() < 1e-9, "{v:?}");
        // A quarter turn per second about z, 1 ms.
        let a = std::f64::consts::FRAC_PI_2 * 1e-3;
        let q = [0.0, 0.0, (a / 2.0).sin(), (a / 2.0).cos()];
        let (_, v) = t.update(&pose(0.001, q), 2_000_000).unwrap();
        assert!((v.angular_rad_s[2] - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
        // Slightly off unit: renormalised.
        let (p, _) = t
            .update(&pose(0.001, [0.0, 0.0, 0.0, 1.0005]), 3_000_000)
            .unwrap();
        assert!((p.orientation_xyzw[3] - 1.0).abs() < 1e-12);
        assert_eq!(
            t.update(&pose(f64::NAN, ID), 4_000_000),
            Err(PoseRejection::NonFinite)
        );
        assert!(matches!(
            t.update(&pose(0.0, [0.0, 0.0, 0.0, 2.0]), 4_000_000),
            Err(PoseRejection::NotUnit { .. })
        ));
        assert!(matches!(
            t.update(&pose(1e9, ID), 4_000_000),
            Err(PoseRejection::Absurd { .. })
        ));
        // A filter of 10 ms takes a step of velocity part of the way per sample.
        let mut f = PoseTracker::new(0.01);
        f.update(&pose(0.0, ID), 0).unwrap();
        let (_, v) = f.update(&pose(0.001, ID), 1_000_000).unwrap();
        assert!(v.linear_m_s[0] > 0.05 && v.linear_m_s[0] < 0.2, "{v:?}");
    }

    #[test]
    fn commands_become_saturated_wrenches_or_zero() {
        let limits = DeviceLimits {
            max_force_n: 2.0,
            max_torque_nm: 0.1,
            ..CONSERVATIVE_LIMITS
        };
        let mut c = DriverCommand {
            header: Header {
                sequence: 1,
                ..Header::default()
            },
            output: OutputCode::ON,
            ..DriverCommand::default()
        };
        c.wrench.force_n = [3.0, 4.0, 0.0];
        c.wrench.torque_nm = [0.0, 0.05, 0.0];
        let w = wrench_for(&c, &limits);
        assert!((Vector3::from(w.force).norm() - 2.0).abs() < 1e-12);
        assert!(
            (w.force[0] / w.force[1] - 0.75).abs() < 1e-12,
            "direction kept"
        );
        assert_eq!(w.torque, [0.0, 0.05, 0.0]);
        c.output = OutputCode::OFF;
        assert_eq!(wrench_for(&c, &limits), msgs::Wrench::default());
        c.output = OutputCode::ON;
        c.wrench.force_n[0] = f64::NAN;
        assert_eq!(wrench_for(&c, &limits), msgs::Wrench::default());
    }

    #[test]
    fn the_config_is_checked_and_its_limits_announced() {
        let mut config = DeviceConfig::new("hrrtc_test", "/arm/pose", "/arm/wrench");
        config.limits.max_stiffness_n_per_m = 800.0;
        config.buttons = 3;
        assert!(validate(&config).is_ok());
        let s = driver_state(
            &config,
            1,
            5,
            ipc_types::Pose::IDENTITY,
            ipc_types::Twist::default(),
            0,
            DriverStatus::OK,
        );
        assert_eq!(s.validate(), Ok(()));
        assert_eq!(
            s.limits(),
            DeviceLimits {
                max_stiffness_n_per_m: 800.0,
                ..CONSERVATIVE_LIMITS
            }
        );
        assert_eq!((s.button_count, s.orientation_input), (3, 1));

        config.limits.max_damping_n_s_per_m = -2.0;
        let e = validate(&config).unwrap_err().to_string();
        assert!(e.contains("max_damping_n_s_per_m is -2"), "{e}");
        config.limits.max_damping_n_s_per_m = 5.0;
        config.buttons = 33;
        assert!(validate(&config).is_err());
    }
}
