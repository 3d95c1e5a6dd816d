//! `haptic-loop run`: the loop on the simulated arm or a real device, with no planner of
//! its own (start one with `planner serve`). Runs until Ctrl-C / SIGTERM or --duration-s.

use crate::args::{self, RunArgs};
use crate::ros2;
use haptic_loop::device_choice::{self, DeviceChoice};
use haptic_loop::session::{self, scenario};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// Runs the command; the exit code is 0.
pub fn run(args: &RunArgs, stop: &Arc<AtomicBool>) -> anyhow::Result<i32> {
    // Before any child: a ROS 2 driver's gateway inherits it.
    let oom = crate::lower_oom_score_adj();
    let setup = args.common.to_setup("scripted", 1)?;
    let duration = args
        .duration_s
        .map(|d| args::seconds("duration-s", d))
        .transpose()?;
    let choice = &args.device.device;
    // A ROS 2 driver's arm is served by hrrtc-ros2 as an external driver: start it first.
    let mut gateway = match choice {
        DeviceChoice::Ros2(d) => Some(ros2::Gateway::start(
            d,
            &setup.namespace,
            args.device.ros2_exe.as_deref(),
        )?),
        _ => None,
    };
    let mut operator = None;
    let mut device = device_choice::build(&args.device.options(), &setup.namespace, |input| {
        let (device, stats) = scenario::simulated_device(&setup, input)?;
        operator = stats;
        Ok(device)
    })?;
    // Open now: a backend's limits are final only once open, and the contact coupling is
    // sized from them. `Tick::new` opens it again, which the device trait allows.
    device.open().map_err(|e| choice.open_error(e))?;
    // Build the voxmap before anything starts: it takes seconds at fine voxel sizes.
    let Some(contact) = crate::build_contact(&setup, device.spec(), stop)? else {
        eprintln!("haptic-loop: stopped during start-up");
        return Ok(130);
    };
    tracing::info!(
        "haptic loop at {} Hz on {}, namespace '{}', scene '{}'",
        setup.runner.rate_hz,
        choice.name(),
        setup.namespace,
        setup.scene.name
    );
    let end = session::run(
        &setup,
        device,
        |e| choice.open_error(e),
        contact,
        stop,
        |_, elapsed| {
            if let Some(g) = gateway.as_mut() {
                g.watch();
            }
            duration.is_some_and(|d| elapsed >= d)
        },
    )?;
    drop(gateway);
    let mut summary = end.summary();
    summary.operator = operator.as_deref().map(session::OperatorSummary::of);
    summary.oom_score_adj = Some(oom);
    crate::finish(&summary, args.common.summary_json.as_deref())?;
    Ok(0)
}
