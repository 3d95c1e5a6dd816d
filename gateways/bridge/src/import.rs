//! Samples from the network into local services: each is checked and re-stamped into local
//! time ([`accept`]); the paths and roadmaps on the loop's host go through a bounded queue
//! to the import thread, which owns their iceoryx2 ports ([`Import`]).

use crate::clock::{self, PeerDelays};
use crate::frame::{self, Carried, FrameError, FrameHeader, Kind};
use crate::report::{Counters, bump};
use crate::session::{declare_error, key};
use crate::{BridgeConfig, BridgeError, Side, lock, spawn};
use ipc_types::services;
use ipc_types::{Guidance, Path, Roadmap};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use zenoh::Wait;
use zenoh::pubsub::Subscriber;

/// A frame received from Zenoh, waiting for the import thread.
pub(crate) struct Incoming {
    bytes: Vec<u8>,
    arrival_ns: u64,
}

impl Incoming {
    /// A sample as it arrives in a Zenoh callback: stamped first, then copied out.
    pub(crate) fn arrived(sample: &zenoh::sample::Sample) -> Self {
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

/// The queued imports: Zenoh's subscribers feed the import thread. Dropping it undeclares
/// the subscribers; join the thread first.
pub(crate) struct Import {
    subscribers: Vec<Subscriber<()>>,
    /// The import thread.
    pub(crate) thread: JoinHandle<()>,
}

impl Import {
    /// Subscribes to the keys this side imports through the queue (the loop side: paths,
    /// and roadmaps when carried) and starts the import thread, which reports on `ready`
    /// whether its ports opened.
    pub(crate) fn start(
        config: &BridgeConfig,
        session: &zenoh::Session,
        counters: &Arc<Counters>,
        delays: &Arc<Mutex<PeerDelays>>,
        stop: &Arc<AtomicBool>,
        ready: std::sync::mpsc::Sender<Result<(), BridgeError>>,
    ) -> Result<Self, BridgeError> {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Incoming>(IMPORT_QUEUE);
        let imported: &[&str] = match config.side {
            Side::Loop if config.roadmap => &["path", "roadmap"],
            Side::Loop => &["path"],
            Side::Planner => &[],
        };
        let mut subscribers = Vec::new();
        for leaf in imported {
            let k = key(config.keys(), leaf);
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
            subscribers.push(sub);
        }
        drop(tx);
        let thread = {
            let stop = stop.clone();
            let counters = counters.clone();
            let delays = delays.clone();
            let config = config.clone();
            spawn("import", move || {
                import_thread(&config, rx, &counters, &delays, &stop, ready)
            })?
        };
        Ok(Import {
            subscribers,
            thread,
        })
    }

    /// Undeclares the subscribers after the thread has ended.
    pub(crate) fn close(self) {
        let _ = self.thread.join();
        drop(self.subscribers);
    }
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

/// Decodes one frame into a `T` in local time, from a bridge that has answered this
/// bridge's probes lately ([`PeerDelays::answered_recently`]); counts a rejection or an
/// unanswered sender (each logged at most once a second per kind, so a flood cannot flood
/// the log).
pub(crate) fn accept<T: Carried>(
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
        Ok((h, v)) if lock(delays).answered_recently(h.sender, incoming.arrival_ns) => Some((h, v)),
        Ok((h, _)) => {
            bump(&counters.unverified, T::KIND);
            if last_warning.is_none_or(|t| t.elapsed() >= Duration::from_secs(1)) {
                tracing::warn!(
                    "not handing on a {} sample from bridge {:016x}: it has not answered this \
                     bridge's probes in the last {} s",
                    T::KIND.name(),
                    h.sender,
                    clock::ANSWERED_WITHIN_NS / 1_000_000_000
                );
                *last_warning = Some(Instant::now());
            }
            None
        }
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

/// Hands the queued samples to the local services (the ports are not `Send`, so this
/// thread opens and owns them), reporting on `ready` whether they opened.
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
            // Its state goes straight from Zenoh's callback (`Direct`).
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
