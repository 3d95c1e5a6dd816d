//! Reports of a sweep: the runs as CSV, a summary per configuration as a markdown table,
//! and PNG plots (plotters).
//!
//! Summaries take unsolved runs at the time limit (as the papers' curves, which approach
//! the limit for hopeless settings) and report the solved fraction beside the median.

use super::RunResult;
use crate::LabError;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Median of `v` (NaN when empty).
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// One configuration's summary.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// Scene.
    pub scene: String,
    /// Method (`auto` for automatic RRT-Connect).
    pub method: String,
    /// σ (weighted m).
    pub sigma: f64,
    /// ε_v (weighted m per iteration).
    pub eps_v: f64,
    /// α, NaN when not applicable.
    pub alpha: f64,
    /// Runs.
    pub runs: usize,
    /// Solved runs.
    pub solved: usize,
    /// Median time (s), unsolved runs counted at the limit.
    pub median_time_s: f64,
    /// Median iterations.
    pub median_iterations: f64,
    /// Median nodes.
    pub median_nodes: f64,
}

/// Groups runs by (scene, method, σ, ε_v, α); `limit_s` stands in for unsolved times.
pub fn summarize(results: &[RunResult], limit_s: f64) -> Vec<Summary> {
    let key = |r: &RunResult| {
        (
            r.scene.clone(),
            r.method.clone(),
            r.sigma.to_bits(),
            r.eps_v.to_bits(),
            r.alpha.to_bits(),
        )
    };
    let mut groups: BTreeMap<_, Vec<&RunResult>> = BTreeMap::new();
    for r in results {
        groups.entry(key(r)).or_default().push(r);
    }
    groups
        .into_values()
        .map(|g| {
            let mut t: Vec<f64> = g
                .iter()
                .map(|r| if r.solved { r.time_s } else { limit_s })
                .collect();
            let mut it: Vec<f64> = g.iter().map(|r| r.iterations as f64).collect();
            let mut nd: Vec<f64> = g.iter().map(|r| r.nodes as f64).collect();
            Summary {
                scene: g[0].scene.clone(),
                method: g[0].method.clone(),
                sigma: g[0].sigma,
                eps_v: g[0].eps_v,
                alpha: g[0].alpha,
                runs: g.len(),
                solved: g.iter().filter(|r| r.solved).count(),
                median_time_s: median(&mut t),
                median_iterations: median(&mut it),
                median_nodes: median(&mut nd),
            }
        })
        .collect()
}

/// The runs as CSV (header first).
pub fn to_csv(results: &[RunResult]) -> String {
    let mut out = String::from(
        "scene,method,sigma,eps_v,alpha,seed,solved,time_s,iterations,nodes,collision_checks,path_length,contact_iterations\n",
    );
    for r in results {
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{:.4},{},{},{},{:.4},{}",
            r.scene,
            r.method,
            r.sigma,
            r.eps_v,
            r.alpha,
            r.seed,
            r.solved,
            r.time_s,
            r.iterations,
            r.nodes,
            r.collision_checks,
            r.path_length,
            r.contact_iterations
        );
    }
    out
}

fn opt(v: f64) -> String {
    if v.is_nan() {
        "–".into()
    } else {
        format!("{v}")
    }
}

/// The summaries as a markdown table.
pub fn to_markdown(summaries: &[Summary]) -> String {
    let mut out = String::from(
        "| scene | method | σ | ε_v | α | solved | median time (s) | median iterations | median nodes |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for s in summaries {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {}/{} | {:.3} | {:.0} | {:.0} |",
            s.scene,
            s.method,
            if s.method == "auto" || s.method.starts_with("hrrtc") {
                "–".into()
            } else {
                opt(s.sigma)
            },
            if s.method == "auto" {
                "–".into()
            } else {
                opt(s.eps_v)
            },
            opt(s.alpha),
            s.solved,
            s.runs,
            s.median_time_s,
            s.median_iterations,
            s.median_nodes
        );
    }
    out
}

