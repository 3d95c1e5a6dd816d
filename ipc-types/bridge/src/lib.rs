//! `hrrtc-bridge`: one namespace's iceoryx2 services carried between hosts over Zenoh.
//!
//! iceoryx2 is host-local. To run the planner on another machine than the haptic arm, each
//! host runs a bridge of the same namespace, joined over Zenoh (TCP, explicit endpoints):
//!
//! | service | from | to | Zenoh key | semantics |
//! |---|---|---|---|---|
//! | `HapticState` blackboard | loop's host ([`Side::Loop`]) | planners' hosts ([`Side::Planner`]) | `hrrtc/<ns>/state` | every new tick (or at most `state_rate_hz`); on arrival written to the local blackboard, newest wins |
//! | `Guidance` | planners' hosts | loop's host | `hrrtc/<ns>/guidance` | every sample, then the guidance event wakes the loop's relay |
//! | `Path` | planners' hosts | loop's host | `hrrtc/<ns>/path` | every new path, and the newest again each second for a bridge that joins late |
//! | `Roadmap` | planners' hosts | loop's host | `hrrtc/<ns>/roadmap` | every increment (optional) |
//!
//! Nothing waits on the network: Zenoh publishers drop instead of blocking
//! (`CongestionControl::Drop`), received samples go through a bounded queue that drops
//! when full, and local ports are the non-blocking latest-value services the processes
//! already use, so the loop and the planner cannot tell a remote peer from a local one. The
//! loop's RT thread never touches Zenoh; the bridge is a separate, non-RT process.
//!
//! Every received sample is checked (frame size, kind, the type's own checks, see
//! [`frame`]) and re-stamped into local time ([`clock`]) before local processes see it;
//! rejected samples are counted and logged, never handed on.

pub mod clock;
pub mod frame;

use clock::{HostClock, PeerDelays};
use frame::{Carried, FrameError, FrameHeader, Kind};
use ipc_types::pacing;
use ipc_types::services::{self, ServiceError};
use ipc_types::{Guidance, HapticState, Path, Roadmap};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use zenoh::Wait;
use zenoh::qos::{CongestionControl, Priority};

/// Which host the bridge runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The haptic loop's host: sends the state, receives guidance, paths and roadmaps.
    Loop,
    /// A planner's host: receives the state, sends guidance, paths and roadmaps.
    Planner,
}

impl Side {
    /// `loop` or `planner`.
    pub fn name(self) -> &'static str {
        match self {
            Side::Loop => "loop",
            Side::Planner => "planner",
        }
    }
}

/// What a bridge process does.
#[derive(Debug, Clone)]
pub struct BridgeConfig {
    /// This host's role.
    pub side: Side,
    /// The iceoryx2 namespace bridged.
    pub namespace: String,
    /// The Zenoh key prefix is `hrrtc/<key_namespace>/`; `None`: the namespace. (Two
    /// bridges of one host on different namespaces can so be joined, e.g. to measure the
    /// bridge with one clock.)
    pub key_namespace: Option<String>,
    /// Zenoh endpoints to listen on, e.g. `tcp/0.0.0.0:7447`.
    pub listen: Vec<String>,
    /// Zenoh endpoints of the other bridges to connect to, e.g. `tcp/10.0.0.2:7447`.
    pub connect: Vec<String>,
    /// How long to try the `connect` endpoints at start before failing, s.
    pub connect_timeout_s: f64,
    /// Loop side: send at most this many states per second (`None`: every new tick).
    pub state_rate_hz: Option<f64>,
    /// Loop side: how often the state blackboard is polled, µs (the loop does not notify),
    /// until the bridge has locked onto a real-time loop's ticks (`ipc_types::pacing`), and
    /// for a loop without real-time rights.
    pub state_poll_us: u64,
    /// Carry roadmap increments (about 90 KB each, 20 per second per planner).
    pub roadmap: bool,
    /// The clock this bridge presents on the wire (real, or offset and drifting in tests).
    pub clock: HostClock,
    /// Round-trip probes per second.
    pub probe_hz: f64,
    /// Stop after this long, s (`None`: until the stop flag).
    pub duration_s: Option<f64>,
}

impl BridgeConfig {
    /// Defaults for `side` on `namespace` with no endpoints.
    pub fn new(side: Side, namespace: &str) -> Self {
        Self {
            side,
            namespace: namespace.to_owned(),
            key_namespace: None,
            listen: Vec::new(),
            connect: Vec::new(),
            connect_timeout_s: 10.0,
            state_rate_hz: None,
            state_poll_us: 100,
            roadmap: true,
            clock: HostClock::real(),
            probe_hz: 10.0,
            duration_s: None,
        }
    }
}

