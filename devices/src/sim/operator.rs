//! A simulated operator who reacts: it follows an intended route, perceives the held
//! object and the force it feels a reaction time late, hesitates, sometimes takes a wrong
//! turn or holds the object at a wrong orientation, notices when it is blocked and
//! corrects, presses against a surface to slide along it where its route says so, and
//! yields to the planner's guidance once it feels it.
//!
//! The mind ([`Operator`]) only decides an *intent*: the velocity it wants for the held
//! object and the force it presses with. Two bodies carry it out:
//! - [`OperatorHand`] holds a haptic arm through a spring-damper grip whose setpoint moves
//!   with the intent (used by [`SimulatedArm`](super::SimulatedArm));
//! - [`SimulatedSpaceMouse`](super::SimulatedSpaceMouse) turns the intent into puck
//!   deflections of a rate-controlled avatar; there the operator feels nothing and judges
//!   being blocked only by seeing no progress.
//!
//! # The model, per decision (every 1 ms of the operator's clock)
//! 0. **Take hold**: still for `start_hold_s` after the first decision; the route's
//!    first step (the start) then counts as reached wherever the object is.
//! 1. **Perceive** the object's pose and felt wrench now; act on the perception of
//!    `reaction_delay_s` ago ([`perception`]).
//! 2. **Target**: the current route step's pose, moved sideways by a wrong turn and turned
//!    by a wrong orientation if this step drew one, and by the jitter of a retry.
//! 3. **Arrived** within the tolerances (ignoring the press direction on a sliding step)?
//!    A wrong turn is then seen to be wrong and dropped; otherwise dwell, then the next
//!    step (with new random draws). The last step is held.
//! 4. **Intent**: toward the target at `speed_m_per_s` / `angular_speed_rad_per_s`, slowing
//!    within `approach_time_s` of it. A felt force that does not oppose that motion (nor
//!    lie along the press) is guidance: it takes a share `guidance_share · min(|f| /
//!    guidance_full_n, 1)` of the intent (`stuck_guidance_share` once stuck), the same for
//!    torque.
//! 5. **Blocked**: a felt force against the motion above `blocked_force_n` for
//!    `blocked_time_s`, or no progress of `stall_progress_m` for `stall_time_s`. Then, in
//!    this order: drop a wrong turn; else reduce a wrong orientation by `correction_share`;
//!    else back off for `retry_back_s` and retry with a small random change of position and
//!    orientation.
//! 6. **Hesitate** now and then (a Poisson process), standing still.
//!
//! # The newcomer ([`Operator::newcomer`], `config.newcomer` set)
//! An operator who does not know the way: its route is its own coarse way (positions a
//! person would pick from what they see), its orientations turn from the start's toward the
//! goal's as it perceives it (with `goal_orientation_error_rad`) along the way. It checks
//! waypoints off by position (`waypoint_reach_m`). Blocked, it backs off and tries the next
//! turn of a seeded order (none, ±`trial_rad` about each axis), wiggled; but when the
//! guidance it feels is at full share it keeps the orientation the guidance gave instead;
//! near the goal it drops these and turns to the goal's orientation as it perceives it.
//! Its share grows by `share_per_block` with every block at a waypoint up to
//! `stuck_guidance_share`, where it follows the whole felt force; it never holds its
//! guessed orientation against a felt torque.
//!
//! Deterministic for a given config (its `seed`), route and sequence of perceptions; no
//! allocation after construction.

mod config;
mod hand;
mod perception;

pub use config::{NewcomerConfig, OperatorConfig};
pub use hand::OperatorHand;
pub use perception::Perception;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};

use crate::DeviceError;
use perception::DelayLine;

/// How often the operator decides, s.
pub const DECISION_PERIOD_S: f64 = 1e-3;

/// The turns a newcomer tries when blocked: none (a wiggle only), then plus and minus
/// `NewcomerConfig::trial_rad` about each base axis (as a unit axis times ±1).
const TRIALS: [[f64; 3]; 7] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [-1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, -1.0, 0.0],
    [0.0, 0.0, 1.0],
    [0.0, 0.0, -1.0],
];

