//! The viewer process: subscribe, reassemble, log to the Foxglove context (WebSocket
//! server and/or MCAP file). Reads the clock and does I/O: this is process shell, not core.

use crate::ViewError;
use crate::draw::{self, ForceScale};
use crate::model::{Removal, RoadmapModel};
use foxglove::messages::{FrameTransforms, PointCloud, SceneEntityDeletion, SceneUpdate};
use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{Channel, Context, McapWriterHandle, WebSocketServerHandle};
use ipc_types::services::{self, Ipc, StateFollower, Subscriber};
use ipc_types::{ContactCode, Guidance, HapticState, monotonic_ns};
use scene::Scene;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Everything `planner view` needs, validated.
#[derive(Debug, Clone)]
pub struct ViewConfig {
    /// IPC namespace of the haptic loop and the planner.
    pub namespace: String,
    /// The scene they run (for the obstacles and the object's shape).
    pub scene: Scene,
    /// Address the WebSocket server binds to.
    pub host: String,
    /// WebSocket port (0: any free port); `None`: no live server (recording only).
    pub port: Option<u16>,
    /// Write the channels to this MCAP file (truncated).
    pub record: Option<PathBuf>,
    /// Most updates per second of the object poses and the force arrows.
    pub rate_hz: f64,
    /// Arrow length per newton, m/N.
    pub m_per_n: f64,
    /// Stop after this long (`None`: until the stop flag is set).
    pub duration_s: Option<f64>,
}

/// What a view run did; `--json` writes it.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ViewReport {
    /// Seconds the view ran.
    pub run_s: f64,
    /// The WebSocket port, if a server ran.
    pub port: Option<u16>,
    /// Distinct haptic states seen.
    pub states_seen: u64,
    /// Times a restarted haptic loop was found and followed.
    pub loops_followed: u64,
    /// Roadmap samples applied.
    pub roadmap_samples: u64,
    /// Roadmap samples the planner sent that the view missed (sequence gaps).
    pub roadmap_samples_missed: u64,
    /// Nodes the view knows.
    pub nodes_known: u64,
    /// Nodes the planner reported in its newest sample.
    pub planner_nodes: u64,
    /// Trees the view knows.
    pub trees: u64,
    /// The planner reported a solution.
    pub solved: bool,
    /// Waypoints of the newest solution path received.
    pub path_waypoints: u64,
    /// Messages logged per topic (to every sink subscribed then).
    pub messages: BTreeMap<String, u64>,
}

/// `/view/status`: one line of counters, for Foxglove's raw-message and plot panels.
#[derive(Debug, Clone, foxglove::Encode)]
pub struct ViewStatus {
    /// Haptic loop tick (`HapticState.header.sequence`), 0 before the loop publishes.
    pub loop_tick: u64,
    /// Deadline misses of the loop since it started.
    pub deadline_misses: u64,
    /// Fault code name of the loop.
    pub fault: String,
    /// Contact state: disabled, free, proximity, contact.
    pub contact: String,
    /// Deepest penetration this tick, mm.
    pub penetration_mm: f64,
    /// Freshness of the guidance the loop rendered.
    pub guidance: String,
    /// Nodes in all of the planner's trees.
    pub planner_nodes: u64,
    /// Nodes the view has received and shows.
    pub nodes_shown: u64,
    /// Trees (start, goal, local).
    pub trees: u32,
    /// Planner iterations.
    pub iterations: u64,
    /// A solution path exists.
    pub solved: bool,
}

struct Channels {
    scene: Channel<SceneUpdate>,
    object: Channel<SceneUpdate>,
    tf: Channel<FrameTransforms>,
    forces: Channel<SceneUpdate>,
    edges: Channel<SceneUpdate>,
    nodes: Channel<PointCloud>,
    trail: Channel<SceneUpdate>,
    path: Channel<SceneUpdate>,
    status: Channel<ViewStatus>,
}

