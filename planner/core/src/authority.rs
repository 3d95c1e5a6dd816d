//! H-RRT-C's authority sharing: the paper's fixed α, and an authority that adapts to the
//! operator's behaviour (the paper's future work: "adapting the algorithm parameters such
//! as ellipse size and interactivity parameter in real time in function of the user's
//! behavior").
//!
//! # Why
//!
//! H-RRT-C as the paper writes it (Algorithm 2) samples only the contact ellipse while the
//! operator is in contact, and q_device with probability 1 − α in free space. An operator
//! who does not know the way presses on the first wall for the whole session: every
//! sample then lies in a few centimetres of that wall, and the free-space exploration that
//! solves these scenes on its own (live automatic RRT-Connect: narrow tunnels 19/20,
//! crossing planes 18/20 within 60 s) starves. The operator's samples are worth their
//! share only while they bring something new; an operator who does not advance repeats
//! what the trees already hold.
//!
//! # The rule ([`Authority::Adaptive`])
//!
//! The planner keeps the operator's *trust* `T ∈ [0, 1]` from the time of its last
//! *progress* (times are the operator input's own, [`crate::UserInput::time_s`], s; the
//! core reads no clock). Progress is any of:
//!
//! 1. **Towards the goal**: the weighted distance (I-RRT eq. 2) from q_user to the goal
//!    fell by [`AdaptiveAuthority::goal_progress`] (default 0.01 weighted m: 1 cm or
//!    0.1 rad) below its value at the last progress. Going back and returning is no
//!    progress.
//! 2. **New ground**: q_user's position is farther than [`AdaptiveAuthority::new_ground_m`]
//!    (default 0.05 m) from every place where it made progress before (the last
//!    [`LANDMARKS`] of them). Sliding along a wall, or going round an obstacle away from
//!    the goal, counts; wiggling and backing off at one place does not.
//! 3. **Fruit**: a sample of the operator's present input (a contact sample, or q_device
//!    itself in free space; not the samples near its travelled path that stand in for a
//!    repeated q_device) was new ground for the roadmap and a tree reached it (its nearest
//!    node was more than one extension step away: [`crate::IterReport::novel`]), or its
//!    iteration merged a local tree or solved. A tree that only grows towards the samples
//!    without reaching them (the goal tree behind the wall the operator presses on) is no
//!    fruit.
//!
//! With `s` the time since the last progress, `T = 1` while `s ≤ patience_s`, then it
//! falls linearly to 0 over `ramp_s`. The machine share (the probability of a machine
//! sample, [`crate::params::MachineSampler`]) is
//!
//! - in free space and in contact alike: `m = α + (m_max − α)(1 − T)`.
//!
//! The machine keeps its share α in contact too (Algorithm 2 gives it none there; the
//! fixed rule keeps that, or α with [`crate::sampling::ContactParams::shared_authority`]).
//! Why: trust is restored by any progress, and an operator sliding along a wall finds new
//! ground every few centimetres, so with Algorithm 2's contact rule the machine drew no
//! sample for most of a session spent in contact (live, crossing planes without its route,
//! the newcomer, α = 0.5, seeds 1 and 2: solved after 51.6 s and 12.7 s, automatic
//! RRT-Connect 1.7 s and 3.4 s; with α kept in contact and α = 0.9: 1.9 s and 0.34 s).
//! With α in contact the operator's samples can cost at most their share 1 − α of the
//! iterations, whatever the operator does.
//!
//! and the rest goes to the operator as in Algorithm 2: HapticSampling in contact (the
//! ellipse stays where the operator pushes, with the share `1 − m` that shrinks while it
//! bears no fruit), q_device (or the `fresh` human mode's stand-in) in free space. Any
//! progress restores `T = 1` at once: the operator's share comes back the moment it
//! advances again. `α` is `--alpha`, `m_max` is [`AdaptiveAuthority::max_machine_share`]
//! (default 1: all of it).
//!
//! Defaults: `patience_s` = 0.5 s (one block-and-retry cycle of the simulated expert: the
//! block felt for 0.2 s, then 0.3 s backing off; as long as its typical hesitation),
//! `ramp_s` = 0.5 s. An operator pressed on one wall without progress from time `t₀` gets
//! the full machine share from `t₀ + 1 s`; against automatic planning that costs the
//! operator's share (1 − α) of the time it took to get stuck, plus `patience_s + ramp_s /
//! 2` of its share in contact. Chosen over 1 s + 1 s on the live wall-hole and tunnels
//! with their routes removed (expert, α = 0.5, 5 seeds, median time to solve: wall-hole
//! 1.18 s against 3.08 s, tunnels 11.9 s against 17.2 s; docs/experiments.md). A
//! shorter patience takes the share from operators who are merely slow: the novice
//! hesitates for up to 1.5 s.
//!
//! Deterministic: the trust is a function of the input sequence (times, poses, contact)
//! and of what the planner's own iterations did.

