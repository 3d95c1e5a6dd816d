//! The service catalogue: names, their semantics and quality of service, and the one place
//! every process opens them. The generational protocol of the state blackboard is in
//! [`state`].
//!
//! | service | pattern | writer | semantics |
//! |---|---|---|---|
//! | [`HAPTIC_STATE`]`/<generation>` | blackboard, one entry | haptic loop (RT thread) | latest value; never blocks, never allocates; a loop restarted after a crash writes a new generation, readers follow the newest ([`state::newest_state_generation`]) |
//! | [`GUIDANCE`] | publish-subscribe | planner | history 1, safe overflow: latest value; a restarted planner simply publishes again |
//! | [`GUIDANCE_EVENT`] | event | planner | "a guidance sample was sent": wakes the loop's relay thread (non-RT); the relay also polls, so a lost or absent notification costs only latency |
//! | [`PATH`] | publish-subscribe | planner | history 1, safe overflow: late subscribers get the newest path; the planner never blocks |
//! | [`ROADMAP`] | publish-subscribe | planner | no history, [`ROADMAP_SUBSCRIBER_BUFFER`] samples, safe overflow: increments; a slow or late viewer catches up from the rolling window (see [`crate::Roadmap`]); the planner never blocks |
//! | [`DRIVER_STATE`] | publish-subscribe | external device driver | history 1, safe overflow: latest value; a restarted driver simply publishes again |
//! | [`DRIVER_COMMAND`] | publish-subscribe | haptic loop (external driver's relay thread) | history 1, safe overflow: latest value; the driver zeroes force when it goes stale |
//!
//! The driver pair is publish-subscribe for the same reason as guidance: either side may
//! die and restart. On the loop's side a non-RT relay thread receives and sends and talks
//! to the RT thread through triple buffers, adding at most its poll period (250 µs by
//! default) in each direction.
//!
//! Why a blackboard for the state: iceoryx2 0.10 `Publisher::loan_uninit()` and `send_copy()`
//! allocate one `Arc` per sample, and `Notifier::notify()` rebuilds its connection list
//! (allocating) when a listener joins. A blackboard entry is a lock-free single-writer,
//! multi-reader cell in shared memory: `update_with_copy()` and `get()` touch only that
//! memory, whatever the other process does. The price is latest-value semantics and no
//! wake-up: a reader that wants every tick polls once per tick just after each write (the
//! planner locks onto the stamps' tick grid) and uses `header.sequence` to count what it
//! skipped.
//!
//! Why not a blackboard for guidance: the writer of a blackboard entry holds a producer flag
//! in shared memory that iceoryx2 0.10 does not release when the writer's process dies, so a
//! planner restarted after `kill -9` could never write again. Guidance therefore goes over
//! publish-subscribe; the haptic loop receives it on a non-RT relay thread (where
//! `receive()` may allocate while it reconnects to a new planner) and hands the newest
//! sample to the RT thread through an in-process triple buffer.
//!
//! Service names are `hrrtc/<namespace>/<leaf>`; the namespace lets tests and several
//! independent setups share a host.

pub mod state;

pub use state::{
    GENERATION_CHECK, StateFollower, newest_state_generation, state_reader,
    state_reader_generation, state_writer,
};

use crate::{DriverCommand, DriverState, Guidance, HapticState, Path, Roadmap};
use iceoryx2::port::reader::EntryHandle;
use iceoryx2::port::writer::EntryHandleMut;
use iceoryx2::prelude::*;

/// Leaf name of the event the planner notifies after each [`GUIDANCE`] sample, which wakes
/// the loop's non-RT relay thread at once instead of at its next poll.
pub const GUIDANCE_EVENT: &str = "guidance_event";
/// Leaf name of the [`HapticState`] blackboard (one per generation, see [`state`]).
pub const HAPTIC_STATE: &str = "haptic_state";
/// Leaf name of the [`Guidance`] publish-subscribe service (planner → loop).
pub const GUIDANCE: &str = "guidance";
/// Leaf name of the [`Path`] publish-subscribe service.
pub const PATH: &str = "path";
/// Leaf name of the [`Roadmap`] publish-subscribe service (planner → viewers).
pub const ROADMAP: &str = "roadmap";
/// Leaf name of the [`crate::DriverState`] service (driver → loop).
pub const DRIVER_STATE: &str = "driver/state";
/// Leaf name of the [`crate::DriverCommand`] service (loop → driver).
pub const DRIVER_COMMAND: &str = "driver/command";
/// The single key of each blackboard.
pub const ENTRY_KEY: u64 = 0;
/// Namespace used when none is given.
pub const DEFAULT_NAMESPACE: &str = "default";
/// Most readers per blackboard (loop, planner, viewers, recorders, benchmarks).
pub const MAX_READERS: usize = 16;
/// Most nodes that may open one service.
pub const MAX_NODES: usize = 32;
/// Subscriber buffer of the latest-value services ([`GUIDANCE`], [`PATH`], the driver
/// pair): only the newest sample matters.
pub const LATEST_SUBSCRIBER_BUFFER: usize = 2;
/// Most publishers of a latest-value service: a planner (or driver) and its restarted
/// successor while the dead one's port is not yet cleaned up.
pub const MAX_PLANNER_PUBLISHERS: usize = 4;

