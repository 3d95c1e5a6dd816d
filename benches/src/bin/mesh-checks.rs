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
    println!("| triangles per mesh | colliding | is_free µs | clearance (≤ 5 mm) µs |");
    println!("|---|---|---|---|");
    for p in &points {
        println!(
            "| {} | {:.0} % | {:.2} | {:.2} |",
            p.triangles,
            100.0 * p.colliding,
            p.is_free_us,
            p.clearance_us
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
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&points)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}
