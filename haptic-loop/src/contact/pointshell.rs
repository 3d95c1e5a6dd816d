//! The pointshell: points on the moving object's surface at about voxel spacing, each with
//! its inward unit normal, in the object frame (origin = the object's reference point).
//!
//! Every cell of a grid of the target spacing that the surface of a part passes through
//! (centre within half a cell diagonal) contributes the surface point nearest its centre;
//! one point is kept per grid cell, and points buried inside another part of the object (not
//! on the union's surface) are dropped. A triangle mesh is sampled triangle by triangle
//! (each visits the cells around it, so the cost follows the surface), its normal the
//! angle-weighted pseudo-normal of the feature holding the point, negated; a primitive by
//! projecting the cell centres of its box, its normal the gradient of its signed distance
//! (central differences), negated. An open mesh (a sheet) gets each point twice, once with
//! each normal, so either side can touch.
//!
//! Points are grouped into clusters (cells of `CLUSTER_CELLS` points' spacing) with a bounding
//! sphere each, so that the contact stage can reject a whole cluster far from the scene with
//! one voxmap look-up, and clusters into groups (cells of `GROUP_CLUSTERS` clusters), so that
//! a large object does not cost a look at each of its clusters per tick.
//!
//! # Levels of detail
//!
//! The points also form [`LEVELS`] nested pointshells, level L at about 2^L spacings
//! (Barbič & James's multi-resolution pointshells, built here by clustering): level L
//! groups the points of level L − 1 by cells of 2^L spacings and, within a cell, by normal
//! (a point joins the first group whose normal is within 30° of its own, so the
//! faces meeting at an edge and the edge points between them stay apart); each group is
//! represented by its member nearest the group's weighted centroid, which carries the
//! group's weight: the number of level-0 points it stands for, i.e. its share of the
//! surface in point areas. Every level's weights sum to the point count, so a flat patch
//! pressed uniformly gets the same total stiffness and force at every level. Each level is
//! a pointshell of its own ([`Pointshell::with_coarser`]) with clusters and groups at its
//! spacing, so a search at level L costs what its points cost, not level 0's clusters.

use nalgebra::Vector3;
use parry3d_f64::bounding_volume::{Aabb, BoundingVolume};
use parry3d_f64::math::{Pose, Vector as PVec};
use parry3d_f64::shape::SharedShape;
use std::collections::BTreeMap;

use super::error::ContactError;
use super::mesh::{Feature, Mesh};
use scene::progress::Progress;

/// A surface point and its inward normal.
type PointNormal = (Vector3<f64>, Vector3<f64>);

/// Cluster edge, in point spacings.
const CLUSTER_CELLS: f64 = 3.0;

/// Group edge, in clusters.
const GROUP_CLUSTERS: i64 = 8;

/// Number of levels of detail (level 0 is every point).
pub const LEVELS: usize = 5;

/// Points whose normals differ by more than this (30°, as its cosine) are never grouped
/// into one coarser point.
const GROUP_COS: f64 = 0.866;

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

