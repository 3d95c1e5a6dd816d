//! Exact tests between two triangles, the leaves of the mesh-against-mesh traversal
//! ([`super::obb_tree`]): Möller's triangle–triangle intersection test ("A fast
//! triangle-triangle intersection test", J. Graphics Tools 2(2), 1997), with the coplanar
//! case done in 2D, and the distance between disjoint triangles (the least of the six
//! corner–triangle and nine edge–edge distances, Ericson, "Real-Time Collision
//! Detection", 2005, §5.1). Surfaces are tested, as parry does for meshes: touching counts
//! as intersecting.

use parry3d_f64::math::Vector;

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
pub(super) fn disjoint_triangle_distance(a: &[Vector; 3], b: &[Vector; 3]) -> f64 {
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
pub(super) fn closest_on_triangle(p: Vector, t: &[Vector; 3]) -> Vector {
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
pub(super) fn segments_distance_squared(p1: Vector, q1: Vector, p2: Vector, q2: Vector) -> f64 {
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
    use parry3d_f64::math::Pose;
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
}
