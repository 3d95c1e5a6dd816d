//! Mesh checks: the cost of one collision check and of one capped clearance query between
//! two closed bumpy spheres against their triangle count, as a table, JSON and a log–log
//! PNG.
//!
//! `cargo build --release -p benches && target/release/mesh-checks --png docs/mesh-checks.png`;
//! `--scene FILE` measures a scene's own pair of meshes instead (e.g. a CAD puzzle converted
//! by `benches/cad/convert.py`).

use anyhow::{Context, bail};
use benches::mesh_checks::{self, MeshPoint};
use benches::scaling::{loglog_slope, plot_loglog};
use clap::Parser;
use std::path::{Path, PathBuf};

/// Per-check cost against triangle count, mesh against mesh.
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
    /// Measure these scenes (files or built-in names, comma-separated; each one mesh
    /// obstacle and one mesh object) at poses drawn in their bounds, instead of the
    /// spheres at `--triangles`.
    #[arg(long, value_delimiter = ',', value_name = "SCENE")]
    scene: Vec<String>,
}

/// `cases.json` of `--export`.
#[derive(serde::Serialize)]
struct Cases {
    /// Object poses in the obstacle's frame: x, y, z (m), qw, qx, qy, qz (for every case
    /// without its own).
    poses: Vec<[f64; 7]>,
    sizes: Vec<Case>,
}

#[derive(serde::Serialize)]
struct Case {
    /// What the row is (a mesh size, or a scene and its pose set).
    label: String,
    triangles: usize,
    /// This case's own poses, as `Cases::poses`.
    #[serde(skip_serializing_if = "Option::is_none")]
    poses: Option<Vec<[f64; 7]>>,
    obstacle_obj: String,
    object_obj: String,
    /// Our verdict per pose.
    colliding: Vec<bool>,
    is_free_us: f64,
    parry_us: f64,
}

fn pose_row(q: &planner::Se3) -> [f64; 7] {
    [
        q.pos.x, q.pos.y, q.pos.z, q.rot.w, q.rot.i, q.rot.j, q.rot.k,
    ]
}

/// Writes a pair's meshes as OBJ into `dir`, returning the obstacle's and the object's
/// file names.
fn export_pair(dir: &Path, stem: &str, scene: &planner::Scene) -> anyhow::Result<[String; 2]> {
    let Some((obstacle, object)) = mesh_checks::mesh_pair(scene) else {
        bail!(
            "scene `{}` is not one mesh obstacle and one mesh object",
            scene.name
        );
    };
    let mut names = [String::new(), String::new()];
    for (name, (role, mesh)) in names
        .iter_mut()
        .zip([("obstacle", obstacle), ("object", object)])
    {
        *name = format!("{role}-{stem}.obj");
        std::fs::write(dir.join(&*name), mesh.to_obj())
            .with_context(|| format!("writing {}", dir.join(&*name).display()))?;
    }
    Ok(names)
}

/// `--scene`: each scene's pair at poses drawn uniformly in its bounds and at those near
/// the obstacle.
fn scenes(args: &Args) -> anyhow::Result<()> {
    if args.png.is_some() {
        bail!("--png draws cost against triangle count: not with --scene");
    }
    println!(
        "| scene | triangles (object × obstacle) | poses | {} |",
        mesh_checks::CELLS_HEADER
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let mut cases = Vec::new();
    let mut rows = Vec::new();
    for name in &args.scene {
        let scene =
            planner::Scene::by_name_or_path(name).with_context(|| format!("--scene {name}"))?;
        let Some((_, object)) = mesh_checks::mesh_pair(&scene) else {
            bail!(
                "--scene {name}: needs exactly one mesh obstacle (identity pose) and one mesh object"
            );
        };
        let object_triangles = object.triangles.len();
        let names = match &args.export {
            Some(dir) => {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("creating {}", dir.display()))?;
                Some(export_pair(dir, &scene.name, &scene)?)
            }
            None => None,
        };
        for (set, near) in [("uniform", false), ("near", true)] {
            let poses = mesh_checks::scene_poses(&scene, args.poses, near);
            if poses.is_empty() {
                bail!("--scene {name}: no pose in the bounds reaches the obstacle");
            }
            let p = mesh_checks::measure_scene(&scene, &poses, args.repeats)
                .expect("mesh_pair checked above");
            println!(
                "| {} ({set}) | {object_triangles} × {} | {} | {} |",
                scene.name,
                p.triangles,
                p.poses,
                p.cells()
            );
            if let Some([obstacle_obj, object_obj]) = &names {
                let checker = planner::CollisionChecker::new(&scene);
                cases.push(Case {
                    label: format!("{} ({set})", scene.name),
                    triangles: p.triangles,
                    poses: Some(poses.iter().map(pose_row).collect()),
                    obstacle_obj: obstacle_obj.clone(),
                    object_obj: object_obj.clone(),
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
        let all = Cases {
            poses: Vec::new(),
            sizes: cases,
        };
        std::fs::write(&file, serde_json::to_string(&all)?)
            .with_context(|| format!("writing {}", file.display()))?;
    }
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&rows)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
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
    let poses = mesh_checks::poses(args.poses);
    let points: Vec<MeshPoint> = args
        .triangles
        .iter()
        .map(|&n| mesh_checks::measure(n, &poses, args.repeats))
        .collect();
    println!("| triangles per mesh | {} |", mesh_checks::CELLS_HEADER);
    println!("|---|---|---|---|---|---|---|---|---|");
    for p in &points {
        println!("| {} | {} |", p.triangles, p.cells());
    }
    let series = [
        (
            "is_free".to_string(),
            points
                .iter()
                .map(|p| (p.triangles as f64, p.is_free_us))
                .collect::<Vec<_>>(),
        ),
        (
            "is_free by parry's mesh test".to_string(),
            points
                .iter()
                .map(|p| (p.triangles as f64, p.parry_us))
                .collect(),
        ),
        (
            "parry's clearance up to 5 mm".to_string(),
            points
                .iter()
                .map(|p| (p.triangles as f64, p.clearance_parry_us))
                .collect(),
        ),
        (
            "clearance up to 5 mm".to_string(),
            points
                .iter()
                .map(|p| (p.triangles as f64, p.clearance_us))
                .collect(),
        ),
    ];
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
            "mesh against mesh: cost per query",
            "triangles per mesh",
            "µs per query",
            &series,
        )
        .map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?;
    }
    if let Some(dir) = &args.export {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let mut sizes = Vec::new();
        for (p, &asked) in points.iter().zip(&args.triangles) {
            let scene = mesh_checks::two_spheres(asked);
            let checker = planner::CollisionChecker::new(&scene);
            let names = export_pair(dir, &p.triangles.to_string(), &scene)?;
            sizes.push(Case {
                label: p.triangles.to_string(),
                triangles: p.triangles,
                poses: None,
                obstacle_obj: names[0].clone(),
                object_obj: names[1].clone(),
                colliding: poses.iter().map(|q| !checker.is_free(q)).collect(),
                is_free_us: p.is_free_us,
                parry_us: p.parry_us,
            });
        }
        let cases = Cases {
            poses: poses.iter().map(pose_row).collect(),
            sizes,
        };
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