/// Consecutive clusters with a sphere holding all their points (object frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClusterGroup {
    /// Centre of the bounding sphere, m.
    pub centre: Vector3<f64>,
    /// Radius, m.
    pub radius_m: f64,
    /// Range of the group's clusters in [`Pointshell::clusters`].
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
    groups: Vec<ClusterGroup>,
    /// Per point: the number of level-0 points it stands for (1 at level 0).
    weights: Vec<f64>,
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
        Self::build_with(parts, &[], spacing_m, &Progress::default())
    }

    /// [`Self::build`], where the parts `open` marks (by index; missing: closed) are open
    /// meshes: each of their points is sampled twice, once with each normal, so that
    /// either side of the sheet can touch. Triangle meshes are sampled from their
    /// triangles (a cost that follows their surface, not their box); the build reports to
    /// and stops on `progress`.
    pub fn build_with(
        parts: &[(Pose, SharedShape)],
        open: &[bool],
        spacing_m: f64,
        progress: &Progress,
    ) -> Result<Self, ContactError> {
        if !(spacing_m.is_finite() && spacing_m > 0.0) {
            return Err(ContactError::Spacing(spacing_m));
        }
        let h = spacing_m;
        let key = |p: &Vector3<f64>| cell_of(p, h);
        // One point per cell, ordered by cell so that the result is deterministic.
        let mut cells: BTreeMap<[i64; 3], (Vector3<f64>, Vector3<f64>)> = BTreeMap::new();
        // Open parts' points with their other normal.
        let mut backs: BTreeMap<[i64; 3], (Vector3<f64>, Vector3<f64>)> = BTreeMap::new();
        let buried = |i: usize, s: &Vector3<f64>| {
            parts
                .iter()
                .enumerate()
                .any(|(j, (pj, sj))| j != i && signed_distance(pj, sj, s) < -1e-9)
        };
        let triangles: u64 = parts
            .iter()
            .filter_map(|(_, s)| s.as_trimesh())
            .map(|t| t.indices().len() as u64)
            .sum();
        progress.stage("pointshell", triangles);
        for (i, (pose, shape)) in parts.iter().enumerate() {
            if let Some(trimesh) = shape.as_trimesh() {
                let vertices: Vec<Vector3<f64>> = trimesh
                    .vertices()
                    .iter()
                    .map(|v| nvec(pose.transform_point(*v)))
                    .collect();
                let mesh = Mesh::new(&vertices, trimesh.indices());
                let sampled = surface_points(&mesh, h, progress).ok_or(ContactError::Cancelled)?;
                for (s, outward) in sampled {
                    if buried(i, &s) {
                        continue;
                    }
                    cells.entry(key(&s)).or_insert((s, -outward));
                    if open.get(i).copied().unwrap_or(false) {
                        backs.entry(key(&s)).or_insert((s, outward));
                    }
                }
                continue;
            }
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
                        if buried(i, &s) {
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
                if !buried(i, &p) {
                    cells.insert(key(&p), (p, -outward));
                }
            }
        }
        if cells.is_empty() {
            return Err(ContactError::NoSurface);
        }

        Ok(Self::clustered(
            cells
                .into_values()
                .chain(backs.into_values())
                .map(|(p, n)| (p, n, 1.0))
                .collect(),
            h,
        ))
    }

    /// This pointshell (level 0) and its [`LEVELS`] − 1 coarser levels of detail (see the
    /// module docs), each a pointshell of its own with clusters and groups at its spacing.
    pub fn with_coarser(self) -> Vec<Self> {
        let h = self.spacing_m;
        let finest: Vec<PointNormal> = self
            .points
            .iter()
            .copied()
            .zip(self.normals.iter().copied())
            .collect();
        let weights = levels(&finest, h);
        let mut out = vec![self];
        for (level, w) in weights.iter().enumerate().skip(1) {
            let entries = finest
                .iter()
                .zip(w)
                .filter(|(_, w)| **w > 0.0)
                .map(|(&(p, n), &w)| (p, n, w))
                .collect();
            out.push(Self::clustered(entries, h * f64::from(1u32 << level)));
        }
        out
    }

    /// Points (position, inward normal, weight) at `spacing_m` grouped into clusters and
    /// groups; the points of a cluster, and the clusters of a group, are consecutive.
    /// Deterministic: in cell order, and in the given order within a cell.
    fn clustered(entries: Vec<(Vector3<f64>, Vector3<f64>, f64)>, spacing_m: f64) -> Self {
        let ck = |p: &Vector3<f64>| cell_of(p, spacing_m * CLUSTER_CELLS);
        // Keyed by (group cell, cluster cell): a group's clusters are consecutive.
        type Entry = (Vector3<f64>, Vector3<f64>, f64);
        let mut cells: BTreeMap<([i64; 3], [i64; 3]), Vec<Entry>> = BTreeMap::new();
        for e in entries {
            let c = ck(&e.0);
            let g = c.map(|x| x.div_euclid(GROUP_CLUSTERS));
            cells.entry((g, c)).or_default().push(e);
        }
        let group_of: Vec<[i64; 3]> = cells.keys().map(|(g, _)| *g).collect();
        let mut shell = Self {
            points: Vec::new(),
            normals: Vec::new(),
            weights: Vec::new(),
            clusters: Vec::with_capacity(cells.len()),
            groups: Vec::new(),
            spacing_m,
        };
        for members in cells.into_values() {
            let start = shell.points.len() as u32;
            let (centre, radius_m) = sphere_around(members.iter().map(|(p, _, _)| (*p, 0.0)));
            for (p, n, w) in members {
                shell.points.push(p);
                shell.normals.push(n);
                shell.weights.push(w);
            }
            shell.clusters.push(Cluster {
                centre,
                radius_m,
                start,
                end: shell.points.len() as u32,
            });
        }
        shell.groups = cluster_groups(&shell.clusters, &group_of);
        shell
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

    /// Groups of consecutive clusters.
    pub fn groups(&self) -> &[ClusterGroup] {
        &self.groups
    }

    /// Weights, one per point: the number of level-0 points each stands for (all 1 at
    /// level 0; at each level they sum to level 0's point count).
    pub fn weights(&self) -> &[f64] {
        &self.weights
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

/// The cell of a grid of `size_m` cells (origin at a corner) holding `p`.
fn cell_of(p: &Vector3<f64>, size_m: f64) -> [i64; 3] {
    [p.x, p.y, p.z].map(|c| (c / size_m).floor() as i64)
}

/// A sphere holding the given spheres (centre, radius in m; radius 0 for points): centred
/// in the box of their centres. Not the smallest, but cheap and deterministic.
fn sphere_around(
    spheres: impl Iterator<Item = (Vector3<f64>, f64)> + Clone,
) -> (Vector3<f64>, f64) {
    let mut centres = spheres.clone().map(|(c, _)| c);
    let first = centres.next().expect("at least one sphere");
    let (lo, hi) = centres.fold((first, first), |(lo, hi), c| (lo.inf(&c), hi.sup(&c)));
    let centre = (lo + hi) / 2.0;
    let radius_m = spheres
        .map(|(c, r)| (c - centre).norm() + r)
        .fold(0.0, f64::max);
    (centre, radius_m)
}

/// The groups of `clusters`, where `group_of[i]` is cluster i's group cell (consecutive
/// clusters of one cell form a group), each with a sphere holding its clusters' spheres.
fn cluster_groups(clusters: &[Cluster], group_of: &[[i64; 3]]) -> Vec<ClusterGroup> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < clusters.len() {
        let end = (start..clusters.len())
            .find(|&i| group_of[i] != group_of[start])
            .unwrap_or(clusters.len());
        let (centre, radius_m) =
            sphere_around(clusters[start..end].iter().map(|c| (c.centre, c.radius_m)));
        out.push(ClusterGroup {
            centre,
            radius_m,
            start: start as u32,
            end: end as u32,
        });
        start = end;
    }
    out
}

/// The levels of detail of `points` (spacing `h`; see the module docs): for each level the
/// weight of every point (0 where it does not belong). Deterministic: cells are visited in
/// key order, members in index order.
fn levels(points: &[PointNormal], h: f64) -> [Vec<f64>; LEVELS] {
    let n = points.len();
    let mut weights: [Vec<f64>; LEVELS] = std::array::from_fn(|_| vec![0.0; n]);
    weights[0].fill(1.0);
    let mut members: Vec<usize> = (0..n).collect();
    for level in 1..LEVELS {
        let cell = h * f64::from(1u32 << level);
        // Per cell, groups of (member indices), each led by its first member's normal.
        let mut cells: BTreeMap<[i64; 3], Vec<Vec<usize>>> = BTreeMap::new();
        for &i in &members {
            let (p, normal) = &points[i];
            let key = cell_of(p, cell);
            let groups = cells.entry(key).or_default();
            match groups
                .iter_mut()
                .find(|g| points[g[0]].1.dot(normal) >= GROUP_COS)
            {
                Some(g) => g.push(i),
                None => groups.push(vec![i]),
            }
        }
        let (finer, rest) = weights.split_at_mut(level);
        let (finer, this) = (&finer[level - 1], &mut rest[0]);
        let mut next = Vec::with_capacity(cells.len());
        for group in cells.values().flatten() {
            let total: f64 = group.iter().map(|&i| finer[i]).sum();
            let centroid = group
                .iter()
                .map(|&i| points[i].0 * finer[i])
                .sum::<Vector3<f64>>()
                / total;
            let rep = group
                .iter()
                .copied()
                .min_by(|&a, &b| {
                    let da = (points[a].0 - centroid).norm_squared();
                    let db = (points[b].0 - centroid).norm_squared();
                    da.total_cmp(&db).then(a.cmp(&b))
                })
                .expect("groups are not empty");
            this[rep] = total;
            next.push(rep);
        }
        next.sort_unstable();
        members = next;
    }
    weights
}

/// For every cell of a grid of spacing `h` whose centre lies within half a cell diagonal
/// of `mesh`, the mesh's point nearest the centre with the unit outward pseudo-normal of
/// the feature (face, edge, vertex) holding it, in cell order: what projecting each cell
/// centre on the mesh gives, found triangle by triangle (each visits only the cells around
/// it). `None` when `progress` was cancelled.
fn surface_points(
    mesh: &Mesh,
    h: f64,
    progress: &Progress,
) -> Option<Vec<(Vector3<f64>, Vector3<f64>)>> {
    let reach = 0.87 * h;
    // Cell → (squared distance from its centre, point, triangle, feature).
    let mut best: foldhash::HashMap<[i64; 3], (f64, Vector3<f64>, u32, Feature)> =
        foldhash::HashMap::with_capacity_and_hasher(mesh.len() * 2, Default::default());
    for t in 0..mesh.len() as u32 {
        if t.is_multiple_of(8192) && t > 0 {
            if progress.cancelled() {
                return None;
            }
            progress.add(8192);
        }
        let c = mesh.corners(t);
        let lo = c[0].inf(&c[1]).inf(&c[2]).add_scalar(-reach);
        let hi = c[0].sup(&c[1]).sup(&c[2]).add_scalar(reach);
        let (a, z) = (cell_of(&lo, h), cell_of(&hi, h));
        for k in a[2]..=z[2] {
            for j in a[1]..=z[1] {
                for i in a[0]..=z[0] {
                    let centre = Vector3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * h;
                    let at = mesh.closest(t, &centre);
                    if at.distance2 > reach * reach {
                        continue;
                    }
                    let e =
                        best.entry([i, j, k])
                            .or_insert((f64::INFINITY, at.point, t, at.feature));
                    if at.distance2 < e.0 {
                        *e = (at.distance2, at.point, t, at.feature);
                    }
                }
            }
        }
    }
    let mut out: Vec<([i64; 3], Vector3<f64>, Vector3<f64>)> = best
        .into_iter()
        .filter_map(|(cell, (_, p, t, f))| {
            let n = mesh.pseudo_normal(t, f).try_normalize(1e-12)?;
            Some((cell, p, n))
        })
        .collect();
    out.sort_unstable_by_key(|(cell, _, _)| *cell);
    Some(out.into_iter().map(|(_, p, n)| (p, n)).collect())
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

    /// A mesh part's points (sampled from its triangles) lie on its surface with inward
    /// normals, one per cell, as a primitive's do: a box mesh and the box give the same
    /// cells, and a bumpy sphere's points lie on it.
    #[test]
    fn mesh_points_come_from_the_triangles_on_the_surface_with_inward_normals() {
        use scene::{MeshData, Part, Primitive, Se3};
        let part = |m: MeshData| Part {
            primitive: Primitive::Mesh {
                mesh: std::sync::Arc::new(m),
            },
            pose: Se3::from_xyz(0.003, -0.002, 0.001),
        };
        let boxed =
            scene::shapes::part_shapes(&[part(MeshData::cuboid("box", [0.01, 0.015, 0.02]))]);
        let primitive = scene::shapes::part_shapes(&[Part::axis_box(
            [0.01, 0.015, 0.02],
            [0.003, -0.002, 0.001],
        )]);
        let (m, p) = (
            Pointshell::build(&boxed, 0.001).unwrap(),
            Pointshell::build(&primitive, 0.001).unwrap(),
        );
        let cells = |s: &Pointshell| -> std::collections::BTreeSet<[i64; 3]> {
            s.points().iter().map(|q| cell_of(q, 0.001)).collect()
        };
        let (cm, cp) = (cells(&m), cells(&p));
        let shared = cm.intersection(&cp).count();
        assert!(
            shared as f64 >= 0.97 * cp.len() as f64,
            "{shared} of {} cells",
            cp.len()
        );
        let inside = |q: &Vector3<f64>| {
            let l = q - Vector3::new(0.003, -0.002, 0.001);
            l.x.abs() < 0.01 && l.y.abs() < 0.015 && l.z.abs() < 0.02
        };
        for (q, n) in m.points().iter().zip(m.normals()) {
            assert!(
                !inside(&(q - n * 1e-4)) && inside(&(q + n * 1e-4)),
                "{q:?} {n:?}"
            );
        }
        let sphere = scene::shapes::part_shapes(&[part(MeshData::bumpy_sphere("s", 0.03, 40, 80))]);
        let s = Pointshell::build(&sphere, 0.001).unwrap();
        for (q, n) in s.points().iter().zip(s.normals()) {
            let (pose, shape) = &sphere[0];
            assert!(
                signed_distance(pose, shape, q).abs() < 1e-9,
                "{q:?} off the surface"
            );
            assert!(
                signed_distance(pose, shape, &(q + n * 1e-4)) < 0.0,
                "{q:?} normal {n:?}"
            );
        }
    }

    /// An open part (a square sheet) gets each point with both normals.
    #[test]
    fn an_open_part_has_points_facing_both_ways() {
        use scene::{MeshData, Part, Primitive, Se3};
        let v = vec![
            Vector3::new(-0.01, -0.01, 0.0),
            Vector3::new(0.01, -0.01, 0.0),
            Vector3::new(0.01, 0.01, 0.0),
            Vector3::new(-0.01, 0.01, 0.0),
        ];
        let sheet = MeshData::new("sheet", v, vec![[0, 1, 2], [0, 2, 3]]).unwrap();
        let parts = scene::shapes::part_shapes(&[Part {
            primitive: Primitive::Mesh {
                mesh: std::sync::Arc::new(sheet),
            },
            pose: Se3::identity(),
        }]);
        let s = Pointshell::build_with(&parts, &[true], 0.001, &Progress::default()).unwrap();
        let up = s.normals().iter().filter(|n| n.z > 0.99).count();
        let down = s.normals().iter().filter(|n| n.z < -0.99).count();
        assert!(
            up > 300 && up == down,
            "{up} up, {down} down of {}",
            s.len()
        );
        let closed = Pointshell::build(&parts, 0.001).unwrap();
        assert_eq!(closed.len() * 2, s.len());
    }

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
        // Groups partition the clusters and hold their points.
        let mut next = 0;
        for g in s.groups() {
            assert_eq!(g.start, next);
            assert!(g.end > g.start);
            next = g.end;
            for c in &s.clusters()[g.start as usize..g.end as usize] {
                for p in &s.points()[c.start as usize..c.end as usize] {
                    assert!((p - g.centre).norm() <= g.radius_m + 1e-12);
                }
            }
        }
        assert_eq!(next as usize, s.clusters().len());
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
    fn levels_are_nested_and_their_weights_sum_to_the_point_count() {
        let parts = vec![(Pose::IDENTITY, SharedShape::cuboid(0.02, 0.01, 0.015))];
        let levels = Pointshell::build(&parts, 0.001).unwrap().with_coarser();
        assert_eq!(levels.len(), LEVELS);
        let n = levels[0].len() as f64;
        assert!(levels[0].weights().iter().all(|&w| w == 1.0));
        for (level, s) in levels.iter().enumerate() {
            assert_eq!(s.weights().iter().sum::<f64>(), n, "level {level}");
            assert_eq!(s.spacing_m(), 0.001 * f64::from(1u32 << level));
            // Clusters partition the points, groups the clusters.
            let covered: u32 = s.clusters().iter().map(|c| c.end - c.start).sum();
            assert_eq!(covered as usize, s.len());
            assert_eq!(s.groups().last().unwrap().end as usize, s.clusters().len());
            if level > 0 {
                // A coarser point is a finer level's point, with its normal.
                let finer = &levels[level - 1];
                for (p, nrm) in s.points().iter().zip(s.normals()) {
                    let i = finer.points().iter().position(|q| q == p).expect("nested");
                    assert_eq!(finer.normals()[i], *nrm);
                }
                // Faces make up the box: about a quarter of the points per level, while
                // its smallest face (20 mm) is two cells across or more (at 16 mm its
                // edges and corners are most of the points).
                let ratio = finer.len() as f64 / s.len() as f64;
                if 2.0 * s.spacing_m() <= 0.02 {
                    assert!((2.5..=4.5).contains(&ratio), "level {level}: ratio {ratio}");
                } else {
                    assert!(ratio > 1.0, "level {level}: ratio {ratio}");
                }
            }
        }
    }

    #[test]
    fn coarse_points_never_merge_faces_of_a_box() {
        // Faces, edges and corners of a box have normals at least 35° apart, more than a
        // group spans: at every level the weight carried by points of each normal equals
        // the number of level-0 points with that normal, so each face keeps its area.
        let parts = vec![(Pose::IDENTITY, SharedShape::cuboid(0.01, 0.012, 0.008))];
        let levels = Pointshell::build(&parts, 0.001).unwrap().with_coarser();
        let key = |n: &Vector3<f64>| n.map(|c| (c * 100.0).round() as i64);
        let by_normal = |s: &Pointshell| {
            let mut sums: BTreeMap<[i64; 3], f64> = BTreeMap::new();
            for (n, w) in s.normals().iter().zip(s.weights()) {
                let k = key(n);
                *sums.entry([k.x, k.y, k.z]).or_default() += w;
            }
            sums
        };
        let finest = by_normal(&levels[0]);
        // 6 faces, 12 edges, 8 corners.
        assert_eq!(finest.len(), 26, "{finest:?}");
        for (level, s) in levels.iter().enumerate().skip(1) {
            assert_eq!(by_normal(s), finest, "level {level}");
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
