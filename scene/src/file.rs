//! TOML scene format. Example (`scene/scenes/wall-hole.toml`):
//!
//! ```toml
//! name = "wall-hole"            # optional
//! [bounds]                      # reference point bounds, scene frame (m)
//! min_m = [-0.30, -0.25, -0.25]
//! max_m = [0.30, 0.25, 0.25]
//! [start]                       # and [goal]: position (m), roll-pitch-yaw (rad)
//! position_m = [-0.2, 0.0, 0.0]
//! rpy_rad = [0.0, 0.0, 0.0]     # optional, Rz(yaw)·Ry(pitch)·Rx(roll)
//! [[obstacles]]                 # pose in the scene frame
//! shape = "box"                 # "box" needs half_extents_m, "sphere" needs radius_m
//! half_extents_m = [0.01, 0.35, 0.155]
//! position_m = [0.0, 0.0, 0.195]
//! [[moving_object]]             # pose relative to the object's reference point
//! shape = "sphere"
//! radius_m = 0.02
//! [[moving_object]]
//! shape = "mesh"                # a triangle mesh: OBJ or STL (ASCII or binary)
//! file = "meshes/part.obj"      # relative to this scene file's directory
//! scale = 0.001                 # optional, m per file unit (default 1: file in m)
//! ```
//!
//! `space = "planar"` (top level, default `"se3"`) plans in (x, y, θ): z stays at the
//! start's, rotations are about the scene z axis; set `min_m.z = max_m.z`.
//!
//! Unknown keys are rejected. Bad numbers (non-finite, non-positive sizes) are reported
//! with toml's line and column; semantic errors name the field and the line of its table;
//! mesh errors name the scene file, the part, the mesh file and the mesh's line.

use super::{Bounds, MeshData, Part, Primitive, RouteStep, Scene, SceneError, SpaceKind};
use crate::pose::Se3;
use nalgebra::Vector3;
use serde::Deserialize;
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;
use toml::Spanned;

/// A finite number; rejected during deserialisation so toml reports the value's span.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(try_from = "f64")]
struct Finite(f64);

impl TryFrom<f64> for Finite {
    type Error = String;
    fn try_from(v: f64) -> Result<Self, String> {
        if v.is_finite() {
            Ok(Finite(v))
        } else {
            Err(format!("number must be finite, got {v}"))
        }
    }
}

/// A finite, strictly positive size (m).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(try_from = "f64")]
struct Positive(f64);

