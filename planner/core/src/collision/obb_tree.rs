//! A bounding-volume tree of oriented boxes over a mesh's triangles, and the mesh against
//! mesh intersection and distance by a simultaneous traversal of two such trees, after
//! Gottschalk, Lin and Manocha, "OBBTree" (SIGGRAPH 1996), the volumes coal and FCL use.
//!
//! Why not parry's own tree: its nodes are boxes aligned with the mesh's axes, and CAD
//! parts are full of long thin triangles that run at an angle to those axes (the alpha
//! puzzle's twisted tubes), whose aligned boxes are mostly empty. On that puzzle a check
//! met ~550 triangle pairs through parry's tree; each box here is fitted to its
//! triangles' principal axes.
//!
//! Triangles that cover the same three points as one already kept (a double-sided mesh
//! repeats each face with the opposite winding) are kept once: they are the same set of
//! points, so intersection and distance answers do not change, and such meshes would
//! otherwise test every pair four times.

use super::obb::{Obb, gap, overlap};
use super::solid::Solid;
use parry3d_f64::math::{Matrix, Vector};
use parry3d_f64::shape::TriMesh;
use std::collections::HashSet;

/// Most triangles in a leaf.
const LEAF_TRIANGLES: usize = 1;

#[derive(Debug, Clone)]
struct Node {
    obb: Obb,
    /// Leaf: the first triangle and the count (> 0); inner node: `count == 0` and the two
    /// children at `first` and `second`.
    first: u32,
    count: u32,
    second: u32,
}

/// The oriented-box tree of one mesh, in the mesh's frame.
#[derive(Debug, Clone)]
pub struct ObbTree {
    nodes: Vec<Node>,
    /// Triangle corners in leaf order.
    triangles: Vec<[Vector; 3]>,
}

impl ObbTree {
    /// The tree of `mesh`'s triangles (kept once per set of three corners).
    pub fn new(mesh: &TriMesh) -> Self {
        let v = mesh.vertices();
        let mut seen = HashSet::new();
        let triangles: Vec<[Vector; 3]> = mesh
            .indices()
            .iter()
            .filter(|t| {
                let mut key = **t;
                key.sort_unstable();
                seen.insert(key)
            })
            .map(|t| t.map(|i| v[i as usize]))
            .collect();
        Self::from_triangles(triangles)
    }

    fn from_triangles(mut triangles: Vec<[Vector; 3]>) -> Self {
        let mut nodes = Vec::with_capacity(2 * triangles.len());
        if !triangles.is_empty() {
            let n = triangles.len();
            build(&mut nodes, &mut triangles, 0, n);
        }
        ObbTree { nodes, triangles }
    }

    /// Triangles kept.
    #[cfg(test)]
    fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// This mesh and `other`, at rotation `r` and translation `t` in this mesh's frame
    /// (`x_self = r·x_other + t`), share a point (surfaces; touching counts).
    pub fn intersects(&self, other: &ObbTree, r: &Matrix, t: &Vector) -> bool {
        if self.nodes.is_empty() || other.nodes.is_empty() {
            return false;
        }
        let mut stack = Vec::with_capacity(64);
        stack.push((0u32, 0u32));
        while let Some((i, j)) = stack.pop() {
            let (a, b) = (&self.nodes[i as usize], &other.nodes[j as usize]);
            if !overlap(&a.obb, &b.obb, r, t) {
                continue;
            }
            match (a.count > 0, b.count > 0) {
                (true, true) => {
                    for ta in &self.triangles[a.first as usize..(a.first + a.count) as usize] {
                        for tb in &other.triangles[b.first as usize..(b.first + b.count) as usize] {
                            let tb = tb.map(|p| *r * p + *t);
                            if super::triangle_pair::triangles_intersect(ta, &tb) {
                                return true;
                            }
                        }
                    }
                }
                // Descend the larger box (or the one that is not a leaf).
                (false, true) => stack.extend([(a.first, j), (a.second, j)]),
                (true, false) => stack.extend([(i, b.first), (i, b.second)]),
                (false, false) => {
                    if a.obb.half.length_squared() >= b.obb.half.length_squared() {
                        stack.extend([(a.first, j), (a.second, j)]);
                    } else {
                        stack.extend([(i, b.first), (i, b.second)]);
                    }
                }
            }
        }
        false
    }

