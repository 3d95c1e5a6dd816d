//! Local samples out to the network: the export thread reads this host's services (the
//! loop's state on its host; guidance, paths and roadmaps on a planner's) and puts what is
//! new on Zenoh, and pings the other bridges.

use crate::clock::HostClock;
use crate::frame::{Carried, Kind};
use crate::report::{Counters, bump};
use crate::session::{declare_error, declare_publisher, key, outgoing};
use crate::{BridgeConfig, BridgeError, Side, probe};
use ipc_types::services;
use ipc_types::{Guidance, Path, Roadmap, pacing};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use zenoh::Wait;
use zenoh::pubsub::Publisher;
use zenoh::qos::CongestionControl;

/// The export thread: opens its local ports and Zenoh publishers (reporting on `ready`
/// whether they opened), then until `stop`: hands on what is new locally, and pings.
pub(crate) fn export_thread(
    config: &BridgeConfig,
    session: &zenoh::Session,
    id: u64,
    counters: &Counters,
    stop: &AtomicBool,
    own_guidance_direct: bool,
    ready: std::sync::mpsc::Sender<Result<(), BridgeError>>,
) {
    let opened = Exporter::open(config, session, id, counters, own_guidance_direct);
    let (_node, mut exporter) = match opened {
        Ok(o) => {
            let _ = ready.send(Ok(()));
            o
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return;
        }
    };
    if !ipc_types::set_thread_timer_slack_ns(1_000) {
        tracing::debug!("cannot set the export thread's timer slack");
    }
    while !stop.load(Ordering::Acquire) {
        match &mut exporter.input {
            LocalIn::Loop(state) => state.once(&exporter.out),
            LocalIn::Planner(samples) => samples.once(&exporter.out),
        }
        exporter.probe_if_due();
    }
}

/// The export thread's ports and state.
struct Exporter<'a> {
    input: LocalIn,
    out: Out<'a>,
    ping: Publisher<'static>,
    probe_period: Duration,
    next_probe: Instant,
}

/// Where exported samples go: this side's publishers, in the order of its leaves.
struct Out<'a> {
    publishers: Vec<Publisher<'static>>,
    clock: HostClock,
    id: u64,
    counters: &'a Counters,
}

impl Out<'_> {
    /// Puts `v` on the `leaf`-th publisher, counting it sent or dropped (never waits).
    fn put<T: Carried>(&self, leaf: usize, v: T, kind: Kind) {
        match self.publishers[leaf]
            .put(outgoing(v, &self.clock, self.id))
            .wait()
        {
            Ok(()) => bump(&self.counters.sent, kind),
            Err(_) => bump(&self.counters.dropped, kind),
        }
    }
}

/// The export thread's local ports (one per bridge: their size does not matter).
#[allow(clippy::large_enum_variant)]
enum LocalIn {
    Loop(StateExport),
    Planner(PlannerExport),
}

impl<'a> Exporter<'a> {
    /// Opens the local ports of `config.side` and the Zenoh publishers; the node must
    /// outlive the exporter.
    fn open(
        config: &BridgeConfig,
        session: &zenoh::Session,
        id: u64,
        counters: &'a Counters,
        own_guidance_direct: bool,
    ) -> Result<(iceoryx2::node::Node<services::Ipc>, Self), BridgeError> {
        let ns = &config.namespace;
        let keys = config.keys();
        let (node, _) = services::create_node(&format!("bridge_out_{}", std::process::id()))?;
        let input = match config.side {
            Side::Loop => LocalIn::Loop(StateExport::new(
                services::StateFollower::open(&node, ns)?,
                config,
            )),
            Side::Planner => LocalIn::Planner(PlannerExport {
                listener: services::guidance_listener(&node, ns)?,
                guidance: services::subscriber::<Guidance>(&node, ns)?,
                path: services::subscriber::<Path>(&node, ns)?,
                roadmap: if config.roadmap {
                    Some(services::subscriber::<Roadmap>(&node, ns)?)
                } else {
                    None
                },
                own_guidance_direct,
                newest_path: None,
                next_path_resend: Instant::now(),
            }),
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
        let exporter = Exporter {
            input,
            out: Out {
                publishers,
                clock: config.clock,
                id,
                counters,
            },
            ping,
            probe_period: Duration::from_secs_f64(1.0 / config.probe_hz),
            next_probe: Instant::now(),
        };
        Ok((node, exporter))
    }

    /// A ping to the other bridges, `probe_hz` times a second.
    fn probe_if_due(&mut self) {
        if Instant::now() >= self.next_probe {
            self.next_probe += self.probe_period;
            let _ = self
                .ping
                .put(probe::ping(self.out.id, &self.out.clock))
                .wait();
        }
    }
}

/// The loop side: the loop's state, every new tick (or at most `state_rate_hz`).
struct StateExport {
    state: services::StateFollower,
    state_period_ns: u64,
    poll_ns: u64,
    last_seq: u64,
    last_pid: u32,
    last_sent_ns: u64,
    next_poll: u64,
    /// Phase-locked to a real-time loop's ticks (else polled every `poll_ns`).
    paced: bool,
    pacer: pacing::StatePacer,
}

impl StateExport {
    fn new(state: services::StateFollower, config: &BridgeConfig) -> Self {
        let poll_ns = config.state_poll_us.max(10) * 1_000;
        StateExport {
            state,
            state_period_ns: config.state_rate_hz.map_or(0, |r| (1e9 / r) as u64),
            poll_ns,
            last_seq: 0,
            last_pid: 0,
            last_sent_ns: 0,
            next_poll: ipc_types::monotonic_ns(),
            paced: false,
            pacer: pacing::StatePacer::sleeping(poll_ns),
        }
    }