/// What can stop a bridge from starting.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// The namespace cannot name services.
    #[error("namespace: {0}")]
    Namespace(#[from] services::NamespaceError),
    /// A Zenoh endpoint does not parse.
    #[error("Zenoh endpoint '{endpoint}': {reason}")]
    Endpoint {
        /// As given.
        endpoint: String,
        /// What is wrong with it.
        reason: String,
    },
    /// Zenoh could not open the session: an endpoint cannot be listened on, or none of the
    /// `connect` endpoints answered in time.
    #[error("Zenoh session (listen {listen:?}, connect {connect:?}): {reason}")]
    Session {
        /// Listen endpoints.
        listen: Vec<String>,
        /// Connect endpoints.
        connect: Vec<String>,
        /// What Zenoh said.
        reason: String,
    },
    /// A Zenoh publisher or subscriber could not be declared.
    #[error("Zenoh key '{key}': {reason}")]
    Declare {
        /// The key expression.
        key: String,
        /// What Zenoh said.
        reason: String,
    },
    /// An iceoryx2 node, service or port could not be opened.
    #[error(transparent)]
    Ipc(#[from] ServiceError),
    /// A bad setting.
    #[error("{0}")]
    Config(String),
    /// A thread could not be started.
    #[error("cannot start the bridge's {thread} thread: {reason}")]
    Thread {
        /// Which.
        thread: &'static str,
        /// Why.
        reason: String,
    },
}

/// Counts per frame kind (indexed by `Kind.0`).
#[derive(Debug, Default)]
struct Counters {
    sent: [AtomicU64; 7],
    received: [AtomicU64; 7],
    delivered: [AtomicU64; 7],
    rejected: [AtomicU64; 7],
    dropped: [AtomicU64; 7],
}

fn bump(counter: &[AtomicU64; 7], kind: Kind) {
    if let Some(c) = counter.get(kind.0 as usize) {
        c.fetch_add(1, Ordering::Relaxed);
    }
}

/// What one kind of sample did in a bridge.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct KindReport {
    /// Put on Zenoh.
    pub sent: u64,
    /// Arrived from Zenoh.
    pub received: u64,
    /// Handed to local processes.
    pub delivered: u64,
    /// Arrived malformed, oversized or invalid: never handed on.
    pub rejected: u64,
    /// Lost to a full queue or a failed local send (never waited for).
    pub dropped: u64,
}

/// What a bridge did, at its end.
#[derive(Debug, Clone, Default)]
pub struct BridgeReport {
    /// `(kind name, counts)` for state, guidance, path, roadmap.
    pub kinds: Vec<(&'static str, KindReport)>,
    /// Peer bridges whose probes came back.
    pub peers: usize,
    /// Smallest round trip to any peer, µs.
    pub min_rtt_us: Option<f64>,
    /// Seconds run.
    pub seconds: f64,
}

impl BridgeReport {
    /// The counts of `kind` (`state`, `guidance`, `path`, `roadmap`).
    pub fn kind(&self, kind: &str) -> KindReport {
        self.kinds
            .iter()
            .find(|(k, _)| *k == kind)
            .map_or_else(KindReport::default, |(_, r)| *r)
    }
}

/// Zenoh key of `leaf` on `namespace`.
pub fn key(namespace: &str, leaf: &str) -> String {
    format!("hrrtc/{namespace}/{leaf}")
}

/// A frame received from Zenoh, waiting for the import thread.
struct Incoming {
    bytes: Vec<u8>,
    arrival_ns: u64,
}

impl Incoming {
    /// A sample as it arrives in a Zenoh callback: stamped first, then copied out.
    fn arrived(sample: &zenoh::sample::Sample) -> Self {
        let arrival_ns = ipc_types::monotonic_ns();
        Incoming {
            bytes: sample.payload().to_bytes().into_owned(),
            arrival_ns,
        }
    }
}

/// Samples queued between Zenoh's threads and the import thread; beyond this they are
/// dropped (counted): a burst after a stall is old news.
const IMPORT_QUEUE: usize = 256;

/// Runs a bridge until `stop` is set (or `config.duration_s` passes).
pub fn run(config: &BridgeConfig, stop: Arc<AtomicBool>) -> Result<BridgeReport, BridgeError> {
    run_inner(config, stop, None)
}

/// Runs the planner side of a bridge inside a planner's process, until `stop` is set: as
/// [`run`] with [`Side::Planner`], except that the planner puts its own guidance on Zenoh
/// with the [`GuidanceSender`] handed to `sender` once the session is up (so no bridge
/// thread has to be woken between the planner and the network), and the export thread
/// leaves the guidance this process publishes locally alone. Guidance of other processes
/// on this host, paths and roadmaps go as through [`run`].
pub fn run_in_planner(
    config: &BridgeConfig,
    stop: Arc<AtomicBool>,
    sender: std::sync::mpsc::Sender<GuidanceSender>,
) -> Result<BridgeReport, BridgeError> {
    if config.side != Side::Planner {
        return Err(BridgeError::Config(
            "a bridge inside a planner's process must be the planner side".into(),
        ));
    }
    run_inner(config, stop, Some(sender))
}

/// Puts a planner's guidance on Zenoh from the planner's own thread ([`run_in_planner`]).
#[derive(Clone)]
pub struct GuidanceSender {
    publisher: Arc<zenoh::pubsub::Publisher<'static>>,
    clock: HostClock,
    id: u64,
    counters: Arc<Counters>,
}

impl GuidanceSender {
    /// Sends `g` (re-stamped into the presented clock) to the loop's host; never waits on
    /// the network: a sample Zenoh cannot take at once is dropped and counted. `false` if
    /// it was dropped.
    pub fn send(&self, g: &Guidance) -> bool {
        let sent = self
            .publisher
            .put(outgoing(*g, &self.clock, self.id))
            .wait()
            .is_ok();
        let counter = if sent {
            &self.counters.sent
        } else {
            &self.counters.dropped
        };
        bump(counter, Kind::GUIDANCE);
        sent
    }
}

/// `v` framed for the wire, its stamps in the presented clock.
fn outgoing<T: Carried>(mut v: T, clock: &HostClock, id: u64) -> Vec<u8> {
    v.restamp(|t| clock.at(t));
    frame::encode(id, clock.now(), &v)
}

/// A publisher for `leaf`: newest wins, so it drops rather than queue behind a slow link,
/// and skips Zenoh's batching for the small, frequent samples.
fn declare_publisher(
    session: &zenoh::Session,
    keys: &str,
    leaf: &str,
) -> Result<zenoh::pubsub::Publisher<'static>, BridgeError> {
    let k = key(keys, leaf);
    session
        .declare_publisher(k.clone())
        .congestion_control(CongestionControl::Drop)
        .priority(Priority::InteractiveHigh)
        .express(leaf != "roadmap")
        .wait()
        .map_err(declare_error(&k))
}