/// One step of an operator's route, device base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RouteStep {
    /// Pose to bring the held object to (m).
    pub pose: Isometry3<f64>,
    /// Force the hand adds while heading here, N: pressing the object against a surface
    /// to slide along it (H-RRT-C's use of contact). Zero for free motion.
    pub press_n: Vector3<f64>,
    /// Pause on arrival, s.
    pub dwell_s: f64,
}

impl RouteStep {
    /// A free-motion step to `pose` with no dwell.
    pub fn to(pose: Isometry3<f64>) -> Self {
        RouteStep {
            pose,
            press_n: Vector3::zeros(),
            dwell_s: 0.0,
        }
    }
}

/// What the operator wants at one instant, device base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intent {
    /// Wanted velocity of the held object, m/s.
    pub linear_velocity: Vector3<f64>,
    /// Wanted angular velocity, rad/s.
    pub angular_velocity: Vector3<f64>,
    /// Force pressed with, N.
    pub press_n: Vector3<f64>,
}

impl Intent {
    const STILL: Intent = Intent {
        linear_velocity: Vector3::new(0.0, 0.0, 0.0),
        angular_velocity: Vector3::new(0.0, 0.0, 0.0),
        press_n: Vector3::new(0.0, 0.0, 0.0),
    };
}

/// What the operator did so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct OperatorStats {
    /// Route steps reached (the last one included once held).
    pub steps_reached: u32,
    /// Times it felt or saw itself blocked.
    pub blocks: u32,
    /// Wrong turns taken.
    pub wrong_turns: u32,
    /// Wrong orientations drawn.
    pub wrong_orientations: u32,
    /// Corrections of a wrong turn or orientation after a block or on arrival.
    pub corrections: u32,
    /// Retries (back off and change a little) after a block with nothing to correct.
    pub retries: u32,
    /// Hesitations.
    pub hesitations: u32,
}

/// The operator's counts, readable from another thread while it acts (a session reports
/// them at its end; the device itself is owned by the real-time loop). Relaxed atomics:
/// updated once per decision, allocation-free.
#[derive(Debug, Default)]
pub struct SharedStats {
    step: AtomicU32,
    steps_reached: AtomicU32,
    blocks: AtomicU32,
    wrong_turns: AtomicU32,
    wrong_orientations: AtomicU32,
    corrections: AtomicU32,
    retries: AtomicU32,
    hesitations: AtomicU32,
}

impl SharedStats {
    /// The counts now, and the route step the operator heads for.
    pub fn read(&self) -> (OperatorStats, u32) {
        let g = |a: &AtomicU32| a.load(Ordering::Relaxed);
        (
            OperatorStats {
                steps_reached: g(&self.steps_reached),
                blocks: g(&self.blocks),
                wrong_turns: g(&self.wrong_turns),
                wrong_orientations: g(&self.wrong_orientations),
                corrections: g(&self.corrections),
                retries: g(&self.retries),
                hesitations: g(&self.hesitations),
            },
            g(&self.step),
        )
    }

