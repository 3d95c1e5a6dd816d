//! A deterministic simulated 6-DOF arm implementing [`HapticDevice`].

use nalgebra::{Isometry3, Vector3};

use super::body::{MassProperties, RigidBody};
use super::config::SimulatedArmConfig;
use super::operator::OperatorHand;
use super::sensor::quantize_pose;
use super::user::ScriptedUser;
use crate::{DeviceError, DeviceSpec, DeviceState, HapticDevice, Wrench};

/// A simulated desktop 6-DOF arm: a rigid end effector of the configured mass and inertia,
/// pushed by the last written (saturated) wrench, an optional hand (a [`ScriptedUser`]
/// replaying a timed path, or an [`OperatorHand`] that reacts to what it feels), viscous
/// damping and a spherical workspace wall.
///
/// # Time
/// `read(now_ns)` integrates from the previous `read`'s `now_ns` to this one: the first
/// read after `open` does not advance; a gap is clamped to `max_step_ns` (a stall cannot
/// blow up the simulation, simulated time then lags the clock) and split into equal
/// sub-steps of at most `max_substep_ns`; a `now_ns` that goes back advances nothing.
/// Forces are evaluated at the start of each sub-step and integrated by semi-implicit
/// Euler. The user's clock is the simulated time since the user was attached.
///
/// # Sensing
/// `read` reports the pose quantized to the configured resolutions; velocities are exact
/// (an ideal tachometer); the internal state stays exact ([`true_pose`](Self::true_pose)).
///
/// # Real-time
/// `read` and `write` do not allocate or block; everything is preallocated in
/// [`new`](Self::new) / [`with_user`](Self::with_user). Fully deterministic: the same
/// config, user, `now_ns` sequence and written wrenches give bit-identical states.
#[derive(Debug)]
pub struct SimulatedArm {
    config: SimulatedArmConfig,
    spec: DeviceSpec,
    mass: MassProperties,
    body: RigidBody,
    user: Option<Hand>,
    /// Simulated time at which the user was attached, ns.
    user_start_ns: u64,
    /// Last valid written wrench after saturation.
    command: Wrench,
    /// Last wrench applied by the user's hand.
    hand: Wrench,
    buttons: u32,
    fault: Option<DeviceError>,
    open: bool,
    last_now_ns: Option<u64>,
    sim_time_ns: u64,
}

/// Whose hand holds the arm.
#[derive(Debug, Clone)]
enum Hand {
    Scripted(Box<ScriptedUser>),
    Operator(Box<OperatorHand>),
}

impl SimulatedArm {
    /// An arm at rest at the base origin (identity orientation) with no user. Validates and
    /// allocates.
    pub fn new(config: SimulatedArmConfig) -> Result<Self, DeviceError> {
        config.validate()?;
        let [ix, iy, iz] = config.inertia_kg_m2;
        Ok(SimulatedArm {
            spec: config.spec(),
            mass: MassProperties {
                mass_kg: config.mass_kg,
                inertia_kg_m2: Vector3::new(ix, iy, iz),
            },
            config,
            body: RigidBody::at_rest(Isometry3::identity()),
            user: None,
            user_start_ns: 0,
            command: Wrench::ZERO,
            hand: Wrench::ZERO,
            buttons: 0,
            fault: None,
            open: false,
            last_now_ns: None,
            sim_time_ns: 0,
        })
    }

    /// An arm held by `user`, starting at rest at the user's first setpoint.
    pub fn with_user(config: SimulatedArmConfig, user: ScriptedUser) -> Result<Self, DeviceError> {
        let mut arm = SimulatedArm::new(config)?;
        arm.set_true_pose(user.setpoint(0.0));
        arm.attach_user(user);
        Ok(arm)
    }

