//! Latency of the real haptic loop next to the machine's own floor, measured in the same
//! run at the same priority and interval.
//!
//! Two phases, one after the other (so they do not compete for the 2 cores), repeated
//! `--rounds` times:
//! 1. **floor**: `cyclictest` (Debian `rt-tests`) with one thread at `--priority` and a
//!    `--rate-hz` interval, histogram mode; when it is not installed, a built-in bare
//!    absolute-deadline sleeper thread (the same `clock_nanosleep(TIMER_ABSTIME)` loop the RT
//!    thread uses, doing nothing else), named `builtin-sleeper` in the report.
//! 2. **loop**: the haptic loop's RT thread (`haptic_loop::runner`) on the simulated arm with
//!    contact rendering on, the simulated operator pushing the S against the wall beside the
//!    hole and sliding it, and optionally a planner process attached over iceoryx2.
//!
//! Prints a table (p50 / p90 / p99 / p99.9 / max, µs) with the loop/floor ratios, and writes
//! JSON with `--json`. The ratios are the medians over the rounds of each round's ratio,
//! and the tables show the round whose p99 ratio is that median: on a shared VM the floor
//! alone moves 3× between two consecutive phases, so one pair decides nothing.
//!
//! `cargo build --release -p planner -p benches && target/release/loop-latency --seconds 30 --json out.json`

use anyhow::{Context, bail};
use benches::harness::{PlannerChild, WallLoop, wall_loop};
use clap::Parser;
use haptic_loop::rt::{self, RtOptions};
use haptic_loop::runner::LoopReport;
use haptic_loop::stats::{NsHistogram, Percentiles};
use serde::Serialize;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[global_allocator]
static ALLOC: haptic_loop::alloc_count::CountingAllocator =
    haptic_loop::alloc_count::CountingAllocator;

/// Haptic-loop latency versus the machine's floor (cyclictest or a bare sleeper).
#[derive(Debug, Parser)]
struct Args {
    /// Seconds of each phase (floor, then loop).
    #[arg(long, default_value_t = 20.0)]
    seconds: f64,
    /// Rounds of (floor, loop), one after the other; the ratios are the medians of the
    /// rounds' ratios.
    #[arg(long, default_value_t = 3)]
    rounds: u32,
    /// Tick rate and floor interval, Hz.
    #[arg(long, default_value_t = 1000.0)]
    rate_hz: f64,
    /// SCHED_FIFO priority of the RT thread and the floor thread (1–99; 0 = normal).
    #[arg(long, default_value_t = 80)]
    priority: u8,
    /// Pin both to this CPU.
    #[arg(long)]
    cpu: Option<usize>,
    /// Neither the loop nor the floor requests a 0 µs CPU wake-up latency (PM QoS,
    /// `/dev/cpu_dma_latency`; both do by default): shows what the request buys.
    #[arg(long)]
    no_cpu_latency_request: bool,
    /// Floor tool: `auto` (cyclictest if installed, else the built-in sleeper),
    /// `cyclictest`, or `builtin`.
    #[arg(long, default_value = "auto")]
    floor: String,
    /// Attach a planner process (`planner serve`, from the same target directory), running
    /// through the floor phase too so that both phases carry its load.
    #[arg(long)]
    planner: bool,
    /// Render no contact.
    #[arg(long)]
    no_contact: bool,
    /// Voxel size, mm.
    #[arg(long, default_value_t = 1.0)]
    voxel_mm: f64,
    /// Write the figures as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Draw the wake-up latency histogram and the CDFs (wake-up, compute) as a PNG here.
    #[arg(long)]
    png: Option<PathBuf>,
}

#[derive(Debug, Serialize)]
struct Floor {
    tool: String,
    wake_latency_us: Percentiles,
    /// (µs, count) per histogram bucket, for the plot.
    #[serde(skip)]
    distribution: Vec<(f64, u64)>,
}

#[derive(Debug, Serialize)]
struct LoopFigures {
    ticks: u64,
    deadline_misses: u64,
    /// Of them, missed by ticks whose own CPU time passed the period.
    overruns: u64,
    /// Of them, missed while the machine had the CPU.
    preempted: u64,
    wake_latency_us: Percentiles,
    period_us: Percentiles,
    compute_us: Percentiles,
    /// Compute time by the RT thread's CPU clock.
    compute_cpu_us: Percentiles,
    guidance_age_us: Percentiles,
    fifo: bool,
    pinned: bool,
    memory_locked: bool,
    contact: bool,
    planner: bool,
}