    fn write(&self, s: &OperatorStats, step: usize) {
        let p = |a: &AtomicU32, v: u32| a.store(v, Ordering::Relaxed);
        p(&self.step, step as u32);
        p(&self.steps_reached, s.steps_reached);
        p(&self.blocks, s.blocks);
        p(&self.wrong_turns, s.wrong_turns);
        p(&self.wrong_orientations, s.wrong_orientations);
        p(&self.corrections, s.corrections);
        p(&self.retries, s.retries);
        p(&self.hesitations, s.hesitations);
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    Moving,
    /// Standing still until `until` (s).
    Hesitating {
        until: f64,
    },
    /// At the step, pausing until `until` (s).
    Dwelling {
        until: f64,
    },
    /// Moving back along `direction` (unit) until `until` (s).
    BackingOff {
        until: f64,
        direction: Vector3<f64>,
    },
    /// At the last step, holding it.
    Done,
}

/// The operator's mind. See the module docs.
#[derive(Debug, Clone)]
pub struct Operator {
    config: OperatorConfig,
    route: Vec<RouteStep>,
    rng: ChaCha8Rng,
    step: usize,
    mode: Mode,
    /// Wrong turn of this step: sideways offset of its position, m.
    turn: Vector3<f64>,
    /// Wrong orientation of this step (identity when none), applied in the base frame.
    orientation_error: UnitQuaternion<f64>,
    /// A retry's change of the target.
    jitter: Isometry3<f64>,
    blocks_here: u32,
    /// Pressing on this step now.
    pressing: bool,
    /// The newcomer's turns to try when blocked (indices into [`TRIALS`]), in the order
    /// drawn from the seed, and the next one.
    trial_order: [usize; TRIALS.len()],
    trial_next: usize,
    /// At the last decision it felt guidance at full share (force or torque).
    led: bool,
    /// Time the felt resistance has lasted, s.
    resisted_s: f64,
    /// Best progress measure this attempt and when it was reached, s.
    best: f64,
    best_at: f64,
    last_t: Option<f64>,
    /// Time of the first decision, s (see `OperatorConfig::start_hold_s`).
    first_t: Option<f64>,
    line: DelayLine,
    intent: Intent,
    stats: OperatorStats,
    shared: Arc<SharedStats>,
}

impl Operator {
    /// An operator following `route` (device base frame). Allocates; fails on an invalid
    /// config or an empty or non-finite route.
    pub fn new(config: OperatorConfig, route: Vec<RouteStep>) -> Result<Self, DeviceError> {
        config.validate()?;
        if route.is_empty() {
            return Err(DeviceError::InvalidConfig("route (empty)"));
        }
        let finite = |s: &RouteStep| {
            s.pose.translation.vector.iter().all(|v| v.is_finite())
                && s.pose.rotation.coords.iter().all(|v| v.is_finite())
                && s.press_n.iter().all(|v| v.is_finite())
                && s.dwell_s.is_finite()
                && s.dwell_s >= 0.0
        };
        if !route.iter().all(finite) {
            return Err(DeviceError::InvalidConfig(
                "route (a non-finite pose, press or dwell)",
            ));
        }
        Ok(Operator {
            rng: ChaCha8Rng::seed_from_u64(config.seed),
            line: DelayLine::new(config.reaction_delay_s, DECISION_PERIOD_S),
            config,
            route,
            step: 0,
            mode: Mode::Moving,
            turn: Vector3::zeros(),
            orientation_error: UnitQuaternion::identity(),
            jitter: Isometry3::identity(),
            blocks_here: 0,
            pressing: false,
            trial_order: std::array::from_fn(|i| i),
            trial_next: TRIALS.len(),
            led: false,
            resisted_s: 0.0,
            best: f64::INFINITY,
            best_at: 0.0,
            last_t: None,
            first_t: None,
            intent: Intent::STILL,
            stats: OperatorStats::default(),
            shared: Arc::new(SharedStats::default()),
        })
    }

