//! The RT thread and its stats thread.
//!
//! The RT thread: set up (SCHED_FIFO, affinity, mlockall), then per period: sleep to the
//! absolute deadline, [`Tick::step`], push a [`TickSample`] into the ring, account for missed
//! deadlines. After set-up it allocates nothing, takes no lock, logs nothing; the counting
//! allocator measures that on every run ([`LoopReport::rt_allocations`]).

use crate::alloc_count;
use crate::rt::{self, RtOptions, RtSetupReport};
use crate::stats::{Percentiles, SecondSummary, SlowestTick, TickSample, TimingHistograms};
use crate::tick::{GuidanceSource, PrevTiming, StateSink, Tick};
use devices::HapticDevice;
use serde::Serialize;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

/// How the RT thread runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunnerConfig {
    /// Tick rate, Hz (500–4000).
    pub rate_hz: f64,
    /// Priority, affinity, memory locking.
    pub rt: RtOptions,
    /// Spin this long before each deadline instead of sleeping, ns (0 = pure sleep).
    pub spin_ns: u64,
    /// Stop after this many ticks (`None` = until stopped).
    pub max_ticks: Option<u64>,
}

/// Counters the RT thread updates each tick, readable from any thread.
#[derive(Debug, Default)]
pub struct LiveCounters {
    /// Ticks done.
    pub ticks: AtomicU64,
    /// Deadlines missed.
    pub deadline_misses: AtomicU64,
    /// Of them, overruns: missed by ticks whose own CPU time passed the period.
    pub overruns: AtomicU64,
    /// Samples dropped because the stats ring was full.
    pub dropped_samples: AtomicU64,
    /// Set when the RT thread has left its loop.
    pub finished: AtomicBool,
}

/// Final figures of a run.
#[derive(Debug, Clone, Serialize)]
pub struct LoopReport {
    /// Ticks done.
    pub ticks: u64,
    /// Deadlines missed (a tick that ends after the next deadline misses it, and every
    /// deadline it overran): `overruns + preempted`.
    pub deadline_misses: u64,
    /// Deadlines missed by ticks whose own CPU time (`compute_cpu_us`) passed the period:
    /// the loop's work did not fit.
    pub overruns: u64,
    /// Deadlines missed by ticks whose CPU time fit the period: the machine took the CPU
    /// away from the thread or woke it late.
    pub preempted: u64,
    /// Heap allocations made by the RT thread after set-up; `None` when the counting
    /// allocator is not installed in this process.
    pub rt_allocations: Option<u64>,
    /// `rt_allocations / ticks`.
    pub allocations_per_tick: Option<f64>,
    /// Wake-up latency, µs.
    pub wake_latency_us: Percentiles,
    /// Compute time per tick by the wall clock (wake-up to the end of its work), µs.
    pub compute_us: Percentiles,
    /// Compute time per tick by the RT thread's CPU clock, from its wake-up to the end of
    /// its work, µs: what the tick itself used, not time the machine gave to other threads
    /// (on a VM it still holds what the host took from the virtual CPU meanwhile).
    pub compute_cpu_us: Percentiles,
    /// Period between wake-ups, µs.
    pub period_us: Percentiles,
    /// Guidance age at render time, µs.
    pub guidance_age_us: Percentiles,
    /// Guidance publish (the planner's header stamp) → wake-up of the first tick that
    /// renders the sample, µs; one value per new sample.
    pub guidance_latency_us: Percentiles,
    /// Samples the stats thread missed (they are still counted in `ticks`).
    pub dropped_samples: u64,
    /// SCHED_FIFO active.
    pub fifo: bool,
    /// Thread pinned.
    pub pinned: bool,
    /// Memory locked.
    pub memory_locked: bool,
    /// The CPU wake-up latency requested from the kernel (PM QoS) while the loop ran, µs;
    /// `None` if none was requested or the request failed.
    pub cpu_latency_us: Option<u32>,
    /// The tick that used the most CPU time and its work counts.
    pub slowest_tick: SlowestTick,
    /// Guidance samples rejected as invalid.
    pub guidance_rejected: u64,
    /// Faults latched.
    pub faults: u64,
    /// Wake-up latency distribution, (µs, count) per bucket (for plots; not serialised).
    #[serde(skip)]
    pub wake_latency_distribution: Vec<(f64, u64)>,
    /// Compute time distribution, (µs, count) per bucket (for plots; not serialised).
    #[serde(skip)]
    pub compute_distribution: Vec<(f64, u64)>,
}

/// What the RT thread hands back when it ends: the tick (device included), what its
/// real-time set-up achieved, and its allocation count (`None` if not measured).
type RtOutcome<D, G, S> = (Tick<D, G, S>, RtSetupReport, Option<u64>);

