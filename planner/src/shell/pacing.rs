//! When the planner's receiver thread polls the haptic state: phase-locked to the loop's
//! ticks instead of at a fixed rate.
//!
//! The haptic loop writes its state into a blackboard once per tick, stamped with the tick's
//! wake-up time (`header.timestamp_ns`), and wakes nobody: its RT thread makes no system call
//! beyond the clock and the device (see `ipc_types::services` for why an iceoryx2 event is
//! not notified from it). A reader polling at a fixed rate therefore waits half a poll period
//! on average. [`StatePacer`] instead predicts when the next state becomes readable — the
//! loop's next on-time tick (its grid: a loop never wakes early, so the earliest stamps,
//! projected by whole periods, mark it) plus some `delay` (its wake-up latency and the
//! compute before the write) — and sleeps until then. A first poll that finds
//! the new state shortens `delay` a little; one that does not lengthens it more and polls
//! again [`RETRY_NS`] later. So `delay` settles where about four first polls in five
//! succeed, and a state is read a few microseconds after it was written, with about one
//! wake-up per tick. Without new states (no loop yet, a stopped or dead loop) it polls at
//! the fallback rate.
//!
//! Pure logic on `CLOCK_MONOTONIC` nanoseconds passed in, so it is tested without clocks.

/// Wait before polling again when the predicted poll found nothing new, ns.
pub const RETRY_NS: u64 = 10_000;
/// How much a first poll that succeeded shortens the delay, ns.
const STEP_DOWN_NS: u64 = 1_000;
/// How much a first poll that failed lengthens the delay, ns (4 × [`STEP_DOWN_NS`]: the delay
/// settles where 4 first polls in 5 succeed).
const STEP_UP_NS: u64 = 4_000;
/// Longest tick period the pacer locks onto, ns (slower loops are polled at the fallback).
const MAX_PERIOD_NS: u64 = 100_000_000;

/// Decides the time of the receiver's next poll. See the module docs.
#[derive(Debug, Clone)]
pub struct StatePacer {
    fallback_ns: u64,
    /// The loop's tick period, estimated from the stamps since the anchor (ns).
    period_ns: Option<u64>,
    /// The first state seen from this loop: sequence and stamp (ns).
    anchor_sequence: u64,
    anchor_stamp_ns: u64,
    /// Stamp → readable, as learnt (ns).
    delay_ns: u64,
    last_sequence: u64,
    last_stamp_ns: u64,
    /// A tick time of the loop's on-time grid near the last stamp, ns.
    grid_ns: u64,
    /// The poll now pending was predicted (not a fallback poll).
    predicted: bool,
    /// Polls since the prediction that found nothing new.
    retries: u32,
}

impl StatePacer {
    /// A pacer that polls every `fallback_ns` until it has locked onto a loop.
    pub fn new(fallback_ns: u64) -> Self {
        Self {
            fallback_ns: fallback_ns.max(1),
            period_ns: None,
            anchor_sequence: 0,
            anchor_stamp_ns: 0,
            delay_ns: 0,
            last_sequence: 0,
            last_stamp_ns: 0,
            grid_ns: 0,
            predicted: false,
            retries: 0,
        }
    }

    /// The loop's tick period as estimated, ns.
    pub fn period_ns(&self) -> Option<u64> {
        self.period_ns
    }

    /// Whether the pending poll was predicted from the loop's ticks (not a fallback or a
    /// retry poll): the one worth a short spin.
    pub fn predicted(&self) -> bool {
        self.predicted && self.retries == 0
    }

    /// The learnt delay from a state's stamp to when it can be read, ns.
    pub fn delay_ns(&self) -> u64 {
        self.delay_ns
    }

