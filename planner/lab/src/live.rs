//! Live experiments: real sessions of the two processes (`haptic-loop demo`: the loop at its
//! rate with contact on the simulated arm or SpaceMouse held by the simulated operator, the
//! planner as its own process), one per scene × method × seed, and their reports.
//!
//! This module knows the methods and what a run's summary says; starting the processes is
//! the binary's business (`planner experiment live`). Reports: the runs as CSV, a summary
//! per (scene, method) as markdown, and a plot of the times to solve.

mod report;

pub use report::{LiveSummary, plot, summarize, to_csv, to_markdown};

use crate::LabError;
use serde::{Deserialize, Serialize};

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
    /// `planner serve --sampling`.
    pub sampling: String,
    /// H-RRT-C's α, if the method has one.
    pub alpha: Option<f64>,
    /// What the operator holds.
    pub input: Input,
    /// Guidance rendered (false: `--no-guidance`).
    pub guidance: bool,
    /// Operator preset.
    pub operator: String,
    /// More `planner serve` options.
    pub planner_args: Option<String>,
}

/// The method names [`LiveMethod::parse`] accepts.
pub const METHOD_NAMES: [&str; 11] = [
    "rrt-connect",
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

impl LiveMethod {
    fn new(name: String, sampling: &str, alpha: Option<f64>, input: Input) -> Self {
        LiveMethod {
            name,
            sampling: sampling.to_owned(),
            alpha,
            input,
            guidance: true,
            operator: "expert".to_owned(),
            planner_args: None,
        }
    }

    /// The methods a name stands for:
    /// - `rrt-connect`: automatic (`--sampling cs`; the operator moves, the planner ignores
    ///   it);
    /// - `pos+cs`, `path`: I-RRT's samplers with the operator on the arm;
    /// - `irrtc-mouse`: I-RRT-C, contact sampling with authority α = 0 (H-RRT-C Table II),
    ///   the operator on the SpaceMouse;
    /// - `hrrtc`: H-RRT-C with the operator on the arm, one method per α of `alphas`;
    /// - `hrrtc-paper`: the same with Algorithm 2's human mode as the paper writes it
    ///   (`planner serve --human-mode every`: q_device sampled even when it repeats), one
    ///   method per α;
    /// - `hrrtc-noguide`, `hrrtc-novice`, `hrrtc-novice-noguide`, `hrrtc-mouse`: H-RRT-C at
    ///   `guide_alpha` without guidance, with the novice, with the novice and no guidance,
    ///   on the SpaceMouse;
    /// - `hrrtc-shared`: H-RRT-C at `guide_alpha` keeping the authority share in contact
    ///   (`planner serve --contact-authority shared`), with the novice, who is blocked
    ///   and stays in contact most.
    pub fn parse(name: &str, alphas: &[f64], guide_alpha: f64) -> Result<Vec<Self>, LabError> {
        let hrrtc = |tag: &str, a: f64, input| {
            LiveMethod::new(format!("{tag} α={a}"), "hrrtc", Some(a), input)
        };
        Ok(match name {
            "rrt-connect" => vec![LiveMethod::new(name.into(), "cs", None, Input::Arm)],
            "pos+cs" | "path" => vec![LiveMethod::new(
                format!("irrt-{name}"),
                name,
                None,
                Input::Arm,
            )],
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
        })
    }

    /// The `haptic-loop demo` options of this method (scene, seed and limits aside).
    pub fn demo_args(&self) -> Vec<String> {
        let mut a = vec![
            "--sampling".to_owned(),
            self.sampling.clone(),
            "--device".to_owned(),
            match self.input {
                Input::Arm => "sim",
                Input::Mouse => "sim-spacemouse",
            }
            .to_owned(),
            "--operator".to_owned(),
            self.operator.clone(),
        ];
        if let Some(alpha) = self.alpha {
            a.push("--alpha".into());
            a.push(alpha.to_string());
        }
        if !self.guidance {
            a.push("--no-guidance".into());
        }
        if let Some(extra) = &self.planner_args {
            a.push("--planner-args".into());
            a.push(extra.clone());
        }
        a
    }
}

/// One live run: a CSV row.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LiveRun {
    /// Scene.
    pub scene: String,
    /// Method name.
    pub method: String,
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
    /// The run of `method` on `scene` with `seed` from the demo's summary JSON `text`
    /// (`origin` names it in errors).
    pub fn from_summary(
        scene: &str,
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
            method: method.name.clone(),
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
            run_s: s.run_s,
            blocks: s.operator.as_ref().map_or(0, |o| o.blocks),
            corrections: s.operator.as_ref().map_or(0, |o| o.corrections),
            retries: s.operator.as_ref().map_or(0, |o| o.retries),
        })
    }
}

#[cfg(test)]
mod tests;