/// Subscriber buffer of [`ROADMAP`]: half a second of increments at 20 Hz; a viewer that
/// falls further behind loses the oldest and catches up from the rolling window.
pub const ROADMAP_SUBSCRIBER_BUFFER: usize = 10;
/// Most subscribers of [`ROADMAP`] (viewers and recorders). Each one costs the planner's
/// shared memory `ROADMAP_SUBSCRIBER_BUFFER` samples of 90 KB.
pub const ROADMAP_MAX_SUBSCRIBERS: usize = 4;

/// The iceoryx2 transport every process uses.
pub type Ipc = ipc::Service;
/// Read handle of the [`HAPTIC_STATE`] entry.
pub type StateReader = EntryHandle<Ipc, u64, HapticState>;
/// Write handle of the [`HAPTIC_STATE`] entry.
pub type StateWriter = EntryHandleMut<Ipc, u64, HapticState>;
/// Publisher of the service that carries `T` (see [`Topic`]).
pub type Publisher<T> = iceoryx2::port::publisher::Publisher<Ipc, T, ()>;
/// Subscriber of the service that carries `T` (see [`Topic`]).
pub type Subscriber<T> = iceoryx2::port::subscriber::Subscriber<Ipc, T, ()>;
/// Notifier of [`GUIDANCE_EVENT`] (planner).
pub type GuidanceNotifier = iceoryx2::port::notifier::Notifier<Ipc>;
/// The same shared-memory transport as [`Ipc`] with ports that are `Send + Sync` (their
/// state behind a mutex), for a process that writes from a thread it does not own (the
/// bridge, from Zenoh's callbacks). Ports of both kinds meet on the same services.
pub type IpcThreadsafe = ipc_threadsafe::Service;
/// Listener of [`GUIDANCE_EVENT`] (the loop's relay thread).
pub type GuidanceListener = iceoryx2::port::listener::Listener<Ipc>;

/// What went wrong opening a node, a service or a port; each message names it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ServiceError {
    /// The node could not be created.
    #[error("iceoryx2 node '{node}': {reason}")]
    Node {
        /// Node name.
        node: String,
        /// What iceoryx2 said.
        reason: String,
    },
    /// The service could not be opened or created.
    #[error("iceoryx2 service '{service}': {reason}")]
    Service {
        /// Full service name.
        service: String,
        /// What failed.
        reason: String,
    },
    /// A port (publisher, subscriber, notifier, listener, reader) could not be created.
    #[error("iceoryx2 service '{service}': cannot create {port} ({reason}){hint}")]
    Port {
        /// Full service name.
        service: String,
        /// Which port.
        port: &'static str,
        /// What iceoryx2 said.
        reason: String,
        /// What the limit is, when the service has one worth saying (may be empty).
        hint: String,
    },
    /// Another live process holds the state blackboard's writer.
    #[error(
        "iceoryx2 service '{service}': another live process already writes it ({reason}); stop it first"
    )]
    WriterTaken {
        /// Full service name.
        service: String,
        /// What iceoryx2 said.
        reason: String,
    },
}

/// A namespace that cannot be part of a service name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("must be non-empty ASCII letters, digits, '_' or '-', got {0:?}")]
pub struct NamespaceError(pub String);

/// Checks that `namespace` can be part of a service name: non-empty ASCII letters, digits,
/// `_` or `-`.
pub fn validate_namespace(namespace: &str) -> Result<(), NamespaceError> {
    let ok = !namespace.is_empty()
        && namespace
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if ok {
        Ok(())
    } else {
        Err(NamespaceError(namespace.to_owned()))
    }
}

/// Full service name `hrrtc/<namespace>/<leaf>`.
pub fn service_name(namespace: &str, leaf: &str) -> String {
    format!("hrrtc/{namespace}/{leaf}")
}

