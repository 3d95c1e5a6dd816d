//! A built-in scene's worst steady contact for the tick budget: the moving object pressed
//! with its largest flat face onto the largest obstacle face it fits against, and slid
//! along that face (issue 21's "every contact configuration").
//!
//! * The object's face: of its pointshell's outward normals, binned to 0.05 of a unit
//!   vector's components, the bin with the most points on its supporting plane, object
//!   frame; its centre is the mean of those points.
//! * The obstacle face: the faces of the scene's box obstacles by area, largest first; the
//!   first whose placement is collision-free 2 mm off the face (the planner's own checker),
//!   trying the object turned by 0° and 90° about the face normal. The object's face
//!   normal is turned onto the obstacle face's inward normal by the shortest rotation.
//! * The route, device frame (= the placement's frame, mapped 1:1): pressed 2 cm into the
//!   face, so the coupling saturates at the arm's maximum force, then slid ±3 cm along the
//!   face's longer side for as long as the run lasts.

use crate::BenchError;
use crate::harness::scripted_arm;
use devices::sim::{SimulatedArm, Waypoint};
use haptic_loop::contact::{ContactConfig, ContactModel, ContactStage, Coupling, Pointshell};
use haptic_loop::tick::TickConfig;
use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use planner_core::CollisionChecker;
use scene::{Primitive, Scene, Se3};
use std::collections::BTreeMap;
use std::sync::Arc;

/// Gap between the faces at the start, m.
const GAP_M: f64 = 0.002;
/// How far the device target goes into the face, m.
const PUSH_M: f64 = 0.02;
/// Half the slide, m.
const SLIDE_M: f64 = 0.03;

/// Where the object was put: for the report.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    /// Pose of the object's reference point, scene frame.
    pub pose: Isometry3<f64>,
    /// Outward normal of the obstacle face, scene frame.
    pub face_normal: Vector3<f64>,
    /// Area of the obstacle face, m².
    pub face_area_m2: f64,
    /// Pointshell points on the object's face.
    pub face_points: usize,
    /// Unit vector along the obstacle face's longer side, scene frame: where it slides.
    pub slide_direction: Vector3<f64>,
}

/// The object's largest flat face: outward unit normal, centre (object frame) and the
/// number of pointshell points on it. Among the points of each normal bin only those on
/// the bin's supporting plane (within half a spacing of the outermost) count: parallel
/// faces at different heights (the S's sticks) are not one face.
pub fn largest_face(shell: &Pointshell) -> Option<(Vector3<f64>, Vector3<f64>, usize)> {
    let key = |n: &Vector3<f64>| {
        let q = |v: f64| (v * 20.0).round() as i32;
        (q(n.x), q(n.y), q(n.z))
    };
    let mut bins: BTreeMap<(i32, i32, i32), Vec<usize>> = BTreeMap::new();
    for (i, n) in shell.normals().iter().enumerate() {
        bins.entry(key(&-n)).or_default().push(i);
    }
    let (points, normals) = (shell.points(), shell.normals());
    let mut best: Option<(Vector3<f64>, Vector3<f64>, usize)> = None;
    for members in bins.values() {
        let sum: Vector3<f64> = members.iter().map(|&i| -normals[i]).sum();
        let Some(u) = sum.try_normalize(1e-9) else {
            continue;
        };
        let outermost = members
            .iter()
            .map(|&i| points[i].dot(&u))
            .fold(f64::NEG_INFINITY, f64::max);
        let on_plane: Vec<usize> = members
            .iter()
            .copied()
            .filter(|&i| points[i].dot(&u) >= outermost - 0.5 * shell.spacing_m())
            .collect();
        if best.as_ref().is_none_or(|b| on_plane.len() > b.2) {
            let centre =
                on_plane.iter().map(|&i| points[i]).sum::<Vector3<f64>>() / on_plane.len() as f64;
            best = Some((u, centre, on_plane.len()));
        }
    }
    best
}

/// A face of a box obstacle, scene frame.
struct Face {
    /// Outward unit normal.
    normal: Vector3<f64>,
    /// Centre, m.
    centre: Vector3<f64>,
    /// Unit vector along the longer in-plane side.
    long: Vector3<f64>,
    /// Area, m².
    area_m2: f64,
}

/// The faces of the scene's box obstacles, largest first.
fn box_faces(scene: &Scene) -> Vec<Face> {
    let mut faces = Vec::new();
    for part in &scene.obstacles {
        let Primitive::Box { half_extents_m: h } = &part.primitive else {
            continue;
        };
        for axis in 0..3 {
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let long = if h[a] >= h[b] { a } else { b };
            let area = 4.0 * h[a] * h[b];
            for sign in [-1.0, 1.0] {
                let n = part.pose.rot * (Vector3::ith(axis, 1.0) * sign);
                let centre = part.pose.pos + n * h[axis];
                faces.push(Face {
                    normal: n,
                    centre,
                    long: part.pose.rot * Vector3::ith(long, 1.0),
                    area_m2: area,
                });
            }
        }
    }
    faces.sort_by(|x, y| y.area_m2.total_cmp(&x.area_m2));
    faces
}