/// Sets the flag when a client subscribes to a channel whose entities persist (the scene,
/// the roadmap...): they are re-sent in full on the next poll.
struct Resend(Arc<AtomicBool>);

impl ServerListener for Resend {
    fn on_subscribe(&self, _client: Client, _channel: ChannelView) {
        self.0.store(true, Ordering::Release);
    }
}

/// Trail points are kept when the operator moved at least this far, m.
const TRAIL_STEP_M: f64 = 0.002;
/// Most trail points; beyond it every other point is dropped.
const TRAIL_MAX: usize = 20_000;
/// Edge chunks re-sent per edges update (4 Hz) beyond the changed ones, so that seeking in
/// a recording gets the whole roadmap back after a while (a Foxglove client that
/// subscribes gets every chunk at once); a 50 000-node roadmap is re-sent every 12 s.
const EDGE_REFRESH_CHUNKS: usize = 1;

/// The viewer: services, sinks, and what it has assembled.
pub struct Viewer {
    config: ViewConfig,
    _node: iceoryx2::node::Node<Ipc>,
    state: StateFollower,
    guidance: Subscriber<Guidance>,
    path_sub: Subscriber<ipc_types::Path>,
    roadmap: Subscriber<ipc_types::Roadmap>,
    ctx: Arc<Context>,
    channels: Channels,
    server: Option<WebSocketServerHandle>,
    mcap: Option<McapWriterHandle<BufWriter<File>>>,
    resend: Arc<AtomicBool>,
    model: RoadmapModel,
    last_state: HapticState,
    last_guidance: Option<Guidance>,
    path: Vec<[f64; 3]>,
    path_pid: u32,
    path_changed: bool,
    trail: Vec<[f64; 3]>,
    trail_changed: bool,
    nodes_changed: bool,
    pending_deletions: Vec<SceneEntityDeletion>,
    refresh_cursor: usize,
    report: ViewReport,
}

impl std::fmt::Debug for Viewer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Viewer")
            .field("namespace", &self.config.namespace)
            .field("port", &self.report.port)
            .finish_non_exhaustive()
    }
}

fn contact_name(c: ContactCode) -> &'static str {
    match c {
        ContactCode::DISABLED => "disabled",
        ContactCode::FREE => "free",
        ContactCode::PROXIMITY => "proximity",
        ContactCode::CONTACT => "contact",
        _ => "unknown",
    }
}

