//! `hrrtc-ros2 serve`: one namespace's loop and planner as a ROS 2 node.
//!
//! On the loop's host, its own process: a state thread reads the state blackboard
//! phase-locked to the loop's ticks (as `hrrtc-bridge` and the planner's receiver do,
//! `ipc_types::pacing`; at SCHED_FIFO 10, below the loop's 80, when permitted, and waking
//! just before the write and watching for it, as the planner's receiver) and publishes each tick (or every `state_decimation`-th) on the
//! topics of [`topics`]; a planner thread (normal scheduler) republishes the planner's
//! solution path and roadmap ([`markers`]) and the scene; and guidance from ROS 2
//! ([`guidance`]) goes to the loop's guidance service straight from Zenoh's callback
//! through thread-safe ports, waking the loop's relay. Nothing waits on the network.
//!
//! | topic (under the node's namespace, default `/hrrtc`) | type | QoS | rate |
//! |---|---|---|---|
//! | `object_pose`, `hand_pose`, `device_pose` | geometry_msgs/PoseStamped | reliable, volatile, depth 1 | every tick |
//! | `commanded_wrench`, `guidance_wrench`, `contact_wrench` | geometry_msgs/WrenchStamped | reliable, volatile, depth 1 | every tick |
//! | `contact` | std_msgs/Float64MultiArray | reliable, volatile, depth 1 | every tick |
//! | `/tf` | tf2_msgs/TFMessage | reliable, volatile, depth 100 | every tick |
//! | `/tf_static` | tf2_msgs/TFMessage | reliable, transient local, depth 1 | at start |
//! | `path` | nav_msgs/Path | reliable, transient local, depth 1 | each new solution |
//! | `scene_markers` | visualization_msgs/MarkerArray | reliable, transient local, depth 1 | at start, then every 5 s |
//! | `planner_markers` | visualization_msgs/MarkerArray | reliable, volatile, depth 1 | `marker_rate_hz` (2 Hz) |
//! | `guidance` (subscribed) | geometry_msgs/WrenchStamped | reliable, volatile, depth 1 | the node's |

pub mod guidance;
pub mod markers;
pub mod topics;

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use ipc_types::services;
use ipc_types::{Path, Roadmap, pacing};
use scene::Scene;
use serde::Serialize;
use zenoh::Wait;

use crate::GatewayError;
use crate::clock::Clocks;
use crate::msgs::{self, Header, Message, TfMessage, TransformStamped};
use crate::participant::{Participant, RosError, RosPublisher, SessionConfig, Subscription};
use crate::rejections::Rejections;
use crate::rmw::{self, Qos};
use guidance::{GuidanceInput, Rejection};
use markers::RoadmapModel;
use topics::Frames;

/// Period of the scene markers' republication, s.
pub const SCENE_PERIOD_S: f64 = 5.0;

/// What the gateway does.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    /// The iceoryx2 namespace of the loop and planner.
    pub namespace: String,
    /// The node's ROS namespace (absolute); frames are named under it.
    pub ros_namespace: String,
    /// The node's name.
    pub node_name: String,
    /// Zenoh and ROS domain settings.
    pub session: SessionConfig,
    /// The loop's scene (markers, start and goal frames); `None`: neither.
    pub scene: Option<Arc<Scene>>,
    /// A frame to hang `scene` from (identity, on `/tf_static`).
    pub parent_frame: Option<String>,
    /// Publish every n-th tick (1: every tick).
    pub state_decimation: u32,
    /// Poll period of the state blackboard before locking onto a real-time loop's ticks,
    /// and for a loop without real-time rights, µs.
    pub state_poll_us: u64,
    /// Longest the state thread spins for a predicted state after waking before it, µs
    /// (0: it only sleeps, reading each state its wake-up latency after the write); only
    /// for a loop with a real-time thread (see `ipc_types::pacing`).
    pub state_spin_us: f64,
    /// SCHED_FIFO priority of the thread that reads the state and publishes the tick topics
    /// (below the loop's 80), so that it wakes on time on a busy host; 0 keeps the normal
    /// scheduler, as does a lack of permission (with a warning).
    pub state_priority: u8,
    /// Rate of `planner_markers`, Hz.
    pub marker_rate_hz: f64,
    /// Time-to-live of guidance from ROS 2, s.
    pub guidance_ttl_s: f64,
    /// Meshes with more triangles are drawn as their bounding boxes.
    pub max_mesh_triangles: usize,
    /// Most roadmap nodes kept for the markers.
    pub max_roadmap_nodes: usize,
    /// Stop after this long, s (`None`: until the stop flag).
    pub duration_s: Option<f64>,
}

