//! Soak: the product's processes as deployed, for an hour (docs/benchmarks.md, "Soak"). The
//! loop (`haptic-loop run`, the simulated arm held by the newcomer, on a scene with no way
//! through so that the planners plan all the while) with a local planner that is killed
//! (`kill -9`) or hung (`SIGSTOP`, then killed) and restarted every `--restart-s`, and a
//! second planner across the bridge (`hrrtc-bridge --side loop` here, `planner serve
//! --bridge-connect quic/...` in another iceoryx2 domain as host B, mutual TLS) for the
//! whole run, held to `--remote-max-memory-mb`. Every process's `RssAnon` and `RssShmem`
//! once a minute; at the end a table (and `--json`) of the loop's faults, deadline misses,
//! allocations, guidance lost and back, the restarts and whether each was followed, memory
//! at minutes 1, 10, 30 and 60, and the goals, PASS or FAIL (`--check`: exit code 1 when one
//! fails). Ctrl-C / SIGTERM stops every process and reports what ran (exit code 130).
//!
//! `cargo build --release -p benches -p planner -p haptic-loop -p hrrtc-bridge &&
//! target/release/soak --minutes 60 --check --json soak.json`

use anyhow::{Context, bail};
use benches::across::sibling_exe;
use benches::harness::soak::{self, SoakConfig, SoakError};
use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;

/// The scene of the soak: the wall's hole cut to 22 x 22 mm, too small for the S, and no
/// route (the newcomer looks for its own way).
const SCENE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../tests/scenes/wall-hole-22mm.toml"
);

/// Soak the loop, a planner killed and restarted beside it and a planner across the
/// bridge; report faults, deadline misses, restarts followed and every process's memory.
#[derive(Debug, Parser)]
struct Args {
    /// How long, minutes (from the moment every process serves).
    #[arg(long, default_value_t = 60.0)]
    minutes: f64,
    /// Kill or hang the local planner, then restart it, every this many seconds
    /// (alternately `kill -9` and `SIGSTOP` followed by `kill -9` after --hang-s).
    #[arg(long, default_value_t = 60.0)]
    restart_s: f64,
    /// How long a hung planner stays stopped before it is killed, s.
    #[arg(long, default_value_t = 2.0)]
    hang_s: f64,
    /// A restarted planner counts as followed when, within this many seconds of its start,
    /// its guidance reached the loop fresh and the loop rendered fresh guidance.
    #[arg(long, default_value_t = 10.0)]
    follow_s: f64,
    /// Scene file [default: tests/scenes/wall-hole-22mm.toml of this checkout].
    #[arg(long)]
    scene: Option<PathBuf>,
    /// The simulated operator (`haptic-loop run --operator`).
    #[arg(long, default_value = "newcomer", value_parser = ["expert", "novice", "newcomer", "scripted"])]
    operator: String,
    /// SCHED_FIFO priority of the loop's RT thread (0 = normal scheduler).
    #[arg(long, default_value_t = 80)]
    priority: u8,
    /// Voxel size of the loop's contact, mm.
    #[arg(long, default_value_t = 1.0)]
    voxel_mm: f64,
    /// The remote planner's memory bound (`planner serve --max-memory-mb`, passed when
    /// that planner has the flag), MiB.
    #[arg(long, default_value_t = 256)]
    remote_max_memory_mb: u64,
    /// What the remote planner's RssAnon may exceed its bound by (thread stacks, the
    /// allocator's slack, the Zenoh session and what lies outside its trees), MiB.
    #[arg(long, default_value_t = 64)]
    remote_allowance_mb: u64,
    /// Exit with code 1 when a goal is not met.
    #[arg(long)]
    check: bool,
    /// Write the report as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// The run's folder: logs and reports of every process, certificates, host B
    /// [default: hrrtc-soak-PID in the temporary directory, removed when every goal is
    /// met].
    #[arg(long)]
    dir: Option<PathBuf>,
    /// Keep the run's folder when every goal is met.
    #[arg(long)]
    keep: bool,
    /// `haptic-loop` [default: beside this executable].
    #[arg(long)]
    loop_exe: Option<PathBuf>,
    /// `planner` [default: beside this executable].
    #[arg(long)]
    planner_exe: Option<PathBuf>,
    /// `hrrtc-bridge` [default: beside this executable].
    #[arg(long)]
    bridge_exe: Option<PathBuf>,
    /// How long start-up may take (the loop's voxmap, the planners), s.
    #[arg(long, default_value_t = 300.0)]
    start_timeout_s: f64,
}

