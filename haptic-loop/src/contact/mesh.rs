//! A triangle mesh as the voxmap's band build and the pointshell read it: vertices in the scene frame, the
//! triangles across each edge and around each vertex (for walking from one triangle to a
//! nearer one), and the angle-weighted pseudo-normals of Bærentzen & Aanæs (2005) that give
//! the sign of a distance at whichever feature (face, edge, vertex) holds the closest
//! point: exact for a closed, consistently outward-wound surface.

use nalgebra::Vector3;

/// No triangle (on an edge's other side at a boundary).
const NONE: u32 = u32::MAX;

/// Where on a triangle the closest point lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(in crate::contact) enum Feature {
    /// Inside the face.
    Face,
    /// On edge `e` (0: corners 0–1, 1: 1–2, 2: 2–0), between its ends.
    Edge(u8),
    /// At corner `v` (0, 1, 2).
    Vertex(u8),
}

/// The closest point of a triangle to a point.
#[derive(Debug, Clone, Copy)]
pub(in crate::contact) struct Closest {
    /// Squared distance, m².
    pub(in crate::contact) distance2: f64,
    /// The closest point, m.
    pub(in crate::contact) point: Vector3<f64>,
    /// Where it lies on the triangle.
    pub(in crate::contact) feature: Feature,
}

/// How many of the triangles a walk stood on [`Walk`] keeps.
const PATH: usize = 8;

/// Where a walk ([`Mesh::walk`]) ended and the way it went.
#[derive(Debug, Clone, Copy)]
pub(in crate::contact) struct Walk {
    /// The triangle it ended on and its closest point.
    pub(in crate::contact) t: u32,
    pub(in crate::contact) at: Closest,
    /// The first [`PATH`] triangles it stood on, the start first.
    path: [u32; PATH],
    /// How many triangles it stood on (rings looked at).
    pub(in crate::contact) stood: usize,
    /// Triangle distances it computed.
    pub(in crate::contact) distances: u32,
}

impl Walk {
    /// Whether the walk stood on triangle `t` (among the first [`PATH`]).
    #[inline]
    pub(in crate::contact) fn stood_on(&self, t: u32) -> bool {
        self.path[..self.stood.min(PATH)].contains(&t)
    }
}

/// A mesh in the scene frame with its adjacency and pseudo-normals.
#[derive(Debug)]
pub(in crate::contact) struct Mesh {
    /// Each triangle's corners (welded, positive area), inline: the band reads them for
    /// every distance, and one contiguous record per triangle keeps that to one cache miss.
    corners: Vec<[Vector3<f64>; 3]>,
    /// Each triangle's corners as indices of welded vertices.
    pub(in crate::contact) triangles: Vec<[u32; 3]>,
    /// The triangles sharing a corner with each triangle (itself excluded):
    /// `ring[ring_start[t]..ring_start[t + 1]]`.
    ring_start: Vec<u32>,
    ring: Vec<u32>,
    /// Unit outward normal of each triangle.
    face_normals: Vec<Vector3<f64>>,
    /// Per triangle and edge, the sum of the normals of the triangles sharing it.
    edge_normals: Vec<[Vector3<f64>; 3]>,
    /// Per vertex, the sum of its triangles' normals weighted by their angles there.
    vertex_normals: Vec<Vector3<f64>>,
}

impl Mesh {
    /// Welds `vertices` by exact position and keeps the triangles with positive area, in
    /// their order.
    pub(in crate::contact) fn new(vertices: &[Vector3<f64>], triangles: &[[u32; 3]]) -> Self {
        Self::build(vertices, triangles, false)
    }

    /// [`Self::new`], with the triangles stored along a Morton (Z-order) curve through
    /// their centroids and the vertices in the order those triangles first use them, so
    /// that triangles near each other in space are near each other in memory whatever
    /// order the input had. The band reads a node's triangle and its 1-ring for every node
    /// and sweeps the whole surface once per layer of nodes: with triangles in an order
    /// without locality (an exporter's, a subdivision's), each of those reads was a cache
    /// miss and the build took 2–2.5 times as long. Normals are computed before the
    /// reordering, in the input's order, so every value is the same bit for bit; only
    /// which of two triangles at exactly the same distance is met first can differ.
    pub(in crate::contact) fn new_spatial(
        vertices: &[Vector3<f64>],
        triangles: &[[u32; 3]],
    ) -> Self {
        Self::build(vertices, triangles, true)
    }