impl ServeConfig {
    /// Defaults on `namespace`: ROS namespace `/hrrtc`, node `hrrtc_gateway`, every tick
    /// from a SCHED_FIFO 10 thread, markers at 2 Hz, guidance fresh for 100 ms.
    pub fn new(namespace: &str) -> Self {
        ServeConfig {
            namespace: namespace.to_owned(),
            ros_namespace: "/hrrtc".into(),
            node_name: "hrrtc_gateway".into(),
            session: SessionConfig::default(),
            scene: None,
            parent_frame: None,
            state_decimation: 1,
            state_poll_us: 100,
            state_spin_us: 100.0,
            state_priority: 10,
            marker_rate_hz: 2.0,
            guidance_ttl_s: 0.1,
            max_mesh_triangles: 100_000,
            max_roadmap_nodes: 200_000,
            duration_s: None,
        }
    }
}

/// Samples put on one topic.
#[derive(Debug, Clone, Serialize)]
pub struct TopicCount {
    /// Fully qualified topic.
    pub topic: String,
    /// Its key expression.
    pub key: String,
    /// Put.
    pub sent: u64,
    /// Refused by Zenoh.
    pub failed: u64,
}

/// What became of guidance from ROS 2.
#[derive(Debug, Clone, Default, Serialize)]
pub struct GuidanceCounts {
    /// Samples that arrived.
    pub received: u64,
    /// Handed to the loop.
    pub delivered: u64,
    /// Valid but not taken by the local service.
    pub dropped: u64,
    /// Rejected, by kind (see [`guidance`]).
    pub rejected: BTreeMap<&'static str, u64>,
}

/// What the gateway did.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ServeReport {
    /// Seconds run.
    pub seconds: f64,
    /// Distinct ticks read from the loop.
    pub ticks_seen: u64,
    /// Ticks published.
    pub ticks_published: u64,
    /// Solution paths republished.
    pub paths: u64,
    /// Roadmap increments read.
    pub roadmap_increments: u64,
    /// Per topic.
    pub topics: Vec<TopicCount>,
    /// Guidance in.
    pub guidance: GuidanceCounts,
    /// Meshes drawn as bounding boxes.
    pub boxed_meshes: Vec<String>,
}

struct StatePubs {
    object_pose: RosPublisher<msgs::PoseStamped>,
    hand_pose: RosPublisher<msgs::PoseStamped>,
    device_pose: RosPublisher<msgs::PoseStamped>,
    commanded_wrench: RosPublisher<msgs::WrenchStamped>,
    guidance_wrench: RosPublisher<msgs::WrenchStamped>,
    contact_wrench: RosPublisher<msgs::WrenchStamped>,
    contact: RosPublisher<msgs::Float64MultiArray>,
    tf: RosPublisher<TfMessage>,
    tf_static: RosPublisher<TfMessage>,
    path: RosPublisher<msgs::Path>,
    scene_markers: RosPublisher<msgs::MarkerArray>,
    planner_markers: RosPublisher<msgs::MarkerArray>,
}

impl StatePubs {
    fn declare(p: &Participant) -> Result<Self, RosError> {
        let tick = Qos::volatile(1);
        Ok(StatePubs {
            object_pose: p.publisher("object_pose", tick, true)?,
            hand_pose: p.publisher("hand_pose", tick, true)?,
            device_pose: p.publisher("device_pose", tick, true)?,
            commanded_wrench: p.publisher("commanded_wrench", tick, true)?,
            guidance_wrench: p.publisher("guidance_wrench", tick, true)?,
            contact_wrench: p.publisher("contact_wrench", tick, true)?,
            contact: p.publisher("contact", tick, true)?,
            tf: p.publisher("/tf", Qos::volatile(100), true)?,
            tf_static: p.publisher("/tf_static", Qos::transient_local(1), false)?,
            path: p.publisher("path", Qos::transient_local(1), false)?,
            scene_markers: p.publisher("scene_markers", Qos::transient_local(1), false)?,
            planner_markers: p.publisher("planner_markers", Qos::volatile(1), false)?,
        })
    }

