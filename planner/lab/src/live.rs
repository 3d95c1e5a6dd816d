//! Live experiments: real sessions of the two processes (`haptic-loop demo`: the loop at its
//! rate with contact on the simulated arm or SpaceMouse held by the simulated operator, the
//! planner as its own process), one per scene × method × seed, and their reports.
//!
//! This module knows the methods and what a run's summary says; starting the processes is
//! the binary's business (`planner experiment live`). Reports: the runs as CSV, a summary
//! per (scene, method) as markdown, and a plot of the times to solve.

mod report;

pub use report::{
    LiveSummary, MIN_SEEDS_FOR_INTERVAL, RunTimes, from_csv, plot, seed_interval, summarize,
    to_csv, to_markdown,
};

use crate::LabError;
use scene::Scene;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The device the simulated operator holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Input {
    /// The simulated haptic arm (`--device sim`): contact and guidance are felt.
    Arm,
    /// The simulated SpaceMouse (`--device sim-spacemouse`): rate control, nothing felt.
    Mouse,
}

/// One way of planning in a live session.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LiveMethod {
    /// Name in reports (e.g. `hrrtc α=0.1`).
    pub name: String,
    /// A planner runs (false: the operator alone, `haptic-loop demo --no-planner`).
    pub planner: bool,
    /// `planner serve --sampling`.
    pub sampling: String,
    /// H-RRT-C's α, if the method has one.
    pub alpha: Option<f64>,
    /// H-RRT-C's `planner serve --authority` (`fixed` or `adaptive`), if the method sets it.
    pub authority: Option<String>,
    /// What the operator holds.
    pub input: Input,
    /// Guidance rendered (false: `--no-guidance`).
    pub guidance: bool,
    /// Operator preset.
    pub operator: String,
    /// `planner serve --portfolio` (the narrow-passage methods taking turns), if the
    /// method sets it: `off` keeps the papers' single planner whatever the default is.
    pub portfolio: Option<String>,
    /// More `planner serve` options.
    pub planner_args: Option<String>,
}

/// The method names [`LiveMethod::parse`] accepts.
pub const METHOD_NAMES: [&str; 15] = [
    "operator-alone",
    "rrt-connect",
    "hrrtc-fixed",
    "hrrtc-adaptive",
    "hrrtc-portfolio",
    "pos+cs",
    "path",
    "irrtc-mouse",
    "hrrtc",
    "hrrtc-paper",
    "hrrtc-noguide",
    "hrrtc-novice",
    "hrrtc-novice-noguide",
    "hrrtc-mouse",
    "hrrtc-shared",
];

/// The operator preset of the methods that do not name their own.
pub const DEFAULT_OPERATOR: &str = "expert";

impl LiveMethod {
    fn new(name: String, sampling: &str, alpha: Option<f64>, input: Input) -> Self {
        LiveMethod {
            name,
            planner: true,
            sampling: sampling.to_owned(),
            alpha,
            authority: Some("fixed".to_owned()),
            input,
            guidance: true,
            operator: DEFAULT_OPERATOR.to_owned(),
            portfolio: Some("off".to_owned()),
            planner_args: None,
        }
    }