    fn build(vertices: &[Vector3<f64>], triangles: &[[u32; 3]], spatial: bool) -> Self {
        let ids = scene::weld(vertices);
        let mut unique =
            vec![Vector3::zeros(); ids.iter().map(|&i| i as usize + 1).max().unwrap_or(0)];
        for (v, &i) in vertices.iter().zip(&ids) {
            unique[i as usize] = *v;
        }
        let mut kept = Vec::with_capacity(triangles.len());
        let mut face_normals = Vec::with_capacity(triangles.len());
        for t in triangles {
            let Some([a, b, c]) = t
                .iter()
                .map(|&i| ids.get(i as usize).copied())
                .collect::<Option<Vec<u32>>>()
                .and_then(|v| <[u32; 3]>::try_from(v).ok())
            else {
                continue;
            };
            let [pa, pb, pc] = [a, b, c].map(|i| unique[i as usize]);
            let Some(n) = (pb - pa).cross(&(pc - pa)).try_normalize(0.0) else {
                continue;
            };
            if a == b || b == c || a == c || !n.iter().all(|x| x.is_finite()) {
                continue;
            }
            kept.push([a, b, c]);
            face_normals.push(n);
        }
        let mut vertices = unique;
        let mut triangles = kept;

        // Edges: the (at most two) triangles on each undirected edge.
        let mut edges: foldhash::HashMap<(u32, u32), [(u32, u8); 2]> =
            foldhash::HashMap::with_capacity_and_hasher(
                triangles.len() * 3 / 2,
                Default::default(),
            );
        let mut shared_by_more = Vec::new();
        for (t, tri) in triangles.iter().enumerate() {
            for e in 0..3u8 {
                let (a, b) = (tri[e as usize], tri[(e as usize + 1) % 3]);
                let k = (a.min(b), a.max(b));
                let slot = edges.entry(k).or_insert([(NONE, 0); 2]);
                if slot[0].0 == NONE {
                    slot[0] = (t as u32, e);
                } else if slot[1].0 == NONE {
                    slot[1] = (t as u32, e);
                } else {
                    shared_by_more.push(k);
                }
            }
        }
        for k in shared_by_more {
            // A non-manifold edge: each side keeps its own normal.
            if let Some(slot) = edges.get_mut(&k) {
                *slot = [(NONE, 0); 2];
            }
        }
        let mut edge_normals = face_normals.iter().map(|n| [*n; 3]).collect::<Vec<_>>();
        for [(t0, e0), (t1, e1)] in edges.values().copied() {
            if t0 != NONE && t1 != NONE {
                let sum = face_normals[t0 as usize] + face_normals[t1 as usize];
                edge_normals[t0 as usize][e0 as usize] = sum;
                edge_normals[t1 as usize][e1 as usize] = sum;
            }
        }
        drop(edges);

        // Angle-weighted vertex normals.
        let mut vertex_normals = vec![Vector3::zeros(); vertices.len()];
        for (t, tri) in triangles.iter().enumerate() {
            for c in 0..3 {
                let v = tri[c] as usize;
                let p = vertices[v];
                let u = vertices[tri[(c + 1) % 3] as usize] - p;
                let w = vertices[tri[(c + 2) % 3] as usize] - p;
                vertex_normals[v] += face_normals[t] * u.angle(&w);
            }
        }
        if spatial {
            let order = morton_order(&triangles, &vertices);
            // Vertices renumbered in the order the reordered triangles first use them.
            let mut renumbered = vec![NONE; vertices.len()];
            let mut used = Vec::with_capacity(vertices.len());
            for &t in &order {
                for &v in &triangles[t as usize] {
                    if renumbered[v as usize] == NONE {
                        renumbered[v as usize] = used.len() as u32;
                        used.push(v);
                    }
                }
            }
            vertices = used.iter().map(|&v| vertices[v as usize]).collect();
            vertex_normals = used.iter().map(|&v| vertex_normals[v as usize]).collect();
            triangles = order
                .iter()
                .map(|&t| triangles[t as usize].map(|v| renumbered[v as usize]))
                .collect();
            face_normals = order.iter().map(|&t| face_normals[t as usize]).collect();
            edge_normals = order.iter().map(|&t| edge_normals[t as usize]).collect();
        }

        // Fans: the triangles around each vertex.
        let mut fan_start = vec![0u32; vertices.len() + 1];
        for tri in &triangles {
            for &v in tri {
                fan_start[v as usize + 1] += 1;
            }
        }
        for i in 1..fan_start.len() {
            fan_start[i] += fan_start[i - 1];
        }
        let mut fill = fan_start.clone();
        let mut fan = vec![0u32; fan_start[vertices.len()] as usize];
        for (t, tri) in triangles.iter().enumerate() {
            for &v in tri {
                fan[fill[v as usize] as usize] = t as u32;
                fill[v as usize] += 1;
            }
        }
        // Each triangle's 1-ring: the union of its corners' fans, itself excluded.
        let mut ring_start = Vec::with_capacity(triangles.len() + 1);
        let mut ring = Vec::with_capacity(triangles.len() * 12);
        ring_start.push(0u32);
        for (t, tri) in triangles.iter().enumerate() {
            let from = ring.len();
            for &v in tri {
                for &n in &fan[fan_start[v as usize] as usize..fan_start[v as usize + 1] as usize] {
                    if n != t as u32 && !ring[from..].contains(&n) {
                        ring.push(n);
                    }
                }
            }
            ring_start.push(ring.len() as u32);
        }
        let corners = triangles
            .iter()
            .map(|t| t.map(|i| vertices[i as usize]))
            .collect();
        Mesh {
            corners,
            triangles,
            ring_start,
            ring,
            face_normals,
            edge_normals,
            vertex_normals,
        }
    }

