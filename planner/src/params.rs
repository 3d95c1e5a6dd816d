//! Planner parameters and errors.

use crate::scene::SceneError;
use crate::space::Weights;

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
    /// `p`, the number of nearest nodes in F_a's barycenter (I-RRT: 5).
    pub neighbours: usize,
    /// `ε` of the barycenter weight `1/(ε + distance label)` (weighted m, default 0.05).
    pub label_epsilon: f64,
    /// How far ahead of the user's nearest path point F_a pulls once solved (weighted m,
    /// default 0.05, one step).
    pub lookahead: f64,
    /// Probability in [0, 1] of sampling around the user configuration instead of
    /// uniformly, when one is given to `iterate` (default 0: plain RRT-Connect). I-RRT's
    /// "+CS" mixing with β = 3 corresponds to 0.75.
    pub user_bias: f64,
    /// Per-axis standard deviation of the Gaussian around the user (weighted m, default
    /// 0.03: 3 cm, 0.3 rad).
    pub user_sigma: f64,
}

impl Default for PlannerParams {
    fn default() -> Self {
        PlannerParams {
            weights: Weights::default(),
            step: 0.05,
            edge_resolution: crate::collision::DEFAULT_EDGE_RESOLUTION,
            neighbours: 5,
            label_epsilon: 0.05,
            lookahead: 0.05,
            user_bias: 0.0,
            user_sigma: 0.03,
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
        pos("label_epsilon", self.label_epsilon)?;
        pos("user_sigma", self.user_sigma)?;
        if !(self.lookahead.is_finite() && self.lookahead >= 0.0) {
            return Err(PlannerError::InvalidParam {
                name: "lookahead",
                reason: format!("must be finite and >= 0, got {}", self.lookahead),
            });
        }
        if !(0.0..=1.0).contains(&self.user_bias) {
            return Err(PlannerError::InvalidParam {
                name: "user_bias",
                reason: format!("must be in [0, 1], got {}", self.user_bias),
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
            user_bias: 1.5,
            ..Default::default()
        };
        assert!(p.validate().unwrap_err().to_string().contains("user_bias"));
    }
}
