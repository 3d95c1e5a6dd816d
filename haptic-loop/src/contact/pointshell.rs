//! The pointshell: points on the moving object's surface at about voxel spacing, each with
//! its inward unit normal, in the object frame (origin = the object's reference point).
//!
//! Built from the object's parry shapes, so primitives and meshes go through the same code:
//! every cell of a grid of the target spacing that the surface of a part passes through (centre within half a cell diagonal)
//! surface contributes the nearest surface point; one point is kept per grid cell, and points
//! buried inside another part of the object (not on the union's surface) are dropped. The
//! normal is the gradient of the part's signed distance (central differences), negated.
//!
//! Points are grouped into clusters (cells of `CLUSTER_CELLS` points' spacing) with a bounding
//! sphere each, so that the contact stage can reject a whole cluster far from the scene with
//! one voxmap look-up.

use nalgebra::Vector3;
use parry3d_f64::bounding_volume::{Aabb, BoundingVolume};
use parry3d_f64::math::{Pose, Vector as PVec};
use parry3d_f64::shape::SharedShape;
use std::collections::BTreeMap;

use super::error::ContactError;

/// A surface point and its inward normal.
type PointNormal = (Vector3<f64>, Vector3<f64>);

/// Cluster edge, in point spacings.
const CLUSTER_CELLS: f64 = 3.0;

/// A group of consecutive points with a bounding sphere (object frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cluster {
    /// Centre of the bounding sphere, m.
    pub centre: Vector3<f64>,
    /// Radius, m.
    pub radius_m: f64,
    /// Range of the cluster's points in [`Pointshell::points`].
    pub start: u32,
    /// End of the range (exclusive).
    pub end: u32,
}

/// Surface points with inward normals, object frame.
#[derive(Debug, Clone)]
pub struct Pointshell {
    points: Vec<Vector3<f64>>,
    normals: Vec<Vector3<f64>>,
    clusters: Vec<Cluster>,
    spacing_m: f64,
}

fn pvec(v: &Vector3<f64>) -> PVec {
    PVec::new(v.x, v.y, v.z)
}

fn nvec(v: PVec) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

fn signed_distance(pose: &Pose, shape: &SharedShape, p: &Vector3<f64>) -> f64 {
    let q = pvec(p);
    let proj = shape.project_point(pose, q, false);
    let d = (proj.point - q).length();
    if proj.is_inside { -d } else { d }
}

impl Pointshell {
    /// Samples the surface of the union of `parts` (poses in the object frame) at about
    /// `spacing_m`. Fails on a non-positive spacing or an object without surface.
    pub fn build(parts: &[(Pose, SharedShape)], spacing_m: f64) -> Result<Self, ContactError> {
        if !(spacing_m.is_finite() && spacing_m > 0.0) {
            return Err(ContactError::Spacing(spacing_m));
        }
        let h = spacing_m;
        let key = |p: &Vector3<f64>| [p.x, p.y, p.z].map(|c| (c / h).floor() as i64);
        // One point per cell, ordered by cell so that the result is deterministic.
        let mut cells: BTreeMap<[i64; 3], (Vector3<f64>, Vector3<f64>)> = BTreeMap::new();
        for (i, (pose, shape)) in parts.iter().enumerate() {
            let aabb: Aabb = shape.compute_aabb(pose).loosened(h);
            let lo = key(&nvec(aabb.mins));
            let hi = key(&nvec(aabb.maxs));
            let cells_needed = (0..3).map(|a| (hi[a] - lo[a] + 1) as f64).product::<f64>();
            if cells_needed > 5e8 {
                return Err(ContactError::PartTooLarge {
                    part: i,
                    cells: cells_needed,
                    spacing_mm: h * 1e3,
                });
            }
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        let c = Vector3::new(x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5) * h;
                        let proj = shape.project_point(pose, pvec(&c), false);
                        let s = nvec(proj.point);
                        if (s - c).norm() > 0.87 * h {
                            continue;
                        }
                        let buried = parts
                            .iter()
                            .enumerate()
                            .any(|(j, (pj, sj))| j != i && signed_distance(pj, sj, &s) < -1e-9);
                        if buried {
                            continue;
                        }
                        let e = 1e-3 * h;
                        let grad = Vector3::new(
                            signed_distance(pose, shape, &(s + Vector3::x() * e))
                                - signed_distance(pose, shape, &(s - Vector3::x() * e)),
                            signed_distance(pose, shape, &(s + Vector3::y() * e))
                                - signed_distance(pose, shape, &(s - Vector3::y() * e)),
                            signed_distance(pose, shape, &(s + Vector3::z() * e))
                                - signed_distance(pose, shape, &(s - Vector3::z() * e)),
                        );
                        let Some(outward) = grad.try_normalize(1e-12) else {
                            continue;
                        };
                        cells.entry(key(&s)).or_insert((s, -outward));
                    }
                }
            }
        }
        // Sharp features: grid sampling rarely lands on a box's corners and edges, where a
        // tilted object touches first, so they are sampled explicitly and take their cell.
        for (i, (pose, shape)) in parts.iter().enumerate() {
            let Some(cuboid) = shape.as_cuboid() else {
                continue;
            };
            let he = nvec(cuboid.half_extents);
            for (p_local, outward_local) in box_features(&he, h) {
                let p = nvec(pose.transform_point(pvec(&p_local)));
                let outward = nvec(pose.rotation * pvec(&outward_local));
                let buried = parts
                    .iter()
                    .enumerate()
                    .any(|(j, (pj, sj))| j != i && signed_distance(pj, sj, &p) < -1e-9);
                if !buried {
                    cells.insert(key(&p), (p, -outward));
                }
            }
        }
        if cells.is_empty() {
            return Err(ContactError::NoSurface);
        }

        // Group by cluster cell; points of a cluster are stored contiguously.
        let ck =
            |p: &Vector3<f64>| [p.x, p.y, p.z].map(|c| (c / (h * CLUSTER_CELLS)).floor() as i64);
        let mut groups: BTreeMap<[i64; 3], Vec<PointNormal>> = BTreeMap::new();
        for (p, n) in cells.into_values() {
            groups.entry(ck(&p)).or_default().push((p, n));
        }
        let mut shell = Self {
            points: Vec::new(),
            normals: Vec::new(),
            clusters: Vec::with_capacity(groups.len()),
            spacing_m: h,
        };
        for members in groups.into_values() {
            let start = shell.points.len() as u32;
            let (mut lo, mut hi) = (members[0].0, members[0].0);
            for (p, _) in &members {
                lo = lo.inf(p);
                hi = hi.sup(p);
            }
            let centre = (lo + hi) / 2.0;
            let radius_m = members
                .iter()
                .map(|(p, _)| (p - centre).norm())
                .fold(0.0, f64::max);
            for (p, n) in members {
                shell.points.push(p);
                shell.normals.push(n);
            }
            shell.clusters.push(Cluster {
                centre,
                radius_m,
                start,
                end: shell.points.len() as u32,
            });
        }
        Ok(shell)
    }

    /// Points, object frame, m.
    pub fn points(&self) -> &[Vector3<f64>] {
        &self.points
    }

    /// Inward unit normals, object frame, one per point.
    pub fn normals(&self) -> &[Vector3<f64>] {
        &self.normals
    }

    /// Clusters of consecutive points.
    pub fn clusters(&self) -> &[Cluster] {
        &self.clusters
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when there are no points (never after a successful build).
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Target spacing, m.
    pub fn spacing_m(&self) -> f64 {
        self.spacing_m
    }

    /// Radius of the sphere about `centre` (object frame) that holds every point, m.
    pub fn radius_about(&self, centre: &Vector3<f64>) -> f64 {
        self.points
            .iter()
            .map(|p| (p - centre).norm())
            .fold(0.0, f64::max)
    }
}