/// iceoryx2's configuration: its config file when one exists (iceoryx2 looks in the project,
/// the user's and the system's config folders), else its defaults.
///
/// iceoryx2 warns on its own console logger, in colour, every time a process starts without
/// a config file, though defaults are what these processes are meant to run with. The
/// first look-up therefore runs with iceoryx2's log level at `Error` (unless the user set
/// `IOX2_LOG_LEVEL`), and the level goes back to the user's or iceoryx2's default after it.
pub fn iceoryx_config() -> &'static Config {
    static LOADED: std::sync::Once = std::sync::Once::new();
    LOADED.call_once(|| {
        if std::env::var_os("IOX2_LOG_LEVEL").is_none() {
            set_log_level(LogLevel::Error);
        }
        let _ = Config::global_config();
        set_log_level_from_env_or_default();
    });
    Config::global_config()
}

/// Creates a node named `name` with iceoryx2's own signal handling disabled (the processes
/// install their own), after removing the resources of dead nodes so that a crashed
/// predecessor cannot block a service. Returns the node and how many dead nodes were cleaned.
pub fn create_node(name: &str) -> Result<(Node<Ipc>, usize), ServiceError> {
    create_node_in::<Ipc>(name)
}

/// [`create_node`] for the transport `S` (e.g. [`IpcThreadsafe`]).
pub fn create_node_in<S: iceoryx2::service::Service>(
    name: &str,
) -> Result<(Node<S>, usize), ServiceError> {
    crate::startup::hold_resources();
    let cleaned = cleanup_dead_nodes();
    let node_error = |reason: String| ServiceError::Node {
        node: name.to_owned(),
        reason,
    };
    let node_name: NodeName = name
        .try_into()
        .map_err(|e| node_error(format!("invalid node name: {e:?}")))?;
    let node = NodeBuilder::new()
        .config(iceoryx_config())
        .name(&node_name)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<S>()
        .map_err(|e| node_error(format!("cannot create node: {e:?}")))?;
    Ok((node, cleaned))
}

/// Removes the resources of every dead node on this host; returns how many were removed.
pub fn cleanup_dead_nodes() -> usize {
    let mut cleaned = 0;
    let _ = Node::<Ipc>::list(iceoryx_config(), |state| {
        if let NodeState::Dead(view) = state
            && view.try_remove_stale_resources().is_ok()
        {
            cleaned += 1;
        }
        CallbackProgression::Continue
    });
    cleaned
}

/// The full name of service `leaf` on `namespace`, and as an iceoryx2 service name.
fn iceoryx_name(namespace: &str, leaf: &str) -> Result<(String, ServiceName), ServiceError> {
    let full = service_name(namespace, leaf);
    let name = full
        .as_str()
        .try_into()
        .map_err(|e| ServiceError::Service {
            service: full.clone(),
            reason: format!("invalid service name: {e:?}"),
        })?;
    Ok((full, name))
}

/// The error of a port of `service` that could not be created; `hint` says what limit
/// applies (may be empty).
fn port_error<E: core::fmt::Debug>(
    service: String,
    port: &'static str,
    hint: String,
) -> impl FnOnce(E) -> ServiceError {
    move |e| ServiceError::Port {
        service,
        port,
        reason: format!("{e:?}"),
        hint,
    }
}

/// Quality of service of a publish-subscribe service: set by whoever creates it, and the
/// same for every process (a mismatch would make the second opener fail).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// Samples a late subscriber receives on connecting.
    pub history: usize,
    /// Samples a subscriber holds; when full, the oldest is dropped (safe overflow), so
    /// the publisher never blocks.
    pub subscriber_buffer: usize,
    /// Most publishers.
    pub max_publishers: usize,
    /// Most subscribers.
    pub max_subscribers: usize,
}

/// Latest value: history 1, a buffer of [`LATEST_SUBSCRIBER_BUFFER`].
pub const LATEST_VALUE: Qos = Qos {
    history: 1,
    subscriber_buffer: LATEST_SUBSCRIBER_BUFFER,
    max_publishers: MAX_PLANNER_PUBLISHERS,
    max_subscribers: MAX_READERS,
};

/// A publish-subscribe service of the catalogue, named by the wire type it carries.
pub trait Topic: ZeroCopySend + core::fmt::Debug + Sized + 'static {
    /// Leaf of its service name.
    const LEAF: &'static str;
    /// Its quality of service.
    const QOS: Qos;
}

impl Topic for Guidance {
    const LEAF: &'static str = GUIDANCE;
    const QOS: Qos = LATEST_VALUE;
}

