//! One haptic tick: device → scene → contact → guidance → safety → device → publish.
//!
//! [`Tick::new`] may allocate and fail; [`Tick::step`] works on preallocated state only and is
//! what the RT thread calls once per period (see `runner`). It reads no clock itself: the
//! tick time is passed in, so tests and benches drive it in lockstep.

mod state_fill;

use crate::contact::{Anchor, ContactOutput, ContactStage};
use crate::guidance::{GuidanceConfig, GuidanceFilter, RenderedGuidance};
use crate::mapping::{Mapping, MappingConfig};
use crate::safety::{self, Plausibility, Safety, SafetyConfig};
use crate::work::{TickWork, WorkCaps};
use devices::{DeviceError, DeviceSpec, DeviceState, HapticDevice};
use ipc_types::{ContactCode, FaultCode, Guidance, HapticState};
use nalgebra::{Isometry3, Vector3};
use state_fill::TickResults;

/// Where the newest [`Guidance`] comes from. Must not allocate or block.
pub trait GuidanceSource {
    /// The newest sample (sequence 0 if none was ever written).
    fn latest(&mut self) -> Guidance;
}

/// Where each tick's [`HapticState`] goes. Must not allocate or block.
pub trait StateSink {
    /// Publishes one state.
    fn publish(&mut self, state: &HapticState);
}

impl StateSink for ipc_types::services::StateWriter {
    fn publish(&mut self, state: &HapticState) {
        let mut s = *state;
        s.published_ns = ipc_types::monotonic_ns();
        self.update_with_copy(s);
    }
}

/// One sample, always (tests, benches, replays): the newest is this one.
impl GuidanceSource for Guidance {
    fn latest(&mut self) -> Guidance {
        *self
    }
}

/// No planner: never any guidance.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoGuidance;

impl GuidanceSource for NoGuidance {
    fn latest(&mut self) -> Guidance {
        Guidance::default()
    }
}

/// Publishes nowhere.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoSink;

impl StateSink for NoSink {
    fn publish(&mut self, _: &HapticState) {}
}

/// A configuration the tick watches for: the first tick whose object pose (the proxy, or
/// the mapped device pose without contact) is within both tolerances of `pose` is
/// recorded (the operator's time to reach the goal).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GoalZone {
    /// The goal configuration, scene frame.
    pub pose: Isometry3<f64>,
    /// Position tolerance, m.
    pub position_m: f64,
    /// Orientation tolerance, rad.
    pub angle_rad: f64,
}

impl GoalZone {
    /// True when `pose` (scene frame) is within the zone.
    #[inline]
    pub fn contains(&self, pose: &Isometry3<f64>) -> bool {
        (pose.translation.vector - self.pose.translation.vector).norm() <= self.position_m
            && pose.rotation.angle_to(&self.pose.rotation) <= self.angle_rad
    }
}

/// What shapes the tick; validated by the caller (see `config`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TickConfig {
    /// Device → scene mapping.
    pub mapping: MappingConfig,
    /// Guidance fade and bounds.
    pub guidance: GuidanceConfig,
    /// Output limits and fault handling.
    pub safety: SafetyConfig,
    /// Nominal tick period, s.
    pub period_s: f64,
}

impl Default for TickConfig {
    /// 1 kHz with the default mapping, guidance and safety.
    fn default() -> Self {
        Self {
            mapping: MappingConfig::default(),
            guidance: GuidanceConfig::default(),
            safety: SafetyConfig::default(),
            period_s: 0.001,
        }
    }
}

/// Timing facts of the previous tick, published in this tick's state.
#[derive(Debug, Default, Clone, Copy)]
pub struct PrevTiming {
    /// Wake-up latency, ns.
    pub wake_latency_ns: u64,
    /// Compute time, ns.
    pub compute_ns: u64,
    /// Period between the two previous wake-ups, ns.
    pub period_ns: u64,
    /// Deadline misses since start.
    pub deadline_misses: u64,
}

/// The loop's state between ticks.
#[derive(Debug)]
pub struct Tick<D, G, S> {
    device: D,
    spec: DeviceSpec,
    guidance_source: G,
    sink: S,
    mapping: Mapping,
    guidance: GuidanceFilter,
    safety: Safety,
    period_s: f64,
    sequence: u64,
    last_proxy: Option<Isometry3<f64>>,
    plausibility: Plausibility,
    state: HapticState,
    guidance_age_ns: u64,
    pid: u32,
    contact: Option<ContactStage>,
    contact_ticks: u64,
    max_penetration_m: f64,
    goal: Option<GoalZone>,
    first_ns: Option<u64>,
    at_goal_ns: Option<u64>,
    last_force_n: Option<Vector3<f64>>,
    max_force_step_n: f64,
    work: TickWork,
}

