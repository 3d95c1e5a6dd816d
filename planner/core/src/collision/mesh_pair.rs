//! Mesh against mesh intersection by a simultaneous traversal of both bounding-volume
//! trees, as coal and FCL do, instead of parry's composite-against-composite test (which
//! descends the second tree once for every triangle of the first whose box meets the
//! second's bounds, and ends in a GJK test per triangle pair).
//!
//! Node pairs are culled by a separating-axis test of the two boxes along the six face
//! axes of both frames (the nine edge–edge axes are skipped: keeping a pair is only slower,
//! never wrong); leaf pairs get Möller's triangle–triangle test ("A fast triangle-triangle
//! intersection test", J. Graphics Tools 2(2), 1997), with the coplanar case done in 2D.
//! Surfaces are tested, as parry does for meshes: touching counts as intersecting.
//!
//! Distances use the same traversal: node pairs whose boxes are at least the nearest
//! distance found so far apart (their gap along the six face axes, a lower bound) are
//! pruned; leaf pairs take the exact triangle–triangle distance (0 when they intersect,
//! else the least of the six corner–triangle and nine edge–edge distances, Ericson,
//! "Real-Time Collision Detection", 2005, §5.1).

use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::math::{Matrix, Pose, Vector};
use parry3d_f64::shape::TriMesh;
use std::cell::Cell;

/// `m1` and `m2` intersect, with `m2` at `pose12` in `m1`'s frame.
pub fn trimeshes_intersect(pose12: &Pose, m1: &TriMesh, m2: &TriMesh) -> bool {
    Frames::new(pose12).meshes_intersect(m1, m2)
}

/// Below this product of the two meshes' triangle counts parry's closest points answer a
/// capped distance faster than [`trimeshes_distance_up_to`] (`mesh-checks`: 21 against
/// 15 µs at 80 triangles a side, 59 against 121 µs at 1 890; the crossing is near 500).
pub const OWN_DISTANCE_MIN_TRIANGLE_PAIRS: usize = 500 * 500;

/// `min(distance between m1's and m2's surfaces, cap_m)` (m), `m2` at `pose12` in `m1`'s
/// frame; 0 when they intersect.
pub fn trimeshes_distance_up_to(pose12: &Pose, m1: &TriMesh, m2: &TriMesh, cap_m: f64) -> f64 {
    let frames = Frames::new(pose12);
    // Intersecting meshes (the common case near contact) are found faster by the
    // intersection test, which stops at the first crossing pair.
    if frames.meshes_intersect(m1, m2) {
        return 0.0;
    }
    let nearest = Cell::new(cap_m);
    let pairs = m1.bvh().leaf_pairs(m2.bvh(), |n1, n2| {
        frames.box_gap(&n1.aabb(), &n2.aabb()) < nearest.get()
    });
    for (a, b) in pairs {
        let (ta, tb) = frames.triangles(m1, a, m2, b);
        // The meshes are disjoint, so no pair intersects: skip that test.
        let d = disjoint_triangle_distance(&ta, &tb);
        if d < nearest.get() {
            if d <= 0.0 {
                return 0.0;
            }
            nearest.set(d);
        }
    }
    nearest.get()
}

/// Distance between the closed triangles `a` and `b` (m, 0 when they intersect).
#[cfg(test)]
fn triangle_distance(a: &[Vector; 3], b: &[Vector; 3]) -> f64 {
    if triangles_intersect(a, b) {
        return 0.0;
    }
    disjoint_triangle_distance(a, b)
}

/// [`triangle_distance`] of triangles known not to intersect: they are nearest at a
/// corner of one or between two edges.
fn disjoint_triangle_distance(a: &[Vector; 3], b: &[Vector; 3]) -> f64 {
    let mut d2 = f64::INFINITY;
    for p in a {
        d2 = d2.min((*p - closest_on_triangle(*p, b)).length_squared());
    }
    for p in b {
        d2 = d2.min((*p - closest_on_triangle(*p, a)).length_squared());
    }
    for i in 0..3 {
        for j in 0..3 {
            d2 = d2.min(segments_distance_squared(
                a[i],
                a[(i + 1) % 3],
                b[j],
                b[(j + 1) % 3],
            ));
        }
    }
    d2.sqrt()
}

/// The point of triangle `t` nearest to `p` (Ericson §5.1.5, by Voronoi regions).
fn closest_on_triangle(p: Vector, t: &[Vector; 3]) -> Vector {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom.is_nan() || denom == 0.0 {
        // A degenerate triangle: its nearest corner (its edges are tested too).
        return [a, b, c]
            .into_iter()
            .min_by(|x, y| {
                (p - *x)
                    .length_squared()
                    .total_cmp(&(p - *y).length_squared())
            })
            .unwrap_or(a);
    }
    a + ab * (vb / denom) + ac * (vc / denom)
}