fn run_inner(
    config: &BridgeConfig,
    stop: Arc<AtomicBool>,
    guidance_sender: Option<std::sync::mpsc::Sender<GuidanceSender>>,
) -> Result<BridgeReport, BridgeError> {
    services::validate_namespace(&config.namespace)?;
    if let Some(k) = &config.key_namespace {
        services::validate_namespace(k)?;
    }
    for e in config.listen.iter().chain(&config.connect) {
        e.parse::<zenoh::config::EndPoint>()
            .map_err(|err| BridgeError::Endpoint {
                endpoint: e.clone(),
                reason: err.to_string(),
            })?;
    }
    if let Some(r) = config.state_rate_hz
        && !(r.is_finite() && r > 0.0)
    {
        return Err(BridgeError::Config(format!(
            "state rate {r} Hz: must be a positive number"
        )));
    }
    if !(config.probe_hz.is_finite() && config.probe_hz > 0.0) {
        return Err(BridgeError::Config(format!(
            "probe rate {} Hz: must be a positive number",
            config.probe_hz
        )));
    }
    let started = Instant::now();
    let session = open_session(config)?;
    let id = session_id(&session);
    let counters = Arc::new(Counters::default());
    let delays = Arc::new(Mutex::new(PeerDelays::default()));
    let clock = config.clock;
    let ns = config.key_namespace.as_ref().unwrap_or(&config.namespace);

    // Probes: answer others' pings at once (on Zenoh's thread), time our own.
    let pong_key = key(ns, "bridge/pong");
    let ping_sub = {
        let replier = session.clone();
        let pong_key = pong_key.clone();
        session
            .declare_subscriber(key(ns, "bridge/ping"))
            .callback(move |sample| {
                let bytes = sample.payload().to_bytes();
                if let Ok((h, _)) = frame::decode_raw(&bytes)
                    && h.kind == Kind::PING
                    && h.sender != id
                {
                    let pong = frame::encode_raw(
                        FrameHeader {
                            kind: Kind::PONG,
                            ..h
                        },
                        &id.to_le_bytes(),
                    );
                    let _ = replier.put(&pong_key, pong).wait();
                }
            })
            .wait()
            .map_err(declare_error(&key(ns, "bridge/ping")))?
    };
    let pong_sub = {
        let delays = delays.clone();
        session
            .declare_subscriber(&pong_key)
            .callback(move |sample| {
                let now = clock.now();
                let bytes = sample.payload().to_bytes();
                if let Ok((h, payload)) = frame::decode_raw(&bytes)
                    && h.kind == Kind::PONG
                    && h.sender == id
                    && let Ok(peer) = <[u8; 8]>::try_from(payload)
                {
                    let rtt = now.wrapping_sub(h.sent_ns);
                    // A reply to a probe of a previous life of this id would be absurd.
                    if rtt < 10_000_000_000 {
                        lock(&delays).record(u64::from_le_bytes(peer), rtt);
                    }
                }
            })
            .wait()
            .map_err(declare_error(&pong_key))?
    };

    // Guidance on the loop's host goes to the loop's relay from Zenoh's own callback, through
    // thread-safe ports of the same services: no second thread to wake on the latency path.
    let direct_guidance = match config.side {
        Side::Loop => Some(direct_guidance(
            config,
            ns,
            counters.clone(),
            delays.clone(),
            &session,
        )?),
        Side::Planner => None,
    };
    // Likewise the state on the planner's host goes into the local blackboard from Zenoh's
    // callback (the blackboard's writer is `Send`; a mutex makes it shareable): no import
    // thread to wake between the network and the planner's reader.
    let state_node = match config.side {
        Side::Planner => Some(services::create_node(&format!(
            "bridge_state_{}",
            std::process::id()
        ))?),
        Side::Loop => None,
    };
    let direct_state = match &state_node {
        Some((node, _)) => Some(direct_state(
            config,
            node,
            ns,
            counters.clone(),
            delays.clone(),
            &session,
        )?),
        None => None,
    };
    // The other received samples: Zenoh's threads queue them for the import thread, which
    // owns those iceoryx2 ports (they are not `Send`).
    let (tx, rx) = std::sync::mpsc::sync_channel::<Incoming>(IMPORT_QUEUE);
    let imported: &[&str] = match config.side {
        Side::Loop if config.roadmap => &["path", "roadmap"],
        Side::Loop => &["path"],
        Side::Planner => &[],
    };
    let mut import_subs = Vec::new();
    for leaf in imported {
        let k = key(ns, leaf);
        let tx: SyncSender<Incoming> = tx.clone();
        let counters = counters.clone();
        let sub = session
            .declare_subscriber(&k)
            .callback(move |sample| {
                let incoming = Incoming::arrived(&sample);
                let kind = frame::decode_raw(&incoming.bytes).map_or(Kind(0), |(h, _)| h.kind);
                match tx.try_send(incoming) {
                    Ok(()) => {}
                    Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => {
                        bump(&counters.dropped, kind)
                    }
                }
            })
            .wait()
            .map_err(declare_error(&k))?;
        import_subs.push(sub);
    }
    drop(tx);

    let (ready_tx, ready_rx) = std::sync::mpsc::channel::<Result<(), BridgeError>>();
    let import = {
        let stop = stop.clone();
        let counters = counters.clone();
        let delays = delays.clone();
        let config = config.clone();
        let ready = ready_tx.clone();
        spawn("import", move || {
            import_thread(&config, rx, &counters, &delays, &stop, ready)
        })?
    };
    let own_guidance_direct = guidance_sender.is_some();
    let export = {
        let stop = stop.clone();
        let counters = counters.clone();
        let config = config.clone();
        let session = session.clone();
        let ready = ready_tx;
        spawn("export", move || {
            export_thread(
                &config,
                &session,
                id,
                &counters,
                &stop,
                own_guidance_direct,
                ready,
            )
        })?
    };
    // Both threads report whether their ports opened.
    let mut setup = Ok(());
    for _ in 0..2 {
        match ready_rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => setup = Err(e),
            Err(_) => {
                setup = Err(BridgeError::Thread {
                    thread: "import/export",
                    reason: "it died during set-up".into(),
                })
            }
        }
    }
    if setup.is_ok()
        && let Some(out) = guidance_sender
    {
        match declare_publisher(&session, ns, "guidance") {
            Ok(p) => {
                let _ = out.send(GuidanceSender {
                    publisher: Arc::new(p),
                    clock,
                    id,
                    counters: counters.clone(),
                });
            }
            Err(e) => setup = Err(e),
        }
    }
    if setup.is_ok() {
        tracing::info!(
            "bridge {id:016x} ({} side) on namespace '{}', keys hrrtc/{ns}/: listening on {:?}, connected to {:?}",
            config.side.name(),
            config.namespace,
            config.listen,
            config.connect
        );
    }
    let mut next_log = Instant::now() + Duration::from_secs(5);
    while setup.is_ok() && !stop.load(Ordering::Acquire) {
        if config
            .duration_s
            .is_some_and(|d| started.elapsed().as_secs_f64() >= d)
        {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
        if Instant::now() >= next_log {
            next_log += Duration::from_secs(5);
            log_progress(&report(&counters, &delays, started));
        }
    }
    stop.store(true, Ordering::Release);
    let _ = import.join();
    let _ = export.join();
    drop(import_subs);
    drop(direct_guidance);
    // The subscriber first, then the writer its callback held, then the writer's node.
    drop(direct_state);
    drop(state_node);
    drop(ping_sub);
    drop(pong_sub);
    let _ = session.close().wait();
    setup?;
    Ok(report(&counters, &delays, started))
}