    /// Reads the blackboard, sends a new state, and sleeps until the next read.
    fn once(&mut self, out: &Out) {
        let s = self.state.get();
        let new = s.header.sequence != 0
            && (s.header.sequence != self.last_seq || s.header.writer_pid != self.last_pid);
        if let Err(e) = self.state.after_read(new) {
            tracing::warn!("cannot follow a restarted haptic loop: {e}");
        }
        if new && s.header.writer_pid != self.last_pid {
            // Phase-lock to a real-time loop's ticks (as the planner's receiver does); a
            // loop without real-time rights ticks late and in bursts, and is polled.
            self.paced = pacing::phase_lock_to(s.header.writer_pid);
            self.pacer = pacing::StatePacer::sleeping(self.poll_ns);
        }
        let now = ipc_types::monotonic_ns();
        if new && now.wrapping_sub(self.last_sent_ns) >= self.state_period_ns {
            out.put(0, s, Kind::STATE);
            self.last_sent_ns = now;
        }
        if new {
            self.last_seq = s.header.sequence;
            self.last_pid = s.header.writer_pid;
        }
        let next = if self.paced {
            let seen = if new {
                pacing::Seen::Found {
                    sequence: s.header.sequence,
                    stamp_ns: s.header.timestamp_ns,
                }
            } else {
                pacing::Seen::Nothing
            };
            self.pacer.next_poll(ipc_types::monotonic_ns(), seen)
        } else {
            self.next_poll += self.poll_ns;
            if self.next_poll < now {
                self.next_poll = now + self.poll_ns;
            }
            self.next_poll
        };
        ipc_types::sleep_until_ns(next);
    }
}

/// A planner's side: guidance, paths (the newest again each second, for a bridge that
/// joins late) and roadmaps.
struct PlannerExport {
    listener: services::GuidanceListener,
    guidance: services::Subscriber<Guidance>,
    path: services::Subscriber<Path>,
    roadmap: Option<services::Subscriber<Roadmap>>,
    /// The planner in this process puts its own guidance on Zenoh ([`crate::run_in_planner`]).
    own_guidance_direct: bool,
    newest_path: Option<Path>,
    next_path_resend: Instant,
}

impl PlannerExport {
    /// Waits for the planner's guidance notification (at most 1 ms), then sends what is new.
    fn once(&mut self, out: &Out) {
        // Woken by the planner's notification after each guidance sample, else after a
        // millisecond for paths and roadmaps.
        if self
            .listener
            .timed_wait(|_| {}, Duration::from_millis(1))
            .is_err()
        {
            std::thread::sleep(Duration::from_millis(1));
        }
        let own_pid = std::process::id();
        while let Ok(Some(g)) = self.guidance.receive() {
            // The planner in this process has put its own on Zenoh already.
            if self.own_guidance_direct && g.header.writer_pid == own_pid {
                continue;
            }
            out.put(0, *g, Kind::GUIDANCE);
        }
        while let Ok(Some(p)) = self.path.receive() {
            out.put(1, *p, Kind::PATH);
            self.newest_path = Some(*p);
            self.next_path_resend = Instant::now() + Duration::from_secs(1);
        }
        if let Some(p) = &self.newest_path
            && Instant::now() >= self.next_path_resend
        {
            out.put(1, *p, Kind::PATH);
            self.next_path_resend = Instant::now() + Duration::from_secs(1);
        }
        if let Some(rm) = &mut self.roadmap {
            while let Ok(Some(r)) = rm.receive() {
                out.put(2, *r, Kind::ROADMAP);
            }
        }
    }
}