    /// The methods a name stands for, held by `operator` (a `haptic-loop demo
    /// --operator` preset, which the demo checks) unless the method names its own:
    /// - `operator-alone`: no planner at all (`haptic-loop demo --no-planner`): the
    ///   operator's own time to the goal;
    /// - `rrt-connect`: automatic (`--sampling cs`; the operator moves, the planner ignores
    ///   it; once solved, its path's guidance leads the operator);
    /// - `hrrtc-fixed`: H-RRT-C with the paper's fixed α (`--authority fixed`), one method
    ///   per α of `alphas`;
    /// - `hrrtc-adaptive`: H-RRT-C with the authority that adapts to a stuck operator
    ///   (`--authority adaptive`, α while it progresses), one method per α;
    /// - `hrrtc-portfolio`: H-RRT-C with the fixed α and the narrow-passage methods
    ///   taking turns (`--portfolio all`), one method per α;
    ///
    /// Every method but `hrrtc-portfolio` runs one planner (`--portfolio off`): the
    /// papers' methods as they wrote them, whatever `planner serve`'s default.
    /// - `pos+cs`, `path`: I-RRT's samplers with the operator on the arm;
    /// - `irrtc-mouse`: I-RRT-C, contact sampling with authority α = 0 (H-RRT-C Table II),
    ///   the operator on the SpaceMouse;
    /// - `hrrtc`: H-RRT-C with the operator on the arm, one method per α of `alphas`, with
    ///   the fixed α (as `hrrtc-fixed`, under the name of the sweeps of 3 Dec; all the
    ///   `hrrtc-…` methods below also run with the fixed α);
    /// - `hrrtc-paper`: the same with Algorithm 2's human mode as the paper writes it
    ///   (`planner serve --human-mode every`: q_device sampled even when it repeats), one
    ///   method per α;
    /// - `hrrtc-noguide`, `hrrtc-novice`, `hrrtc-novice-noguide`, `hrrtc-mouse`: H-RRT-C at
    ///   `guide_alpha` without guidance, with the novice, with the novice and no guidance,
    ///   on the SpaceMouse;
    /// - `hrrtc-shared`: H-RRT-C at `guide_alpha` keeping the authority share in contact
    ///   (`planner serve --contact-authority shared`), with the novice, who is blocked
    ///   and stays in contact most.
    ///
    /// `NAME=α` (e.g. `hrrtc-adaptive=0.9`) runs a method that takes an α at this α only,
    /// instead of `alphas` (or `guide_alpha`).
    pub fn parse(
        name: &str,
        alphas: &[f64],
        guide_alpha: f64,
        operator: &str,
    ) -> Result<Vec<Self>, LabError> {
        if let Some((base, a)) = name.split_once('=') {
            let alpha = a
                .parse::<f64>()
                .ok()
                .filter(|a| (0.0..=1.0).contains(a))
                .ok_or_else(|| LabError::MethodAlpha(name.to_owned()))?;
            return Self::parse(base, &[alpha], alpha, operator);
        }
        let hrrtc = |tag: &str, a: f64, input| {
            LiveMethod::new(format!("{tag} α={a}"), "hrrtc", Some(a), input)
        };
        let mut methods = match name {
            "operator-alone" => vec![LiveMethod {
                planner: false,
                sampling: "none".into(),
                authority: None,
                portfolio: None,
                guidance: false,
                ..LiveMethod::new(name.into(), "none", None, Input::Arm)
            }],
            "rrt-connect" => vec![LiveMethod {
                authority: None,
                ..LiveMethod::new(name.into(), "cs", None, Input::Arm)
            }],
            "hrrtc-fixed" => alphas.iter().map(|&a| hrrtc(name, a, Input::Arm)).collect(),
            "hrrtc-portfolio" => alphas
                .iter()
                .map(|&a| LiveMethod {
                    portfolio: Some("all".into()),
                    ..hrrtc(name, a, Input::Arm)
                })
                .collect(),
            "hrrtc-adaptive" => alphas
                .iter()
                .map(|&a| LiveMethod {
                    authority: Some("adaptive".into()),
                    ..hrrtc(name, a, Input::Arm)
                })
                .collect(),
            "pos+cs" | "path" => vec![LiveMethod {
                authority: None,
                ..LiveMethod::new(format!("irrt-{name}"), name, None, Input::Arm)
            }],
            "irrtc-mouse" => vec![LiveMethod::new(
                name.into(),
                "hrrtc",
                Some(0.0),
                Input::Mouse,
            )],
            "hrrtc" => alphas
                .iter()
                .map(|&a| hrrtc("hrrtc", a, Input::Arm))
                .collect(),
            "hrrtc-paper" => alphas
                .iter()
                .map(|&a| LiveMethod {
                    planner_args: Some("--human-mode every".into()),
                    ..hrrtc(name, a, Input::Arm)
                })
                .collect(),
            "hrrtc-noguide" => vec![LiveMethod {
                guidance: false,
                ..hrrtc(name, guide_alpha, Input::Arm)
            }],
            "hrrtc-novice" => vec![LiveMethod {
                operator: "novice".into(),
                ..hrrtc(name, guide_alpha, Input::Arm)
            }],
            "hrrtc-novice-noguide" => vec![LiveMethod {
                operator: "novice".into(),
                guidance: false,
                ..hrrtc(name, guide_alpha, Input::Arm)
            }],
            "hrrtc-mouse" => vec![hrrtc(name, guide_alpha, Input::Mouse)],
            "hrrtc-shared" => vec![LiveMethod {
                operator: "novice".into(),
                planner_args: Some("--contact-authority shared".into()),
                ..hrrtc(name, guide_alpha, Input::Arm)
            }],
            _ => return Err(LabError::UnknownMethod(name.to_owned())),
        };
        for m in &mut methods {
            if m.operator == DEFAULT_OPERATOR {
                m.operator = operator.to_owned();
            }
        }
        Ok(methods)
    }

