//! `haptic-loop`: the 1 kHz haptic loop's command line. Parses the arguments (`args`),
//! validates them into a `LoopSetup`, and runs a command (`run`, `demo`, `devices`); the
//! work is in the `haptic_loop` library.

mod args;
mod demo;
mod devices;
mod ros2;
mod run;

use anyhow::Context;
use args::{DemoArgs, DevicesArgs, RunArgs};
use clap::{Parser, Subcommand};
use haptic_loop::alloc_count::CountingAllocator;
use haptic_loop::session::Summary;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

// Counts the RT thread's allocations so every run reports them (one relaxed atomic add per
// allocation on marked threads, one thread-local read otherwise).
#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// Hard-real-time haptic loop paired with an interactive motion planner.
#[derive(Debug, Parser)]
#[command(name = "haptic-loop", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Loop + planner process (the `planner` executable) + a simulated operator heading
    /// for the hole; prints progress each second and a summary. Exit code 0 when solved
    /// within the time limit.
    Demo(DemoArgs),
    /// Only the loop, on the simulated arm or a real device (--device); start a planner
    /// yourself with `planner serve`. Runs until Ctrl-C / SIGTERM or --duration-s.
    Run(RunArgs),
    /// List attached devices (SpaceMouse, Force Dimension, OpenHaptics, external driver)
    /// with their limits. Exit code 0, also when none is found.
    Devices(DevicesArgs),
}

/// The flag SIGINT / SIGTERM set once the process holds IPC resources or a child; before
/// that (reading the scene, building the contact model for a simulated device) the signal
/// ends the process at once with exit code 130 (`ipc_types::startup`).
fn stop_on_signal() -> anyhow::Result<Arc<AtomicBool>> {
    ipc_types::startup::stop_on_signal("haptic-loop")
        .context("cannot install the SIGINT/SIGTERM handler")
}

/// Shows the contact model's build (a progress line on a terminal, a log line every 2 s
/// otherwise) and stops it on `stop`; the build's error, or `None` when it was stopped.
fn build_contact(
    setup: &haptic_loop::session::LoopSetup,
    spec: &::devices::DeviceSpec,
    stop: &Arc<AtomicBool>,
) -> anyhow::Result<Option<Option<haptic_loop::contact::ContactStage>>> {
    use haptic_loop::contact::Progress;
    use scene::progress::Display;
    let progress = Arc::new(Progress::new(stop.clone()));
    let display = Display::start(progress.clone(), std::time::Duration::from_secs(2));
    let built = setup.contact_stage(spec, &progress);
    drop(display);
    match built {
        Ok(stage) => Ok(Some(stage)),
        Err(_) if stop.load(Ordering::Acquire) => Ok(None),
        Err(e) => Err(e.into()),
    }
}

/// The loop's `oom_score_adj`: the kernel's OOM killer takes every other process of the
/// host first (default 0; the planner raises its own to 500, the gateways to 300), since
/// with the loop gone the arm is no longer driven. Not -1000, which would exempt it: a loop
/// that leaks is still ended before the host locks up.
const OOM_SCORE_ADJ: i32 = -900;

/// Lowers this process's `oom_score_adj` to [`OOM_SCORE_ADJ`] where `CAP_SYS_RESOURCE`
/// allows it; without it the value is kept, with a warning (not an error). Processes the
/// loop starts afterwards inherit it (a ROS 2 driver's gateway keeps it; the demo's planner
/// raises its own). What is in effect goes into the summary.
fn lower_oom_score_adj() -> ipc_types::startup::OomScoreAdj {
    use ipc_types::startup::OomOutcome;
    let oom = ipc_types::startup::lower_oom_score_adj(OOM_SCORE_ADJ);
    match oom.outcome {
        OomOutcome::Applied | OomOutcome::Kept => tracing::info!("oom_score_adj {oom}"),
        OomOutcome::Refused | OomOutcome::Unavailable => tracing::warn!(
            "oom_score_adj {oom}; under memory pressure the OOM killer may take the loop \
             before other processes (docs/guide/running-as-a-service.md)"
        ),
    }
    oom
}

/// Prints the summary and writes it as JSON when asked.
fn finish(summary: &Summary, json: Option<&std::path::Path>) -> anyhow::Result<()> {
    println!("{summary}");
    match json {
        Some(p) => args::write_json(p, summary),
        None => Ok(()),
    }
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    ipc_types::startup::init_logging("info");
    let result = match cli.command {
        Command::Demo(a) => stop_on_signal().and_then(|stop| demo::run(&a, &stop)),
        Command::Run(a) => stop_on_signal().and_then(|stop| run::run(&a, &stop)),
        Command::Devices(a) => devices::run(&a),
    };
    match result {
        Ok(code) => std::process::ExitCode::from(code.clamp(0, 255) as u8),
        Err(e) => {
            eprintln!("haptic-loop: error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}
