//! The guidance relay: a non-RT thread that receives [`Guidance`] from the planner over
//! iceoryx2 publish-subscribe and hands the newest sample to the RT thread through a
//! lock-free triple buffer.
//!
//! Why a relay: `Subscriber::receive()` rebuilds its connections, allocating, when a
//! publisher appears or vanishes, i.e. whenever a planner (re)starts. That must not happen on
//! the RT thread. The relay absorbs it; the RT thread only swaps a triple-buffer index.
//! The relay sleeps on the planner's guidance event (`services::GUIDANCE_EVENT`), so a new
//! sample reaches the triple buffer microseconds after it was sent and is rendered by the
//! next tick; it also wakes every `poll` (default 1 ms) on its own, so a planner that does
//! not notify, or a lost notification, costs at most that.
//!
//! Several planners may publish at once (one service, many publishers): the relay follows
//! one of them, chosen by [`choice::PlannerChoice`], and hands on only its samples.

pub mod choice;

use crate::Error;
use crate::tick::GuidanceSource;
use ipc_types::Guidance;
use ipc_types::services;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// The RT side of the relay: reads the newest sample without allocating or blocking.
#[derive(Debug)]
pub struct RelayOutput(triple_buffer::Output<Guidance>);

impl GuidanceSource for RelayOutput {
    #[inline]
    fn latest(&mut self) -> Guidance {
        *self.0.read()
    }
}

/// The non-RT side: the relay thread and what it shares with observers.
#[derive(Debug)]
pub struct Relay {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    newest: Arc<Mutex<Guidance>>,
    switches: Arc<AtomicU64>,
}

impl Relay {
    /// How often the haptic loop's relay polls for guidance: a sample waits at most this
    /// long before the RT thread can render it.
    pub const LOOP_POLL: Duration = Duration::from_millis(1);

    /// Starts the relay thread on `namespace`. Fails if the iceoryx2 subscriber cannot be
    /// created (the error names the service).
    pub fn spawn(namespace: &str, poll: Duration) -> Result<(Relay, RelayOutput), Error> {
        let (mut input, output) = triple_buffer::triple_buffer(&Guidance::default());
        let stop = Arc::new(AtomicBool::new(false));
        let newest = Arc::new(Mutex::new(Guidance::default()));
        let switches = Arc::new(AtomicU64::new(0));
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let thread = {
            let namespace = namespace.to_string();
            let stop = stop.clone();
            let newest = newest.clone();
            let switches = switches.clone();
            std::thread::Builder::new()
                .name("guidance-relay".into())
                .spawn(move || {
                    // iceoryx2 ports are not Send: create them on this thread.
                    let sub =
                        services::create_node(&format!("haptic_relay_{}", std::process::id()))
                            .and_then(|(node, _)| {
                                let sub =
                                    services::subscriber::<ipc_types::Guidance>(&node, &namespace)?;
                                let listener = services::guidance_listener(&node, &namespace)?;
                                Ok((sub, listener, node))
                            });
                    let (sub, listener, _node) = match sub {
                        Ok(s) => {
                            let _ = ready_tx.send(Ok(()));
                            s
                        }
                        Err(e) => {
                            let _ = ready_tx.send(Err(e));
                            return;
                        }
                    };
                    let mut choice = choice::PlannerChoice::default();
                    let mut handed_on: Option<(u32, u32, u64)> = None;
                    while !stop.load(Ordering::Acquire) {
                        let mut latest = None;
                        loop {
                            match sub.receive() {
                                Ok(Some(sample)) => {
                                    let g = *sample;
                                    if g.validate().is_err() {
                                        // The RT filter rejects and counts it, keeping the
                                        // last valid sample.
                                        latest = Some(g);
                                        continue;
                                    }
                                    let now = ipc_types::monotonic_ns();
                                    if let Some(pick) = choice.offer(g, now) {
                                        latest = Some(pick);
                                    }
                                }
                                Ok(None) => break,
                                Err(e) => {
                                    tracing::warn!("guidance relay: receive failed: {e:?}");
                                    break;
                                }
                            }
                        }
                        if let Some(g) = latest {
                            let id = (g.planner_id, g.header.writer_pid, g.header.sequence);
                            if handed_on != Some(id) || g.validate().is_err() {
                                handed_on = Some(id);
                                input.write(g);
                                *newest.lock().unwrap_or_else(|p| p.into_inner()) = g;
                            }
                        }
                        switches.store(choice.switches(), Ordering::Relaxed);
                        // Woken by the planner's notification or after `poll`; a failed
                        // wait (e.g. an interrupting signal) falls back to sleeping.
                        if listener.timed_wait(|_| {}, poll).is_err() {
                            std::thread::sleep(poll);
                        }
                    }
                })
                .map_err(|e| Error::Thread {
                    thread: "guidance relay",
                    reason: e.to_string(),
                })?
        };
        ready_rx.recv().map_err(|_| Error::Thread {
            thread: "guidance relay",
            reason: "it died during set-up".into(),
        })??;
        Ok((
            Relay {
                stop,
                thread: Some(thread),
                newest,
                switches,
            },
            RelayOutput(output),
        ))
    }

    /// The newest sample the relay has seen (for progress lines and summaries).
    pub fn newest(&self) -> Guidance {
        *self.newest.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Times the relay moved from one planner's guidance to another's.
    pub fn planner_switches(&self) -> u64 {
        self.switches.load(Ordering::Relaxed)
    }

    /// A handle observers on other threads can read the newest sample from.
    pub fn observer(&self) -> Arc<Mutex<Guidance>> {
        self.newest.clone()
    }
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Instant;

    #[test]
    fn the_planners_notification_wakes_the_relay_before_its_poll() {
        let ns = format!("relay_wake_{}", std::process::id());
        // A poll period far longer than the wait below: only the event can deliver in time.
        let (relay, mut output) = Relay::spawn(&ns, Duration::from_secs(30)).unwrap();
        let (node, _) = services::create_node("relay_wake_planner").unwrap();
        let publisher = services::publisher::<ipc_types::Guidance>(&node, &ns).unwrap();
        let event = services::guidance_notifier(&node, &ns).unwrap();
        // Let the relay enter its wait (it received nothing yet: no publisher existed).
        std::thread::sleep(Duration::from_millis(200));
        let mut g = Guidance::default();
        g.header.sequence = 7;
        publisher.send_copy(g).unwrap();
        event.notify().unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        while output.latest().header.sequence != 7 {
            assert!(
                Instant::now() < deadline,
                "the relay did not wake on the guidance event"
            );
            std::thread::sleep(Duration::from_millis(5));
        }
        assert_eq!(relay.newest().header.sequence, 7);
    }
}
