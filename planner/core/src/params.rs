//! Planner parameters and errors.

use crate::authority::Authority;
use crate::sampling::{ContactParams, Sampling};
use crate::space::Weights;
use scene::SceneError;

/// Tree-growing algorithm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Algorithm {
    /// Single-tree RRT (LaValle 1998), one `step` per iteration towards the sample, with
    /// `goal_bias` goal samples; solved when a new node joins the goal by a free edge.
    Rrt,
    /// RRT-Connect (Kuffner & LaValle 2000) with greedy I-RRT Extend on both trees, and
    /// I-RRT local trees when `local_trees` is on.
    RrtConnect,
}

/// How far RRT-Connect's tree A grows towards the sample each iteration (tree B always
/// connects greedily towards A's newest node).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExtendA {
    /// I-RRT's greedy Extend: steps of `step` until the sample is reached or an edge
    /// collides ("connect–connect", Kuffner & LaValle 2000).
    Greedy,
    /// One step of at most `step` ("extend–connect", the RRT-Connect of Kuffner &
    /// LaValle 2000 and OMPL's `RRTConnect`).
    Step,
}

/// How samples without an operator ("machine" samples: automatic planning, the uniform
/// share of the +CS methods and H-RRT-C's machine mode) are drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MachineSampler {
    /// Uniform over the bounded space.
    Uniform,
    /// The bridge test of Hsu, Jiang, Reif and Sun ("The bridge test for sampling narrow
    /// passages with probabilistic roadmap planners", ICRA 2003), mixed with uniform
    /// samples: with probability `share`, draw q1 uniformly and q2 from a Gaussian of
    /// per-axis σ `sigma` (weighted m) around it; when both collide and their midpoint is
    /// free, the midpoint is the sample (it lies in a passage narrower than about σ).
    /// After [`crate::rrt::BRIDGE_TRIES`] failed tries the sample is uniform.
    BridgeTest {
        /// Probability of a bridge sample, in [0, 1].
        share: f64,
        /// σ of the bridge's second end (weighted m, > 0).
        sigma: f64,
    },
}

impl MachineSampler {
    /// `uniform` or `bridge-test` (with `share` and `sigma`).
    pub fn parse(name: &str, share: f64, sigma: f64) -> Option<Self> {
        match name {
            "uniform" => Some(MachineSampler::Uniform),
            "bridge-test" => Some(MachineSampler::BridgeTest { share, sigma }),
            _ => None,
        }
    }
}

/// What H-RRT-C's human mode samples (Algorithm 2, line 11: `q_current ← q_device`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HumanMode {
    /// q_device at every human-mode sample, as the paper writes it. The live planner
    /// iterates tens of times per haptic state, and a still operator (holding at the goal,
    /// or pausing) gives the same configuration over and over: once the tree holds it,
    /// those samples add nothing.
    Every,
    /// q_device when it moved since the last q_device sampled (by
    /// [`crate::rrt::FRESH_USER_FRACTION`] of the edge resolution); otherwise a sample near
    /// the operator's travelled path (I-RRT PATH: a Gaussian of σ `user_sigma` around one
    /// of its points), so the operator's demonstration keeps helping after it stopped.
    Fresh,
}