    fn counts(&self) -> Vec<TopicCount> {
        fn c<M: Message>(p: &RosPublisher<M>) -> TopicCount {
            let (sent, failed) = p.counts();
            TopicCount {
                topic: p.topic().to_owned(),
                key: p.key().to_owned(),
                sent,
                failed,
            }
        }
        vec![
            c(&self.object_pose),
            c(&self.hand_pose),
            c(&self.device_pose),
            c(&self.commanded_wrench),
            c(&self.guidance_wrench),
            c(&self.contact_wrench),
            c(&self.contact),
            c(&self.tf),
            c(&self.tf_static),
            c(&self.path),
            c(&self.scene_markers),
            c(&self.planner_markers),
        ]
    }

    /// One tick's topics, stamped with the tick's start in ROS time.
    fn publish_state(&self, s: &ipc_types::HapticState, frames: &Frames) {
        let clocks = Clocks::now();
        let stamp = clocks.to_ros(s.header.timestamp_ns);
        let m = topics::state_messages(s, stamp, frames);
        let now = clocks.realtime_ns;
        self.object_pose.publish(&m.object_pose, now);
        self.hand_pose.publish(&m.hand_pose, now);
        self.device_pose.publish(&m.device_pose, now);
        self.commanded_wrench.publish(&m.commanded_wrench, now);
        self.guidance_wrench.publish(&m.guidance_wrench, now);
        self.contact_wrench.publish(&m.contact_wrench, now);
        self.contact.publish(&m.contact, now);
        self.tf.publish(&m.tf, now);
    }
}

/// Counters shared with Zenoh's callback.
#[derive(Debug, Default)]
struct Counters {
    received: AtomicU64,
    delivered: AtomicU64,
    dropped: AtomicU64,
    rejected: Rejections<Rejection>,
    ticks_seen: AtomicU64,
    ticks_published: AtomicU64,
    paths: AtomicU64,
    roadmap_increments: AtomicU64,
    newest_tick: AtomicU64,
}