    /// The surface's area, m².
    pub(in crate::contact) fn area_m2(&self) -> f64 {
        self.corners
            .iter()
            .map(|[a, b, c]| 0.5 * (b - a).cross(&(c - a)).norm())
            .sum()
    }

    /// The number of triangles.
    pub(in crate::contact) fn len(&self) -> usize {
        self.corners.len()
    }

    /// The corners of triangle `t`.
    #[inline]
    pub(in crate::contact) fn corners(&self, t: u32) -> [Vector3<f64>; 3] {
        self.corners[t as usize]
    }

    /// The closest point of triangle `t` to `p`.
    #[inline]
    pub(in crate::contact) fn closest(&self, t: u32, p: &Vector3<f64>) -> Closest {
        let [a, b, c] = &self.corners[t as usize];
        closest_on_triangle(p, a, b, c)
    }

    /// Whether triangle `n` shares a corner with triangle `t`.
    #[inline]
    pub(in crate::contact) fn in_ring(&self, t: u32, n: u32) -> bool {
        let (s, e) = (
            self.ring_start[t as usize] as usize,
            self.ring_start[t as usize + 1] as usize,
        );
        self.ring[s..e].contains(&n)
    }

    /// From triangle `t`, whose closest point to `p` is `at`, walks to neighbouring
    /// triangles while one is nearer, looking at every triangle sharing a corner with the
    /// current one: not only across the feature holding the closest point, since on the
    /// concave side of a surface a neighbour tilted towards `p` can be nearer although `p`
    /// projects into this face, both being local minima. Ends at a triangle none of whose
    /// neighbours is nearer: on a surface smooth at the scale of `p`'s distance, the
    /// closest.
    #[cfg(test)]
    pub(in crate::contact) fn descend(
        &self,
        p: &Vector3<f64>,
        t: u32,
        at: Closest,
    ) -> (u32, Closest) {
        let w = self
            .walk(p, t, at, None)
            .expect("a walk without a stop ends");
        (w.t, w.at)
    }