#[derive(Debug, Serialize)]
struct Ratios {
    p50: f64,
    p90: f64,
    p99: f64,
    p999: f64,
    max: f64,
}

#[derive(Debug, Serialize)]
struct Report {
    rate_hz: f64,
    priority: u8,
    cpu: Option<usize>,
    seconds_per_phase: f64,
    floor: Floor,
    #[serde(rename = "loop")]
    loop_: LoopFigures,
    /// Loop wake-up latency / floor wake-up latency, per percentile: the median over the
    /// rounds of each round's ratio.
    wake_ratio: Ratios,
    /// Each round's ratios, in the order run.
    round_ratios: Vec<Ratios>,
    /// The round whose figures `floor` and `loop` are (0-based): the one with the median
    /// p99 ratio.
    shown_round: usize,
    allocations_per_tick: Option<f64>,
}

impl Ratios {
    /// `loop_ / floor` per percentile (NaN where the floor's figure is 0).
    fn of(loop_: &Percentiles, floor: &Percentiles) -> Self {
        let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::NAN };
        Self {
            p50: ratio(loop_.p50, floor.p50),
            p90: ratio(loop_.p90, floor.p90),
            p99: ratio(loop_.p99, floor.p99),
            p999: ratio(loop_.p999, floor.p999),
            max: ratio(loop_.max, floor.max),
        }
    }
}

/// One round's figures: the floor, then the loop.
struct Round {
    floor: Floor,
    loop_: LoopFigures,
    report: LoopReport,
}

