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
//!
//! The parts: `config` (what a bridge is told), `session` (the Zenoh session and its
//! keys), `probe` (round trips between bridges), `direct` (the paths from Zenoh's
//! callbacks straight into local services), `import` and `export` (the two threads that
//! own the other iceoryx2 ports), `report` (counts).

mod access;
pub mod certs;
pub mod clock;
mod config;
mod direct;
mod export;
pub mod frame;
mod import;
mod probe;
mod report;
mod session;

pub use config::{BridgeConfig, BridgeError, Side};
pub use direct::GuidanceSender;
pub use report::{BridgeReport, KindReport};
pub use session::key;
pub use zenoh_session::{Refusals, Security, SecurityArgs, TlsFiles, refusal_counter};

use clock::PeerDelays;
use report::Counters;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use zenoh::Wait;

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

fn run_inner(
    config: &BridgeConfig,
    stop: Arc<AtomicBool>,
    guidance_sender: Option<std::sync::mpsc::Sender<GuidanceSender>>,
) -> Result<BridgeReport, BridgeError> {
    // 1. The settings, then the session.
    config.validate()?;
    let started = Instant::now();
    let session = session::open_session(config)?;
    let id = session::session_id(&session);
    let counters = Arc::new(Counters::default());
    let delays = Arc::new(Mutex::new(PeerDelays::default()));
    // 2. Probes: answer others' pings at once (on Zenoh's thread), time our own.
    let probes = probe::Probes::declare(&session, config.keys(), id, config.clock, &delays)?;
    // 3. The direct path of this side: guidance into the loop's relay, or the state into
    //    the planner host's blackboard, from Zenoh's callback (no thread to wake).
    let direct = direct::Direct::declare(config, &counters, &delays, &session)?;
    // 4. The import and export threads, which own the other ports (they are not `Send`);
    //    both report whether their ports opened.
    let (ready_tx, ready_rx) = std::sync::mpsc::channel::<Result<(), BridgeError>>();
    let import = import::Import::start(
        config,
        &session,
        &counters,
        &delays,
        &stop,
        ready_tx.clone(),
    )?;
    let export = {
        let stop = stop.clone();
        let counters = counters.clone();
        let config = config.clone();
        let session = session.clone();
        let own_guidance_direct = guidance_sender.is_some();
        spawn("export", move || {
            export::export_thread(
                &config,
                &session,
                id,
                &counters,
                &stop,
                own_guidance_direct,
                ready_tx,
            )
        })?
    };
    let mut setup = threads_ready(&ready_rx);
    // 5. A planner running its bridge in-process gets its guidance publisher.
    if setup.is_ok()
        && let Some(out) = guidance_sender
    {
        setup = session::declare_publisher(&session, config.keys(), "guidance").map(|p| {
            let _ = out.send(GuidanceSender {
                publisher: Arc::new(p),
                clock: config.clock,
                id,
                counters: counters.clone(),
            });
        });
    }
    // 6. Run until stopped, with a progress line every 5 s.
    if setup.is_ok() {
        tracing::info!(
            "bridge {id:016x} ({} side) on namespace '{}', keys hrrtc/{}/: listening on {:?}, connected to {:?}",
            config.side.name(),
            config.namespace,
            config.keys(),
            config.listen,
            config.connect
        );
        run_until_stopped(config, &stop, &counters, &delays, started);
    }
    // 7. Down in order: the threads, then the subscribers before the ports they feed.
    stop.store(true, Ordering::Release);
    import.close();
    let _ = export.join();
    drop(direct);
    drop(probes);
    let _ = session.close().wait();
    setup?;
    Ok(report::report(&counters, &delays, started))
}

/// Waits for the import and export threads' reports on opening their ports: the first
/// error, if any.
fn threads_ready(
    ready: &std::sync::mpsc::Receiver<Result<(), BridgeError>>,
) -> Result<(), BridgeError> {
    let mut setup = Ok(());
    for _ in 0..2 {
        match ready.recv() {
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
    setup
}

/// Sleeps until `stop` is set or `config.duration_s` has passed since `started`, logging
/// the counts every 5 s.
fn run_until_stopped(
    config: &BridgeConfig,
    stop: &AtomicBool,
    counters: &Counters,
    delays: &Mutex<PeerDelays>,
    started: Instant,
) {
    let mut next_log = Instant::now() + Duration::from_secs(5);
    // Refusals (peers Zenoh kept out) are warned of when they grow, at most once a second.
    let (mut refused, mut refusal_warned) = (zenoh_session::Refusals::now(), None::<Instant>);
    while !stop.load(Ordering::Acquire) {
        let now_refused = zenoh_session::Refusals::now();
        if now_refused != refused && refusal_warned.is_none_or(|t| t.elapsed().as_secs_f64() >= 1.0)
        {
            tracing::warn!("kept out since start: {now_refused}");
            (refused, refusal_warned) = (now_refused, Some(Instant::now()));
        }
        if config
            .duration_s
            .is_some_and(|d| started.elapsed().as_secs_f64() >= d)
        {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
        if Instant::now() >= next_log {
            next_log += Duration::from_secs(5);
            report::log_progress(&report::report(counters, delays, started));
        }
    }
}

/// The mutex's value, also after a panic elsewhere poisoned it (counts and clocks stay
/// usable).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Starts the bridge's `thread` (named `bridge-<thread>`).
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
