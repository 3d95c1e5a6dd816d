//! Contact rendering: voxmap-pointshell (McNeely, Puterbaugh, Troy 1999; distance layers and
//! pre-contact braking from their 2006 paper) with a 6-DOF virtual coupling.
//!
//! * [`Voxmap`]: the static scene as a sparse signed-distance field (scene frame).
//! * [`Pointshell`]: the moving object as surface points with inward normals (object frame).
//! * [`ContactStage`]: the dynamic proxy object. Once per tick it sums the scene's penalty
//!   wrench on the pointshell, adds the coupling spring-damper towards the device-mapped
//!   pose, and integrates one step. The device receives the negated coupling wrench.
//!
//! # Force model (written down because the papers leave a choice)
//!
//! *Tangent-plane model on the distance field.* For a point at signed distance s < 0 the
//! depth is d = −s and the force is `k_p·d` along the field's gradient n at the point, i.e.
//! along the outward normal of the obstacle surface nearest the point, which on a locally
//! flat surface is exactly the tangent-plane force of VPS 1999 (the stored distance *is* the
//! distance to the tangent plane). Using the scene's normal, not the point's, makes the
//! total force agree with the geometric contact normal also for corners and edges of the
//! object. The point's inward normal culls points on the side of the object turned away
//! from that surface (n_inward · n < −0.5, i.e. more than 120°), which happen only after
//! tunnelling through thin features and would pull the object further in; points at right
//! angles to the surface (an edge of the object against a face) are kept.
//!
//! Per-point stiffness `k_p` is not averaged over the number of contacts (VPS 1999 divides by
//! N/10 for stability): the proxy is integrated with linearly implicit (backward) Euler using
//! the 6×6 contact stiffness Σ k_p JᵀJ (J = [nᵀ, (r×n)ᵀ]), which is stable for any number of
//! contacts and dissipates energy instead of creating it. What the hand feels is bounded by
//! the coupling, whose gains come from the device's stable stiffness and damping.
//!
//! *Travel bound* (VPS 2006's speed limit): a point entering contact has no stiffness in
//! the implicit solve until the next search sees it, so while any point is within reach of
//! a surface no point of the proxy travels more than `max_travel_voxels` (half a voxel) per
//! step; a hand far ahead of a blocked object, or a light object tipping over an edge, then
//! cannot carry a face deep into the scene in one step. The velocities are scaled down, which
//! only removes energy.
//!
//! Contact damping along each normal, and the pre-contact braking of points approaching the
//! surface inside the proximity layer (weighted by 1 − s/proximity so it fades in), are each
//! a total damping shared among the points that produce it, so a face touching with 2000
//! points brakes like an edge touching with 20. Neither term ever pulls.
//!
//! # Frames
//!
//! Everything here is in the scene frame except pointshell data (object frame). The proxy's
//! pose is the pose of the object's reference point; its dynamics are about the centre of
//! mass (the volume centroid of the object's parts, uniform density). The coupling joins the
//! centre of mass of the device-mapped object to the proxy's.

mod error;
mod jtj;
mod lanes;
mod level;
mod mesh;
mod near;
mod pointshell;
#[cfg(test)]
mod tests;
mod voxmap;

pub use error::ContactError;
pub use level::Resolution;
pub use pointshell::{Cluster, LEVELS, Pointshell};
pub use scene::progress::Progress;
pub use voxmap::cache as voxmap_cache;
pub use voxmap::{Obstacle, Sample, Surface, Voxmap, VoxmapConfig, VoxmapError, VoxmapReport};

use devices::DeviceSpec;
use ipc_types::ContactCode;
use level::{LevelChooser, Plan};
use nalgebra::{
    Isometry3, Matrix3, Matrix6, Point3, Translation3, UnitQuaternion, Vector3, Vector6,
};
use near::{ClusterBudget, Found, PassParams, Scratch, SearchParams, ShellColumns};
use parry3d_f64::mass_properties::MassProperties;
use parry3d_f64::math::Pose;
use parry3d_f64::shape::SharedShape;
use scene::Scene;
use std::sync::Arc;
use std::time::Instant;