    /// [`Self::descend`], telling the way it went; `None` if it stood on a triangle of
    /// `stop`'s path, from which it would have gone on as `stop` did (the next triangle is
    /// the nearest of the ring, whatever came before) and ended where `stop` ended.
    ///
    /// A ring's triangles that were in the ring before (or were the triangle before) are
    /// not looked at again: none of them is nearer than the current triangle, which was
    /// the nearest of them. The way is the same as looking at all of them, at about half
    /// the distances per step (neighbouring rings share about half their triangles).
    #[inline]
    pub(in crate::contact) fn walk(
        &self,
        p: &Vector3<f64>,
        mut t: u32,
        mut at: Closest,
        stop: Option<&Walk>,
    ) -> Option<Walk> {
        let mut walk = Walk {
            t,
            at,
            path: [NONE; PATH],
            stood: 0,
            distances: 0,
        };
        let mut before: &[u32] = &[];
        let mut previous = NONE;
        loop {
            if stop.is_some_and(|w| w.stood_on(t)) {
                return None;
            }
            if walk.stood < PATH {
                walk.path[walk.stood] = t;
            }
            walk.stood += 1;
            let mut best = (t, at);
            let ring = self.ring_of(t);
            for &n in ring {
                if n == previous || before.contains(&n) {
                    continue;
                }
                walk.distances += 1;
                let c = self.closest(n, p);
                if c.distance2 < best.1.distance2 {
                    best = (n, c);
                }
            }
            if best.0 == t {
                (walk.t, walk.at) = best;
                return Some(walk);
            }
            (previous, before) = (t, ring);
            (t, at) = best;
        }
    }

    /// The triangles sharing a corner with triangle `t`.
    #[inline]
    fn ring_of(&self, t: u32) -> &[u32] {
        &self.ring[self.ring_start[t as usize] as usize..self.ring_start[t as usize + 1] as usize]
    }

    /// The pseudo-normal at the feature of triangle `t` that holds a closest point: its
    /// sign against `p − closest` is the sign of `p`'s distance (positive outside).
    pub(in crate::contact) fn pseudo_normal(&self, t: u32, feature: Feature) -> Vector3<f64> {
        match feature {
            Feature::Face => self.face_normals[t as usize],
            Feature::Edge(e) => self.edge_normals[t as usize][e as usize],
            Feature::Vertex(v) => {
                self.vertex_normals[self.triangles[t as usize][v as usize] as usize]
            }
        }
    }
}

/// The triangles (indices) sorted by the Morton code of their centroids, quantised to
/// 2²¹ steps per axis of the vertices' box (ties in input order).
fn morton_order(triangles: &[[u32; 3]], vertices: &[Vector3<f64>]) -> Vec<u32> {
    let (lo, hi) = scene::bounding_box(vertices);
    let steps = f64::from((1u32 << 21) - 1);
    let scale = (hi - lo).map(|e| if e > 0.0 { steps / e } else { 0.0 });
    // Spreads the low 21 bits of `x` to every third bit.
    let spread = |x: u64| {
        let mut x = x & 0x1f_ffff;
        x = (x | x << 32) & 0x001f_0000_0000_ffff;
        x = (x | x << 16) & 0x001f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        (x | x << 2) & 0x1249_2492_4924_9249
    };
    let mut keyed: Vec<(u64, u32)> = triangles
        .iter()
        .enumerate()
        .map(|(t, tri)| {
            let c = tri
                .iter()
                .fold(Vector3::zeros(), |s, &v| s + vertices[v as usize])
                / 3.0;
            let q = (c - lo)
                .component_mul(&scale)
                .map(|x| x.clamp(0.0, steps) as u64);
            (spread(q.x) | spread(q.y) << 1 | spread(q.z) << 2, t as u32)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, t)| t).collect()
}