    /// The `haptic-loop demo` options of this method (scene, seed and limits aside).
    pub fn demo_args(&self) -> Vec<String> {
        let device = match self.input {
            Input::Arm => "sim",
            Input::Mouse => "sim-spacemouse",
        };
        let mut a: Vec<String> = Vec::new();
        if self.planner {
            a.extend(["--sampling".to_owned(), self.sampling.clone()]);
        } else {
            a.push("--no-planner".into());
        }
        a.extend([
            "--device".to_owned(),
            device.to_owned(),
            "--operator".to_owned(),
            self.operator.clone(),
        ]);
        if let Some(alpha) = self.alpha {
            a.push("--alpha".into());
            a.push(alpha.to_string());
        }
        if !self.guidance && self.planner {
            a.push("--no-guidance".into());
        }
        let planner_args: Vec<String> = self
            .authority
            .iter()
            .map(|x| format!("--authority {x}"))
            .chain(self.portfolio.iter().map(|x| format!("--portfolio {x}")))
            .chain(self.planner_args.clone())
            .collect();
        if !planner_args.is_empty() {
            a.push("--planner-args".into());
            a.push(planner_args.join(" "));
        }
        a
    }
}

/// One live run: a CSV row.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LiveRun {
    /// Scene.
    pub scene: String,
    /// The scene's `[[route]]` was kept (false: the session ran on a copy without it).
    pub route: bool,
    /// Method name.
    pub method: String,
    /// A planner ran (false: `operator-alone`).
    pub planner: bool,
    /// α, NaN when the method has none.
    pub alpha: f64,
    /// `arm` or `mouse`.
    pub input: Input,
    /// Guidance rendered.
    pub guidance: bool,
    /// Operator preset.
    pub operator: String,
    /// Seed of the planner and the operator.
    pub seed: u64,
    /// Solved within the limit.
    pub solved: bool,
    /// Wall-clock time from the loop's start to the planner's solution, s (NaN unsolved).
    pub time_to_solve_s: f64,
    /// Planner nodes at the end.
    pub nodes: u64,
    /// Tree edges at the end (nodes − trees).
    pub edges: u64,
    /// Time until the held object first reached the goal zone, s (NaN if it did not).
    pub time_to_goal_s: f64,
    /// Time in contact, s.
    pub contact_s: f64,
    /// Deepest penetration, mm.
    pub max_penetration_mm: f64,
    /// Voxel size, mm.
    pub voxel_mm: f64,
    /// Largest change of the commanded force between ticks, N.
    pub max_force_step_n: f64,
    /// Ticks.
    pub ticks: u64,
    /// Deadline misses.
    pub deadline_misses: u64,
    /// 99.9th percentile of the loop's compute time per tick, µs.
    pub compute_p999_us: f64,
    /// Session length, s.
    pub run_s: f64,
    /// Times the operator was blocked (0 without a reacting operator).
    pub blocks: u32,
    /// Its corrections of a wrong turn or orientation.
    pub corrections: u32,
    /// Its retries after a block with nothing to correct.
    pub retries: u32,
}

