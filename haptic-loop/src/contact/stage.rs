//! [`ContactStage`]: the dynamic proxy object and its coupling, one step per tick (see the
//! module docs of `contact` for the force model).

use super::coherence::Coherence;
use super::coherence::LevelCache;
use super::level::{self, LevelChooser, Levels, Plan, SLAM, WARM_CHECKS};
use super::near::{Found, NearPass, PassParams, SearchParams, Totals};
use super::{
    Anchor, ContactConfig, ContactError, ContactModel, ContactOutput, Coupling, LEVELS, Probe,
    Resolution, Sample,
};
use crate::work::{Allowance, ContactWork};
use devices::DeviceSpec;
use ipc_types::ContactCode;
use nalgebra::{
    Isometry3, Matrix3, Matrix6, Point3, Translation3, UnitQuaternion, Vector3, Vector6,
};
use parry3d_f64::math::Pose;
use parry3d_f64::shape::SharedShape;
use std::sync::Arc;

/// `[a; b]` as one 6-vector (velocity and angular velocity, or force and torque).
fn stack(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector6<f64> {
    Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z)
}

/// The dynamic proxy with its coupling. `step` is allocation-free.
#[derive(Debug, Clone)]
pub struct ContactStage {
    model: Arc<ContactModel>,
    config: ContactConfig,
    coupling: Coupling,
    /// Proxy reference-point pose.
    pose: Isometry3<f64>,
    /// Velocity of the centre of mass, m/s.
    velocity: Vector3<f64>,
    /// Angular velocity, rad/s.
    angular_velocity: Vector3<f64>,
    in_contact: bool,
    held_normal: Vector3<f64>,
    held_point: Vector3<f64>,
    started: bool,
    /// Penetrating and braking points of the previous step (see `shared_damping`).
    previous_contacts: u32,
    previous_braking: u32,
    last_tested: u32,
    /// Level of detail in use, and a change of level being blended.
    levels: LevelChooser,
    /// The coarsest level the resolution allows at the model's spacing.
    coarsest_level: usize,
    /// Changes of the rendered level so far.
    level_changes: u64,
    cache: Coherence,
    /// What the last step did.
    work: ContactWork,
    /// Steps whose caps left work on a rendered level for later steps.
    deferred_steps: u64,
}

impl ContactStage {
    /// A proxy for `model`; it is placed at the first anchor it sees.
    pub fn new(model: Arc<ContactModel>, config: ContactConfig, coupling: Coupling) -> Self {
        Self {
            cache: Coherence::new(&model.shells),
            levels: LevelChooser::starting(&config.resolution),
            coarsest_level: config
                .resolution
                .coarsest_level(model.shells[0].spacing_m()),
            level_changes: 0,
            model,
            config,
            coupling,
            pose: Isometry3::identity(),
            velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
            in_contact: false,
            held_normal: Vector3::zeros(),
            held_point: Vector3::zeros(),
            started: false,
            previous_contacts: 0,
            previous_braking: 0,
            last_tested: 0,
            work: ContactWork::default(),
            deferred_steps: 0,
        }
    }

    /// Builds model and stage in one go: obstacles (scene frame) and object parts (object
    /// frame) at `config`'s voxel size, coupling gains from `spec` at `position_scale`.
    pub fn from_shapes(
        obstacles: &[(Pose, SharedShape)],
        object: &[(Pose, SharedShape)],
        config: ContactConfig,
        spec: &DeviceSpec,
        position_scale: f64,
    ) -> Result<Self, ContactError> {
        let model = ContactModel::build(obstacles, object, &config.voxmap)?;
        let coupling = Coupling::from_spec(spec, position_scale, config.coupling_fraction);
        Ok(Self::new(Arc::new(model), config, coupling))
    }

    /// The coupling gains in use.
    pub fn coupling(&self) -> &Coupling {
        &self.coupling
    }

    /// Pointshell points tested against the voxmap in the last step (after culling),
    /// those looked up to bring a level up to date for a blend included.
    pub fn last_points_tested(&self) -> u32 {
        self.last_tested
    }

