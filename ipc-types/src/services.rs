//! Service names, their semantics, and the one place both processes open them.
//!
//! | service | pattern | writer | semantics |
//! |---|---|---|---|
//! | [`HAPTIC_STATE`]`/<generation>` | blackboard, one entry | haptic loop (RT thread) | latest value; never blocks, never allocates; a loop restarted after a crash writes a new generation, readers follow the newest ([`newest_state_generation`]) |
//! | [`GUIDANCE`] | publish-subscribe | planner | history 1, safe overflow: latest value; a restarted planner simply publishes again |
//! | [`GUIDANCE_EVENT`] | event | planner | "a guidance sample was sent": wakes the loop's relay thread (non-RT); the relay also polls, so a lost or absent notification costs only latency |
//! | [`PATH`] | publish-subscribe | planner | history 1, safe overflow: late subscribers get the newest path; the planner never blocks |
//! | [`ROADMAP`] | publish-subscribe | planner | no history, [`ROADMAP_SUBSCRIBER_BUFFER`] samples, safe overflow: increments; a slow or late viewer catches up from the rolling window (see [`crate::Roadmap`]); the planner never blocks |
//! | [`DRIVER_STATE`] | publish-subscribe | external device driver | history 1, safe overflow: latest value; a restarted driver simply publishes again |
//! | [`DRIVER_COMMAND`] | publish-subscribe | haptic loop (bridge relay thread) | history 1, safe overflow: latest value; the driver zeroes force when it goes stale |
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

use crate::{DriverCommand, DriverState, Guidance, HapticState, Path, Roadmap};
use core::time::Duration;
use iceoryx2::port::reader::EntryHandle;
use iceoryx2::port::writer::EntryHandleMut;
use iceoryx2::prelude::*;
use iceoryx2::service::builder::blackboard::{BlackboardCreateError, BlackboardOpenError};

/// Leaf name of the event the planner notifies after each [`GUIDANCE`] sample, which wakes
/// the loop's non-RT relay thread at once instead of at its next poll.
pub const GUIDANCE_EVENT: &str = "guidance_event";
/// Leaf name of the [`HapticState`] blackboard.
pub const HAPTIC_STATE: &str = "haptic_state";
/// Leaf name of the [`Guidance`] blackboard.
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
/// Subscriber buffer of [`PATH`] and [`GUIDANCE`]: only the newest sample matters.
pub const LATEST_SUBSCRIBER_BUFFER: usize = 2;
/// Most publishers of [`PATH`] and [`GUIDANCE`]: a planner and its restarted successor
/// while the dead one's port is not yet cleaned up.
pub const MAX_PLANNER_PUBLISHERS: usize = 4;

/// Subscriber buffer of [`ROADMAP`]: half a second of increments at 20 Hz; a viewer that
/// falls further behind loses the oldest and catches up from the rolling window.
pub const ROADMAP_SUBSCRIBER_BUFFER: usize = 10;
/// Most subscribers of [`ROADMAP`] (viewers and recorders). Each one costs the planner's
/// shared memory `ROADMAP_SUBSCRIBER_BUFFER` samples of 90 KB.
pub const ROADMAP_MAX_SUBSCRIBERS: usize = 4;

/// The iceoryx2 transport both processes use.
pub type Ipc = ipc::Service;
/// Read handle of the [`HAPTIC_STATE`] entry.
pub type StateReader = EntryHandle<Ipc, u64, HapticState>;
/// Write handle of the [`HAPTIC_STATE`] entry.
pub type StateWriter = EntryHandleMut<Ipc, u64, HapticState>;
/// Publisher of [`GUIDANCE`].
pub type GuidancePublisher = iceoryx2::port::publisher::Publisher<Ipc, Guidance, ()>;
/// Subscriber of [`GUIDANCE`].
pub type GuidanceSubscriber = iceoryx2::port::subscriber::Subscriber<Ipc, Guidance, ()>;
/// Publisher of [`DRIVER_STATE`] (the driver).
pub type DriverStatePublisher = iceoryx2::port::publisher::Publisher<Ipc, DriverState, ()>;
/// Subscriber of [`DRIVER_STATE`] (the loop's bridge).
pub type DriverStateSubscriber = iceoryx2::port::subscriber::Subscriber<Ipc, DriverState, ()>;
/// Publisher of [`DRIVER_COMMAND`] (the loop's bridge).
pub type DriverCommandPublisher = iceoryx2::port::publisher::Publisher<Ipc, DriverCommand, ()>;
/// Subscriber of [`DRIVER_COMMAND`] (the driver).
pub type DriverCommandSubscriber = iceoryx2::port::subscriber::Subscriber<Ipc, DriverCommand, ()>;
/// Publisher of [`PATH`].
pub type PathPublisher = iceoryx2::port::publisher::Publisher<Ipc, Path, ()>;
/// Publisher of [`ROADMAP`].
pub type RoadmapPublisher = iceoryx2::port::publisher::Publisher<Ipc, Roadmap, ()>;
/// Subscriber of [`ROADMAP`].
pub type RoadmapSubscriber = iceoryx2::port::subscriber::Subscriber<Ipc, Roadmap, ()>;
/// Subscriber of [`PATH`].
pub type PathSubscriber = iceoryx2::port::subscriber::Subscriber<Ipc, Path, ()>;
/// Notifier of [`GUIDANCE_EVENT`] (planner).
pub type GuidanceNotifier = iceoryx2::port::notifier::Notifier<Ipc>;
/// Listener of [`GUIDANCE_EVENT`] (the loop's relay thread).
pub type GuidanceListener = iceoryx2::port::listener::Listener<Ipc>;

