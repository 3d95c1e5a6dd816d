//! The experiment harness: planner and simulated operator in lockstep (one operator step
//! per planner iteration, no real-time coupling), sweeps over the papers' parameters, and
//! reports (CSV, markdown, PNG plots).
//!
//! Two sweeps:
//! - `irrt` (I-RRT §6, Fig. 15–17): sampling method × σ × ε_v on the planar maze with a
//!   pass-through operator.
//! - `hrrtc` (H-RRT-C Tables I and III): α on narrow tunnels and crossing planes with a
//!   contact-seeking operator, next to automatic RRT-Connect (no operator).
//!
//! Everything but `time_s` is deterministic per seed; `time_s` is wall-clock time on this
//! machine (the limit is wall-clock too, as in the papers).

pub mod report;
pub mod sweep;
pub mod user;

use crate::LabError;
use planner_core::Planner;
use planner_core::params::PlannerParams;
use planner_core::sampling::Sampling;
use planner_core::space::path_length;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use scene::Scene;
use serde::Serialize;
use std::time::Instant;
use user::SimUser;

/// The operator model of a run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum UserModel {
    /// No operator: automatic planning.
    None,
    /// Pass-through operator moving `eps_v` weighted m per iteration.
    PassThrough {
        /// ε_v (weighted m per iteration).
        eps_v: f64,
    },
    /// Contact-seeking operator (see [`user`]).
    ContactSeeking {
        /// ε_v (weighted m per iteration).
        eps_v: f64,
        /// σ of the operator's orientation error (rad per axis).
        error_sigma_rad: f64,
    },
}

/// One run's configuration.
#[derive(Clone, Debug)]
pub struct RunSpec {
    /// Built-in scene name.
    pub scene: String,
    /// Planner parameters (sampling method, σ, …).
    pub params: PlannerParams,
    /// Operator model.
    pub user: UserModel,
    /// Seed of the planner and of the operator's error.
    pub seed: u64,
    /// Wall-clock limit (s).
    pub time_limit_s: f64,
}

/// One run's outcome (a CSV row).
#[derive(Clone, Debug, Serialize)]
pub struct RunResult {
    /// Scene name.
    pub scene: String,
    /// Sampling method name.
    pub method: String,
    /// σ (weighted m).
    pub sigma: f64,
    /// ε_v (weighted m per iteration), 0 without operator.
    pub eps_v: f64,
    /// α (H-RRT-C), or NaN when not applicable.
    pub alpha: f64,
    /// Seed.
    pub seed: u64,
    /// Solved within the limit.
    pub solved: bool,
    /// Wall-clock seconds to the solution or the limit.
    pub time_s: f64,
    /// Iterations.
    pub iterations: u64,
    /// Nodes in all trees.
    pub nodes: u64,
    /// Collision checks.
    pub collision_checks: u64,
    /// Weighted length of the (smoothed) solution, NaN if unsolved.
    pub path_length: f64,
    /// Iterations the operator spent in contact.
    pub contact_iterations: u64,
}

/// Runs one experiment.
pub fn run(spec: &RunSpec) -> Result<RunResult, LabError> {
    run_drawn(spec, None).map(|(r, _)| r)
}

/// [`run`], then draws the final roadmap, the operator's path and the solution into
/// `png` (top-down, nodes by distance label; see [`crate::picture`]). The second value
/// is the drawing's outcome (`Ok` when nothing was asked).
pub fn run_drawn(
    spec: &RunSpec,
    png: Option<&std::path::Path>,
) -> Result<(RunResult, Result<(), LabError>), LabError> {
    let scene =
        Scene::builtin(&spec.scene).ok_or_else(|| LabError::UnknownScene(spec.scene.clone()))?;
    let mut planner = Planner::new(&scene, spec.params.clone(), spec.seed)?;
    let keyframes = user::keyframes(&scene);
    // The operator's error has its own stream so that it does not depend on the planner.
    let mut user_rng = ChaCha8Rng::seed_from_u64(spec.seed ^ 0x5eed_0f05_e700);
    let mut sim = match spec.user {
        UserModel::None => None,
        UserModel::PassThrough { eps_v } => {
            Some(SimUser::pass_through(planner.space(), keyframes, eps_v))
        }
        UserModel::ContactSeeking {
            eps_v,
            error_sigma_rad,
        } => Some(SimUser::contact_seeking(
            planner.space(),
            keyframes,
            eps_v,
            error_sigma_rad,
            &mut user_rng,
        )),
    };
    let started = Instant::now();
    let mut elapsed = 0.0;
    while !planner.solved() {
        let input = sim
            .as_mut()
            .map(|u| u.step(planner.space(), planner.checker()));
        planner.iterate_input(input.as_ref());
        // Reading the clock every 16 iterations keeps its cost out of the measurement.
        if planner.stats().iterations % 16 == 0 || planner.solved() {
            elapsed = started.elapsed().as_secs_f64();
            if elapsed >= spec.time_limit_s {
                break;
            }
        }
    }
    let s = planner.stats();
    let drawn = match png {
        Some(file) => {
            let label = format!(
                "{} {} seed {}",
                spec.scene,
                match spec.user {
                    UserModel::None => "auto",
                    _ => spec.params.sampling.name(),
                },
                spec.seed
            );
            crate::picture::draw_planner_png(
                &scene,
                &planner,
                &label,
                crate::picture::ColorBy::Distance,
                crate::picture::Plane::XY,
                file,
                (900, 900),
            )
        }
        None => Ok(()),
    };
    let (eps_v, alpha) = match (spec.user, spec.params.sampling) {
        (
            UserModel::PassThrough { eps_v } | UserModel::ContactSeeking { eps_v, .. },
            Sampling::Hrrtc { alpha },
        ) => (eps_v, alpha),
        (UserModel::PassThrough { eps_v } | UserModel::ContactSeeking { eps_v, .. }, _) => {
            (eps_v, f64::NAN)
        }
        (UserModel::None, _) => (0.0, f64::NAN),
    };
    let result = RunResult {
        scene: spec.scene.clone(),
        method: match spec.user {
            UserModel::None => "auto".into(),
            _ if spec.params.local_trees => format!("{}+local", spec.params.sampling.name()),
            _ => spec.params.sampling.name().into(),
        },
        sigma: spec.params.user_sigma,
        eps_v,
        alpha,
        seed: spec.seed,
        solved: planner.solved(),
        time_s: elapsed,
        iterations: s.iterations,
        nodes: s.nodes as u64,
        collision_checks: s.collision_checks,
        path_length: planner
            .solution()
            .map_or(f64::NAN, |p| path_length(planner.space(), p)),
        contact_iterations: sim.map_or(0, |u| u.contact_iterations),
    };
    Ok((result, drawn))
}

