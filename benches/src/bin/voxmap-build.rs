//! Voxmap build time and memory against mesh size: generated closed spheres (radius
//! 0.25 m) from 20 k to 1.3 M triangles, an assembly-sized scene of many parts (about
//! 2 × 1 × 0.5 m), or a scene file's obstacles, each case in a child process of its own so
//! that its peak memory is its own.
//!
//! The spheres (`--mesh`): `uv`, the bumpy UV sphere (`MeshData::bumpy_sphere`: rings ×
//! segments, bumps of ±10 %, slivers at the poles); `icosphere`, `icosphere-bumps` and
//! `icosphere-fine`, the subdivided icosahedron (every triangle about the same size)
//! smooth, with the UV sphere's bumps, or with finer ones (`scene::Bumps`); a `+shuffled`
//! suffix stores the same sphere's triangles and vertices in random order. A scene file
//! (`--scene FILE`) goes through `ContactModel::obstacles`, as `haptic-loop run` builds
//! its voxmap.
//!
//! `cargo build --release -p benches && target/release/voxmap-build`; `--voxel-mm 0.5`,
//! `--triangles 20480,1310720`, `--mesh uv,icosphere-fine`, `--assembly`, `--scene FILE`,
//! `--json FILE`. `RUST_LOG=haptic_loop=debug` shows the build's stages.

use anyhow::{Context, bail};
use clap::Parser;
use haptic_loop::contact::{ContactModel, Obstacle, Progress, Surface, Voxmap, VoxmapConfig};
use parry3d_f64::math::Pose;
use scene::{Bumps, MeshData};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// Voxmap build time and peak memory per mesh size.
#[derive(Debug, Parser)]
struct Args {
    /// Triangles of each sphere, comma-separated (rounded to the UV sphere's grid, or to
    /// the nearest 20·4^s of an icosphere).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "20480,81920,327680,1310720"
    )]
    triangles: Vec<usize>,
    /// The spheres, comma-separated: uv, icosphere, icosphere-bumps, icosphere-fine, each
    /// optionally with `+shuffled` (triangles and vertices in random order).
    #[arg(long, value_delimiter = ',', default_value = "uv")]
    mesh: Vec<String>,
    /// Only this scene file's obstacles (built-in scene names work too).
    #[arg(long)]
    scene: Option<String>,
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
    /// Instead: write each sphere (--mesh × --triangles) into this folder as an OBJ file and
    /// a scene file with it as the only obstacle (for `haptic-loop run --scene`), and stop.
    #[arg(long)]
    write_scenes: Option<PathBuf>,
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

/// The sphere `kind` (see the module docs) of radius 0.25 m and about `triangles`
/// triangles.
fn sphere(kind: &str, triangles: usize) -> anyhow::Result<MeshData> {
    if let Some(kind) = kind.strip_suffix("+shuffled") {
        return Ok(shuffled(sphere(kind, triangles)?));
    }
    let ico = |bumps| {
        // 20·4^s triangles.
        let s = ((triangles.max(20) as f64 / 20.0).log(4.0).round() as u32).min(10);
        MeshData::icosphere(kind, 0.25, s, bumps)
    };
    Ok(match kind {
        "uv" => {
            // 2·s·(s/2 − 1) ≈ s² triangles for `s` segments and `s/2` rings.
            let s = ((triangles as f64).sqrt().round() as u32).max(8);
            MeshData::bumpy_sphere("bumpy sphere", 0.25, s / 2, s)
        }
        "icosphere" => ico(Bumps::None),
        "icosphere-bumps" => ico(Bumps::Bench),
        "icosphere-fine" => ico(Bumps::Fine),
        _ => bail!(
            "unknown mesh {kind:?}: uv, icosphere, icosphere-bumps or icosphere-fine, each optionally +shuffled"
        ),
    })
}