/// The parts of `haptic-loop --summary-json` a run reads.
#[derive(Deserialize)]
struct DemoSummary {
    solved: bool,
    time_to_solve_s: Option<f64>,
    planner_nodes: u64,
    planner_trees: u32,
    time_to_goal_s: Option<f64>,
    max_force_step_n: f64,
    ticks: u64,
    deadline_misses: u64,
    run_s: f64,
    contact: Option<DemoContact>,
    operator: Option<DemoOperator>,
    loop_report: DemoLoop,
}

#[derive(Deserialize)]
struct DemoLoop {
    compute_us: DemoPercentiles,
}

#[derive(Deserialize)]
struct DemoPercentiles {
    p999: f64,
}

#[derive(Deserialize)]
struct DemoOperator {
    blocks: u32,
    corrections: u32,
    retries: u32,
}

#[derive(Deserialize)]
struct DemoContact {
    contact_s: f64,
    max_penetration_mm: f64,
    voxel_mm: f64,
}

impl LiveRun {
    /// The run of `method` on `scene` (`route`: with its `[[route]]`) with `seed` from the
    /// demo's summary JSON `text` (`origin` names it in errors).
    pub fn from_summary(
        scene: &str,
        route: bool,
        method: &LiveMethod,
        seed: u64,
        text: &str,
        origin: &str,
    ) -> Result<Self, LabError> {
        let s: DemoSummary = serde_json::from_str(text).map_err(|e| LabError::Summary {
            origin: origin.to_owned(),
            reason: e.to_string(),
        })?;
        let (contact_s, pen, voxel) = s.contact.map_or((0.0, 0.0, f64::NAN), |c| {
            (c.contact_s, c.max_penetration_mm, c.voxel_mm)
        });
        Ok(LiveRun {
            scene: scene.to_owned(),
            route,
            method: method.name.clone(),
            planner: method.planner,
            alpha: method.alpha.unwrap_or(f64::NAN),
            input: method.input,
            guidance: method.guidance,
            operator: method.operator.clone(),
            seed,
            solved: s.solved,
            time_to_solve_s: s.time_to_solve_s.unwrap_or(f64::NAN),
            nodes: s.planner_nodes,
            edges: s.planner_nodes.saturating_sub(u64::from(s.planner_trees)),
            time_to_goal_s: s.time_to_goal_s.unwrap_or(f64::NAN),
            contact_s,
            max_penetration_mm: pen,
            voxel_mm: voxel,
            max_force_step_n: s.max_force_step_n,
            ticks: s.ticks,
            deadline_misses: s.deadline_misses,
            compute_p999_us: s.loop_report.compute_us.p999,
            run_s: s.run_s,
            blocks: s.operator.as_ref().map_or(0, |o| o.blocks),
            corrections: s.operator.as_ref().map_or(0, |o| o.corrections),
            retries: s.operator.as_ref().map_or(0, |o| o.retries),
        })
    }
}

/// A copy of `scene` (a built-in name or a scene file) without its `[[route]]`, written
/// into `dir/<scene, file-name safe>/` (`<name>.toml` and its meshes); returns the file.
/// A session on it is a session on a user's own scene: the simulated operator has no
/// route to follow.
pub fn write_without_route(scene: &str, dir: &Path) -> Result<PathBuf, LabError> {
    let mut s = Scene::by_name_or_path(scene).map_err(|source| LabError::Scene {
        scene: scene.to_owned(),
        source,
    })?;
    s.route.clear();
    let safe: String = scene
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let sub = dir.join(safe);
    s.write_to_dir(&sub).map_err(LabError::write(&sub))
}

#[cfg(test)]
mod tests;