impl Counters {
    fn guidance(&self) -> GuidanceCounts {
        GuidanceCounts {
            received: self.received.load(Ordering::Relaxed),
            delivered: self.delivered.load(Ordering::Relaxed),
            dropped: self.dropped.load(Ordering::Relaxed),
            rejected: self.rejected.counts(),
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// A random non-zero planner id (from the Zenoh session id, random per session).
fn planner_id(p: &Participant) -> u32 {
    let z = p.session().zid().to_le_bytes();
    u32::from_le_bytes([z[0], z[1], z[2], z[3]]).max(1)
}

fn validate(config: &ServeConfig) -> Result<(), GatewayError> {
    services::validate_namespace(&config.namespace)?;
    rmw::validate_absolute("namespace", &config.ros_namespace).map_err(RosError::from)?;
    rmw::validate_node_name(&config.node_name).map_err(RosError::from)?;
    let positive = |name: &str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(GatewayError::Config(format!(
                "{name} {v}: must be a positive number"
            )))
        }
    };
    positive("marker rate (Hz)", config.marker_rate_hz)?;
    if !(config.state_spin_us.is_finite() && config.state_spin_us >= 0.0) {
        return Err(GatewayError::Config(format!(
            "state spin {} µs: must be a number ≥ 0",
            config.state_spin_us
        )));
    }
    positive("guidance time-to-live (s)", config.guidance_ttl_s)?;
    if let Some(d) = config.duration_s {
        positive("duration (s)", d)?;
    }
    if config.state_decimation == 0 {
        return Err(GatewayError::Config(
            "state decimation 0: publish every n-th tick, n ≥ 1".into(),
        ));
    }
    if let Some(f) = &config.parent_frame
        && (f.is_empty() || f.starts_with('/'))
    {
        return Err(GatewayError::Config(format!(
            "parent frame {f:?}: a TF frame id is non-empty and does not start with '/'"
        )));
    }
    Ok(())
}

/// Runs the gateway until `stop` is set (or `config.duration_s` passes).
pub fn run(config: &ServeConfig, stop: Arc<AtomicBool>) -> Result<ServeReport, GatewayError> {
    let started = Instant::now();
    let gateway = ServeGateway::start(config, &stop)?;
    let mut next_log = Instant::now() + Duration::from_secs(5);
    while !stop.load(Ordering::Acquire)
        && config
            .duration_s
            .is_none_or(|d| started.elapsed().as_secs_f64() < d)
    {
        std::thread::sleep(Duration::from_millis(20));
        if Instant::now() >= next_log {
            next_log += Duration::from_secs(5);
            gateway.log_progress();
        }
    }
    Ok(gateway.finish(&stop, started))
}

/// A running `hrrtc-ros2 serve`: the participant, the guidance subscription (whose
/// callback hands samples straight to the loop's guidance service), and the state and
/// planner threads that publish the session. The main thread only waits and logs.
struct ServeGateway {
    participant: Arc<Participant>,
    pubs: Arc<StatePubs>,
    counters: Arc<Counters>,
    guidance: Subscription,
    threads: [std::thread::JoinHandle<Vec<String>>; 2],
}

impl ServeGateway {
    /// Checks the configuration, opens the participant, declares the topics and the
    /// guidance subscription, publishes the static frames, and starts the threads; fails
    /// if either cannot open its ports (the other is stopped then).
    fn start(config: &ServeConfig, stop: &Arc<AtomicBool>) -> Result<Self, GatewayError> {
        validate(config)?;
        let participant = Arc::new(Participant::open(
            &config.session,
            &config.ros_namespace,
            &config.node_name,
        )?);
        let frames = Frames::new(&config.ros_namespace);
        let pubs = StatePubs::declare(&participant)?;
        let counters = Arc::new(Counters::default());
        let guidance = subscribe_guidance(config, &participant, &frames, &counters)?;
        // Static frames, once (late joiners get them from the publication cache).
        let statics = static_transforms(config, &frames);
        if !statics.transforms.is_empty() {
            pubs.tf_static
                .publish(&statics, crate::clock::realtime_ns());
        }
        let pubs = Arc::new(pubs);
        let threads = start_threads(config, &frames, &pubs, &counters, stop)?;
        let n = participant.node();
        tracing::info!(
            "ROS 2 node {}{}{} (domain {}, {:?}, session {}) serving namespace '{}': \
             connect {:?}, listen {:?}; links: {}",
            n.namespace,
            if n.namespace == "/" { "" } else { "/" },
            n.name,
            n.domain,
            participant.distro(),
            n.session,
            config.namespace,
            participant.links().connect,
            participant.links().listen,
            config.session.security.describe()
        );
        Ok(ServeGateway {
            participant,
            pubs,
            counters,
            guidance,
            threads,
        })
    }

    fn log_progress(&self) {
        let g = self.counters.guidance();
        let rejected: u64 = g.rejected.values().sum();
        tracing::info!(
            "ticks seen {}, published {}; guidance received {}, delivered {}, rejected {}",
            self.counters.ticks_seen.load(Ordering::Relaxed),
            self.counters.ticks_published.load(Ordering::Relaxed),
            g.received,
            g.delivered,
            rejected
        );
    }

