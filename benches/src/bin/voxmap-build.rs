//! Voxmap build time and memory against mesh size: generated closed bumpy spheres (radius
//! 0.25 m, bumps of ±10 %) from 20 k to 1.3 M triangles, and an assembly-sized scene of many
//! parts (about 2 × 1 × 0.5 m), each case in a child process of its own so that its peak
//! memory is its own.
//!
//! `cargo build --release -p benches && target/release/voxmap-build`; `--voxel-mm 0.5`,
//! `--triangles 20480,1310720`, `--assembly`, `--json FILE`.

use anyhow::{Context, bail};
use clap::Parser;
use haptic_loop::contact::{Obstacle, Progress, Surface, Voxmap, VoxmapConfig};
use parry3d_f64::math::Pose;
use scene::MeshData;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// Voxmap build time and peak memory per mesh size.
#[derive(Debug, Parser)]
struct Args {
    /// Triangles of the bumpy sphere, comma-separated (rounded to the sphere's grid).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "20480,81920,327680,1310720"
    )]
    triangles: Vec<usize>,
    /// Voxel size, mm.
    #[arg(long, default_value_t = 1.0)]
    voxel_mm: f64,
    /// Also the assembly-sized scene of many parts.
    #[arg(long)]
    assembly: bool,
    /// Only the assembly.
    #[arg(long)]
    assembly_only: bool,
    /// Instead: the pointshell (and mass properties) of a moving part, a bumpy sphere of
    /// this many triangles (radius 0.05 m), at the voxel size.
    #[arg(long)]
    part_triangles: Option<usize>,
    /// Write the rows as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Run one case in this process and print its row as JSON (how the parent runs each).
    #[arg(long, hide = true)]
    one: Option<String>,
}

/// One case's figures.
#[derive(Debug, Serialize, Deserialize)]
struct Row {
    case: String,
    triangles: usize,
    voxel_mm: f64,
    /// Building the obstacles' triangle lists (generation excluded), s.
    build_s: f64,
    stored_blocks: usize,
    voxmap_mb: f64,
    peak_band_mb: f64,
    /// The process's peak resident memory (VmHWM), MB.
    peak_rss_mb: f64,
}

fn sphere(triangles: usize) -> MeshData {
    // 2·s·(s/2 − 1) ≈ s² triangles for `s` segments and `s/2` rings.
    let s = ((triangles as f64).sqrt().round() as u32).max(8);
    MeshData::bumpy_sphere("bumpy sphere", 0.25, s / 2, s)
}

/// About 2 × 1 × 0.5 m of parts: a 10 × 5 × 2 lattice of bumpy spheres (radius 0.04 m,
/// 20 k triangles each) and boxes (closed box meshes) alternating, 0.2 m apart.
fn assembly() -> Vec<Obstacle> {
    let ball = Arc::new(MeshData::bumpy_sphere("part", 0.04, 100, 200));
    let brick = Arc::new(MeshData::cuboid("brick", [0.06, 0.03, 0.05]));
    let mut out = Vec::new();
    for i in 0..10 {
        for j in 0..5 {
            for k in 0..2 {
                let mesh = if (i + j + k) % 2 == 0 { &ball } else { &brick };
                out.push(Obstacle::Mesh {
                    pose: Pose::translation(0.2 * i as f64, 0.2 * j as f64, 0.25 * k as f64),
                    mesh: mesh.clone(),
                    surface: Surface::Solid,
                });
            }
        }
    }
    out
}

fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1e3)
}