/// What went wrong opening a service; the message names the service.
#[derive(Debug)]
pub struct ServiceError {
    /// Full iceoryx2 service name.
    pub service: String,
    /// What failed.
    pub what: String,
}

impl core::fmt::Display for ServiceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "iceoryx2 service '{}': {}", self.service, self.what)
    }
}

impl std::error::Error for ServiceError {}

fn err(service: &str, what: impl core::fmt::Display) -> ServiceError {
    ServiceError {
        service: service.to_string(),
        what: what.to_string(),
    }
}

/// Checks that `namespace` can be part of a service name: non-empty ASCII letters, digits,
/// `_` or `-`. The error says what is wrong.
pub fn validate_namespace(namespace: &str) -> Result<(), String> {
    let ok = !namespace.is_empty()
        && namespace
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if ok {
        Ok(())
    } else {
        Err(format!(
            "must be non-empty ASCII letters, digits, '_' or '-', got {namespace:?}"
        ))
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
        let user_level = std::env::var_os("IOX2_LOG_LEVEL").is_some();
        if !user_level {
            iceoryx2::prelude::set_log_level(iceoryx2::prelude::LogLevel::Error);
        }
        let _ = Config::global_config();
        iceoryx2::prelude::set_log_level_from_env_or_default();
    });
    Config::global_config()
}

/// Creates a node named `name` with iceoryx2's own signal handling disabled (the processes
/// install their own), after removing the resources of dead nodes so that a crashed
/// predecessor cannot block a service. Returns the node and how many dead nodes were cleaned.
pub fn create_node(name: &str) -> Result<(Node<Ipc>, usize), ServiceError> {
    let cleaned = cleanup_dead_nodes();
    let node_name: NodeName = name
        .try_into()
        .map_err(|e| err(name, format!("invalid node name: {e:?}")))?;
    let node = NodeBuilder::new()
        .config(iceoryx_config())
        .name(&node_name)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<Ipc>()
        .map_err(|e| err(name, format!("cannot create node: {e:?}")))?;
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
        .map_err(|e| err(&full, format!("invalid service name: {e:?}")))?;
    Ok((full, name))
}

/// Opens the blackboard `leaf` holding one `T`, creating it with `initial` if nobody has.
/// Every wire type's `Default` has `header.sequence == 0`: "never written".
/// Either process may come first.
fn blackboard<T>(
    node: &Node<Ipc>,
    namespace: &str,
    leaf: &str,
    initial: T,
) -> Result<iceoryx2::service::port_factory::blackboard::PortFactory<Ipc, u64>, ServiceError>
where
    T: ZeroCopySend + Copy + core::fmt::Debug + 'static,
{
    let (full, name) = iceoryx_name(namespace, leaf)?;
    // Open-or-create by hand: blackboards have no open_or_create. Creation races and services
    // being torn down by their last user are transient, so retry for a short while.
    let mut last = String::new();
    for _ in 0..50 {
        match node
            .service_builder(&name)
            .blackboard_opener::<u64>()
            .max_readers(MAX_READERS)
            .open()
        {
            Ok(f) => return Ok(f),
            Err(BlackboardOpenError::DoesNotExist) => {}
            // A service another process is creating at this moment can also look corrupted
            // (its static config not yet complete).
            Err(BlackboardOpenError::IsMarkedForDestruction)
            | Err(BlackboardOpenError::HangsInCreation)
            | Err(BlackboardOpenError::ServiceInCorruptedState) => {
                last = "is being torn down or created".into();
                std::thread::sleep(Duration::from_millis(10));
                continue;
            }
            Err(e) => return Err(err(&full, format!("cannot open: {e:?}"))),
        }
        match node
            .service_builder(&name)
            .blackboard_creator::<u64>()
            .max_readers(MAX_READERS)
            .max_nodes(MAX_NODES)
            .add::<T>(ENTRY_KEY, initial)
            .create()
        {
            Ok(f) => return Ok(f),
            Err(BlackboardCreateError::AlreadyExists)
            | Err(BlackboardCreateError::IsBeingCreatedByAnotherInstance) => {
                last = "created concurrently".into();
                std::thread::sleep(Duration::from_millis(2));
            }
            Err(e) => return Err(err(&full, format!("cannot create: {e:?}"))),
        }
    }
    Err(err(&full, format!("gave up opening: {last}")))
}

