//! Bare iceoryx2 baselines for the IPC latency harness (`ipc-latency`): one writer thread
//! stamps a wire type with `ipc_types::monotonic_ns` and sends it at a fixed rate; one
//! reader (in another process in the harness, a thread in the tests) records
//! `monotonic_ns() − stamp` for every new sample it sees.
//!
//! Both ends use plain iceoryx2 with default service settings on their own service name:
//! - [`Pattern::PubSub`]: `send_copy` → `receive`;
//! - [`Pattern::Blackboard`]: `update_with_copy` → `get` (our state pattern).
//!
//! The reader either spins ([`Poll::Busy`]: the transport alone) or polls at a rate with the
//! planner receiver's absolute-deadline sleeps ([`Poll::Every`]: transport plus the wait
//! for the next poll, the part a polling reader adds), its rate detuned by 0.1 % so that
//! the wait is averaged over all phases between writer and reader.
//!
//! The writer marks warm-up samples (not recorded: the first sends after a reader joins
//! rebuild connections) and a final stop sample in `header.reserved`.

use crate::BenchError;
use haptic_loop::rt::{self, RtOptions};
use haptic_loop::stats::NsHistogram;
use iceoryx2::port::reader::EntryHandle;
use iceoryx2::port::writer::EntryHandleMut;
use iceoryx2::prelude::*;
use ipc_types::{Guidance, HapticState, Header, services};
use std::time::{Duration, Instant};

/// `header.reserved` of a warm-up sample: not recorded.
pub const WARM_UP: u32 = 2;
/// `header.reserved` of the last sample: the reader stops.
pub const STOP: u32 = 1;

/// A wire type with a [`Header`].
pub trait Stamped: ZeroCopySend + Copy + Default + core::fmt::Debug + 'static {
    /// The header.
    fn header(&self) -> &Header;
    /// The header, writable.
    fn header_mut(&mut self) -> &mut Header;
}

impl Stamped for HapticState {
    fn header(&self) -> &Header {
        &self.header
    }
    fn header_mut(&mut self) -> &mut Header {
        &mut self.header
    }
}

impl Stamped for Guidance {
    fn header(&self) -> &Header {
        &self.header
    }
    fn header_mut(&mut self) -> &mut Header {
        &mut self.header
    }
}

/// Which iceoryx2 messaging pattern.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pattern {
    /// Publish-subscribe.
    PubSub,
    /// Blackboard with one entry.
    Blackboard,
}

impl Pattern {
    /// Name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Pattern::PubSub => "pubsub",
            Pattern::Blackboard => "blackboard",
        }
    }

    /// Parses [`Pattern::name`].
    pub fn parse(s: &str) -> Result<Self, BenchError> {
        match s {
            "pubsub" => Ok(Pattern::PubSub),
            "blackboard" => Ok(Pattern::Blackboard),
            _ => Err(BenchError::Pattern(s.to_owned())),
        }
    }
}

/// How the reader looks for new samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Poll {
    /// Spin on the port.
    Busy,
    /// Poll at this rate, Hz, sleeping to absolute deadlines in between.
    Every(f64),
}

/// One bare measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bare {
    /// Pattern.
    pub pattern: Pattern,
    /// Writer rate, Hz.
    pub rate_hz: f64,
    /// Reader polling.
    pub poll: Poll,
    /// Recorded seconds (after a 0.2 s warm-up).
    pub seconds: f64,
}

fn service_name(ns: &str) -> Result<ServiceName, BenchError> {
    let full = services::service_name(ns, "bare");
    full.as_str()
        .try_into()
        .map_err(BenchError::iceoryx(&format!("invalid service name {full}")))
}

/// The writing end, created before the reader opens the service.
pub enum Writer<T: Stamped> {
    /// Publisher.
    PubSub(
        iceoryx2::port::publisher::Publisher<services::Ipc, T, ()>,
        iceoryx2::service::port_factory::publish_subscribe::PortFactory<services::Ipc, T, ()>,
    ),
    /// Blackboard entry.
    Blackboard(
        EntryHandleMut<services::Ipc, u64, T>,
        iceoryx2::service::port_factory::blackboard::PortFactory<services::Ipc, u64>,
    ),
}

impl<T: Stamped> std::fmt::Debug for Writer<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Writer")
    }
}