impl TryFrom<f64> for Positive {
    type Error = String;
    fn try_from(v: f64) -> Result<Self, String> {
        if v.is_finite() && v > 0.0 {
            Ok(Positive(v))
        } else {
            Err(format!("size must be finite and > 0, got {v}"))
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    name: Option<String>,
    #[serde(default)]
    space: SpaceFile,
    bounds: Spanned<BoundsFile>,
    start: Spanned<PoseFile>,
    goal: Spanned<PoseFile>,
    #[serde(default)]
    obstacles: Vec<Spanned<PartFile>>,
    moving_object: Vec<Spanned<PartFile>>,
    #[serde(default)]
    route: Vec<Spanned<RouteFile>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RouteFile {
    position_m: [Finite; 3],
    #[serde(default)]
    rpy_rad: [Finite; 3],
    #[serde(default)]
    press_n: [Finite; 3],
    #[serde(default)]
    dwell_s: Finite,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BoundsFile {
    min_m: [Finite; 3],
    max_m: [Finite; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PoseFile {
    position_m: [Finite; 3],
    #[serde(default)]
    rpy_rad: [Finite; 3],
}

#[derive(Deserialize, Default)]
#[serde(rename_all = "lowercase")]
enum SpaceFile {
    #[default]
    Se3,
    Planar,
}

#[derive(Deserialize)]
#[serde(rename_all = "lowercase")]
enum ShapeKind {
    Box,
    Sphere,
    Mesh,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PartFile {
    shape: ShapeKind,
    half_extents_m: Option<[Positive; 3]>,
    radius_m: Option<Positive>,
    file: Option<Spanned<String>>,
    scale: Option<Spanned<Positive>>,
    #[serde(default)]
    position_m: [Finite; 3],
    #[serde(default)]
    rpy_rad: [Finite; 3],
}

fn vec3(v: &[Finite; 3]) -> Vector3<f64> {
    Vector3::new(v[0].0, v[1].0, v[2].0)
}

fn pose(position_m: &[Finite; 3], rpy_rad: &[Finite; 3]) -> Se3 {
    Se3::from_rpy(vec3(position_m), rpy_rad[0].0, rpy_rad[1].0, rpy_rad[2].0)
}

/// 1-based line number of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

pub(super) fn parse(text: &str, origin: &str) -> Result<Scene, SceneError> {
    let raw: SceneFile = toml::from_str(text).map_err(|e| SceneError::Parse {
        origin: origin.to_owned(),
        message: e.to_string(),
    })?;
    let base_dir = Path::new(origin).parent().unwrap_or(Path::new(""));
    // Spans of the top-level tables, to give semantic errors a line.
    let mut spans: Vec<(String, usize)> = vec![
        ("bounds".into(), raw.bounds.span().start),
        ("start".into(), raw.start.span().start),
        ("goal".into(), raw.goal.span().start),
    ];
    let mut convert = |list: &str, items: &[Spanned<PartFile>]| -> Result<Vec<Part>, SceneError> {
        let mut out = Vec::with_capacity(items.len());
        for (i, item) in items.iter().enumerate() {
            let field = format!("{list}[{i}]");
            spans.push((field.clone(), item.span().start));
            let p = item.get_ref();
            let line = Some(line_of(text, item.span().start));
            let sizes = (&p.half_extents_m, &p.radius_m, &p.file, &p.scale);
            let primitive = match (&p.shape, sizes) {
                (ShapeKind::Box, (Some(h), None, None, None)) => Primitive::Box {
                    half_extents_m: Vector3::new(h[0].0, h[1].0, h[2].0),
                },
                (ShapeKind::Sphere, (None, Some(r), None, None)) => {
                    Primitive::Sphere { radius_m: r.0 }
                }
                (ShapeKind::Mesh, (None, None, Some(f), scale)) => {
                    let path = base_dir.join(f.get_ref());
                    let scale = scale.as_ref().map_or(1.0, |s| s.get_ref().0);
                    let mesh = MeshData::load(&path, scale).map_err(|source| SceneError::Mesh {
                        origin: origin.to_owned(),
                        line,
                        field: format!("{field}.file"),
                        error: Box::new(source),
                    })?;
                    Primitive::Mesh {
                        mesh: Arc::new(mesh),
                    }
                }
                _ => {
                    return Err(SceneError::Invalid {
                        origin: origin.to_owned(),
                        line,
                        field,
                        reason: "a box needs exactly `half_extents_m`, a sphere exactly \
                                 `radius_m`, a mesh `file` and optionally `scale`"
                            .into(),
                    });
                }
            };
            out.push(Part {
                primitive,
                pose: pose(&p.position_m, &p.rpy_rad),
            });
        }
        Ok(out)
    };
    let obstacles = convert("obstacles", &raw.obstacles)?;
    let moving_object = convert("moving_object", &raw.moving_object)?;
    let (start, goal) = (raw.start.get_ref(), raw.goal.get_ref());
    let mut route = Vec::with_capacity(raw.route.len());
    for (i, item) in raw.route.iter().enumerate() {
        spans.push((format!("route[{i}]"), item.span().start));
        let r = item.get_ref();
        route.push(RouteStep {
            pose: pose(&r.position_m, &r.rpy_rad),
            press_n: vec3(&r.press_n),
            dwell_s: r.dwell_s.0,
        });
    }
    let mut scene = Scene {
        name: raw.name.clone().unwrap_or_else(|| default_name(origin)),
        obstacles,
        moving_object,
        bounds: Bounds {
            min_m: vec3(&raw.bounds.get_ref().min_m),
            max_m: vec3(&raw.bounds.get_ref().max_m),
        },
        start: pose(&start.position_m, &start.rpy_rad),
        goal: pose(&goal.position_m, &goal.rpy_rad),
        space: match raw.space {
            SpaceFile::Se3 => SpaceKind::Se3,
            SpaceFile::Planar => SpaceKind::Planar,
        },
        route,
    };
    scene.validate(origin).map_err(|e| match e {
        SceneError::Invalid {
            origin,
            field,
            reason,
            ..
        } => {
            let table = field.split('.').next().unwrap_or(&field);
            let line = spans
                .iter()
                .find(|(name, _)| name == table)
                .map(|(_, off)| line_of(text, *off));
            SceneError::Invalid {
                origin,
                line,
                field,
                reason,
            }
        }
        other => other,
    })?;
    scene.repair_meshes();
    Ok(scene)
}

/// `text`, a scene file, with the `file` of each part named in `files` (e.g.
/// `obstacles[0]` → `meshes/part.repaired.obj`) replaced and its `scale`, if any, set to 1
/// (the new files are in metres); everything else, comments included, as it was.
pub(super) fn retarget_mesh_files(
    text: &str,
    origin: &str,
    files: &HashMap<String, String>,
) -> Result<String, SceneError> {
    let raw: SceneFile = toml::from_str(text).map_err(|e| SceneError::Parse {
        origin: origin.to_owned(),
        message: e.to_string(),
    })?;
    let mut edits = Vec::new();
    for (list, items) in [
        ("obstacles", &raw.obstacles),
        ("moving_object", &raw.moving_object),
    ] {
        for (i, item) in items.iter().enumerate() {
            let Some(new) = files.get(&format!("{list}[{i}]")) else {
                continue;
            };
            let p = item.get_ref();
            if let Some(f) = &p.file {
                edits.push((f.span(), toml::Value::String(new.clone()).to_string()));
            }
            if let Some(s) = &p.scale {
                edits.push((s.span(), "1.0".to_owned()));
            }
        }
    }
    // Back to front, so that earlier spans stay where they were.
    edits.sort_by_key(|(span, _)| std::cmp::Reverse(span.start));
    let mut out = text.to_owned();
    for (span, new) in edits {
        out.replace_range(span, &new);
    }
    Ok(out)
}

/// The file stem of `origin`, or `origin` itself.
fn default_name(origin: &str) -> String {
    std::path::Path::new(origin)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| origin.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    const SHIPPED: &str = include_str!("../scenes/wall-hole.toml");

    fn close(a: &Se3, b: &Se3) -> bool {
        (a.pos - b.pos).norm() < 1e-12 && a.rot.angle_to(&b.rot) < 1e-12
    }

    #[test]
    fn shipped_file_equals_embedded_scene() {
        let f = Scene::from_toml_str(SHIPPED, "scenes/wall-hole.toml").expect("parses");
        let e = Scene::wall_with_hole();
        assert_eq!(f.name, e.name);
        assert_eq!(f.bounds, e.bounds);
        assert!(close(&f.start, &e.start) && close(&f.goal, &e.goal));
        for (a, b) in [
            (&f.obstacles, &e.obstacles),
            (&f.moving_object, &e.moving_object),
        ] {
            assert_eq!(a.len(), b.len());
            for (pa, pb) in a.iter().zip(b) {
                assert!(close(&pa.pose, &pb.pose), "{pa:?} vs {pb:?}");
                let (Primitive::Box { half_extents_m: ha }, Primitive::Box { half_extents_m: hb }) =
                    (&pa.primitive, &pb.primitive)
                else {
                    panic!("not boxes");
                };
                assert!((ha - hb).norm() < 1e-12);
            }
        }
    }

    const MINIMAL: &str = r#"
[bounds]
min_m = [-1, -1, -1]
max_m = [1, 1, 1]
[start]
position_m = [0, 0, 0]
[goal]
position_m = [0.5, 0, 0]
[[moving_object]]
shape = "sphere"
radius_m = 0.1
"#;

    #[test]
    fn minimal_file_parses_with_defaults() {
        let s = Scene::from_toml_str(MINIMAL, "dir/mini.toml").expect("parses");
        assert_eq!(s.name, "mini");
        assert!(s.obstacles.is_empty());
        assert_eq!(
            s.moving_object[0].primitive,
            Primitive::Sphere { radius_m: 0.1 }
        );
    }

    #[test]
    fn a_route_parses_and_a_bad_step_is_named_with_its_line() {
        let text = format!(
            "{MINIMAL}\n[[route]]\nposition_m = [0.1, 0, 0]\n\n[[route]]\nposition_m = [0.2, 0, 0]\nrpy_rad = [0, 0, 1]\npress_n = [0, 0, -2]\ndwell_s = 0.5\n"
        );
        let s = Scene::from_toml_str(&text, "r.toml").expect("parses");
        assert_eq!(s.route.len(), 2);
        assert_eq!(s.route[0], RouteStep::to(Se3::from_xyz(0.1, 0.0, 0.0)));
        assert_eq!(s.route[1].press_n, Vector3::new(0.0, 0.0, -2.0));
        assert_eq!(s.route[1].dwell_s, 0.5);
        assert!((s.route[1].pose.rot.angle() - 1.0).abs() < 1e-12);
        let whole = s.operator_route();
        assert_eq!(whole.len(), 4);
        assert_eq!(whole[0].pose, s.start);
        assert_eq!(whole[3].pose, s.goal);
        let line = text.lines().count() - 4;
        let e = err(&text.replace("[0.2, 0, 0]", "[9, 0, 0]"));
        assert!(
            e.contains(&format!("f.toml:{line}"))
                && e.contains("route[1]")
                && e.contains("outside"),
            "{e}"
        );
        let e = err(&text.replace("dwell_s = 0.5", "dwell_s = -1"));
        assert!(e.contains("route[1]") && e.contains("dwell_s"), "{e}");
        let e = err(&text.replace("press_n", "push_n"));
        assert!(e.contains("push_n"), "{e}");
    }

    fn err(text: &str) -> String {
        Scene::from_toml_str(text, "f.toml")
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn errors_name_file_field_and_line() {
        let e = err(&MINIMAL.replace("radius_m = 0.1", "radius_m = -0.1"));
        assert!(
            e.starts_with("f.toml") && e.contains("line 11") && e.contains("> 0"),
            "{e}"
        );
        let e = err(&MINIMAL.replace("[0.5, 0, 0]", "[nan, 0, 0]"));
        assert!(e.contains("finite") && e.contains("line 8"), "{e}");
        let e = err(&MINIMAL.replace("[0.5, 0, 0]", "[2, 0, 0]"));
        assert!(
            e.contains("f.toml:7") && e.contains("`goal`") && e.contains("outside"),
            "{e}"
        );
        let e = err(&MINIMAL.replace("radius_m = 0.1", "half_extents_m = [0.1, 0.1, 0.1]"));
        assert!(e.contains("moving_object[0]"), "{e}");
        let e = err(&MINIMAL.replace("shape =", "shpe ="));
        assert!(e.contains("shpe"), "{e}");
        let e = err("this is = = not toml");
        assert!(e.starts_with("f.toml"), "{e}");
        let e = err(&MINIMAL.replace("[[moving_object]]\nshape = \"sphere\"\nradius_m = 0.1", ""));
        assert!(e.contains("moving_object"), "{e}");
    }

    #[test]
    fn mesh_parts_load_relative_to_the_scene_file_and_errors_name_both_files() {
        let dir = std::env::temp_dir().join(format!("planner-scene-mesh-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("m")).expect("dir");
        std::fs::write(
            dir.join("m/tet.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
        )
        .expect("obj");
        std::fs::write(dir.join("m/bad.obj"), "v 0 0 0\nf 1 2 3\n").expect("obj");
        let with = |file: &str, extra: &str| {
            MINIMAL.replace(
                "shape = \"sphere\"\nradius_m = 0.1",
                &format!("shape = \"mesh\"\nfile = \"{file}\"\n{extra}"),
            )
        };
        let origin = dir.join("s.toml").display().to_string();
        let s = Scene::from_toml_str(&with("m/tet.obj", "scale = 0.1"), &origin).expect("loads");
        let Primitive::Mesh { mesh } = &s.moving_object[0].primitive else {
            panic!("mesh part")
        };
        assert!((s.object_radius_m() - 0.1).abs() < 1e-9 && mesh.triangles.len() == 4);
        let e = Scene::from_toml_str(&with("m/bad.obj", ""), &origin)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.toml:9")
                && e.contains("moving_object[0].file")
                && e.contains("bad.obj:2"),
            "{e}"
        );
        let e = Scene::from_toml_str(&with("m/none.stl", ""), &origin)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("none.stl") && e.contains("moving_object[0]"),
            "{e}"
        );
        let e = Scene::from_toml_str(&with("m/tet.obj", "radius_m = 1.0"), &origin)
            .unwrap_err()
            .to_string();
        assert!(e.contains("moving_object[0]") && e.contains("mesh"), "{e}");
        let e = Scene::from_toml_str(&with("m/tet.obj", "scale = 0"), &origin)
            .unwrap_err()
            .to_string();
        assert!(e.contains("> 0"), "{e}");
        let e = Scene::from_toml_str(&format!("space = \"plane\"\n{MINIMAL}"), &origin)
            .unwrap_err()
            .to_string();
        assert!(e.contains("plane") && e.contains("line 1"), "{e}");
    }

    #[test]
    fn a_double_sided_mesh_is_repaired_on_load() {
        let dir = std::env::temp_dir().join(format!("planner-scene-repair-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let c = MeshData::cuboid("c", [100.0, 100.0, 100.0]);
        // The reversed twins first, so the triangles kept must also be turned outward.
        let mut t: Vec<_> = c.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect();
        t.extend(&c.triangles);
        let double = MeshData::new("double", c.vertices_m.clone(), t).expect("valid");
        std::fs::write(dir.join("double.obj"), double.to_obj()).expect("obj");
        let text = MINIMAL.replace(
            "shape = \"sphere\"\nradius_m = 0.1",
            "shape = \"mesh\"\nfile = \"double.obj\"\nscale = 0.001",
        );
        let origin = dir.join("s.toml").display().to_string();
        let s = Scene::from_toml_str(&text, &origin).expect("loads");
        let Primitive::Mesh { mesh } = &s.moving_object[0].primitive else {
            panic!("mesh part")
        };
        let topology = crate::topology::Topology::of(mesh);
        assert!(topology.is_closed_outward(), "{topology}");
        assert!(
            (topology.signed_volume_m3 - 0.008).abs() < 1e-12,
            "{topology}"
        );
        let checks = s.mesh_checks();
        assert!(checks[0].is_ok());
        assert_eq!(checks[0].surface(), crate::repair::Surface::ClosedOutward);
        let report = checks[0].repair.as_ref().expect("repaired on load");
        assert_eq!((report.twins, report.triangles_out), (12, 12));
        assert!(report.changed());
    }
}