/// The write handle of a blackboard entry; fails when another live process already writes it.
fn writer<T: ZeroCopySend + Copy + Default + core::fmt::Debug + 'static>(
    node: &Node<Ipc>,
    namespace: &str,
    leaf: &str,
) -> Result<EntryHandleMut<Ipc, u64, T>, ServiceError> {
    let full = service_name(namespace, leaf);
    let factory = blackboard::<T>(node, namespace, leaf, T::default())?;
    let writer = factory.writer_builder().create().map_err(|e| {
        err(
            &full,
            format!("another live process already writes it ({e:?}); stop it first"),
        )
    })?;
    writer
        .entry::<T>(&ENTRY_KEY)
        .map_err(|e| err(&full, format!("cannot write its entry: {e:?}")))
}

fn reader<T: ZeroCopySend + Copy + Default + core::fmt::Debug + 'static>(
    node: &Node<Ipc>,
    namespace: &str,
    leaf: &str,
) -> Result<EntryHandle<Ipc, u64, T>, ServiceError> {
    let full = service_name(namespace, leaf);
    let factory = blackboard::<T>(node, namespace, leaf, T::default())?;
    let reader = factory
        .reader_builder()
        .create()
        .map_err(|e| err(&full, format!("cannot create reader: {e:?}")))?;
    reader
        .entry::<T>(&ENTRY_KEY)
        .map_err(|e| err(&full, format!("cannot read its entry: {e:?}")))
}

/// Leaf name of generation `generation` of the [`HAPTIC_STATE`] blackboard.
fn state_leaf(generation: u32) -> String {
    format!("{HAPTIC_STATE}/{generation}")
}

/// Most generations a starting loop steps over before it gives up.
const MAX_GENERATION_STEPS: u32 = 16;

/// The newest generation of the [`HAPTIC_STATE`] blackboard on `namespace`, if any exists.
///
/// Generations exist because iceoryx2 0.10 does not release a blackboard writer's flag when
/// its process dies: a haptic loop restarted after `kill -9` while a planner still holds the
/// old blackboard cannot write it again, so it writes the next generation instead, and
/// readers follow the newest one (see [`state_writer`]).
pub fn newest_state_generation(namespace: &str) -> Option<u32> {
    let prefix = format!("{}/", service_name(namespace, HAPTIC_STATE));
    let mut newest = None;
    let _ = Ipc::list(Config::global_config(), |service| {
        let name = service.static_details.name().to_string();
        if let Some(g) = name
            .strip_prefix(&prefix)
            .and_then(|g| g.parse::<u32>().ok())
        {
            newest = newest.max(Some(g));
        }
        CallbackProgression::Continue
    });
    newest
}

/// Whether process `pid` exists and is not a zombie (Linux `/proc`).
fn process_alive(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        // The state letter follows the parenthesised command name.
        Ok(stat) => stat
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().next())
            .is_some_and(|state| state != "Z" && state != "X"),
        Err(_) => false,
    }
}

/// Whether the writer of generation `generation` is a live process: the entry's
/// `writer_pid` names one. An entry never written gets a moment for its writer's first tick.
fn state_writer_alive(node: &Node<Ipc>, namespace: &str, generation: u32) -> bool {
    let Ok(entry) = reader::<HapticState>(node, namespace, &state_leaf(generation)) else {
        return false;
    };
    let mut pid = entry.get().header.writer_pid;
    if pid == 0 {
        std::thread::sleep(Duration::from_millis(200));
        pid = entry.get().header.writer_pid;
    }
    pid != 0 && process_alive(pid)
}