use crate::space::ConfigSpace;
use nalgebra::Vector3;
use scene::pose::Se3;

/// How H-RRT-C shares authority between machine samples and the operator's. See the
/// module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Authority {
    /// The paper's fixed α (Algorithm 2): machine samples with probability α in free space,
    /// none in contact (α there too with shared contact authority).
    Fixed,
    /// α while the operator progresses; up to `max_machine_share` while it does not.
    Adaptive(AdaptiveAuthority),
}

impl Authority {
    /// `fixed` or `adaptive` (with the default adaptive parameters).
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "fixed" => Some(Authority::Fixed),
            "adaptive" => Some(Authority::Adaptive(AdaptiveAuthority::default())),
            _ => None,
        }
    }

    /// `fixed` or `adaptive`.
    pub fn name(&self) -> &'static str {
        match self {
            Authority::Fixed => "fixed",
            Authority::Adaptive(_) => "adaptive",
        }
    }
}

/// Parameters of [`Authority::Adaptive`]. See the module docs for the rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveAuthority {
    /// Time without progress before the operator's trust starts to fall, s (> 0, default
    /// 0.5).
    pub patience_s: f64,
    /// Time over which the trust then falls from full to none, s (> 0, default 0.5).
    pub ramp_s: f64,
    /// Machine share at no trust, in [0, 1] (default 1: all samples are the machine's).
    /// Never below α: adaptation only ever takes authority from a stuck operator.
    pub max_machine_share: f64,
    /// Decrease of the weighted distance from q_user to the goal that counts as progress,
    /// weighted m (> 0, default 0.01: 1 cm or 0.1 rad).
    pub goal_progress: f64,
    /// Distance of q_user's position from every earlier place of progress that counts as
    /// new ground, m (> 0, default 0.05: half the size of the built-in scenes' objects).
    pub new_ground_m: f64,
}

impl Default for AdaptiveAuthority {
    fn default() -> Self {
        AdaptiveAuthority {
            patience_s: 0.5,
            ramp_s: 0.5,
            max_machine_share: 1.0,
            goal_progress: 0.01,
            new_ground_m: 0.05,
        }
    }
}

impl AdaptiveAuthority {
    /// The first field out of range, and why.
    pub fn invalid(&self) -> Option<(&'static str, String)> {
        for (name, v) in [
            ("authority.patience_s", self.patience_s),
            ("authority.ramp_s", self.ramp_s),
            ("authority.goal_progress", self.goal_progress),
            ("authority.new_ground_m", self.new_ground_m),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Some((name, format!("must be finite and > 0, got {v}")));
            }
        }
        let m = self.max_machine_share;
        if !(0.0..=1.0).contains(&m) {
            return Some((
                "authority.max_machine_share",
                format!("must be in [0, 1], got {m}"),
            ));
        }
        None
    }

    /// Trust after `stagnant_s` seconds without progress (1 within the patience, then
    /// falling linearly to 0 over the ramp).
    pub fn trust_after(&self, stagnant_s: f64) -> f64 {
        (1.0 - (stagnant_s - self.patience_s) / self.ramp_s).clamp(0.0, 1.0)
    }
}

/// Places of progress remembered for the new-ground test (the oldest is forgotten first).
pub const LANDMARKS: usize = 128;

/// What the authority is now (for logs, reports and tests).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AuthorityState {
    /// The operator's trust, in [0, 1] (always 1 with [`Authority::Fixed`]).
    pub trust: f64,
    /// Probability of a machine sample while the operator is in free space.
    pub machine_share_free: f64,
    /// Probability of a machine sample while the operator is in contact (adaptive: the
    /// same as in free space).
    pub machine_share_contact: f64,
    /// Seconds since the operator's last progress (0 with no input yet, or fixed α).
    pub stagnant_s: f64,
    /// Times the operator's trust came back to full after it had fallen.
    pub restores: u64,
}

/// The adaptive rule's memory; one per planner.
#[derive(Clone, Debug, Default)]
pub struct TrustTracker {
    /// Time of the newest input, s.
    now_s: Option<f64>,
    /// Time of the last progress, s.
    progress_at_s: f64,
    /// Weighted distance to the goal at the last progress.
    goal_ref: f64,
    /// Positions of progress, ring of at most [`LANDMARKS`].
    landmarks: Vec<Vector3<f64>>,
    next_landmark: usize,
    /// The trust had fallen below 1 since the last progress.
    fallen: bool,
    restores: u64,
}

