//! Parameters of the reactive operator, with the "expert" and "novice" presets.

use serde::{Deserialize, Serialize};

use crate::DeviceError;
use crate::sim::grip::Grip;

/// Parameters of [`Operator`](super::Operator) and of the hand that holds the arm
/// ([`OperatorHand`](super::OperatorHand)). Lengths, speeds and forces are at the device
/// (device base frame), not in the scene. Every field has a default (the expert), so a
/// partial TOML/JSON table deserializes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OperatorConfig {
    /// Time between what the operator perceives (pose, felt force) and its reaction to it,
    /// s (people: about 0.1–0.25). Expert 0.12, novice 0.22, newcomer 0.2.
    pub reaction_delay_s: f64,
    /// How long it holds the handle still before it starts, s: a person takes hold of the
    /// arm and waits until it comes alive (the loop keeps forces off until the device has
    /// been still, then ramps them in over 0.5 s; an operator who starts at once may meet the
    /// first obstacle with no force felt). Default 0.6.
    pub start_hold_s: f64,
    /// Hand speed toward the next route step in free motion, m/s. Expert 0.08, novice and newcomer 0.05.
    pub speed_m_per_s: f64,
    /// Turning rate toward the next step's orientation, rad/s. Expert 1.0, novice and
    /// newcomer 0.6.
    pub angular_speed_rad_per_s: f64,
    /// Slowing near a target: the speed is at most distance / this, s. Default 0.25.
    pub approach_time_s: f64,
    /// Length that weighs an angle against a distance in the operator's sense of progress
    /// and arrival, m/rad (about the object's size at the device). Default 0.02.
    pub rotation_length_m: f64,
    /// A route step counts as reached within this distance, m. Default 0.002.
    pub position_tolerance_m: f64,
    /// ... and within this angle, rad. Default 0.05.
    pub angle_tolerance_rad: f64,
    /// On a pressing step the operator presses (and lets the surface set the height along
    /// the press) only while the object is within this distance of the step along the
    /// press, m (and stops beyond twice that); farther off it first brings the object back.
    /// Default 0.003.
    pub press_slack_m: f64,
    /// Hesitations start at this rate while moving, 1/s (a Poisson process). Expert 0.05,
    /// novice 0.2, newcomer 0.1.
    pub hesitation_rate_per_s: f64,
    /// Shortest hesitation, s (its length is uniform between the two). Expert 0.2, novice 0.4,
    /// newcomer 0.3.
    pub hesitation_min_s: f64,
    /// Longest hesitation, s. Expert 0.6, novice 1.5, newcomer 1.0.
    pub hesitation_max_s: f64,
    /// Probability, per route step after the first, of heading first to a wrong place
    /// (the step's position moved sideways by `wrong_turn_m`). Expert 0.05, novice 0.25,
    /// newcomer 0.1 (per waypoint of its own way).
    pub wrong_turn_probability: f64,
    /// How far sideways a wrong turn aims, m. Expert 0.015, novice 0.025, newcomer 0.01.
    pub wrong_turn_m: f64,
    /// Probability, per route step after the first, of holding the object at a wrong
    /// orientation (off by `wrong_orientation_rad` × U(0.5, 1.5) about a random axis).
    /// Expert 0.15, novice 0.5, newcomer 0 (its orientations are guesses already: see
    /// `NewcomerConfig::goal_orientation_error_rad`).
    pub wrong_orientation_probability: f64,
    /// Typical size of a wrong orientation, rad. Expert 0.12, novice 0.3.
    pub wrong_orientation_rad: f64,
    /// Felt force against the intended motion that the operator reads as "blocked", N.
    /// Expert 1.5, novice and newcomer 2.5. (Only with force feedback.)
    pub blocked_force_n: f64,
    /// ... once felt for this long, s. Expert 0.2, novice 0.4, newcomer 0.3.
    pub blocked_time_s: f64,
    /// Seen progress toward the step smaller than `stall_progress_m` for this long reads as
    /// "blocked" too, s (what a SpaceMouse user, who feels nothing, goes by). Expert 0.6,
    /// novice 1.2, newcomer 1.0.
    pub stall_time_s: f64,
    /// Progress that counts, m (angles weighed by `rotation_length_m`). Default 0.001.
    pub stall_progress_m: f64,
    /// Share of a wrong orientation removed at each correction, 0–1. Expert 0.8, novice 0.5.
    pub correction_share: f64,
    /// After a block with nothing to correct: back off for this long, s, then retry with a
    /// small random change. Default 0.3, newcomer 0.4.
    pub retry_back_s: f64,
    /// Sideways change of a first retry at a step, m (σ per axis; halved at each further
    /// block there; the newcomer's wiggle, not halved). Expert 0.002, novice 0.004, newcomer
    /// 0.003.
    pub retry_jitter_m: f64,
    /// Orientation change of a first retry, rad (σ per axis; halved likewise, but not the
    /// newcomer's). Expert 0.03, novice 0.06, newcomer 0.15 (a person's turn by hand is off
    /// by about that).
    pub retry_jitter_rad: f64,
    /// Share of the operator's intent that comes from a guidance force it feels at
    /// `guidance_full_n` or more (0–1; weaker forces give a proportionally smaller share).
    /// Expert 0.3, novice and newcomer 0.5.
    pub guidance_share: f64,
    /// The same share once blocked `stuck_after_blocks` times at one step: stuck, it lets
    /// the guidance lead more. Expert 0.5, novice 0.7, newcomer 0.9 (reached by
    /// `NewcomerConfig::share_per_block`).
    pub stuck_guidance_share: f64,
    /// Blocks at one step after which the operator counts itself stuck. Default 3 (the
    /// newcomer's share grows with each block instead).
    pub stuck_after_blocks: u32,
    /// Guidance force felt at full share, N. Default 1.0, newcomer 0.3 (below the 0.1–0.8 N
    /// of the planner's guidance before a solution, far below its lead's 2 N).
    pub guidance_full_n: f64,
    /// Guidance torque felt at full share, N·m. Default 0.05, newcomer 0.015 (the lead
    /// saturates at 0.1).
    pub guidance_full_nm: f64,
    /// Grip: translational stiffness between the hand and the handle, N/m. Default 300.
    pub hand_stiffness_n_per_m: f64,
    /// Grip: translational damping, N·s/m. Default 5.
    pub hand_damping_n_s_per_m: f64,
    /// Grip: rotational stiffness, N·m/rad. Default 0.5.
    pub hand_rot_stiffness_nm_per_rad: f64,
    /// Grip: rotational damping, N·m·s/rad. Default 0.02.
    pub hand_rot_damping_nm_s_per_rad: f64,
    /// Largest force the hand applies, N (bounded effort). Default 6.
    pub max_force_n: f64,
    /// Largest torque the hand applies, N·m. Default 0.4.
    pub max_torque_nm: f64,
    /// Seed of every random choice (ChaCha8). Default 1.
    pub seed: u64,
    /// How an operator who does not know the way behaves (the `newcomer` preset); `None`
    /// for one that follows a route it was given (expert, novice).
    pub newcomer: Option<NewcomerConfig>,
}