/// Registers a TrueType font for plot text from the usual system locations; false when
/// none is found (plots are then skipped, CSV and markdown are still written).
pub fn register_font() -> bool {
    const CANDIDATES: [&str; 3] = [
        "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
        "/usr/share/fonts/TTF/DejaVuSans.ttf",
        "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    ];
    for c in CANDIDATES {
        if let Ok(bytes) = std::fs::read(c) {
            // plotters keeps fonts for the whole process: leak the bytes once.
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                return true;
            }
        }
    }
    false
}

type PlotResult = Result<(), Box<dyn std::error::Error + Send + Sync>>;

const COLOURS: [RGBColor; 6] = [BLUE, GREEN, RED, MAGENTA, CYAN, BLACK];

/// The time axis of the plots (s, log scale): from below the shortest positive median to
/// above the limit, where unsolved medians sit. Medians span milliseconds to the limit.
fn time_axis(summaries: &[Summary], limit_s: f64) -> std::ops::Range<f64> {
    let shortest = summaries
        .iter()
        .map(|s| s.median_time_s)
        .filter(|t| *t > 0.0)
        .fold(limit_s, f64::min);
    (shortest * 0.5).max(1e-5)..limit_s * 1.5
}

/// I-RRT Fig. 15 layout: one panel per method, median time (log scale) against ε_v (log
/// scale), one line per σ. The error names the file.
pub fn plot_irrt(summaries: &[Summary], limit_s: f64, path: &Path) -> Result<(), LabError> {
    draw_irrt(summaries, limit_s, path).map_err(|source| LabError::Draw {
        path: path.to_path_buf(),
        source,
    })
}

fn draw_irrt(summaries: &[Summary], limit_s: f64, path: &Path) -> PlotResult {
    let root = BitMapBackend::new(path, (1200, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let methods: Vec<String> = dedup(summaries.iter().map(|s| s.method.clone()));
    let panels = root.split_evenly((2, methods.len().div_ceil(2).max(1)));
    let eps: Vec<f64> = summaries.iter().map(|s| s.eps_v).collect();
    let (lo, hi) = (
        eps.iter().copied().fold(f64::INFINITY, f64::min),
        eps.iter().copied().fold(0.0, f64::max),
    );
    for (m, panel) in methods.iter().zip(panels.iter()) {
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!("{m}: median time vs user speed"),
                ("sans-serif", 22),
            )
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(
                (lo * 0.8..hi * 1.25).log_scale(),
                time_axis(summaries, limit_s).log_scale(),
            )?;
        chart
            .configure_mesh()
            .x_desc("ε_v (weighted m / iteration)")
            .y_desc("median time (s), log")
            .x_label_formatter(&|v| format!("{v:.1e}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()?;
        let sigmas: Vec<f64> =
            dedup_f(summaries.iter().filter(|s| &s.method == m).map(|s| s.sigma));
        for (i, sigma) in sigmas.iter().enumerate() {
            let c = COLOURS[i % COLOURS.len()];
            let mut pts: Vec<(f64, f64)> = summaries
                .iter()
                .filter(|s| &s.method == m && s.sigma == *sigma)
                .map(|s| (s.eps_v, s.median_time_s))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            chart
                .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?
                .label(format!("σ = {sigma}"))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
            chart.draw_series(pts.iter().map(|p| Circle::new(*p, 4, c.filled())))?;
        }
        chart.configure_series_labels().border_style(BLACK).draw()?;
    }
    root.present()?;
    Ok(())
}

/// H-RRT-C Tables I / III as a plot: median time against α per scene, with automatic
/// RRT-Connect as a dashed level. The error names the file.
pub fn plot_hrrtc(summaries: &[Summary], limit_s: f64, path: &Path) -> Result<(), LabError> {
    draw_hrrtc(summaries, limit_s, path).map_err(|source| LabError::Draw {
        path: path.to_path_buf(),
        source,
    })
}

fn draw_hrrtc(summaries: &[Summary], limit_s: f64, path: &Path) -> PlotResult {
    let root = BitMapBackend::new(path, (1200, 500)).into_drawing_area();
    root.fill(&WHITE)?;
    let scenes: Vec<String> = dedup(summaries.iter().map(|s| s.scene.clone()));
    let panels = root.split_evenly((1, scenes.len().max(1)));
    for (scene, panel) in scenes.iter().zip(panels.iter()) {
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("{scene}: median time vs α"), ("sans-serif", 22))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(-0.02..1.02, time_axis(summaries, limit_s).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("α")
            .y_desc("median time (s), log")
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()?;
        let mut pts: Vec<(f64, f64)> = summaries
            .iter()
            .filter(|s| &s.scene == scene && s.method.starts_with("hrrtc"))
            .map(|s| (s.alpha, s.median_time_s))
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(pts.clone(), BLUE.stroke_width(2)))?
            .label("H-RRT-C, simulated operator")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
        chart.draw_series(pts.iter().map(|p| Circle::new(*p, 4, BLUE.filled())))?;
        if let Some(a) = summaries
            .iter()
            .find(|s| &s.scene == scene && s.method == "auto")
        {
            let level = a.median_time_s;
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(0.0, level), (1.0, level)],
                    8,
                    6,
                    RED.stroke_width(2),
                ))?
                .label("automatic RRT-Connect")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
        }
        chart.configure_series_labels().border_style(BLACK).draw()?;
    }
    root.present()?;
    Ok(())
}

