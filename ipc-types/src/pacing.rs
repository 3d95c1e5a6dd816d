//! When a reader of the haptic state polls it (the planner's receiver thread, the loop-side
//! bridge's export thread): phase-locked to the loop's ticks instead of at a fixed rate.
//!
//! The haptic loop writes its state into a blackboard once per tick, stamped with the tick's
//! wake-up time (`header.timestamp_ns`), and wakes nobody: its RT thread makes no system call
//! beyond the clock and the device (see `ipc_types::services` for why an iceoryx2 event is
//! not notified from it). A reader polling at a fixed rate therefore waits half a poll period
//! on average. [`StatePacer`] instead locks onto the loop's grid of on-time ticks (a loop
//! never wakes early, so the earliest stamps, projected by whole periods, mark it) and wakes
//! the receiver at the next tick plus a learnt offset, about once per tick. Without new
//! states (no loop yet, a stopped or dead loop) it polls at the fallback rate.
//!
//! The offset is learnt from what each predicted wake-up found, by steps that settle where
//! four outcomes in five are the cheap one (`STEP_CHEAP_NS` one way, four times as much the
//! other way), so the offset follows the loop's compute time and the receiver's own wake-up
//! lateness, whatever they are on the machine:
//!
//! * **Sleeping** ([`StatePacer::sleeping`]): the receiver polls once when it wakes. A poll
//!   that finds the new state moves the offset earlier; one that finds nothing moves it later
//!   and polls again [`RETRY_NS`] later. A state is read after its write by about the
//!   receiver's wake-up lateness (5–30 µs on a VM).
//! * **Spinning** ([`StatePacer::spinning`]): the receiver wakes *before* the write and
//!   watches the entry until the state comes (for at most its spin window). A state that
//!   came while it watched moves the offset later (less spinning); one already there at the
//!   wake-up moves it earlier. So four wake-ups in five precede the write, and those read the
//!   state within a microsecond of it. The offset measures the requested time, so the
//!   receiver's wake-up lateness is learnt with it: an offset that aimed at the write itself
//!   (the earlier design) was as late as the lateness, which on this VM is wider than any
//!   fixed window around the write.
//!
//! [`StatePacer`] is pure logic on `CLOCK_MONOTONIC` nanoseconds passed in, so it is tested
//! without clocks; [`has_real_time_thread`] reads `/proc`.

/// Whether process `pid` has a thread scheduled SCHED_FIFO or SCHED_RR, from
/// `/proc/PID/task/*/stat` (field 41, the policy). False when it cannot be read (another
/// PID namespace, no such process). Readers phase-lock only to such a loop: a loop without
/// real-time rights ticks late and in bursts.
pub fn has_real_time_thread(pid: u32) -> bool {
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return false;
    };
    tasks.flatten().any(|task| {
        std::fs::read_to_string(task.path().join("stat"))
            .ok()
            .and_then(|stat| {
                // The command name may hold spaces and parentheses: fields count from the
                // last ')', which is followed by field 3.
                let rest = &stat[stat.rfind(')')? + 1..];
                rest.split_whitespace().nth(41 - 3)?.parse::<u32>().ok()
            })
            .is_some_and(|policy| policy == 1 || policy == 2)
    })
}

/// Whether a reader should phase-lock to the ticks of the state blackboard's writer `pid`:
/// another process with a real-time thread (a haptic loop with real-time rights). A state
/// written by the reader's own process is the in-process bridge's import (`planner serve
/// --bridge-connect`): it arrives at the network's pace, bunched and jittered by hundreds of
/// microseconds, so a reader phase-locked to its stamps' grid polls between two arrivals
/// and misses one of them (issue 34: 700–780 of 1 000 states per second), however many
/// real-time threads the process has (the planner's receiver is one). Such a reader polls.
pub fn phase_lock_to(pid: u32) -> bool {
    pid != std::process::id() && has_real_time_thread(pid)
}