/// The loop side's guidance path: a Zenoh subscriber whose callback checks, re-stamps and
/// sends each sample to the local guidance service and notifies the relay. Dropping the
/// returned pair undeclares the subscriber, then closes the ports.
fn direct_guidance(
    config: &BridgeConfig,
    keys: &str,
    counters: Arc<Counters>,
    delays: Arc<Mutex<PeerDelays>>,
    session: &zenoh::Session,
) -> Result<(zenoh::pubsub::Subscriber<()>, Arc<GuidancePorts>), BridgeError> {
    let (node, _) = services::create_node_in::<services::IpcThreadsafe>(&format!(
        "bridge_guidance_{}",
        std::process::id()
    ))?;
    let ports = Arc::new(GuidancePorts {
        publisher: services::publisher_in::<services::IpcThreadsafe, Guidance>(
            &node,
            &config.namespace,
        )?,
        notifier: services::guidance_notifier_in::<services::IpcThreadsafe>(
            &node,
            &config.namespace,
        )?,
        last_warning: Mutex::new(None),
        _node: node,
    });
    let k = key(keys, "guidance");
    let out = ports.clone();
    let sub = session
        .declare_subscriber(&k)
        .callback(move |sample| {
            let incoming = Incoming::arrived(&sample);
            bump(&counters.received, Kind::GUIDANCE);
            let mut warned = lock(&out.last_warning);
            if let Some((_, g)) = accept::<Guidance>(&incoming, &counters, &delays, &mut warned) {
                if out.publisher.send_copy(g).is_ok() {
                    bump(&counters.delivered, Kind::GUIDANCE);
                } else {
                    bump(&counters.dropped, Kind::GUIDANCE);
                }
                // The relay also polls: a failed wake-up costs only latency.
                let _ = out.notifier.notify();
            }
        })
        .wait()
        .map_err(declare_error(&k))?;
    Ok((sub, ports))
}