/// `mesh` with its triangles and its vertices each in a random order (seeded): the same
/// surface stored without locality, as some tools write it.
fn shuffled(mut mesh: MeshData) -> MeshData {
    use rand::SeedableRng;
    use rand::seq::SliceRandom;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let mut order: Vec<u32> = (0..mesh.vertices_m.len() as u32).collect();
    order.shuffle(&mut rng);
    let mut new_index = vec![0u32; order.len()];
    for (new, &old) in order.iter().enumerate() {
        new_index[old as usize] = new as u32;
    }
    mesh.vertices_m = order.iter().map(|&o| mesh.vertices_m[o as usize]).collect();
    for t in &mut mesh.triangles {
        *t = t.map(|v| new_index[v as usize]);
    }
    mesh.triangles.shuffle(&mut rng);
    mesh.source.push_str(" (shuffled)");
    mesh
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

/// Runs `case`: `assembly`, `scene` (the obstacles of `scene`), or `KIND:TRIANGLES` (a
/// sphere; a bare number is a UV sphere).
fn one(case: &str, voxel_mm: f64, scene: Option<&str>) -> anyhow::Result<Row> {
    let config = VoxmapConfig {
        voxel_m: voxel_mm * 1e-3,
        ..VoxmapConfig::default()
    };
    let obstacles = if case == "assembly" {
        assembly()
    } else if case == "scene" {
        let name = scene.context("case `scene` needs --scene")?;
        let scene = scene::Scene::by_name_or_path(name)?;
        ContactModel::obstacles(&scene, &config)?
    } else {
        let (kind, n) = case.split_once(':').unwrap_or(("uv", case));
        let n: usize = n.parse().context("a triangle count")?;
        vec![Obstacle::Mesh {
            pose: Pose::IDENTITY,
            mesh: Arc::new(sphere(kind, n)?),
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

/// Writes each sphere `kinds` × `triangles` as `DIR/KIND-N.obj` and a scene `DIR/KIND-N.toml`
/// with it as the only obstacle, a small ball to move from one side of it to the other.
fn write_scenes(
    dir: &std::path::Path,
    kinds: &[String],
    triangles: &[usize],
) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)?;
    for kind in kinds {
        for &n in triangles {
            let mesh = sphere(kind, n)?;
            let name = format!("{kind}-{}", mesh.triangles.len());
            std::fs::write(dir.join(format!("{name}.obj")), mesh.to_obj())?;
            let toml = format!(
                "name = \"{name}\"\n\n[bounds]\nmin_m = [-0.6, -0.6, -0.6]\nmax_m = [0.6, 0.6, 0.6]\n\n\
                 [start]\nposition_m = [-0.45, 0.0, 0.0]\n\n[goal]\nposition_m = [0.45, 0.0, 0.0]\n\n\
                 [[obstacles]]\nshape = \"mesh\"\nfile = \"{name}.obj\"\nposition_m = [0.0, 0.0, 0.0]\n\n\
                 [[moving_object]]\nshape = \"sphere\"\nradius_m = 0.02\n"
            );
            let path = dir.join(format!("{name}.toml"));
            std::fs::write(&path, toml)?;
            println!("{}", path.display());
        }
    }
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
        let row = one(case, args.voxel_mm, args.scene.as_deref())?;
        println!("{}", serde_json::to_string(&row)?);
        return Ok(());
    }
    for kind in &args.mesh {
        sphere(kind, 20)?;
    }
    if let Some(dir) = &args.write_scenes {
        return write_scenes(dir, &args.mesh, &args.triangles);
    }
    let mut cases: Vec<String> = if args.assembly_only || args.scene.is_some() {
        Vec::new()
    } else {
        args.mesh
            .iter()
            .flat_map(|m| args.triangles.iter().map(move |t| format!("{m}:{t}")))
            .collect()
    };
    if args.scene.is_some() {
        cases.push("scene".into());
    }
    if args.assembly || args.assembly_only {
        cases.push("assembly".into());
    }
    let me = std::env::current_exe()?;
    println!(
        "{:>22} {:>10} {:>8} {:>9} {:>8} {:>10} {:>9} {:>9}",
        "case", "triangles", "voxel mm", "build s", "blocks", "voxmap MB", "band MB", "peak MB"
    );
    let mut rows = Vec::new();
    for case in cases {
        let mut child = std::process::Command::new(&me);
        child.args(["--one", &case, "--voxel-mm", &args.voxel_mm.to_string()]);
        if let Some(scene) = &args.scene {
            child.args(["--scene", scene]);
        }
        let out = child.stderr(std::process::Stdio::inherit()).output()?;
        if !out.status.success() {
            bail!("case {case}: {}", out.status);
        }
        let row: Row = serde_json::from_slice(&out.stdout)?;
        println!(
            "{:>22} {:>10} {:>8} {:>9.2} {:>8} {:>10.1} {:>9.1} {:>9.0}",
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