    /// An operator who does not know the way (`config.newcomer` must be set): it goes from
    /// `start` through the positions of its own coarse `way` (device base frame, m; the
    /// start's and goal's positions may be left out) to `goal`, turning the object from
    /// the start's orientation toward the goal's as perceived (off by
    /// `goal_orientation_error_rad` about an axis drawn from the seed) in proportion to the
    /// way's length covered. Allocates; fails on an invalid config or a non-finite pose.
    pub fn newcomer(
        config: OperatorConfig,
        start: Isometry3<f64>,
        goal: Isometry3<f64>,
        way: &[Vector3<f64>],
    ) -> Result<Self, DeviceError> {
        let Some(n) = config.newcomer else {
            return Err(DeviceError::InvalidConfig(
                "newcomer (an operator without a route needs the newcomer's parameters)",
            ));
        };
        config.validate()?;
        let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
        let axis: Vector3<f64> = Vector3::from_fn(|_, _| rng.sample(StandardNormal));
        let error = axis
            .try_normalize(1e-9)
            .map_or_else(UnitQuaternion::identity, |a| {
                UnitQuaternion::from_scaled_axis(a * n.goal_orientation_error_rad)
            });
        let seen_goal = error * goal.rotation;
        let mut points = vec![start.translation.vector];
        points.extend(way.iter().copied());
        points.push(goal.translation.vector);
        points.dedup_by(|a, b| (*a - *b).norm() < 1e-9);
        let total: f64 = points.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
        let mut covered = 0.0;
        let mut route = Vec::with_capacity(points.len() + 1);
        route.push(RouteStep::to(start));
        for w in points.windows(2) {
            covered += (w[1] - w[0]).norm();
            let share = if total > 0.0 { covered / total } else { 1.0 };
            let q = start
                .rotation
                .try_slerp(&seen_goal, share, 1e-9)
                .unwrap_or(seen_goal);
            route.push(RouteStep::to(Isometry3::from_parts(
                Translation3::from(w[1]),
                q,
            )));
        }
        let mut op = Operator::new(config, route)?;
        // The trials' order, then the rest of its choices, from the same seed.
        op.rng = rng;
        op.shuffle_trials();
        Ok(op)
    }

    /// Its counts as another thread can read them while it acts.
    pub fn shared_stats(&self) -> Arc<SharedStats> {
        self.shared.clone()
    }

    /// The configuration.
    pub fn config(&self) -> &OperatorConfig {
        &self.config
    }

    /// The route.
    pub fn route(&self) -> &[RouteStep] {
        &self.route
    }

    /// Where the operator starts: the first step's pose.
    pub fn start_pose(&self) -> Isometry3<f64> {
        self.route[0].pose
    }

    /// Index of the route step it is heading for (or holding).
    pub fn step_index(&self) -> usize {
        self.step
    }

    /// True once it holds the last step.
    pub fn finished(&self) -> bool {
        self.mode == Mode::Done
    }

    /// True while hesitating.
    pub fn hesitating(&self) -> bool {
        matches!(self.mode, Mode::Hesitating { .. })
    }

    /// The current wrong orientation's angle, rad (0 when none).
    pub fn orientation_error_rad(&self) -> f64 {
        self.orientation_error.angle()
    }

    /// What it did so far.
    pub fn stats(&self) -> OperatorStats {
        self.stats
    }

    /// The intent of the last decision.
    pub fn intent(&self) -> Intent {
        self.intent
    }

    /// The pose it aims for now (the step's pose with this attempt's errors), base frame.
    pub fn target(&self) -> Isometry3<f64> {
        let step = &self.route[self.step];
        let p = step.pose.translation.vector + self.turn + self.jitter.translation.vector;
        let q = self.jitter.rotation * self.orientation_error * step.pose.rotation;
        Isometry3::from_parts(Translation3::from(p), q)
    }

    /// Decides with what is perceived now (acting on what was perceived
    /// `reaction_delay_s` earlier) and returns the intent. Call once per
    /// [`DECISION_PERIOD_S`] with non-decreasing times.
    pub fn decide(&mut self, now: &Perception) -> Intent {
        let dt = self.last_t.map_or(0.0, |t| (now.t_s - t).clamp(0.0, 0.1));
        self.last_t = Some(now.t_s);
        let seen = self.line.push(*now);
        let t = now.t_s;
        let first = *self.first_t.get_or_insert(t);
        if t - first < self.config.start_hold_s {
            self.intent = Intent::STILL;
            return self.intent;
        }
        if self.step == 0 && self.route.len() > 1 {
            // The first step is the start, where it took hold: reached however far a
            // guidance pull moved the object during the hold (heading back to it, it would
            // read the pull as resistance and fight the planner's lead from the start).
            self.stats.steps_reached += 1;
            self.next_step(t);
        }
        self.update_pressing(&seen);
        if self.best.is_infinite() {
            self.begin_attempt(t);
        }
        self.intent = match self.mode {
            Mode::Done => self.toward(&seen, false),
            Mode::Hesitating { until } | Mode::Dwelling { until } if t < until => {
                self.best_at = t;
                Intent {
                    press_n: self.press_now(),
                    ..Intent::STILL
                }
            }
            Mode::Dwelling { .. } => {
                self.next_step(t);
                self.toward(&seen, true)
            }
            Mode::Hesitating { .. } => {
                self.mode = Mode::Moving;
                self.best_at = t;
                self.toward(&seen, true)
            }
            Mode::BackingOff { until, direction } if t < until => Intent {
                linear_velocity: direction * (0.5 * self.config.speed_m_per_s),
                ..Intent::STILL
            },
            Mode::BackingOff { .. } => {
                self.mode = Mode::Moving;
                self.begin_attempt(t);
                self.toward(&seen, true)
            }
            Mode::Moving => self.moving(&seen, t, dt),
        };
        self.shared.write(&self.stats, self.step);
        self.intent
    }

