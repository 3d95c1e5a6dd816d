//! Planning scenes, shared by the haptic loop and the planner: static obstacles, the moving
//! object, the bounds of its reference point, the start and goal configurations, and the
//! route a (simulated) operator intends to take.
//!
//! Frames and units: the scene frame is right-handed with Z up, lengths in metres, angles
//! in radians. Obstacle poses are in the scene frame; moving-object part poses are in the
//! object frame, whose origin is the object's *reference point* (the point that
//! configurations and the bounds talk about).
//!
//! Code map:
//! - this file: the model ([`Scene`], [`Part`], [`Primitive`], [`Bounds`]), validation,
//!   [`SceneError`];
//! - [`pose`]: the [`Se3`] pose type and rotation-vector helpers;
//! - `file` / `mesh`: the TOML format (`scene/scenes/README.md`) and OBJ / STL meshes;
//! - `builtin`: the papers' scenes, built in code ([`BUILTIN_NAMES`]); `export` writes
//!   them as TOML + OBJ;
//! - [`shapes`]: parry shapes of parts, the one conversion both processes use;
//! - [`topology`]: whether a mesh is closed and wound outward ([`Scene::mesh_checks`]);
//! - [`repair`]: meshes as exported made closed and outward where they can be (twins,
//!   duplicates and degenerate triangles dropped, winding made consistent and outward),
//!   done on load ([`Scene::repair_meshes`]).
//!
//! Validation here covers numbers, sizes and bounds; whether start and goal are collision
//! free is checked by the caller that owns a collision checker (`Planner::new` does it).
#![warn(missing_docs)]
#![deny(unsafe_code)]

mod builtin;
pub mod coarse;
mod export;
mod file;
mod mesh;
pub mod pose;
pub mod progress;
pub mod repair;
pub mod shapes;
mod stl;
pub mod topology;
mod weld;

pub use builtin::BUILTIN_NAMES;
pub use mesh::{Bumps, MeshData, MeshError, bounding_box};
pub use pose::Se3;
pub use weld::weld;

use nalgebra::Vector3;
use std::path::Path;
use std::sync::Arc;

/// A geometric primitive in its own local frame (centred on the local origin).
#[derive(Clone, Debug, PartialEq)]
pub enum Primitive {
    /// A box (cuboid) with the given half extents along its local x, y, z axes (m, > 0).
    Box {
        /// Half extents (m), each strictly positive.
        half_extents_m: Vector3<f64>,
    },
    /// A sphere (m, radius > 0).
    Sphere {
        /// Radius (m), strictly positive.
        radius_m: f64,
    },
    /// A triangle mesh (vertices in m, local frame), shared because meshes can be large.
    Mesh {
        /// The validated mesh.
        mesh: Arc<MeshData>,
    },
}

/// A primitive placed by a pose (obstacles: in the scene frame; object parts: in the
/// object frame).
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    /// The shape.
    pub primitive: Primitive,
    /// Pose of the primitive's local frame in the parent frame.
    pub pose: Se3,
}

impl Part {
    /// Largest distance from the parent frame's origin to a point of the part (m).
    pub fn reach_m(&self) -> f64 {
        match &self.primitive {
            Primitive::Box { half_extents_m: h } => {
                let mut r: f64 = 0.0;
                for corner in 0..8 {
                    let sign = |bit: u32| if corner & (1 << bit) == 0 { -1.0 } else { 1.0 };
                    let c = Vector3::new(sign(0) * h.x, sign(1) * h.y, sign(2) * h.z);
                    r = r.max(self.pose.transform_point(&c).norm());
                }
                r
            }
            Primitive::Sphere { radius_m } => self.pose.pos.norm() + radius_m,
            Primitive::Mesh { mesh } => mesh.reach_m(|v| self.pose.transform_point(v)),
        }
    }

    /// A box of half extents `(hx, hy, hz)` (m) centred at `(x, y, z)` (m), axis aligned.
    pub fn axis_box(half: [f64; 3], centre: [f64; 3]) -> Self {
        Part {
            primitive: Primitive::Box {
                half_extents_m: Vector3::from(half),
            },
            pose: Se3::from_xyz(centre[0], centre[1], centre[2]),
        }
    }
}

