//! Scaling: contact step time against pointshell size, and planner iteration cost against
//! tree size, as JSON and log–log PNG plots.
//!
//! `cargo build --release -p benches && target/release/scaling --out-dir docs --json scaling.json`

use anyhow::{Context, bail};
use benches::scaling::{self, PlannerPoint, TickPoint, loglog_slope};
use clap::Parser;
use serde::Serialize;
use std::path::PathBuf;
use std::time::Duration;

/// Contact step time vs pointshell size and planner iteration cost vs tree size.
#[derive(Debug, Parser)]
struct Args {
    /// Cube pointshell sizes (points, 1 mm voxels), comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1000,2000,5000,10000,20000,50000"
    )]
    points: Vec<usize>,
    /// Voxel sizes of the S-on-wall case, mm, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "4,2,1,0.7")]
    s_voxels_mm: Vec<f64>,
    /// Contact steps timed per case.
    #[arg(long, default_value_t = 2000)]
    steps: usize,
    /// Scenes whose planner is grown, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "maze,wall-hole,tunnels")]
    scenes: Vec<String>,
    /// Stop growing a scene's trees at this many nodes.
    #[arg(long, default_value_t = 100_000)]
    max_nodes: usize,
    /// Seconds spent growing each scene's trees at most.
    #[arg(long, default_value_t = 20.0)]
    planner_seconds: f64,
    /// Iterations per timed batch.
    #[arg(long, default_value_t = 500)]
    batch: u64,
    /// Write scaling-tick.png and scaling-planner.png here.
    #[arg(long)]
    out_dir: Option<PathBuf>,
    /// Write the figures as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(Debug, Serialize)]
struct Report {
    tick: Vec<TickPoint>,
    /// Log–log slope of step p50 against points, per case (1 = linear).
    tick_slopes: Vec<(String, Option<f64>)>,
    planner: Vec<PlannerPoint>,
    /// Log–log slope of mean iteration time against nodes, per scene.
    planner_slopes: Vec<(String, Option<f64>)>,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if args.points.iter().any(|&p| !(100..=500_000).contains(&p)) {
        bail!("--points must each be within 100–500000");
    }
    if args
        .s_voxels_mm
        .iter()
        .any(|&v| !(0.25..=20.0).contains(&v))
    {
        bail!("--s-voxels-mm must each be within 0.25–20");
    }
    if args.steps == 0 || args.batch == 0 {
        bail!("--steps and --batch must be > 0");
    }
    if !(args.planner_seconds.is_finite() && args.planner_seconds > 0.0) {
        bail!("--planner-seconds must be > 0");
    }
    for s in &args.scenes {
        if scene::Scene::builtin(s).is_none() {
            bail!("--scenes: no built-in scene '{s}'");
        }
    }
    eprintln!(
        "contact: {} cube sizes, {} S voxel sizes",
        args.points.len(),
        args.s_voxels_mm.len()
    );
    let tick = scaling::tick_series(&args.points, &args.s_voxels_mm, args.steps);
    let mut planner = Vec::new();
    for s in &args.scenes {
        eprintln!("planner: {s}");
        planner.extend(scaling::planner_series(
            s,
            args.batch,
            args.max_nodes,
            Duration::from_secs_f64(args.planner_seconds),
        )?);
    }
    let tick_series = group(tick.iter().map(|p| {
        (
            format!("{} (p50)", p.case),
            (p.points as f64, p.step_us.p50),
        )
    }));
    let planner_series = group(
        planner
            .iter()
            .map(|p| (p.scene.clone(), (p.nodes as f64, p.mean_us))),
    );
    let slopes = |series: &[(String, Vec<(f64, f64)>)]| {
        series
            .iter()
            .map(|(n, pts)| (n.clone(), loglog_slope(pts)))
            .collect::<Vec<_>>()
    };
    let report = Report {
        tick_slopes: slopes(&tick_series),
        planner_slopes: slopes(&planner_series),
        tick,
        planner,
    };
    println!("| case | voxel mm | points | p50 µs | p99 µs | max µs |");
    println!("|---|---|---|---|---|---|");
    for p in &report.tick {
        println!(
            "| {} | {} | {} | {:.2} | {:.2} | {:.1} |",
            p.case, p.voxel_mm, p.points, p.step_us.p50, p.step_us.p99, p.step_us.max
        );
    }
    println!();
    println!("| scene | nodes | µs per iteration |");
    println!("|---|---|---|");
    // One row per doubling of the tree (every batch is in the JSON).
    let mut next = (String::new(), 0usize);
    for p in &report.planner {
        if p.scene != next.0 {
            next = (p.scene.clone(), 0);
        }
        if p.nodes >= next.1 {
            println!("| {} | {} | {:.1} |", p.scene, p.nodes, p.mean_us);
            next.1 = (p.nodes * 2).max(1);
        }
    }
    println!();
    for (n, s) in report.tick_slopes.iter().chain(&report.planner_slopes) {
        println!(
            "log–log slope {n}: {}",
            s.map_or("n/a".into(), |s| format!("{s:.2}"))
        );
    }
    if let Some(dir) = &args.out_dir {
        if lab::register_font() {
            let tick_png = dir.join("scaling-tick.png");
            scaling::plot_loglog(
                &tick_png,
                "contact step time vs pointshell size",
                "pointshell points",
                "µs per step (p50)",
                &tick_series,
            )
            .map_err(|e| anyhow::anyhow!("cannot draw {}: {e}", tick_png.display()))?;
            let planner_png = dir.join("scaling-planner.png");
            scaling::plot_loglog(
                &planner_png,
                "RRT-Connect iteration cost vs tree size",
                "nodes in all trees",
                "µs per iteration (batch mean)",
                &planner_series,
            )
            .map_err(|e| anyhow::anyhow!("cannot draw {}: {e}", planner_png.display()))?;
        } else {
            eprintln!("no TrueType font found (DejaVuSans.ttf): plots not drawn");
        }
    }
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&report)? + "\n")
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    Ok(())
}

/// (name, point) pairs grouped by name, in first-seen order, points sorted by x.
fn group(items: impl Iterator<Item = (String, (f64, f64))>) -> Vec<(String, Vec<(f64, f64)>)> {
    let mut out: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for (name, p) in items {
        match out.iter_mut().find(|s| s.0 == name) {
            Some(s) => s.1.push(p),
            None => out.push((name, vec![p])),
        }
    }
    for s in &mut out {
        s.1.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    out
}
