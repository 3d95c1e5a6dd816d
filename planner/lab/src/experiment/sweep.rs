//! A whole sweep as `planner experiment` runs it: every run in order (the first seed of each
//! configuration drawn into `roadmaps/` when pictures are asked for), then `runs.csv`,
//! `summary.md` and the sweep's plot in the output directory.

use super::report::{self, Summary};
use super::{RunResult, RunSpec, UserModel, run_drawn};
use crate::LabError;
use planner_core::Sampling;
use std::path::PathBuf;

/// Which of the papers' sweeps (it decides the plot and the file names).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SweepKind {
    /// I-RRT §6: sampling method × σ × ε_v ([`super::irrt_specs`]).
    Irrt,
    /// H-RRT-C Tables I and III: α per scene beside automatic RRT-Connect
    /// ([`super::hrrtc_specs`]).
    Hrrtc,
}

impl SweepKind {
    /// `irrt` or `hrrtc`, as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SweepKind::Irrt => "irrt",
            SweepKind::Hrrtc => "hrrtc",
        }
    }
}

/// A sweep's runs and where its results go.
#[derive(Clone, Debug)]
pub struct SweepConfig {
    /// Which sweep.
    pub kind: SweepKind,
    /// The runs, in order.
    pub specs: Vec<RunSpec>,
    /// Seeds per configuration (for the summary's title).
    pub seeds: u64,
    /// Wall-clock limit per run, s (unsolved runs count at the limit in medians).
    pub time_limit_s: f64,
    /// Output directory (created).
    pub out: PathBuf,
    /// Draw the final roadmap of each configuration's first seed into `out/roadmaps/`.
    pub pictures: bool,
}

/// What [`Sweep::write_reports`] wrote.
#[derive(Clone, Debug)]
pub struct Reports {
    /// One summary per configuration.
    pub summaries: Vec<Summary>,
    /// The summaries as a markdown table.
    pub markdown: String,
    /// `out/runs.csv`.
    pub csv: PathBuf,
    /// `out/summary.md`.
    pub md: PathBuf,
}

/// A validated sweep whose output directories exist.
#[derive(Debug)]
pub struct Sweep {
    config: SweepConfig,
    pictures: bool,
    roadmaps: PathBuf,
}

impl Sweep {
    /// Checks every run (parameters, built-in scene), creates the output directory, and,
    /// when pictures are asked for and a font is found, `out/roadmaps/`.
    pub fn new(config: SweepConfig) -> Result<Sweep, LabError> {
        for s in &config.specs {
            s.params.validate()?;
            if scene::Scene::builtin(&s.scene).is_none() {
                return Err(LabError::UnknownScene(s.scene.clone()));
            }
        }
        std::fs::create_dir_all(&config.out).map_err(LabError::create_dir(&config.out))?;
        let pictures = config.pictures && crate::register_font();
        let roadmaps = config.out.join("roadmaps");
        if pictures {
            std::fs::create_dir_all(&roadmaps).map_err(LabError::create_dir(&roadmaps))?;
        }
        Ok(Sweep {
            config,
            pictures,
            roadmaps,
        })
    }

    /// Runs in the sweep.
    pub fn runs(&self) -> usize {
        self.config.specs.len()
    }

    /// Whether roadmaps are drawn: asked for, and a font was found for their text.
    pub fn pictures(&self) -> bool {
        self.pictures
    }

    /// Runs every spec in order; `after_each` gets each result and, when its picture could
    /// not be drawn, why (the sweep goes on without it).
    pub fn run(
        &self,
        mut after_each: impl FnMut(&RunResult, Option<LabError>),
    ) -> Result<Vec<RunResult>, LabError> {
        let mut results = Vec::with_capacity(self.config.specs.len());
        for s in &self.config.specs {
            let png = (self.pictures && s.seed == 1).then(|| self.roadmaps.join(picture_name(s)));
            let (r, drawn) = run_drawn(s, png.as_deref())?;
            after_each(&r, drawn.err());
            results.push(r);
        }
        Ok(results)
    }