    fn moving(&mut self, seen: &Perception, t: f64, dt: f64) -> Intent {
        let c = self.config;
        if let Some(k) = self.passed_waypoint(seen) {
            // A newcomer checks its waypoints off by position, skipping those it is past.
            self.stats.steps_reached += (k + 1 - self.step) as u32;
            self.step = k;
            self.turn = Vector3::zeros();
            self.next_step(t);
            return self.toward(seen, true);
        }
        if self.near_goal_with_changes(seen) {
            // At the goal it looks at the goal's orientation again: the turns it tried and
            // the orientation a guidance gave were for the way there.
            self.jitter = Isometry3::identity();
            self.begin_attempt(t);
        }
        let (e_p, e_r) = self.errors(seen);
        if e_p.norm() <= c.position_tolerance_m && e_r.norm() <= c.angle_tolerance_rad {
            if self.turn != Vector3::zeros() {
                // It sees it went the wrong way.
                self.turn = Vector3::zeros();
                self.stats.corrections += 1;
                self.begin_attempt(t);
                return self.toward(seen, true);
            }
            self.stats.steps_reached += 1;
            let dwell = self.route[self.step].dwell_s;
            if self.step + 1 == self.route.len() {
                self.mode = Mode::Done;
            } else if dwell > 0.0 {
                self.mode = Mode::Dwelling { until: t + dwell };
            } else {
                self.next_step(t);
            }
            return self.toward(seen, true);
        }
        if self.rng.random::<f64>() < c.hesitation_rate_per_s * dt {
            let span = c.hesitation_max_s - c.hesitation_min_s;
            let until = t + c.hesitation_min_s + span * self.rng.random::<f64>();
            self.mode = Mode::Hesitating { until };
            self.stats.hesitations += 1;
            return Intent {
                press_n: self.press_now(),
                ..Intent::STILL
            };
        }
        let intent = self.toward(seen, true);
        // Progress: the seen distance to the target, angles weighed as lengths.
        let measure = e_p.norm() + c.rotation_length_m * e_r.norm();
        if measure < self.best - c.stall_progress_m {
            self.best = measure;
            self.best_at = t;
        }
        let resistance = self.resistance(seen, &e_p);
        let press = self.press_now();
        self.led = seen.felt.is_some_and(|felt| {
            let (pull, twist) = self.pull_and_twist(&felt, &e_p, &e_r, &press);
            pull.norm() >= c.guidance_full_n || twist.norm() >= c.guidance_full_nm
        });
        if resistance > c.blocked_force_n {
            self.resisted_s += dt;
        } else if resistance < 0.5 * c.blocked_force_n {
            self.resisted_s = 0.0;
        }
        let felt_block = seen.felt.is_some() && self.resisted_s >= c.blocked_time_s;
        if felt_block || t - self.best_at >= c.stall_time_s {
            self.blocked(t, &e_p, seen);
            return Intent {
                press_n: press,
                ..Intent::STILL
            };
        }
        intent
    }

    /// The force pressed with now: the step's press while within its slack, else none.
    fn press_now(&self) -> Vector3<f64> {
        match self.press_direction() {
            Some(_) => self.press(),
            None => Vector3::zeros(),
        }
    }