    /// An arm held by a reacting operator's `hand`, starting at rest at its route's start.
    pub fn with_operator(
        config: SimulatedArmConfig,
        hand: OperatorHand,
    ) -> Result<Self, DeviceError> {
        let mut arm = SimulatedArm::new(config)?;
        arm.set_true_pose(hand.setpoint());
        arm.user = Some(Hand::Operator(Box::new(hand)));
        arm.user_start_ns = arm.sim_time_ns;
        Ok(arm)
    }

    /// Attaches `user` (replacing any other hand); its clock starts at the current
    /// simulated time. The arm does not move.
    pub fn attach_user(&mut self, user: ScriptedUser) {
        self.user = Some(Hand::Scripted(Box::new(user)));
        self.user_start_ns = self.sim_time_ns;
    }

    /// The attached scripted user, if any.
    pub fn user(&self) -> Option<&ScriptedUser> {
        match &self.user {
            Some(Hand::Scripted(u)) => Some(u),
            _ => None,
        }
    }

    /// The attached reacting operator's hand, if any.
    pub fn operator_hand(&self) -> Option<&OperatorHand> {
        match &self.user {
            Some(Hand::Operator(h)) => Some(h),
            _ => None,
        }
    }

    /// Seconds on the attached user's clock (simulated time since it was attached).
    pub fn user_time_s(&self) -> f64 {
        self.sim_time_ns.saturating_sub(self.user_start_ns) as f64 * 1e-9
    }

    /// Teleports the end effector to `pose` (m, base frame) at rest. For test set-up.
    pub fn set_true_pose(&mut self, pose: Isometry3<f64>) {
        self.body = RigidBody::at_rest(pose);
    }

    /// Sets the button mask `read` reports (bits beyond the button count are dropped).
    pub fn set_buttons(&mut self, buttons: u32) {
        let count = self.spec.capabilities.buttons;
        self.buttons = if count >= 32 {
            buttons
        } else {
            buttons & ((1u32 << count) - 1)
        };
    }

    /// Makes every `read` and `write` fail with `fault` until cleared with `None`
    /// (simulates a disconnect or a bad link). A write that fails is not applied.
    pub fn inject_fault(&mut self, fault: Option<DeviceError>) {
        self.fault = fault;
    }

    /// The configuration.
    pub fn config(&self) -> &SimulatedArmConfig {
        &self.config
    }

    /// Exact (unquantized) end-effector pose, m, base frame.
    pub fn true_pose(&self) -> Isometry3<f64> {
        self.body.pose
    }

    /// Exact linear velocity (m/s) and angular velocity (rad/s), base frame.
    pub fn true_twist(&self) -> (Vector3<f64>, Vector3<f64>) {
        (self.body.linear_velocity, self.body.angular_velocity)
    }

    /// The user's hand wrench at the last sub-step (N, N·m at the end-effector point, base
    /// frame): ground truth for the operator force `f_u`. Zero without a user.
    pub fn hand_wrench(&self) -> Wrench {
        self.hand
    }

    /// The device wrench being applied: the last valid write, saturated to the spec.
    pub fn commanded_wrench(&self) -> Wrench {
        self.command
    }

    /// Simulated time integrated so far, s.
    pub fn sim_time_s(&self) -> f64 {
        self.sim_time_ns as f64 * 1e-9
    }

    /// Force (N, base frame) of the workspace wall: a one-sided spring-damper on the
    /// penetration beyond the sphere of radius `workspace_radius_m`; it pushes, never pulls.
    fn wall_force(&self) -> Vector3<f64> {
        let p = self.body.pose.translation.vector;
        let r = p.norm();
        let depth = r - self.config.workspace_radius_m;
        if depth <= 0.0 || r <= 0.0 {
            return Vector3::zeros();
        }
        let normal = p / r;
        let outward_speed = self.body.linear_velocity.dot(&normal);
        let push = self.config.wall_stiffness_n_per_m * depth
            + self.config.wall_damping_n_s_per_m * outward_speed;
        -normal * push.max(0.0)
    }