/// Parameters of contact rendering. Gains of the coupling are not here: they are derived from
/// the device's specification (see [`Coupling::from_spec`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactConfig {
    /// The voxmap's voxel size and distance layers; the pointshell uses the same spacing.
    pub voxmap: VoxmapConfig,
    /// Penalty stiffness per penetrating point, N/m.
    pub point_stiffness_n_per_m: f64,
    /// Total contact damping along the normals, shared among the penetrating points, N·s/m.
    pub contact_damping_n_s_per_m: f64,
    /// Thickness of the proximity layer, in voxels (≤ `voxmap.layers_out` − 1).
    pub proximity_voxels: f64,
    /// Total pre-contact braking damping, shared among the approaching points in the
    /// proximity layer, N·s/m.
    pub braking_n_s_per_m: f64,
    /// Mass of the proxy object, kg. Its inertia follows from its shape at uniform density.
    pub proxy_mass_kg: f64,
    /// Fraction (0, 1] of the device's stable stiffness and damping the coupling uses.
    pub coupling_fraction: f64,
    /// Contact is released only when no point is closer than this to the surface, in
    /// voxels (hysteresis against chatter of the contact flag).
    pub release_voxels: f64,
    /// Which of the pointshell's levels of detail is rendered: a fixed one, or the finest
    /// that fits a per-tick point budget (see [`Resolution`]).
    pub resolution: Resolution,
    /// How far any point of the proxy may travel in one step while some point is within
    /// reach of a surface, in voxels (see `ContactStage::step`): a point entering contact
    /// is found at most this deep, whatever pulls on the proxy.
    pub max_travel_voxels: f64,
}

impl Default for ContactConfig {
    fn default() -> Self {
        Self {
            voxmap: VoxmapConfig::default(),
            point_stiffness_n_per_m: 10_000.0,
            contact_damping_n_s_per_m: 40.0,
            proximity_voxels: 2.0,
            braking_n_s_per_m: 20.0,
            proxy_mass_kg: 0.05,
            coupling_fraction: 0.75,
            release_voxels: 0.25,
            resolution: Resolution::DEFAULT,
            max_travel_voxels: 0.5,
        }
    }
}

impl ContactConfig {
    /// The defaults with voxels (and pointshell spacing) of `voxel_m` metres.
    pub fn with_voxel_m(voxel_m: f64) -> Self {
        Self {
            voxmap: VoxmapConfig {
                voxel_m,
                ..VoxmapConfig::default()
            },
            ..Self::default()
        }
    }

    /// Checks every field; the error names the field.
    pub fn validate(&self) -> Result<(), ContactError> {
        let positive = [
            (self.point_stiffness_n_per_m, "point stiffness (N/m)"),
            (self.proxy_mass_kg, "proxy mass (kg)"),
            (self.coupling_fraction, "coupling fraction"),
            (self.max_travel_voxels, "travel per step (voxels)"),
        ];
        for (v, name) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(ContactError::Parameter {
                    name,
                    need: "> 0",
                    value: v,
                });
            }
        }
        let non_negative = [
            (self.contact_damping_n_s_per_m, "contact damping (N·s/m)"),
            (self.braking_n_s_per_m, "braking damping (N·s/m)"),
            (self.proximity_voxels, "proximity layer (voxels)"),
            (self.release_voxels, "release distance (voxels)"),
        ];
        for (v, name) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ContactError::Parameter {
                    name,
                    need: "≥ 0",
                    value: v,
                });
            }
        }
        if self.coupling_fraction > 1.0 {
            return Err(ContactError::Parameter {
                name: "coupling fraction",
                need: "≤ 1",
                value: self.coupling_fraction,
            });
        }
        self.resolution
            .validate()
            .map_err(ContactError::Resolution)?;
        let layer = f64::from(self.voxmap.layers_out) - 1.0;
        if self.proximity_voxels > layer || self.release_voxels > layer {
            return Err(ContactError::Layers {
                proximity_voxels: self.proximity_voxels,
                release_voxels: self.release_voxels,
                layer_voxels: layer,
            });
        }
        Ok(())
    }
}