/// Axis-aligned box for the reference point of the moving object, scene frame (m).
/// `min_m[i] <= max_m[i]` (equal pins that coordinate).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Lower corner (m).
    pub min_m: Vector3<f64>,
    /// Upper corner (m).
    pub max_m: Vector3<f64>,
}

impl Bounds {
    /// True when `p` (m, scene frame) lies inside the closed box.
    pub fn contains(&self, p: &Vector3<f64>) -> bool {
        (0..3).all(|i| p[i] >= self.min_m[i] && p[i] <= self.max_m[i])
    }
}

/// Which configuration space a scene is planned in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SpaceKind {
    /// Free-flying rigid object: 3 translations, 3 rotations.
    #[default]
    Se3,
    /// Planar object (I-RRT §5.2 and §6): x, y and a rotation θ about z; z stays at the
    /// start's height and the rotation is the start's tilt composed with θ about scene z.
    Planar,
}

/// One step of the route an operator intends to take, scene frame: where to bring the
/// object next, and whether to press it against a surface on the way (H-RRT-C's sliding
/// in contact).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RouteStep {
    /// Configuration to bring the object to.
    pub pose: Se3,
    /// Force the operator presses with while heading here, N, scene frame (pushing the
    /// object onto a surface to slide along it); zero for free motion.
    pub press_n: Vector3<f64>,
    /// Pause on arrival, s (≥ 0).
    pub dwell_s: f64,
}

impl RouteStep {
    /// A free-motion step to `pose`.
    pub fn to(pose: Se3) -> Self {
        RouteStep {
            pose,
            press_n: Vector3::zeros(),
            dwell_s: 0.0,
        }
    }

    /// This step pressing with `press_n` (N, scene frame).
    pub fn pressing(self, press_n: [f64; 3]) -> Self {
        RouteStep {
            press_n: Vector3::from(press_n),
            ..self
        }
    }
}

/// A complete planning scene. See the module docs for frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Human-readable name (e.g. `wall-hole`).
    pub name: String,
    /// Static obstacles, poses in the scene frame. May be empty.
    pub obstacles: Vec<Part>,
    /// Parts of the moving object, poses relative to its reference point. Not empty.
    pub moving_object: Vec<Part>,
    /// Bounds of the reference point (m, scene frame).
    pub bounds: Bounds,
    /// Start configuration of the object (scene frame).
    pub start: Se3,
    /// Goal configuration of the object (scene frame).
    pub goal: Se3,
    /// Configuration space to plan in.
    pub space: SpaceKind,
    /// The steps an operator takes between start and goal (the operator's intent, not a
    /// solution: it may need the right orientation only roughly, and contact on the way);
    /// empty: straight from start to goal. See [`Scene::operator_route`].
    pub route: Vec<RouteStep>,
}

/// Why a scene could not be loaded or is invalid. Every variant names its origin (a file
/// path or `<embedded>`).
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{origin}: cannot read scene file: {error}")]
    Io {
        /// File path.
        origin: String,
        /// The I/O error.
        error: std::io::Error,
    },
    /// The TOML text is malformed or has a bad value; the message carries line and column.
    #[error("{origin}: {message}")]
    Parse {
        /// File path or label.
        origin: String,
        /// toml's message, with line, column and a snippet.
        message: String,
    },
    /// A mesh referenced by `field` could not be loaded; the mesh error names its file and
    /// line.
    #[error("{origin}{}: field `{field}`: {error}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Mesh {
        /// Scene file path.
        origin: String,
        /// 1-based line of the part's table in the scene file, when known.
        line: Option<usize>,
        /// The part, e.g. `moving_object[0]`.
        field: String,
        /// The mesh error (boxed: keeps `SceneError` small).
        error: Box<MeshError>,
    },
    /// The scene parsed but a field is invalid.
    #[error("{origin}{}: field `{field}`: {reason}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Invalid {
        /// File path or label.
        origin: String,
        /// 1-based line of the offending table, when known.
        line: Option<usize>,
        /// Dotted field path, e.g. `obstacles[2].half_extents_m`.
        field: String,
        /// What is wrong.
        reason: String,
    },
}