    /// The nearest distance found `N` (m) with `min(distance between the two meshes'
    /// surfaces, cap_m)` in `[N / (1 + rel), N]`, `other` placed as in
    /// [`Self::intersects`]; 0 when they intersect; exact for `rel = 0`. Node pairs are
    /// visited nearer first and pruned once their boxes' gap (a lower bound of their
    /// distance) times `1 + rel` reaches `N`, so every pruned pair is at least
    /// `N / (1 + rel)` apart: a relative tolerance prunes far more pairs when the meshes
    /// are far apart, where an exact distance must rule out every pair of nearly the same
    /// distance. `N` is returned undivided, so the search over several pairs can go on
    /// below it and divide once at the end.
    pub fn distance_up_to(
        &self,
        other: &ObbTree,
        r: &Matrix,
        t: &Vector,
        cap_m: f64,
        rel: f64,
    ) -> f64 {
        let widen = 1.0 + rel.max(0.0);
        if self.nodes.is_empty() || other.nodes.is_empty() {
            return cap_m;
        }
        // Intersecting meshes (common near contact) are found faster by the intersection
        // test, which stops at the first crossing pair; after it no pair intersects.
        if self.intersects(other, r, t) {
            return 0.0;
        }
        let mut nearest = cap_m;
        let mut stack = Vec::with_capacity(64);
        stack.push((
            0u32,
            0u32,
            gap(&self.nodes[0].obb, &other.nodes[0].obb, r, t),
        ));
        while let Some((i, j, g)) = stack.pop() {
            if g * widen >= nearest {
                continue;
            }
            let (a, b) = (&self.nodes[i as usize], &other.nodes[j as usize]);
            if a.count > 0 && b.count > 0 {
                for ta in &self.triangles[a.first as usize..(a.first + a.count) as usize] {
                    for tb in &other.triangles[b.first as usize..(b.first + b.count) as usize] {
                        let tb = tb.map(|p| *r * p + *t);
                        nearest =
                            nearest.min(super::triangle_pair::disjoint_triangle_distance(ta, &tb));
                    }
                }
                continue;
            }
            let split_a = b.count > 0
                || (a.count == 0 && a.obb.half.length_squared() >= b.obb.half.length_squared());
            let children = if split_a {
                [(a.first, j), (a.second, j)]
            } else {
                [(i, b.first), (i, b.second)]
            };
            let [c0, c1] = children.map(|(ci, cj)| {
                let g = gap(
                    &self.nodes[ci as usize].obb,
                    &other.nodes[cj as usize].obb,
                    r,
                    t,
                );
                (ci, cj, g)
            });
            // The nearer pair on top, so it is searched first and tightens the bound.
            let (near, far) = if c0.2 <= c1.2 { (c0, c1) } else { (c1, c0) };
            for c in [far, near] {
                if c.2 * widen < nearest {
                    stack.push(c);
                }
            }
        }
        nearest
    }
}