/// Wait before polling again when the predicted poll found nothing new, ns.
pub const RETRY_NS: u64 = 10_000;
/// How far the cheap outcome moves the offset, ns (polling earlier when sleeping, waking
/// later when spinning).
const STEP_CHEAP_NS: i64 = 1_000;
/// How far the costly outcome moves it back, ns (4 × [`STEP_CHEAP_NS`]: the offset settles
/// where 4 outcomes in 5 are the cheap one).
const STEP_COSTLY_NS: i64 = 4 * STEP_CHEAP_NS;
/// Longest tick period the pacer locks onto, ns (slower loops are polled at the fallback).
const MAX_PERIOD_NS: u64 = 100_000_000;

/// What the receiver saw at a poll.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Seen {
    /// Nothing new.
    Nothing,
    /// A new state with this `header.sequence` and stamp (ns), already there when the
    /// receiver woke.
    Found {
        /// `header.sequence` of the state.
        sequence: u64,
        /// `header.timestamp_ns` of the state.
        stamp_ns: u64,
    },
    /// A new state that came while the receiver watched the entry (spinning): it woke
    /// before the write.
    Came {
        /// `header.sequence` of the state.
        sequence: u64,
        /// `header.timestamp_ns` of the state.
        stamp_ns: u64,
    },
}

/// Decides the time of the receiver's next poll. See the module docs.
#[derive(Debug, Clone)]
pub struct StatePacer {
    fallback_ns: u64,
    /// The receiver watches the entry after it wakes (see the module docs).
    spinning: bool,
    /// The loop's tick period, estimated from the stamps since the anchor (ns).
    period_ns: Option<u64>,
    /// The first state seen from this loop: sequence and stamp (ns).
    anchor_sequence: u64,
    anchor_stamp_ns: u64,
    /// Next on-time tick → requested wake-up, as learnt (ns; negative: before the tick).
    offset_ns: i64,
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
    /// A pacer for a receiver that polls once at each wake-up; it polls every
    /// `fallback_ns` until it has locked onto a loop.
    pub fn sleeping(fallback_ns: u64) -> Self {
        Self::new(fallback_ns, false)
    }

    /// A pacer for a receiver that, at each predicted wake-up, watches the entry until the
    /// state comes; it polls every `fallback_ns` until it has locked onto a loop.
    pub fn spinning(fallback_ns: u64) -> Self {
        Self::new(fallback_ns, true)
    }

