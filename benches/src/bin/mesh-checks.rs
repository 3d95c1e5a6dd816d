//! Mesh checks: the cost of one collision check and of one capped clearance query between
//! two closed bumpy spheres against their triangle count, as a table, JSON and a log–log
//! PNG.
//!
//! `cargo build --release -p benches && target/release/mesh-checks --png docs/mesh-checks.png`

use anyhow::{Context, bail};
use benches::mesh_checks::{self, MeshPoint};
use benches::scaling::{loglog_slope, plot_loglog};
use clap::Parser;
use std::path::PathBuf;

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
}

/// `cases.json` of `--export`.
#[derive(serde::Serialize)]
struct Cases {
    /// Object poses in the obstacle's frame: x, y, z (m), qw, qx, qy, qz.
    poses: Vec<[f64; 7]>,
    sizes: Vec<Case>,
}

#[derive(serde::Serialize)]
struct Case {
    triangles: usize,
    obstacle_obj: String,
    object_obj: String,
    /// Our verdict per pose.
    colliding: Vec<bool>,
    is_free_us: f64,
    parry_us: f64,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
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
    println!(
        "| triangles per mesh | colliding | is_free µs | parry's mesh test µs | speed-up | clearance (≤ 5 mm) µs | parry's clearance µs |"
    );
    println!("|---|---|---|---|---|---|---|");
    for p in &points {
        println!(
            "| {} | {:.0} % | {:.2} | {:.2} | {:.1}× | {:.2} | {:.2} |",
            p.triangles,
            100.0 * p.colliding,
            p.is_free_us,
            p.parry_us,
            p.parry_us / p.is_free_us,
            p.clearance_us,
            p.clearance_parry_us
        );
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
            let mut names = Vec::new();
            for (role, part) in [
                ("obstacle", &scene.obstacles[0]),
                ("object", &scene.moving_object[0]),
            ] {
                let scene::Primitive::Mesh { mesh } = &part.primitive else {
                    bail!("the fixture's parts are meshes");
                };
                let name = format!("{role}-{}.obj", p.triangles);
                std::fs::write(dir.join(&name), mesh.to_obj())
                    .with_context(|| format!("writing {}", dir.join(&name).display()))?;
                names.push(name);
            }
            sizes.push(Case {
                triangles: p.triangles,
                obstacle_obj: names[0].clone(),
                object_obj: names[1].clone(),
                colliding: poses.iter().map(|q| !checker.is_free(q)).collect(),
                is_free_us: p.is_free_us,
                parry_us: p.parry_us,
            });
        }
        let cases = Cases {
            poses: poses
                .iter()
                .map(|q| {
                    [
                        q.pos.x, q.pos.y, q.pos.z, q.rot.w, q.rot.i, q.rot.j, q.rot.k,
                    ]
                })
                .collect(),
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