    /// What the last step did, counted where it was done.
    pub fn last_work(&self) -> ContactWork {
        self.work
    }

    /// Steps so far whose caps left work on a rendered level for later steps (a due
    /// cluster unchecked, a near cluster unscanned, a due point not looked up): in them the
    /// proxy travelled at most what keeps every point of that work out of the surface
    /// (see `bound_travel`).
    pub fn deferred_steps(&self) -> u64 {
        self.deferred_steps
    }

    /// The most work of each kind one step of `dt_s` seconds does (see
    /// ARCHITECTURE.md, "The bounded tick"): from the point budget at that period; none
    /// with a fixed level of detail ([`Resolution::Level`] renders every point near the
    /// surface, whatever it costs).
    pub fn caps(&self, dt_s: f64) -> ContactWork {
        match self.budget(dt_s) {
            None => ContactWork {
                checks: u32::MAX,
                compares: u32::MAX,
                look_ups: u32::MAX,
                searches: 2,
                near_passes: 2 * LEVELS as u32,
                solves: 1,
            },
            Some(budget) => level::caps(budget, self.model.shells[LEVELS - 1].len() as u32),
        }
    }

    /// Points a step of `dt_s` seconds may render: the point budget times the period;
    /// `None` with a fixed level of detail.
    fn budget(&self, dt_s: f64) -> Option<f64> {
        match self.config.resolution {
            Resolution::Level(_) => None,
            Resolution::Budget { points_per_ms, .. } => Some(points_per_ms * dt_s * 1e3),
        }
    }

    /// The coarsest level whose points all fit what a level in use may hold (`SLAM`
    /// times `budget`), from the spacing's `coarsest` on, else the coarsest of all (whose
    /// points the look-up cap holds: `level::caps`): where a budget goes when even the
    /// spacing's coarsest holds more near points.
    fn last_resort(&self, coarsest: usize, budget: f64) -> usize {
        (coarsest..LEVELS)
            .find(|&l| self.model.shells[l].len() as f64 <= SLAM * budget)
            .unwrap_or(LEVELS - 1)
    }

    /// Renders at `resolution` from the next step on (a fixed level starts at once, a
    /// budget from level 0). Fails, changing nothing, on an invalid resolution.
    pub fn set_resolution(&mut self, resolution: Resolution) -> Result<(), ContactError> {
        resolution.validate().map_err(ContactError::Resolution)?;
        self.config.resolution = resolution;
        self.levels = LevelChooser::starting(&resolution);
        self.coarsest_level = resolution.coarsest_level(self.model.shells[0].spacing_m());
        Ok(())
    }

    /// Level of detail rendered in the last step (the new one while a change is blended).
    pub fn level(&self) -> usize {
        self.levels.level()
    }

    /// Whether a change of level is being blended.
    pub fn blending(&self) -> bool {
        self.levels.blending()
    }

    /// How many times the rendered level has changed since the stage was made.
    pub fn level_changes(&self) -> u64 {
        self.level_changes
    }

    /// The model.
    pub fn model(&self) -> &ContactModel {
        &self.model
    }

    /// Proxy pose (reference point), scene frame.
    pub fn pose(&self) -> &Isometry3<f64> {
        &self.pose
    }

    /// Puts the proxy at `pose` at rest (start-up, tests).
    pub fn place(&mut self, pose: Isometry3<f64>) {
        self.pose = pose;
        self.velocity = Vector3::zeros();
        self.angular_velocity = Vector3::zeros();
        self.in_contact = false;
        self.started = true;
        self.cache.reset();
    }