/// The `irrt` sweep: every method × σ × ε_v × seed on `scene`.
pub fn irrt_specs(
    scene: &str,
    methods: &[Sampling],
    sigmas: &[f64],
    eps: &[f64],
    seeds: u64,
    time_limit_s: f64,
) -> Vec<RunSpec> {
    let mut out = Vec::new();
    for &sampling in methods {
        for &sigma in sigmas {
            for &eps_v in eps {
                for seed in 1..=seeds {
                    out.push(RunSpec {
                        scene: scene.into(),
                        params: PlannerParams {
                            sampling,
                            user_sigma: sigma,
                            ..PlannerParams::default()
                        },
                        user: UserModel::PassThrough { eps_v },
                        seed,
                        time_limit_s,
                    });
                }
            }
        }
    }
    out
}

/// The `hrrtc` sweep: automatic RRT-Connect and H-RRT-C for every α, per scene and seed,
/// with a contact-seeking operator; `local_trees`: operator samples that cannot connect
/// start I-RRT local trees.
pub fn hrrtc_specs(
    scenes: &[String],
    alphas: &[f64],
    eps_v: f64,
    error_sigma_rad: f64,
    local_trees: bool,
    seeds: u64,
    time_limit_s: f64,
) -> Vec<RunSpec> {
    let mut out = Vec::new();
    for scene in scenes {
        for seed in 1..=seeds {
            out.push(RunSpec {
                scene: scene.clone(),
                params: PlannerParams::default(),
                user: UserModel::None,
                seed,
                time_limit_s,
            });
        }
        for &alpha in alphas {
            for seed in 1..=seeds {
                out.push(RunSpec {
                    scene: scene.clone(),
                    params: PlannerParams {
                        sampling: Sampling::Hrrtc { alpha },
                        local_trees,
                        ..PlannerParams::default()
                    },
                    user: UserModel::ContactSeeking {
                        eps_v,
                        error_sigma_rad,
                    },
                    seed,
                    time_limit_s,
                });
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_are_deterministic_and_operators_help_on_an_easy_scene() {
        let spec = |user, sampling| RunSpec {
            scene: "free".into(),
            params: PlannerParams {
                sampling,
                ..PlannerParams::default()
            },
            user,
            seed: 3,
            time_limit_s: 5.0,
        };
        let a = run(&spec(
            UserModel::PassThrough { eps_v: 0.01 },
            Sampling::Pos { beta: None },
        ))
        .expect("run");
        let b = run(&spec(
            UserModel::PassThrough { eps_v: 0.01 },
            Sampling::Pos { beta: None },
        ))
        .expect("run");
        assert!(a.solved && b.solved);
        assert_eq!(
            (a.iterations, a.nodes, a.collision_checks),
            (b.iterations, b.nodes, b.collision_checks)
        );
        assert_eq!(a.method, "pos");
        let h = run(&spec(
            UserModel::ContactSeeking {
                eps_v: 0.01,
                error_sigma_rad: 0.1,
            },
            Sampling::Hrrtc { alpha: 0.5 },
        ))
        .expect("run");
        assert!(h.solved && h.alpha == 0.5 && h.method == "hrrtc");
        let auto = run(&spec(UserModel::None, Sampling::Uniform)).expect("run");
        assert_eq!((auto.method.as_str(), auto.eps_v), ("auto", 0.0));
        assert!(
            run(&RunSpec {
                scene: "nope".into(),
                ..spec(UserModel::None, Sampling::Uniform)
            })
            .is_err()
        );
    }

    #[test]
    fn sweeps_enumerate_every_combination() {
        let m = [
            Sampling::Pos { beta: None },
            Sampling::Path { beta: Some(3.0) },
        ];
        assert_eq!(
            irrt_specs("maze", &m, &[0.01, 0.05], &[0.001], 3, 1.0).len(),
            2 * 2 * 3
        );
        let h = hrrtc_specs(&["tunnels".into()], &[0.0, 0.5], 0.002, 0.1, false, 4, 1.0);
        assert_eq!(h.len(), 4 * 3);
        assert_eq!(h.iter().filter(|s| s.user == UserModel::None).count(), 4);
        assert!(h.iter().all(|s| !s.params.local_trees));
        // Local trees go to the operator-driven runs only (automatic runs have no operator).
        let l = hrrtc_specs(&["tunnels".into()], &[0.5], 0.002, 0.1, true, 2, 1.0);
        assert!(
            l.iter()
                .all(|s| s.params.local_trees == (s.user != UserModel::None))
        );
    }
}