impl<D: HapticDevice, G: GuidanceSource, S: StateSink> Tick<D, G, S> {
    /// Opens the device and builds the tick's state.
    pub fn new(
        mut device: D,
        config: &TickConfig,
        guidance_source: G,
        sink: S,
    ) -> Result<Self, DeviceError> {
        device.open()?;
        let spec = device.spec().clone();
        let limits = spec.limits;
        Ok(Self {
            mapping: Mapping::new(&config.mapping),
            guidance: GuidanceFilter::new(
                config.guidance,
                limits.max_force_n,
                limits.max_torque_nm,
            ),
            safety: Safety::new(config.safety, limits.max_force_n, limits.max_torque_nm),
            spec,
            device,
            guidance_source,
            sink,
            period_s: config.period_s,
            sequence: 0,
            last_proxy: None,
            plausibility: Plausibility::new(&config.safety, config.period_s),
            state: HapticState::default(),
            guidance_age_ns: 0,
            pid: std::process::id(),
            contact: None,
            contact_ticks: 0,
            max_penetration_m: 0.0,
            goal: None,
            first_ns: None,
            at_goal_ns: None,
            last_force_n: None,
            max_force_step_n: 0.0,
            work: TickWork::default(),
        })
    }

    /// Watches for the object reaching `goal` (see [`Tick::time_to_goal_s`]).
    pub fn with_goal(mut self, goal: GoalZone) -> Self {
        self.goal = Some(goal);
        self
    }

    /// Seconds from the first tick to the first tick in the goal zone, if one was.
    pub fn time_to_goal_s(&self) -> Option<f64> {
        let (first, at) = (self.first_ns?, self.at_goal_ns?);
        Some(at.saturating_sub(first) as f64 * 1e-9)
    }

    /// Largest change of the commanded force between two consecutive fault-free ticks, N
    /// (device frame): what the hand feels as a step (a fault's drop to zero force is left
    /// out: it is the fail-safe, counted as a fault).
    pub fn max_force_step_n(&self) -> f64 {
        self.max_force_step_n
    }

    /// Turns contact rendering on with `stage` (built at init: voxmap, pointshell, coupling).
    pub fn with_contact(mut self, stage: ContactStage) -> Self {
        self.contact = Some(stage);
        self
    }

    /// The contact stage, when contact rendering is on.
    pub fn contact(&self) -> Option<&ContactStage> {
        self.contact.as_ref()
    }

    /// Ticks spent in contact (contact code CONTACT) since start.
    pub fn contact_ticks(&self) -> u64 {
        self.contact_ticks
    }

    /// Deepest penetration of the proxy into the scene since start, m.
    pub fn max_penetration_m(&self) -> f64 {
        self.max_penetration_m
    }

    /// The device's specification.
    pub fn spec(&self) -> &DeviceSpec {
        &self.spec
    }

    /// The device (e.g. to read a simulator's ground truth in tests).
    pub fn device(&self) -> &D {
        &self.device
    }

    /// Mutable device access (tests inject faults through it).
    pub fn device_mut(&mut self) -> &mut D {
        &mut self.device
    }

    /// The state published by the last [`Tick::step`].
    pub fn state(&self) -> &HapticState {
        &self.state
    }

    /// The most work of each kind one [`Tick::step`] does (see ARCHITECTURE.md, "The
    /// bounded tick"): once each for the stages that run once, the contact stage's caps at
    /// this period.
    pub fn caps(&self) -> WorkCaps {
        WorkCaps {
            contact: self
                .contact
                .as_ref()
                .map_or(WorkCaps::WITHOUT_CONTACT.contact, |c| c.caps(self.period_s)),
            ..WorkCaps::WITHOUT_CONTACT
        }
    }

    /// What the last [`Tick::step`] did, counted where it was done.
    pub fn last_work(&self) -> &TickWork {
        &self.work
    }

    /// Age of the guidance sample rendered in the last tick, ns (0 if none).
    pub fn guidance_age_ns(&self) -> u64 {
        self.guidance_age_ns
    }

    /// Guidance samples rejected as invalid so far.
    pub fn guidance_rejected(&self) -> u64 {
        self.guidance.rejected()
    }

    /// Faults latched since start.
    pub fn faults_total(&self) -> u64 {
        self.safety.faults_total()
    }

