//! What the soak sees of the loop from outside, as a planner would: an observer thread
//! polling the loop's `HapticState` at 2 kHz (new states, the longest gap between two,
//! guidance lost and back, faults) and reading the loop's guidance service, which carries
//! every planner's samples to the loop's relay (each planner's first sample and first fresh
//! one, and the first tick that rendered its guidance).

use super::SoakError;
use ipc_types::services::{self, StateReader, Subscriber};
use ipc_types::{FaultCode, Guidance, GuidanceFreshness};
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// What one planner process's guidance did on the loop's host.
#[derive(Debug, Clone, Copy)]
pub struct PlannerSeen {
    /// The `writer_pid` of its samples.
    pub pid: u32,
    /// When its first sample arrived within its time-to-live (fresh, as the relay takes it).
    pub first_fresh: Option<Instant>,
    /// When the loop first rendered one of its samples, fresh.
    pub first_rendered: Option<Instant>,
    /// Its newest sample's distance of its start tree to the goal (what the relay's choice
    /// compares).
    pub distance_to_goal: f64,
    /// Samples received.
    pub samples: u64,
}

/// Everything seen so far.
#[derive(Debug, Clone, Default)]
pub struct Seen {
    /// The newest state's tick number.
    pub ticks: u64,
    /// The loop's deadline misses, from its newest state.
    pub deadline_misses: u64,
    /// Longest time between two new states, ms (the observer polls every 0.5 ms).
    pub longest_state_gap_ms: f64,
    /// Times the loop's guidance went from fresh to lost.
    pub guidance_lost: u64,
    /// Times it came back (lost to fresh).
    pub guidance_back: u64,
    /// Longest time from lost to fresh again, ms.
    pub longest_lost_ms: f64,
    /// When a state last showed fresh guidance.
    pub last_fresh: Option<Instant>,
    /// The planner whose guidance the loop rendered last (pid), when it could be told.
    pub rendering: Option<u32>,
    /// Distinct faults seen in the states (code and name), start-up excluded.
    pub faults: Vec<String>,
    /// Every planner heard from, in order of its first sample.
    pub planners: Vec<PlannerSeen>,
}

impl Seen {
    /// What was seen of the planner with process id `pid`.
    pub fn planner(&self, pid: u32) -> Option<&PlannerSeen> {
        self.planners.iter().find(|p| p.pid == pid)
    }
}

/// The observer thread; stopped when dropped.
pub struct Watch {
    stop: Arc<AtomicBool>,
    seen: Arc<Mutex<Seen>>,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for Watch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Watch").finish_non_exhaustive()
    }
}

/// Guidance samples kept to tell which planner wrote the sequence number a state names.
const RECENT: usize = 1024;

fn lock(seen: &Mutex<Seen>) -> MutexGuard<'_, Seen> {
    seen.lock().unwrap_or_else(|p| p.into_inner())
}

impl Watch {
    /// Starts watching namespace `ns`, whose state blackboard must exist (the loop runs).
    pub fn start(ns: &str) -> Result<Self, SoakError> {
        let stop = Arc::new(AtomicBool::new(false));
        let seen = Arc::new(Mutex::new(Seen::default()));
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let thread = {
            let (ns, stop, seen) = (ns.to_owned(), stop.clone(), seen.clone());
            std::thread::Builder::new()
                .name("soak-watch".into())
                .spawn(move || {
                    // iceoryx2 ports are not Send: made on this thread.
                    let ports =
                        services::create_node(&format!("soak_watch_{}", std::process::id()))
                            .and_then(|(node, _)| {
                                let state = services::state_reader(&node, &ns)?;
                                let guidance = services::subscriber::<Guidance>(&node, &ns)?;
                                Ok((node, state, guidance))
                            });
                    let (_node, state, guidance) = match ports {
                        Ok(p) => {
                            let _ = ready_tx.send(Ok(()));
                            p
                        }
                        Err(e) => {
                            let _ = ready_tx.send(Err(e));
                            return;
                        }
                    };
                    observe(&state, &guidance, &stop, &seen);
                })
                .map_err(|error| SoakError::Start {
                    what: "the observer thread".into(),
                    error,
                })?
        };
        match ready_rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(e.into()),
            Err(_) => {
                return Err(SoakError::Setup {
                    what: "the observer thread".into(),
                    reason: "it ended during set-up".into(),
                });
            }
        }
        Ok(Watch {
            stop,
            seen,
            thread: Some(thread),
        })
    }

    /// A copy of what was seen so far.
    pub fn seen(&self) -> Seen {
        lock(&self.seen).clone()
    }

    /// Stops the thread; what it saw.
    pub fn finish(mut self) -> Seen {
        self.halt();
        self.seen()
    }

    fn halt(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        self.halt();
    }
}