impl<T: Stamped> Writer<T> {
    /// Creates the service `hrrtc/<ns>/bare` and its writing port.
    pub fn create(
        node: &Node<services::Ipc>,
        ns: &str,
        pattern: Pattern,
    ) -> Result<Self, BenchError> {
        let name = service_name(ns)?;
        Ok(match pattern {
            Pattern::PubSub => {
                let factory = node
                    .service_builder(&name)
                    .publish_subscribe::<T>()
                    .open_or_create()
                    .map_err(BenchError::iceoryx("bare pub/sub service"))?;
                let publisher = factory
                    .publisher_builder()
                    .create()
                    .map_err(BenchError::iceoryx("bare publisher"))?;
                Writer::PubSub(publisher, factory)
            }
            Pattern::Blackboard => {
                let factory = node
                    .service_builder(&name)
                    .blackboard_creator::<u64>()
                    .add::<T>(services::ENTRY_KEY, T::default())
                    .create()
                    .map_err(BenchError::iceoryx("bare blackboard"))?;
                let writer = factory
                    .writer_builder()
                    .create()
                    .map_err(BenchError::iceoryx("bare blackboard writer"))?;
                let entry = writer
                    .entry::<T>(&services::ENTRY_KEY)
                    .map_err(BenchError::iceoryx("bare blackboard entry"))?;
                Writer::Blackboard(entry, factory)
            }
        })
    }

    fn write(&self, value: T) -> Result<(), BenchError> {
        match self {
            Writer::PubSub(p, _) => {
                p.send_copy(value).map_err(BenchError::iceoryx("send"))?;
            }
            Writer::Blackboard(e, _) => e.update_with_copy(value),
        }
        Ok(())
    }

    /// Writes at `bare.rate_hz` for 0.2 s of warm-up, then `bare.seconds`, then one stop
    /// sample; each stamped just before it is written. Returns how many recorded samples
    /// were written (neither warm-up nor stop) and the time each write call took (stamp →
    /// return of `send_copy` / `update_with_copy`, ns), which is part of the latency.
    pub fn run(&self, bare: &Bare, rt: RtOptions) -> Result<(u64, NsHistogram), BenchError> {
        let _setup = rt::setup_current_thread(&rt);
        let period_ns = (1e9 / bare.rate_hz).round() as u64;
        let warm_up = (0.2 * bare.rate_hz) as u64;
        let total = warm_up + (bare.seconds * bare.rate_hz) as u64;
        let pid = std::process::id();
        let mut value = T::default();
        let mut write_ns = NsHistogram::new();
        let mut deadline = rt::monotonic_ns() + period_ns;
        for seq in 1..=total + 1 {
            rt::sleep_until(deadline, 0);
            deadline += period_ns;
            *value.header_mut() = Header {
                sequence: seq,
                timestamp_ns: 0,
                writer_pid: pid,
                reserved: if seq <= warm_up {
                    WARM_UP
                } else if seq > total {
                    STOP
                } else {
                    0
                },
            };
            let stamp = ipc_types::monotonic_ns();
            value.header_mut().timestamp_ns = stamp;
            self.write(value)?;
            if seq > warm_up && seq <= total {
                write_ns.record(ipc_types::monotonic_ns() - stamp);
            }
        }
        Ok((total - warm_up, write_ns))
    }
}

enum ReadPort<T: Stamped> {
    PubSub(iceoryx2::port::subscriber::Subscriber<services::Ipc, T, ()>),
    Blackboard(EntryHandle<services::Ipc, u64, T>),
}

/// The reading end.
pub struct Reader<T: Stamped> {
    port: ReadPort<T>,
}

impl<T: Stamped> std::fmt::Debug for Reader<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Reader")
    }
}

impl<T: Stamped> Reader<T> {
    /// Opens `hrrtc/<ns>/bare` (created by a [`Writer`]) and its reading port.
    pub fn open(
        node: &Node<services::Ipc>,
        ns: &str,
        pattern: Pattern,
    ) -> Result<Self, BenchError> {
        let name = service_name(ns)?;
        let port = match pattern {
            Pattern::PubSub => {
                let factory = node
                    .service_builder(&name)
                    .publish_subscribe::<T>()
                    .open_or_create()
                    .map_err(BenchError::iceoryx("bare pub/sub service"))?;
                ReadPort::PubSub(
                    factory
                        .subscriber_builder()
                        .create()
                        .map_err(BenchError::iceoryx("bare subscriber"))?,
                )
            }
            Pattern::Blackboard => {
                let factory = node
                    .service_builder(&name)
                    .blackboard_opener::<u64>()
                    .open()
                    .map_err(BenchError::iceoryx("bare blackboard"))?;
                let reader = factory
                    .reader_builder()
                    .create()
                    .map_err(BenchError::iceoryx("bare blackboard reader"))?;
                ReadPort::Blackboard(
                    reader
                        .entry::<T>(&services::ENTRY_KEY)
                        .map_err(BenchError::iceoryx("bare blackboard entry"))?,
                )
            }
        };
        Ok(Self { port })
    }