    /// Position error (m) and rotation vector (rad) from the seen pose to the target, base
    /// frame; while pressing, the position error's part along the press is dropped.
    fn errors(&self, seen: &Perception) -> (Vector3<f64>, Vector3<f64>) {
        let target = self.target();
        let mut e_p = target.translation.vector - seen.pose.translation.vector;
        if let Some(n) = self.press_direction() {
            e_p -= n * e_p.dot(&n);
        }
        let e_r = (target.rotation * seen.pose.rotation.inverse()).scaled_axis();
        (e_p, e_r)
    }

    /// The unit press direction of this step while pressing (see [`Operator::update_pressing`]).
    fn press_direction(&self) -> Option<Vector3<f64>> {
        let n = self.route[self.step].press_n.try_normalize(1e-9)?;
        self.pressing.then_some(n)
    }

    /// Pressing lets the surface set the height along the press, but an object far off that
    /// height (it slipped past the surface's edge, or has not reached it) is brought back
    /// first: pressing starts when the object is seen within `press_slack_m` of the step
    /// along the press and stops beyond twice that.
    fn update_pressing(&mut self, seen: &Perception) {
        let Some(n) = self.route[self.step].press_n.try_normalize(1e-9) else {
            self.pressing = false;
            return;
        };
        let off = (self.target().translation.vector - seen.pose.translation.vector)
            .dot(&n)
            .abs();
        let slack = self.config.press_slack_m;
        self.pressing = if self.pressing {
            off <= 2.0 * slack
        } else {
            off <= slack
        };
    }

    /// The felt force against the wanted motion, N (0 without force feedback).
    fn resistance(&self, seen: &Perception, e_p: &Vector3<f64>) -> f64 {
        let (Some(felt), Some(d)) = (seen.felt, e_p.try_normalize(1e-9)) else {
            return 0.0;
        };
        (-felt.force.dot(&d)).max(0.0)
    }

    fn press(&self) -> Vector3<f64> {
        self.route[self.step].press_n
    }

    /// The intent toward the target from `seen`, with the guidance share when `yielding`.
    fn toward(&self, seen: &Perception, yielding: bool) -> Intent {
        let c = &self.config;
        let (e_p, e_r) = self.errors(seen);
        // Position and orientation arrive together (a straight line and a slerp, as the
        // planner interpolates), at the pace of the slower one.
        let time_s = (e_p.norm() / c.speed_m_per_s)
            .max(e_r.norm() / c.angular_speed_rad_per_s)
            .max(c.approach_time_s);
        let v_route = e_p / time_s;
        let w_route = e_r / time_s;
        let mut intent = Intent {
            linear_velocity: v_route,
            angular_velocity: w_route,
            press_n: self.press_now(),
        };
        let Some(felt) = seen.felt.filter(|_| yielding) else {
            return intent;
        };
        let (pull, twist) = self.pull_and_twist(&felt, &e_p, &e_r, &intent.press_n);
        let share = self.guidance_share();
        let wf = share * (pull.norm() / c.guidance_full_n).min(1.0);
        let wt = share * (twist.norm() / c.guidance_full_nm).min(1.0);
        if let Some(u) = pull.try_normalize(1e-9) {
            intent.linear_velocity = v_route * (1.0 - wf) + u * (wf * c.speed_m_per_s);
        }
        if let Some(u) = twist.try_normalize(1e-9) {
            intent.angular_velocity = w_route * (1.0 - wt) + u * (wt * c.angular_speed_rad_per_s);
        }
        intent
    }

    /// The share of its intent that guidance felt at full strength takes now.
    fn guidance_share(&self) -> f64 {
        let c = &self.config;
        match c.newcomer {
            // Grows with every block at this waypoint.
            Some(n) => (c.guidance_share + n.share_per_block * f64::from(self.blocks_here))
                .min(c.stuck_guidance_share.max(c.guidance_share)),
            // Stuck: it lets the guidance lead more.
            None if self.blocks_here >= c.stuck_after_blocks => c.stuck_guidance_share,
            None => c.guidance_share,
        }
    }

