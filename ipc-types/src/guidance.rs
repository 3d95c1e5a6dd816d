//! [`Guidance`]: what the planner tells the haptic loop.

use crate::{GuidanceMode, Header};
use iceoryx2::prelude::ZeroCopySend;

/// The planner's pseudo-force F_a and the gains that turn it into the guidance force
/// F_s = k·F_a (I-RRT eq. 3), plus planner statistics for displays.
///
/// Semantics: latest value (see [`crate::services::GUIDANCE`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("hrrtc::Guidance.v1")]
pub struct Guidance {
    /// Sequence from 1 per planner process; timestamp = when F_a was computed.
    pub header: Header,
    /// F_a as a 6-vector in the scene frame: `[dx, dy, dz]` in m (towards the target
    /// position of the object's reference point) then `[rx, ry, rz]` a rotation vector in
    /// rad (towards the target orientation).
    pub attractive: [f64; 6],
    /// k for the translational part: F_s force = k_t · F_a[0..3], N/m.
    pub gain_n_per_m: f64,
    /// k for the rotational part: F_s torque = k_r · F_a[3..6], N·m/rad.
    pub gain_nm_per_rad: f64,
    /// How long after `header.timestamp_ns` the sample is fresh, ns. After it the loop
    /// fades F_s linearly to zero over its own fade time.
    pub time_to_live_ns: u64,
    /// `header.sequence` of the [`crate::HapticState`] whose `user_pose` F_a was computed
    /// for; lets the loop and benchmarks measure the round trip.
    pub state_sequence: u64,
    /// [`GuidanceMode`].
    pub mode: GuidanceMode,
    /// 1 once a solution path exists, else 0.
    pub solved: u32,
    /// Planner iterations since start.
    pub iterations: u64,
    /// Nodes in all trees.
    pub nodes: u64,
    /// Number of trees (start, goal, local trees).
    pub trees: u32,
    /// Identity of the planner that wrote the sample: random, non-zero, fixed for the
    /// planner's life. Tells planners apart when several serve one loop, also across hosts
    /// where process ids repeat; 0 from writers that do not set it (then `header.writer_pid`
    /// is the identity).
    pub planner_id: u32,
    /// Weighted distance (I-RRT eq. 2) from the goal to the nearest node of the start tree.
    pub distance_to_goal: f64,
    /// Collision checks since start.
    pub collision_checks: u64,
}

/// Why a [`Guidance`] sample was rejected by [`Guidance::validate`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GuidanceError {
    /// `header.sequence` is 0: nothing was ever written.
    NeverWritten,
    /// F_a or a gain is NaN or infinite.
    NonFinite,
    /// A gain is negative (it would push the operator away from the roadmap).
    NegativeGain,
    /// F_a or a gain is beyond [`Guidance::MAX_MAGNITUDE`]: no real planner sends that, and
    /// their product could overflow to infinity.
    OutOfRange,
    /// The mode code is unknown to this build.
    UnknownMode,
}

impl Guidance {
    /// A sample leading along the roadmap ([`GuidanceMode::ROADMAP`]): F_a = `attractive`
    /// (m, then rad), gains k (N/m, N·m/rad), fresh for `time_to_live_ns` after
    /// `header.timestamp_ns`; no statistics, planner id 0.
    pub fn roadmap(
        header: Header,
        attractive: [f64; 6],
        gain_n_per_m: f64,
        gain_nm_per_rad: f64,
        time_to_live_ns: u64,
    ) -> Self {
        Guidance {
            header,
            attractive,
            gain_n_per_m,
            gain_nm_per_rad,
            time_to_live_ns,
            mode: GuidanceMode::ROADMAP,
            ..Guidance::default()
        }
    }

    /// Largest accepted |F_a| component (m or rad) and gain (N/m or N·m/rad): far above any
    /// scene (metres) or device (kN/m), far below where `F_a · k` could overflow.
    pub const MAX_MAGNITUDE: f64 = 1e6;

    /// Checks what a reader must check before it renders a sample another process wrote.
    /// Cheap, allocation-free, suitable for the RT thread.
    pub fn validate(&self) -> Result<(), GuidanceError> {
        if self.header.sequence == 0 {
            return Err(GuidanceError::NeverWritten);
        }
        let finite = self.attractive.iter().all(|v| v.is_finite())
            && self.gain_n_per_m.is_finite()
            && self.gain_nm_per_rad.is_finite();
        if !finite {
            return Err(GuidanceError::NonFinite);
        }
        if self.gain_n_per_m < 0.0 || self.gain_nm_per_rad < 0.0 {
            return Err(GuidanceError::NegativeGain);
        }
        let in_range = self
            .attractive
            .iter()
            .chain([&self.gain_n_per_m, &self.gain_nm_per_rad])
            .all(|v| v.abs() <= Self::MAX_MAGNITUDE);
        if !in_range {
            return Err(GuidanceError::OutOfRange);
        }
        match self.mode {
            GuidanceMode::NONE
            | GuidanceMode::ROADMAP
            | GuidanceMode::PATH
            | GuidanceMode::NO_WAY => Ok(()),
            _ => Err(GuidanceError::UnknownMode),
        }
    }
}

const _: () = {
    assert!(core::mem::size_of::<Guidance>() == 152);
};

#[cfg(test)]
mod tests {
    use super::*;

    fn valid() -> Guidance {
        Guidance {
            header: Header {
                sequence: 1,
                ..Header::default()
            },
            gain_n_per_m: 20.0,
            mode: GuidanceMode::ROADMAP,
            ..Guidance::default()
        }
    }

    #[test]
    fn validation_accepts_good_and_rejects_bad_samples() {
        assert_eq!(valid().validate(), Ok(()));
        assert_eq!(
            Guidance::default().validate(),
            Err(GuidanceError::NeverWritten)
        );
        let mut nan = valid();
        nan.attractive[4] = f64::NAN;
        assert_eq!(nan.validate(), Err(GuidanceError::NonFinite));
        let mut neg = valid();
        neg.gain_nm_per_rad = -1.0;
        assert_eq!(neg.validate(), Err(GuidanceError::NegativeGain));
        let mut mode = valid();
        mode.mode = GuidanceMode(99);
        assert_eq!(mode.validate(), Err(GuidanceError::UnknownMode));
        // Found by the guidance_sample fuzz target: finite values whose product overflows.
        let mut huge = valid();
        huge.attractive[0] = 1e300;
        huge.gain_n_per_m = 1e300;
        assert_eq!(huge.validate(), Err(GuidanceError::OutOfRange));
    }
}
