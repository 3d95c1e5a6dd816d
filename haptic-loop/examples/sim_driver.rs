//! Example device driver for the haptic loop's driver bridge: serves a simulated arm over
//! iceoryx2. Run it, then `haptic-loop run --device driver` with the same `--namespace`.
//!
//! ```sh
//! cargo run -p haptic-loop --example sim_driver -- --namespace default
//! ```

use std::sync::atomic::Ordering;
use std::time::Duration;

use clap::Parser;

/// Serve a simulated arm on the driver bridge services until Ctrl-C.
#[derive(Debug, Parser)]
struct Args {
    /// IPC namespace (the loop must use the same).
    #[arg(long, default_value = ipc_types::services::DEFAULT_NAMESPACE)]
    namespace: String,
    /// State publish rate, Hz.
    #[arg(long, default_value_t = 1000.0)]
    rate_hz: f64,
    /// Zero force when the newest command is older than this, ms.
    #[arg(long, default_value_t = 50)]
    command_timeout_ms: u64,
    /// Stop after this many seconds.
    #[arg(long)]
    duration_s: Option<f64>,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    if let Err(e) = ipc_types::services::validate_namespace(&args.namespace) {
        eprintln!("sim_driver: --namespace: {e}");
        return std::process::ExitCode::from(2);
    }
    let stop = match ipc_types::startup::stop_on_signal("sim_driver") {
        Ok(s) => s,
        Err(e) => {
            eprintln!("sim_driver: cannot install the signal handler: {e}");
            return std::process::ExitCode::from(2);
        }
    };
    if let Some(d) = args.duration_s {
        if !(d.is_finite() && d > 0.0) {
            eprintln!("sim_driver: --duration-s must be a finite number > 0, got {d}");
            return std::process::ExitCode::from(2);
        }
        let s = stop.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_secs_f64(d));
            s.store(true, Ordering::Release);
        });
    }
    match haptic_loop::sim_driver::run(
        &args.namespace,
        args.rate_hz,
        Duration::from_millis(args.command_timeout_ms),
        &stop,
    ) {
        Ok(r) => {
            println!(
                "sim_driver: {} states published, {} commands applied, {} ignored",
                r.states, r.applied, r.ignored
            );
            std::process::ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("sim_driver: error: {e}");
            std::process::ExitCode::from(2)
        }
    }
}