impl Viewer {
    /// Opens the services, starts the WebSocket server (if `config.port` is set) and the
    /// MCAP writer (if `config.record` is set).
    pub fn new(config: &ViewConfig) -> Result<Viewer, ViewError> {
        let (node, cleaned) = services::create_node(&format!("view_{}", std::process::id()))?;
        if cleaned > 0 {
            tracing::info!("removed resources of {cleaned} dead iceoryx2 node(s)");
        }
        let ns = &config.namespace;
        let state = StateFollower::open(&node, ns)?;
        let guidance = services::subscriber::<ipc_types::Guidance>(&node, ns)?;
        let path_sub = services::subscriber::<ipc_types::Path>(&node, ns)?;
        let roadmap = services::subscriber::<ipc_types::Roadmap>(&node, ns)?;

        let ctx = Context::new();
        let ch = |topic: &str| ctx.channel_builder(topic);
        let channels = Channels {
            scene: ch("/view/scene").build(),
            object: ch("/view/object").build(),
            tf: ch("/view/tf").build(),
            forces: ch("/view/forces").build(),
            edges: ch("/view/roadmap/edges").build(),
            nodes: ch("/view/roadmap/nodes").build(),
            trail: ch("/view/trail").build(),
            path: ch("/view/path").build(),
            status: ch("/view/status").build(),
        };
        let mcap = match &config.record {
            Some(p) => {
                let file = File::create(p).map_err(|source| ViewError::File {
                    action: "create the recording",
                    path: p.clone(),
                    source,
                })?;
                let options = mcap::WriteOptions::new()
                    .compression(Some(mcap::Compression::Lz4))
                    .profile("hrrtc");
                Some(
                    ctx.mcap_writer_with_options(options)
                        .create(BufWriter::new(file))
                        .map_err(|source| ViewError::Recording {
                            action: "write",
                            path: p.clone(),
                            source,
                        })?,
                )
            }
            None => None,
        };
        let resend = Arc::new(AtomicBool::new(true));
        let server = match config.port {
            Some(port) => Some(
                ctx.websocket_server()
                    .name(format!("hrrtc view ({ns})"))
                    .bind(config.host.clone(), port)
                    .listener(Arc::new(Resend(resend.clone())))
                    .start_blocking()
                    .map_err(|source| ViewError::Server {
                        host: config.host.clone(),
                        port,
                        source,
                    })?,
            ),
            None => None,
        };
        let report = ViewReport {
            port: server.as_ref().map(WebSocketServerHandle::port),
            ..ViewReport::default()
        };
        Ok(Viewer {
            config: config.clone(),
            _node: node,
            state,
            guidance,
            path_sub,
            roadmap,
            ctx,
            channels,
            server,
            mcap,
            resend,
            model: RoadmapModel::new(),
            last_state: HapticState::default(),
            last_guidance: None,
            path: Vec::new(),
            path_pid: 0,
            path_changed: false,
            trail: Vec::new(),
            trail_changed: false,
            nodes_changed: false,
            pending_deletions: Vec::new(),
            refresh_cursor: 0,
            report,
        })
    }

    /// The WebSocket server's port, if it runs.
    pub fn port(&self) -> Option<u16> {
        self.report.port
    }

    /// The roadmap as assembled so far.
    pub fn model(&self) -> &RoadmapModel {
        &self.model
    }

    fn count(&mut self, topic: &str) {
        *self.report.messages.entry(topic.to_string()).or_default() += 1;
    }

    /// Drains the services; returns true when a new haptic state arrived.
    fn receive(&mut self) -> Result<bool, ViewError> {
        let failed = |service| move |source| ViewError::Receive { service, source };
        while let Some(sample) = self.roadmap.receive().map_err(failed("roadmap"))? {
            match self.model.apply(&sample) {
                Some(Removal::All) => {
                    let now = monotonic_ns();
                    self.pending_deletions.clear();
                    self.pending_deletions.push(draw::deletion(None, now));
                    if self.path_pid != sample.header.writer_pid {
                        self.path.clear();
                        self.path_changed = true;
                    }
                }
                Some(Removal::Chunks(chunks)) => {
                    let now = monotonic_ns();
                    for (t, c) in chunks {
                        self.pending_deletions
                            .push(draw::deletion(Some(draw::chunk_id(t, c)), now));
                    }
                }
                None => {}
            }
            self.nodes_changed |= self.model.take_changed();
        }
        while let Some(p) = self.path_sub.receive().map_err(failed("path"))? {
            self.path = p.waypoints().iter().map(|w| w.position_m).collect();
            self.path_pid = p.header.writer_pid;
            self.path_changed = true;
            self.report.path_waypoints = p.waypoints().len() as u64;
        }
        while let Some(g) = self.guidance.receive().map_err(failed("guidance"))? {
            if g.validate().is_ok() {
                self.last_guidance = Some(*g);
            }
        }
        let s = self.state.get();
        let fresh = s.header.sequence != 0
            && (s.header.sequence != self.last_state.header.sequence
                || s.header.writer_pid != self.last_state.header.writer_pid);
        match self.state.after_read(fresh) {
            Ok(Some(generation)) => {
                tracing::info!(
                    "following the haptic state of a new loop (generation {generation})"
                );
                self.report.loops_followed += 1;
            }
            Ok(None) => {}
            Err(e) => tracing::warn!("cannot follow a restarted haptic loop: {e}"),
        }
        if fresh {
            self.report.states_seen += 1;
            let p = s.user_pose.position_m;
            let far = self.trail.last().is_none_or(|l| {
                let d2: f64 = (0..3).map(|i| (l[i] - p[i]).powi(2)).sum();
                d2 >= TRAIL_STEP_M * TRAIL_STEP_M
            });
            if far && p.iter().all(|v| v.is_finite()) {
                if self.trail.len() >= TRAIL_MAX {
                    let mut k = 0;
                    self.trail.retain(|_| {
                        k += 1;
                        k % 2 == 1
                    });
                }
                self.trail.push(p);
                self.trail_changed = true;
            }
            self.last_state = s;
        }
        Ok(fresh)
    }