/// The observer's loop: every 0.5 ms, the guidance that arrived and the newest state.
fn observe(
    state: &StateReader,
    guidance: &Subscriber<Guidance>,
    stop: &AtomicBool,
    seen: &Mutex<Seen>,
) {
    let mut recent: VecDeque<(u64, u32)> = VecDeque::with_capacity(RECENT);
    let (mut last_seq, mut last_new) = (0u64, Instant::now());
    let mut was_fresh = false;
    let mut lost_at: Option<Instant> = None;
    while !stop.load(Ordering::Acquire) {
        let now = Instant::now();
        let now_ns = ipc_types::monotonic_ns();
        let mut s = lock(seen);
        while let Ok(Some(sample)) = guidance.receive() {
            let g = *sample;
            let pid = g.header.writer_pid;
            if recent.len() == RECENT {
                recent.pop_front();
            }
            recent.push_back((g.header.sequence, pid));
            let fresh = now_ns.saturating_sub(g.header.timestamp_ns) <= g.time_to_live_ns;
            match s.planners.iter_mut().find(|p| p.pid == pid) {
                Some(p) => {
                    p.samples += 1;
                    p.distance_to_goal = g.distance_to_goal;
                    if fresh && p.first_fresh.is_none() {
                        p.first_fresh = Some(now);
                    }
                }
                None => s.planners.push(PlannerSeen {
                    pid,
                    first_fresh: fresh.then_some(now),
                    first_rendered: None,
                    distance_to_goal: g.distance_to_goal,
                    samples: 1,
                }),
            }
        }
        let st = *state.get();
        if st.header.sequence != last_seq {
            if last_seq != 0 {
                let gap = now.duration_since(last_new).as_secs_f64() * 1e3;
                s.longest_state_gap_ms = s.longest_state_gap_ms.max(gap);
            }
            last_seq = st.header.sequence;
            last_new = now;
            s.ticks = st.header.sequence;
            s.deadline_misses = st.deadline_misses;
            if st.fault != FaultCode::NONE && st.fault != FaultCode::STARTUP {
                let name = format!("{} ({})", st.fault.0, st.fault.name());
                if !s.faults.contains(&name) {
                    s.faults.push(name);
                }
            }
            match st.guidance_freshness {
                GuidanceFreshness::FRESH => {
                    if let Some(t) = lost_at.take() {
                        s.guidance_back += 1;
                        let ms = now.duration_since(t).as_secs_f64() * 1e3;
                        s.longest_lost_ms = s.longest_lost_ms.max(ms);
                    }
                    was_fresh = true;
                    s.last_fresh = Some(now);
                    // The writer of the sequence rendered, if only one planner sent it lately.
                    let mut writers = recent
                        .iter()
                        .filter(|(seq, _)| *seq == st.guidance_sequence)
                        .map(|(_, pid)| *pid);
                    if let Some(pid) = writers.next()
                        && writers.all(|other| other == pid)
                    {
                        s.rendering = Some(pid);
                        if let Some(p) = s.planners.iter_mut().find(|p| p.pid == pid)
                            && p.first_rendered.is_none()
                        {
                            p.first_rendered = Some(now);
                        }
                    }
                }
                GuidanceFreshness::LOST if was_fresh => {
                    was_fresh = false;
                    s.guidance_lost += 1;
                    lost_at = Some(now);
                }
                _ => {}
            }
        }
        drop(s);
        std::thread::sleep(Duration::from_micros(500));
    }
}