impl Topic for Path {
    const LEAF: &'static str = PATH;
    const QOS: Qos = LATEST_VALUE;
}

/// No history (a sample is an increment, not a state), a deeper buffer than the
/// latest-value services.
impl Topic for Roadmap {
    const LEAF: &'static str = ROADMAP;
    const QOS: Qos = Qos {
        history: 0,
        subscriber_buffer: ROADMAP_SUBSCRIBER_BUFFER,
        max_publishers: MAX_PLANNER_PUBLISHERS,
        max_subscribers: ROADMAP_MAX_SUBSCRIBERS,
    };
}

impl Topic for DriverState {
    const LEAF: &'static str = DRIVER_STATE;
    const QOS: Qos = LATEST_VALUE;
}

impl Topic for DriverCommand {
    const LEAF: &'static str = DRIVER_COMMAND;
    const QOS: Qos = LATEST_VALUE;
}

fn topic<S: iceoryx2::service::Service, T: Topic>(
    node: &Node<S>,
    namespace: &str,
) -> Result<
    (
        String,
        iceoryx2::service::port_factory::publish_subscribe::PortFactory<S, T, ()>,
    ),
    ServiceError,
> {
    let (full, name) = iceoryx_name(namespace, T::LEAF)?;
    let q = T::QOS;
    let factory = node
        .service_builder(&name)
        .publish_subscribe::<T>()
        .history_size(q.history)
        .subscriber_max_buffer_size(q.subscriber_buffer)
        .enable_safe_overflow(true)
        .max_publishers(q.max_publishers)
        .max_subscribers(q.max_subscribers)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| ServiceError::Service {
            service: full.clone(),
            reason: format!("cannot open or create: {e:?}"),
        })?;
    Ok((full, factory))
}