    /// After a poll at `now_ns` that found a new state (`Some((sequence, stamp_ns))`) or
    /// nothing new (`None`): when to poll next (absolute ns, never before `now_ns`).
    pub fn next_poll(&mut self, now_ns: u64, new_state: Option<(u64, u64)>) -> u64 {
        let Some((sequence, stamp_ns)) = new_state else {
            return self.nothing_new(now_ns);
        };
        if self.predicted {
            if self.retries == 0 {
                self.delay_ns = self.delay_ns.saturating_sub(STEP_DOWN_NS);
            } else {
                self.delay_ns += STEP_UP_NS;
            }
        }
        if self.anchor_sequence == 0
            || sequence <= self.last_sequence
            || stamp_ns <= self.last_stamp_ns
        {
            // The first state, or a new loop (its sequence starts again): relearn.
            self.anchor_sequence = sequence;
            self.anchor_stamp_ns = stamp_ns;
            self.period_ns = None;
            self.grid_ns = 0;
        } else {
            // The mean period since the anchor: a late wake-up's error shrinks with every
            // tick, and skipped states (gaps in the sequence) need no special case.
            let p = (stamp_ns - self.anchor_stamp_ns) / (sequence - self.anchor_sequence);
            self.period_ns = (p > 0 && p <= MAX_PERIOD_NS).then_some(p);
        }
        self.last_sequence = sequence;
        self.last_stamp_ns = stamp_ns;
        self.retries = 0;
        match self.period_ns {
            Some(p) => {
                self.follow_grid(stamp_ns, p);
                // The delay never grows past a period: then the prediction is useless and
                // the fallback does as well.
                self.delay_ns = self.delay_ns.min(p);
                self.predicted = true;
                (self.grid_ns + p + self.delay_ns).max(now_ns)
            }
            None => {
                self.predicted = false;
                now_ns + self.fallback_ns
            }
        }
    }

    /// Moves the grid estimate to the tick of `stamp_ns`: one whole number of periods on,
    /// then down to the stamp if it came earlier (less late) than the estimate, else a
    /// 1/64 step up toward it (so an error in the period or one early outlier cannot keep
    /// the estimate off for long).
    fn follow_grid(&mut self, stamp_ns: u64, p: u64) {
        if self.grid_ns == 0 || self.grid_ns > stamp_ns + p {
            self.grid_ns = stamp_ns;
            return;
        }
        let periods = (stamp_ns + p / 2 - self.grid_ns) / p;
        let on_time = self.grid_ns + periods * p;
        self.grid_ns = if stamp_ns <= on_time {
            stamp_ns
        } else {
            on_time + (stamp_ns - on_time) / 64
        };
    }