    /// The felt force and torque it reads as guidance: what does not push back against its
    /// motion (nor lie along its press). A newcomer takes the whole torque (its orientations
    /// are guesses it does not hold against a felt turn), and once its share has grown to
    /// the stuck share the whole force too: it stops insisting on its own way.
    fn pull_and_twist(
        &self,
        felt: &crate::Wrench,
        e_p: &Vector3<f64>,
        e_r: &Vector3<f64>,
        press_n: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let c = &self.config;
        let newcomer = c.newcomer.is_some();
        let whole = newcomer && self.guidance_share() >= c.stuck_guidance_share;
        let mut pull = felt.force;
        let mut twist = felt.torque;
        if !whole && let Some(d) = e_p.try_normalize(1e-9) {
            pull -= d * pull.dot(&d).min(0.0);
        }
        if !newcomer && let Some(d) = e_r.try_normalize(1e-9) {
            twist -= d * twist.dot(&d).min(0.0);
        }
        if let Some(n) = press_n.try_normalize(1e-9) {
            pull -= n * pull.dot(&n);
        }
        (pull, twist)
    }

    fn blocked(&mut self, t: f64, e_p: &Vector3<f64>, seen: &Perception) {
        let c = self.config;
        self.stats.blocks += 1;
        self.blocks_here += 1;
        self.resisted_s = 0.0;
        if let Some(n) = c.newcomer {
            self.newcomer_blocked(t, e_p, seen, &n);
            return;
        }
        if self.turn != Vector3::zeros() {
            self.turn = Vector3::zeros();
            self.stats.corrections += 1;
            self.begin_attempt(t);
            return;
        }
        if self.orientation_error.angle() > 0.0 {
            let kept = self
                .orientation_error
                .try_slerp(&UnitQuaternion::identity(), c.correction_share, 1e-9)
                .unwrap_or_else(UnitQuaternion::identity);
            self.orientation_error = if kept.angle() < 0.5 * c.angle_tolerance_rad {
                UnitQuaternion::identity()
            } else {
                kept
            };
            self.stats.corrections += 1;
            self.begin_attempt(t);
            return;
        }
        // Nothing it knows to correct: back off, then try a little differently, more
        // carefully each time it is blocked at this step (the change halves).
        self.stats.retries += 1;
        let care = 0.5f64.powi(self.blocks_here.saturating_sub(1).min(30) as i32);
        let back = e_p.try_normalize(1e-9).map_or_else(Vector3::zeros, |d| -d);
        self.mode = Mode::BackingOff {
            until: t + c.retry_back_s,
            direction: back,
        };
        let sideways = self.gaussian3() * (c.retry_jitter_m * care);
        let sideways = match e_p.try_normalize(1e-9) {
            Some(d) => sideways - d * sideways.dot(&d),
            None => sideways,
        };
        let turn = self.gaussian3() * (c.retry_jitter_rad * care);
        self.jitter = Isometry3::from_parts(
            Translation3::from(sideways),
            UnitQuaternion::from_scaled_axis(turn),
        );
    }

    /// A newcomer's answer to a block. Led by guidance it felt at full share, it keeps the
    /// orientation the guidance gave the object (its target turns to the seen orientation)
    /// and goes on, its share grown; otherwise it backs off and tries the next turn of its
    /// seeded order, wiggled.
    fn newcomer_blocked(
        &mut self,
        t: f64,
        e_p: &Vector3<f64>,
        seen: &Perception,
        n: &NewcomerConfig,
    ) {
        let c = self.config;
        let planned = self.orientation_error * self.route[self.step].pose.rotation;
        if self.led {
            self.jitter.rotation = seen.pose.rotation * planned.inverse();
            self.begin_attempt(t);
            return;
        }
        self.stats.retries += 1;
        let back = e_p.try_normalize(1e-9).map_or_else(Vector3::zeros, |d| -d);
        self.mode = Mode::BackingOff {
            until: t + c.retry_back_s,
            direction: back,
        };
        if self.trial_next >= TRIALS.len() {
            self.shuffle_trials();
        }
        let axis = Vector3::from(TRIALS[self.trial_order[self.trial_next]]);
        self.trial_next += 1;
        let sideways = self.gaussian3() * c.retry_jitter_m;
        let sideways = match e_p.try_normalize(1e-9) {
            Some(d) => sideways - d * sideways.dot(&d),
            None => sideways,
        };
        let wiggle = UnitQuaternion::from_scaled_axis(self.gaussian3() * c.retry_jitter_rad);
        let trial = UnitQuaternion::from_scaled_axis(axis * n.trial_rad);
        self.jitter = Isometry3::from_parts(Translation3::from(sideways), wiggle * trial);
    }