/// The placement of [`largest_face`] on the largest box face where the object fits (see
/// the module docs), or `None` when no face admits it.
pub fn place(scene: &Scene, shell: &Pointshell) -> Option<Placement> {
    let (u, c, face_points) = largest_face(shell)?;
    let checker = CollisionChecker::new(scene);
    for Face {
        normal: n,
        centre,
        long,
        area_m2: area,
    } in box_faces(scene)
    {
        // The object's face normal onto the obstacle's inward normal.
        let onto = UnitQuaternion::rotation_between(&u, &-n).unwrap_or_else(|| {
            UnitQuaternion::from_axis_angle(&orthogonal(&u), std::f64::consts::PI)
        });
        for turn in [0.0, std::f64::consts::FRAC_PI_2] {
            let rot = UnitQuaternion::from_axis_angle(&Unit::new_normalize(n), turn) * onto;
            let pos = centre + n * GAP_M - rot * c;
            let q = Se3 { pos, rot };
            if checker.is_free(&q) {
                let pose = Isometry3::from_parts(Translation3::from(pos), rot);
                return Some(Placement {
                    pose,
                    face_normal: n,
                    face_area_m2: area,
                    face_points,
                    slide_direction: long,
                });
            }
        }
    }
    None
}

/// A unit vector orthogonal to `v`.
fn orthogonal(v: &Vector3<f64>) -> Unit<Vector3<f64>> {
    let other = if v.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    Unit::new_normalize(v.cross(&other))
}

/// The simulated arm pressing `scene`'s object onto its face (see the module docs) for
/// `seconds`, the tick at `rate_hz`, and the contact stage at `voxel_m`.
pub fn face_setup(
    scene: &Scene,
    rate_hz: f64,
    seconds: f64,
    voxel_m: f64,
) -> Result<(SimulatedArm, TickConfig, ContactStage, Placement), BenchError> {
    let contact = ContactConfig::with_voxel_m(voxel_m);
    let model = ContactModel::from_scene(scene, &contact.voxmap)?;
    let Some(placement) = place(scene, model.pointshell()) else {
        return Err(BenchError::NoFace(scene.name.clone()));
    };
    // Device displacements are turned by the placement's rotation into the scene.
    let inv = placement.pose.rotation.inverse();
    let push = inv * (-placement.face_normal * PUSH_M);
    let slide = inv * (placement.slide_direction * SLIDE_M);
    let at = |d: Vector3<f64>| Waypoint::new(Isometry3::translation(d.x, d.y, d.z));
    let mut route = vec![at(Vector3::zeros()), at(push)];
    for _ in 0..((seconds / 4.0).ceil() as usize).max(1) {
        route.extend([at(push + slide), at(push - slide)]);
    }
    let (arm, config, spec) = scripted_arm(route, placement.pose, rate_hz)?;
    let coupling = Coupling::from_spec(&spec, 1.0, contact.coupling_fraction);
    let stage = ContactStage::new(Arc::new(model), contact, coupling);
    Ok((arm, config, stage, placement))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_built_in_scene_has_a_face_placement_off_its_obstacles() {
        for name in [
            "wall-hole",
            "tunnels",
            "crossing-planes",
            "silencer",
            "maze",
            "bug-trap",
        ] {
            let scene = Scene::builtin(name).unwrap();
            let model =
                ContactModel::from_scene(&scene, &ContactConfig::with_voxel_m(0.002).voxmap)
                    .unwrap();
            let p = place(&scene, model.pointshell()).unwrap_or_else(|| panic!("{name}"));
            // Free at the placement, touching 2 mm further in.
            let checker = CollisionChecker::new(&scene);
            let q = |d: f64| Se3 {
                pos: p.pose.translation.vector - p.face_normal * d,
                rot: p.pose.rotation,
            };
            assert!(checker.is_free(&q(0.0)), "{name}");
            assert!(
                !checker.is_free(&q(GAP_M + 0.001)),
                "{name}: no face 3 mm below"
            );
            assert!(
                p.face_points >= 20,
                "{name}: {} points on the face",
                p.face_points
            );
        }
    }

    #[test]
    fn the_largest_face_of_a_flat_plate_is_one_of_its_broad_sides() {
        let scene = Scene::crossing_planes();
        let model =
            ContactModel::from_scene(&scene, &ContactConfig::with_voxel_m(0.002).voxmap).unwrap();
        let (u, c, n) = largest_face(model.pointshell()).unwrap();
        assert!((u.z.abs() - 1.0).abs() < 1e-6, "{u}");
        assert!((c.z.abs() - 0.004).abs() < 0.0015, "{c}");
        // A 120 × 120 mm side at 2 mm spacing holds about 3 600 points.
        assert!((3000..4000).contains(&n), "{n} points");
    }
}