/// Spring-damper gains of the virtual coupling, scene side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coupling {
    /// Translational stiffness, N per scene metre.
    pub k_n_per_m: f64,
    /// Translational damping, N·s per scene metre.
    pub b_n_s_per_m: f64,
    /// Rotational stiffness, N·m/rad.
    pub k_nm_per_rad: f64,
    /// Rotational damping, N·m·s/rad.
    pub b_nm_s_per_rad: f64,
}

impl Coupling {
    /// Gains such that the device feels `fraction` of its stable limits: a scene-side
    /// stiffness k is felt as `position_scale·k` per device metre (see `mapping`), so the
    /// translational gains are divided by the scale; rotations are not scaled.
    pub fn from_spec(spec: &DeviceSpec, position_scale: f64, fraction: f64) -> Self {
        Self {
            k_n_per_m: fraction * spec.max_stiffness_n_per_m / position_scale,
            b_n_s_per_m: fraction * spec.max_damping_n_s_per_m / position_scale,
            k_nm_per_rad: fraction * spec.max_rot_stiffness_nm_per_rad,
            b_nm_s_per_rad: fraction * spec.max_rot_damping_nm_s_per_rad,
        }
    }
}

/// What init builds once per scene: voxmap, pointshell, and the object's mass properties.
/// Shared read-only (`Arc`) between the contact stage and, e.g., tests.
#[derive(Debug)]
pub struct ContactModel {
    voxmap: Voxmap,
    /// The pointshell's levels of detail, finest (every point) first.
    shells: Vec<Pointshell>,
    /// Each level as the search reads it.
    columns: Vec<ShellColumns>,
    /// Centre of mass, object frame, m.
    com_local: Vector3<f64>,
    /// Inertia tensor about the centre of mass per kg of mass, object frame, m².
    inertia_per_kg: Matrix3<f64>,
    /// Radius about the centre of mass holding every point, m.
    radius_m: f64,
    /// Pointshell build time, s.
    shell_build_s: f64,
}

impl ContactModel {
    /// Builds the voxmap of `scene.obstacles` and the pointshell of `scene.moving_object`.
    /// See [`Self::from_scene_with`].
    pub fn from_scene(scene: &Scene, voxmap: &VoxmapConfig) -> Result<Self, ContactError> {
        Self::from_scene_with(scene, voxmap, &Progress::default(), None)
    }

    /// Builds the voxmap of `scene.obstacles` and the pointshell of `scene.moving_object`,
    /// reporting progress to and stopping on `control`. A closed, outward mesh is solid;
    /// an open one (a panel, a sheet: holes in its surface) is rendered as a shell of
    /// [`VoxmapConfig::shell_voxels`] around its surface, with a warning; a mesh whose
    /// inside cannot be told is refused ([`ContactError::Mesh`]), naming why. With a
    /// `cache_dir`, the voxmap is read from there when it was built from the same inputs
    /// before, and written there when built (`voxmap::cache`).
    pub fn from_scene_with(
        scene: &Scene,
        voxmap: &VoxmapConfig,
        control: &Progress,
        cache_dir: Option<&std::path::Path>,
    ) -> Result<Self, ContactError> {
        use scene::repair::Surface as Found;
        let mut obstacles = Vec::with_capacity(scene.obstacles.len());
        for (i, part) in scene.obstacles.iter().enumerate() {
            let pose = scene::shapes::to_parry(&part.pose);
            let scene::Primitive::Mesh { mesh } = &part.primitive else {
                obstacles.push(Obstacle::Shape {
                    pose,
                    shape: scene::shapes::part_shape(part),
                });
                continue;
            };
            let surface = match mesh.surface() {
                Found::ClosedOutward => Surface::Solid,
                Found::Open => {
                    let thickness_m = voxmap.shell_voxels * voxmap.voxel_m;
                    tracing::warn!(
                        "contact: mesh {} (obstacles[{i}]) is open: rendered as a shell {:.1} mm thick around its surface",
                        mesh.source,
                        thickness_m * 1e3
                    );
                    Surface::Shell { thickness_m }
                }
                Found::Refused(why) => {
                    return Err(ContactError::Mesh {
                        field: format!("obstacles[{i}]"),
                        source_file: mesh.source.clone(),
                        reason: why.to_string(),
                    });
                }
            };
            obstacles.push(Obstacle::Mesh {
                pose,
                mesh: mesh.clone(),
                surface,
            });
        }
        let mut open = Vec::with_capacity(scene.moving_object.len());
        for (i, part) in scene.moving_object.iter().enumerate() {
            let scene::Primitive::Mesh { mesh } = &part.primitive else {
                open.push(false);
                continue;
            };
            match mesh.surface() {
                Found::ClosedOutward => open.push(false),
                Found::Open => {
                    tracing::warn!(
                        "contact: mesh {} (moving_object[{i}]) is open: its points touch from either side, its mass is that of a shell {:.1} mm thick",
                        mesh.source,
                        voxmap.shell_voxels * voxmap.voxel_m * 1e3
                    );
                    open.push(true);
                }
                Found::Refused(why) => {
                    return Err(ContactError::Mesh {
                        field: format!("moving_object[{i}]"),
                        source_file: mesh.source.clone(),
                        reason: why.to_string(),
                    });
                }
            }
        }
        let shell_m = voxmap.shell_voxels * voxmap.voxel_m;
        let voxmap = cached_voxmap(&obstacles, voxmap, control, cache_dir)?;
        let object = scene::shapes::part_shapes(&scene.moving_object);
        Self::with_voxmap(voxmap, &object, &open, shell_m, control)
    }