/// What makes the newcomer: it has no route, only its own coarse way (positions, from what
/// it sees of the scene), it guesses the goal's orientation, turns the object the way a
/// person would try when blocked, and lets felt guidance lead more the longer it is stuck.
/// Lengths at the device (device base frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NewcomerConfig {
    /// Error of its perception of the goal's orientation, rad: the orientation it turns the
    /// object toward along its way is the goal's turned by this angle about an axis drawn
    /// from the seed. Newcomer 0.06 (the goal zone accepts 0.1).
    pub goal_orientation_error_rad: f64,
    /// A waypoint of its way before the last counts as passed once the object is seen within
    /// this distance of it or of any later waypoint, m; the orientation does not count there
    /// (a person checks off "past the opening" by position). Newcomer 0.008.
    pub waypoint_reach_m: f64,
    /// Size of the turns it tries when blocked and not led, rad: plus and minus this about
    /// each base axis, and no turn, in an order drawn from the seed; each try is wiggled by
    /// `retry_jitter_m` / `retry_jitter_rad` (σ, not halved). Newcomer π/2 (quarter turns).
    pub trial_rad: f64,
    /// Guidance share added at each block at one waypoint, from `guidance_share` up to
    /// `stuck_guidance_share` (the share grows while it is stuck). Once there, it follows the
    /// whole felt wrench, even where it pushes against its own way. Newcomer 0.1.
    pub share_per_block: f64,
}

impl Default for NewcomerConfig {
    fn default() -> Self {
        NewcomerConfig {
            goal_orientation_error_rad: 0.06,
            waypoint_reach_m: 0.008,
            trial_rad: std::f64::consts::FRAC_PI_2,
            share_per_block: 0.1,
        }
    }
}

impl Default for OperatorConfig {
    fn default() -> Self {
        OperatorConfig::expert()
    }
}

