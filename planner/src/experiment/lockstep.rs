//! `planner experiment irrt|hrrtc`: the papers' sweeps with a simulated operator in
//! lockstep, then runs.csv, summary.md and plots. The options are validated into a
//! [`SweepConfig`]; [`Sweep`] does the work, this file shows its progress.

use super::ExperimentArgs;
use crate::common::positive;
use anyhow::{Context, bail};
use lab::LabError;
use lab::experiment::sweep::{Sweep, SweepConfig, SweepKind};
use lab::experiment::{hrrtc_specs, irrt_specs};

/// Validates the arguments into a [`SweepConfig`].
fn sweep_config(a: &ExperimentArgs) -> anyhow::Result<SweepConfig> {
    let time_limit_s = positive("time-limit", a.time_limit.unwrap_or(10.0))?;
    let seeds = a.seeds.unwrap_or(5);
    if seeds == 0 {
        bail!("--seeds must be >= 1");
    }
    let (kind, specs) = if a.sweep == "irrt" {
        let methods = a
            .methods
            .iter()
            .map(|m| {
                planner_core::Sampling::parse(m, a.beta, 0.5)
                    .with_context(|| format!("unknown method `{m}` in --methods"))
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let specs = irrt_specs(&a.scene, &methods, &a.sigmas, &a.eps, seeds, time_limit_s);
        (SweepKind::Irrt, specs)
    } else {
        let specs = hrrtc_specs(
            &a.scenes,
            &a.alphas,
            a.hrrtc_eps,
            a.error_sigma,
            a.local_trees,
            seeds,
            time_limit_s,
        );
        (SweepKind::Hrrtc, specs)
    };
    Ok(SweepConfig {
        kind,
        specs,
        seeds,
        time_limit_s,
        out: a.out.clone(),
        pictures: a.pictures,
    })
}

/// Runs the command: the sweep with a progress bar, then prints the summary table and what
/// was written. The exit code is 0; pictures and plots that cannot be drawn are reported
/// and skipped.
pub fn run(a: &ExperimentArgs) -> anyhow::Result<i32> {
    let sweep = Sweep::new(sweep_config(a)?)?;
    let bar = if a.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(sweep.runs() as u64)
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{elapsed_precise} [{bar:40}] {pos}/{len} runs, eta {eta} {msg}",
        )
        .context("progress template")?,
    );
    if a.pictures && !sweep.pictures() {
        eprintln!("planner: no TrueType font found (DejaVuSans.ttf): pictures skipped");
    }
    let results = sweep.run(|r, not_drawn| {
        if let Some(e) = not_drawn {
            eprintln!("planner: {:#}", anyhow::Error::new(e));
        }
        bar.set_message(format!(
            "{} {} seed {}: {}",
            r.scene,
            r.method,
            r.seed,
            if r.solved {
                format!("{:.2} s", r.time_s)
            } else {
                "unsolved".into()
            }
        ));
        bar.inc(1);
    })?;
    bar.finish();
    let reports = sweep.write_reports(&results)?;
    println!("{}", reports.markdown);
    println!(
        "wrote {} and {}",
        reports.csv.display(),
        reports.md.display()
    );
    match sweep.plot(&reports.summaries) {
        Ok(png) => println!("wrote {}", png.display()),
        Err(LabError::NoFont) => {
            eprintln!("planner: no TrueType font found (DejaVuSans.ttf): plots skipped")
        }
        Err(LabError::Draw { path, source }) => {
            eprintln!("planner: cannot draw {}: {source}", path.display())
        }
        Err(e) => return Err(e.into()),
    }
    Ok(0)
}