    /// Builds from parry shapes: obstacles in the scene frame, object parts in the object
    /// frame.
    pub fn build(
        obstacles: &[(Pose, SharedShape)],
        object: &[(Pose, SharedShape)],
        voxmap: &VoxmapConfig,
    ) -> Result<Self, ContactError> {
        let voxmap = Voxmap::build(obstacles, voxmap)?;
        Self::with_voxmap(voxmap, object, &[], 0.0, &Progress::default())
    }

    /// The model of `object` (parts in the object frame) against a built `voxmap`.
    /// The parts `open` marks are open meshes: their points face both ways and their mass
    /// is that of a shell `shell_m` thick.
    fn with_voxmap(
        voxmap: Voxmap,
        object: &[(Pose, SharedShape)],
        open: &[bool],
        shell_m: f64,
        progress: &Progress,
    ) -> Result<Self, ContactError> {
        let started = Instant::now();
        let shells =
            Pointshell::build_with(object, open, voxmap.voxel_m(), progress)?.with_coarser();
        let shell = &shells[0];
        let shell_build_s = started.elapsed().as_secs_f64();
        // Summed part by part: parry's `Compound` refuses a mesh among its parts (it
        // panics on nested composite shapes), as the silencer's body is.
        let mp: MassProperties = object
            .iter()
            .enumerate()
            .map(|(i, (pose, shape))| match shape.as_trimesh() {
                Some(t) if open.get(i).copied().unwrap_or(false) => {
                    shell_mass_properties(pose, t, shell_m)
                }
                _ => shape.mass_properties(1.0).transform_by(pose),
            })
            .sum();
        let volume = mp.mass();
        if !(volume.is_finite() && volume > 0.0) {
            return Err(ContactError::NoVolume);
        }
        let c = mp.local_com;
        let com_local = Vector3::new(c.x, c.y, c.z);
        let r = mp.principal_inertia_local_frame;
        let frame = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(r.w, r.x, r.y, r.z))
            .to_rotation_matrix();
        let inv = mp.inv_principal_inertia;
        let principal =
            Vector3::new(inv.x, inv.y, inv.z).map(|i| if i > 0.0 { 1.0 / i } else { 0.0 });
        let inertia_per_kg =
            frame.matrix() * Matrix3::from_diagonal(&principal) * frame.matrix().transpose()
                / volume;
        let radius_m = shell.radius_about(&com_local);
        Ok(Self {
            voxmap,
            columns: shells.iter().map(ShellColumns::new).collect(),
            shells,
            com_local,
            inertia_per_kg,
            radius_m,
            shell_build_s,
        })
    }

    /// The scene's voxmap.
    pub fn voxmap(&self) -> &Voxmap {
        &self.voxmap
    }

    /// The object's pointshell (every point: level 0).
    pub fn pointshell(&self) -> &Pointshell {
        &self.shells[0]
    }

    /// Its level of detail `level` (< [`LEVELS`]; see `pointshell`'s module docs).
    pub fn pointshell_at(&self, level: usize) -> &Pointshell {
        &self.shells[level]
    }

    /// Centre of mass, object frame, m.
    pub fn com_local(&self) -> Vector3<f64> {
        self.com_local
    }

    /// One line for the start-up log: voxmap size, memory, build times, point count.
    pub fn describe(&self) -> String {
        format!(
            "{}; pointshell {} points in {} clusters (levels of detail: {} points), built in {:.2} s",
            self.voxmap.report(),
            self.shells[0].len(),
            self.shells[0].clusters().len(),
            self.shells
                .iter()
                .map(|s| s.len().to_string())
                .collect::<Vec<_>>()
                .join(" / "),
            self.shell_build_s
        )
    }
}

