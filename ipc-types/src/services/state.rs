//! The generational protocol of the [`HAPTIC_STATE`] blackboard.
//!
//! iceoryx2 0.10 does not release a blackboard writer's flag when its process dies, so a
//! haptic loop restarted after `kill -9` while a planner still holds the old blackboard
//! could never write it again. The state therefore lives in generations,
//! `hrrtc/<namespace>/haptic_state/<n>`: a starting loop writes the newest generation, or
//! the next one when the newest was left behind by a dead writer (its `writer_pid` is gone
//! or a zombie); a live writer, even a stopped one, makes the start fail. Readers open the
//! newest generation and, through [`StateFollower`], move to a newer one when no new state
//! has come for [`GENERATION_CHECK`].

use super::{
    ENTRY_KEY, HAPTIC_STATE, Ipc, MAX_NODES, MAX_READERS, ServiceError, StateReader, StateWriter,
    create_node, iceoryx_config, iceoryx_name, service_name,
};
use crate::HapticState;
use core::time::Duration;
use iceoryx2::port::reader::EntryHandle;
use iceoryx2::port::writer::EntryHandleMut;
use iceoryx2::prelude::*;
use iceoryx2::service::builder::blackboard::{BlackboardCreateError, BlackboardOpenError};

fn service_error(service: &str, reason: String) -> ServiceError {
    ServiceError::Service {
        service: service.to_owned(),
        reason,
    }
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
            Err(e) => return Err(service_error(&full, format!("cannot open: {e:?}"))),
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
            Err(e) => return Err(service_error(&full, format!("cannot create: {e:?}"))),
        }
    }
    Err(service_error(&full, format!("gave up opening: {last}")))
}

/// The write handle of a blackboard entry; fails when another live process already writes it.
fn writer<T: ZeroCopySend + Copy + Default + core::fmt::Debug + 'static>(
    node: &Node<Ipc>,
    namespace: &str,
    leaf: &str,
) -> Result<EntryHandleMut<Ipc, u64, T>, ServiceError> {
    let full = service_name(namespace, leaf);
    let factory = blackboard::<T>(node, namespace, leaf, T::default())?;
    let writer = factory
        .writer_builder()
        .create()
        .map_err(|e| ServiceError::WriterTaken {
            service: full.clone(),
            reason: format!("{e:?}"),
        })?;
    writer
        .entry::<T>(&ENTRY_KEY)
        .map_err(|e| service_error(&full, format!("cannot write its entry: {e:?}")))
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
        .map_err(|e| ServiceError::Port {
            service: full.clone(),
            port: "reader",
            reason: format!("{e:?}"),
            hint: format!("; at most {MAX_READERS} readers"),
        })?;
    reader
        .entry::<T>(&ENTRY_KEY)
        .map_err(|e| service_error(&full, format!("cannot read its entry: {e:?}")))
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
    let _ = Ipc::list(iceoryx_config(), |service| {
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
    Err(service_error(
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

// The haptic loop moves its handles into the RT thread and the planner into its receiver
// thread: keep them `Send`.
const fn assert_send<T: Send>() {}
const _: () = assert_send::<StateWriter>();
const _: () = assert_send::<StateReader>();