impl OperatorConfig {
    /// The hand's grip.
    pub(crate) fn grip(&self) -> Grip {
        Grip {
            stiffness_n_per_m: self.hand_stiffness_n_per_m,
            damping_n_s_per_m: self.hand_damping_n_s_per_m,
            rot_stiffness_nm_per_rad: self.hand_rot_stiffness_nm_per_rad,
            rot_damping_nm_s_per_rad: self.hand_rot_damping_nm_s_per_rad,
            max_force_n: self.max_force_n,
            max_torque_nm: self.max_torque_nm,
        }
    }

    /// A trained operator: quick to react, few mistakes, corrects most of an error at once,
    /// lets guidance take 30 % of its intent.
    pub fn expert() -> Self {
        OperatorConfig {
            reaction_delay_s: 0.12,
            start_hold_s: 0.6,
            speed_m_per_s: 0.08,
            angular_speed_rad_per_s: 1.0,
            approach_time_s: 0.25,
            rotation_length_m: 0.02,
            position_tolerance_m: 0.002,
            angle_tolerance_rad: 0.05,
            press_slack_m: 0.003,
            hesitation_rate_per_s: 0.05,
            hesitation_min_s: 0.2,
            hesitation_max_s: 0.6,
            wrong_turn_probability: 0.05,
            wrong_turn_m: 0.015,
            wrong_orientation_probability: 0.15,
            wrong_orientation_rad: 0.12,
            blocked_force_n: 1.5,
            blocked_time_s: 0.2,
            stall_time_s: 0.6,
            stall_progress_m: 0.001,
            correction_share: 0.8,
            retry_back_s: 0.3,
            retry_jitter_m: 0.002,
            retry_jitter_rad: 0.03,
            guidance_share: 0.3,
            stuck_guidance_share: 0.5,
            stuck_after_blocks: 3,
            guidance_full_n: 1.0,
            guidance_full_nm: 0.05,
            hand_stiffness_n_per_m: 300.0,
            hand_damping_n_s_per_m: 5.0,
            hand_rot_stiffness_nm_per_rad: 0.5,
            hand_rot_damping_nm_s_per_rad: 0.02,
            max_force_n: 6.0,
            max_torque_nm: 0.4,
            seed: 1,
            newcomer: None,
        }
    }

    /// An untrained operator: slower, hesitant, often wrong, corrects half an error at a
    /// time, leans on guidance (50 %).
    pub fn novice() -> Self {
        OperatorConfig {
            reaction_delay_s: 0.22,
            speed_m_per_s: 0.05,
            angular_speed_rad_per_s: 0.6,
            hesitation_rate_per_s: 0.2,
            hesitation_min_s: 0.4,
            hesitation_max_s: 1.5,
            wrong_turn_probability: 0.25,
            wrong_turn_m: 0.025,
            wrong_orientation_probability: 0.5,
            wrong_orientation_rad: 0.3,
            blocked_force_n: 2.5,
            blocked_time_s: 0.4,
            stall_time_s: 1.2,
            correction_share: 0.5,
            retry_jitter_m: 0.004,
            retry_jitter_rad: 0.06,
            guidance_share: 0.5,
            stuck_guidance_share: 0.7,
            ..OperatorConfig::expert()
        }
    }

    /// An operator who does not know the way (see [`NewcomerConfig`]): a novice's pace and
    /// reactions, no route, and guidance felt at full share from 0.3 N and 0.015 N·m (the
    /// planner's guidance before a solution is about 0.1–0.8 N, its lead at most 2 N and
    /// 0.1 N·m), a share growing from 50 % to 90 % while stuck. It makes no wrong
    /// orientations of its own on top of its guess of the goal's orientation.
    pub fn newcomer() -> Self {
        OperatorConfig {
            reaction_delay_s: 0.2,
            speed_m_per_s: 0.05,
            angular_speed_rad_per_s: 0.6,
            hesitation_rate_per_s: 0.1,
            hesitation_min_s: 0.3,
            hesitation_max_s: 1.0,
            wrong_turn_probability: 0.1,
            wrong_turn_m: 0.01,
            wrong_orientation_probability: 0.0,
            blocked_force_n: 2.5,
            blocked_time_s: 0.3,
            stall_time_s: 1.0,
            retry_back_s: 0.4,
            retry_jitter_m: 0.003,
            retry_jitter_rad: 0.15,
            guidance_share: 0.5,
            stuck_guidance_share: 0.9,
            guidance_full_n: 0.3,
            guidance_full_nm: 0.015,
            newcomer: Some(NewcomerConfig::default()),
            ..OperatorConfig::expert()
        }
    }