/// The closest point of triangle (a, b, c) to `p`, by the regions of Ericson,
/// "Real-Time Collision Detection" §5.1.5, naming the feature it lies on.
#[inline]
pub(in crate::contact) fn closest_on_triangle(
    p: &Vector3<f64>,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    c: &Vector3<f64>,
) -> Closest {
    let at = |point: Vector3<f64>, feature| Closest {
        distance2: (p - point).norm_squared(),
        point,
        feature,
    };
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return at(*a, Feature::Vertex(0));
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return at(*b, Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return at(a + ab * v, Feature::Edge(0));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return at(*c, Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return at(a + ac * w, Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return at(b + (c - b) * w, Feature::Edge(1));
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    at(a + ab * v + ac * w, Feature::Face)
}

#[cfg(test)]
pub(in crate::contact) mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A unit cube's 12 triangles wound outward, corners (0|1)³.
    pub(in crate::contact) fn cube() -> (Vec<Vector3<f64>>, Vec<[u32; 3]>) {
        let v = (0..8)
            .map(|i| Vector3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        let t = vec![
            [0, 2, 1],
            [1, 2, 3], // z = 0
            [4, 5, 6],
            [5, 7, 6], // z = 1
            [0, 1, 4],
            [1, 5, 4], // y = 0
            [2, 6, 3],
            [3, 6, 7], // y = 1
            [0, 4, 2],
            [2, 4, 6], // x = 0
            [1, 3, 5],
            [3, 7, 5], // x = 1
        ];
        (v, t)
    }

    #[test]
    fn the_closest_point_matches_a_dense_search_and_names_its_feature() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (a, b, c) = (
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.2, 0.1),
            Vector3::new(0.3, 0.9, -0.2),
        );
        for _ in 0..2000 {
            let p = Vector3::from_fn(|_, _| rng.random_range(-1.0..2.0));
            let got = closest_on_triangle(&p, &a, &b, &c);
            // Dense barycentric search.
            let mut best = f64::INFINITY;
            let n = 200;
            for i in 0..=n {
                for j in 0..=(n - i) {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    let q = a + (b - a) * u + (c - a) * v;
                    best = best.min((p - q).norm_squared());
                }
            }
            assert!(got.distance2 <= best + 1e-12, "{p:?}");
            assert!(best.sqrt() - got.distance2.sqrt() < 0.01, "{p:?}");
            let on = |x: &Vector3<f64>| (got.point - x).norm() < 1e-12;
            match got.feature {
                Feature::Vertex(0) => assert!(on(&a)),
                Feature::Vertex(1) => assert!(on(&b)),
                Feature::Vertex(2) => assert!(on(&c)),
                _ => {}
            }
        }
    }

    #[test]
    fn pseudo_normals_sign_every_point_around_a_cube() {
        let (v, t) = cube();
        let mesh = Mesh::new(&v, &t);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..5000 {
            let p = Vector3::from_fn(|_, _| rng.random_range(-0.5..1.5));
            let (tri, at) = (0..mesh.triangles.len() as u32)
                .map(|tri| (tri, mesh.closest(tri, &p)))
                .min_by(|x, y| x.1.distance2.total_cmp(&y.1.distance2))
                .unwrap();
            let inside = p.iter().all(|&x| (0.0..=1.0).contains(&x));
            let outward = (p - at.point).dot(&mesh.pseudo_normal(tri, at.feature)) > 0.0;
            if at.distance2 > 1e-12 {
                assert_eq!(outward, !inside, "{p:?} {:?}", at.feature);
            }
        }
    }

    #[test]
    fn descending_from_a_neighbour_of_the_closest_triangle_finds_it() {
        let (v, t) = cube();
        let mesh = Mesh::new(&v, &t);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for _ in 0..2000 {
            let p = Vector3::from_fn(|_, _| rng.random_range(-1.0..2.0));
            if p.iter().all(|x| (0.0..=1.0).contains(x)) {
                // Inside, every face holds a local minimum: the band brings the closest
                // face's triangle from the nodes between a node and the surface.
                continue;
            }
            let (best, exact) = (0..mesh.triangles.len() as u32)
                .map(|tri| (tri, mesh.closest(tri, &p).distance2))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            // Any triangle sharing a corner with the closest one: where the band hands a
            // node its neighbour's triangle, it is about this far off.
            let near: Vec<u32> = (0..mesh.triangles.len() as u32)
                .filter(|&o| {
                    mesh.triangles[o as usize]
                        .iter()
                        .any(|c| mesh.triangles[best as usize].contains(c))
                })
                .collect();
            let start = near[rng.random_range(0..near.len())];
            let (_, at) = mesh.descend(&p, start, mesh.closest(start, &p));
            assert!((at.distance2 - exact).abs() < 1e-12, "{p:?} from {start}");
        }
    }

    /// A bumpy sphere (not convex) with its triangles in random order.
    fn shuffled_sphere() -> (Vec<Vector3<f64>>, Vec<[u32; 3]>) {
        use rand::seq::SliceRandom;
        let m = scene::MeshData::bumpy_sphere("s", 0.05, 20, 40);
        let mut t = m.triangles.clone();
        t.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(1));
        (m.vertices_m, t)
    }

    /// Every triangle's corners, normals and corners' vertex normals, as bits, sorted.
    fn per_triangle_bits(m: &Mesh) -> Vec<Vec<u64>> {
        let mut out: Vec<Vec<u64>> = (0..m.len())
            .map(|t| {
                let mut v: Vec<f64> = m.corners[t]
                    .iter()
                    .flat_map(|c| c.iter().copied())
                    .collect();
                v.extend(m.face_normals[t].iter());
                v.extend(m.edge_normals[t].iter().flat_map(|n| n.iter().copied()));
                for &i in &m.triangles[t] {
                    v.extend(m.vertex_normals[i as usize].iter());
                }
                v.iter().map(|x| x.to_bits()).collect()
            })
            .collect();
        out.sort();
        out
    }

    #[test]
    fn the_spatial_order_keeps_every_value_and_puts_neighbours_near_in_memory() {
        let (v, t) = shuffled_sphere();
        let (plain, spatial) = (Mesh::new(&v, &t), Mesh::new_spatial(&v, &t));
        assert_eq!(per_triangle_bits(&plain), per_triangle_bits(&spatial));
        // How far apart in memory a triangle's ring lies, on average.
        let spread = |m: &Mesh| {
            let mut sum = 0u64;
            for t in 0..m.len() as u32 {
                sum += m
                    .ring_of(t)
                    .iter()
                    .map(|&n| u64::from(n.abs_diff(t)))
                    .sum::<u64>();
            }
            sum as f64 / m.ring.len() as f64
        };
        let (a, b) = (spread(&plain), spread(&spatial));
        assert!(
            b < 0.25 * a,
            "ring index distance {b:.0} (spatial) vs {a:.0}"
        );
    }

    #[test]
    fn a_walk_goes_the_way_of_a_descent_that_looks_at_every_triangle_of_every_ring() {
        let (v, t) = shuffled_sphere();
        let mesh = Mesh::new_spatial(&v, &t);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let mut steps = 0;
        for _ in 0..3000 {
            let p = Vector3::from_fn(|_, _| rng.random_range(-0.07..0.07));
            let start = rng.random_range(0..mesh.len() as u32);
            // The descent as it was: the whole ring at every step.
            let (mut t, mut at) = (start, mesh.closest(start, &p));
            let mut way = vec![t];
            loop {
                let mut best = (t, at);
                for &n in mesh.ring_of(t) {
                    let c = mesh.closest(n, &p);
                    if c.distance2 < best.1.distance2 {
                        best = (n, c);
                    }
                }
                if best.0 == t {
                    break;
                }
                (t, at) = best;
                way.push(t);
            }
            let w = mesh.walk(&p, start, mesh.closest(start, &p), None).unwrap();
            assert_eq!((w.t, w.at.distance2.to_bits()), (t, at.distance2.to_bits()));
            assert_eq!(w.stood, way.len());
            steps += way.len() - 1;
            // A walk that meets the first one's way stops; one that does not ends as it
            // would have.
            let other = rng.random_range(0..mesh.len() as u32);
            match mesh.walk(&p, other, mesh.closest(other, &p), Some(&w)) {
                None => {}
                Some(o) => {
                    let alone = mesh.walk(&p, other, mesh.closest(other, &p), None).unwrap();
                    assert_eq!((o.t, o.stood), (alone.t, alone.stood));
                    assert!((0..o.stood.min(PATH)).all(|i| !w.stood_on(o.path[i])));
                }
            }
        }
        assert!(steps > 3000, "{steps}");
    }

    #[test]
    fn degenerate_and_welded_input() {
        let (v, t) = cube();
        // Each triangle with its own corners (STL), and a zero-area triangle.
        let mut soup = Vec::new();
        let mut tris = Vec::new();
        for tri in &t {
            let base = soup.len() as u32;
            soup.extend(tri.iter().map(|&i| v[i as usize]));
            tris.push([base, base + 1, base + 2]);
        }
        tris.push([0, 0, 1]);
        tris.push([0, 1, 9999]);
        let mesh = Mesh::new(&soup, &tris);
        assert_eq!(mesh.vertex_normals.len(), 8);
        assert_eq!(mesh.len(), 12);
    }
}