impl TrustTracker {
    /// Takes in the operator's input at `time_s` (s): progress towards `goal` or on new
    /// ground resets the stagnation time. Non-finite times are ignored; a time earlier
    /// than the last one (another clock: a restarted loop) starts afresh.
    pub fn observe(
        &mut self,
        rule: &AdaptiveAuthority,
        space: &dyn ConfigSpace,
        q_user: &Se3,
        goal: &Se3,
        time_s: f64,
    ) {
        if !time_s.is_finite() {
            return;
        }
        let to_goal = space.distance(q_user, goal);
        let restart = self.now_s.is_none_or(|t| time_s < t);
        if restart {
            self.progress_at_s = time_s;
            self.goal_ref = to_goal;
            self.landmarks.clear();
            self.next_landmark = 0;
            self.fallen = false;
            self.landmark(q_user.pos);
        }
        self.now_s = Some(time_s);
        if restart {
            return;
        }
        let closer = to_goal <= self.goal_ref - rule.goal_progress;
        let ground = rule.new_ground_m;
        let new_ground = self
            .landmarks
            .iter()
            .all(|l| (l - q_user.pos).norm() > ground);
        if closer || new_ground {
            self.goal_ref = self.goal_ref.min(to_goal);
            self.landmark(q_user.pos);
            self.progress(rule);
        } else if rule.trust_after(time_s - self.progress_at_s) < 1.0 {
            self.fallen = true;
        }
    }

    /// A sample of the operator's present input bore fruit (see the module docs).
    pub fn fruit(&mut self, rule: &AdaptiveAuthority) {
        self.progress(rule);
    }

    fn progress(&mut self, rule: &AdaptiveAuthority) {
        let Some(now) = self.now_s else {
            return;
        };
        if self.fallen || rule.trust_after(now - self.progress_at_s) < 1.0 {
            self.restores += 1;
        }
        self.fallen = false;
        self.progress_at_s = now;
    }

    fn landmark(&mut self, p: Vector3<f64>) {
        if self.landmarks.len() < LANDMARKS {
            self.landmarks.push(p);
        } else {
            self.landmarks[self.next_landmark] = p;
        }
        self.next_landmark = (self.next_landmark + 1) % LANDMARKS;
    }

    /// Seconds since the last progress (0 before any input).
    pub fn stagnant_s(&self) -> f64 {
        self.now_s
            .map_or(0.0, |t| (t - self.progress_at_s).max(0.0))
    }

