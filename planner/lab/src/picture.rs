//! Pictures without a viewer: a projection of the scene, the roadmap coloured by an I-RRT
//! label and the paths onto a coordinate plane (top-down x–y by default), like I-RRT
//! Fig. 9. Drawn with plotters into a PNG; text needs [`crate::register_font`].
//!
//! Obstacles are filled grey shapes (the projected outline of each box, sphere or mesh
//! triangle); edges are thin lines in their tree's colour (start blue, goal green, local
//! trees magenta); nodes are dots coloured by the distance label (green at the goal, red
//! far away) or the collision label (green: extensions from the node made progress; red:
//! they collided); the solution path is thick black, the operator's travelled path cyan.

use crate::LabError;
use nalgebra::Vector3;
use planner_core::Se3;
use planner_core::tree::Tree;
use plotters::prelude::*;
use scene::{Part, Primitive, Scene};
use std::path::Path;

/// Which label colours the nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColorBy {
    /// I-RRT distance label: weighted distance to the goal.
    Distance,
    /// I-RRT collision label: share of extensions from the node that made progress.
    Collision,
}

impl ColorBy {
    /// Parses `distance` or `collision`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "distance" => Some(Self::Distance),
            "collision" => Some(Self::Collision),
            _ => None,
        }
    }
}

/// The projection plane: two scene axes (0 = x, 1 = y, 2 = z).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Plane(pub usize, pub usize);

impl Plane {
    /// Top-down.
    pub const XY: Plane = Plane(0, 1);

    /// Parses `xy`, `xz` or `yz`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "xy" => Some(Plane(0, 1)),
            "xz" => Some(Plane(0, 2)),
            "yz" => Some(Plane(1, 2)),
            _ => None,
        }
    }

    fn name(self) -> String {
        let axis = |i: usize| ["x", "y", "z"][i];
        format!("{}–{}", axis(self.0), axis(self.1))
    }

    fn project(self, p: &Vector3<f64>) -> (f64, f64) {
        (p[self.0], p[self.1])
    }
}

/// What to draw.
#[derive(Debug, Clone, Copy)]
pub struct Picture<'a> {
    /// The scene (obstacles, bounds, start and goal).
    pub scene: &'a Scene,
    /// `[start tree, goal tree, local trees…]` (`Planner::trees`).
    pub trees: &'a [Tree],
    /// The solution path, if any.
    pub solution: Option<&'a [Se3]>,
    /// The operator's travelled path (may be empty).
    pub user_path: &'a [Se3],
    /// Node colours.
    pub color_by: ColorBy,
    /// Projection plane.
    pub plane: Plane,
    /// Title line.
    pub title: &'a str,
}

/// Green (0) → yellow (0.5) → red (1).
fn ramp(t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let lerp = |a: f64, b: f64, u: f64| (a + (b - a) * u).round() as u8;
    if t < 0.5 {
        let u = t / 0.5;
        RGBColor(
            lerp(20.0, 235.0, u),
            lerp(160.0, 190.0, u),
            lerp(60.0, 0.0, u),
        )
    } else {
        let u = (t - 0.5) / 0.5;
        RGBColor(
            lerp(235.0, 210.0, u),
            lerp(190.0, 30.0, u),
            lerp(0.0, 30.0, u),
        )
    }
}

fn tree_color(position: usize) -> RGBAColor {
    match position {
        0 => RGBColor(40, 90, 230).mix(0.35),
        1 => RGBColor(20, 150, 60).mix(0.35),
        _ => RGBColor(200, 30, 180).mix(0.6),
    }
}