/// A running loop.
pub struct LoopHandle<D, G, S> {
    stop: Arc<AtomicBool>,
    counters: Arc<LiveCounters>,
    rt: JoinHandle<RtOutcome<D, G, S>>,
    stats: JoinHandle<TimingHistograms>,
}

impl<D, G, S> std::fmt::Debug for LoopHandle<D, G, S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LoopHandle").finish_non_exhaustive()
    }
}

const RING_CAPACITY: usize = 16_384;

/// Starts the RT thread running `tick` and the stats thread calling `on_second` once per
/// second of loop time (from the stats thread; it may log, allocate, lock).
pub fn spawn<D, G, S>(
    tick: Tick<D, G, S>,
    config: RunnerConfig,
    mut on_second: impl FnMut(&SecondSummary) + Send + 'static,
) -> std::io::Result<LoopHandle<D, G, S>>
where
    D: HapticDevice + 'static,
    G: GuidanceSource + Send + 'static,
    S: StateSink + Send + 'static,
{
    let stop = Arc::new(AtomicBool::new(false));
    let counters = Arc::new(LiveCounters::default());
    let (producer, mut consumer) = rtrb::RingBuffer::<TickSample>::new(RING_CAPACITY);

    let rt = {
        let stop = stop.clone();
        let counters = counters.clone();
        std::thread::Builder::new()
            .name("haptic-rt".into())
            .spawn(move || rt_thread(tick, config, producer, &stop, &counters))?
    };

    let stats = {
        let counters = counters.clone();
        std::thread::Builder::new()
            .name("haptic-stats".into())
            .spawn(move || {
                let mut total = TimingHistograms::default();
                let mut window = TimingHistograms::default();
                let start = std::time::Instant::now();
                let mut next_report = 1.0;
                loop {
                    let done = counters.finished.load(Ordering::Acquire);
                    while let Ok(s) = consumer.pop() {
                        total.record(&s);
                        window.record(&s);
                    }
                    let elapsed = start.elapsed().as_secs_f64();
                    if elapsed >= next_report {
                        let w = window.wake.percentiles_us();
                        on_second(&SecondSummary {
                            elapsed_s: elapsed,
                            ticks: window.ticks,
                            wake_p99_us: w.p99,
                            wake_max_us: w.max,
                            compute_p99_us: window.compute.percentiles_us().p99,
                            compute_cpu_max_us: window.compute_cpu.percentiles_us().max,
                            deadline_misses_total: counters.deadline_misses.load(Ordering::Relaxed),
                            overruns_total: counters.overruns.load(Ordering::Relaxed),
                            dropped_samples_total: counters.dropped_samples.load(Ordering::Relaxed),
                        });
                        window.reset();
                        next_report += 1.0;
                    }
                    if done {
                        return total;
                    }
                    std::thread::sleep(Duration::from_millis(50));
                }
            })?
    };

    Ok(LoopHandle {
        stop,
        counters,
        rt,
        stats,
    })
}

impl<D, G, S> LoopHandle<D, G, S> {
    /// Live counters of the RT thread.
    pub fn counters(&self) -> &LiveCounters {
        &self.counters
    }

    /// Asks the RT thread to stop after its current tick.
    pub fn request_stop(&self) {
        self.stop.store(true, Ordering::Release);
    }

    /// True once the RT thread has left its loop (stopped or reached `max_ticks`).
    pub fn is_finished(&self) -> bool {
        self.counters.finished.load(Ordering::Acquire)
    }

    /// Stops the loop (if not already) and returns the tick state and the report.
    pub fn join(self) -> (Tick<D, G, S>, LoopReport)
    where
        D: HapticDevice,
        G: GuidanceSource,
        S: StateSink,
    {
        self.request_stop();
        let (tick, setup, allocations) = match self.rt.join() {
            Ok(r) => r,
            Err(p) => std::panic::resume_unwind(p),
        };
        let hist = match self.stats.join() {
            Ok(h) => h,
            Err(p) => std::panic::resume_unwind(p),
        };
        let ticks = self.counters.ticks.load(Ordering::Relaxed);
        let deadline_misses = self.counters.deadline_misses.load(Ordering::Relaxed);
        let overruns = self.counters.overruns.load(Ordering::Relaxed);
        let report = LoopReport {
            ticks,
            deadline_misses,
            overruns,
            preempted: deadline_misses - overruns,
            rt_allocations: allocations,
            allocations_per_tick: allocations.map(|a| a as f64 / ticks.max(1) as f64),
            wake_latency_us: hist.wake.percentiles_us(),
            wake_latency_distribution: hist.wake.distribution_us(),
            compute_distribution: hist.compute.distribution_us(),
            compute_us: hist.compute.percentiles_us(),
            compute_cpu_us: hist.compute_cpu.percentiles_us(),
            slowest_tick: hist.slowest,
            period_us: hist.period.percentiles_us(),
            guidance_age_us: hist.guidance_age.percentiles_us(),
            guidance_latency_us: hist.guidance_latency.percentiles_us(),
            dropped_samples: self.counters.dropped_samples.load(Ordering::Relaxed),
            fifo: setup.fifo,
            pinned: setup.pinned,
            memory_locked: setup.memory_locked,
            cpu_latency_us: setup.cpu_latency.as_ref().map(|r| r.us),
            guidance_rejected: tick.guidance_rejected(),
            faults: tick.faults_total(),
        };
        (tick, report)
    }
}