impl ObbTree {
    /// The mesh meets `solid` (a box or a ball in this mesh's frame): the solid against
    /// each box on the way down, against triangles only at the leaves it reaches.
    pub fn meets_solid(&self, solid: &Solid) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let mut stack = Vec::with_capacity(64);
        stack.push(0u32);
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i as usize];
            if !solid.meets_box(&n.obb) {
                continue;
            }
            if n.count > 0 {
                let leaf = &self.triangles[n.first as usize..(n.first + n.count) as usize];
                if leaf.iter().any(|t| solid.meets_triangle(t)) {
                    return true;
                }
            } else {
                stack.extend([n.second, n.first]);
            }
        }
        false
    }

    /// `p` (this mesh's frame) lies in the box holding the whole mesh: the cheap test
    /// before asking whether a closed mesh holds a point.
    pub fn box_holds(&self, p: Vector) -> bool {
        self.nodes.first().is_some_and(|n| {
            let local = n.obb.axes.transpose() * (p - n.obb.center);
            local.abs().cmple(n.obb.half).all()
        })
    }

    /// The nearest distance found `N` (m) with `min(distance from the mesh to solid,
    /// cap_m)` in `[N / (1 + rel), N]`; 0 when they meet; exact for `rel = 0`. Nearer
    /// boxes first, pruned as in [`Self::distance_up_to`].
    pub fn distance_to_solid_up_to(&self, solid: &Solid, cap_m: f64, rel: f64) -> f64 {
        let widen = 1.0 + rel.max(0.0);
        if self.nodes.is_empty() {
            return cap_m;
        }
        if self.meets_solid(solid) {
            return 0.0;
        }
        let mut nearest = cap_m;
        let mut stack = Vec::with_capacity(64);
        stack.push((0u32, solid.gap_to_box(&self.nodes[0].obb)));
        while let Some((i, g)) = stack.pop() {
            if g * widen >= nearest {
                continue;
            }
            let n = &self.nodes[i as usize];
            if n.count > 0 {
                for t in &self.triangles[n.first as usize..(n.first + n.count) as usize] {
                    nearest = nearest.min(solid.triangle_distance(t));
                }
                continue;
            }
            let [c0, c1] =
                [n.first, n.second].map(|c| (c, solid.gap_to_box(&self.nodes[c as usize].obb)));
            // The nearer child on top, so it is searched first and tightens the bound.
            let (near, far) = if c0.1 <= c1.1 { (c0, c1) } else { (c1, c0) };
            for c in [far, near] {
                if c.1 * widen < nearest {
                    stack.push(c);
                }
            }
        }
        nearest
    }
}

/// Builds the subtree of `triangles[start..end]` (reordered in place), returning its
/// node's index.
fn build(nodes: &mut Vec<Node>, triangles: &mut [[Vector; 3]], start: usize, end: usize) -> u32 {
    let obb = fit(&triangles[start..end]);
    let index = nodes.len() as u32;
    nodes.push(Node {
        obb,
        first: start as u32,
        count: (end - start) as u32,
        second: 0,
    });
    if end - start <= LEAF_TRIANGLES {
        return index;
    }
    // Split across the box's longest axis at the mean of the triangles' centres; at the
    // median when that leaves one side with less than an eighth (a skewed mesh, e.g.
    // triangles spaced geometrically, would otherwise make the tree, and this recursion,
    // as deep as the mesh is long: with the eighth, depth ≤ ln n / ln(8/7), ~105 for a
    // million triangles).
    let axis = obb.axes.col(longest(obb.half));
    let key = |t: &[Vector; 3]| axis.dot(t[0] + t[1] + t[2]);
    let part = &mut triangles[start..end];
    let mean = part.iter().map(key).sum::<f64>() / part.len() as f64;
    let mut mid = partition(part, |t| key(t) < mean);
    if mid.min(part.len() - mid) < part.len().div_ceil(8) {
        mid = part.len() / 2;
        part.select_nth_unstable_by(mid, |a, b| key(a).total_cmp(&key(b)));
    }
    let first = build(nodes, triangles, start, start + mid);
    let second = build(nodes, triangles, start + mid, end);
    let node = &mut nodes[index as usize];
    node.first = first;
    node.second = second;
    node.count = 0;
    index
}

/// Moves the elements for which `left` holds to the front; returns how many.
fn partition(s: &mut [[Vector; 3]], left: impl Fn(&[Vector; 3]) -> bool) -> usize {
    let mut k = 0;
    for i in 0..s.len() {
        if left(&s[i]) {
            s.swap(i, k);
            k += 1;
        }
    }
    k
}