fn one(case: &str, voxel_mm: f64) -> anyhow::Result<Row> {
    let obstacles = if case == "assembly" {
        assembly()
    } else {
        let n: usize = case.parse().context("a triangle count")?;
        vec![Obstacle::Mesh {
            pose: Pose::IDENTITY,
            mesh: Arc::new(sphere(n)),
            surface: Surface::Solid,
        }]
    };
    let triangles = obstacles
        .iter()
        .map(|o| match o {
            Obstacle::Mesh { mesh, .. } => mesh.triangles.len(),
            Obstacle::Shape { .. } => 0,
        })
        .sum();
    let config = VoxmapConfig {
        voxel_m: voxel_mm * 1e-3,
        ..VoxmapConfig::default()
    };
    let started = Instant::now();
    let v = Voxmap::build_obstacles(&obstacles, &config, &Progress::default())?;
    let build_s = started.elapsed().as_secs_f64();
    let r = v.report();
    Ok(Row {
        case: case.to_owned(),
        triangles,
        voxel_mm,
        build_s,
        stored_blocks: r.stored_blocks,
        voxmap_mb: r.memory_bytes as f64 / 1e6,
        peak_band_mb: r.peak_band_bytes as f64 / 1e6,
        peak_rss_mb: peak_rss_mb(),
    })
}

/// Times the contact model of a bumpy-sphere part of about `triangles` triangles against
/// an empty scene: its pointshell with levels of detail and mass properties.
fn pointshell(triangles: usize, voxel_mm: f64) -> anyhow::Result<()> {
    let s = ((triangles as f64).sqrt().round() as u32).max(8);
    let mesh = MeshData::bumpy_sphere("part", 0.05, s / 2, s);
    let n = mesh.triangles.len();
    let part = scene::Part {
        primitive: scene::Primitive::Mesh {
            mesh: Arc::new(mesh),
        },
        pose: scene::Se3::identity(),
    };
    let started = Instant::now();
    let object = scene::shapes::part_shapes(std::slice::from_ref(&part));
    let shapes_s = started.elapsed().as_secs_f64();
    let config = VoxmapConfig {
        voxel_m: voxel_mm * 1e-3,
        ..VoxmapConfig::default()
    };
    let started = Instant::now();
    let model = haptic_loop::contact::ContactModel::build(&[], &object, &config)?;
    let model_s = started.elapsed().as_secs_f64();
    println!(
        "part of {n} triangles at {voxel_mm} mm: parry shape {shapes_s:.2} s, pointshell and mass properties {model_s:.2} s ({} points); peak {:.0} MB",
        model.pointshell().len(),
        peak_rss_mb()
    );
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .init();
    if !(args.voxel_mm.is_finite() && args.voxel_mm > 0.0) {
        bail!(
            "--voxel-mm must be a positive number, got {}",
            args.voxel_mm
        );
    }
    if let Some(n) = args.part_triangles {
        return pointshell(n, args.voxel_mm);
    }
    if let Some(case) = &args.one {
        println!("{}", serde_json::to_string(&one(case, args.voxel_mm)?)?);
        return Ok(());
    }
    let mut cases: Vec<String> = if args.assembly_only {
        Vec::new()
    } else {
        args.triangles.iter().map(|t| t.to_string()).collect()
    };
    if args.assembly || args.assembly_only {
        cases.push("assembly".into());
    }
    let me = std::env::current_exe()?;
    println!(
        "{:>10} {:>10} {:>8} {:>9} {:>8} {:>10} {:>9} {:>9}",
        "case", "triangles", "voxel mm", "build s", "blocks", "voxmap MB", "band MB", "peak MB"
    );
    let mut rows = Vec::new();
    for case in cases {
        let out = std::process::Command::new(&me)
            .args(["--one", &case, "--voxel-mm", &args.voxel_mm.to_string()])
            .output()?;
        if !out.status.success() {
            bail!("case {case}: {}", String::from_utf8_lossy(&out.stderr));
        }
        let row: Row = serde_json::from_slice(&out.stdout)?;
        println!(
            "{:>10} {:>10} {:>8} {:>9.2} {:>8} {:>10.1} {:>9.1} {:>9.0}",
            row.case,
            row.triangles,
            row.voxel_mm,
            row.build_s,
            row.stored_blocks,
            row.voxmap_mb,
            row.peak_band_mb,
            row.peak_rss_mb
        );
        rows.push(row);
    }
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&rows)?)?;
    }
    Ok(())
}