fn measure_round(
    args: &Args,
    ns: &str,
    rt: RtOptions,
    period_ns: u64,
    phase: Duration,
    use_cyclictest: bool,
) -> anyhow::Result<Round> {
    let floor = if use_cyclictest {
        let (wake_latency_us, distribution) = cyclictest(args, period_ns, phase)?;
        Floor {
            tool: "cyclictest".into(),
            wake_latency_us,
            distribution,
        }
    } else {
        let (wake_latency_us, distribution) = builtin_floor(rt, period_ns, phase)?;
        Floor {
            tool: "builtin-sleeper".into(),
            wake_latency_us,
            distribution,
        }
    };
    let (report, contact, planner) = run_loop(args, ns, rt, phase)?;
    let loop_ = LoopFigures {
        ticks: report.ticks,
        deadline_misses: report.deadline_misses,
        overruns: report.overruns,
        preempted: report.preempted,
        wake_latency_us: report.wake_latency_us,
        period_us: report.period_us,
        compute_us: report.compute_us,
        compute_cpu_us: report.compute_cpu_us,
        guidance_age_us: report.guidance_age_us,
        fifo: report.fifo,
        pinned: report.pinned,
        memory_locked: report.memory_locked,
        contact,
        planner,
    };
    Ok(Round {
        floor,
        loop_,
        report,
    })
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if !(args.seconds.is_finite() && args.seconds >= 1.0 && args.seconds <= 3600.0) {
        bail!("--seconds must be within 1–3600, got {}", args.seconds);
    }
    if !(args.rate_hz.is_finite() && (500.0..=4000.0).contains(&args.rate_hz)) {
        bail!("--rate-hz must be within 500–4000, got {}", args.rate_hz);
    }
    if !(1..=50).contains(&args.rounds) {
        bail!("--rounds must be within 1–50, got {}", args.rounds);
    }
    if args.priority > 99 {
        bail!("--priority must be 0–99, got {}", args.priority);
    }
    if !matches!(args.floor.as_str(), "auto" | "cyclictest" | "builtin") {
        bail!(
            "--floor must be auto, cyclictest or builtin, got '{}'",
            args.floor
        );
    }
    let rt = RtOptions {
        fifo_priority: (args.priority > 0).then_some(args.priority),
        cpu: args.cpu,
        lock_memory: true,
        cpu_latency_us: (!args.no_cpu_latency_request).then_some(0),
    };
    let period_ns = (1e9 / args.rate_hz).round() as u64;
    let phase = Duration::from_secs_f64(args.seconds);

    // The planner runs through both phases (planning without an operator while the floor
    // is measured), so that the floor sees the same load as the loop.
    let ns = format!("latency_{}", std::process::id());
    let _planner = if args.planner {
        Some(PlannerChild::spawn_with(
            &ns,
            &["--plan-without-operator".into()],
        )?)
    } else {
        None
    };
    let use_cyclictest = match args.floor.as_str() {
        "builtin" => false,
        "cyclictest" => true,
        _ => cyclictest_available(),
    };
    let mut rounds = Vec::new();
    for round in 0..args.rounds {
        eprintln!(
            "round {}/{}: floor ({}) {:.0} s, then the loop {:.0} s, at {} Hz, priority {}",
            round + 1,
            args.rounds,
            if use_cyclictest {
                "cyclictest"
            } else {
                "built-in sleeper"
            },
            args.seconds,
            args.seconds,
            args.rate_hz,
            args.priority
        );
        rounds.push(measure_round(
            &args,
            &ns,
            rt,
            period_ns,
            phase,
            use_cyclictest,
        )?);
    }
    let round_ratios: Vec<Ratios> = rounds
        .iter()
        .map(|r| Ratios::of(&r.loop_.wake_latency_us, &r.floor.wake_latency_us))
        .collect();
    let median_of = |f: fn(&Ratios) -> f64| {
        let mut v: Vec<f64> = round_ratios.iter().map(f).collect();
        lab::experiment::report::median(&mut v)
    };
    let wake_ratio = Ratios {
        p50: median_of(|r| r.p50),
        p90: median_of(|r| r.p90),
        p99: median_of(|r| r.p99),
        p999: median_of(|r| r.p999),
        max: median_of(|r| r.max),
    };
    // The round whose p99 ratio is nearest the median (the median itself when odd).
    let shown_round = (0..rounds.len())
        .min_by(|&a, &b| {
            let d = |i: usize| (round_ratios[i].p99 - wake_ratio.p99).abs();
            d(a).total_cmp(&d(b))
        })
        .unwrap_or(0);
    let shown = rounds.swap_remove(shown_round);
    let out = Report {
        rate_hz: args.rate_hz,
        priority: args.priority,
        cpu: args.cpu,
        seconds_per_phase: args.seconds,
        wake_ratio,
        round_ratios,
        shown_round,
        allocations_per_tick: shown.report.allocations_per_tick,
        floor: shown.floor,
        loop_: shown.loop_,
    };
    let report = shown.report;
    print_table(&out);
    if let Some(p) = &args.png {
        if lab::register_font() {
            plot(
                p,
                &out,
                &report.wake_latency_distribution,
                &report.compute_distribution,
            )
            .map_err(|e| anyhow::anyhow!("cannot draw {}: {e}", p.display()))?;
        } else {
            eprintln!(
                "no TrueType font found (DejaVuSans.ttf): {} not drawn",
                p.display()
            );
        }
    }
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&out)? + "\n")
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    Ok(())
}

/// Fraction of samples ≤ each value, from a (value, count) distribution.
fn cdf(dist: &[(f64, u64)]) -> Vec<(f64, f64)> {
    let total: u64 = dist.iter().map(|d| d.1).sum();
    let mut seen = 0u64;
    dist.iter()
        .map(|&(v, c)| {
            seen += c;
            (v, seen as f64 / total.max(1) as f64)
        })
        .collect()
}

/// Counts per logarithmic bin (10 per decade) of a (value µs, count) distribution.
fn log_bins(dist: &[(f64, u64)]) -> Vec<(f64, u64)> {
    let mut bins: std::collections::BTreeMap<i64, u64> = std::collections::BTreeMap::new();
    for &(v, c) in dist {
        *bins
            .entry((v.max(0.1).log10() * 10.0).floor() as i64)
            .or_default() += c;
    }
    bins.into_iter()
        .map(|(b, c)| (10f64.powf(b as f64 / 10.0), c))
        .collect()
}