    /// The authority now under `authority`, with H-RRT-C's `alpha` and, for the fixed
    /// rule, `shared` contact authority (the adaptive rule always shares it).
    pub fn state(&self, authority: &Authority, alpha: f64, shared: bool) -> AuthorityState {
        let contact_base = if shared { alpha } else { 0.0 };
        match authority {
            Authority::Fixed => AuthorityState {
                trust: 1.0,
                machine_share_free: alpha,
                machine_share_contact: contact_base,
                stagnant_s: 0.0,
                restores: 0,
            },
            Authority::Adaptive(rule) => {
                let stagnant_s = self.stagnant_s();
                let trust = rule.trust_after(stagnant_s);
                let share = |base: f64| {
                    let top = rule.max_machine_share.max(base);
                    base + (top - base) * (1.0 - trust)
                };
                AuthorityState {
                    trust,
                    machine_share_free: share(alpha),
                    machine_share_contact: share(alpha),
                    stagnant_s,
                    restores: self.restores,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::space::tests::space;

    #[test]
    fn trust_holds_for_the_patience_then_falls_over_the_ramp() {
        let r = AdaptiveAuthority {
            patience_s: 1.0,
            ramp_s: 2.0,
            ..Default::default()
        };
        assert_eq!(r.trust_after(0.0), 1.0);
        assert_eq!(r.trust_after(1.0), 1.0);
        assert!((r.trust_after(2.0) - 0.5).abs() < 1e-12);
        assert_eq!(r.trust_after(3.0), 0.0);
        assert_eq!(r.trust_after(30.0), 0.0);
    }

    #[test]
    fn goal_progress_and_new_ground_reset_the_stagnation() {
        let s = space();
        let rule = AdaptiveAuthority {
            patience_s: 1.0,
            ramp_s: 1.0,
            ..Default::default()
        };
        let goal = Se3::from_xyz(0.2, 0.0, 0.0);
        let mut t = TrustTracker::default();
        t.observe(&rule, &s, &Se3::from_xyz(-0.2, 0.0, 0.0), &goal, 10.0);
        // 5 mm closer: not yet progress.
        t.observe(&rule, &s, &Se3::from_xyz(-0.195, 0.0, 0.0), &goal, 10.5);
        assert!((t.stagnant_s() - 0.5).abs() < 1e-12);
        // 1 cm closer than at the last progress: progress.
        t.observe(&rule, &s, &Se3::from_xyz(-0.19, 0.0, 0.0), &goal, 11.0);
        assert_eq!(t.stagnant_s(), 0.0);
        assert_eq!(t.restores, 0, "the trust had not fallen yet");
        // Back 3 cm and forward again to where it was: no progress.
        t.observe(&rule, &s, &Se3::from_xyz(-0.22, 0.0, 0.0), &goal, 11.5);
        t.observe(&rule, &s, &Se3::from_xyz(-0.19, 0.0, 0.0), &goal, 12.0);
        assert!((t.stagnant_s() - 1.0).abs() < 1e-12);
        // Sideways by 4 cm: within the new-ground radius of the landmarks (no progress);
        // by 6 cm from every landmark: new ground.
        t.observe(&rule, &s, &Se3::from_xyz(-0.19, 0.04, 0.0), &goal, 13.5);
        assert!((t.stagnant_s() - 2.5).abs() < 1e-12);
        t.observe(&rule, &s, &Se3::from_xyz(-0.19, 0.06, 0.0), &goal, 14.0);
        assert_eq!(t.stagnant_s(), 0.0);
        assert_eq!(
            t.restores, 1,
            "trust had fallen after 2.5 s without progress"
        );
        // A clock that goes back (a restarted loop) starts afresh.
        t.observe(&rule, &s, &Se3::from_xyz(-0.19, 0.06, 0.0), &goal, 1.0);
        assert_eq!(t.stagnant_s(), 0.0);
        t.observe(&rule, &s, &Se3::from_xyz(-0.19, 0.06, 0.0), &goal, f64::NAN);
        assert_eq!(t.stagnant_s(), 0.0);
    }

    #[test]
    fn shares_move_between_alpha_and_the_cap() {
        let s = space();
        let rule = AdaptiveAuthority {
            patience_s: 1.0,
            ramp_s: 1.0,
            max_machine_share: 0.9,
            ..Default::default()
        };
        let adaptive = Authority::Adaptive(rule);
        let goal = Se3::from_xyz(0.2, 0.0, 0.0);
        let q = Se3::from_xyz(-0.06, 0.0, 0.0);
        let mut t = TrustTracker::default();
        t.observe(&rule, &s, &q, &goal, 0.0);
        let a = t.state(&adaptive, 0.3, false);
        assert_eq!((a.trust, a.machine_share_free), (1.0, 0.3));
        assert_eq!(a.machine_share_contact, 0.3, "α in contact too");
        t.observe(&rule, &s, &q, &goal, 1.5);
        let a = t.state(&adaptive, 0.3, false);
        assert!((a.trust - 0.5).abs() < 1e-12);
        assert!((a.machine_share_free - 0.6).abs() < 1e-12);
        assert!((a.machine_share_contact - 0.6).abs() < 1e-12);
        let shared = t.state(&adaptive, 0.3, true);
        assert_eq!(shared, a, "the adaptive rule always shares");
        t.observe(&rule, &s, &q, &goal, 5.0);
        let a = t.state(&adaptive, 0.3, false);
        assert_eq!(a.trust, 0.0);
        assert!((a.machine_share_free - 0.9).abs() < 1e-12);
        assert!((a.machine_share_contact - 0.9).abs() < 1e-12);
        // A cap below α never lowers the machine share.
        assert!((t.state(&adaptive, 0.95, false).machine_share_free - 0.95).abs() < 1e-12);
        // Fixed α: whatever the stagnation.
        let f = t.state(&Authority::Fixed, 0.3, false);
        assert_eq!(
            (f.trust, f.machine_share_free, f.machine_share_contact),
            (1.0, 0.3, 0.0)
        );
        // Fruit restores the trust at once.
        t.fruit(&rule);
        assert_eq!(t.state(&adaptive, 0.3, false).trust, 1.0);
        assert_eq!(t.state(&adaptive, 0.3, false).restores, 1);
    }

    #[test]
    fn parameters_are_named_when_out_of_range() {
        assert!(AdaptiveAuthority::default().invalid().is_none());
        let bad = AdaptiveAuthority {
            ramp_s: 0.0,
            ..Default::default()
        };
        assert_eq!(bad.invalid().map(|e| e.0), Some("authority.ramp_s"));
        let bad = AdaptiveAuthority {
            max_machine_share: 1.5,
            ..Default::default()
        };
        assert_eq!(
            bad.invalid().map(|e| e.0),
            Some("authority.max_machine_share")
        );
        assert_eq!(
            Authority::parse("adaptive").map(|a| a.name()),
            Some("adaptive")
        );
        assert_eq!(Authority::parse("fixed"), Some(Authority::Fixed));
        assert!(Authority::parse("auto").is_none());
    }
}