    /// Stops the threads, closes the ROS 2 side and reports.
    fn finish(self, stop: &AtomicBool, started: Instant) -> ServeReport {
        stop.store(true, Ordering::Release);
        let boxed = self
            .threads
            .into_iter()
            .flat_map(|t| t.join().unwrap_or_default())
            .collect();
        drop(self.guidance);
        let c = &self.counters;
        let report = ServeReport {
            seconds: started.elapsed().as_secs_f64(),
            ticks_seen: c.ticks_seen.load(Ordering::Relaxed),
            ticks_published: c.ticks_published.load(Ordering::Relaxed),
            paths: c.paths.load(Ordering::Relaxed),
            roadmap_increments: c.roadmap_increments.load(Ordering::Relaxed),
            topics: self.pubs.counts(),
            guidance: c.guidance(),
            boxed_meshes: boxed,
        };
        drop(self.pubs);
        if let Ok(p) = Arc::try_unwrap(self.participant) {
            p.close();
        }
        report
    }
}

/// Guidance from ROS 2: every sample on the guidance topic's keys (of any type, so that a
/// wrong type is named) is checked and goes from Zenoh's callback straight into the loop's
/// guidance service.
fn subscribe_guidance(
    config: &ServeConfig,
    participant: &Participant,
    frames: &Frames,
    counters: &Arc<Counters>,
) -> Result<Subscription, GatewayError> {
    let inlet = services::GuidanceInlet::open(
        &format!("ros2_guidance_{}", std::process::id()),
        &config.namespace,
    )?;
    let (topic, key, token) =
        participant.subscription_token::<msgs::WrenchStamped>("guidance", Qos::volatile(1))?;
    let input = Mutex::new(GuidanceInput::new(
        key.clone(),
        frames.scene.clone(),
        (config.guidance_ttl_s * 1e9) as u64,
        planner_id(participant),
    ));
    let any_type = rmw::topic_key_any_type(config.session.domain, &topic);
    let counters = counters.clone();
    let sub = participant
        .session()
        .declare_subscriber(any_type.clone())
        .callback(move |sample| {
            let now = Clocks::now();
            counters.received.fetch_add(1, Ordering::Relaxed);
            let payload = sample.payload().to_bytes();
            let attachment = sample.attachment().map(|a| a.to_bytes());
            let newest = counters.newest_tick.load(Ordering::Relaxed);
            let mut input = lock(&input);
            match input.accept(
                sample.key_expr().as_str(),
                &payload,
                attachment.as_deref(),
                now,
                newest,
            ) {
                Ok(g) => {
                    drop(input);
                    if inlet.send(g) {
                        counters.delivered.fetch_add(1, Ordering::Relaxed);
                    } else {
                        counters.dropped.fetch_add(1, Ordering::Relaxed);
                    }
                }
                Err(e) => counters.rejected.count(&e, sample.key_expr().as_str()),
            }
        })
        .wait()
        .map_err(crate::participant::declare_error(&any_type))?;
    Ok((sub, token))
}

/// Starts the state and planner threads (each owns its iceoryx2 ports, which are not
/// `Send`) and waits until both say whether their ports opened; if either could not, both
/// are stopped and the first error returned.
fn start_threads(
    config: &ServeConfig,
    frames: &Frames,
    pubs: &Arc<StatePubs>,
    counters: &Arc<Counters>,
    stop: &Arc<AtomicBool>,
) -> Result<[std::thread::JoinHandle<Vec<String>>; 2], GatewayError> {
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let spawn = |name: &'static str, body: ThreadBody| {
        let (config, frames, pubs, counters, stop, ready) = (
            config.clone(),
            frames.clone(),
            pubs.clone(),
            counters.clone(),
            stop.clone(),
            ready_tx.clone(),
        );
        std::thread::Builder::new()
            .name(format!("ros2-{name}"))
            .spawn(move || body(&config, &frames, &pubs, &counters, &stop, ready))
            .map_err(|e| GatewayError::Thread {
                thread: name,
                reason: e.to_string(),
            })
    };
    let state = spawn("state", state_thread)?;
    let planner = match spawn("planner", planner_thread) {
        Ok(t) => t,
        Err(e) => {
            stop.store(true, Ordering::Release);
            let _ = state.join();
            return Err(e);
        }
    };
    let threads = [state, planner];
    drop(ready_tx);
    let mut setup = Ok(());
    for _ in 0..threads.len() {
        match ready_rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => setup = Err(e),
            Err(_) => {
                setup = Err(GatewayError::Thread {
                    thread: "state or planner",
                    reason: "it died during set-up".into(),
                })
            }
        }
    }
    if let Err(e) = setup {
        stop.store(true, Ordering::Release);
        for t in threads {
            let _ = t.join();
        }
        return Err(e);
    }
    Ok(threads)
}

/// `/tf_static`: the scene's start and goal, and `scene` under the parent frame if any.
fn static_transforms(config: &ServeConfig, frames: &Frames) -> TfMessage {
    let stamp = crate::clock::Clocks::now().to_ros(ipc_types::monotonic_ns());
    let t = |parent: &str, child: &str, pose: &scene::Se3| {
        let q = pose.rot.coords;
        TransformStamped {
            header: Header {
                stamp,
                frame_id: parent.to_owned(),
            },
            child_frame_id: child.to_owned(),
            translation: pose.pos.into(),
            rotation: [q.x, q.y, q.z, q.w],
        }
    };
    let mut transforms = Vec::new();
    if let Some(parent) = &config.parent_frame {
        transforms.push(t(parent, &frames.scene, &scene::Se3::identity()));
    }
    if let Some(s) = &config.scene {
        transforms.push(t(&frames.scene, &frames.start, &s.start));
        transforms.push(t(&frames.scene, &frames.goal, &s.goal));
    }
    TfMessage { transforms }
}