    fn nothing_new(&mut self, now_ns: u64) -> u64 {
        match self.period_ns {
            // Still within the tick the state was predicted for: look again shortly.
            Some(p) if self.predicted && now_ns < self.last_stamp_ns + 2 * p => {
                self.retries += 1;
                now_ns + RETRY_NS.min(p)
            }
            _ => {
                self.predicted = false;
                now_ns + self.fallback_ns
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;
    const US: u64 = 1_000;

    /// A loop ticking every 1 ms from `t0`, each state readable `visible_after(k)` after
    /// its stamp; a reader woken `wake_late` after each poll time. Returns the read latency
    /// (read − stamp) of each state and the number of polls.
    fn run(
        ticks: u64,
        stamp_jitter: impl Fn(u64) -> u64,
        visible_after: impl Fn(u64) -> u64,
        wake_late: u64,
    ) -> (Vec<u64>, u64) {
        let mut pacer = StatePacer::new(MS / 2);
        let t0 = 10 * MS;
        let stamp = |k: u64| t0 + k * MS + stamp_jitter(k);
        let readable = |k: u64| stamp(k) + visible_after(k);
        let mut latencies = Vec::new();
        let mut polls = 0;
        let mut last_read = 0u64; // the newest sequence read (k + 1)
        let mut t = 0u64;
        while t < t0 + ticks * MS {
            polls += 1;
            // The newest state readable at t.
            let newest = (0..ticks).rev().find(|&k| readable(k) <= t);
            let new_state = match newest {
                Some(k) if k + 1 > last_read => {
                    latencies.push(t - stamp(k));
                    last_read = k + 1;
                    Some((k + 1, stamp(k)))
                }
                _ => None,
            };
            t = pacer.next_poll(t, new_state) + wake_late;
        }
        (latencies, polls)
    }

    fn median(v: &mut [u64]) -> u64 {
        v.sort_unstable();
        v[v.len() / 2]
    }

    #[test]
    fn locks_onto_the_ticks_and_reads_each_state_soon_after_it_is_written() {
        // Readable 5 µs after the stamp, the reader wakes 3 µs late.
        let (mut lat, polls) = run(2000, |_| 0, |_| 5 * US, 3 * US);
        assert!(lat.len() >= 1990, "read {} of 2000", lat.len());
        let steady = &mut lat[100..];
        let m = median(steady);
        assert!((5 * US..=15 * US).contains(&m), "median latency {m} ns");
        // About one wake-up per tick (fixed 2 kHz polling takes two, and waits 250 µs).
        assert!(polls < 2000 * 13 / 10, "{polls} polls for 2000 ticks");
    }

    #[test]
    fn follows_a_varying_compute_time_and_a_jittery_loop() {
        // Contact rendering: readable 60–140 µs after the stamp; wake-ups up to 30 µs late.
        let (mut lat, polls) = run(
            3000,
            |k| (k * 7919 % 31) * US,
            |k| 60 * US + (k * 104_729 % 81) * US,
            3 * US,
        );
        assert!(lat.len() >= 2990);
        let m = median(&mut lat[200..]);
        // Fixed-rate polling at 2 kHz would wait 250 µs on average on top of the compute.
        assert!(m < 150 * US, "median latency {m} ns");
        assert!(polls < 3000 * 3, "{polls} polls for 3000 ticks");
    }

    #[test]
    fn without_states_it_polls_at_the_fallback_rate() {
        let mut p = StatePacer::new(500 * US);
        assert_eq!(p.next_poll(1_000, None), 501_000);
        // One state alone gives no period yet: still the fallback.
        assert_eq!(p.next_poll(2_000, Some((1, 1_500))), 502_000);
        assert_eq!(p.next_poll(1_001_600, Some((2, 1_001_500))), 2_001_500);
        assert_eq!(p.period_ns(), Some(MS));
        // The loop stops: retries for the rest of the predicted tick, then the fallback.
        let t = p.next_poll(2_001_500, None);
        assert_eq!(t, 2_001_500 + RETRY_NS);
        assert_eq!(p.next_poll(3_100_000, None), 3_600_000);
        assert_eq!(p.next_poll(3_600_000, None), 4_100_000);
    }

    #[test]
    fn skipped_states_keep_the_lock() {
        let mut p = StatePacer::new(500 * US);
        for k in 0..100 {
            p.next_poll(k * MS + 2 * US, Some((k + 1, k * MS)));
        }
        assert_eq!(p.period_ns(), Some(MS));
        // States 101 and 102 were missed: the next one is still predicted on the grid.
        assert_eq!(
            p.next_poll(102 * MS + 50 * US, Some((103, 102 * MS))),
            103 * MS
        );
        assert_eq!(p.period_ns(), Some(MS));
        // A late wake-up hardly moves the grid: the next prediction stays on time (to
        // within 1/64 of the lateness and its effect on the mean period).
        let next = p.next_poll(103 * MS + 90 * US, Some((104, 103 * MS + 80 * US)));
        assert!((104 * MS..104 * MS + 3 * US).contains(&next), "{next}");
    }

    #[test]
    fn a_restarted_loop_is_relearnt() {
        let mut p = StatePacer::new(500 * US);
        p.next_poll(0, Some((1, 0)));
        p.next_poll(MS, Some((2, MS)));
        assert_eq!(p.period_ns(), Some(MS));
        // A new loop starts its sequence at 1 again, with another period.
        assert_eq!(p.next_poll(5 * MS, Some((1, 5 * MS))), 5 * MS + 500 * US);
        assert_eq!(p.period_ns(), None);
        p.next_poll(7 * MS, Some((2, 7 * MS)));
        assert_eq!(p.period_ns(), Some(2 * MS));
    }
}
