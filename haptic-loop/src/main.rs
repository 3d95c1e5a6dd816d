//! `haptic-loop`: see `haptic-loop --help`. Parsing and running live in `haptic_loop::app`.

use clap::{Parser, Subcommand};
use haptic_loop::alloc_count::CountingAllocator;
use haptic_loop::app::{self, DemoArgs, RunArgs};

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
    /// Loop + planner process + a simulated operator heading for the hole; prints progress
    /// each second and a summary. Exit code 0 when solved within the time limit.
    Demo(DemoArgs),
    /// Only the loop, on the simulated arm or a real device (--device); start a planner
    /// yourself with `planner serve`. Runs until Ctrl-C / SIGTERM or --duration-s.
    Run(RunArgs),
    /// List attached devices (SpaceMouse, Force Dimension, OpenHaptics, bridged driver)
    /// with their limits. Exit code 0, also when none is found.
    Devices(haptic_loop::device_select::DevicesArgs),
    /// The planner process, exactly as the `planner` binary (`haptic-loop planner --help`).
    #[command(disable_help_flag = true)]
    Planner {
        /// Arguments for the planner.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<std::ffi::OsString>,
    },
}

fn main() -> std::process::ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => e.exit(),
    };
    let result = match cli.command {
        Command::Planner { args } => {
            let argv = std::iter::once(std::ffi::OsString::from("planner")).chain(args);
            planner::cli::main_with_args(argv)
        }
        Command::Demo(a) => {
            planner::cli::init_logging();
            app::demo(&a)
        }
        Command::Devices(a) => haptic_loop::device_select::list(&a),
        Command::Run(a) => {
            planner::cli::init_logging();
            app::run(&a)
        }
    };
    match result {
        Ok(code) => std::process::ExitCode::from(code.clamp(0, 255) as u8),
        Err(e) => {
            eprintln!("haptic-loop: error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}