/// The planner side's state path: a Zenoh subscriber whose callback checks and re-stamps
/// each sample and writes it to the local `HapticState` blackboard as its writer (the pid
/// is this bridge's: readers check the writer's liveness by it). Dropping the subscriber
/// drops the writer; `node` must outlive both.
fn direct_state(
    config: &BridgeConfig,
    node: &iceoryx2::node::Node<services::Ipc>,
    keys: &str,
    counters: Arc<Counters>,
    delays: Arc<Mutex<PeerDelays>>,
    session: &zenoh::Session,
) -> Result<zenoh::pubsub::Subscriber<()>, BridgeError> {
    let writer = Mutex::new(services::state_writer(node, &config.namespace)?);
    let warned = Mutex::new(None);
    let pid = std::process::id();
    let k = key(keys, "state");
    session
        .declare_subscriber(&k)
        .callback(move |sample| {
            let incoming = Incoming::arrived(&sample);
            bump(&counters.received, Kind::STATE);
            if let Some((_, mut s)) =
                accept::<HapticState>(&incoming, &counters, &delays, &mut lock(&warned))
            {
                s.header.writer_pid = pid;
                lock(&writer).update_with_copy(s);
                bump(&counters.delivered, Kind::STATE);
            }
        })
        .wait()
        .map_err(declare_error(&k))
}

/// The loop side's guidance ports, shared with Zenoh's callback threads.
struct GuidancePorts {
    publisher: iceoryx2::port::publisher::Publisher<services::IpcThreadsafe, Guidance, ()>,
    notifier: iceoryx2::port::notifier::Notifier<services::IpcThreadsafe>,
    last_warning: Mutex<Option<Instant>>,
    _node: iceoryx2::node::Node<services::IpcThreadsafe>,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

fn spawn(
    thread: &'static str,
    f: impl FnOnce() + Send + 'static,
) -> Result<std::thread::JoinHandle<()>, BridgeError> {
    std::thread::Builder::new()
        .name(format!("bridge-{thread}"))
        .spawn(f)
        .map_err(|e| BridgeError::Thread {
            thread,
            reason: e.to_string(),
        })
}

fn declare_error(key: &str) -> impl FnOnce(zenoh::Error) -> BridgeError + '_ {
    move |e| BridgeError::Declare {
        key: key.to_owned(),
        reason: e.to_string(),
    }
}

/// A JSON list of strings (endpoints parse as EndPoints, so they hold no quote).
fn json_list(items: &[String]) -> String {
    let quoted: Vec<String> = items.iter().map(|s| format!("\"{s}\"")).collect();
    format!("[{}]", quoted.join(","))
}