/// Squared distance between the segments `p1 q1` and `p2 q2` (Ericson §5.1.9).
fn segments_distance_squared(p1: Vector, q1: Vector, p2: Vector, q2: Vector) -> f64 {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    const TINY: f64 = 1e-30;
    let (s, t) = if a <= TINY && e <= TINY {
        (0.0, 0.0)
    } else if a <= TINY {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= TINY {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > TINY {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    ((p1 + d1 * s) - (p2 + d2 * t)).length_squared()
}

fn abs(m: &Matrix) -> Matrix {
    // A small slack on |R| makes the box test conservative under rounding.
    Matrix::from_cols(
        m.x_axis.abs() + Vector::splat(1e-12),
        m.y_axis.abs() + Vector::splat(1e-12),
        m.z_axis.abs() + Vector::splat(1e-12),
    )
}

/// Frame 2 in frame 1: `x1 = r·x2 + t`.
struct Frames {
    r: Matrix,
    abs_r: Matrix,
    t: Vector,
}

impl Frames {
    fn new(pose12: &Pose) -> Self {
        let r = Matrix::from_quat(pose12.rotation);
        Frames {
            r,
            abs_r: abs(&r),
            t: pose12.translation,
        }
    }

    /// Triangle `a` of `m1` and triangle `b` of `m2`, both in frame 1.
    fn triangles(&self, m1: &TriMesh, a: u32, m2: &TriMesh, b: u32) -> ([Vector; 3], [Vector; 3]) {
        let (v1, v2) = (m1.vertices(), m2.vertices());
        let ta = m1.indices()[a as usize].map(|i| v1[i as usize]);
        let tb = m2.indices()[b as usize].map(|i| self.r * v2[i as usize] + self.t);
        (ta, tb)
    }

    /// `m1` (frame 1) and `m2` (frame 2) intersect.
    fn meshes_intersect(&self, m1: &TriMesh, m2: &TriMesh) -> bool {
        m1.bvh()
            .leaf_pairs(m2.bvh(), |n1, n2| {
                self.boxes_overlap(&n1.aabb(), &n2.aabb())
            })
            .any(|(a, b)| {
                let (ta, tb) = self.triangles(m1, a, m2, b);
                triangles_intersect(&ta, &tb)
            })
    }

    /// The box `b1` (frame 1) and the box `b2` (frame 2) overlap along all six face axes.
    fn boxes_overlap(&self, b1: &Aabb, b2: &Aabb) -> bool {
        let (c1, h1) = (b1.center(), b1.half_extents());
        let (c2, h2) = (b2.center(), b2.half_extents());
        // Centre of box 2 relative to box 1, in frame 1.
        let d = self.r * c2 + self.t - c1;
        // Frame 1's axes: box 2's extent along them is |R|·h2.
        let e2 = self.abs_r * h2;
        if d.x.abs() > h1.x + e2.x || d.y.abs() > h1.y + e2.y || d.z.abs() > h1.z + e2.z {
            return false;
        }
        // Frame 2's axes: the same in frame 2 (Rᵀ).
        let d2 = self.r.transpose() * d;
        let e1 = self.abs_r.transpose() * h1;
        d2.x.abs() <= h2.x + e1.x && d2.y.abs() <= h2.y + e1.y && d2.z.abs() <= h2.z + e1.z
    }

    /// A lower bound of the distance between the boxes: their largest gap along the six
    /// face axes (0 when every axis overlaps).
    fn box_gap(&self, b1: &Aabb, b2: &Aabb) -> f64 {
        let (c1, h1) = (b1.center(), b1.half_extents());
        let (c2, h2) = (b2.center(), b2.half_extents());
        let d = self.r * c2 + self.t - c1;
        let g1 = d.abs() - h1 - self.abs_r * h2;
        let d2 = self.r.transpose() * d;
        let g2 = d2.abs() - h2 - self.abs_r.transpose() * h1;
        g1.max_element().max(g2.max_element()).max(0.0)
    }
}

/// The closed triangles `a` and `b` share a point.
pub fn triangles_intersect(a: &[Vector; 3], b: &[Vector; 3]) -> bool {
    // Plane of b; where a's corners lie against it.
    let nb = (b[1] - b[0]).cross(b[2] - b[0]);
    let da = a.map(|p| nb.dot(p - b[0]));
    if same_side(&da) {
        return false;
    }
    let na = (a[1] - a[0]).cross(a[2] - a[0]);
    let db = b.map(|p| na.dot(p - a[0]));
    if same_side(&db) {
        return false;
    }
    let coplanar_tol = 1e-12 * na.length() * nb.length();
    if da.iter().all(|d| d.abs() <= coplanar_tol) || db.iter().all(|d| d.abs() <= coplanar_tol) {
        return coplanar_intersect(a, b, na);
    }
    // Both cross the other's plane: compare the segments each cuts from the line where
    // the planes meet, projected on that line's largest axis.
    let dir = na.cross(nb);
    let axis = largest_axis(dir);
    let (lo_a, hi_a) = interval(a, &da, axis);
    let (lo_b, hi_b) = interval(b, &db, axis);
    lo_a <= hi_b && lo_b <= hi_a
}

/// All three strictly on one side (a corner on the plane counts as touching it).
fn same_side(d: &[f64; 3]) -> bool {
    (d[0] > 0.0 && d[1] > 0.0 && d[2] > 0.0) || (d[0] < 0.0 && d[1] < 0.0 && d[2] < 0.0)
}

fn largest_axis(v: Vector) -> usize {
    let a = v.abs();
    if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    }
}

/// The interval, along coordinate `axis`, of the segment where triangle `t` (signed plane
/// distances `d` of its corners, not all zero and not all on one side) meets the plane.
fn interval(t: &[Vector; 3], d: &[f64; 3], axis: usize) -> (f64, f64) {
    let p = t.map(|v| v[axis]);
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    let mut add = |x: f64| {
        lo = lo.min(x);
        hi = hi.max(x);
    };
    for i in 0..3 {
        let j = (i + 1) % 3;
        if d[i] == 0.0 {
            add(p[i]);
        }
        // The edge crosses the plane strictly: its crossing point.
        if (d[i] > 0.0 && d[j] < 0.0) || (d[i] < 0.0 && d[j] > 0.0) {
            add(p[i] + (p[j] - p[i]) * d[i] / (d[i] - d[j]));
        }
    }
    (lo, hi)
}

/// Coplanar triangles with normal `n`: projected on the plane of the two coordinates
/// other than `n`'s largest, they share a point when two edges cross or a corner of one
/// lies in the other.
fn coplanar_intersect(a: &[Vector; 3], b: &[Vector; 3], n: Vector) -> bool {
    let drop = largest_axis(n);
    let (u, v) = match drop {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let a2 = a.map(|p| [p[u], p[v]]);
    let b2 = b.map(|p| [p[u], p[v]]);
    for i in 0..3 {
        for j in 0..3 {
            if segments_cross(a2[i], a2[(i + 1) % 3], b2[j], b2[(j + 1) % 3]) {
                return true;
            }
        }
    }
    inside(a2[0], &b2) || inside(b2[0], &a2)
}

fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

fn segments_cross(p: [f64; 2], q: [f64; 2], r: [f64; 2], s: [f64; 2]) -> bool {
    let (o1, o2) = (orient(p, q, r), orient(p, q, s));
    let (o3, o4) = (orient(r, s, p), orient(r, s, q));
    let on = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        c[0] >= a[0].min(b[0])
            && c[0] <= a[0].max(b[0])
            && c[1] >= a[1].min(b[1])
            && c[1] <= a[1].max(b[1])
    };
    if o1 * o2 < 0.0 && o3 * o4 < 0.0 {
        return true;
    }
    (o1 == 0.0 && on(p, q, r))
        || (o2 == 0.0 && on(p, q, s))
        || (o3 == 0.0 && on(r, s, p))
        || (o4 == 0.0 && on(r, s, q))
}

fn inside(p: [f64; 2], t: &[[f64; 2]; 3]) -> bool {
    let o = [
        orient(t[0], t[1], p),
        orient(t[1], t[2], p),
        orient(t[2], t[0], p),
    ];
    (o[0] >= 0.0 && o[1] >= 0.0 && o[2] >= 0.0) || (o[0] <= 0.0 && o[1] <= 0.0 && o[2] <= 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use parry3d_f64::query::intersection_test;
    use parry3d_f64::shape::Triangle;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn v(x: f64, y: f64, z: f64) -> Vector {
        Vector::new(x, y, z)
    }

    /// A triangle with corners uniform in the unit cube.
    fn random_triangle(rng: &mut ChaCha8Rng) -> [Vector; 3] {
        [0; 3].map(|_| v(rng.random(), rng.random(), rng.random()))
    }

    #[test]
    fn triangle_pairs_agree_with_gjk() {
        // Random triangles in a unit cube, about half of the pairs intersecting.
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut hits = 0;
        for _ in 0..20_000 {
            let (a, b) = (random_triangle(&mut rng), random_triangle(&mut rng));
            let ours = triangles_intersect(&a, &b);
            let gjk = intersection_test(
                &Pose::IDENTITY,
                &Triangle::new(a[0], a[1], a[2]),
                &Pose::IDENTITY,
                &Triangle::new(b[0], b[1], b[2]),
            )
            .expect("supported")
            .intersecting;
            assert_eq!(ours, gjk, "{a:?} {b:?}");
            hits += usize::from(ours);
        }
        assert!((2_000..18_000).contains(&hits), "{hits}");
    }

    #[test]
    fn triangle_distances_agree_with_gjk() {
        use parry3d_f64::query::distance;
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let mut apart = 0;
        for _ in 0..20_000 {
            let (a, b) = (random_triangle(&mut rng), random_triangle(&mut rng));
            let ours = triangle_distance(&a, &b);
            let gjk = distance(
                &Pose::IDENTITY,
                &Triangle::new(a[0], a[1], a[2]),
                &Pose::IDENTITY,
                &Triangle::new(b[0], b[1], b[2]),
            )
            .expect("supported")
            .distance;
            assert!((ours - gjk).abs() < 1e-9, "{ours} vs {gjk}: {a:?} {b:?}");
            apart += usize::from(ours > 0.0);
        }
        assert!(apart > 2_000, "{apart}");
        // Parallel edges and a degenerate (point) triangle.
        let a = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        let above = a.map(|p| p + v(0.0, 0.0, 0.25));
        assert!((triangle_distance(&a, &above) - 0.25).abs() < 1e-12);
        let shifted = a.map(|p| p + v(2.0, 0.0, 0.0));
        assert!((triangle_distance(&a, &shifted) - 1.0).abs() < 1e-12);
        let point = [v(0.25, 0.25, 0.5); 3];
        assert!((triangle_distance(&a, &point) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn touching_and_coplanar_triangles() {
        let a = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        // Coplanar, overlapping; coplanar and apart; coplanar, one inside the other.
        let over = [v(0.5, 0.5, 0.0), v(1.5, 0.5, 0.0), v(0.5, 1.5, 0.0)];
        let apart = [v(2.0, 2.0, 0.0), v(3.0, 2.0, 0.0), v(2.0, 3.0, 0.0)];
        let within = [v(0.1, 0.1, 0.0), v(0.2, 0.1, 0.0), v(0.1, 0.2, 0.0)];
        assert!(triangles_intersect(&a, &over));
        assert!(!triangles_intersect(&a, &apart));
        assert!(triangles_intersect(&a, &within) && triangles_intersect(&within, &a));
        // A corner touching the face from above; the same lifted by 1 µm.
        let touch = [v(0.2, 0.2, 0.0), v(0.2, 0.3, 1.0), v(0.3, 0.2, 1.0)];
        let lifted = touch.map(|p| p + v(0.0, 0.0, 1e-6));
        assert!(triangles_intersect(&a, &touch));
        assert!(!triangles_intersect(&a, &lifted));
        // Piercing through the middle; passing beside the edge.
        let pierce = [v(0.2, 0.2, -1.0), v(0.2, 0.2, 1.0), v(0.3, 0.3, 1.0)];
        let beside = pierce.map(|p| p + v(1.0, 1.0, 0.0));
        assert!(triangles_intersect(&a, &pierce));
        assert!(!triangles_intersect(&a, &beside));
    }

    #[test]
    fn box_culling_never_drops_an_overlapping_pair() {
        // Random boxes and poses: whenever the boxes' corner clouds intersect (tested as
        // convex hulls by GJK), the six-axis test keeps them.
        use parry3d_f64::shape::Cuboid;
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut kept_apart = 0;
        for _ in 0..20_000 {
            let h1 = v(rng.random(), rng.random(), rng.random()) * 0.5 + Vector::splat(0.01);
            let h2 = v(rng.random(), rng.random(), rng.random()) * 0.5 + Vector::splat(0.01);
            let c1 = v(rng.random(), rng.random(), rng.random()) * 2.0;
            let c2 = v(rng.random(), rng.random(), rng.random()) * 2.0;
            let rot = parry3d_f64::math::Rotation::from_scaled_axis(
                v(rng.random(), rng.random(), rng.random()) * 3.0,
            );
            let pose12 = Pose::from_parts(v(rng.random(), rng.random(), rng.random()), rot);
            let f = Frames::new(&pose12);
            let (b1, b2) = (Aabb::new(c1 - h1, c1 + h1), Aabb::new(c2 - h2, c2 + h2));
            let exact = intersection_test(
                &Pose::from_translation(c1),
                &Cuboid::new(h1),
                &(pose12 * Pose::from_translation(c2)),
                &Cuboid::new(h2),
            )
            .expect("supported")
            .intersecting;
            let kept = f.boxes_overlap(&b1, &b2);
            assert!(kept || !exact, "dropped an overlapping pair");
            kept_apart += usize::from(kept && !exact);
        }
        // Skipping the edge axes keeps a few separated pairs, no more.
        assert!(kept_apart < 2_000, "{kept_apart}");
    }
}