/// The mass properties (density 1) of a triangle mesh taken as a shell `thickness_m`
/// thick, in the frame `pose` maps the mesh into: per triangle of area A, mass A·t at its
/// centroid and the second moment t·A/12·(Σ vᵢvᵢᵀ + (Σ vᵢ)(Σ vᵢ)ᵀ) of a thin triangle.
fn shell_mass_properties(
    pose: &Pose,
    mesh: &parry3d_f64::shape::TriMesh,
    thickness_m: f64,
) -> MassProperties {
    let v: Vec<Vector3<f64>> = mesh
        .vertices()
        .iter()
        .map(|p| {
            let q = pose.transform_point(*p);
            Vector3::new(q.x, q.y, q.z)
        })
        .collect();
    let (mut mass, mut first, mut second) = (0.0, Vector3::zeros(), Matrix3::zeros());
    for t in mesh.indices() {
        let [a, b, c] = t.map(|i| v[i as usize]);
        let area = 0.5 * (b - a).cross(&(c - a)).norm();
        let m = area * thickness_m;
        let sum = a + b + c;
        mass += m;
        first += sum * (m / 3.0);
        second +=
            (a * a.transpose() + b * b.transpose() + c * c.transpose() + sum * sum.transpose())
                * (m / 12.0);
    }
    // Zero area (or NaN from a degenerate mesh): no mass to speak of.
    if mass.is_nan() || mass <= 0.0 {
        return MassProperties::default();
    }
    let com = first / mass;
    // Inertia about the origin from the second moment, then about the centre of mass.
    let about_origin = Matrix3::identity() * second.trace() - second;
    let about_com =
        about_origin - (Matrix3::identity() * com.norm_squared() - com * com.transpose()) * mass;
    let m = about_com;
    MassProperties::with_inertia_matrix(
        parry3d_f64::math::Vector::new(com.x, com.y, com.z),
        mass,
        parry3d_f64::math::Matrix::from_cols_array(&[
            m[(0, 0)],
            m[(1, 0)],
            m[(2, 0)],
            m[(0, 1)],
            m[(1, 1)],
            m[(2, 1)],
            m[(0, 2)],
            m[(1, 2)],
            m[(2, 2)],
        ]),
    )
}

/// The voxmap of `obstacles`: from `cache_dir` when built from the same inputs before, else
/// built (and then written there). A cache file that cannot be used is reported and
/// rebuilt over; one that cannot be written is reported, and the build is used as is.
fn cached_voxmap(
    obstacles: &[Obstacle],
    config: &VoxmapConfig,
    control: &Progress,
    cache_dir: Option<&std::path::Path>,
) -> Result<Voxmap, ContactError> {
    let Some((dir, key)) =
        cache_dir.and_then(|d| voxmap::cache::key(obstacles, config).map(|k| (d, k)))
    else {
        return Ok(Voxmap::build_obstacles(obstacles, config, control)?);
    };
    match voxmap::cache::load(dir, &key) {
        Ok(Some(v)) => {
            tracing::info!(
                "voxmap read from {}",
                voxmap::cache::path(dir, &key).display()
            );
            return Ok(v);
        }
        Ok(None) => {}
        Err(e) => tracing::warn!("voxmap cache: {e}; building it again"),
    }
    let v = Voxmap::build_obstacles(obstacles, config, control)?;
    match voxmap::cache::store(dir, &key, &v) {
        Ok(path) => tracing::info!("voxmap written to {}", path.display()),
        Err(e) => tracing::warn!("voxmap cache: cannot write it: {e}"),
    }
    Ok(v)
}