    /// Integrates `dt_ns` of simulated time in equal sub-steps.
    fn advance(&mut self, dt_ns: u64) {
        let dt_ns = dt_ns.min(self.config.max_step_ns);
        let steps = dt_ns.div_ceil(self.config.max_substep_ns);
        for i in 0..steps {
            // Integer split so sub-steps sum to dt_ns exactly.
            let sub_ns = dt_ns * (i + 1) / steps - dt_ns * i / steps;
            self.substep(sub_ns as f64 * 1e-9);
            self.sim_time_ns += sub_ns;
        }
    }

    fn substep(&mut self, h: f64) {
        let t_user = self.user_time_s();
        let body = self.body;
        self.hand = match self.user.as_mut() {
            Some(Hand::Scripted(user)) => user.hand_wrench(
                t_user,
                &body.pose,
                &body.linear_velocity,
                &body.angular_velocity,
            ),
            // The hand feels what the device pushes the end effector with.
            Some(Hand::Operator(hand)) => hand.hand_wrench(
                t_user,
                &body.pose,
                &body.linear_velocity,
                &body.angular_velocity,
                &self.command,
            ),
            None => Wrench::ZERO,
        };
        let damping = Wrench::new(
            -body.linear_velocity * self.config.linear_damping_n_s_per_m,
            -body.angular_velocity * self.config.angular_damping_nm_s_per_rad,
        );
        let wall = Wrench::from_force(self.wall_force());
        let total = self.command + self.hand + damping + wall;
        self.body.step(&self.mass, &total, h);
    }

    fn check_usable(&self) -> Result<(), DeviceError> {
        match (self.fault, self.open) {
            (Some(fault), _) => Err(fault),
            (None, false) => Err(DeviceError::NotOpen),
            (None, true) => Ok(()),
        }
    }
}

impl HapticDevice for SimulatedArm {
    /// Opens the simulated link: the command is zeroed and the next `read` starts a new
    /// time base (it does not advance). Never fails.
    fn open(&mut self) -> Result<(), DeviceError> {
        self.open = true;
        self.command = Wrench::ZERO;
        self.last_now_ns = None;
        Ok(())
    }

    fn spec(&self) -> &DeviceSpec {
        &self.spec
    }

    fn read(&mut self, now_ns: u64) -> Result<DeviceState, DeviceError> {
        self.check_usable()?;
        if let Some(previous) = self.last_now_ns {
            self.advance(now_ns.saturating_sub(previous));
        }
        self.last_now_ns = Some(self.last_now_ns.map_or(now_ns, |p| p.max(now_ns)));
        Ok(DeviceState {
            pose: quantize_pose(
                &self.body.pose,
                self.config.position_resolution_m,
                self.config.angle_resolution_rad,
            ),
            linear_velocity: self.body.linear_velocity,
            angular_velocity: self.body.angular_velocity,
            buttons: self.buttons,
            timestamp_ns: now_ns,
        })
    }

    fn write(&mut self, wrench: &Wrench) -> Result<(), DeviceError> {
        self.check_usable()?;
        if !wrench.is_finite() {
            return Err(DeviceError::InvalidData);
        }
        self.command = self.spec.saturate(wrench);
        Ok(())
    }

    fn close(&mut self) {
        self.open = false;
        self.command = Wrench::ZERO;
        self.last_now_ns = None;
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Translation3, UnitQuaternion};

    use super::*;

    const MS: u64 = 1_000_000;

    fn open_arm() -> SimulatedArm {
        let mut arm = SimulatedArm::new(SimulatedArmConfig::default()).expect("valid config");
        arm.open().expect("open");
        arm
    }

    /// Reads at `start_ns + k·1 ms` for k in 1..=n, writing `wrench` after each read.
    fn run(arm: &mut SimulatedArm, start_ns: u64, n: u64, wrench: &Wrench) -> DeviceState {
        let mut state = arm.read(start_ns).expect("read");
        for k in 1..=n {
            arm.write(wrench).expect("write");
            state = arm.read(start_ns + k * MS).expect("read");
        }
        state
    }

