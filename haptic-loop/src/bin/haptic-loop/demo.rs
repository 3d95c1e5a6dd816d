//! `haptic-loop demo`: the loop on the simulated arm (or SpaceMouse) held by a simulated
//! operator following the scene's route (or, on a scene without one, the newcomer on its
//! own coarse way), the planner as a child process (the `planner`
//! executable, H-RRT-C by default), progress each second and a summary. Exit code 0 when
//! solved within the time limit, 1 when not, 3 when the planner proved there is no way
//! through (the session ends then), 130 when interrupted unsolved. With `--no-planner` the
//! operator is alone: 0 when the object reached the goal, 1 when not.

use crate::args::{self, DemoArgs};
use anyhow::Context;
use haptic_loop::device_choice::DeviceChoice;
use haptic_loop::session::{self, scenario};
use std::path::PathBuf;
use std::process::{Child, Command};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The planner executable: `--planner-exe`, else `planner` in this executable's folder
/// (where cargo builds both).
fn planner_exe(given: Option<&PathBuf>) -> anyhow::Result<PathBuf> {
    if let Some(p) = given {
        anyhow::ensure!(
            p.is_file(),
            "--planner-exe {}: no such file; build it with `cargo build --release -p planner`",
            p.display()
        );
        return Ok(p.clone());
    }
    let me = std::env::current_exe().context("cannot find the haptic-loop executable")?;
    let dir = me
        .parent()
        .context("the haptic-loop executable has no folder")?;
    let exe = dir.join("planner");
    anyhow::ensure!(
        exe.is_file(),
        "the planner executable is not beside haptic-loop ({} is missing): build it with \
         `cargo build --release -p planner` (or the same profile as haptic-loop), or give \
         its path with --planner-exe",
        exe.display()
    );
    Ok(exe)
}

/// Asks the planner to stop (SIGTERM), waits up to 5 s, then kills it.
fn stop_planner(child: &mut Child) {
    // SAFETY: kill(2) with a pid we spawned and still own (not yet reaped).
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) };
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline && matches!(child.try_wait(), Ok(None)) {
        std::thread::sleep(Duration::from_millis(20));
    }
    if matches!(child.try_wait(), Ok(None)) {
        let _ = child.kill();
    }
    let _ = child.wait();
}

/// Exit code when the planner proved there is no way from the start to the goal (as
/// `planner solve`'s).
pub const NO_WAY_EXIT: i32 = 3;

/// Runs the command; see the module docs for the exit code.
pub fn run(args: &DemoArgs, stop: &Arc<AtomicBool>) -> anyhow::Result<i32> {
    let oom = crate::lower_oom_score_adj();
    let setup = args.common.to_setup("expert", args.seed)?;
    let limit = args::seconds("time-limit-s", args.time_limit_s)?;
    let after = args::seconds_or_zero("after-solve-s", args.after_solve_s)?;
    let min_run = args::seconds_or_zero("min-run-s", args.min_run_s)?;
    let exe = match args.no_planner {
        true => None,
        false => Some(planner_exe(args.planner_exe.as_ref())?),
    };
    let choice: DeviceChoice = args.device.parse()?;
    let input = match choice {
        DeviceChoice::SimSpaceMouse => scenario::SimInput::SpaceMouse,
        _ => scenario::SimInput::Arm,
    };
    let (mut device, operator) = scenario::simulated_device(&setup, input)?;
    device.open().map_err(|e| choice.open_error(e))?;
    // Build the voxmap before anything starts: it takes seconds at fine voxel sizes.
    let Some(contact) = crate::build_contact(&setup, device.spec(), stop)? else {
        eprintln!("haptic-loop: stopped during start-up");
        return Ok(130);
    };

    let mut child = match &exe {
        Some(exe) => Some(start_planner(exe, args, &setup)?),
        None => None,
    };
    let planner = match &child {
        Some(c) => format!("planner pid {} ({})", c.id(), args.sampling),
        None => "no planner (the operator alone)".to_owned(),
    };
    tracing::info!(
        "demo: haptic loop at {} Hz on {}, {planner}, scene '{}', time limit {} s",
        setup.runner.rate_hz,
        choice.name(),
        setup.scene.name,
        args.time_limit_s
    );

    let mut planner_exited = child.is_none();
    let end = session::run(
        &setup,
        device,
        |e| choice.open_error(e),
        contact,
        stop,
        |watch, elapsed| {
            if !planner_exited
                && let Some(child) = child.as_mut()
                && let Ok(Some(status)) = child.try_wait()
            {
                tracing::warn!(
                    "demo: planner process exited ({status}); the loop goes on without guidance"
                );
                planner_exited = true;
            }
            let reached = match (args.until_goal, watch.solved_at()) {
                _ if args.no_planner => watch.at_goal_at().filter(|_| args.until_goal),
                (false, Some(t)) => Some(t),
                (true, Some(t)) => watch.at_goal_at().map(|g| g.max(t)),
                (_, None) => None,
            };
            if watch.no_way_at().is_some() {
                return true;
            }
            match reached {
                Some(t) => elapsed >= (t + after).max(min_run),
                None => elapsed >= limit,
            }
        },
    );
    if let Some(child) = child.as_mut() {
        stop_planner(child);
    }
    let mut summary = end?.summary();
    summary.operator = operator.as_deref().map(session::OperatorSummary::of);
    summary.oom_score_adj = Some(oom);
    crate::finish(&summary, args.common.summary_json.as_deref())?;
    let done = match args.no_planner {
        true => summary.time_to_goal_s.is_some(),
        false => summary.solved,
    };
    if summary.no_way {
        return Ok(NO_WAY_EXIT);
    }
    if stop.load(Ordering::Acquire) && !done {
        return Ok(130);
    }
    Ok(if done { 0 } else { 1 })
}

/// Starts `planner serve` on the session's namespace and scene with the demo's planner
/// options.
fn start_planner(
    exe: &std::path::Path,
    args: &DemoArgs,
    setup: &session::LoopSetup,
) -> anyhow::Result<Child> {
    let mut command = Command::new(exe);
    command
        .args(["serve", "--namespace", &setup.namespace])
        .args(["--scene", &setup.scene_arg])
        .args(["--seed", &args.seed.to_string()])
        .args(["--sampling", &args.sampling]);
    if let Some(alpha) = args.alpha {
        command.args(["--alpha", &alpha.to_string()]);
    }
    if let Some(extra) = &args.planner_args {
        command.args(extra.split_whitespace());
    }
    // A signal now stops the session in order (and the planner with it).
    ipc_types::startup::hold_resources();
    command
        .spawn()
        .with_context(|| format!("cannot start the planner process ({})", exe.display()))
}