/// Write handle of [`HAPTIC_STATE`] (for the haptic loop), on the newest generation, or on
/// a new one when the newest was left behind by a dead loop. Fails if a live loop writes it.
pub fn state_writer(node: &Node<Ipc>, namespace: &str) -> Result<StateWriter, ServiceError> {
    let mut generation = newest_state_generation(namespace).unwrap_or(0);
    for _ in 0..MAX_GENERATION_STEPS {
        match writer::<HapticState>(node, namespace, &state_leaf(generation)) {
            Ok(w) => return Ok(w),
            Err(e) if state_writer_alive(node, namespace, generation) => return Err(e),
            // Its writer died without releasing it: start the next generation.
            Err(_) => generation += 1,
        }
    }
    Err(err(
        &service_name(namespace, HAPTIC_STATE),
        format!("{MAX_GENERATION_STEPS} generations are held by dead writers"),
    ))
}

/// Read handle of the newest generation of [`HAPTIC_STATE`], and that generation.
pub fn state_reader_generation(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<(StateReader, u32), ServiceError> {
    let generation = newest_state_generation(namespace).unwrap_or(0);
    let r = reader::<HapticState>(node, namespace, &state_leaf(generation))?;
    Ok((r, generation))
}

/// Read handle of the newest generation of [`HAPTIC_STATE`].
pub fn state_reader(node: &Node<Ipc>, namespace: &str) -> Result<StateReader, ServiceError> {
    state_reader_generation(node, namespace).map(|(r, _)| r)
}

/// How long without a new state before a [`StateFollower`] looks for a newer generation,
/// and how often it looks then.
pub const GENERATION_CHECK: Duration = Duration::from_millis(500);

/// A reader of [`HAPTIC_STATE`] that moves to a newer generation (a haptic loop restarted
/// after a crash) when no new state has arrived for [`GENERATION_CHECK`]. For non-RT
/// readers: looking allocates (service listing, a node of its own the first time).
pub struct StateFollower {
    namespace: String,
    reader: StateReader,
    generation: u32,
    node: Option<Node<Ipc>>,
    last_new: std::time::Instant,
    last_check: std::time::Instant,
}

impl core::fmt::Debug for StateFollower {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("StateFollower")
            .field("namespace", &self.namespace)
            .field("generation", &self.generation)
            .finish()
    }
}

impl StateFollower {
    /// Reads the newest generation on `namespace` through `node`.
    pub fn open(node: &Node<Ipc>, namespace: &str) -> Result<Self, ServiceError> {
        let (reader, generation) = state_reader_generation(node, namespace)?;
        let now = std::time::Instant::now();
        Ok(Self {
            namespace: namespace.to_string(),
            reader,
            generation,
            node: None,
            last_new: now,
            last_check: now,
        })
    }

    /// The current generation's entry.
    pub fn get(&self) -> HapticState {
        *self.reader.get()
    }

    /// The generation read.
    pub fn generation(&self) -> u32 {
        self.generation
    }

    /// Tells the follower whether the last [`Self::get`] brought a new state; after
    /// [`GENERATION_CHECK`] without one it looks for a newer generation (at most that
    /// often). Returns the new generation when it switched; an error when it found one
    /// but could not open it (it tries again later).
    pub fn after_read(&mut self, new_state: bool) -> Result<Option<u32>, ServiceError> {
        let now = std::time::Instant::now();
        if new_state {
            self.last_new = now;
            return Ok(None);
        }
        if now - self.last_new < GENERATION_CHECK || now - self.last_check < GENERATION_CHECK {
            return Ok(None);
        }
        self.last_check = now;
        match newest_state_generation(&self.namespace) {
            Some(newest) if newest > self.generation => {}
            _ => return Ok(None),
        }
        if self.node.is_none() {
            let name = format!("state_follower_{}", std::process::id());
            self.node = Some(create_node(&name)?.0);
        }
        let Some(node) = &self.node else {
            return Ok(None);
        };
        let (reader, generation) = state_reader_generation(node, &self.namespace)?;
        self.reader = reader;
        self.generation = generation;
        Ok(Some(generation))
    }
}

