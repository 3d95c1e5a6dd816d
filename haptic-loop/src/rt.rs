//! The monotonic clock, absolute-deadline sleeping and real-time thread set-up.
//!
//! Only `clock_gettime` (the monotonic clock, and the thread's CPU clock twice) and
//! `clock_nanosleep` run per tick; the set-up functions run once
//! on the RT thread before its first tick.

pub use ipc_types::monotonic_ns;

/// Deadlines missed by a tick that ended at `end_ns` when the next was due at `next_ns`
/// (ns, `period_ns` apart): the loop skips them rather than bursting to catch up.
#[inline]
pub fn missed_deadlines(end_ns: u64, next_ns: u64, period_ns: u64) -> u64 {
    if end_ns > next_ns {
        (end_ns - next_ns) / period_ns + 1
    } else {
        0
    }
}

/// CPU time the calling thread has used, ns (`CLOCK_THREAD_CPUTIME_ID`; 0 if the clock
/// cannot be read). Unlike `CLOCK_MONOTONIC` this is a system call, not a vDSO read (about
/// 0.17 µs here, against 17 ns for the monotonic clock: `cargo bench -p benches --bench
/// spine -- clock`); the loop reads it twice a tick, at its wake-up and at the end of its
/// work.
#[inline]
pub fn thread_cpu_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the clock id is one Linux always has.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc != 0 {
        return 0;
    }
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Sleeps until `CLOCK_MONOTONIC` reaches `deadline_ns` (absolute, so no drift
/// accumulates), then spins for the last `spin_ns` if non-zero. Returns the wake-up time.
#[inline]
pub fn sleep_until(deadline_ns: u64, spin_ns: u64) -> u64 {
    ipc_types::sleep_until_ns(deadline_ns.saturating_sub(spin_ns));
    let mut now = monotonic_ns();
    while now < deadline_ns {
        std::hint::spin_loop();
        now = monotonic_ns();
    }
    now
}

/// What [`setup_current_thread`] managed to do; each failure is reported once, then the loop
/// runs anyway (a desktop without RT permissions still gets a working, if jittery, loop).
#[derive(Debug, Clone, Default)]
pub struct RtSetupReport {
    /// SCHED_FIFO at the requested priority is active.
    pub fifo: bool,
    /// The thread is pinned to the requested CPU.
    pub pinned: bool,
    /// `mlockall(MCL_CURRENT | MCL_FUTURE)` succeeded.
    pub memory_locked: bool,
    /// The CPU wake-up latency request in effect (held while this report lives).
    pub cpu_latency: Option<CpuLatencyRequest>,
    /// One line per thing that could not be done, with the reason.
    pub warnings: Vec<String>,
}

/// Real-time options for the RT thread.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RtOptions {
    /// SCHED_FIFO priority 1–99; `None` keeps the normal scheduler.
    pub fifo_priority: Option<u8>,
    /// CPU to pin the thread to; `None` leaves affinity alone.
    pub cpu: Option<usize>,
    /// Lock all current and future pages in RAM so no page fault stalls a tick.
    pub lock_memory: bool,
    /// Ask the kernel (PM QoS, `/dev/cpu_dma_latency`) to keep every CPU's wake-up from
    /// idle within this many µs while the loop runs; `None` leaves it alone. 0, the default,
    /// keeps idle CPUs polling instead of halting (as `cyclictest` does by default): on a
    /// virtual machine a halted vCPU waits for its hypervisor to be scheduled again, which
    /// put this VM's loop wake-up p99 at 0.8–2 ms while the machine idled, against 74–88 µs
    /// with the request (docs/guide/configuration.md, "Without real-time permissions").
    pub cpu_latency_us: Option<u32>,
}

impl Default for RtOptions {
    fn default() -> Self {
        Self {
            fifo_priority: Some(80),
            cpu: None,
            lock_memory: true,
            cpu_latency_us: Some(0),
        }
    }
}

/// An open PM QoS request on `/dev/cpu_dma_latency`: the kernel keeps it while the file is
/// open and drops it when the last clone of this is dropped.
#[derive(Debug, Clone)]
pub struct CpuLatencyRequest {
    /// The requested wake-up latency bound, µs.
    pub us: u32,
    _file: std::sync::Arc<std::fs::File>,
}

impl CpuLatencyRequest {
    /// Opens the request (the device takes a native-endian `i32` of µs). Needs write access
    /// to `/dev/cpu_dma_latency` (root, or a udev rule giving it to a group).
    pub fn open(us: u32) -> std::io::Result<Self> {
        use std::io::Write;
        const PATH: &str = "/dev/cpu_dma_latency";
        let value = i32::try_from(us).map_err(|_| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "latency above i32::MAX µs",
            )
        })?;
        let mut file = std::fs::OpenOptions::new().write(true).open(PATH)?;
        file.write_all(&value.to_ne_bytes())?;
        Ok(CpuLatencyRequest {
            us,
            _file: std::sync::Arc::new(file),
        })
    }
}