    /// Closes the device.
    pub fn close(&mut self) {
        self.device.close();
    }

    /// One tick at `now_ns` (CLOCK_MONOTONIC, start of the tick). Allocation-free.
    pub fn step(&mut self, now_ns: u64, prev: PrevTiming) -> &HapticState {
        self.sequence += 1;
        let mut work = TickWork::default();

        // 1. Device, checked for plausibility; while it fails, its last good state.
        let read = self.device.read(now_ns);
        work.device_reads += 1;
        let (reading, fault) = self.plausibility.check(read, prev.deadline_misses);
        let device = reading.unwrap_or_else(|| self.plausibility.last_good());
        let still = self.safety.config().is_still(&device);

        // 2. Map into the scene.
        let user = self.mapping.to_scene(&device.pose, device.buttons);

        // 3. Contact: the proxy is pulled towards the user's pose by the virtual coupling
        //    and held out of the obstacles; the device gets the negated coupling wrench.
        let contact = self.render_contact(&user, &device);
        if let Some(stage) = &self.contact {
            work.contact = stage.last_work();
        }
        let proxy = contact.as_ref().map_or(user, |c| c.proxy);
        let (device_force, device_torque) = contact
            .as_ref()
            .map_or((Vector3::zeros(), Vector3::zeros()), |c| {
                (c.device_force_n, c.device_torque_nm)
            });
        let displacement = self.last_proxy.map_or(Vector3::zeros(), |p| {
            proxy.translation.vector - p.translation.vector
        });
        self.last_proxy = Some(proxy);

        // 4. Guidance F_s = k·F_a, faded and bounded.
        let sample = self.guidance_source.latest();
        let g: RenderedGuidance = self.guidance.render(&sample, now_ns);
        work.guidance_renders += 1;
        self.guidance_age_ns = g.age_ns;

        // 5. Sum in the scene frame, rotate to the device frame, apply safety.
        let wanted = safety::wanted_wrench(
            self.safety.config(),
            &self.spec,
            &self.mapping,
            &device,
            &(device_force + g.force_n),
            &(device_torque + g.torque_nm),
        );
        let (out, fault) = self.safety.apply(&wanted, fault, still, self.period_s);

        // 6. Device.
        let fault = match (fault, self.device.write(&out)) {
            (FaultCode::NONE, Err(_)) => FaultCode::DEVICE_WRITE,
            (f, _) => f,
        };
        work.device_writes += 1;

        // 7. Count and publish.
        if let Some(c) = &contact {
            self.contact_ticks += u64::from(c.code == ContactCode::CONTACT);
            self.max_penetration_m = self.max_penetration_m.max(c.penetration_m);
        }
        self.first_ns.get_or_insert(now_ns);
        if self.at_goal_ns.is_none() && self.goal.is_some_and(|g| g.contains(&proxy)) {
            self.at_goal_ns = Some(now_ns);
        }
        // Between fault-free ticks only: a fault zeroes the force at once, by design.
        if fault == FaultCode::NONE {
            if let Some(last) = self.last_force_n {
                self.max_force_step_n = self.max_force_step_n.max((out.force - last).norm());
            }
            self.last_force_n = Some(out.force);
        } else {
            self.last_force_n = None;
        }
        let results = TickResults {
            sequence: self.sequence,
            now_ns,
            pid: self.pid,
            device: &device,
            user: &user,
            proxy: &proxy,
            commanded: &out,
            contact: contact.as_ref(),
            guidance: &g,
            fault,
            displacement,
            prev,
        };
        state_fill::fill(&mut self.state, &results);
        self.sink.publish(&self.state);
        work.publishes += 1;
        self.work = work;
        &self.state
    }