    /// Writes `runs.csv` and `summary.md` (titled with the sweep, the run count, the seeds
    /// and the limit) into the output directory.
    pub fn write_reports(&self, results: &[RunResult]) -> Result<Reports, LabError> {
        let c = &self.config;
        let summaries = report::summarize(results, c.time_limit_s);
        let csv = c.out.join("runs.csv");
        std::fs::write(&csv, report::to_csv(results)).map_err(LabError::write(&csv))?;
        let md = c.out.join("summary.md");
        let markdown = report::to_markdown(&summaries);
        let header = format!(
            "# `planner experiment {}`: {} runs, {} seeds per configuration, {} s limit\n\n",
            c.kind.name(),
            results.len(),
            c.seeds,
            c.time_limit_s
        );
        std::fs::write(&md, header + &markdown).map_err(LabError::write(&md))?;
        Ok(Reports {
            summaries,
            markdown,
            csv,
            md,
        })
    }

    /// Plots the summaries into `out/<sweep>.png` and returns its path;
    /// [`LabError::NoFont`] when no font for the text was found (nothing is drawn).
    pub fn plot(&self, summaries: &[Summary]) -> Result<PathBuf, LabError> {
        if !crate::register_font() {
            return Err(LabError::NoFont);
        }
        let c = &self.config;
        let png = c.out.join(format!("{}.png", c.kind.name()));
        match c.kind {
            SweepKind::Irrt => report::plot_irrt(summaries, c.time_limit_s, &png)?,
            SweepKind::Hrrtc => report::plot_hrrtc(summaries, c.time_limit_s, &png)?,
        }
        Ok(png)
    }
}

/// `<scene>-<method>-sigma<σ>-eps<ε_v>[-alpha<α>].png`, `auto` for automatic runs.
fn picture_name(s: &RunSpec) -> String {
    let method = match s.user {
        UserModel::None => "auto",
        _ => s.params.sampling.name(),
    };
    format!(
        "{}-{}-sigma{}-{}.png",
        s.scene,
        method.replace('+', "_"),
        s.params.user_sigma,
        match s.user {
            UserModel::PassThrough { eps_v } | UserModel::ContactSeeking { eps_v, .. } =>
                format!("eps{eps_v}"),
            UserModel::None => "auto".into(),
        } + &match s.params.sampling {
            Sampling::Hrrtc { alpha } => format!("-alpha{alpha}"),
            _ => String::new(),
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use planner_core::PlannerParams;

    #[test]
    fn pictures_are_named_after_their_configuration() {
        let spec = |user, sampling| RunSpec {
            scene: "tunnels".into(),
            params: PlannerParams {
                sampling,
                user_sigma: 0.05,
                ..PlannerParams::default()
            },
            user,
            seed: 1,
            time_limit_s: 1.0,
        };
        let h = spec(
            UserModel::ContactSeeking {
                eps_v: 0.001,
                error_sigma_rad: 0.1,
            },
            Sampling::Hrrtc { alpha: 0.5 },
        );
        assert_eq!(
            picture_name(&h),
            "tunnels-hrrtc-sigma0.05-eps0.001-alpha0.5.png"
        );
        let p = spec(
            UserModel::PassThrough { eps_v: 0.01 },
            Sampling::Pos { beta: Some(3.0) },
        );
        assert_eq!(picture_name(&p), "tunnels-pos_cs-sigma0.05-eps0.01.png");
        let a = spec(UserModel::None, Sampling::Uniform);
        assert_eq!(picture_name(&a), "tunnels-auto-sigma0.05-auto.png");
    }

    #[test]
    fn a_sweep_checks_its_runs_before_it_creates_anything() {
        let out = std::env::temp_dir().join(format!("lab-sweep-{}", std::process::id()));
        let config = SweepConfig {
            kind: SweepKind::Hrrtc,
            specs: super::super::hrrtc_specs(&["nope".into()], &[0.5], 0.001, 0.1, false, 1, 1.0),
            seeds: 1,
            time_limit_s: 1.0,
            out: out.clone(),
            pictures: false,
        };
        let e = Sweep::new(config).unwrap_err();
        assert!(
            matches!(&e, LabError::UnknownScene(s) if s == "nope"),
            "{e}"
        );
        assert!(!out.exists());
    }
}