/// A latest-value publish-subscribe service: history 1, small buffers, safe overflow (a
/// full subscriber loses its oldest sample; the publisher never blocks).
fn latest_value_service<T: ZeroCopySend + core::fmt::Debug + 'static>(
    node: &Node<Ipc>,
    namespace: &str,
    leaf: &str,
) -> Result<iceoryx2::service::port_factory::publish_subscribe::PortFactory<Ipc, T, ()>, ServiceError>
{
    let (full, name) = iceoryx_name(namespace, leaf)?;
    node.service_builder(&name)
        .publish_subscribe::<T>()
        .history_size(1)
        .subscriber_max_buffer_size(LATEST_SUBSCRIBER_BUFFER)
        .enable_safe_overflow(true)
        .max_publishers(MAX_PLANNER_PUBLISHERS)
        .max_subscribers(MAX_READERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| err(&full, format!("cannot open or create: {e:?}")))
}

fn publisher<T: ZeroCopySend + core::fmt::Debug + 'static>(
    node: &Node<Ipc>,
    namespace: &str,
    leaf: &str,
) -> Result<iceoryx2::port::publisher::Publisher<Ipc, T, ()>, ServiceError> {
    latest_value_service::<T>(node, namespace, leaf)?
        .publisher_builder()
        .create()
        .map_err(|e| {
            err(
                &service_name(namespace, leaf),
                format!("cannot create publisher: {e:?}"),
            )
        })
}

fn subscriber<T: ZeroCopySend + core::fmt::Debug + 'static>(
    node: &Node<Ipc>,
    namespace: &str,
    leaf: &str,
) -> Result<iceoryx2::port::subscriber::Subscriber<Ipc, T, ()>, ServiceError> {
    latest_value_service::<T>(node, namespace, leaf)?
        .subscriber_builder()
        .create()
        .map_err(|e| {
            err(
                &service_name(namespace, leaf),
                format!("cannot create subscriber: {e:?}"),
            )
        })
}

