//! Scaling measurements for the `scaling` harness: contact-stage step time against
//! pointshell size, and planner iteration cost against tree size; log–log plots.

use crate::BenchError;
use crate::contact_fixture::{Fixture, Situation};
use haptic_loop::stats::{NsHistogram, Percentiles};
use planner_core::{Planner, PlannerParams, Scene};
use serde::Serialize;
use std::path::Path;
use std::time::{Duration, Instant};

/// Contact step time at one pointshell size.
#[derive(Debug, Clone, Serialize)]
pub struct TickPoint {
    /// Fixture: `cube-resting` (a cube face-down on a plate: a sixth of the points in
    /// contact), `cube-free` (far from the plate: all culled), `s-on-wall` (the wall-hole
    /// S sliding on the wall).
    pub case: String,
    /// Voxel size, mm.
    pub voxel_mm: f64,
    /// Pointshell points.
    pub points: usize,
    /// Step time, µs.
    pub step_us: Percentiles,
}

/// Planner iteration cost at one tree size.
#[derive(Debug, Clone, Serialize)]
pub struct PlannerPoint {
    /// Scene.
    pub scene: String,
    /// Nodes in all trees, in the middle of the batch.
    pub nodes: usize,
    /// Iterations in the batch.
    pub iterations: u64,
    /// Mean time per iteration over the batch, µs.
    pub mean_us: f64,
}

/// Steps `fixture` `steps` times and records each step's time.
pub fn time_steps(fixture: &mut Fixture, steps: usize) -> Percentiles {
    let mut h = NsHistogram::new();
    for _ in 0..steps {
        let t = Instant::now();
        std::hint::black_box(fixture.step());
        h.record(t.elapsed().as_nanos() as u64);
    }
    h.percentiles_us()
}

/// Contact step time of the cube fixtures at each size in `points` (1 mm voxels) and of the
/// S on the wall at each voxel size in `s_voxels_mm`, `steps` steps each.
pub fn tick_series(points: &[usize], s_voxels_mm: &[f64], steps: usize) -> Vec<TickPoint> {
    let mut out = Vec::new();
    for &n in points {
        for (case, situation) in [
            ("cube-resting", Situation::Resting),
            ("cube-free", Situation::Free),
        ] {
            let mut f = Fixture::cube_on_plate(n, 0.001, situation);
            out.push(TickPoint {
                case: case.into(),
                voxel_mm: 1.0,
                points: f.points(),
                step_us: time_steps(&mut f, steps),
            });
        }
    }
    for &v in s_voxels_mm {
        let mut f = Fixture::s_on_wall(v / 1000.0);
        out.push(TickPoint {
            case: "s-on-wall".into(),
            voxel_mm: v,
            points: f.points(),
            step_us: time_steps(&mut f, steps),
        });
    }
    out
}

/// Grows automatic RRT-Connect on `scene` (seed 1) in batches of `batch` iterations until
/// `max_nodes`, `budget` or a solution, and returns the mean iteration time per batch.
pub fn planner_series(
    scene: &str,
    batch: u64,
    max_nodes: usize,
    budget: Duration,
) -> Result<Vec<PlannerPoint>, BenchError> {
    let s = Scene::builtin(scene).ok_or_else(|| BenchError::UnknownScene(scene.to_owned()))?;
    let mut p = Planner::new(&s, PlannerParams::default(), 1)?;
    let started = Instant::now();
    let mut out = Vec::new();
    while started.elapsed() < budget && p.stats().nodes < max_nodes && !p.solved() {
        let before = p.stats().nodes;
        let t = Instant::now();
        for _ in 0..batch {
            p.iterate(None);
        }
        let dt = t.elapsed();
        out.push(PlannerPoint {
            scene: scene.into(),
            nodes: (before + p.stats().nodes) / 2,
            iterations: batch,
            mean_us: dt.as_secs_f64() * 1e6 / batch as f64,
        });
    }
    Ok(out)
}

/// Least-squares slope of log y against log x: the exponent of a power law y ∝ x^slope.
/// `None` with fewer than two distinct positive x.
pub fn loglog_slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = logs.len() as f64;
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (logs.len() >= 2 && sxx > 1e-12).then(|| sxy / sxx)
}

type PlotResult = Result<(), Box<dyn std::error::Error>>;

/// One log–log chart of named series.
pub fn plot_loglog(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[(String, Vec<(f64, f64)>)],
) -> PlotResult {
    use plotters::prelude::*;
    let all = || series.iter().flat_map(|s| s.1.iter());
    let (x_lo, x_hi) = all().fold((f64::INFINITY, 0.0f64), |a, p| (a.0.min(p.0), a.1.max(p.0)));
    let (y_lo, y_hi) = all().fold((f64::INFINITY, 0.0f64), |a, p| (a.0.min(p.1), a.1.max(p.1)));
    if !(x_lo.is_finite() && y_lo.is_finite() && x_lo > 0.0 && y_lo > 0.0) {
        return Err("nothing to plot".into());
    }
    let root = BitMapBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(
            (x_lo / 1.5..x_hi * 1.5).log_scale(),
            (y_lo / 1.5..y_hi * 1.5).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .draw()?;
    const COLOURS: [RGBColor; 6] = [RED, BLUE, GREEN, MAGENTA, CYAN, BLACK];
    for (i, (name, pts)) in series.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        chart
            .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
        chart.draw_series(pts.iter().map(|p| Circle::new(*p, 3, c.filled())))?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_of_a_power_law() {
        let pts: Vec<(f64, f64)> = (1..6)
            .map(|i| (i as f64, 3.0 * (i as f64).powi(2)))
            .collect();
        assert!((loglog_slope(&pts).unwrap() - 2.0).abs() < 1e-9);
        assert_eq!(loglog_slope(&[(1.0, 1.0)]), None);
        assert_eq!(loglog_slope(&[(1.0, 1.0), (1.0, 2.0)]), None);
    }

    #[test]
    fn tick_series_records_every_step_of_every_case() {
        let s = tick_series(&[300], &[], 20);
        assert_eq!(s.len(), 2);
        for p in &s {
            assert!(p.points > 100, "{p:?}");
            assert_eq!(p.step_us.count, 20);
            assert!(p.step_us.p50 <= p.step_us.max);
        }
    }

    #[test]
    fn planner_series_stops_at_the_node_limit() {
        let s = planner_series("maze", 50, 300, Duration::from_secs(30)).unwrap();
        assert!(!s.is_empty());
        assert!(s.windows(2).all(|w| w[0].nodes <= w[1].nodes));
        assert!(s.iter().all(|p| p.iterations == 50 && p.mean_us > 0.0));
    }
}