/// Tuning of [`crate::rrt::Planner`]. Distances are weighted distances (weighted m, see
/// [`crate::space`]); with the default weights 0.01 weighted m is 1 cm or 0.1 rad.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannerParams {
    /// Distance weights (default `w_t = 1`, `w_r = 0.01`).
    pub weights: Weights,
    /// Extension step (weighted m, default 0.05: 5 cm or 0.5 rad).
    pub step: f64,
    /// Edge validation resolution (weighted m, default 0.005).
    pub edge_resolution: f64,
    /// Whether edges are also certified free between the checked configurations.
    pub edge_check: crate::collision::EdgeCheck,
    /// `p`, the number of nearest nodes in F_a's barycenter (I-RRT: 5).
    pub neighbours: usize,
    /// `ε` of the barycenter weight `1/(ε + distance label)` (weighted m, default 0.05).
    pub label_epsilon: f64,
    /// Once solved, how far along the path the guidance's carrot runs ahead of the
    /// operator's nearest path point (weighted m, default 0.1: two steps;
    /// [`crate::guidance::PathGuide::force`]).
    pub lookahead: f64,
    /// Once solved, the length of the guidance's pull towards the carrot at which it
    /// saturates (m, > 0, default 0.05). `planner serve` renders this as `--lead-force-n`.
    pub lead_saturation_m: f64,
    /// Once solved, the angle of the guidance's turn towards the carrot's orientation at
    /// which it saturates (rad, > 0, default 0.5). `planner serve` renders this as
    /// `--lead-torque-nm`.
    pub lead_saturation_rad: f64,
    /// Tree algorithm (default RRT-Connect).
    pub algorithm: Algorithm,
    /// RRT-Connect: how tree A grows towards the sample (default greedy, as in I-RRT).
    pub extend_a: ExtendA,
    /// Sampling method (default uniform: automatic planning). See [`crate::sampling`].
    pub sampling: Sampling,
    /// How machine samples are drawn (default uniform).
    pub machine_sampler: MachineSampler,
    /// Share of machine samples (and of the bridge test's first ends) whose orientation
    /// is square to an obstacle ([`crate::aligned`]) instead of uniform, in [0, 1]
    /// (default 0: off).
    pub aligned_share: f64,
    /// Per-axis σ of the jitter around an aligned orientation (rad, ≥ 0, default 0.02).
    pub aligned_jitter_rad: f64,
    /// σ, per-axis standard deviation of the Gaussians of POS and PATH (weighted m,
    /// default 0.03: 3 cm, 0.3 rad).
    pub user_sigma: f64,
    /// α of I-RRT eq. 1, `F_r = α·F_u + (1−α)·F_a` (default 1/2 as in I-RRT §5.1).
    pub fr_alpha: f64,
    /// I-RRT local trees for operator samples that cannot reach a main tree (RRT-Connect
    /// only; default off).
    pub local_trees: bool,
    /// At most this many local trees at once (default 16); beyond it the oldest-made
    /// local tree is dropped, bounding the per-iteration work.
    pub max_local_trees: usize,
    /// Goal-sample probability of the single-tree RRT (default 0.05).
    pub goal_bias: f64,
    /// HapticSampling tuning.
    pub contact: ContactParams,
    /// What H-RRT-C's human mode samples (default [`HumanMode::Fresh`]).
    pub human_mode: HumanMode,
    /// H-RRT-C's authority sharing: the paper's fixed α (the default here) or adaptive
    /// ([`crate::authority`]).
    pub authority: Authority,
    /// Random shortcut attempts on a new solution (default 100; 0 keeps the raw path).
    pub shortcut_attempts: u32,
    /// Touch retraction: the operator's configuration (q_device, as H-RRT-C samples it in
    /// free mode) in collision no deeper than this (m, ≥ 0) is pushed out along the
    /// deepest contact's normal to a free configuration and used, instead of lost: the
    /// configurations an operator passes a slot with touch its walls by 0.1–0.2 mm.
    /// Default 0 (off): on the bug trap without its route it has not helped yet (live,
    /// seeds 1–3, 60 s: 2 of 3 solved with 1 mm, 3 of 3 without; issue 46's note).
    pub touch_depth_m: f64,
}

impl Default for PlannerParams {
    fn default() -> Self {
        PlannerParams {
            weights: Weights::default(),
            step: 0.05,
            edge_resolution: crate::collision::DEFAULT_EDGE_RESOLUTION,
            edge_check: crate::collision::EdgeCheck::default(),
            neighbours: 5,
            label_epsilon: 0.05,
            lookahead: 0.1,
            lead_saturation_m: 0.05,
            lead_saturation_rad: 0.5,
            algorithm: Algorithm::RrtConnect,
            extend_a: ExtendA::Greedy,
            sampling: Sampling::Uniform,
            machine_sampler: MachineSampler::Uniform,
            aligned_share: 0.0,
            aligned_jitter_rad: 0.02,
            human_mode: HumanMode::Fresh,
            authority: Authority::Fixed,
            user_sigma: 0.03,
            fr_alpha: 0.5,
            local_trees: false,
            max_local_trees: 16,
            goal_bias: 0.05,
            contact: ContactParams::default(),
            shortcut_attempts: 100,
            touch_depth_m: 0.0,
        }
    }
}