/// Points on the 12 edges (corners included) of a box of half extents `he`, at most `h`
/// apart, with the outward normal of each: the normalised sum of the adjacent faces'.
fn box_features(he: &Vector3<f64>, h: f64) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    let mut out = Vec::new();
    for axis in 0..3 {
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        let steps = ((2.0 * he[axis]) / h).ceil().max(1.0) as usize;
        for (sa, sb) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
            for k in 0..=steps {
                let mut p = Vector3::zeros();
                p[axis] = -he[axis] + 2.0 * he[axis] * k as f64 / steps as f64;
                p[a] = sa * he[a];
                p[b] = sb * he[b];
                let mut n = Vector3::zeros();
                n[a] = sa;
                n[b] = sb;
                if k == 0 || k == steps {
                    n[axis] = if k == 0 { -1.0 } else { 1.0 };
                }
                out.push((p, n.normalize()));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_points_lie_on_the_surface_with_inward_normals() {
        let parts = vec![(Pose::IDENTITY, SharedShape::cuboid(0.01, 0.01, 0.01))];
        let s = Pointshell::build(&parts, 0.001).unwrap();
        // 6 faces of 20 × 20 mm at 1 mm: about 2400 points.
        assert!((2200..=2700).contains(&s.len()), "{} points", s.len());
        for (p, n) in s.points().iter().zip(s.normals()) {
            assert!((p.amax() - 0.01).abs() < 1e-9, "{p:?} off the surface");
            // Inward: stepping along the normal goes inside.
            let q = p + n * 1e-4;
            assert!(q.amax() < 0.01, "{p:?} normal {n:?}");
            assert!((n.norm() - 1.0).abs() < 1e-9);
        }
        // Clusters partition the points.
        let covered: u32 = s.clusters().iter().map(|c| c.end - c.start).sum();
        assert_eq!(covered as usize, s.len());
        for c in s.clusters() {
            for p in &s.points()[c.start as usize..c.end as usize] {
                assert!((p - c.centre).norm() <= c.radius_m + 1e-12);
            }
        }
    }

    #[test]
    fn buried_points_of_overlapping_parts_are_dropped() {
        // Two boxes overlapping by half: no point may lie strictly inside the union.
        let parts = vec![
            (Pose::IDENTITY, SharedShape::cuboid(0.01, 0.01, 0.01)),
            (
                Pose::translation(0.01, 0.0, 0.0),
                SharedShape::cuboid(0.01, 0.01, 0.01),
            ),
        ];
        let s = Pointshell::build(&parts, 0.001).unwrap();
        for p in s.points() {
            let inside_both = p.x > -0.01 + 1e-6
                && p.x < 0.02 - 1e-6
                && p.y.abs() < 0.01 - 1e-6
                && p.z.abs() < 0.01 - 1e-6;
            assert!(!inside_both, "buried point {p:?}");
        }
    }

    #[test]
    fn bad_spacing_is_an_error() {
        let parts = vec![(Pose::IDENTITY, SharedShape::ball(0.01))];
        assert!(Pointshell::build(&parts, 0.0).is_err());
        assert!(Pointshell::build(&parts, f64::NAN).is_err());
        assert!(Pointshell::build(&[], 0.001).is_err());
    }
}