fn dedup(it: impl Iterator<Item = String>) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for s in it {
        if !v.contains(&s) {
            v.push(s);
        }
    }
    v
}

fn dedup_f(it: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = Vec::new();
    for s in it {
        if !v.contains(&s) {
            v.push(s);
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(method: &str, eps: f64, seed: u64, solved: bool, t: f64) -> RunResult {
        RunResult {
            scene: "maze".into(),
            method: method.into(),
            sigma: 0.05,
            eps_v: eps,
            alpha: f64::NAN,
            seed,
            solved,
            time_s: t,
            iterations: seed * 10,
            nodes: seed,
            collision_checks: 1,
            path_length: 1.0,
            contact_iterations: 0,
        }
    }

    #[test]
    fn summaries_count_unsolved_at_the_limit() {
        let rs = vec![
            r("pos", 0.001, 1, true, 1.0),
            r("pos", 0.001, 2, false, 9.0),
            r("pos", 0.001, 3, true, 2.0),
            r("path", 0.001, 1, true, 4.0),
        ];
        let s = summarize(&rs, 10.0);
        assert_eq!(s.len(), 2);
        let pos = s.iter().find(|x| x.method == "pos").expect("pos");
        assert_eq!(
            (
                pos.runs,
                pos.solved,
                pos.median_time_s,
                pos.median_iterations
            ),
            (3, 2, 2.0, 20.0)
        );
        let md = to_markdown(&s);
        assert!(
            md.contains("| maze | pos | 0.05 | 0.001 | – | 2/3 | 2.000 | 20 | 2 |"),
            "{md}"
        );
        let csv = to_csv(&rs);
        assert_eq!(csv.lines().count(), 5);
        assert!(
            csv.lines()
                .nth(2)
                .expect("row")
                .starts_with("maze,pos,0.05,0.001,NaN,2,false,")
        );
        assert!(median(&mut []).is_nan());
        assert_eq!(median(&mut [3.0, 1.0]), 2.0);
    }

    #[test]
    fn plots_are_written_when_a_font_exists() {
        if !register_font() {
            return; // No system font: plots are skipped by design (see `register_font`).
        }
        let rs = vec![
            r("pos", 0.001, 1, true, 1.0),
            r("pos", 0.01, 1, true, 0.5),
            r("path", 0.001, 1, true, 2.0),
        ];
        let s = summarize(&rs, 10.0);
        let dir = std::env::temp_dir().join(format!("planner-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        plot_irrt(&s, 10.0, &dir.join("irrt.png")).expect("plot");
        let meta = std::fs::metadata(dir.join("irrt.png")).expect("png");
        assert!(meta.len() > 1000);
    }
}