/// The topology of one mesh part of a scene and what loading did to it (see
/// [`Scene::mesh_checks`]).
#[derive(Debug, Clone, PartialEq)]
pub struct MeshCheck {
    /// The part, e.g. `obstacles[2]` or `moving_object[0]`.
    pub field: String,
    /// Where the mesh came from (its file).
    pub source: String,
    /// What its triangles bound, as they are in the scene (after any repair).
    pub topology: topology::Topology,
    /// What [`repair::repair`] found and did on load; `None` for a mesh built in code.
    pub repair: Option<repair::RepairReport>,
}

impl MeshCheck {
    /// True when containment and signed distances are right for it (closed, outward).
    pub fn is_ok(&self) -> bool {
        self.topology.is_closed_outward()
    }

    /// How contact can render it: the repair's verdict, or for a mesh that was never
    /// repaired, its topology's (closed and outward, open, else refused as not repaired).
    pub fn surface(&self) -> repair::Surface {
        match &self.repair {
            Some(r) => r.surface.clone(),
            None => repair::Surface::judged(&self.topology),
        }
    }
}

impl std::fmt::Display for MeshCheck {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}): {}", self.source, self.field, self.topology)
    }
}

impl Scene {
    /// The embedded default scene, I-RRT §5.3 "Simple 6D case".
    ///
    /// A 700 × 700 × 20 mm wall in the y–z plane at x = 0 (x ∈ [−0.01, 0.01] m) with an
    /// 80 × 80 mm square hole at its centre, built from 4 boxes. The moving object is an
    /// S of three 20 × 20 × 100 mm sticks lying inside a virtual 100 mm cube centred on
    /// the reference point, along three consecutive, mutually perpendicular edges:
    /// an x-edge at (y, z) = (−, −), a y-edge at (x, z) = (+, −), a z-edge at
    /// (x, y) = (+, +). Bounds keep the reference point in x ∈ [−0.30, 0.30],
    /// y, z ∈ [−0.25, 0.25] m: the object reaches at most √3·0.05 ≈ 0.087 m from it, so it
    /// can never pass around the wall (0.35 m half size). Start (−0.2, 0, 0) and goal
    /// (+0.2, 0, 0), identity orientation.
    pub fn wall_with_hole() -> Scene {
        Self::wall_with_square_hole(0.08)
    }

    /// A 20 mm cube from x = −0.15 to 0.15 m past a 60 × 160 × 160 mm box in the middle:
    /// no narrow passage, but no straight way either; no route. The smallest scene an
    /// operator who does not know the way has to think about (tests of the coarse way and
    /// the newcomer).
    pub fn box_between() -> Scene {
        Scene {
            name: "box-between".into(),
            obstacles: vec![Part::axis_box([0.03, 0.08, 0.08], [0.0, 0.0, 0.0])],
            moving_object: vec![Part::axis_box([0.01, 0.01, 0.01], [0.0, 0.0, 0.0])],
            bounds: Bounds {
                min_m: Vector3::new(-0.2, -0.15, -0.15),
                max_m: Vector3::new(0.2, 0.15, 0.15),
            },
            start: Se3::from_xyz(-0.15, 0.0, 0.0),
            goal: Se3::from_xyz(0.15, 0.0, 0.0),
            space: SpaceKind::Se3,
            route: Vec::new(),
        }
    }

    /// [`Scene::wall_with_hole`] with a square hole of side `hole_side_m` (m, in
    /// (0, 0.7)) instead of 80 mm; named `wall-hole-<side in mm>` unless the side is 80 mm.
    /// Larger holes give easier scenes for tests.
    pub fn wall_with_square_hole(hole_side_m: f64) -> Scene {
        // Wall half thickness, half size, hole half size (m).
        let (t, w, h) = (0.01, 0.35, 0.5 * hole_side_m);
        let side = 0.5 * (w - h); // half extent of a frame box across the hole
        let mid = 0.5 * (w + h); // centre offset of a frame box
        let obstacles = vec![
            Part::axis_box([t, w, side], [0.0, 0.0, mid]),
            Part::axis_box([t, w, side], [0.0, 0.0, -mid]),
            Part::axis_box([t, side, h], [0.0, mid, 0.0]),
            Part::axis_box([t, side, h], [0.0, -mid, 0.0]),
        ];
        let (s, e) = (0.01, 0.04); // stick half width, offset of a stick axis from centre
        let moving_object = vec![
            Part::axis_box([0.05, s, s], [0.0, -e, -e]),
            Part::axis_box([s, 0.05, s], [e, 0.0, -e]),
            Part::axis_box([s, s, 0.05], [e, e, 0.0]),
        ];
        Scene {
            name: if hole_side_m == 0.08 {
                "wall-hole".to_owned()
            } else {
                format!("wall-hole-{:.0}", hole_side_m * 1000.0)
            },
            obstacles,
            moving_object,
            bounds: Bounds {
                min_m: Vector3::new(-0.30, -0.25, -0.25),
                max_m: Vector3::new(0.30, 0.25, 0.25),
            },
            start: Se3::from_xyz(-0.20, 0.0, 0.0),
            goal: Se3::from_xyz(0.20, 0.0, 0.0),
            space: SpaceKind::Se3,
            route: builtin::wall_hole_route(hole_side_m),
        }
    }