    /// The newest sample now, if any.
    fn newest(&self) -> Result<Option<T>, BenchError> {
        match &self.port {
            ReadPort::PubSub(s) => {
                let mut newest = None;
                while let Some(sample) = s.receive().map_err(BenchError::iceoryx("receive"))? {
                    newest = Some(*sample);
                }
                Ok(newest)
            }
            ReadPort::Blackboard(e) => Ok(Some(*e.get())),
        }
    }

    /// Records the age of every new sample until the stop sample or `timeout`; returns the
    /// histogram (ns). Fails on timeout.
    pub fn run(&self, poll: Poll, timeout: Duration) -> Result<NsHistogram, BenchError> {
        let mut hist = NsHistogram::new();
        let started = Instant::now();
        let mut last_seq = 0u64;
        let period = match poll {
            Poll::Busy => None,
            // Detuned by 0.1 %: the poll phase sweeps uniformly relative to the writer's
            // (with commensurate rates the phase would stay where the two happened to
            // start, and the figure would depend on it).
            Poll::Every(hz) => Some(Duration::from_secs_f64(1.001 / hz)),
        };
        let mut next = Instant::now();
        loop {
            if let Some(v) = self.newest()? {
                let h = *v.header();
                if h.sequence != 0 && h.sequence != last_seq {
                    last_seq = h.sequence;
                    match h.reserved {
                        STOP => return Ok(hist),
                        WARM_UP => {}
                        _ => hist.record(ipc_types::monotonic_ns().saturating_sub(h.timestamp_ns)),
                    }
                }
            }
            if started.elapsed() > timeout {
                return Err(BenchError::NoStop(timeout));
            }
            match period {
                None => std::hint::spin_loop(),
                Some(p) => {
                    next += p;
                    let now = Instant::now();
                    if next > now {
                        std::thread::sleep(next - now);
                    } else {
                        next = now;
                    }
                }
            }
        }
    }
}

/// The reader of a bare measurement in this process (the harness's child process):
/// opens, prints `ready` on stdout, records, returns the histogram.
pub fn read<T: Stamped>(ns: &str, pattern: Pattern, poll: Poll) -> Result<NsHistogram, BenchError> {
    use std::io::Write;
    let (node, _) = services::create_node(&format!("bare_rx_{}", std::process::id()))?;
    let reader = Reader::<T>::open(&node, ns, pattern)?;
    println!("ready");
    std::io::stdout().flush()?;
    reader.run(poll, Duration::from_secs(3600))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bare(pattern: Pattern, poll: Poll) -> (u64, NsHistogram) {
        let ns = format!("bare_test_{}_{}", pattern.name(), std::process::id());
        let (node, _) = services::create_node("bare_test").unwrap();
        let writer = Writer::<HapticState>::create(&node, &ns, pattern).unwrap();
        let spec = Bare {
            pattern,
            rate_hz: 1000.0,
            poll,
            seconds: 0.1,
        };
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        // iceoryx2 ports are not Send: the reader opens its own on its thread.
        let rx = std::thread::spawn(move || {
            let (node, _) = services::create_node("bare_test_rx").unwrap();
            let reader = Reader::<HapticState>::open(&node, &ns, pattern).unwrap();
            ready_tx.send(()).unwrap();
            reader.run(poll, Duration::from_secs(20)).unwrap()
        });
        ready_rx.recv().unwrap();
        let rt = RtOptions {
            fifo_priority: None,
            cpu: None,
            lock_memory: false,
            cpu_latency_us: None,
        };
        let (sent, write_ns) = writer.run(&spec, rt).unwrap();
        assert_eq!(write_ns.percentiles_us().count, sent);
        (sent, rx.join().unwrap())
    }

    #[test]
    fn busy_pubsub_records_every_sample_but_warm_up_and_stop() {
        let (sent, hist) = bare(Pattern::PubSub, Poll::Busy);
        assert_eq!(sent, 100);
        // Pub/sub delivers every sample (the buffer holds more than one period's worth of
        // lateness only if the reader is starved; a spinning reader on a quiet core keeps up,
        // and a starved one loses samples, never invents them).
        let p = hist.percentiles_us();
        assert!(p.count <= sent && p.count > 0, "{p:?}");
        assert!(p.p50 <= p.max && p.max < 20_000_000.0, "{p:?}");
    }

    #[test]
    fn polled_blackboard_sees_at_most_what_was_written() {
        let (sent, hist) = bare(Pattern::Blackboard, Poll::Every(500.0));
        let p = hist.percentiles_us();
        // Polling at half the write rate sees at most every other sample.
        assert!(p.count > 0 && p.count <= sent / 2 + 1, "{p:?} of {sent}");
    }
}