fn rt_thread<D, G, S>(
    mut tick: Tick<D, G, S>,
    config: RunnerConfig,
    mut ring: rtrb::Producer<TickSample>,
    stop: &AtomicBool,
    counters: &LiveCounters,
) -> RtOutcome<D, G, S>
where
    D: HapticDevice,
    G: GuidanceSource,
    S: StateSink,
{
    let setup = rt::setup_current_thread(&config.rt);
    for w in &setup.warnings {
        tracing::warn!("{w}");
    }
    let counting = alloc_count::is_installed();
    let period_ns = (1e9 / config.rate_hz).round() as u64;
    let max_ticks = config.max_ticks.unwrap_or(u64::MAX);

    // From here on: no allocation, no lock, no logging.
    let allocations_before = alloc_count::counted();
    alloc_count::count_this_thread(true);
    let mut deadline = rt::monotonic_ns() + period_ns;
    let mut prev = PrevTiming::default();
    let mut last_wake = 0u64;
    let mut ticks = 0u64;
    let mut last_guidance_sequence = 0u64;
    let mut overruns = 0u64;
    while ticks < max_ticks && !stop.load(Ordering::Acquire) {
        let wake = rt::sleep_until(deadline, config.spin_ns);
        // The CPU clock is read at the wake-up and at the end of the work (0.17 µs each):
        // read once a tick, the difference from the last read also held the sleep's way
        // into the kernel and back, and a wake-up the VM's host stalled for 19 ms counted
        // as 19 ms of the tick's CPU time (a live tunnels session, whose tick took 12 µs).
        let cpu_wake = rt::thread_cpu_ns();
        let rendered = tick.step(wake, prev).guidance_sequence;
        let guidance_age_ns = tick.guidance_age_ns();
        // The first tick rendering a sample (its sequence changed) records publish → render.
        let guidance_latency_ns = if rendered != 0 && rendered != last_guidance_sequence {
            guidance_age_ns
        } else {
            0
        };
        last_guidance_sequence = rendered;
        let end = rt::monotonic_ns();
        let compute_cpu_ns = rt::thread_cpu_ns().saturating_sub(cpu_wake);

        let next = deadline + period_ns;
        let missed = rt::missed_deadlines(end, next, period_ns);
        // An overrun: the tick's own CPU time passed the period. The live counters are
        // the report's source (the stats thread may drop samples).
        if compute_cpu_ns > period_ns {
            overruns += missed;
        }
        let sample = TickSample {
            tick: ticks + 1,
            wake_latency_ns: wake - deadline,
            compute_ns: end - wake,
            compute_cpu_ns,
            period_ns: if last_wake == 0 { 0 } else { wake - last_wake },
            guidance_age_ns,
            guidance_latency_ns,
            missed,
            work: *tick.last_work(),
        };
        if ring.push(sample).is_err() {
            counters.dropped_samples.fetch_add(1, Ordering::Relaxed);
        }
        prev = PrevTiming {
            wake_latency_ns: sample.wake_latency_ns,
            compute_ns: sample.compute_ns,
            period_ns: sample.period_ns,
            deadline_misses: prev.deadline_misses + missed,
        };
        // Overran: skip the deadlines already past instead of bursting to catch up.
        deadline = next + missed * period_ns;
        last_wake = wake;
        ticks += 1;
        counters.ticks.store(ticks, Ordering::Relaxed);
        counters
            .deadline_misses
            .store(prev.deadline_misses, Ordering::Relaxed);
        counters.overruns.store(overruns, Ordering::Relaxed);
    }
    alloc_count::count_this_thread(false);
    let allocations = counting.then(|| alloc_count::counted() - allocations_before);
    counters.finished.store(true, Ordering::Release);
    tick.close();
    (tick, setup, allocations)
}
