//! Mesh checks: the cost of one collision check and of one capped clearance query between
//! two closed bumpy spheres, and between such a sphere and a box either way round, against
//! their triangle count, as a table, JSON and a log–log PNG.
//!
//! `cargo build --release -p benches && target/release/mesh-checks --png docs/mesh-checks.png`;
//! `--scene FILE` measures a scene's own parts instead (e.g. a CAD puzzle converted by
//! `benches/cad/convert.py`, or a CAD link among boxes written by `benches/cad/rtb_scenes.py`).

use anyhow::{Context, bail};
use benches::mesh_checks::{self, MeshPoint};
use benches::scaling::{loglog_slope, plot_loglog};
use clap::Parser;
use std::path::{Path, PathBuf};

/// Per-check cost against triangle count, mesh against mesh and mesh against box.
#[derive(Debug, Parser)]
struct Args {
    /// Triangles per mesh, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "100,300,1000,2000,5000,20000"
    )]
    triangles: Vec<usize>,
    /// Random poses around contact.
    #[arg(long, default_value_t = 500)]
    poses: usize,
    /// Times each pose is checked.
    #[arg(long, default_value_t = 5)]
    repeats: usize,
    /// Write the figures as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Draw the log–log plot here.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Write the meshes (OBJ), the poses and our verdicts and times here (`cases.json`),
    /// for a reference library to check and time the same cases (`benches/coal/run.py`).
    #[arg(long, value_name = "DIR")]
    export: Option<PathBuf>,
    /// Measure these scenes (files or built-in names, comma-separated; each with a mesh)
    /// at poses drawn in their bounds, instead of the generated pairs at `--triangles`.
    #[arg(long, value_delimiter = ',', value_name = "SCENE")]
    scene: Vec<String>,
    /// The generated pairs (comma-separated): `mesh-mesh` (two bumpy spheres), `mesh-box`
    /// (the sphere moving against a box), `box-mesh` (a box moving against the sphere).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "mesh-mesh,mesh-box,box-mesh"
    )]
    pairs: Vec<String>,
}

/// `cases.json` of `--export`.
#[derive(serde::Serialize)]
struct Cases {
    sizes: Vec<Case>,
}

#[derive(serde::Serialize)]
struct Case {
    /// What the row is (a pair and its mesh size, or a scene and its pose set).
    label: String,
    triangles: usize,
    /// The object's poses in the scene frame: x, y, z (m), qw, qx, qy, qz.
    poses: Vec<[f64; 7]>,
    /// The obstacle's parts, scene frame.
    obstacle: Vec<PartOut>,
    /// The moving object's parts, object frame.
    object: Vec<PartOut>,
    /// Our verdict per pose.
    colliding: Vec<bool>,
    is_free_us: f64,
    parry_us: f64,
}

/// One part as `cases.json` gives it: a mesh (OBJ file), a box or a sphere at a pose.
#[derive(serde::Serialize)]
struct PartOut {
    /// `mesh`, `box` or `sphere`.
    kind: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    obj: Option<String>,
    /// Half extents of a box, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    half_extents_m: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    radius_m: Option<f64>,
    /// x, y, z (m), qw, qx, qy, qz.
    pose: [f64; 7],
}

fn pose_row(q: &planner_core::Se3) -> [f64; 7] {
    [
        q.pos.x, q.pos.y, q.pos.z, q.rot.w, q.rot.i, q.rot.j, q.rot.k,
    ]
}

/// Writes the scene's mesh parts as OBJ into `dir` (names from `stem`) and describes every
/// part: the obstacle's and the object's.
fn export_parts(
    dir: &Path,
    stem: &str,
    scene: &planner_core::Scene,
) -> anyhow::Result<[Vec<PartOut>; 2]> {
    use scene::Primitive;
    let mut out = [Vec::new(), Vec::new()];
    for (list, (role, parts)) in out.iter_mut().zip([
        ("obstacle", &scene.obstacles),
        ("object", &scene.moving_object),
    ]) {
        for (i, part) in parts.iter().enumerate() {
            let mut p = PartOut {
                kind: "mesh",
                obj: None,
                half_extents_m: None,
                radius_m: None,
                pose: pose_row(&part.pose),
            };
            match &part.primitive {
                Primitive::Mesh { mesh } => {
                    let name = format!("{role}-{stem}-{i}.obj");
                    std::fs::write(dir.join(&name), mesh.to_obj())
                        .with_context(|| format!("writing {}", dir.join(&name).display()))?;
                    p.obj = Some(name);
                }
                Primitive::Box { half_extents_m: h } => {
                    p.kind = "box";
                    p.half_extents_m = Some([h.x, h.y, h.z]);
                }
                Primitive::Sphere { radius_m } => {
                    p.kind = "sphere";
                    p.radius_m = Some(*radius_m);
                }
            }
            list.push(p);
        }
    }
    Ok(out)
}