    fn send_static(&mut self, now: u64) {
        if self.channels.scene.has_sinks() {
            self.channels
                .scene
                .log_with_time(&draw::scene_update(&self.config.scene, now), now);
            self.count("/view/scene");
        }
        if self.channels.object.has_sinks() {
            self.channels
                .object
                .log_with_time(&draw::object_update(&self.config.scene, now), now);
            self.count("/view/object");
        }
    }

    fn send_pose(&mut self, now: u64) {
        let s = self.last_state;
        if s.header.sequence == 0 {
            return;
        }
        if self.channels.tf.has_sinks() && s.user_pose.is_valid() && s.proxy_pose.is_valid() {
            self.channels
                .tf
                .log_with_time(&draw::frame_transforms(&s, now), now);
            self.count("/view/tf");
        }
        if self.channels.forces.has_sinks() {
            let fa = self
                .last_guidance
                .filter(|g| {
                    g.mode != ipc_types::GuidanceMode::NONE
                        && now <= g.header.timestamp_ns.saturating_add(g.time_to_live_ns)
                })
                .map(|g| g.attractive);
            let scale = ForceScale {
                m_per_n: self.config.m_per_n,
                normal_m: 0.05,
            };
            self.channels
                .forces
                .log_with_time(&draw::forces_update(&s, fa, scale, now), now);
            self.count("/view/forces");
        }
    }

    fn send_edges(&mut self, now: u64, all: bool) {
        let mut chunks = self.model.take_dirty();
        if !self.channels.edges.has_sinks() {
            return; // the chunks will come back through the refresh or a resend
        }
        let every = self.model.all_chunks();
        if all {
            chunks = every;
        } else if !every.is_empty() {
            for _ in 0..EDGE_REFRESH_CHUNKS.min(every.len()) {
                let c = every[self.refresh_cursor % every.len()];
                self.refresh_cursor = self.refresh_cursor.wrapping_add(1);
                if !chunks.contains(&c) {
                    chunks.push(c);
                }
            }
        }
        let deletions = std::mem::take(&mut self.pending_deletions);
        if chunks.is_empty() && deletions.is_empty() {
            return;
        }
        let msg = draw::edges_update(&self.model, &chunks, deletions, now);
        self.channels.edges.log_with_time(&msg, now);
        self.count("/view/roadmap/edges");
    }

    fn send_nodes(&mut self, now: u64) {
        if self.channels.nodes.has_sinks() && self.model.known_nodes() > 0 {
            self.channels
                .nodes
                .log_with_time(&draw::nodes_cloud(&self.model, now), now);
            self.count("/view/roadmap/nodes");
        }
    }

    fn send_trail(&mut self, now: u64) {
        if self.channels.trail.has_sinks() {
            let msg = draw::polyline_update("trail", &self.trail, draw::TRAIL, 2.0, now);
            self.channels.trail.log_with_time(&msg, now);
            self.count("/view/trail");
        }
    }

    fn send_path(&mut self, now: u64) {
        if self.channels.path.has_sinks() {
            let msg = draw::polyline_update("solution", &self.path, draw::SOLUTION, 4.0, now);
            self.channels.path.log_with_time(&msg, now);
            self.count("/view/path");
        }
    }