    /// Draws a new order of the newcomer's trials (Fisher–Yates on the fixed array).
    fn shuffle_trials(&mut self) {
        for i in (1..TRIALS.len()).rev() {
            let j = self.rng.random_range(0..=i);
            self.trial_order.swap(i, j);
        }
        self.trial_next = 0;
    }

    /// For a newcomer before its last waypoint: the farthest waypoint from the current one
    /// on (not the last) that the object is seen within `waypoint_reach_m` of.
    fn passed_waypoint(&self, seen: &Perception) -> Option<usize> {
        let reach = self.config.newcomer?.waypoint_reach_m;
        let p = seen.pose.translation.vector;
        (self.step..self.route.len() - 1)
            .rev()
            .find(|&k| (self.route[k].pose.translation.vector - p).norm() <= reach)
    }

    /// For a newcomer heading for its last waypoint (the goal) with a changed target (a
    /// turn tried, an orientation kept from guidance): true once the object is seen within
    /// `waypoint_reach_m` of the goal or of that changed target.
    fn near_goal_with_changes(&self, seen: &Perception) -> bool {
        let Some(n) = self.config.newcomer else {
            return false;
        };
        if self.step + 1 != self.route.len() || self.jitter == Isometry3::identity() {
            return false;
        }
        let p = seen.pose.translation.vector;
        let goal = self.route[self.step].pose.translation.vector;
        (goal - p).norm() <= n.waypoint_reach_m
            || (self.target().translation.vector - p).norm() <= n.waypoint_reach_m
    }

    /// Moves to the next step and draws its errors.
    fn next_step(&mut self, t: f64) {
        let c = self.config;
        self.step += 1;
        self.mode = Mode::Moving;
        self.blocks_here = 0;
        self.jitter = Isometry3::identity();
        self.turn = Vector3::zeros();
        self.orientation_error = UnitQuaternion::identity();
        let last = self.step + 1 == self.route.len();
        if !last && self.rng.random::<f64>() < c.wrong_turn_probability {
            let from = self.route[self.step - 1].pose.translation.vector;
            let to = self.route[self.step].pose.translation.vector;
            let mut side = self.gaussian3();
            if let Some(d) = (to - from).try_normalize(1e-9) {
                side -= d * side.dot(&d);
            }
            if let Some(s) = side.try_normalize(1e-9) {
                self.turn = s * c.wrong_turn_m;
                self.stats.wrong_turns += 1;
            }
        }
        if !last && self.rng.random::<f64>() < c.wrong_orientation_probability {
            let axis = self.gaussian3();
            if let Some(a) = axis.try_normalize(1e-9) {
                let angle = c.wrong_orientation_rad * (0.5 + self.rng.random::<f64>());
                self.orientation_error = UnitQuaternion::from_scaled_axis(a * angle);
                self.stats.wrong_orientations += 1;
            }
        }
        self.begin_attempt(t);
    }

    fn begin_attempt(&mut self, t: f64) {
        self.best = f64::MAX;
        self.best_at = t;
        self.resisted_s = 0.0;
    }

    fn gaussian3(&mut self) -> Vector3<f64> {
        Vector3::new(
            self.rng.sample(StandardNormal),
            self.rng.sample(StandardNormal),
            self.rng.sample(StandardNormal),
        )
    }
}

#[cfg(test)]
mod tests;
