//! The receiver thread: reads the haptic state blackboard phase-locked to the loop's ticks
//! ([`super::pacing::StatePacer`]) and keeps the newest operator state for the planning
//! thread, with what it counted and measured on the way.

use super::pacing::{Seen, StatePacer, phase_lock_to};
use ipc_types::HapticState;
use ipc_types::services;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// The newest operator state as seen by the receiver thread.
#[derive(Debug, Default, Clone, Copy)]
pub(super) struct Operator {
    pub(super) state: Option<HapticState>,
    /// `Instant` of the last new state, for staleness.
    pub(super) seen_at: Option<Instant>,
    pub(super) received: u64,
    pub(super) skipped: u64,
    pub(super) rejected: u64,
    pub(super) first_at: Option<Instant>,
    pub(super) last_at: Option<Instant>,
    /// Times the receiver switched to a restarted loop's state.
    pub(super) loop_generations: u64,
}

impl Operator {
    /// When the newest state came, if less than `timeout_s` before `now`: else there is no
    /// operator to follow.
    pub(super) fn fresh_seen_at(&self, now: Instant, timeout_s: f64) -> Option<Instant> {
        self.seen_at
            .filter(|t| now.saturating_duration_since(*t).as_secs_f64() < timeout_s)
    }
}

pub(super) fn lock(m: &Mutex<Operator>) -> std::sync::MutexGuard<'_, Operator> {
    // The receiver never panics while holding the lock; recover the data if it ever did.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// What the state receiver measured (see [`super::ShellReport`]'s `state_latency_us` and
/// `state_age_us`).
pub(super) struct StateLatency {
    pub(super) transport: ipc_types::latency::NsHistogram,
    pub(super) age: ipc_types::latency::NsHistogram,
}

pub(super) fn receive_states(
    mut source: services::StateFollower,
    operator: Arc<Mutex<Operator>>,
    stop: &AtomicBool,
    poll_ns: u64,
    spin_ns: u64,
) -> StateLatency {
    let mut latency = StateLatency {
        transport: ipc_types::latency::NsHistogram::new(),
        age: ipc_types::latency::NsHistogram::new(),
    };
    let mut last_seq = 0u64;
    let mut last_pid = 0u32;
    let mut pacer = StatePacer::sleeping(poll_ns);
    // Phase-lock and spin only for a loop with a real-time thread in another process
    // (decided per loop, below; `phase_lock_to` says why not for a bridge in this one). Spinning on a CPU that a loop without real-time rights waits for costs it its
    // deadlines (measured: 370–500 instead of ~800 ticks/s at normal priority on 2 cores),
    // and such a loop's ticks come late and in bursts that a once-per-tick receiver misses:
    // for it the receiver polls at `poll_ns` instead.
    let mut real_time = false;
    let mut spin = false;
    // The state now read came while the thread watched for it (woke before the write).
    let mut came = false;
    // The pacer aims within microseconds; the default 50 µs timer slack would blur that.
    if !ipc_types::set_thread_timer_slack_ns(1_000) {
        tracing::debug!("cannot set the receiver's timer slack; its polls may be up to 50 µs late");
    }
    while !stop.load(Ordering::Acquire) {
        let s = source.get();
        let seq = s.header.sequence;
        let restarted = s.header.writer_pid != last_pid;
        let new_state = seq != 0 && (seq != last_seq || restarted);
        match source.after_read(new_state) {
            Ok(Some(generation)) => {
                tracing::info!(
                    "following the haptic state of a new loop (generation {generation})"
                );
                lock(&operator).loop_generations += 1;
            }
            Ok(None) => {}
            Err(e) => tracing::warn!("cannot follow a restarted haptic loop: {e}"),
        }
        if new_state && restarted {
            real_time = phase_lock_to(s.header.writer_pid);
            spin = spin_ns > 0 && real_time;
            pacer = if spin {
                StatePacer::spinning(poll_ns)
            } else {
                StatePacer::sleeping(poll_ns)
            };
            tracing::debug!(
                "haptic loop pid {}: {}",
                s.header.writer_pid,
                match (real_time, spin) {
                    (true, true) => "real-time: phase-locked, spinning for each state",
                    (true, false) => "real-time: phase-locked",
                    (false, _) => "not real-time, not visible or this process's bridge: polled",
                }
            );
        }
        if new_state {
            let now = ipc_types::monotonic_ns();
            latency
                .age
                .record(now.saturating_sub(s.header.timestamp_ns));
            // A loop older than the stamp publishes 0: nothing to measure.
            if s.published_ns != 0 {
                latency.transport.record(now.saturating_sub(s.published_ns));
            }
            let now = Instant::now();
            let mut op = lock(&operator);
            if !restarted && seq > last_seq + 1 && last_seq != 0 {
                op.skipped += seq - last_seq - 1;
            }
            if s.user_pose.is_valid() {
                op.state = Some(s);
                op.seen_at = Some(now);
            } else {
                op.rejected += 1;
            }
            op.received += 1;
            op.first_at.get_or_insert(now);
            op.last_at = Some(now);
            last_seq = seq;
            last_pid = s.header.writer_pid;
        }
        let seen = match (new_state, came) {
            (false, _) => Seen::Nothing,
            (true, false) => Seen::Found {
                sequence: seq,
                stamp_ns: s.header.timestamp_ns,
            },
            (true, true) => Seen::Came {
                sequence: seq,
                stamp_ns: s.header.timestamp_ns,
            },
        };
        let now = ipc_types::monotonic_ns();
        let next = if real_time {
            pacer.next_poll(now, seen)
        } else {
            now + poll_ns
        };
        ipc_types::sleep_until_ns(next);
        came = false;
        if spin && pacer.predicted() && source.get().header.sequence == seq {
            // Woken before the write (the pacer aims so four times in five): watch the
            // entry until the state comes or the window closes, and read it within about a
            // microsecond of its write.
            let end = ipc_types::monotonic_ns() + spin_ns;
            while source.get().header.sequence == seq && ipc_types::monotonic_ns() < end {
                std::hint::spin_loop();
            }
            came = true;
        }
    }
    latency
}