fn open_session(config: &BridgeConfig) -> Result<zenoh::Session, BridgeError> {
    let session_error = |reason: String| BridgeError::Session {
        listen: config.listen.clone(),
        connect: config.connect.clone(),
        reason,
    };
    let mut z = zenoh::Config::default();
    let timeout_ms = (config.connect_timeout_s * 1e3).round() as i64;
    let settings = [
        ("mode", "\"peer\"".to_owned()),
        // Explicit endpoints only: nothing is found by multicast, which many networks
        // (and network namespaces) do not carry.
        ("scouting/multicast/enabled", "false".to_owned()),
        ("listen/endpoints", json_list(&config.listen)),
        ("connect/endpoints", json_list(&config.connect)),
        ("connect/timeout_ms", timeout_ms.to_string()),
        ("connect/exit_on_failure", "true".to_owned()),
        // Reconnect quickly after the link drops (the default backs off to 4 s).
        (
            "connect/retry",
            "{period_init_ms: 100, period_max_ms: 1000, period_increase_factor: 2}".to_owned(),
        ),
    ];
    for (k, v) in settings {
        z.insert_json5(k, &v)
            .map_err(|e| session_error(format!("setting {k} = {v}: {e}")))?;
    }
    zenoh::open(z)
        .wait()
        .map_err(|e| session_error(e.to_string()))
}

/// A random id for this bridge's frames: the low 64 bits of its Zenoh session id (random
/// per session).
fn session_id(session: &zenoh::Session) -> u64 {
    let zid = session.zid().to_le_bytes();
    let mut low = [0u8; 8];
    low.copy_from_slice(&zid[..8]);
    u64::from_le_bytes(low).max(1)
}

fn report(counters: &Counters, delays: &Mutex<PeerDelays>, started: Instant) -> BridgeReport {
    let kinds = [Kind::STATE, Kind::GUIDANCE, Kind::PATH, Kind::ROADMAP]
        .into_iter()
        .map(|k| {
            let i = k.0 as usize;
            let get = |c: &[AtomicU64; 7]| c[i].load(Ordering::Relaxed);
            (
                k.name(),
                KindReport {
                    sent: get(&counters.sent),
                    received: get(&counters.received),
                    delivered: get(&counters.delivered),
                    rejected: get(&counters.rejected),
                    dropped: get(&counters.dropped),
                },
            )
        })
        .collect();
    let d = lock(delays);
    let min_rtt_us = d.min_rtt_overall_ns().map(|r| r as f64 / 1e3);
    BridgeReport {
        kinds,
        peers: d.peers(),
        min_rtt_us,
        seconds: started.elapsed().as_secs_f64(),
    }
}

fn log_progress(r: &BridgeReport) {
    let parts: Vec<String> = r
        .kinds
        .iter()
        .filter(|(_, k)| k.sent + k.received > 0)
        .map(|(name, k)| {
            format!(
                "{name}: {} sent, {} received, {} delivered, {} rejected, {} dropped",
                k.sent, k.received, k.delivered, k.rejected, k.dropped
            )
        })
        .collect();
    let rtt = r.min_rtt_us.map_or("no peer answered yet".to_owned(), |v| {
        format!("{} peer(s), round trip ≥ {v:.0} µs", r.peers)
    });
    tracing::info!("{}; {rtt}", parts.join("; "));
}

/// Re-stamps `value` from the sender's clock into ours and checks it was not stamped in
/// the sender's future (beyond 100 ms of slack, the loop's own limit).
fn to_local_time<T: Carried>(
    value: &mut T,
    header: &FrameHeader,
    arrival_ns: u64,
    delays: &Mutex<PeerDelays>,
) -> Result<(), FrameError> {
    const MAX_FUTURE_NS: i64 = 100_000_000;
    if clock::age_at_send_ns(value.stamp(), header.sent_ns) < -MAX_FUTURE_NS {
        return Err(FrameError::Invalid {
            kind: T::KIND.name(),
            reason: "stamped more than 100 ms after it was sent".into(),
        });
    }
    let one_way = lock(delays).one_way_ns(header.sender);
    let sent = header.sent_ns;
    value.restamp(|t| clock::to_local(t, sent, arrival_ns, one_way));
    Ok(())
}

/// Decodes one frame into a `T` in local time, counting a rejection (logged at most once a
/// second per kind, so a flood cannot flood the log).
fn accept<T: Carried>(
    incoming: &Incoming,
    counters: &Counters,
    delays: &Mutex<PeerDelays>,
    last_warning: &mut Option<Instant>,
) -> Option<(FrameHeader, T)> {
    let result = frame::decode::<T>(&incoming.bytes).and_then(|(h, mut v)| {
        to_local_time(&mut v, &h, incoming.arrival_ns, delays)?;
        Ok((h, v))
    });
    match result {
        Ok(ok) => Some(ok),
        Err(e) => {
            bump(&counters.rejected, T::KIND);
            if last_warning.is_none_or(|t| t.elapsed() >= Duration::from_secs(1)) {
                tracing::warn!("rejected a {} sample from the network: {e}", T::KIND.name());
                *last_warning = Some(Instant::now());
            }
            None
        }
    }
}