/// Applies `opts` to the calling thread. Never fails: what cannot be done is listed in the
/// report's warnings (typically "Operation not permitted" without `CAP_SYS_NICE` /
/// `rtprio` limits; see docs/guide/configuration.md, "Without real-time permissions").
pub fn setup_current_thread(opts: &RtOptions) -> RtSetupReport {
    let mut report = RtSetupReport::default();
    if let Some(prio) = opts.fifo_priority {
        match ipc_types::set_thread_fifo_priority(prio) {
            Ok(()) => report.fifo = true,
            Err(e) => report
                .warnings
                .push(format!("{e}; running with the normal scheduler")),
        }
    }
    if let Some(cpu) = opts.cpu {
        match pin_to_cpu(cpu) {
            Ok(()) => report.pinned = true,
            Err(e) => report
                .warnings
                .push(format!("cannot pin to CPU {cpu}: {e}")),
        }
    }
    if let Some(us) = opts.cpu_latency_us {
        match CpuLatencyRequest::open(us) {
            Ok(r) => report.cpu_latency = Some(r),
            Err(e) => report.warnings.push(format!(
                "cannot request a CPU wake-up latency of {us} µs from /dev/cpu_dma_latency ({e}); \
                 idle CPUs may wake late (on a VM by milliseconds)"
            )),
        }
    }
    if opts.lock_memory {
        // SAFETY: mlockall has no memory-safety preconditions.
        let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
        if rc == 0 {
            report.memory_locked = true;
        } else {
            report.warnings.push(format!(
                "mlockall failed ({}); page faults may stall ticks",
                std::io::Error::last_os_error()
            ));
        }
    }
    report
}

fn pin_to_cpu(cpu: usize) -> std::io::Result<()> {
    // SAFETY: cpu_set_t is plain data; zeroed is its empty set.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    if cpu >= libc::CPU_SETSIZE as usize {
        return Err(std::io::Error::other(format!(
            "CPU index {cpu} out of range"
        )));
    }
    // SAFETY: `cpu` is below CPU_SETSIZE, checked above.
    unsafe { libc::CPU_SET(cpu, &mut set) };
    // SAFETY: `set` is a valid cpu_set_t of the size passed; pid 0 is the calling thread.
    let rc = unsafe { libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set) };
    if rc == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

/// The CPUs this thread may run on (its affinity mask), in increasing order.
pub fn allowed_cpus() -> std::io::Result<Vec<usize>> {
    // SAFETY: cpu_set_t is plain data; zeroed is its empty set.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    // SAFETY: `set` is a valid, writable cpu_set_t of the size passed; pid 0 is this thread.
    let rc =
        unsafe { libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) };
    if rc != 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok((0..libc::CPU_SETSIZE as usize)
        // SAFETY: every index is below CPU_SETSIZE.
        .filter(|&cpu| unsafe { libc::CPU_ISSET(cpu, &set) })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missed_deadlines_count_every_deadline_already_past() {
        let period = 1_000_000;
        assert_eq!(missed_deadlines(999_999, 1_000_000, period), 0);
        assert_eq!(missed_deadlines(1_000_000, 1_000_000, period), 0);
        assert_eq!(missed_deadlines(1_000_001, 1_000_000, period), 1);
        assert_eq!(missed_deadlines(3_500_000, 1_000_000, period), 3);
    }

    #[test]
    fn sleep_until_never_wakes_early() {
        for _ in 0..20 {
            let deadline = monotonic_ns() + 200_000;
            let woke = sleep_until(deadline, 0);
            assert!(woke >= deadline, "woke {} ns early", deadline - woke);
        }
    }

    #[test]
    fn spin_reaches_the_deadline() {
        let deadline = monotonic_ns() + 300_000;
        let woke = sleep_until(deadline, 100_000);
        assert!(woke >= deadline);
    }

    #[test]
    fn a_cpu_latency_request_holds_while_its_report_lives() {
        let r = setup_current_thread(&RtOptions {
            fifo_priority: None,
            cpu: None,
            lock_memory: false,
            cpu_latency_us: Some(0),
        });
        match &r.cpu_latency {
            Some(req) => {
                assert_eq!(req.us, 0);
                // Reading the device gives the strictest request in effect: ours, 0 µs.
                if let Ok(bytes) = std::fs::read("/dev/cpu_dma_latency") {
                    let v = i32::from_ne_bytes(bytes[..4].try_into().unwrap());
                    assert_eq!(v, 0);
                }
            }
            None => assert!(
                r.warnings
                    .iter()
                    .any(|w| w.contains("/dev/cpu_dma_latency")),
                "{:?}",
                r.warnings
            ),
        }
    }

    #[test]
    fn setup_reports_instead_of_failing() {
        // A CPU of this process's set: CPU 0 need not be in it (taskset, cgroups).
        let cpu = allowed_cpus().expect("affinity")[0];
        let opts = RtOptions {
            fifo_priority: Some(10),
            cpu: Some(cpu),
            lock_memory: false,
            cpu_latency_us: None,
        };
        let r = setup_current_thread(&opts);
        // Whether FIFO is permitted depends on the machine; either it worked or it said why.
        assert!(r.fifo || r.warnings.iter().any(|w| w.contains("SCHED_FIFO")));
        assert!(
            r.pinned,
            "pinning to allowed CPU {cpu} is permitted: {:?}",
            r.warnings
        );
        // A CPU outside the set is reported, not fatal.
        let r = setup_current_thread(&RtOptions {
            fifo_priority: None,
            cpu: Some(libc::CPU_SETSIZE as usize + 1),
            lock_memory: false,
            cpu_latency_us: None,
        });
        assert!(!r.pinned);
        assert!(
            r.warnings.iter().any(|w| w.contains("cannot pin")),
            "{:?}",
            r.warnings
        );
    }
}