    fn is_multiple(value: f64, resolution: f64) -> bool {
        let ratio = value / resolution;
        (ratio - ratio.round()).abs() < 1e-6
    }

    #[test]
    fn free_arm_stays_put() {
        let mut arm = open_arm();
        let start = Isometry3::from_parts(
            Translation3::new(0.02, -0.01, 0.03),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.3, 0.0)),
        );
        arm.set_true_pose(start);
        let state = run(&mut arm, 5 * MS, 1000, &Wrench::ZERO);
        assert_eq!(arm.true_pose().translation, start.translation);
        assert!(arm.true_pose().rotation.angle_to(&start.rotation) < 1e-12);
        assert_eq!(state.linear_velocity, Vector3::zeros());
        assert!((state.pose.translation.vector - start.translation.vector).amax() <= 5e-6);
        assert!((arm.sim_time_s() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn constant_force_accelerates_as_f_over_m() {
        let mut arm = open_arm();
        let w = Wrench::from_force(Vector3::new(0.0, 2.0, 0.0));
        run(&mut arm, 0, 10, &w);
        let (v, _) = arm.true_twist();
        let a = v.y / 0.010;
        assert!((a - 2.0 / 0.2).abs() < 0.02 * 10.0, "a = {a}");
        assert!(v.x.abs() < 1e-15 && v.z.abs() < 1e-15);
    }

    #[test]
    fn saturation_clamps_force_and_torque_to_spec() {
        let mut arm = open_arm();
        let w = Wrench::new(Vector3::new(100.0, 0.0, 0.0), Vector3::new(0.0, 0.0, 10.0));
        run(&mut arm, 0, 10, &w);
        assert!((arm.commanded_wrench().force.norm() - 8.0).abs() < 1e-12);
        assert!((arm.commanded_wrench().torque.norm() - 0.5).abs() < 1e-12);
        let (v, _) = arm.true_twist();
        let a = v.x / 0.010;
        assert!((a - 8.0 / 0.2).abs() < 0.02 * 40.0, "a = {a}");
        // One 1 ms step from rest: ω = τ/I·h = 0.5/1e-4·1e-3 = 5 rad/s.
        let mut arm = open_arm();
        run(&mut arm, 0, 1, &w);
        assert!((arm.true_twist().1.z - 5.0).abs() < 1e-9);
    }

    #[test]
    fn workspace_wall_holds_the_arm_near_the_radius() {
        let mut arm = open_arm();
        let radius = arm.spec().limits.workspace_radius_m;
        let push = Wrench::from_force(Vector3::new(8.0, 0.0, 0.0));
        let mut max_r: f64 = 0.0;
        arm.read(0).expect("read");
        for k in 1..=3000 {
            arm.write(&push).expect("write");
            arm.read(k * MS).expect("read");
            max_r = max_r.max(arm.true_pose().translation.vector.norm());
        }
        let r = arm.true_pose().translation.vector.norm();
        // Pressed against the wall: 8 N / 3e4 N/m ≈ 0.27 mm deep.
        assert!((r - radius - 8.0 / 3e4).abs() < 0.05e-3, "r = {r}");
        // Slammed from the centre (≈ 3 m/s at the wall), it overshoots by a few mm at most.
        assert!(max_r < radius + 5e-3, "max r = {max_r}");
    }

    #[test]
    fn reported_pose_is_quantized_and_true_pose_is_not() {
        let mut arm = open_arm();
        let (pos_res, ang_res) = (1e-5, 1e-3);
        let w = Wrench::new(
            Vector3::new(0.3, -0.2, 0.1),
            Vector3::new(0.001, 0.002, -0.003),
        );
        arm.read(0).expect("read");
        let mut saw_inexact = false;
        for k in 1..=300 {
            arm.write(&w).expect("write");
            let s = arm.read(k * MS).expect("read");
            for c in s.pose.translation.vector.iter() {
                assert!(is_multiple(*c, pos_res), "{c}");
            }
            for c in s.pose.rotation.scaled_axis().iter() {
                assert!(is_multiple(*c, ang_res), "{c}");
            }
            let truth = arm.true_pose();
            let err = (s.pose.translation.vector - truth.translation.vector).amax();
            assert!(err <= pos_res / 2.0 + 1e-15);
            saw_inexact |= err > 0.0;
        }
        assert!(saw_inexact);
    }

    #[test]
    fn time_base_first_read_substeps_stall_and_backwards() {
        let w = Wrench::from_force(Vector3::new(1.0, 0.0, 0.0));
        // First read does not advance.
        let mut arm = open_arm();
        arm.read(123 * MS).expect("read");
        assert_eq!(arm.sim_time_s(), 0.0);
        // One 5 ms gap is five 1 ms sub-steps: bit-identical to five 1 ms ticks.
        let mut coarse = open_arm();
        coarse.read(0).expect("read");
        coarse.write(&w).expect("write");
        coarse.read(5 * MS).expect("read");
        let mut fine = open_arm();
        run(&mut fine, 0, 5, &w);
        assert_eq!(coarse.true_pose(), fine.true_pose());
        assert_eq!(coarse.true_twist(), fine.true_twist());
        // A 1 s stall advances only max_step_ns = 10 ms.
        let mut arm = open_arm();
        arm.read(0).expect("read");
        arm.read(1_000 * MS).expect("read");
        assert!((arm.sim_time_s() - 0.010).abs() < 1e-12);
        // Time going back advances nothing, nor does the return to the latest time.
        arm.read(500 * MS).expect("read");
        arm.read(1_000 * MS).expect("read");
        assert!((arm.sim_time_s() - 0.010).abs() < 1e-12);
    }

    #[test]
    fn non_finite_write_is_rejected_and_ignored() {
        let mut arm = open_arm();
        let good = Wrench::from_force(Vector3::new(0.0, 0.0, 1.0));
        arm.write(&good).expect("write");
        let mut bad = good;
        bad.torque.x = f64::NAN;
        assert_eq!(arm.write(&bad), Err(DeviceError::InvalidData));
        assert_eq!(arm.commanded_wrench(), good);
        let fresh = open_arm();
        let mut fresh = fresh;
        assert_eq!(
            fresh.write(&Wrench::from_force(Vector3::new(f64::INFINITY, 0.0, 0.0))),
            Err(DeviceError::InvalidData)
        );
        assert_eq!(fresh.commanded_wrench(), Wrench::ZERO);
        run(&mut fresh, 0, 10, &Wrench::ZERO);
        assert_eq!(fresh.true_twist().0, Vector3::zeros());
    }

    #[test]
    fn lifecycle_faults_and_buttons() {
        let mut arm = SimulatedArm::new(SimulatedArmConfig::default()).expect("valid");
        assert_eq!(arm.read(0), Err(DeviceError::NotOpen));
        assert_eq!(arm.write(&Wrench::ZERO), Err(DeviceError::NotOpen));
        arm.open().expect("open");
        arm.set_buttons(0b111);
        assert_eq!(arm.read(0).expect("read").buttons, 0b11);
        arm.write(&Wrench::from_force(Vector3::x())).expect("write");
        arm.inject_fault(Some(DeviceError::Disconnected));
        assert_eq!(arm.read(MS), Err(DeviceError::Disconnected));
        assert_eq!(arm.write(&Wrench::ZERO), Err(DeviceError::Disconnected));
        arm.inject_fault(None);
        assert!(arm.read(2 * MS).is_ok());
        arm.close();
        assert_eq!(arm.commanded_wrench(), Wrench::ZERO);
        assert_eq!(arm.read(3 * MS), Err(DeviceError::NotOpen));
        assert!(
            SimulatedArm::new(SimulatedArmConfig {
                mass_kg: -1.0,
                ..Default::default()
            })
            .is_err()
        );
    }
}