    fn send_status(&mut self, now: u64) {
        if !self.channels.status.has_sinks() {
            return;
        }
        let s = &self.last_state;
        let msg = ViewStatus {
            loop_tick: s.header.sequence,
            deadline_misses: s.deadline_misses,
            fault: s.fault.name().into(),
            contact: contact_name(s.contact).into(),
            penetration_mm: s.penetration_m * 1e3,
            guidance: s.guidance_freshness.name().into(),
            planner_nodes: self.model.total_nodes,
            nodes_shown: self.model.known_nodes() as u64,
            trees: self.model.trees.len() as u32,
            iterations: self.model.iterations,
            solved: self.model.solved,
        };
        self.channels.status.log_with_time(&msg, now);
        self.count("/view/status");
    }

    /// Runs until `stop` is set or the configured duration elapses; closes the recording.
    pub fn run(mut self, stop: &AtomicBool) -> Result<ViewReport, ViewError> {
        let started = Instant::now();
        let poll = Duration::from_millis(5);
        let pose_period = Duration::from_secs_f64(1.0 / self.config.rate_hz);
        let mut next_pose = started;
        let mut next_static = started;
        let mut next_edges = started;
        let mut next_nodes = started;
        let mut next_trail = started;
        let mut next_status = started;
        let mut next_path = started;
        let mut next_poll = started;
        let mut pose_pending = false;
        loop {
            let stopping = stop.load(Ordering::Acquire)
                || self
                    .config
                    .duration_s
                    .is_some_and(|d| started.elapsed().as_secs_f64() >= d);
            pose_pending |= self.receive()?;
            let now_i = Instant::now();
            let now = monotonic_ns();
            let resend = self.resend.swap(false, Ordering::AcqRel);
            if resend || now_i >= next_static {
                self.send_static(now);
                next_static = now_i + Duration::from_secs(2);
            }
            if pose_pending && now_i >= next_pose {
                self.send_pose(now);
                pose_pending = false;
                next_pose = now_i + pose_period;
            }
            if resend || stopping || now_i >= next_edges {
                self.send_edges(now, resend);
                next_edges = now_i + Duration::from_millis(250);
            }
            if resend || stopping || (self.nodes_changed && now_i >= next_nodes) {
                self.send_nodes(now);
                self.nodes_changed = false;
                next_nodes = now_i + Duration::from_secs(1);
            }
            if resend || (self.trail_changed && (stopping || now_i >= next_trail)) {
                self.send_trail(now);
                self.trail_changed = false;
                next_trail = now_i + Duration::from_millis(500);
            }
            if self.path_changed || resend || (!self.path.is_empty() && now_i >= next_path) {
                self.send_path(now);
                self.path_changed = false;
                next_path = now_i + Duration::from_secs(2);
            }
            if now_i >= next_status || stopping {
                self.send_status(now);
                next_status = now_i + Duration::from_secs(1);
            }
            if stopping {
                break;
            }
            next_poll += poll;
            let now_i = Instant::now();
            if next_poll > now_i {
                std::thread::sleep(next_poll - now_i);
            } else {
                next_poll = now_i;
            }
        }
        let mut report = std::mem::take(&mut self.report);
        report.run_s = started.elapsed().as_secs_f64();
        report.roadmap_samples = self.model.samples;
        report.roadmap_samples_missed = self.model.samples_missed;
        report.nodes_known = self.model.known_nodes() as u64;
        report.planner_nodes = self.model.total_nodes;
        report.trees = self.model.trees.len() as u64;
        report.solved = self.model.solved;
        if let Some(m) = self.mcap.take() {
            m.close().map_err(|source| ViewError::Recording {
                action: "finish",
                path: self.config.record.clone().unwrap_or_default(),
                source,
            })?;
        }
        if let Some(s) = self.server.take() {
            s.stop().wait_blocking();
        }
        drop(self.ctx);
        Ok(report)
    }
}