/// The import thread's local ports (one of each per bridge: their size does not matter).
#[allow(clippy::large_enum_variant)]
enum LocalOut {
    Loop {
        path: services::Publisher<Path>,
        roadmap: Option<services::Publisher<Roadmap>>,
    },
    /// The planner side: nothing arrives through the queue.
    Nothing,
}

fn import_thread(
    config: &BridgeConfig,
    rx: Receiver<Incoming>,
    counters: &Counters,
    delays: &Mutex<PeerDelays>,
    stop: &AtomicBool,
    ready: std::sync::mpsc::Sender<Result<(), BridgeError>>,
) {
    let ns = &config.namespace;
    let opened = (|| -> Result<(iceoryx2::node::Node<services::Ipc>, LocalOut), BridgeError> {
        let (node, _) = services::create_node(&format!("bridge_in_{}", std::process::id()))?;
        let out = match config.side {
            Side::Loop => LocalOut::Loop {
                path: services::publisher::<Path>(&node, ns)?,
                roadmap: if config.roadmap {
                    Some(services::publisher::<Roadmap>(&node, ns)?)
                } else {
                    None
                },
            },
            // Its state goes straight from Zenoh's callback ([`direct_state`]).
            Side::Planner => LocalOut::Nothing,
        };
        Ok((node, out))
    })();
    let (_node, out) = match opened {
        Ok(o) => {
            let _ = ready.send(Ok(()));
            o
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return;
        }
    };
    let mut warned: [Option<Instant>; 7] = [None; 7];
    // Paths are re-sent each second: hand each one on once.
    let mut last_path: Option<(u64, u32, u64)> = None;
    while !stop.load(Ordering::Acquire) {
        let incoming = match rx.recv_timeout(Duration::from_millis(50)) {
            Ok(i) => i,
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => continue,
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break,
        };
        let kind = frame::decode_raw(&incoming.bytes).map_or(Kind(0), |(h, _)| h.kind);
        bump(&counters.received, kind);
        let warn = &mut warned[(kind.0 as usize).min(6)];
        let delivered = match &out {
            LocalOut::Nothing => None,
            LocalOut::Loop { path, roadmap } => match kind {
                Kind::PATH => {
                    accept::<Path>(&incoming, counters, delays, warn).and_then(|(h, p)| {
                        let id = (h.sender, p.header.writer_pid, p.header.sequence);
                        if last_path == Some(id) {
                            return None;
                        }
                        last_path = Some(id);
                        path.send_copy(p).is_ok().then_some(Kind::PATH)
                    })
                }
                Kind::ROADMAP => roadmap.as_ref().and_then(|rp| {
                    accept::<Roadmap>(&incoming, counters, delays, warn)
                        .and_then(|(_, r)| rp.send_copy(r).is_ok().then_some(Kind::ROADMAP))
                }),
                _ => {
                    // Not a frame of a key this side reads: count it as rejected.
                    let _ = accept::<Guidance>(&incoming, counters, delays, warn);
                    None
                }
            },
        };
        if let Some(k) = delivered {
            bump(&counters.delivered, k);
        }
    }
}

/// The export thread's local ports (one per bridge: their size does not matter).
#[allow(clippy::large_enum_variant)]
enum LocalIn {
    Loop {
        state: services::StateFollower,
    },
    Planner {
        listener: services::GuidanceListener,
        guidance: services::Subscriber<Guidance>,
        path: services::Subscriber<Path>,
        roadmap: Option<services::Subscriber<Roadmap>>,
    },
}