/// The projected outline(s) of a part, as polygons in plot coordinates.
fn outlines(part: &Part, plane: Plane) -> Vec<Vec<(f64, f64)>> {
    match &part.primitive {
        Primitive::Box { half_extents_m: h } => {
            let pts: Vec<(f64, f64)> = (0..8)
                .map(|c| {
                    let s = |bit: u32| if c & (1 << bit) == 0 { -1.0 } else { 1.0 };
                    let local = Vector3::new(s(0) * h.x, s(1) * h.y, s(2) * h.z);
                    plane.project(&part.pose.transform_point(&local))
                })
                .collect();
            vec![convex_hull(pts)]
        }
        Primitive::Sphere { radius_m } => {
            let (cx, cy) = plane.project(&part.pose.pos);
            vec![
                (0..32)
                    .map(|k| {
                        let a = k as f64 / 32.0 * std::f64::consts::TAU;
                        (cx + radius_m * a.cos(), cy + radius_m * a.sin())
                    })
                    .collect(),
            ]
        }
        Primitive::Mesh { mesh } => mesh
            .triangles
            .iter()
            .map(|t| {
                t.iter()
                    .map(|&i| {
                        plane.project(&part.pose.transform_point(&mesh.vertices_m[i as usize]))
                    })
                    .collect()
            })
            .collect(),
    }
}

/// Convex hull (Andrew's monotone chain), counter-clockwise.
fn convex_hull(mut pts: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64)> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &(f64, f64)>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// Draws `planner`'s trees, solution and operator path over `scene` into the PNG `file`
/// (`size` = width, height in pixels), titled "`label`: N nodes, solved" (or "not solved").
pub fn draw_planner_png(
    scene: &Scene,
    planner: &planner_core::Planner,
    label: &str,
    color_by: ColorBy,
    plane: Plane,
    file: &Path,
    size: (u32, u32),
) -> Result<(), LabError> {
    let solved = if planner.solved() {
        "solved"
    } else {
        "not solved"
    };
    let title = format!("{label}: {} nodes, {solved}", planner.stats().nodes);
    let pic = Picture {
        scene,
        trees: planner.trees(),
        solution: planner.solution(),
        user_path: planner.user_path(),
        color_by,
        plane,
        title: &title,
    };
    draw_png(&pic, file, size.0, size.1)
}

/// Draws `pic` into a `width`×`height` PNG at `file`. The error names the file.
pub fn draw_png(pic: &Picture<'_>, file: &Path, width: u32, height: u32) -> Result<(), LabError> {
    draw(pic, file, width, height).map_err(|source| LabError::Draw {
        path: file.to_path_buf(),
        source,
    })
}