/// A gateway thread's body: it says on `ready` whether its ports opened, runs until the stop
/// flag, and returns the meshes it drew as boxes.
type ThreadBody = fn(
    &ServeConfig,
    &Frames,
    &StatePubs,
    &Counters,
    &AtomicBool,
    std::sync::mpsc::Sender<Result<(), GatewayError>>,
) -> Vec<String>;

/// The tick topics: reads the state phase-locked to the loop (as the planner's receiver, at
/// SCHED_FIFO `state_priority` when permitted, so that it wakes on time on a busy host) and
/// publishes each (or each n-th) tick. Owns its iceoryx2 ports (not `Send`).
fn state_thread(
    config: &ServeConfig,
    frames: &Frames,
    pubs: &StatePubs,
    counters: &Counters,
    stop: &AtomicBool,
    ready: std::sync::mpsc::Sender<Result<(), GatewayError>>,
) -> Vec<String> {
    let opened = (|| -> Result<_, GatewayError> {
        let (node, _) = services::create_node(&format!("ros2_state_{}", std::process::id()))?;
        let state = services::StateFollower::open(&node, &config.namespace)?;
        Ok((node, state))
    })();
    let (_node, mut state) = match opened {
        Ok(o) => {
            let _ = ready.send(Ok(()));
            o
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return Vec::new();
        }
    };
    if config.state_priority > 0
        && let Err(e) = ipc_types::set_thread_fifo_priority(config.state_priority)
    {
        tracing::warn!("state thread: {e}; it keeps the normal scheduler");
    }
    if !ipc_types::set_thread_timer_slack_ns(1_000) {
        tracing::debug!("cannot set the state thread's timer slack");
    }
    let poll_ns = config.state_poll_us.max(10) * 1_000;
    let spin_ns = (config.state_spin_us * 1e3) as u64;
    let mut pacer = pacing::StatePacer::sleeping(poll_ns);
    // Phase-locked (and spinning) only for a loop with a real-time thread, as the planner's
    // receiver: a loop at normal priority ticks late and in bursts, and needs the CPU.
    let (mut paced, mut spin, mut came) = (false, false, false);
    let (mut last_seq, mut last_pid) = (0u64, 0u32);
    let mut next_poll = ipc_types::monotonic_ns();
    while !stop.load(Ordering::Acquire) {
        let s = state.get();
        let new = s.header.sequence != 0
            && (s.header.sequence != last_seq || s.header.writer_pid != last_pid);
        if let Err(e) = state.after_read(new) {
            tracing::warn!("cannot follow a restarted haptic loop: {e}");
        }
        if new {
            if s.header.writer_pid != last_pid {
                paced = pacing::has_real_time_thread(s.header.writer_pid);
                spin = paced && spin_ns > 0;
                pacer = if spin {
                    pacing::StatePacer::spinning(poll_ns)
                } else {
                    pacing::StatePacer::sleeping(poll_ns)
                };
            }
            last_seq = s.header.sequence;
            last_pid = s.header.writer_pid;
            counters.newest_tick.store(last_seq, Ordering::Relaxed);
            counters.ticks_seen.fetch_add(1, Ordering::Relaxed);
            if last_seq % u64::from(config.state_decimation) == 0 {
                pubs.publish_state(&s, frames);
                counters.ticks_published.fetch_add(1, Ordering::Relaxed);
            }
        }
        let now = ipc_types::monotonic_ns();
        let next = if paced {
            let seen = match (new, came) {
                (false, _) => pacing::Seen::Nothing,
                (true, false) => pacing::Seen::Found {
                    sequence: s.header.sequence,
                    stamp_ns: s.header.timestamp_ns,
                },
                (true, true) => pacing::Seen::Came {
                    sequence: s.header.sequence,
                    stamp_ns: s.header.timestamp_ns,
                },
            };
            pacer.next_poll(now, seen)
        } else {
            next_poll += poll_ns;
            if next_poll < now {
                next_poll = now + poll_ns;
            }
            next_poll
        };
        ipc_types::sleep_until_ns(next);
        came = false;
        if spin && pacer.predicted() && state.get().header.sequence == last_seq {
            // Woken before the write (the pacer aims so four times in five): watch the entry
            // until the state comes or the window closes, and read it within about a
            // microsecond of its write.
            let end = ipc_types::monotonic_ns() + spin_ns;
            while state.get().header.sequence == last_seq && ipc_types::monotonic_ns() < end {
                std::hint::spin_loop();
            }
            came = true;
        }
    }
    Vec::new()
}

