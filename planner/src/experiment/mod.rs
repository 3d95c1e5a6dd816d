//! `planner experiment`: the papers' sweeps in lockstep (`irrt`, `hrrtc`: [`lockstep`])
//! and live sessions of both processes (`live`: [`live`]), with the options they share
//! ([`ExperimentArgs`]).

mod args;
mod live;
mod lockstep;

pub use args::ExperimentArgs;

/// Runs the sweep `a` names.
pub fn run(a: &ExperimentArgs) -> anyhow::Result<i32> {
    if a.sweep == "live" {
        live::run(a)
    } else {
        lockstep::run(a)
    }
}