    /// A built-in scene by name (see [`BUILTIN_NAMES`]; `default` is `wall-hole`);
    /// anything else is read as a TOML file path.
    pub fn by_name_or_path(s: &str) -> Result<Scene, SceneError> {
        match Scene::builtin(s) {
            Some(scene) => Ok(scene),
            None => Scene::load(Path::new(s)),
        }
    }

    /// Reads and validates a TOML scene file (format: see `scene/scenes/wall-hole.toml`).
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|error| SceneError::Io {
            origin: origin.clone(),
            error,
        })?;
        Scene::from_toml_str(&text, &origin)
    }

    /// Parses and validates TOML scene text; `origin` names it in errors (a path).
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Scene, SceneError> {
        file::parse(text, origin)
    }

    /// Repairs every mesh part that has not been ([`repair::repair`]; a scene file's
    /// meshes are, on load), recording the report in the mesh ([`MeshData::repair`]).
    /// Refused meshes stay as they were. Meshes with nothing to repair keep their
    /// triangles as they are, so planning on them is unchanged.
    pub fn repair_meshes(&mut self) {
        for part in self
            .obstacles
            .iter_mut()
            .chain(self.moving_object.iter_mut())
        {
            if let Primitive::Mesh { mesh } = &mut part.primitive
                && mesh.repair.is_none()
            {
                *mesh = Arc::new(repair::repair(mesh).into_mesh());
            }
        }
    }

    /// The topology of every mesh part, obstacles then object, with what loading did to
    /// it. Planning works on any triangles; contact rendering needs each mesh closed and
    /// wound outward ([`MeshCheck::is_ok`]) or, as a thin shell, open
    /// ([`MeshCheck::surface`]); callers log the repairs and warn about the others.
    pub fn mesh_checks(&self) -> Vec<MeshCheck> {
        let lists = [
            ("obstacles", &self.obstacles),
            ("moving_object", &self.moving_object),
        ];
        let mut out = Vec::new();
        for (list, parts) in lists {
            for (i, part) in parts.iter().enumerate() {
                if let Primitive::Mesh { mesh } = &part.primitive {
                    out.push(MeshCheck {
                        field: format!("{list}[{i}]"),
                        source: mesh.source.clone(),
                        topology: topology::Topology::of(mesh),
                        repair: mesh.repair.as_deref().cloned(),
                    });
                }
            }
        }
        out
    }

    /// One line per mesh part that loading repaired, that is open (contact renders it as
    /// a thin shell, also when its inside cannot be told) or that contact refuses, for the log:
    /// `(is a warning, line)`. Reads the repair's report; judges a mesh that never went
    /// through the repair from its topology.
    pub fn mesh_notes(&self) -> Vec<(bool, String)> {
        use repair::Surface;
        let lists = [
            ("obstacles", &self.obstacles),
            ("moving_object", &self.moving_object),
        ];
        let mut notes = Vec::new();
        for (list, parts) in lists {
            for (i, part) in parts.iter().enumerate() {
                let Primitive::Mesh { mesh } = &part.primitive else {
                    continue;
                };
                let field = format!("{list}[{i}]");
                let report = mesh.repair.as_deref();
                let note = match (mesh.surface(), report) {
                    (Surface::Refused(why), None) => Some((
                        true,
                        format!(
                            "mesh {} ({field}): {why}; contact rendering refuses it (see `planner scenes check`)",
                            mesh.source
                        ),
                    )),
                    (Surface::Refused(_), Some(r)) => Some((
                        true,
                        format!(
                            "{field} {r}; contact rendering refuses it (see `planner scenes check`)"
                        ),
                    )),
                    (Surface::Open, Some(r)) => Some((true, format!("{field} {r}"))),
                    (Surface::Open, None) => Some((
                        true,
                        format!(
                            "mesh {} ({field}) is open; contact renders it as a thin shell",
                            mesh.source
                        ),
                    )),
                    (Surface::ClosedOutward, Some(r)) if r.changed() => {
                        Some((false, format!("{field} {r}")))
                    }
                    (Surface::ClosedOutward, _) => None,
                };
                notes.extend(note);
            }
        }
        notes
    }

    /// Largest distance from the reference point to any point of the object (m).
    pub fn object_radius_m(&self) -> f64 {
        self.moving_object
            .iter()
            .map(Part::reach_m)
            .fold(0.0, f64::max)
    }

    /// Checks finiteness, positive sizes, a non-empty object, ordered bounds, and start
    /// and goal inside the bounds. Does not check collisions. `origin` labels errors.
    pub fn validate(&self, origin: &str) -> Result<(), SceneError> {
        let bad = |field: String, reason: &str| SceneError::Invalid {
            origin: origin.to_owned(),
            line: None,
            field,
            reason: reason.to_owned(),
        };
        let parts = [
            ("obstacles", &self.obstacles),
            ("moving_object", &self.moving_object),
        ];
        for (list, items) in parts {
            for (i, part) in items.iter().enumerate() {
                if !part.pose.is_finite() {
                    return Err(bad(format!("{list}[{i}].pose"), "must be finite"));
                }
                let ok = match &part.primitive {
                    Primitive::Box { half_extents_m } => {
                        half_extents_m.iter().all(|v| v.is_finite() && *v > 0.0)
                    }
                    Primitive::Sphere { radius_m } => radius_m.is_finite() && *radius_m > 0.0,
                    Primitive::Mesh { mesh } => {
                        !mesh.triangles.is_empty()
                            && mesh
                                .vertices_m
                                .iter()
                                .all(|v| v.iter().all(|c| c.is_finite()))
                            && mesh
                                .triangles
                                .iter()
                                .flatten()
                                .all(|&i| (i as usize) < mesh.vertices_m.len())
                    }
                };
                if !ok {
                    return Err(bad(format!("{list}[{i}]"), "sizes must be finite and > 0"));
                }
            }
        }
        if self.moving_object.is_empty() {
            return Err(bad("moving_object".into(), "needs at least one part"));
        }
        let b = &self.bounds;
        let finite = b.min_m.iter().chain(b.max_m.iter()).all(|v| v.is_finite());
        if !finite || (0..3).any(|i| b.min_m[i] > b.max_m[i]) {
            return Err(bad("bounds".into(), "must be finite with min_m <= max_m"));
        }
        if self.space == SpaceKind::Planar {
            let tilt = self.goal.rot * self.start.rot.inverse();
            let about_z = tilt
                .axis()
                .is_none_or(|a| a.x.abs() < 1e-9 && a.y.abs() < 1e-9);
            if (self.goal.pos.z - self.start.pos.z).abs() > 1e-9 || !about_z {
                return Err(bad(
                    "goal".into(),
                    "a planar scene's goal must have the start's z and differ from it by a rotation about z",
                ));
            }
        }
        for (field, q) in [("start", &self.start), ("goal", &self.goal)] {
            if !q.is_finite() {
                return Err(bad(field.into(), "must be finite"));
            }
            if !b.contains(&q.pos) {
                return Err(bad(field.into(), "position_m is outside bounds"));
            }
        }
        for (i, step) in self.route.iter().enumerate() {
            let field = format!("route[{i}]");
            if !step.pose.is_finite() {
                return Err(bad(field, "pose must be finite"));
            }
            if !b.contains(&step.pose.pos) {
                return Err(bad(field, "position_m is outside bounds"));
            }
            if !step.press_n.iter().all(|v| v.is_finite()) {
                return Err(bad(field, "press_n must be finite"));
            }
            if !(step.dwell_s.is_finite() && step.dwell_s >= 0.0) {
                return Err(bad(field, "dwell_s must be finite and >= 0"));
            }
        }
        Ok(())
    }

    /// The operator's whole route: the start, the scene's route steps, the goal.
    pub fn operator_route(&self) -> Vec<RouteStep> {
        let mut r = Vec::with_capacity(self.route.len() + 2);
        r.push(RouteStep::to(self.start));
        r.extend_from_slice(&self.route);
        r.push(RouteStep::to(self.goal));
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_scene_is_valid_and_cannot_be_bypassed() {
        let s = Scene::wall_with_hole();
        s.validate("<embedded>").expect("valid");
        // The object's reach from the bound edge stays inside the wall's 0.35 m half size.
        let reach = s.object_radius_m();
        assert!((reach - 0.05 * 3f64.sqrt()).abs() < 1e-12, "reach {reach}");
        assert!(s.bounds.max_m.y + reach < 0.35 && s.bounds.max_m.z + reach < 0.35);
        assert!(-s.bounds.min_m.y + reach < 0.35 && -s.bounds.min_m.z + reach < 0.35);
    }

    #[test]
    fn by_name_aliases_and_missing_file() {
        assert_eq!(
            Scene::by_name_or_path("default").ok(),
            Some(Scene::wall_with_hole())
        );
        assert_eq!(
            Scene::by_name_or_path("wall-hole").ok(),
            Some(Scene::wall_with_hole())
        );
        let err = Scene::by_name_or_path("/nonexistent/x.toml").unwrap_err();
        assert!(matches!(err, SceneError::Io { .. }));
        assert!(err.to_string().contains("/nonexistent/x.toml"));
    }

    #[test]
    fn every_builtin_mesh_is_closed_and_outward() {
        for name in BUILTIN_NAMES {
            let s = Scene::builtin(name).expect("builtin");
            for c in s.mesh_checks() {
                assert!(c.is_ok(), "{name}: {c}");
                assert_eq!(c.surface(), repair::Surface::ClosedOutward);
            }
        }
    }

    #[test]
    fn meshes_built_in_code_are_judged_by_their_topology_until_repaired() {
        use repair::{Refusal, Surface};
        let cube = MeshData::cuboid("cube.obj", [0.05, 0.05, 0.05]);
        let with = |triangles: Vec<[u32; 3]>| {
            let mesh = MeshData::new("m.obj", cube.vertices_m.clone(), triangles).expect("valid");
            let mut s = Scene::wall_with_hole();
            s.moving_object = vec![Part {
                primitive: Primitive::Mesh {
                    mesh: Arc::new(mesh),
                },
                pose: Se3::identity(),
            }];
            s
        };
        let open = with(cube.triangles[..10].to_vec());
        assert_eq!(open.mesh_checks()[0].surface(), Surface::Open);
        let mut both = cube.triangles.clone();
        both.extend(cube.triangles.iter().map(|&[a, b, c]| [a, c, b]));
        let mut double = with(both);
        let check = &double.mesh_checks()[0];
        assert!(check.repair.is_none() && !check.is_ok());
        assert_eq!(
            check.surface(),
            Surface::Refused(Refusal::NotRepaired {
                kind: topology::MeshKind::DoubleSided
            })
        );
        double.repair_meshes();
        let check = &double.mesh_checks()[0];
        assert!(check.is_ok(), "{check}");
        assert_eq!(check.surface(), Surface::ClosedOutward);
        assert_eq!(check.repair.as_ref().map(|r| r.twins), Some(12));
        // Once repaired, a mesh is not repaired again.
        let again = double.clone();
        double.repair_meshes();
        assert_eq!(double, again);
    }

    #[test]
    fn validate_rejects_bad_values() {
        let mut s = Scene::wall_with_hole();
        s.goal.pos.x = 0.5;
        let e = s.validate("x").unwrap_err().to_string();
        assert!(e.contains("goal"), "{e}");
        let mut s = Scene::wall_with_hole();
        s.obstacles[1].primitive = Primitive::Sphere { radius_m: 0.0 };
        let e = s.validate("x").unwrap_err().to_string();
        assert!(e.contains("obstacles[1]"), "{e}");
        let mut s = Scene::wall_with_hole();
        s.start.pos.y = f64::NAN;
        assert!(s.validate("x").is_err());
    }
}