/// Publisher of [`GUIDANCE`] (for the planner).
pub fn guidance_publisher(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<GuidancePublisher, ServiceError> {
    publisher::<Guidance>(node, namespace, GUIDANCE)
}

/// Subscriber of [`GUIDANCE`].
pub fn guidance_subscriber(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<GuidanceSubscriber, ServiceError> {
    subscriber::<Guidance>(node, namespace, GUIDANCE)
}

fn guidance_event(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<iceoryx2::service::port_factory::event::PortFactory<Ipc>, ServiceError> {
    let (full, name) = iceoryx_name(namespace, GUIDANCE_EVENT)?;
    node.service_builder(&name)
        .event()
        .max_notifiers(MAX_PLANNER_PUBLISHERS)
        .max_listeners(MAX_READERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| err(&full, format!("cannot open or create: {e:?}")))
}

/// Notifier of [`GUIDANCE_EVENT`] (for the planner, after each guidance sample).
pub fn guidance_notifier(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<GuidanceNotifier, ServiceError> {
    guidance_event(node, namespace)?
        .notifier_builder()
        .create()
        .map_err(|e| {
            err(
                &service_name(namespace, GUIDANCE_EVENT),
                format!("cannot create notifier: {e:?}"),
            )
        })
}

/// Listener of [`GUIDANCE_EVENT`] (for the loop's relay thread, never the RT thread).
pub fn guidance_listener(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<GuidanceListener, ServiceError> {
    guidance_event(node, namespace)?
        .listener_builder()
        .create()
        .map_err(|e| {
            err(
                &service_name(namespace, GUIDANCE_EVENT),
                format!("cannot create listener: {e:?}"),
            )
        })
}

/// Publisher of [`PATH`] (for the planner).
pub fn path_publisher(node: &Node<Ipc>, namespace: &str) -> Result<PathPublisher, ServiceError> {
    publisher::<Path>(node, namespace, PATH)
}

/// Subscriber of [`PATH`].
pub fn path_subscriber(node: &Node<Ipc>, namespace: &str) -> Result<PathSubscriber, ServiceError> {
    subscriber::<Path>(node, namespace, PATH)
}

/// The [`ROADMAP`] service: no history (a sample is an increment, not a state), a deeper
/// buffer than the latest-value services, safe overflow.
fn roadmap_service(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<Ipc, Roadmap, ()>,
    ServiceError,
> {
    let (full, name) = iceoryx_name(namespace, ROADMAP)?;
    node.service_builder(&name)
        .publish_subscribe::<Roadmap>()
        .history_size(0)
        .subscriber_max_buffer_size(ROADMAP_SUBSCRIBER_BUFFER)
        .enable_safe_overflow(true)
        .max_publishers(MAX_PLANNER_PUBLISHERS)
        .max_subscribers(ROADMAP_MAX_SUBSCRIBERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| err(&full, format!("cannot open or create: {e:?}")))
}

/// Publisher of [`ROADMAP`] (for the planner). Its samples are loaned (`loan()`), filled
/// in place and sent; a loan that fails (no free sample) is skipped, never waited for.
pub fn roadmap_publisher(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<RoadmapPublisher, ServiceError> {
    roadmap_service(node, namespace)?
        .publisher_builder()
        .create()
        .map_err(|e| {
            err(
                &service_name(namespace, ROADMAP),
                format!("cannot create publisher: {e:?}"),
            )
        })
}

/// Subscriber of [`ROADMAP`] (for viewers). Fails with a clear message when
/// [`ROADMAP_MAX_SUBSCRIBERS`] viewers are already attached.
pub fn roadmap_subscriber(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<RoadmapSubscriber, ServiceError> {
    roadmap_service(node, namespace)?
        .subscriber_builder()
        .create()
        .map_err(|e| {
            err(
                &service_name(namespace, ROADMAP),
                format!(
                    "cannot create subscriber ({e:?}); at most {ROADMAP_MAX_SUBSCRIBERS} viewers may attach"
                ),
            )
        })
}

/// Publisher of [`DRIVER_STATE`] (for a device driver).
pub fn driver_state_publisher(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<DriverStatePublisher, ServiceError> {
    publisher::<DriverState>(node, namespace, DRIVER_STATE)
}

/// Subscriber of [`DRIVER_STATE`] (for the loop's bridge).
pub fn driver_state_subscriber(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<DriverStateSubscriber, ServiceError> {
    subscriber::<DriverState>(node, namespace, DRIVER_STATE)
}

/// Publisher of [`DRIVER_COMMAND`] (for the loop's bridge).
pub fn driver_command_publisher(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<DriverCommandPublisher, ServiceError> {
    publisher::<DriverCommand>(node, namespace, DRIVER_COMMAND)
}

/// Subscriber of [`DRIVER_COMMAND`] (for a device driver).
pub fn driver_command_subscriber(
    node: &Node<Ipc>,
    namespace: &str,
) -> Result<DriverCommandSubscriber, ServiceError> {
    subscriber::<DriverCommand>(node, namespace, DRIVER_COMMAND)
}

// The haptic loop moves its handles into the RT thread and the planner into its receiver
// thread: keep them `Send`.
const fn assert_send<T: Send>() {}
const _: () = assert_send::<StateWriter>();
const _: () = assert_send::<StateReader>();

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{GuidanceMode, Header};
    use iceoryx2::port::update_connections::UpdateConnections;

    fn unique_namespace(tag: &str) -> String {
        format!("test_{tag}_{}", std::process::id())
    }

    #[test]
    fn namespaces_are_validated() {
        assert!(validate_namespace("it_rate-3").is_ok());
        assert!(validate_namespace("").is_err());
        assert!(validate_namespace("a/b").unwrap_err().contains("a/b"));
    }

    #[test]
    fn blackboard_roundtrip_and_single_writer() {
        let ns = unique_namespace("bb");
        let (node, _) = create_node("ipc_types_test").unwrap();
        let reader = state_reader(&node, &ns).unwrap();
        assert_eq!(reader.get().header.sequence, 0, "initial value is zeroed");
        let writer = state_writer(&node, &ns).unwrap();
        let s = HapticState {
            header: Header {
                sequence: 7,
                timestamp_ns: 11,
                writer_pid: 1,
                reserved: 0,
            },
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
        let sub = guidance_subscriber(&node, &ns).unwrap();
        let g = |seq| Guidance {
            header: Header {
                sequence: seq,
                ..Header::default()
            },
            mode: GuidanceMode::ROADMAP,
            ..Guidance::default()
        };
        {
            let first = guidance_publisher(&node, &ns).unwrap();
            first.send_copy(g(1)).unwrap();
        }
        let second = guidance_publisher(&node, &ns).unwrap();
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
        let publisher = path_publisher(&node, &ns).unwrap();
        let mut p = Path::EMPTY;
        p.header.sequence = 1;
        p.len = 2;
        publisher.send_copy(p).unwrap();
        let subscriber = path_subscriber(&node, &ns).unwrap();
        // History reaches a new subscriber when the publisher next updates its connections.
        publisher.update_connections().unwrap();
        let sample = subscriber
            .receive()
            .unwrap()
            .expect("history delivers the path");
        assert_eq!(sample.len, 2);
    }
}