    fn new(fallback_ns: u64, spinning: bool) -> Self {
        Self {
            fallback_ns: fallback_ns.max(1),
            spinning,
            period_ns: None,
            anchor_sequence: 0,
            anchor_stamp_ns: 0,
            offset_ns: 0,
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
    /// retry poll): the one to watch the entry at, when spinning.
    pub fn predicted(&self) -> bool {
        self.predicted && self.retries == 0
    }

    /// The learnt offset from the loop's on-time tick to the requested wake-up, ns
    /// (negative: before the tick).
    pub fn offset_ns(&self) -> i64 {
        self.offset_ns
    }

    /// After a poll at `now_ns` that saw `seen`: when to poll next (absolute ns, never
    /// before `now_ns`).
    pub fn next_poll(&mut self, now_ns: u64, seen: Seen) -> u64 {
        let (sequence, stamp_ns, came) = match seen {
            Seen::Nothing => return self.nothing_new(now_ns),
            Seen::Found { sequence, stamp_ns } => (sequence, stamp_ns, false),
            Seen::Came { sequence, stamp_ns } => (sequence, stamp_ns, true),
        };
        if self.predicted {
            // Which way the outcome says to move: later after a retry (the poll or the
            // watch was too early) or, when spinning, after a state that came while
            // watched; earlier otherwise.
            self.offset_ns += match (self.retries > 0, self.spinning, came) {
                (true, _, _) => STEP_COSTLY_NS,
                (false, true, true) => STEP_CHEAP_NS,
                (false, true, false) => -STEP_COSTLY_NS,
                (false, false, _) => -STEP_CHEAP_NS,
            };
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
                // Within (−½, 1] period of the tick: beyond, the prediction is useless and
                // the fallback does as well.
                let p = p as i64;
                self.offset_ns = self.offset_ns.clamp(-p / 2, p);
                self.predicted = true;
                let next = (self.grid_ns as i64 + p + self.offset_ns).max(0) as u64;
                next.max(now_ns)
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

    /// What [`run`] measured.
    struct Run {
        /// Read − readable of each state read, ns.
        after_write: Vec<u64>,
        /// Read − stamp of each state read, ns.
        after_stamp: Vec<u64>,
        /// Wake-ups.
        polls: u64,
        /// Time spent watching the entry, ns.
        spun_ns: u64,
        /// States that came while watched.
        came: u64,
    }

    /// A loop ticking every 1 ms from `t0`, each state stamped `stamp_jitter(k)` after its
    /// tick and readable `visible_after(k)` after its stamp; a receiver that wakes
    /// `wake_late(i)` after the time it asked for at its i-th poll and, with a spinning
    /// pacer, watches the entry for up to `spin_ns` after predicted wake-ups.
    fn run(
        mut pacer: StatePacer,
        ticks: u64,
        stamp_jitter: impl Fn(u64) -> u64,
        visible_after: impl Fn(u64) -> u64,
        wake_late: impl Fn(u64) -> u64,
        spin_ns: u64,
    ) -> Run {
        let t0 = 10 * MS;
        let stamp = |k: u64| t0 + k * MS + stamp_jitter(k);
        let readable = |k: u64| stamp(k) + visible_after(k);
        // The newest state readable at t.
        let newest = |t: u64| (0..ticks).rev().find(|&k| readable(k) <= t);
        let mut r = Run {
            after_write: Vec::new(),
            after_stamp: Vec::new(),
            polls: 0,
            spun_ns: 0,
            came: 0,
        };
        let mut last_read = 0u64; // the newest sequence read (k + 1)
        let mut t = 0u64;
        let mut watch = false;
        while t < t0 + ticks * MS {
            r.polls += 1;
            let mut seen = match newest(t) {
                Some(k) if k + 1 > last_read => Seen::Found {
                    sequence: k + 1,
                    stamp_ns: stamp(k),
                },
                _ => Seen::Nothing,
            };
            if watch && seen == Seen::Nothing {
                // Spin until the next state is readable or the window closes.
                let next = (last_read..ticks).find(|&k| readable(k) > t);
                match next {
                    Some(k) if readable(k) <= t + spin_ns => {
                        r.spun_ns += readable(k) - t;
                        t = readable(k);
                        seen = Seen::Came {
                            sequence: k + 1,
                            stamp_ns: stamp(k),
                        };
                        r.came += 1;
                    }
                    _ => {
                        r.spun_ns += spin_ns;
                        t += spin_ns;
                    }
                }
            }
            if let Seen::Found { sequence, .. } | Seen::Came { sequence, .. } = seen {
                let k = sequence - 1;
                r.after_write.push(t - readable(k));
                r.after_stamp.push(t - stamp(k));
                last_read = sequence;
            }
            t = pacer.next_poll(t, seen) + wake_late(r.polls);
            watch = spin_ns > 0 && pacer.predicted();
        }
        r
    }

    fn median(v: &mut [u64]) -> u64 {
        v.sort_unstable();
        v[v.len() / 2]
    }

    /// A deterministic spread of `n` values 0..n−1 over the indices.
    fn spread(i: u64, prime: u64, n: u64) -> u64 {
        i * prime % n
    }

    #[test]
    fn sleeping_locks_onto_the_ticks_and_reads_each_state_soon_after_it_is_written() {
        // Readable 5 µs after the stamp, the reader wakes 3 µs late.
        let mut r = run(
            StatePacer::sleeping(MS / 2),
            2000,
            |_| 0,
            |_| 5 * US,
            |_| 3 * US,
            0,
        );
        assert!(
            r.after_stamp.len() >= 1990,
            "read {} of 2000",
            r.after_stamp.len()
        );
        let m = median(&mut r.after_stamp[100..]);
        assert!((5 * US..=15 * US).contains(&m), "median latency {m} ns");
        // About one wake-up per tick (fixed 2 kHz polling takes two, and waits 250 µs).
        assert!(r.polls < 2000 * 13 / 10, "{} polls for 2000 ticks", r.polls);
    }

    #[test]
    fn sleeping_follows_a_varying_compute_time_and_a_jittery_loop() {
        // Contact rendering: readable 60–140 µs after the stamp; wake-ups up to 30 µs late.
        let mut r = run(
            StatePacer::sleeping(MS / 2),
            3000,
            |k| spread(k, 7919, 31) * US,
            |k| 60 * US + spread(k, 104_729, 81) * US,
            |_| 3 * US,
            0,
        );
        assert!(r.after_stamp.len() >= 2990);
        let m = median(&mut r.after_stamp[200..]);
        // Fixed-rate polling at 2 kHz would wait 250 µs on average on top of the compute.
        assert!(m < 150 * US, "median latency {m} ns");
        assert!(r.polls < 3000 * 3, "{} polls for 3000 ticks", r.polls);
    }

    /// This VM's case: the receiver wakes 15–45 µs after the time it asks for, more than the
    /// loop's own compute before the write (8 µs).
    fn late_waker(pacer: StatePacer, spin_ns: u64) -> Run {
        run(
            pacer,
            4000,
            |k| spread(k, 7919, 11) * US,
            |_| 8 * US,
            |i| 15 * US + spread(i, 104_729, 31) * US,
            spin_ns,
        )
    }

    #[test]
    fn spinning_wakes_before_the_write_despite_a_late_waking_receiver() {
        let mut r = late_waker(StatePacer::spinning(MS / 2), 100 * US);
        let n = r.after_write.len() as u64;
        assert!(n >= 3990, "read {n} of 4000");
        // Four wake-ups in five precede the write (the steps' 4 : 1), within a few %.
        let share = r.came as f64 / n as f64;
        assert!(
            (0.74..=0.86).contains(&share),
            "{:.3} came while watched",
            share
        );
        // So the median state is read as it is written.
        assert_eq!(median(&mut r.after_write[200..]), 0);
        // Spinning costs about the spread of the wake-ups (30 µs) per tick, not the window.
        let spin_per_tick = r.spun_ns / n;
        assert!(spin_per_tick < 30 * US, "{spin_per_tick} ns spun per tick");
        assert!(r.polls < 4000 * 13 / 10, "{} polls for 4000 ticks", r.polls);
    }

    #[test]
    fn sleeping_reads_a_late_waking_receivers_states_its_lateness_after_the_write() {
        // The same machine without spinning: what spinning saves.
        let mut r = late_waker(StatePacer::sleeping(MS / 2), 0);
        let m = median(&mut r.after_write[200..]);
        assert!(
            (5 * US..=45 * US).contains(&m),
            "median {m} ns after the write"
        );
    }

    #[test]
    fn without_states_it_polls_at_the_fallback_rate() {
        let mut p = StatePacer::sleeping(500 * US);
        let found = |sequence, stamp_ns| Seen::Found { sequence, stamp_ns };
        assert_eq!(p.next_poll(1_000, Seen::Nothing), 501_000);
        // One state alone gives no period yet: still the fallback.
        assert_eq!(p.next_poll(2_000, found(1, 1_500)), 502_000);
        assert_eq!(p.next_poll(1_001_600, found(2, 1_001_500)), 2_001_500);
        assert_eq!(p.period_ns(), Some(MS));
        // The loop stops: retries for the rest of the predicted tick, then the fallback.
        let t = p.next_poll(2_001_500, Seen::Nothing);
        assert_eq!(t, 2_001_500 + RETRY_NS);
        assert_eq!(p.next_poll(3_100_000, Seen::Nothing), 3_600_000);
        assert_eq!(p.next_poll(3_600_000, Seen::Nothing), 4_100_000);
    }

    #[test]
    fn the_offset_moves_by_the_outcome_of_each_predicted_wake_up() {
        let mut p = StatePacer::spinning(500 * US);
        let came = |sequence, stamp_ns| Seen::Came { sequence, stamp_ns };
        let found = |sequence, stamp_ns| Seen::Found { sequence, stamp_ns };
        p.next_poll(0, found(1, 0));
        assert_eq!(p.next_poll(MS, found(2, MS)), 2 * MS);
        // Came while watched: wake later; already there: earlier, four times as far.
        assert_eq!(p.next_poll(2 * MS, came(3, 2 * MS)), 3 * MS + 1_000);
        assert_eq!(p.next_poll(3 * MS, found(4, 3 * MS)), 4 * MS - 3_000);
        assert_eq!(p.offset_ns(), -3_000);
        // Nothing in the window, found on the retry: later.
        p.next_poll(4 * MS, Seen::Nothing);
        assert_eq!(
            p.next_poll(4 * MS + 20_000, found(5, 4 * MS)),
            5 * MS + 1_000
        );
        // Sleeping, a state found at the first poll moves the poll earlier.
        let mut p = StatePacer::sleeping(500 * US);
        p.next_poll(0, found(1, 0));
        p.next_poll(MS, found(2, MS));
        assert_eq!(p.next_poll(2 * MS, found(3, 2 * MS)), 3 * MS - 1_000);
        assert_eq!(p.offset_ns(), -1_000);
    }

    #[test]
    fn skipped_states_keep_the_lock() {
        let mut p = StatePacer::sleeping(500 * US);
        let found = |sequence, stamp_ns| Seen::Found { sequence, stamp_ns };
        for k in 0..100 {
            p.next_poll(k * MS + 2 * US, found(k + 1, k * MS));
        }
        assert_eq!(p.period_ns(), Some(MS));
        // States 101 and 102 were missed: the next one is still predicted on the grid.
        let offset = p.offset_ns();
        let predicted = (103 * MS) as i64 + offset - 1_000;
        assert_eq!(
            p.next_poll(102 * MS + 50 * US, found(103, 102 * MS)) as i64,
            predicted
        );
        assert_eq!(p.period_ns(), Some(MS));
        // A late wake-up hardly moves the grid: the next prediction stays on time (to
        // within 1/64 of the lateness and its effect on the mean period).
        let next = p.next_poll(103 * MS + 90 * US, found(104, 103 * MS + 80 * US)) as i64;
        let on_time = (104 * MS) as i64 + p.offset_ns();
        assert!((on_time..on_time + 3_000).contains(&next), "{next}");
    }

    #[test]
    fn a_restarted_loop_is_relearnt() {
        let mut p = StatePacer::sleeping(500 * US);
        let found = |sequence, stamp_ns| Seen::Found { sequence, stamp_ns };
        p.next_poll(0, found(1, 0));
        p.next_poll(MS, found(2, MS));
        assert_eq!(p.period_ns(), Some(MS));
        // A new loop starts its sequence at 1 again, with another period.
        assert_eq!(p.next_poll(5 * MS, found(1, 5 * MS)), 5 * MS + 500 * US);
        assert_eq!(p.period_ns(), None);
        p.next_poll(7 * MS, found(2, 7 * MS));
        assert_eq!(p.period_ns(), Some(2 * MS));
    }

    #[test]
    fn a_normal_process_has_no_real_time_thread() {
        // A child at normal priority (not this process: another test makes a thread of
        // it SCHED_FIFO), and a pid that does not exist.
        let mut child = std::process::Command::new("sleep")
            .arg("5")
            .spawn()
            .unwrap();
        let seen = has_real_time_thread(child.id());
        child.kill().unwrap();
        child.wait().unwrap();
        assert!(!seen);
        assert!(!has_real_time_thread(u32::MAX));
    }

    #[test]
    fn a_fifo_thread_is_seen() {
        // A thread of this process made SCHED_FIFO, where the test may (root or
        // CAP_SYS_NICE; without the right there is nothing to see, and it says so).
        let (made, check) = std::sync::mpsc::channel();
        let (done, finish) = std::sync::mpsc::channel::<()>();
        let t = std::thread::spawn(move || {
            made.send(crate::set_thread_fifo_priority(10).is_ok())
                .unwrap();
            let _ = finish.recv();
        });
        if check.recv().unwrap() {
            assert!(has_real_time_thread(std::process::id()));
            // Its own writes (a bridge in this process) are never phase-locked to.
            assert!(!phase_lock_to(std::process::id()));
        } else {
            eprintln!("no right to make a SCHED_FIFO thread here: nothing to check");
        }
        done.send(()).unwrap();
        t.join().unwrap();
    }
}
