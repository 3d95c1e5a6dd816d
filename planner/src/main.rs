//! `planner`: see `planner --help`. Parsing and running live in `planner::cli`.

fn main() -> std::process::ExitCode {
    match planner::cli::main_with_args(std::env::args_os()) {
        Ok(code) => std::process::ExitCode::from(code as u8),
        Err(e) => {
            eprintln!("planner: error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}