    /// The preset named `name` (`expert`, `novice` or `newcomer`).
    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "expert" => Some(OperatorConfig::expert()),
            "novice" => Some(OperatorConfig::novice()),
            "newcomer" => Some(OperatorConfig::newcomer()),
            _ => None,
        }
    }

    /// The longest reaction delay accepted, s (sizes the perception buffer).
    pub const MAX_REACTION_DELAY_S: f64 = 1.0;

    /// Checks every field's range; the error names the field.
    pub fn validate(&self) -> Result<(), DeviceError> {
        let positive = [
            (self.speed_m_per_s, "speed_m_per_s"),
            (self.angular_speed_rad_per_s, "angular_speed_rad_per_s"),
            (self.approach_time_s, "approach_time_s"),
            (self.rotation_length_m, "rotation_length_m"),
            (self.position_tolerance_m, "position_tolerance_m"),
            (self.angle_tolerance_rad, "angle_tolerance_rad"),
            (self.press_slack_m, "press_slack_m"),
            (self.stall_time_s, "stall_time_s"),
            (self.stall_progress_m, "stall_progress_m"),
            (self.guidance_full_n, "guidance_full_n"),
            (self.guidance_full_nm, "guidance_full_nm"),
            (self.max_force_n, "max_force_n"),
            (self.max_torque_nm, "max_torque_nm"),
            (self.hand_stiffness_n_per_m, "hand_stiffness_n_per_m"),
            (
                self.hand_rot_stiffness_nm_per_rad,
                "hand_rot_stiffness_nm_per_rad",
            ),
        ];
        for (v, name) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(DeviceError::InvalidConfig(name));
            }
        }
        let non_negative = [
            (self.start_hold_s, "start_hold_s"),
            (self.hesitation_rate_per_s, "hesitation_rate_per_s"),
            (self.hesitation_min_s, "hesitation_min_s"),
            (self.wrong_turn_m, "wrong_turn_m"),
            (self.wrong_orientation_rad, "wrong_orientation_rad"),
            (self.blocked_force_n, "blocked_force_n"),
            (self.blocked_time_s, "blocked_time_s"),
            (self.retry_back_s, "retry_back_s"),
            (self.retry_jitter_m, "retry_jitter_m"),
            (self.retry_jitter_rad, "retry_jitter_rad"),
            (self.hand_damping_n_s_per_m, "hand_damping_n_s_per_m"),
            (
                self.hand_rot_damping_nm_s_per_rad,
                "hand_rot_damping_nm_s_per_rad",
            ),
        ];
        for (v, name) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(DeviceError::InvalidConfig(name));
            }
        }
        let shares = [
            (self.wrong_turn_probability, "wrong_turn_probability"),
            (
                self.wrong_orientation_probability,
                "wrong_orientation_probability",
            ),
            (self.correction_share, "correction_share"),
            (self.guidance_share, "guidance_share"),
            (self.stuck_guidance_share, "stuck_guidance_share"),
        ];
        for (v, name) in shares {
            if !(0.0..=1.0).contains(&v) {
                return Err(DeviceError::InvalidConfig(name));
            }
        }
        if !(self.reaction_delay_s.is_finite()
            && (0.0..=Self::MAX_REACTION_DELAY_S).contains(&self.reaction_delay_s))
        {
            return Err(DeviceError::InvalidConfig("reaction_delay_s (0–1 s)"));
        }
        if let Some(n) = &self.newcomer {
            let fields = [
                (
                    n.goal_orientation_error_rad,
                    "newcomer.goal_orientation_error_rad",
                ),
                (n.waypoint_reach_m, "newcomer.waypoint_reach_m"),
                (n.trial_rad, "newcomer.trial_rad"),
                (n.share_per_block, "newcomer.share_per_block"),
            ];
            for (v, name) in fields {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(DeviceError::InvalidConfig(name));
                }
            }
            if n.goal_orientation_error_rad > std::f64::consts::PI
                || n.trial_rad > std::f64::consts::PI
            {
                return Err(DeviceError::InvalidConfig(
                    "newcomer.goal_orientation_error_rad / trial_rad (at most π)",
                ));
            }
        }
        if !(self.hesitation_max_s.is_finite() && self.hesitation_max_s >= self.hesitation_min_s) {
            return Err(DeviceError::InvalidConfig(
                "hesitation_max_s (must be at least hesitation_min_s)",
            ));
        }
        Ok(())
    }
}