fn longest(h: Vector) -> usize {
    if h.x >= h.y && h.x >= h.z {
        0
    } else if h.y >= h.z {
        1
    } else {
        2
    }
}

/// The box along the principal axes of the triangles' corners that holds them all.
fn fit(triangles: &[[Vector; 3]]) -> Obb {
    let n = (3 * triangles.len()) as f64;
    let corners = || triangles.iter().flatten();
    let mean = corners().fold(Vector::ZERO, |s, p| s + *p) / n;
    let mut c = nalgebra::Matrix3::<f64>::zeros();
    for p in corners() {
        let d = nalgebra::Vector3::new(p.x - mean.x, p.y - mean.y, p.z - mean.z);
        c += d * d.transpose();
    }
    // A degenerate, overflowing or unconverged decomposition (non-finite, not
    // orthonormal) falls back to the mesh's own axes: a looser box, never a wrong one.
    // Bounded iterations: nalgebra's `new` iterates until convergence, which non-finite
    // input (coordinates near 1e154 square to infinity) never reaches.
    let c = c / n;
    let axes = c
        .iter()
        .all(|x| x.is_finite())
        .then(|| nalgebra::SymmetricEigen::try_new(c, f64::EPSILON, 200))
        .flatten()
        .map(|eigen| {
            let e = eigen.eigenvectors;
            Matrix::from_cols(
                Vector::new(e[(0, 0)], e[(1, 0)], e[(2, 0)]),
                Vector::new(e[(0, 1)], e[(1, 1)], e[(2, 1)]),
                Vector::new(e[(0, 2)], e[(1, 2)], e[(2, 2)]),
            )
        })
        .filter(|axes| {
            (axes.transpose() * *axes - Matrix::IDENTITY)
                .to_cols_array()
                .iter()
                .all(|x| x.abs() < 1e-9)
        })
        .unwrap_or(Matrix::IDENTITY);
    let (mut lo, mut hi) = (
        Vector::splat(f64::INFINITY),
        Vector::splat(f64::NEG_INFINITY),
    );
    for p in corners() {
        let local = axes.transpose() * *p;
        lo = lo.min(local);
        hi = hi.max(local);
    }
    Obb {
        center: axes * ((lo + hi) * 0.5),
        axes,
        half: (hi - lo) * 0.5,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parry3d_f64::math::{Pose, Rot3};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn tri(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [Vector; 3] {
        [a, b, c].map(|p| Vector::new(p[0], p[1], p[2]))
    }

    #[test]
    fn every_box_holds_its_triangles() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let tris: Vec<[Vector; 3]> = (0..300)
            .map(|_| {
                let c = Vector::new(rng.random(), rng.random(), rng.random());
                let mut p = || c + Vector::new(rng.random(), rng.random(), rng.random()) * 0.05;
                [p(), p(), p()]
            })
            .collect();
        let tree = ObbTree::from_triangles(tris.clone());
        assert_eq!(tree.triangle_count(), 300);
        // Every triangle's corners lie in every box on the way to its leaf.
        fn check(tree: &ObbTree, node: u32, path: &mut Vec<Obb>) -> usize {
            let n = &tree.nodes[node as usize];
            path.push(n.obb);
            let leaves = if n.count > 0 {
                for t in &tree.triangles[n.first as usize..(n.first + n.count) as usize] {
                    for b in path.iter() {
                        for p in t {
                            let local = b.axes.transpose() * (*p - b.center);
                            assert!(local.abs().cmple(b.half + Vector::splat(1e-9)).all());
                        }
                    }
                }
                n.count as usize
            } else {
                check(tree, n.first, path) + check(tree, n.second, path)
            };
            path.pop();
            leaves
        }
        assert_eq!(check(&tree, 0, &mut Vec::new()), 300);
    }

    #[test]
    fn the_box_test_is_exact_and_the_gap_a_lower_bound() {
        // Random oriented boxes and poses against GJK on the two cuboids: the 15-axis test
        // keeps every overlapping pair and drops the separated ones (it is exact for boxes,
        // up to its rounding slack), and the gap never exceeds their distance.
        use parry3d_f64::query::{distance, intersection_test};
        use parry3d_f64::shape::Cuboid;
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let v = |rng: &mut ChaCha8Rng| Vector::new(rng.random(), rng.random(), rng.random());
        let rotation = |rng: &mut ChaCha8Rng| Rot3::from_scaled_axis(v(rng) * 3.0);
        let (mut overlapping, mut apart, mut gaps) = (0, 0, 0);
        for _ in 0..20_000 {
            let [a, b] = [0; 2].map(|_| {
                let axes = Matrix::from_quat(rotation(&mut rng));
                Obb {
                    center: v(&mut rng) * 1.2,
                    axes,
                    half: v(&mut rng) * 0.5 + Vector::splat(0.01),
                }
            });
            let pose = Pose::from_parts(v(&mut rng), rotation(&mut rng));
            let (r, t) = (Matrix::from_quat(pose.rotation), pose.translation);
            let placed =
                |o: &Obb, p: Pose| p * Pose::from_parts(o.center, Rot3::from_mat3(&o.axes));
            let (pa, pb) = (placed(&a, Pose::IDENTITY), placed(&b, pose));
            let (ca, cb) = (Cuboid::new(a.half), Cuboid::new(b.half));
            let exact = intersection_test(&pa, &ca, &pb, &cb)
                .expect("supported")
                .intersecting;
            assert_eq!(overlap(&a, &b, &r, &t), exact, "{a:?} {b:?} {pose:?}");
            let d = distance(&pa, &ca, &pb, &cb).expect("supported").distance;
            let g = gap(&a, &b, &r, &t);
            assert!(g <= d + 1e-9, "gap {g} > distance {d}");
            overlapping += usize::from(exact);
            apart += usize::from(!exact);
            gaps += usize::from(g > 0.5 * d);
        }
        assert!(
            overlapping > 1_000 && apart > 1_000,
            "{overlapping} {apart}"
        );
        // The bound is useful: within half the distance for most separated pairs.
        assert!(gaps > apart / 2, "{gaps} of {apart}");
    }

    #[test]
    fn a_skewed_mesh_makes_a_shallow_tree() {
        // Triangles at x = 4^i: the mean of the centres lies above all but the last four,
        // so every mean split would peel off four (a tree ~125 deep); their coordinates
        // also overflow the covariance (the fit falls back to the mesh's axes).
        let n = 500;
        let tris: Vec<[Vector; 3]> = (0..n)
            .map(|i| {
                let x = 4f64.powi(i);
                tri([x, 0.0, 0.0], [x, 1.0, 0.0], [x, 0.0, 1.0])
            })
            .collect();
        let tree = ObbTree::from_triangles(tris);
        fn depth(tree: &ObbTree, node: u32) -> usize {
            let n = &tree.nodes[node as usize];
            if n.count > 0 {
                1
            } else {
                1 + depth(tree, n.first).max(depth(tree, n.second))
            }
        }
        let d = depth(&tree, 0);
        let bound = (f64::from(n).ln() / (8.0f64 / 7.0).ln()).ceil() as usize + 1;
        assert!(d <= bound, "depth {d} > {bound}");
        assert_eq!(tree.triangle_count(), n as usize);
        // Every triangle is still found: each one meets itself.
        assert!(tree.intersects(&tree, &Matrix::IDENTITY, &Vector::ZERO));
    }

    #[test]
    fn reversed_twins_are_kept_once() {
        let t = tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let vertices = t.to_vec();
        let mesh = TriMesh::new(vertices, vec![[0, 1, 2], [0, 2, 1], [1, 2, 0]]).unwrap();
        assert_eq!(ObbTree::new(&mesh).triangle_count(), 1);
    }
}