/// Left: wake-up latency histograms of the loop and the floor (log–log). Right: CDFs of
/// wake-up latency (loop, floor) and of the loop's compute time.
fn plot(
    path: &std::path::Path,
    r: &Report,
    wake: &[(f64, u64)],
    compute: &[(f64, u64)],
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let root = BitMapBackend::new(path, (1400, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let (left, right) = root.split_horizontally(700);
    let floor_name = format!("floor ({})", r.floor.tool);
    let x_max = wake
        .iter()
        .chain(&r.floor.distribution)
        .chain(compute)
        .map(|d| d.0)
        .fold(10.0, f64::max)
        * 1.5;

    let hist_loop = log_bins(wake);
    let hist_floor = log_bins(&r.floor.distribution);
    let y_max = hist_loop
        .iter()
        .chain(&hist_floor)
        .map(|b| b.1)
        .max()
        .unwrap_or(1) as f64
        * 2.0;
    let mut chart = ChartBuilder::on(&left)
        .caption("wake-up latency histogram", ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((0.5..x_max).log_scale(), (0.5..y_max).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("µs")
        .y_desc("ticks per bin (10 bins per decade)")
        .draw()?;
    for (name, bins, colour) in [
        ("loop", &hist_loop, RED),
        (floor_name.as_str(), &hist_floor, BLUE),
    ] {
        chart
            .draw_series(LineSeries::new(
                bins.iter().map(|&(v, c)| (v, c as f64)),
                colour.stroke_width(2),
            ))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
    }
    chart.configure_series_labels().border_style(BLACK).draw()?;

    let mut chart = ChartBuilder::on(&right)
        .caption("cumulative distribution", ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((0.5..x_max).log_scale(), 0.0..1.0)?;
    chart
        .configure_mesh()
        .x_desc("µs")
        .y_desc("fraction of ticks ≤ x")
        .draw()?;
    let series = [
        ("loop wake-up", cdf(wake), RED),
        (floor_name.as_str(), cdf(&r.floor.distribution), BLUE),
        ("loop compute", cdf(compute), GREEN),
    ];
    for (name, points, colour) in series {
        chart
            .draw_series(LineSeries::new(points, colour.stroke_width(2)))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

fn print_table(r: &Report) {
    let row = |name: &str, p: &Percentiles| {
        println!(
            "| {name} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
            p.p50, p.p90, p.p99, p.p999, p.max
        )
    };
    println!(
        "haptic loop at {} Hz, priority {}, contact {}, planner {}: {} ticks, {} deadline misses ({} overruns, {} preempted), allocations/tick {}",
        r.rate_hz,
        r.priority,
        r.loop_.contact,
        r.loop_.planner,
        r.loop_.ticks,
        r.loop_.deadline_misses,
        r.loop_.overruns,
        r.loop_.preempted,
        r.allocations_per_tick
            .map_or("n/a".into(), |a| a.to_string())
    );
    println!("| µs | p50 | p90 | p99 | p99.9 | max |");
    println!("|---|---|---|---|---|---|");
    row(
        &format!("floor wake-up ({})", r.floor.tool),
        &r.floor.wake_latency_us,
    );
    row("loop wake-up", &r.loop_.wake_latency_us);
    let w = &r.wake_ratio;
    println!(
        "| loop / floor, median of {} rounds | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
        r.round_ratios.len(),
        w.p50,
        w.p90,
        w.p99,
        w.p999,
        w.max
    );
    row("loop period", &r.loop_.period_us);
    row("loop compute", &r.loop_.compute_us);
    row("loop compute, thread CPU", &r.loop_.compute_cpu_us);
    row("guidance age", &r.loop_.guidance_age_us);
    println!("(wake-ups, period, compute: round {})", r.shown_round + 1);
    for (i, w) in r.round_ratios.iter().enumerate() {
        println!(
            "round {}: loop / floor p50 {:.2}, p90 {:.2}, p99 {:.2}, p99.9 {:.2}, max {:.2}",
            i + 1,
            w.p50,
            w.p90,
            w.p99,
            w.p999,
            w.max
        );
    }
}

/// Percentiles and (µs, count) distribution of the floor's wake-up latency.
type Floored = (Percentiles, Vec<(f64, u64)>);

fn cyclictest_available() -> bool {
    Command::new("cyclictest")
        .arg("--help")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok()
}

/// Runs cyclictest with one measuring thread and reads its per-µs histogram.
fn cyclictest(args: &Args, period_ns: u64, phase: Duration) -> anyhow::Result<Floored> {
    let loops = (phase.as_nanos() / u128::from(period_ns)).max(1);
    let mut cmd = Command::new("cyclictest");
    cmd.args([
        "-m".to_string(),
        "-q".into(),
        "-t1".into(),
        format!("-p{}", args.priority),
        format!("-i{}", period_ns / 1000),
        format!("-l{loops}"),
        "-h20000".into(),
    ]);
    if let Some(cpu) = args.cpu {
        cmd.arg(format!("-a{cpu}"));
    }
    // cyclictest requests a 0 µs CPU wake-up latency by default, as the loop does; without
    // the request on the loop's side, neither side makes it (--laptop).
    if args.no_cpu_latency_request {
        cmd.arg("--laptop");
    }
    let out = cmd
        .output()
        .context("cannot run cyclictest (install Debian's rt-tests, or use --floor builtin)")?;
    if !out.status.success() {
        bail!(
            "cyclictest failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    parse_cyclictest_histogram(&String::from_utf8_lossy(&out.stdout))
}

/// Percentiles from cyclictest's `-h` output: lines `bucket_us count` (one thread), plus
/// `# Max Latencies:` for the exact maximum.
fn parse_cyclictest_histogram(text: &str) -> anyhow::Result<Floored> {
    let mut hist = NsHistogram::new();
    let mut max_us = None;
    let mut total = 0u64;
    for line in text.lines() {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("# Max Latencies:") {
            max_us = rest
                .split_whitespace()
                .next()
                .and_then(|v| v.parse::<f64>().ok());
            continue;
        }
        if line.starts_with('#') || line.is_empty() {
            continue;
        }
        let mut it = line.split_whitespace();
        let (Some(b), Some(c)) = (it.next(), it.next()) else {
            continue;
        };
        let (Ok(bucket_us), Ok(count)) = (b.parse::<u64>(), c.parse::<u64>()) else {
            continue;
        };
        for _ in 0..count {
            hist.record(bucket_us * 1000);
        }
        total += count;
    }
    if total == 0 {
        bail!("cyclictest printed no histogram");
    }
    let mut p = hist.percentiles_us();
    if let Some(m) = max_us {
        p.max = m;
    }
    Ok((p, hist.distribution_us()))
}

/// A bare absolute-deadline sleeper at the RT options: the floor without cyclictest.
fn builtin_floor(rt: RtOptions, period_ns: u64, phase: Duration) -> anyhow::Result<Floored> {
    let handle = std::thread::Builder::new()
        .name("floor".into())
        .spawn(move || {
            let _setup = rt::setup_current_thread(&rt);
            let mut hist = NsHistogram::new();
            let end = Instant::now() + phase;
            let mut deadline = rt::monotonic_ns() + period_ns;
            while Instant::now() < end {
                let wake = rt::sleep_until(deadline, 0);
                hist.record(wake.saturating_sub(deadline));
                deadline += period_ns;
                let now = rt::monotonic_ns();
                while deadline < now {
                    deadline += period_ns;
                }
            }
            (hist.percentiles_us(), hist.distribution_us())
        })
        .context("cannot start the floor thread")?;
    handle
        .join()
        .map_err(|_| anyhow::anyhow!("the floor thread panicked"))
}

fn run_loop(
    args: &Args,
    ns: &str,
    rt: RtOptions,
    phase: Duration,
) -> anyhow::Result<(LoopReport, bool, bool)> {
    let running = wall_loop(
        ns,
        &WallLoop {
            rate_hz: args.rate_hz,
            rt,
            ticks: (phase.as_secs_f64() * args.rate_hz) as u64,
            voxel_m: (!args.no_contact).then_some(args.voxel_mm / 1000.0),
        },
    )?;
    while !running.handle.is_finished() {
        std::thread::sleep(Duration::from_millis(50));
    }
    let (_tick, report) = running.handle.join();
    Ok((report, !args.no_contact, args.planner))
}

#[cfg(test)]
mod tests {
    use super::parse_cyclictest_histogram;

    #[test]
    fn reads_a_cyclictest_histogram() {
        let text = "# /dev/cpu_dma_latency set to 0us\n000000 000000\n000001 000090\n000002 000009\n000010 000001\n# Total: 000000100\n# Min Latencies: 00001\n# Avg Latencies: 00001\n# Max Latencies: 00010\n";
        let (p, dist) = parse_cyclictest_histogram(text).unwrap();
        assert_eq!(dist.iter().map(|d| d.1).sum::<u64>(), 100);
        assert_eq!(p.count, 100);
        assert!((p.p50 - 1.0).abs() < 0.01, "{p:?}");
        assert!((p.p99 - 2.0).abs() < 0.01, "{p:?}");
        assert_eq!(p.max, 10.0);
        assert!(parse_cyclictest_histogram("# nothing\n").is_err());
    }
}