/// A publisher of the service carrying `T` on `namespace`. Samples are sent with
/// `send_copy` or loaned (`loan()`), filled in place and sent; a loan that fails (no free
/// sample) is skipped, never waited for.
pub fn publisher<T: Topic>(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<Publisher<T>, ServiceError> {
    publisher_in::<Ipc, T>(node, namespace)
}

/// [`publisher`] for the transport `S` (e.g. [`IpcThreadsafe`]).
pub fn publisher_in<S: iceoryx2::service::Service, T: Topic>(
    node: &Node<S>,
    namespace: &str,
) -> Result<iceoryx2::port::publisher::Publisher<S, T, ()>, ServiceError> {
    let (service, factory) = topic::<S, T>(node, namespace)?;
    factory.publisher_builder().create().map_err(port_error(
        service,
        "publisher",
        format!("; at most {} publishers", T::QOS.max_publishers),
    ))
}

/// A subscriber of the service carrying `T` on `namespace`.
pub fn subscriber<T: Topic>(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<Subscriber<T>, ServiceError> {
    let (service, factory) = topic::<Ipc, T>(node, namespace)?;
    factory.subscriber_builder().create().map_err(port_error(
        service,
        "subscriber",
        format!(
            "; at most {} subscribers may attach",
            T::QOS.max_subscribers
        ),
    ))
}

fn guidance_event<S: iceoryx2::service::Service>(
    node: &Node<S>,
    namespace: &str,
) -> Result<
    (
        String,
        iceoryx2::service::port_factory::event::PortFactory<S>,
    ),
    ServiceError,
> {
    let (full, name) = iceoryx_name(namespace, GUIDANCE_EVENT)?;
    let factory = node
        .service_builder(&name)
        .event()
        .max_notifiers(MAX_PLANNER_PUBLISHERS)
        .max_listeners(MAX_READERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| ServiceError::Service {
            service: full.clone(),
            reason: format!("cannot open or create: {e:?}"),
        })?;
    Ok((full, factory))
}

/// Notifier of [`GUIDANCE_EVENT`] (for the planner, after each guidance sample).
pub fn guidance_notifier(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<GuidanceNotifier, ServiceError> {
    guidance_notifier_in::<Ipc>(node, namespace)
}

/// [`guidance_notifier`] for the transport `S` (e.g. [`IpcThreadsafe`]).
pub fn guidance_notifier_in<S: iceoryx2::service::Service>(
    node: &Node<S>,
    namespace: &str,
) -> Result<iceoryx2::port::notifier::Notifier<S>, ServiceError> {
    let (service, factory) = guidance_event(node, namespace)?;
    factory
        .notifier_builder()
        .create()
        .map_err(port_error(service, "notifier", String::new()))
}

/// The loop's guidance service and its wake-up event, written from any thread: for the
/// processes that bring guidance in from a network, whose samples arrive on Zenoh's
/// callback threads (the Zenoh bridge's loop side, the ROS 2 gateway). Owns its node; the
/// ports close before it.
pub struct GuidanceInlet {
    publisher: iceoryx2::port::publisher::Publisher<IpcThreadsafe, Guidance, ()>,
    notifier: iceoryx2::port::notifier::Notifier<IpcThreadsafe>,
    _node: Node<IpcThreadsafe>,
}

impl GuidanceInlet {
    /// Opens the guidance publisher and notifier on `namespace` in a new node named `node`.
    pub fn open(node: &str, namespace: &str) -> Result<Self, ServiceError> {
        let (node, _) = create_node_in::<IpcThreadsafe>(node)?;
        Ok(GuidanceInlet {
            publisher: publisher_in::<IpcThreadsafe, Guidance>(&node, namespace)?,
            notifier: guidance_notifier_in::<IpcThreadsafe>(&node, namespace)?,
            _node: node,
        })
    }

    /// Sends `g` and wakes the loop's relay; false when the sample could not be sent. A
    /// failed wake-up is not reported: the relay also polls, so it costs only latency.
    pub fn send(&self, g: Guidance) -> bool {
        let sent = self.publisher.send_copy(g).is_ok();
        let _ = self.notifier.notify();
        sent
    }
}

/// Listener of [`GUIDANCE_EVENT`] (for the loop's relay thread, never the RT thread).
pub fn guidance_listener(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<GuidanceListener, ServiceError> {
    let (service, factory) = guidance_event(node, namespace)?;
    factory
        .listener_builder()
        .create()
        .map_err(port_error(service, "listener", String::new()))
}

/// A namespace no other process and no earlier call in this process uses (`tag`, the
/// process id and a counter): for tests and benchmarks that run side by side.
pub fn unique_namespace(tag: &str) -> String {
    static COUNTER: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    format!("{tag}_{}_{n}", std::process::id())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Header;
    use iceoryx2::port::update_connections::UpdateConnections;

    #[test]
    fn namespaces_are_validated() {
        assert!(validate_namespace("it_rate-3").is_ok());
        assert!(validate_namespace("").is_err());
        assert!(
            validate_namespace("a/b")
                .unwrap_err()
                .to_string()
                .contains("a/b")
        );
    }

    #[test]
    fn blackboard_roundtrip_and_single_writer() {
        let ns = unique_namespace("bb");
        let (node, _) = create_node("ipc_types_test").unwrap();
        let reader = state_reader(&node, &ns).unwrap();
        assert_eq!(reader.get().header.sequence, 0, "initial value is zeroed");
        let writer = state_writer(&node, &ns).unwrap();
        let s = HapticState {
            header: Header::new(7, 11, 1),
            buttons: 3,
            ..HapticState::default()
        };
        writer.update_with_copy(s);
        assert_eq!(*reader.get(), s);
        assert!(
            state_writer(&node, &ns).is_err(),
            "a second writer must be refused"
        );
    }

    #[test]
    fn guidance_latest_value_survives_a_publisher_restart() {
        let ns = unique_namespace("guid");
        let (node, _) = create_node("ipc_types_guidance_test").unwrap();
        let sub = subscriber::<Guidance>(&node, &ns).unwrap();
        let g = |seq| Guidance::roadmap(Header::new(seq, 0, 0), [0.0; 6], 0.0, 0.0, 0);
        {
            let first = publisher::<Guidance>(&node, &ns).unwrap();
            first.send_copy(g(1)).unwrap();
        }
        let second = publisher::<Guidance>(&node, &ns).unwrap();
        second.send_copy(g(2)).unwrap();
        let mut newest = 0;
        while let Some(s) = sub.receive().unwrap() {
            newest = s.header.sequence;
        }
        assert_eq!(newest, 2, "the new publisher's sample arrives");
    }

    #[test]
    fn path_history_reaches_late_subscriber() {
        let ns = unique_namespace("path");
        let (node, _) = create_node("ipc_types_path_test").unwrap();
        let publisher = publisher::<Path>(&node, &ns).unwrap();
        let mut p = Path::EMPTY;
        p.header.sequence = 1;
        p.len = 2;
        publisher.send_copy(p).unwrap();
        let subscriber = subscriber::<Path>(&node, &ns).unwrap();
        // History reaches a new subscriber when the publisher next updates its connections.
        publisher.update_connections().unwrap();
        let sample = subscriber
            .receive()
            .unwrap()
            .expect("history delivers the path");
        assert_eq!(sample.len, 2);
    }
}