    /// The contact stage's step towards the user's pose `user` (scene frame), moving with
    /// the device's velocities; `None` when contact rendering is off.
    #[inline]
    fn render_contact(
        &mut self,
        user: &Isometry3<f64>,
        device: &DeviceState,
    ) -> Option<ContactOutput> {
        self.contact.as_mut().map(|stage| {
            let rot = self.mapping.rotation();
            let anchor = Anchor {
                pose: *user,
                linear_velocity: rot * device.linear_velocity * self.mapping.scale(),
                angular_velocity: rot * device.angular_velocity,
            };
            stage.step(&anchor, self.period_s)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use devices::sim::{
        ScriptedUser, ScriptedUserConfig, SimulatedArm, SimulatedArmConfig, Waypoint,
    };
    use ipc_types::{GuidanceFreshness, Header};

    fn arm() -> SimulatedArm {
        SimulatedArm::new(SimulatedArmConfig::default()).unwrap()
    }

    const MS: u64 = 1_000_000;

    /// A sample stamped at t = 0, fresh for 10 s, with F_a = `fa` (m) and k = 40 N/m.
    fn guidance(sequence: u64, fa: [f64; 3]) -> Guidance {
        Guidance::roadmap(
            Header::new(sequence, 0, 9),
            [fa[0], fa[1], fa[2], 0.0, 0.0, 0.0],
            40.0,
            0.0,
            10_000 * MS,
        )
    }

    /// The default configuration without the always-on damping and workspace wall, to see guidance alone.
    fn bare() -> TickConfig {
        TickConfig {
            safety: SafetyConfig {
                damping_fraction: 0.0,
                boundary_stiffness_fraction: 0.0,
                ..SafetyConfig::default()
            },
            ..TickConfig::default()
        }
    }

    #[test]
    fn guidance_reaches_the_device_after_the_ramp() {
        let g = guidance(4, [0.0, 0.05, 0.0]);
        let mut t = Tick::new(arm(), &bare(), g, NoSink).unwrap();
        for i in 1..=1000 {
            t.step(i * MS, PrevTiming::default());
        }
        let s = *t.state();
        assert_eq!(s.guidance_freshness, GuidanceFreshness::FRESH);
        assert_eq!(s.guidance_sequence, 4);
        assert!((s.guidance_wrench.force_n[1] - 2.0).abs() < 1e-12);
        // Identity mapping: commanded = guidance once ramped in.
        assert!((s.commanded_wrench.force_n[1] - 2.0).abs() < 1e-9);
        assert!((t.device().commanded_wrench().force.y - 2.0).abs() < 1e-9);
        assert_eq!(s.fault, FaultCode::NONE);
        assert_eq!(s.header.sequence, 1000);
    }

    #[test]
    fn forces_wait_for_a_still_device_at_start() {
        // The operator moves the arm 5 cm at 5 cm/s from the start, then holds it: no force
        // may be rendered while it moves, and forces come on only 0.1 s after it stops.
        let g = guidance(1, [0.05, 0.0, 0.0]);
        let user = ScriptedUser::new(
            ScriptedUserConfig::default(),
            [
                Waypoint::new(Isometry3::translation(-0.05, 0.0, 0.0)),
                Waypoint::new(Isometry3::translation(0.0, 0.0, 0.0)).with_dwell(5.0),
            ],
        )
        .unwrap();
        let mut arm = SimulatedArm::with_user(SimulatedArmConfig::default(), user).unwrap();
        arm.set_true_pose(Isometry3::translation(-0.05, 0.0, 0.0));
        let mut t = Tick::new(arm, &bare(), g, NoSink).unwrap();
        let mut first_force = None;
        let mut moving_ticks = 0;
        for i in 1..=3000u64 {
            let s = *t.step(i * MS, PrevTiming::default());
            if first_force.is_none() {
                if s.commanded_wrench == ipc_types::Wrench::ZERO {
                    assert_eq!(s.fault, FaultCode::STARTUP, "tick {i}");
                    let v = nalgebra::Vector3::from(s.device_twist.linear_m_s).norm();
                    moving_ticks += usize::from(v >= 0.02);
                } else {
                    first_force = Some(i);
                    assert_eq!(s.fault, FaultCode::NONE);
                }
            }
        }
        assert!(
            moving_ticks > 500,
            "the arm moved at start ({moving_ticks} ticks)"
        );
        assert!(first_force.is_some_and(|i| i > 1000), "{first_force:?}");
    }

    #[test]
    fn a_position_jump_is_a_fault_in_the_same_tick() {
        let g = guidance(1, [0.05, 0.0, 0.0]);
        let mut t = Tick::new(arm(), &bare(), g, NoSink).unwrap();
        for i in 1..=1000 {
            t.step(i * MS, PrevTiming::default());
        }
        assert!(t.state().commanded_wrench.force_n[0] > 1.0);
        let p = t.device().true_pose().translation.vector;
        t.device_mut()
            .set_true_pose(Isometry3::translation(p.x + 0.05, p.y, p.z));
        let s = *t.step(1001 * MS, PrevTiming::default());
        assert_eq!(s.fault, FaultCode::DEVICE_JUMP);
        assert_eq!(s.commanded_wrench, ipc_types::Wrench::ZERO);
    }

    #[test]
    fn a_streak_of_missed_deadlines_latches_zero_force() {
        let g = guidance(1, [0.05, 0.0, 0.0]);
        let mut t = Tick::new(arm(), &bare(), g, NoSink).unwrap();
        let mut misses = 0;
        for i in 1..=1000u64 {
            // Isolated misses (every 10th tick) are tolerated.
            if i % 10 == 5 {
                misses += 1;
            }
            let prev = PrevTiming {
                deadline_misses: misses,
                ..PrevTiming::default()
            };
            assert_ne!(t.step(i * MS, prev).fault, FaultCode::OVERRUN_STREAK);
        }
        for i in 1001..=1005u64 {
            misses += 1;
            let prev = PrevTiming {
                deadline_misses: misses,
                ..PrevTiming::default()
            };
            let s = *t.step(i * MS, prev);
            if i < 1005 {
                assert_eq!(s.fault, FaultCode::NONE, "tick {i}");
            } else {
                assert_eq!(s.fault, FaultCode::OVERRUN_STREAK);
                assert_eq!(s.commanded_wrench, ipc_types::Wrench::ZERO);
            }
        }
    }

    #[test]
    fn the_workspace_wall_pushes_back() {
        // The operator holds the arm 3 cm beyond its 0.12 m workspace sphere on +x: the
        // loop's soft wall pushes along −x.
        let user = ScriptedUser::holding(
            ScriptedUserConfig::default(),
            Isometry3::translation(0.15, 0.0, 0.0),
        )
        .unwrap();
        let mut arm = SimulatedArm::with_user(SimulatedArmConfig::default(), user).unwrap();
        arm.set_true_pose(Isometry3::translation(0.15, 0.0, 0.0));
        let mut t = Tick::new(arm, &TickConfig::default(), NoGuidance, NoSink).unwrap();
        for i in 1..=2000u64 {
            t.step(i * MS, PrevTiming::default());
        }
        let s = *t.state();
        // The simulated arm's own end stop holds it just outside the sphere; the loop's wall
        // adds k·(r − R) inwards with k = 0.5 × 2000 N/m.
        let outside = nalgebra::Vector3::from(s.device_pose.position_m).norm() - 0.12;
        assert!(outside > 0.0);
        let expected = -1000.0 * outside;
        let fx = s.commanded_wrench.force_n[0];
        assert!(
            fx < 0.0 && (fx - expected).abs() < 0.05,
            "{fx} N vs {expected} N"
        );
    }

    #[test]
    fn device_fault_zeroes_force_in_the_same_tick() {
        let g = guidance(1, [0.05, 0.0, 0.0]);
        let mut t = Tick::new(arm(), &TickConfig::default(), g, NoSink).unwrap();
        for i in 1..=1000 {
            t.step(i * MS, PrevTiming::default());
        }
        assert!(t.state().commanded_wrench.force_n[0] > 1.9);
        t.device_mut().inject_fault(Some(DeviceError::ReadFailed));
        let s = *t.step(1001 * MS, PrevTiming::default());
        assert_eq!(s.fault, FaultCode::DEVICE_READ);
        assert_eq!(s.commanded_wrench, ipc_types::Wrench::ZERO);
    }

    #[test]
    fn force_steps_and_the_goal_zone_are_measured() {
        // 2 N of guidance ramped in: steps stay within the ramp's; the fault's drop to zero
        // (the fail-safe) is not counted as a step.
        let g = guidance(1, [0.05, 0.0, 0.0]);
        let goal = GoalZone {
            pose: Isometry3::translation(0.0, 0.0, 0.0),
            position_m: 0.005,
            angle_rad: 0.1,
        };
        let mut t = Tick::new(arm(), &bare(), g, NoSink)
            .unwrap()
            .with_goal(goal);
        for i in 1..=1000 {
            t.step(i * MS, PrevTiming::default());
        }
        let ramped = t.max_force_step_n();
        assert!(ramped > 0.0 && ramped < 0.1, "{ramped} N");
        t.device_mut().inject_fault(Some(DeviceError::ReadFailed));
        t.step(1001 * MS, PrevTiming::default());
        assert_eq!(t.max_force_step_n(), ramped);
        // The arm starts at the origin: in the goal zone at the first tick.
        assert_eq!(t.time_to_goal_s(), Some(0.0));
        let far = GoalZone {
            pose: Isometry3::translation(0.5, 0.0, 0.0),
            ..goal
        };
        let mut t = Tick::new(arm(), &bare(), g, NoSink).unwrap().with_goal(far);
        for i in 1..=100 {
            t.step(i * MS, PrevTiming::default());
        }
        assert_eq!(t.time_to_goal_s(), None);
    }
}