fn positive(name: &str, v: f64) -> anyhow::Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        bail!("--{name} must be a finite number > 0, got {v}")
    }
}

/// Validates the flags into the soak's configuration.
fn config(args: &Args) -> anyhow::Result<(SoakConfig, bool)> {
    let minutes = positive("minutes", args.minutes)?;
    if minutes > 24.0 * 60.0 {
        bail!("--minutes must be at most 1440, got {minutes}");
    }
    if !(args.restart_s.is_finite() && args.restart_s >= 5.0) {
        bail!("--restart-s must be at least 5, got {}", args.restart_s);
    }
    positive("hang-s", args.hang_s)?;
    positive("follow-s", args.follow_s)?;
    positive("voxel-mm", args.voxel_mm)?;
    positive("start-timeout-s", args.start_timeout_s)?;
    if args.priority > 99 {
        bail!("--priority must be 0–99, got {}", args.priority);
    }
    let scene = args.scene.clone().unwrap_or_else(|| SCENE.into());
    let scene = std::fs::canonicalize(&scene)
        .with_context(|| format!("scene {} (give --scene)", scene.display()))?;
    let (dir, default_dir) = match &args.dir {
        Some(d) => (d.clone(), false),
        None => (
            std::env::temp_dir().join(format!("hrrtc-soak-{}", std::process::id())),
            true,
        ),
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("making {}", dir.display()))?;
    let dir = std::fs::canonicalize(&dir)?;
    let exe = |given: &Option<PathBuf>, name, package, option| {
        sibling_exe(given.as_deref(), name, package, option)
            .and_then(|p| Ok(std::fs::canonicalize(p)?))
    };
    Ok((
        SoakConfig {
            minutes,
            restart_s: args.restart_s,
            hang_s: args.hang_s,
            follow_s: args.follow_s,
            scene,
            operator: args.operator.clone(),
            priority: args.priority,
            voxel_mm: args.voxel_mm,
            remote_max_memory_mb: args.remote_max_memory_mb,
            remote_allowance_mb: args.remote_allowance_mb,
            loop_exe: exe(&args.loop_exe, "haptic-loop", "haptic-loop", "--loop-exe")?,
            planner_exe: exe(&args.planner_exe, "planner", "planner", "--planner-exe")?,
            bridge_exe: exe(
                &args.bridge_exe,
                "hrrtc-bridge",
                "hrrtc-bridge",
                "--bridge-exe",
            )?,
            dir,
            start_timeout_s: args.start_timeout_s,
        },
        default_dir,
    ))
}

fn main() -> ExitCode {
    match run() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("soak: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run() -> anyhow::Result<ExitCode> {
    let args = Args::parse();
    let (config, default_dir) = config(&args)?;
    let stop = ipc_types::startup::stop_on_signal("soak")
        .context("cannot install the SIGINT/SIGTERM handler")?;
    // From here a signal stops the children in order and reports what ran.
    ipc_types::startup::hold_resources();
    let report = match soak::run(&config, &stop) {
        Ok(r) => r,
        Err(SoakError::Stopped) => {
            eprintln!(
                "soak: stopped during start-up; logs in {}",
                config.dir.display()
            );
            return Ok(ExitCode::from(130));
        }
        Err(e) => {
            return Err(anyhow::Error::new(e).context(format!("logs in {}", config.dir.display())));
        }
    };
    println!("{report}");
    if let Some(p) = &args.json {
        let text = serde_json::to_string_pretty(&report)?;
        std::fs::write(p, text + "\n").with_context(|| format!("cannot write {}", p.display()))?;
    }
    if report.passed() && default_dir && !args.keep {
        let _ = std::fs::remove_dir_all(&config.dir);
        println!(
            "removed {} (every goal met; --keep keeps it)",
            config.dir.display()
        );
    }
    Ok(if report.interrupted {
        ExitCode::from(130)
    } else if args.check && !report.passed() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
