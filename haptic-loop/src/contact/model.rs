//! [`ContactModel`]: what start-up builds once per scene (voxmap, pointshell levels, the
//! object's mass properties), with open meshes as shells and the voxmap cache.

use super::near::ShellColumns;
use super::voxmap::{self, Obstacle, Surface, Voxmap, VoxmapConfig};
use super::{ContactError, Pointshell, Progress};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use parry3d_f64::mass_properties::MassProperties;
use parry3d_f64::math::Pose;
use parry3d_f64::shape::SharedShape;
use scene::Scene;
use std::time::Instant;

/// What init builds once per scene: voxmap, pointshell, and the object's mass properties.
/// Shared read-only (`Arc`) between the contact stage and, e.g., tests.
#[derive(Debug)]
pub struct ContactModel {
    pub(super) voxmap: Voxmap,
    /// The pointshell's levels of detail, finest (every point) first.
    pub(super) shells: Vec<Pointshell>,
    /// Each level as the search reads it.
    pub(super) columns: Vec<ShellColumns>,
    /// Centre of mass, object frame, m.
    pub(super) com_local: Vector3<f64>,
    /// Inertia tensor about the centre of mass per kg of mass, object frame, m².
    pub(super) inertia_per_kg: Matrix3<f64>,
    /// Radius about the centre of mass holding every point, m.
    pub(super) radius_m: f64,
    /// Pointshell build time, s.
    pub(super) shell_build_s: f64,
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
    /// [`VoxmapConfig::shell_voxels`] around its surface, with a warning (so is a closed one
    /// whose inside cannot be told: repair makes it open, saying why); a mesh without a
    /// surface is refused ([`ContactError::Mesh`]), naming why. With a
    /// `cache_dir`, the voxmap is read from there when it was built from the same inputs
    /// before, and written there when built (`voxmap::cache`).
    pub fn from_scene_with(
        scene: &Scene,
        voxmap: &VoxmapConfig,
        control: &Progress,
        cache_dir: Option<&std::path::Path>,
    ) -> Result<Self, ContactError> {
        use scene::repair::Surface as Found;
        let obstacles = Self::obstacles(scene, voxmap)?;
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

    /// The obstacles of `scene` as [`Self::from_scene_with`] voxelises them: primitives as
    /// parry shapes; a closed, outward mesh solid; an open one a shell of
    /// [`VoxmapConfig::shell_voxels`] (with a warning); a mesh whose inside cannot be told
    /// refused ([`ContactError::Mesh`]).
    pub fn obstacles(scene: &Scene, voxmap: &VoxmapConfig) -> Result<Vec<Obstacle>, ContactError> {
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
        Ok(obstacles)
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
pub(super) fn shell_mass_properties(
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