/// How often the planner thread looks for paths and roadmap increments.
const PLANNER_POLL: Duration = Duration::from_millis(10);

/// The planner's output and the scene, at the normal scheduler: the solution path (each new
/// one), the roadmap and path markers (at `marker_rate_hz`), the scene markers (every
/// [`SCENE_PERIOD_S`]). Owns its iceoryx2 ports. Returns the meshes drawn as boxes.
fn planner_thread(
    config: &ServeConfig,
    frames: &Frames,
    pubs: &StatePubs,
    counters: &Counters,
    stop: &AtomicBool,
    ready: std::sync::mpsc::Sender<Result<(), GatewayError>>,
) -> Vec<String> {
    let ns = &config.namespace;
    let opened = (|| -> Result<_, GatewayError> {
        let (node, _) = services::create_node(&format!("ros2_planner_{}", std::process::id()))?;
        let path = services::subscriber::<Path>(&node, ns)?;
        let roadmap = services::subscriber::<Roadmap>(&node, ns)?;
        Ok((node, path, roadmap))
    })();
    let (_node, path_sub, roadmap_sub) = match opened {
        Ok(o) => {
            let _ = ready.send(Ok(()));
            o
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return Vec::new();
        }
    };
    let mut boxed = Vec::new();
    let scene_markers = config.scene.as_ref().map(|s| {
        let stamp = Clocks::now().to_ros(ipc_types::monotonic_ns());
        let (m, b) = markers::scene_markers(s, frames, stamp, config.max_mesh_triangles);
        for name in &b {
            tracing::info!(
                "mesh {name}: more than {} triangles, drawn as its bounding box",
                config.max_mesh_triangles
            );
        }
        boxed = b;
        m.encode()
    });
    let mut next_scene = Instant::now();
    let marker_period = Duration::from_secs_f64(1.0 / config.marker_rate_hz);
    let mut next_markers = Instant::now() + marker_period;
    let mut roadmap = RoadmapModel::new(config.max_roadmap_nodes);
    let mut newest_path: Option<Box<Path>> = None;
    let mut roadmap_warned = false;
    while !stop.load(Ordering::Acquire) {
        while let Ok(Some(p)) = path_sub.receive() {
            if p.header.sequence != 0 && p.waypoints().iter().all(|w| w.is_valid()) {
                let stamp = Clocks::now().to_ros(p.header.timestamp_ns);
                pubs.path.publish(
                    &markers::path_message(&p, frames, stamp),
                    crate::clock::realtime_ns(),
                );
                counters.paths.fetch_add(1, Ordering::Relaxed);
                newest_path = Some(Box::new(*p));
            }
        }
        while let Ok(Some(r)) = roadmap_sub.receive() {
            roadmap.apply(&r);
            counters.roadmap_increments.fetch_add(1, Ordering::Relaxed);
        }
        if roadmap.dropped > 0 && !roadmap_warned {
            tracing::warn!(
                "roadmap beyond {} nodes: further nodes are not drawn",
                config.max_roadmap_nodes
            );
            roadmap_warned = true;
        }
        let now = Instant::now();
        if let Some(bytes) = &scene_markers
            && now >= next_scene
        {
            pubs.scene_markers
                .publish_payload(bytes.clone(), crate::clock::realtime_ns());
            next_scene = now + Duration::from_secs_f64(SCENE_PERIOD_S);
        }
        if now >= next_markers {
            next_markers = now + marker_period;
            let stamp = Clocks::now().to_ros(ipc_types::monotonic_ns());
            let m = markers::planner_markers(&roadmap, newest_path.as_deref(), frames, stamp);
            if m.markers.len() > 1 {
                pubs.planner_markers
                    .publish(&m, crate::clock::realtime_ns());
            }
        }
        std::thread::sleep(PLANNER_POLL);
    }
    boxed
}