impl PlannerParams {
    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), PlannerError> {
        let pos = |name: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(PlannerError::InvalidParam {
                    name,
                    reason: format!("must be finite and > 0, got {v}"),
                })
            }
        };
        pos("weights.translation", self.weights.translation)?;
        pos("weights.rotation", self.weights.rotation)?;
        pos("step", self.step)?;
        pos("edge_resolution", self.edge_resolution)?;
        if let MachineSampler::BridgeTest { share, sigma } = self.machine_sampler {
            if !(0.0..=1.0).contains(&share) {
                return Err(PlannerError::InvalidParam {
                    name: "machine_sampler.share",
                    reason: format!("must be in [0, 1], got {share}"),
                });
            }
            pos("machine_sampler.sigma", sigma)?;
        }
        if !(0.0..=1.0).contains(&self.aligned_share) {
            return Err(PlannerError::InvalidParam {
                name: "aligned_share",
                reason: format!("must be in [0, 1], got {}", self.aligned_share),
            });
        }
        if !(self.aligned_jitter_rad.is_finite() && self.aligned_jitter_rad >= 0.0) {
            return Err(PlannerError::InvalidParam {
                name: "aligned_jitter_rad",
                reason: format!("must be finite and >= 0, got {}", self.aligned_jitter_rad),
            });
        }
        if !(self.touch_depth_m.is_finite() && self.touch_depth_m >= 0.0) {
            return Err(PlannerError::InvalidParam {
                name: "touch_depth_m",
                reason: format!("must be finite and >= 0, got {}", self.touch_depth_m),
            });
        }
        pos("label_epsilon", self.label_epsilon)?;
        pos("user_sigma", self.user_sigma)?;
        if !(self.lookahead.is_finite() && self.lookahead >= 0.0) {
            return Err(PlannerError::InvalidParam {
                name: "lookahead",
                reason: format!("must be finite and >= 0, got {}", self.lookahead),
            });
        }
        pos("lead_saturation_m", self.lead_saturation_m)?;
        pos("lead_saturation_rad", self.lead_saturation_rad)?;
        if let Authority::Adaptive(rule) = &self.authority
            && let Some((name, reason)) = rule.invalid()
        {
            return Err(PlannerError::InvalidParam { name, reason });
        }
        for (name, v) in [("fr_alpha", self.fr_alpha), ("goal_bias", self.goal_bias)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(PlannerError::InvalidParam {
                    name,
                    reason: format!("must be in [0, 1], got {v}"),
                });
            }
        }
        self.sampling
            .validate()
            .map_err(|e| PlannerError::InvalidParam {
                name: "sampling",
                reason: e.to_string(),
            })?;
        let c = &self.contact;
        pos("contact.area_per_newton_m2", c.area_per_newton_m2)?;
        pos("contact.max_semi_axis_m", c.max_semi_axis_m)?;
        let non_negative = |v: f64| v.is_finite() && v >= 0.0;
        if !(non_negative(c.rotation_sigma_rad) && non_negative(c.normal_offset_m)) {
            return Err(PlannerError::InvalidParam {
                name: "contact",
                reason: "rotation_sigma_rad and normal_offset_m must be finite and >= 0".into(),
            });
        }
        if self.neighbours == 0 {
            return Err(PlannerError::InvalidParam {
                name: "neighbours",
                reason: "must be >= 1".into(),
            });
        }
        Ok(())
    }
}

/// Why a planner could not be created.
#[derive(Debug, thiserror::Error)]
pub enum PlannerError {
    /// A parameter is out of range.
    #[error("planner parameter `{name}` {reason}")]
    InvalidParam {
        /// Field name.
        name: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// The scene failed validation.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The start configuration collides (or is out of bounds).
    #[error("scene `{0}`: start configuration is in collision")]
    StartInCollision(String),
    /// The goal configuration collides (or is out of bounds).
    #[error("scene `{0}`: goal configuration is in collision")]
    GoalInCollision(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_values_are_named() {
        PlannerParams::default().validate().expect("valid");
        let p = PlannerParams {
            step: f64::NAN,
            ..Default::default()
        };
        assert!(p.validate().unwrap_err().to_string().contains("`step`"));
        let p = PlannerParams {
            sampling: Sampling::Hrrtc { alpha: 1.5 },
            ..Default::default()
        };
        assert!(p.validate().unwrap_err().to_string().contains("sampling"));
        let p = PlannerParams {
            fr_alpha: -0.1,
            ..Default::default()
        };
        assert!(p.validate().unwrap_err().to_string().contains("fr_alpha"));
        let p = PlannerParams {
            authority: Authority::Adaptive(crate::authority::AdaptiveAuthority {
                patience_s: -1.0,
                ..Default::default()
            }),
            ..Default::default()
        };
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("authority.patience_s"), "{e}");
        let p = PlannerParams {
            lead_saturation_rad: 0.0,
            ..Default::default()
        };
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("lead_saturation_rad"), "{e}");
    }
}