    fn mass_matrix(&self) -> Matrix6<f64> {
        let m = self.config.proxy_mass_kg;
        let r = self.pose.rotation.to_rotation_matrix();
        let inertia = r.matrix() * self.model.inertia_per_kg * r.matrix().transpose() * m;
        let mut mm = Matrix6::zeros();
        mm.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::identity() * m));
        mm.fixed_view_mut::<3, 3>(3, 3).copy_from(&inertia);
        mm
    }

    /// Total energy of proxy and coupling towards a fixed `anchor` plus the contact springs
    /// of the level in use (each point's spring times its weight), J: ½uᵀMu + ½k|Δx|² +
    /// ½k_r|Δθ|² + Σ½w·k_p d². For the passivity test.
    pub fn energy(&self, anchor: &Isometry3<f64>) -> f64 {
        let u = stack(&self.velocity, &self.angular_velocity);
        let kinetic = 0.5 * u.dot(&(self.mass_matrix() * u));
        let c = &self.coupling;
        let dx = anchor.transform_point(&Point3::from(self.model.com_local)) - self.com();
        let dtheta = (anchor.rotation * self.pose.rotation.inverse()).scaled_axis();
        let coupling =
            0.5 * c.k_n_per_m * dx.norm_squared() + 0.5 * c.k_nm_per_rad * dtheta.norm_squared();
        let shell = &self.model.shells[self.levels.level()];
        let contact: f64 = shell
            .points()
            .iter()
            .zip(shell.weights())
            .map(|(p, w)| {
                match self
                    .model
                    .voxmap
                    .sample(&self.pose.transform_point(&Point3::from(*p)).coords)
                {
                    Sample::Near { distance_m, .. } if distance_m < 0.0 => {
                        0.5 * w * self.config.point_stiffness_n_per_m * distance_m * distance_m
                    }
                    _ => 0.0,
                }
            })
            .sum();
        kinetic + coupling + contact
    }

    /// The scene's wrench on the object held still at `pose` (reference point, scene frame)
    /// at the level of detail in use: force (N), torque about the reference point (N·m),
    /// deepest penetration (m) and the number of penetrating points. Does not move the
    /// proxy.
    pub fn probe(&self, pose: &Isometry3<f64>) -> Probe {
        // A fresh cache: a full search. (Allocates: a diagnostic, not for the RT thread.)
        let mut cache = Coherence::new(&self.model.shells);
        let level = self.levels.level();
        let s = self
            .sum_contacts(
                pose,
                &Vector3::zeros(),
                &Vector3::zeros(),
                &mut cache,
                |_| Plan::at(level),
                &mut Allowance::uncapped(),
                &mut ContactWork::default(),
            )
            .totals;
        let force: Vector3<f64> = s.wrench.fixed_rows::<3>(0).into_owned();
        let com = pose
            .transform_point(&Point3::from(self.model.com_local))
            .coords;
        let lever = com - pose.translation.vector;
        Probe {
            force_n: force,
            torque_nm: s.wrench.fixed_rows::<3>(3).into_owned() + lever.cross(&force),
            penetration_m: s.max_depth,
            contacts: s.contacts,
            point_m: if s.weight > 0.0 {
                s.weighted_point / s.weight
            } else {
                Vector3::zeros()
            },
        }
    }

    fn com(&self) -> Point3<f64> {
        self.pose
            .transform_point(&Point3::from(self.model.com_local))
    }

    /// How close to a surface a point counts as near (m): the proximity layer, or the
    /// release distance when that is wider.
    fn reach_m(&self) -> f64 {
        self.config.proximity_voxels.max(self.config.release_voxels) * self.model.voxmap.voxel_m()
    }

    /// Per-point contact damping and braking (N·s/m): the configured totals shared among
    /// the points that produced them in the previous step (one tick of lag, no second pass).
    fn shared_damping(&self) -> (f64, f64) {
        (
            self.config.contact_damping_n_s_per_m / f64::from(self.previous_contacts.max(1)),
            self.config.braking_n_s_per_m / f64::from(self.previous_braking.max(1)),
        )
    }

    /// The scene's wrench on the object at `pose` moving with `velocity` (centre of mass,
    /// m/s) and `angular_velocity` (rad/s), at the levels `plan` chooses, given the near
    /// clusters' point count at any level it asks for. Groups, clusters and points whose
    /// motion budget in `cache` is not used up are skipped (see [`Coherence`]) and the
    /// budgets are renewed.
    ///
    /// This is the hot loop of the tick: after the object-level check it runs in
    /// [`ShellColumns::near_clusters`] and [`ShellColumns::search`] (see the `near`
    /// module).
    #[allow(clippy::too_many_arguments)]
    fn sum_contacts(
        &self,
        pose: &Isometry3<f64>,
        velocity: &Vector3<f64>,
        angular_velocity: &Vector3<f64>,
        cache: &mut Coherence,
        plan: impl FnOnce(&mut dyn Levels) -> Plan,
        allow: &mut Allowance,
        work: &mut ContactWork,
    ) -> Found {
        let model = &*self.model;
        let vox = &model.voxmap;
        let h = vox.voxel_m();
        let prox = self.config.proximity_voxels * h;
        let release = self.config.release_voxels * h;
        let reach = self.reach_m();
        let moved = cache.motion_m;
        let com = pose.transform_point(&Point3::from(model.com_local)).coords;
        // Nothing within reach: the plan sees no near points (and returns to level 0).
        if moved < cache.object {
            plan(&mut |_| 0);
            return Found::default();
        }
        work.checks += 1;
        allow.checks = allow.checks.saturating_sub(1);
        cache.object = moved + vox.clearance(&com) - model.radius_m - reach;
        if moved < cache.object {
            plan(&mut |_| 0);
            return Found::default();
        }
        let (b_contact, b_brake) = self.shared_damping();
        let k = SearchParams {
            rotation: pose.rotation.to_rotation_matrix().into_inner(),
            translation: pose.translation.vector,
            reach_m: reach,
            moved_m: moved,
        };
        let pass = PassParams {
            com,
            velocity: *velocity,
            angular_velocity: *angular_velocity,
            point_stiffness_n_per_m: self.config.point_stiffness_n_per_m,
            contact_damping_n_s_per_m: b_contact,
            braking_n_s_per_m: b_brake,
            proximity_m: prox,
            release_m: release,
        };
        let mut levels = StageLevels {
            model,
            cache: &mut cache.levels,
            passes: [None; LEVELS],
            runs: [0; LEVELS],
            renewed: 0,
            k: &k,
            pass: &pass,
            allow,
            work,
        };
        let plan = plan(&mut levels);
        levels.near(plan.from);
        levels.near(plan.to);
        // What the near passes of the rendered levels left unchecked.
        let overdue = |p: &Option<NearPass>| p.map_or(0.0, |p| p.overdue_m);
        let left = overdue(&levels.passes[plan.from]).max(overdue(&levels.passes[plan.to]));
        let renewed = levels.renewed;
        let (levels, allow, work) = (levels.cache, levels.allow, levels.work);
        let mut search = |l: usize| {
            let c = &mut levels[l];
            model.columns[l].search(&mut c.points, &k, &pass, vox, &mut c.scratch, allow, work)
        };
        let mut from = search(plan.from);
        from.tested += renewed;
        from.overdue_m = from.overdue_m.max(left);
        if plan.to == plan.from {
            return from;
        }
        let to = search(plan.to);
        Found {
            totals: from.totals.lerp(&to.totals, plan.alpha),
            tested: from.tested + to.tested,
            near: from.near.max(to.near),
            overdue_m: from.overdue_m.max(to.overdue_m),
        }
    }
    /// One step of `dt_s` towards `anchor`. Allocation-free.
    pub fn step(&mut self, anchor: &Anchor, dt_s: f64) -> ContactOutput {
        if !self.started {
            self.place(anchor.pose);
        }
        let before = self.pose;
        // 1. The scene's wrench on the points near a surface (the hot loop).
        let found = self.search(dt_s);
        // 2. The coupling's spring-damper towards the anchor.
        let pull = self.pull(anchor);
        // 3. Linearly implicit Euler with the contact and coupling stiffness.
        let u_next = self.implicit_velocity(&found.totals, &pull, dt_s);
        // 4. No point travels further than the travel bound.
        let u_next = self.bound_travel(u_next, &found, dt_s);
        // 5. The proxy moves.
        self.integrate(u_next, &pull.com, dt_s);
        // 6. Contact state, with hysteresis.
        let code = self.contact_state(&found);
        // 7. The wrenches on the proxy and the device.
        self.output(&before, &found, &pull, code)
    }

    /// Step 1: [`Self::sum_contacts`] at the levels the chooser plans from the motion since
    /// the last step; keeps the counts the next step's shared damping needs.
    fn search(&mut self, dt_s: f64) -> Found {
        let mut cache = std::mem::take(&mut self.cache);
        cache.advance(&self.pose, &self.model.com_local, self.model.radius_m);
        let mut levels = self.levels;
        let coarsest = self.coarsest_level;
        let mut work = ContactWork::default();
        let caps = self.caps(dt_s);
        let mut allow = Allowance::of(&caps);
        let budget = self.budget(dt_s);
        let last_resort = budget.map_or(coarsest, |b| self.last_resort(coarsest, b));
        let found = self.sum_contacts(
            &self.pose,
            &self.velocity,
            &self.angular_velocity,
            &mut cache,
            |near| match budget {
                None => Plan::at(levels.level()),
                Some(budget) => levels.plan(
                    near,
                    budget,
                    coarsest,
                    last_resort,
                    (Resolution::BLEND_S / dt_s).round().max(1.0) as u32,
                ),
            },
            &mut allow,
            &mut work,
        );
        self.work = work;
        self.deferred_steps += u64::from(found.overdue_m > 0.0);
        self.level_changes += u64::from(levels.level() != self.levels.level());
        self.levels = levels;
        self.cache = cache;
        self.previous_contacts = found.totals.contacts;
        self.last_tested = found.tested;
        self.previous_braking = found.totals.braking_points;
        found
    }

    /// Step 2: the coupling between the centres of mass of the anchor and the proxy.
    fn pull(&self, anchor: &Anchor) -> Pull {
        let c = self.coupling;
        let com = self.com().coords;
        let anchor_com = anchor
            .pose
            .transform_point(&Point3::from(self.model.com_local))
            .coords;
        let anchor_v = anchor.linear_velocity
            + anchor
                .angular_velocity
                .cross(&(anchor_com - anchor.pose.translation.vector));
        let dtheta = (anchor.pose.rotation * self.pose.rotation.inverse()).scaled_axis();
        let f_spring = c.k_n_per_m * (anchor_com - com);
        Pull {
            force_n: f_spring + c.b_n_s_per_m * (anchor_v - self.velocity),
            torque_nm: c.k_nm_per_rad * dtheta
                + c.b_nm_s_per_rad * (anchor.angular_velocity - self.angular_velocity),
            com,
            anchor_lever_m: anchor_com - anchor.pose.translation.vector,
        }
    }

    /// Step 3: linearly implicit Euler, `(M + dt·D + dt²·K) u' = (M + dt·D) u + dt·F`, where
    /// F already holds the damping forces at u; zero velocities when the solve fails
    /// (only with non-finite input: stop rather than explode).
    fn implicit_velocity(&mut self, s: &Totals, pull: &Pull, dt_s: f64) -> Vector6<f64> {
        let c = self.coupling;
        let mut force = s.wrench;
        force += stack(&pull.force_n, &pull.torque_nm);
        let mut damping = s.damping_jj.matrix(1.0);
        let mut stiffness = s.contact_jj.matrix(self.config.point_stiffness_n_per_m);
        let mut coupling_damping = Matrix6::zeros();
        for a in 0..3 {
            stiffness[(a, a)] += c.k_n_per_m;
            stiffness[(a + 3, a + 3)] += c.k_nm_per_rad;
            coupling_damping[(a, a)] = c.b_n_s_per_m;
            coupling_damping[(a + 3, a + 3)] = c.b_nm_s_per_rad;
        }
        damping += coupling_damping;
        let mass = self.mass_matrix();
        let u = stack(&self.velocity, &self.angular_velocity);
        let lhs = mass + damping * dt_s + stiffness * (dt_s * dt_s);
        let rhs = (mass + damping * dt_s) * u + force * dt_s;
        self.work.solves += 1;
        let u_next = match lhs.cholesky() {
            Some(ch) => ch.solve(&rhs),
            None => Vector6::zeros(),
        };
        if u_next.iter().all(|x| x.is_finite()) {
            u_next
        } else {
            Vector6::zeros()
        }
    }

    /// Step 4, the travel bound (VPS's speed limit): a point that enters contact this step
    /// has no stiffness in the implicit solve yet, so whatever pulls the proxy (the coupling
    /// stretched by a hand far ahead, or a light plate tipping over an edge) could carry it
    /// deep before the next search sees it. While some point is within reach, no point may
    /// travel more than `max_travel_voxels`; otherwise every point is at least the reach
    /// (plus the object's free budget) away, and may travel that much more. Scaling the
    /// velocities only removes kinetic energy, so the bound is passive; the coupling's
    /// force follows positions and so changes continuously.
    fn bound_travel(&self, u_next: Vector6<f64>, found: &Found, dt_s: f64) -> Vector6<f64> {
        let bound = self.config.max_travel_voxels * self.model.voxmap.voxel_m();
        let limit_m = if found.near > 0 {
            bound
        } else {
            (self.cache.object - self.cache.motion_m).max(0.0) + self.reach_m() + bound
        };
        // Work the caps left for later steps (see `NearPass::overdue_m`): its points are
        // at least the reach less the overdue motion from the surface; travelling no more
        // than that keeps them out of it. Infinite overdue (near points not looked at)
        // holds the proxy still.
        let limit_m = limit_m.min((self.reach_m() - found.overdue_m).max(0.0));
        let travel_m = (u_next.fixed_rows::<3>(0).norm()
            + u_next.fixed_rows::<3>(3).norm() * self.model.radius_m)
            * dt_s;
        if travel_m > limit_m {
            u_next * (limit_m / travel_m)
        } else {
            u_next
        }
    }

    /// Step 5: the proxy takes the velocities `u_next` and moves for `dt_s` about its centre
    /// of mass `com` (where it was at the start of the step).
    fn integrate(&mut self, u_next: Vector6<f64>, com: &Vector3<f64>, dt_s: f64) {
        self.velocity = u_next.fixed_rows::<3>(0).into_owned();
        self.angular_velocity = u_next.fixed_rows::<3>(3).into_owned();
        let new_com = com + self.velocity * dt_s;
        let rotation =
            UnitQuaternion::from_scaled_axis(self.angular_velocity * dt_s) * self.pose.rotation;
        let translation = new_com - rotation * self.model.com_local;
        self.pose = Isometry3::from_parts(Translation3::from(translation), rotation);
    }

    /// Step 6: contact with hysteresis, entered on penetration and left only when no point
    /// is within the release distance; the normal is held from the step contact began.
    fn contact_state(&mut self, found: &Found) -> ContactCode {
        let s = &found.totals;
        let entering = s.contacts > 0 && !self.in_contact;
        if s.contacts > 0 {
            self.in_contact = true;
        } else if !s.within_release {
            self.in_contact = false;
        }
        if entering {
            self.held_normal = s
                .normal_sum
                .try_normalize(1e-12)
                .unwrap_or_else(Vector3::zeros);
        }
        if s.weight > 0.0 {
            self.held_point = s.weighted_point / s.weight;
        }
        let code = if self.in_contact {
            ContactCode::CONTACT
        } else if found.near > 0 {
            ContactCode::PROXIMITY
        } else {
            ContactCode::FREE
        };
        if !self.in_contact {
            self.held_normal = Vector3::zeros();
            self.held_point = Vector3::zeros();
        }
        code
    }

    /// Step 7: the wrenches about the reference points (the moment of a force at the
    /// centre of mass): the scene's on the proxy, and the coupling's on the device.
    fn output(
        &self,
        before: &Isometry3<f64>,
        found: &Found,
        pull: &Pull,
        code: ContactCode,
    ) -> ContactOutput {
        let s = &found.totals;
        let lever = pull.com - before.translation.vector;
        let contact_force: Vector3<f64> = s.wrench.fixed_rows::<3>(0).into_owned();
        ContactOutput {
            proxy: self.pose,
            contact_force_n: contact_force,
            contact_torque_nm: s.wrench.fixed_rows::<3>(3) + lever.cross(&contact_force),
            device_force_n: -pull.force_n,
            device_torque_nm: -pull.torque_nm + pull.anchor_lever_m.cross(&(-pull.force_n)),
            operator_force_n: pull.force_n,
            code,
            normal: self.held_normal,
            point_m: self.held_point,
            penetration_m: s.max_depth,
            contacts: s.contacts,
            points_tested: found.tested,
            level: self.levels.level() as u8,
        }
    }
}