fn draw(
    pic: &Picture<'_>,
    file: &Path,
    width: u32,
    height: u32,
) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let plane = pic.plane;
    let scene = pic.scene;
    // Plot range: the bounds of the reference point grown by the object's reach, and a
    // margin; equal scale on both axes.
    let r = scene.object_radius_m();
    let (lo, hi) = (scene.bounds.min_m, scene.bounds.max_m);
    let (mut x0, mut x1) = (lo[plane.0] - r, hi[plane.0] + r);
    let (mut y0, mut y1) = (lo[plane.1] - r, hi[plane.1] + r);
    let plot_w = f64::from(width.saturating_sub(90).max(10));
    let plot_h = f64::from(height.saturating_sub(110).max(10));
    let per_px = ((x1 - x0) / plot_w).max((y1 - y0) / plot_h);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    (x0, x1) = (cx - per_px * plot_w / 2.0, cx + per_px * plot_w / 2.0);
    (y0, y1) = (cy - per_px * plot_h / 2.0, cy + per_px * plot_h / 2.0);

    let root = BitMapBackend::new(file, (width, height)).into_drawing_area();
    root.fill(&WHITE)?;
    let label = match pic.color_by {
        ColorBy::Distance => "nodes by distance label (green near goal → red far)",
        ColorBy::Collision => "nodes by collision label (green free → red colliding)",
    };
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("{} — {}; {label}", pic.title, plane.name()),
            ("sans-serif", 16),
        )
        .margin(15)
        .x_label_area_size(35)
        .y_label_area_size(50)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    let axis = |i: usize| ["x (m)", "y (m)", "z (m)"][i];
    chart
        .configure_mesh()
        .x_desc(axis(plane.0))
        .y_desc(axis(plane.1))
        .light_line_style(WHITE)
        .draw()?;

    let grey = RGBColor(150, 155, 165).mix(0.55);
    for part in &scene.obstacles {
        for poly in outlines(part, plane) {
            chart.draw_series(std::iter::once(Polygon::new(poly, grey.filled())))?;
        }
    }
    // Bounds of the reference point.
    let (bx0, by0) = plane.project(&lo);
    let (bx1, by1) = plane.project(&hi);
    chart.draw_series(std::iter::once(PathElement::new(
        vec![(bx0, by0), (bx1, by0), (bx1, by1), (bx0, by1), (bx0, by0)],
        RGBColor(120, 120, 120).stroke_width(1),
    )))?;

    for (k, tree) in pic.trees.iter().enumerate() {
        let c = tree_color(k);
        chart.draw_series(tree.nodes().iter().filter_map(|n| {
            let p = tree.node(n.parent?).config.pos;
            Some(PathElement::new(
                vec![plane.project(&p), plane.project(&n.config.pos)],
                c.stroke_width(1),
            ))
        }))?;
    }
    let max_d = pic
        .trees
        .iter()
        .flat_map(|t| t.nodes().iter().map(|n| n.labels.distance_to_goal))
        .filter(|d| d.is_finite())
        .fold(1e-9, f64::max);
    let total: usize = pic.trees.iter().map(Tree::len).sum();
    let dot = if total > 5000 { 1 } else { 2 };
    for tree in pic.trees {
        chart.draw_series(tree.nodes().iter().map(|n| {
            let t = match pic.color_by {
                ColorBy::Distance => n.labels.distance_to_goal / max_d,
                ColorBy::Collision => 1.0 - n.labels.freedom(),
            };
            Circle::new(plane.project(&n.config.pos), dot, ramp(t).filled())
        }))?;
    }
    if pic.user_path.len() >= 2 {
        chart.draw_series(std::iter::once(PathElement::new(
            pic.user_path
                .iter()
                .map(|q| plane.project(&q.pos))
                .collect::<Vec<_>>(),
            RGBColor(0, 190, 210).stroke_width(2),
        )))?;
    }
    if let Some(path) = pic.solution {
        chart.draw_series(std::iter::once(PathElement::new(
            path.iter()
                .map(|q| plane.project(&q.pos))
                .collect::<Vec<_>>(),
            BLACK.stroke_width(3),
        )))?;
    }
    for (q, c, name) in [
        (&scene.start, RGBColor(40, 90, 230), "start"),
        (&scene.goal, RGBColor(20, 150, 60), "goal"),
    ] {
        let p = plane.project(&q.pos);
        chart.draw_series(std::iter::once(Circle::new(p, 9, WHITE.filled())))?;
        chart.draw_series(std::iter::once(Circle::new(p, 7, c.filled())))?;
        chart.draw_series(std::iter::once(Text::new(
            name,
            (p.0 + 10.0 * per_px, p.1 + 10.0 * per_px),
            ("sans-serif", 20).into_font().color(&BLACK),
        )))?;
    }
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_of_a_rotated_box_has_its_corners() {
        let part = Part {
            primitive: Primitive::Box {
                half_extents_m: Vector3::new(1.0, 0.5, 0.2),
            },
            pose: Se3::from_rpy(Vector3::zeros(), 0.0, 0.0, 0.3),
        };
        let hull = &outlines(&part, Plane::XY)[0];
        assert_eq!(hull.len(), 4, "{hull:?}");
        // The hull's area is the rectangle's, 2 × 1.
        let area: f64 = (0..4)
            .map(|i| {
                let (a, b) = (hull[i], hull[(i + 1) % 4]);
                a.0 * b.1 - b.0 * a.1
            })
            .sum::<f64>()
            / 2.0;
        assert!((area - 2.0).abs() < 1e-9, "{area}");
        assert!(ramp(0.0).1 > ramp(1.0).1 && ramp(1.0).0 > ramp(0.0).0);
        assert_eq!(Plane::parse("xz"), Some(Plane(0, 2)));
        assert!(Plane::parse("ab").is_none() && ColorBy::parse("x").is_none());
    }
}