/// The motion of the device-mapped object this tick (scene frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Anchor {
    /// Pose of the reference point.
    pub pose: Isometry3<f64>,
    /// Linear velocity of the reference point, m/s.
    pub linear_velocity: Vector3<f64>,
    /// Angular velocity, rad/s.
    pub angular_velocity: Vector3<f64>,
}

/// What one contact step produces (scene frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactOutput {
    /// Proxy pose (reference point) after the step.
    pub proxy: Isometry3<f64>,
    /// Wrench of the scene on the proxy: force (N) and torque about the reference point (N·m).
    pub contact_force_n: Vector3<f64>,
    /// See `contact_force_n`.
    pub contact_torque_nm: Vector3<f64>,
    /// Wrench for the device: the negated coupling wrench, torque about the device-mapped
    /// reference point.
    pub device_force_n: Vector3<f64>,
    /// See `device_force_n`.
    pub device_torque_nm: Vector3<f64>,
    /// Coupling force on the proxy: what the operator pushes with (f_u), N.
    pub operator_force_n: Vector3<f64>,
    /// FREE, PROXIMITY or CONTACT.
    pub code: ContactCode,
    /// Normal of the first contact, held while contact lasts; zero when not in contact.
    pub normal: Vector3<f64>,
    /// Depth-weighted mean of the penetrating points projected on the surface, m; held
    /// while contact lasts without penetration; zero when not in contact.
    pub point_m: Vector3<f64>,
    /// Deepest penetration this tick, m.
    pub penetration_m: f64,
    /// Points that penetrate.
    pub contacts: u32,
    /// Points tested against the voxmap (after cluster culling), over both levels while
    /// a change of level is blended.
    pub points_tested: u32,
    /// Level of detail rendered (0 = every point; the new level while blending).
    pub level: u8,
}

/// The scene's wrench on an object held still at a pose (see [`ContactStage::probe`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Probe {
    /// Force, N.
    pub force_n: Vector3<f64>,
    /// Torque about the reference point, N·m.
    pub torque_nm: Vector3<f64>,
    /// Deepest penetration, m.
    pub penetration_m: f64,
    /// Penetrating points.
    pub contacts: u32,
    /// Depth-weighted mean contact point on the surface, m.
    pub point_m: Vector3<f64>,
}

/// Temporal coherence of the contact search: the whole object, each group, cluster and
/// point carry the total proxy motion (m, any point's worst-case travel, summed over steps)
/// at which they can first come within reach of the surface. Until the running total passes
/// it, they are skipped without a voxmap look-up; a point 5 mm from the wall is looked at
/// again only after the object has moved 1.5–3 mm (a share of its look-ahead staggered by
/// its index, so that points found together are not all due in one tick). Each level of
/// detail keeps its own budgets; one not searched for a while finds them used up and
/// checks again, which is always safe. Preallocated; reset on `place`.
#[derive(Debug, Clone, Default)]
struct Coherence {
    /// Running total of the bound on any point's motion, m.
    motion_m: f64,
    /// Pose at the last search.
    last: Option<Isometry3<f64>>,
    object: f64,
    levels: Vec<LevelCache>,
}

/// One level of detail's budgets (see [`Coherence`]) and the search's scratch.
#[derive(Debug, Clone, Default)]
struct LevelCache {
    groups: Vec<ClusterBudget>,
    clusters: Vec<ClusterBudget>,
    points: Vec<f64>,
    scratch: Scratch,
}