/// `--scene`: each scene's parts at poses drawn uniformly in its bounds and at those near
/// an obstacle.
fn scenes(args: &Args) -> anyhow::Result<()> {
    if args.png.is_some() {
        bail!("--png draws cost against triangle count: not with --scene");
    }
    println!(
        "| scene | triangles (object × obstacles) | poses | {} |",
        mesh_checks::CELLS_HEADER
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let mut cases = Vec::new();
    let mut rows = Vec::new();
    for name in &args.scene {
        let scene = planner_core::Scene::by_name_or_path(name)
            .with_context(|| format!("--scene {name}"))?;
        let object_triangles = mesh_checks::mesh_triangles(&scene.moving_object);
        if object_triangles + mesh_checks::mesh_triangles(&scene.obstacles) == 0 {
            bail!("--scene {name}: has no mesh (this harness measures the mesh pairs)");
        }
        let parts = match &args.export {
            Some(dir) => {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("creating {}", dir.display()))?;
                Some(export_parts(dir, &scene.name, &scene)?)
            }
            None => None,
        };
        for (set, near) in [("uniform", false), ("near", true)] {
            let poses = mesh_checks::scene_poses(&scene, args.poses, near);
            if poses.is_empty() {
                bail!("--scene {name}: no pose in the bounds reaches an obstacle");
            }
            let p = mesh_checks::measure_scene(&scene, &poses, args.repeats)
                .expect("a mesh, checked above");
            println!(
                "| {} ({set}) | {object_triangles} × {} | {} | {} |",
                scene.name,
                mesh_checks::mesh_triangles(&scene.obstacles),
                p.poses,
                p.cells()
            );
            if let Some([obstacle, object]) = &parts {
                let checker = planner_core::CollisionChecker::new(&scene);
                cases.push(Case {
                    label: format!("{} ({set})", scene.name),
                    triangles: p.triangles,
                    poses: poses.iter().map(pose_row).collect(),
                    obstacle: obstacle.iter().map(PartOut::again).collect(),
                    object: object.iter().map(PartOut::again).collect(),
                    colliding: poses.iter().map(|q| !checker.is_free(q)).collect(),
                    is_free_us: p.is_free_us,
                    parry_us: p.parry_us,
                });
            }
            rows.push(serde_json::json!({ "scene": scene.name, "poses_drawn": set, "point": p }));
        }
    }
    if let Some(dir) = &args.export {
        let file = dir.join("cases.json");
        let all = Cases { sizes: cases };
        std::fs::write(&file, serde_json::to_string(&all)?)
            .with_context(|| format!("writing {}", file.display()))?;
    }
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&rows)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

impl PartOut {
    /// The same description (each pose set of a scene is a case of its own).
    fn again(&self) -> PartOut {
        PartOut {
            kind: self.kind,
            obj: self.obj.clone(),
            half_extents_m: self.half_extents_m,
            radius_m: self.radius_m,
            pose: self.pose,
        }
    }
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if !args.scene.is_empty() {
        if args.poses == 0 || args.repeats == 0 {
            bail!("--poses and --repeats must be > 0");
        }
        return scenes(&args);
    }
    if args
        .triangles
        .iter()
        .any(|&n| !(48..=1_000_000).contains(&n))
    {
        bail!("--triangles must each be within 48–1000000");
    }
    if args.poses == 0 || args.repeats == 0 {
        bail!("--poses and --repeats must be > 0");
    }
    let pairs = args
        .pairs
        .iter()
        .map(|p| {
            mesh_checks::Pair::parse(p).with_context(|| {
                format!("--pairs: `{p}` is not one of mesh-mesh, mesh-box, box-mesh")
            })
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    if let Some(dir) = &args.export {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let mut points = Vec::new();
    let mut series = Vec::new();
    let mut cases = Vec::new();
    println!(
        "| pair | triangles per mesh | {} |",
        mesh_checks::CELLS_HEADER
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for &pair in &pairs {
        let poses = mesh_checks::poses_for(pair, args.poses);
        let mut row = Vec::new();
        for &n in &args.triangles {
            let p = mesh_checks::measure(pair, n, &poses, args.repeats);
            println!("| {} | {} | {} |", pair.name(), p.triangles, p.cells());
            if let Some(dir) = &args.export {
                let scene = mesh_checks::pair_scene(pair, n);
                let checker = planner_core::CollisionChecker::new(&scene);
                let stem = format!("{}-{}", pair.name(), p.triangles);
                let [obstacle, object] = export_parts(dir, &stem, &scene)?;
                cases.push(Case {
                    label: stem,
                    triangles: p.triangles,
                    poses: poses.iter().map(pose_row).collect(),
                    obstacle,
                    object,
                    colliding: poses.iter().map(|q| !checker.is_free(q)).collect(),
                    is_free_us: p.is_free_us,
                    parry_us: p.parry_us,
                });
            }
            row.push(p);
        }
        let name = pair.name();
        let at = |f: fn(&MeshPoint) -> f64| -> Vec<(f64, f64)> {
            row.iter().map(|p| (p.triangles as f64, f(p))).collect()
        };
        series.push((format!("{name}: is_free"), at(|p| p.is_free_us)));
        series.push((format!("{name}: is_free by parry"), at(|p| p.parry_us)));
        series.push((
            format!("{name}: parry's clearance up to 5 mm"),
            at(|p| p.clearance_parry_us),
        ));
        series.push((
            format!("{name}: clearance up to 5 mm"),
            at(|p| p.clearance_us),
        ));
        points.push(serde_json::json!({ "pair": name, "points": row }));
    }
    for (name, pts) in &series {
        if let Some(s) = loglog_slope(pts) {
            println!("log–log slope of {name}: {s:.2}");
        }
    }
    if let Some(p) = &args.png {
        if !lab::register_font() {
            bail!(
                "no TrueType font found (DejaVuSans.ttf): cannot draw {}",
                p.display()
            );
        }
        plot_loglog(
            p,
            "mesh pairs: cost per query",
            "triangles per mesh",
            "µs per query",
            &series,
        )
        .map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?;
    }
    if let Some(dir) = &args.export {
        let cases = Cases { sizes: cases };
        let file = dir.join("cases.json");
        std::fs::write(&file, serde_json::to_string(&cases)?)
            .with_context(|| format!("writing {}", file.display()))?;
    }
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&points)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}