fn export_thread(
    config: &BridgeConfig,
    session: &zenoh::Session,
    id: u64,
    counters: &Counters,
    stop: &AtomicBool,
    own_guidance_direct: bool,
    ready: std::sync::mpsc::Sender<Result<(), BridgeError>>,
) {
    let ns = &config.namespace;
    let keys = config.key_namespace.as_ref().unwrap_or(ns);
    let opened = (|| -> Result<_, BridgeError> {
        let (node, _) = services::create_node(&format!("bridge_out_{}", std::process::id()))?;
        let input = match config.side {
            Side::Loop => LocalIn::Loop {
                state: services::StateFollower::open(&node, ns)?,
            },
            Side::Planner => LocalIn::Planner {
                listener: services::guidance_listener(&node, ns)?,
                guidance: services::subscriber::<Guidance>(&node, ns)?,
                path: services::subscriber::<Path>(&node, ns)?,
                roadmap: if config.roadmap {
                    Some(services::subscriber::<Roadmap>(&node, ns)?)
                } else {
                    None
                },
            },
        };
        let exported: &[&str] = match config.side {
            Side::Loop => &["state"],
            Side::Planner => &["guidance", "path", "roadmap"],
        };
        let mut publishers = Vec::new();
        for leaf in exported {
            publishers.push(declare_publisher(session, keys, leaf)?);
        }
        let ping = session
            .declare_publisher(key(keys, "bridge/ping"))
            .congestion_control(CongestionControl::Drop)
            .express(true)
            .wait()
            .map_err(declare_error(&key(keys, "bridge/ping")))?;
        Ok((node, input, publishers, ping))
    })();
    let (_node, mut input, publishers, ping) = match opened {
        Ok(o) => {
            let _ = ready.send(Ok(()));
            o
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return;
        }
    };
    let clock = config.clock;
    let put = |publisher: &zenoh::pubsub::Publisher<'_>, bytes: Vec<u8>, kind: Kind| match publisher
        .put(bytes)
        .wait()
    {
        Ok(()) => bump(&counters.sent, kind),
        Err(_) => bump(&counters.dropped, kind),
    };
    let probe_period = Duration::from_secs_f64(1.0 / config.probe_hz);
    let mut next_probe = Instant::now();
    let state_period_ns = config.state_rate_hz.map_or(0, |r| (1e9 / r) as u64);
    let poll_ns = config.state_poll_us.max(10) * 1_000;
    let mut last_seq = 0u64;
    let mut last_pid = 0u32;
    let mut last_sent_ns = 0u64;
    let mut newest_path: Option<Path> = None;
    let mut next_path_resend = Instant::now();
    if !ipc_types::set_thread_timer_slack_ns(1_000) {
        tracing::debug!("cannot set the export thread's timer slack");
    }
    let mut next_poll = ipc_types::monotonic_ns();
    let mut paced = false;
    let mut pacer = pacing::StatePacer::sleeping(poll_ns);
    while !stop.load(Ordering::Acquire) {
        match &mut input {
            LocalIn::Loop { state } => {
                let s = state.get();
                let new = s.header.sequence != 0
                    && (s.header.sequence != last_seq || s.header.writer_pid != last_pid);
                if let Err(e) = state.after_read(new) {
                    tracing::warn!("cannot follow a restarted haptic loop: {e}");
                }
                if new && s.header.writer_pid != last_pid {
                    // Phase-lock to a real-time loop's ticks (as the planner's receiver
                    // does); a loop without real-time rights ticks late and in bursts, and
                    // is polled.
                    paced = pacing::phase_lock_to(s.header.writer_pid);
                    pacer = pacing::StatePacer::sleeping(poll_ns);
                }
                let now = ipc_types::monotonic_ns();
                if new && now.wrapping_sub(last_sent_ns) >= state_period_ns {
                    put(&publishers[0], outgoing(s, &clock, id), Kind::STATE);
                    last_sent_ns = now;
                }
                if new {
                    last_seq = s.header.sequence;
                    last_pid = s.header.writer_pid;
                }
                let next = if paced {
                    let seen = if new {
                        pacing::Seen::Found {
                            sequence: s.header.sequence,
                            stamp_ns: s.header.timestamp_ns,
                        }
                    } else {
                        pacing::Seen::Nothing
                    };
                    pacer.next_poll(ipc_types::monotonic_ns(), seen)
                } else {
                    next_poll += poll_ns;
                    if next_poll < now {
                        next_poll = now + poll_ns;
                    }
                    next_poll
                };
                ipc_types::sleep_until_ns(next);
            }
            LocalIn::Planner {
                listener,
                guidance,
                path,
                roadmap,
            } => {
                // Woken by the planner's notification after each guidance sample, else
                // after a millisecond for paths and roadmaps.
                if listener
                    .timed_wait(|_| {}, Duration::from_millis(1))
                    .is_err()
                {
                    std::thread::sleep(Duration::from_millis(1));
                }
                let own_pid = std::process::id();
                while let Ok(Some(g)) = guidance.receive() {
                    // The planner in this process has put its own on Zenoh already.
                    if own_guidance_direct && g.header.writer_pid == own_pid {
                        continue;
                    }
                    put(&publishers[0], outgoing(*g, &clock, id), Kind::GUIDANCE);
                }
                while let Ok(Some(p)) = path.receive() {
                    put(&publishers[1], outgoing(*p, &clock, id), Kind::PATH);
                    newest_path = Some(*p);
                    next_path_resend = Instant::now() + Duration::from_secs(1);
                }
                if let Some(p) = &newest_path
                    && Instant::now() >= next_path_resend
                {
                    put(&publishers[1], outgoing(*p, &clock, id), Kind::PATH);
                    next_path_resend = Instant::now() + Duration::from_secs(1);
                }
                if let Some(rm) = roadmap {
                    while let Ok(Some(r)) = rm.receive() {
                        put(&publishers[2], outgoing(*r, &clock, id), Kind::ROADMAP);
                    }
                }
            }
        }
        if Instant::now() >= next_probe {
            next_probe += probe_period;
            let probe = frame::encode_raw(
                FrameHeader {
                    kind: Kind::PING,
                    sender: id,
                    sent_ns: clock.now(),
                },
                &[],
            );
            let _ = ping.put(probe).wait();
        }
    }
}