impl Coherence {
    fn new(shells: &[Pointshell]) -> Self {
        Self {
            motion_m: 0.0,
            last: None,
            object: 0.0,
            levels: shells
                .iter()
                .map(|s| LevelCache {
                    groups: vec![ClusterBudget::default(); s.groups().len()],
                    clusters: vec![ClusterBudget::default(); s.clusters().len()],
                    points: vec![0.0; s.len()],
                    scratch: Scratch::with_capacity(s.clusters().len(), s.len()),
                })
                .collect(),
        }
    }

    /// Forget everything (the object jumped).
    fn reset(&mut self) {
        self.motion_m = 0.0;
        self.last = None;
        self.object = 0.0;
        for l in &mut self.levels {
            l.groups.fill(ClusterBudget::default());
            l.clusters.fill(ClusterBudget::default());
            l.points.fill(0.0);
        }
    }

    /// Adds the motion from the last search to `pose`: the centre of mass's travel plus
    /// the rotation angle times the object's radius about it bounds every point's travel.
    fn advance(&mut self, pose: &Isometry3<f64>, com_local: &Vector3<f64>, radius_m: f64) {
        if let Some(last) = self.last {
            let c0 = last.transform_point(&Point3::from(*com_local));
            let c1 = pose.transform_point(&Point3::from(*com_local));
            let angle = last.rotation.angle_to(&pose.rotation);
            self.motion_m += (c1 - c0).norm() + angle * radius_m;
        }
        self.last = Some(*pose);
    }
}

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

    /// Pointshell points tested against the voxmap in the last step (after culling).
    pub fn last_points_tested(&self) -> u32 {
        self.last_tested
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

    /// Sets the proxy's velocities (centre of mass, m/s; rad/s) — for tests.
    pub fn set_velocity(&mut self, linear: Vector3<f64>, angular: Vector3<f64>) {
        self.velocity = linear;
        self.angular_velocity = angular;
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
    fn sum_contacts(
        &self,
        pose: &Isometry3<f64>,
        velocity: &Vector3<f64>,
        angular_velocity: &Vector3<f64>,
        cache: &mut Coherence,
        plan: impl FnOnce(&mut dyn FnMut(usize) -> u32) -> Plan,
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
        // Each level's near pass at most once, and only for the levels asked for.
        let mut counts = [None; LEVELS];
        let levels = &mut cache.levels;
        let mut near = |l: usize| {
            *counts[l].get_or_insert_with(|| {
                let c = &mut levels[l];
                model.columns[l].near_clusters(
                    &mut c.groups,
                    &mut c.clusters,
                    &k,
                    vox,
                    &mut c.scratch,
                )
            })
        };
        let plan = plan(&mut near);
        near(plan.from);
        near(plan.to);
        let mut search = |l: usize| {
            let c = &mut levels[l];
            model.columns[l].search(&mut c.points, &k, &pass, vox, &mut c.scratch)
        };
        let from = search(plan.from);
        if plan.to == plan.from {
            return from;
        }
        let to = search(plan.to);
        Found {
            totals: from.totals.lerp(&to.totals, plan.alpha),
            tested: from.tested + to.tested,
            near: from.near.max(to.near),
        }
    }

    /// One step of `dt_s` towards `anchor`. Allocation-free.
    pub fn step(&mut self, anchor: &Anchor, dt_s: f64) -> ContactOutput {
        if !self.started {
            self.place(anchor.pose);
        }
        let before = self.pose;
        let mut cache = std::mem::take(&mut self.cache);
        cache.advance(&self.pose, &self.model.com_local, self.model.radius_m);
        let mut levels = self.levels;
        let (resolution, coarsest) = (self.config.resolution, self.coarsest_level);
        let found = self.sum_contacts(
            &self.pose,
            &self.velocity,
            &self.angular_velocity,
            &mut cache,
            |near| match resolution {
                Resolution::Level(_) => Plan::at(levels.level()),
                Resolution::Budget { points_per_ms, .. } => levels.plan(
                    near,
                    points_per_ms * dt_s * 1e3,
                    coarsest,
                    (Resolution::BLEND_S / dt_s).round().max(1.0) as u32,
                ),
            },
        );
        self.level_changes += u64::from(levels.level() != self.levels.level());
        self.levels = levels;
        self.cache = cache;
        let s = found.totals;

        self.previous_contacts = s.contacts;
        self.last_tested = found.tested;
        self.previous_braking = s.braking_points;
        let contact_wrench = s.wrench;
        let mut force = s.wrench;
        let mut damping = s.damping_jj.matrix(1.0);

        // Coupling between the centres of mass.
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
        let f_coupling = f_spring + c.b_n_s_per_m * (anchor_v - self.velocity);
        let t_coupling = c.k_nm_per_rad * dtheta
            + c.b_nm_s_per_rad * (anchor.angular_velocity - self.angular_velocity);
        force += stack(&f_coupling, &t_coupling);
        let mut stiffness = s.contact_jj.matrix(self.config.point_stiffness_n_per_m);
        let mut coupling_damping = Matrix6::zeros();
        for a in 0..3 {
            stiffness[(a, a)] += c.k_n_per_m;
            stiffness[(a + 3, a + 3)] += c.k_nm_per_rad;
            coupling_damping[(a, a)] = c.b_n_s_per_m;
            coupling_damping[(a + 3, a + 3)] = c.b_nm_s_per_rad;
        }
        damping += coupling_damping;

        // Linearly implicit Euler: (M + dt·D + dt²·K) u' = (M + dt·D) u + dt·F, where F already
        // holds the damping forces at u.
        let mass = self.mass_matrix();
        let u = stack(&self.velocity, &self.angular_velocity);
        let lhs = mass + damping * dt_s + stiffness * (dt_s * dt_s);
        let rhs = (mass + damping * dt_s) * u + force * dt_s;
        let u_next = match lhs.cholesky() {
            Some(ch) => ch.solve(&rhs),
            // Not positive definite only with non-finite input: stop rather than explode.
            None => Vector6::zeros(),
        };
        let u_next = if u_next.iter().all(|x| x.is_finite()) {
            u_next
        } else {
            Vector6::zeros()
        };
        // Travel bound (VPS's speed limit): a point that enters contact this step has no
        // stiffness in the implicit solve yet, so whatever pulls the proxy (the coupling
        // stretched by a hand far ahead, or a light plate tipping over an edge) could carry
        // it deep before the next search sees it. While some point is within reach, no
        // point may travel more than `max_travel_voxels`; otherwise every point is at least
        // the reach (plus the object's free budget) away, and may travel that much more.
        // Scaling the velocities only removes kinetic energy, so the bound is passive; the
        // coupling's force follows positions and so changes continuously.
        let bound = self.config.max_travel_voxels * self.model.voxmap.voxel_m();
        let limit_m = if found.near > 0 {
            bound
        } else {
            (self.cache.object - self.cache.motion_m).max(0.0) + self.reach_m() + bound
        };
        let travel_m = (u_next.fixed_rows::<3>(0).norm()
            + u_next.fixed_rows::<3>(3).norm() * self.model.radius_m)
            * dt_s;
        let u_next = if travel_m > limit_m {
            u_next * (limit_m / travel_m)
        } else {
            u_next
        };
        self.velocity = u_next.fixed_rows::<3>(0).into_owned();
        self.angular_velocity = u_next.fixed_rows::<3>(3).into_owned();
        let new_com = com + self.velocity * dt_s;
        let rotation =
            UnitQuaternion::from_scaled_axis(self.angular_velocity * dt_s) * self.pose.rotation;
        let translation = new_com - rotation * self.model.com_local;
        self.pose = Isometry3::from_parts(Translation3::from(translation), rotation);

        // Contact state with hysteresis: enter on penetration, leave only when no point is
        // within the release distance.
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

        // Wrench about the reference points: moment of a force at the centre of mass.
        let lever = com - before.translation.vector;
        let contact_force: Vector3<f64> = contact_wrench.fixed_rows::<3>(0).into_owned();
        let anchor_lever = anchor_com - anchor.pose.translation.vector;
        ContactOutput {
            proxy: self.pose,
            contact_force_n: contact_force,
            contact_torque_nm: contact_wrench.fixed_rows::<3>(3) + lever.cross(&contact_force),
            device_force_n: -f_coupling,
            device_torque_nm: -t_coupling + anchor_lever.cross(&(-f_coupling)),
            operator_force_n: f_coupling,
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