/// The levels' near passes and point budgets as one step's level chooser asks for them
/// ([`Levels`]): each level's near pass once, or twice when a capped one did not get
/// through and more is asked, and only for the levels asked for; all of them, and the
/// searches after them, drawing on one allowance for the step.
struct StageLevels<'a> {
    model: &'a ContactModel,
    cache: &'a mut [LevelCache],
    /// Each level's latest near pass this step.
    passes: [Option<NearPass>; LEVELS],
    /// Near passes run per level this step.
    runs: [u8; LEVELS],
    /// Points looked up only to renew their budgets this step.
    renewed: u32,
    k: &'a SearchParams,
    pass: &'a PassParams,
    allow: &'a mut Allowance,
    work: &'a mut ContactWork,
}

impl StageLevels<'_> {
    /// Level `l`'s near pass this step, of at most `max_checks` clearance checks: run
    /// again (checking what the last left unchecked) only when the last one visited
    /// everything but left due groups or clusters unchecked, checks are left, compares
    /// are left for as many visits, and it ran once: a second pass cut short by the
    /// compares would list less than the first.
    fn near_pass(&mut self, l: usize, max_checks: u32) -> NearPass {
        if let Some(p) = self.passes[l]
            && (p.whole
                || !p.overdue_m.is_finite()
                || self.runs[l] >= 2
                || self.allow.checks == 0
                || self.allow.compares < p.compares)
        {
            return p;
        }
        let c = &mut self.cache[l];
        let p = self.model.columns[l].near_clusters(
            &mut c.groups,
            &mut c.clusters,
            self.k,
            &self.model.voxmap,
            &mut c.scratch,
            max_checks,
            self.allow,
            self.work,
        );
        self.passes[l] = Some(p);
        self.runs[l] += 1;
        p
    }
}

impl Levels for StageLevels<'_> {
    fn near(&mut self, l: usize) -> u32 {
        self.near_pass(l, u32::MAX).points
    }

    fn near_within(&mut self, l: usize) -> Option<u32> {
        let p = self.near_pass(l, WARM_CHECKS);
        p.whole.then_some(p.points)
    }

    fn renew_points(&mut self, l: usize, skip: u32, max: u32) -> u32 {
        // The near list in the scratch must be this step's whole one.
        if !self.near_pass(l, u32::MAX).whole {
            return u32::MAX;
        }
        let c = &mut self.cache[l];
        let due = self.model.columns[l].renew_points(
            &mut c.points,
            self.k,
            self.pass,
            &self.model.voxmap,
            &mut c.scratch,
            skip,
            max,
            self.allow,
            self.work,
        );
        self.renewed += due.min(max);
        due
    }
}

/// The coupling's spring-damper in one step (scene frame).
#[derive(Debug, Clone, Copy)]
struct Pull {
    /// Force on the proxy, at its centre of mass, N.
    force_n: Vector3<f64>,
    /// Torque on the proxy, N·m.
    torque_nm: Vector3<f64>,
    /// The proxy's centre of mass at the start of the step, m.
    com: Vector3<f64>,
    /// From the anchor's reference point to its centre of mass, m.
    anchor_lever_m: Vector3<f64>,
}
