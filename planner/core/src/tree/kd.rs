//! An incremental k-d tree over a lower-bounding embedding of configurations, to find
//! nearest neighbours without scanning every node once trees are large.
//!
//! Each node is stored as its point [`ConfigSpace::embed`] in R^7, whose Euclidean
//! distances never exceed the space's weighted distance (with the query's second image
//! [`ConfigSpace::embed_mirror`] where the embedding has two, SE(3)'s `±q`). A subtree
//! whose bounding box is farther from the query than the best distance found cannot hold
//! a better node, and a node whose point is farther is skipped without computing the
//! exact distance (with its `atan2`s). The exact distance decides among the rest, so the
//! result equals the linear scan's, ties included (smallest id); the pruning keeps a
//! relative slack of 1e-9 so that rounding in the bound can never drop the true answer.
//!
//! Points are inserted in id order. Leaves hold up to [`LEAF_MAX`] ids; a full leaf is
//! split at the median of its widest coordinate (of its bounding box). Boxes are kept
//! exact (grown on insertion), so the bound is tight for the points under a node.
//! Replaces a uniform grid over positions (pruning by translation only), which the
//! rotation term defeated in SE(3) and whose far queries fell back to linear scans.
//!
//! [`ConfigSpace::embed`]: crate::space::ConfigSpace::embed
//! [`ConfigSpace::embed_mirror`]: crate::space::ConfigSpace::embed_mirror

use crate::space::{Combine, EMBED_DIM, EmbedTerms, Embedded};

/// Largest number of ids in a leaf before it is split.
pub const LEAF_MAX: usize = 16;

#[derive(Clone, Debug, PartialEq)]
enum Kind {
    Leaf(Vec<u32>),
    Split {
        axis: usize,
        /// Points with coordinate `< value` go left (`children[0]`), the others right.
        value: f64,
        children: [u32; 2],
    },
}

#[derive(Clone, Debug, PartialEq)]
struct KdNode {
    lo: Embedded,
    hi: Embedded,
    kind: Kind,
}

/// The index. See the module docs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KdTree {
    nodes: Vec<KdNode>,
    /// Embedded point of each id (index = id).
    points: Vec<Embedded>,
    /// True once a point without a (finite) embedding was inserted: queries must then
    /// scan linearly.
    unusable: bool,
    /// Coordinates `dims..` are 0 in every stored point (the planar space uses 4 of 7):
    /// bounds skip them, which only lowers them, so they stay lower bounds.
    dims: usize,
}

/// Grows the box `lo`–`hi` to hold `p`.
fn grow(lo: &mut Embedded, hi: &mut Embedded, p: &Embedded) {
    for ((l, h), &v) in lo.iter_mut().zip(hi.iter_mut()).zip(p) {
        *l = l.min(v);
        *h = h.max(v);
    }
}

/// The squared lower bound of the metric from the gap `gap(i)` of each embedded
/// coordinate `i < dims`, grouped as `terms` says.
#[inline]
fn lb2(terms: EmbedTerms, dims: usize, gap: impl Fn(usize) -> f64) -> f64 {
    if terms.combine == Combine::Euclidean {
        // One sum over all coordinates (the hot path: one loop, no split).
        let mut s = 0.0;
        for i in 0..dims {
            let e = gap(i);
            s += e * e;
        }
        return s;
    }
    let split = terms.split.min(dims);
    let (mut t, mut r) = (0.0, 0.0);
    for i in 0..split {
        let e = gap(i);
        t += e * e;
    }
    for i in split..dims {
        let e = gap(i);
        r += e * e;
    }
    let s = t.sqrt() + r.sqrt();
    s * s
}

fn dist2(terms: EmbedTerms, dims: usize, a: &Embedded, b: &Embedded) -> f64 {
    lb2(terms, dims, |i| a[i] - b[i])
}

fn box_dist2(terms: EmbedTerms, dims: usize, lo: &Embedded, hi: &Embedded, q: &Embedded) -> f64 {
    lb2(terms, dims, |i| (lo[i] - q[i]).max(q[i] - hi[i]).max(0.0))
}

/// Squared lower bound beyond which nothing can beat `best` (weighted m), with slack
/// for rounding in the bound.
fn limit2(best: f64) -> f64 {
    let l = best * (1.0 + 1e-9) + 1e-15;
    l * l
}

/// The query: its image(s) in the embedding and the exact distance to a stored id.
struct Query<'a> {
    images: &'a [Embedded],
    exact: &'a dyn Fn(u32) -> f64,
    dims: usize,
    terms: EmbedTerms,
}

impl Query<'_> {
    fn lb2_box(&self, n: &KdNode) -> f64 {
        let mut b = box_dist2(self.terms, self.dims, &n.lo, &n.hi, &self.images[0]);
        for q in &self.images[1..] {
            b = b.min(box_dist2(self.terms, self.dims, &n.lo, &n.hi, q));
        }
        b
    }

    fn lb2_point(&self, p: &Embedded) -> f64 {
        let mut b = dist2(self.terms, self.dims, p, &self.images[0]);
        for q in &self.images[1..] {
            b = b.min(dist2(self.terms, self.dims, p, q));
        }
        b
    }
}

impl KdTree {
    /// Number of ids inserted.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when nothing was inserted.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Bytes held on the heap, by capacity (points, nodes and their leaves' id lists).
    pub fn heap_bytes(&self) -> usize {
        let leaves: usize = self
            .nodes
            .iter()
            .map(|n| match &n.kind {
                Kind::Leaf(ids) => ids.capacity() * std::mem::size_of::<u32>(),
                Kind::Split { .. } => 0,
            })
            .sum();
        self.points.capacity() * std::mem::size_of::<Embedded>()
            + self.nodes.capacity() * std::mem::size_of::<KdNode>()
            + leaves
    }

    /// True when queries can be answered (every inserted point had a finite embedding).
    pub fn usable(&self) -> bool {
        !self.unusable
    }

    /// Inserts the next id (`len()` before the call) at `point`; `None` or a non-finite
    /// point makes the index unusable (callers then scan linearly).
    pub fn insert(&mut self, point: Option<Embedded>) {
        let id = self.points.len() as u32;
        let Some(p) = point.filter(|p| p.iter().all(|v| v.is_finite())) else {
            self.unusable = true;
            super::push_gently(&mut self.points, [0.0; EMBED_DIM]);
            return;
        };
        super::push_gently(&mut self.points, p);
        if let Some(last) = p.iter().rposition(|&v| v != 0.0) {
            self.dims = self.dims.max(last + 1);
        }
        if self.nodes.is_empty() {
            super::push_gently(
                &mut self.nodes,
                KdNode {
                    lo: p,
                    hi: p,
                    kind: Kind::Leaf(Vec::with_capacity(LEAF_MAX + 1)),
                },
            );
        }
        let mut at = 0;
        loop {
            let n = &mut self.nodes[at];
            grow(&mut n.lo, &mut n.hi, &p);
            match &mut n.kind {
                Kind::Split {
                    axis,
                    value,
                    children,
                } => at = children[usize::from(p[*axis] >= *value)] as usize,
                Kind::Leaf(ids) => {
                    ids.push(id);
                    if ids.len() > LEAF_MAX {
                        self.split(at);
                    }
                    return;
                }
            }
        }
    }

    /// Splits leaf `at` at the median of its widest coordinate; leaves it whole when all
    /// its points coincide.
    fn split(&mut self, at: usize) {
        let n = &self.nodes[at];
        let axis = (0..self.dims.max(1))
            .max_by(|&a, &b| (n.hi[a] - n.lo[a]).total_cmp(&(n.hi[b] - n.lo[b])))
            .unwrap_or(0);
        if n.hi[axis] <= n.lo[axis] {
            return;
        }
        let Kind::Leaf(ids) = &n.kind else {
            return;
        };
        let mut vals: Vec<f64> = ids.iter().map(|&i| self.points[i as usize][axis]).collect();
        vals.sort_by(f64::total_cmp);
        let mut value = vals[vals.len() / 2];
        if value <= vals[0] {
            // More than half at the minimum: split just above it (spread > 0, so some
            // point is greater).
            value = vals
                .iter()
                .copied()
                .find(|&v| v > vals[0])
                .unwrap_or(n.hi[axis]);
        }
        let mut sides = [
            Vec::with_capacity(LEAF_MAX + 1),
            Vec::with_capacity(LEAF_MAX + 1),
        ];
        for &id in ids {
            sides[usize::from(self.points[id as usize][axis] >= value)].push(id);
        }
        let base = self.nodes.len() as u32;
        for side in sides {
            let (mut lo, mut hi) = ([f64::INFINITY; EMBED_DIM], [f64::NEG_INFINITY; EMBED_DIM]);
            for &id in &side {
                grow(&mut lo, &mut hi, &self.points[id as usize]);
            }
            super::push_gently(
                &mut self.nodes,
                KdNode {
                    lo,
                    hi,
                    kind: Kind::Leaf(side),
                },
            );
        }
        self.nodes[at].kind = Kind::Split {
            axis,
            value,
            children: [base, base + 1],
        };
    }

    /// The id nearest to the query and its exact distance (weighted m), ties to the
    /// smallest id. `images` are the query's embedded points (one or two, see the module
    /// docs); `exact(id)` is the space's distance from stored id to the query; `terms`
    /// how gaps bound it. `None` when the index is empty or unusable.
    pub fn nearest(
        &self,
        images: &[Embedded],
        exact: &dyn Fn(u32) -> f64,
        terms: EmbedTerms,
    ) -> Option<(u32, f64)> {
        if self.nodes.is_empty() || self.unusable || images.is_empty() {
            return None;
        }
        let q = Query {
            images,
            exact,
            dims: self.dims,
            terms,
        };
        let mut best = (u32::MAX, f64::INFINITY);
        self.search(0, &q, &mut best);
        (best.0 != u32::MAX).then_some(best)
    }

    fn search(&self, at: usize, q: &Query, best: &mut (u32, f64)) {
        let n = &self.nodes[at];
        if q.lb2_box(n) > limit2(best.1) {
            return;
        }
        match &n.kind {
            Kind::Leaf(ids) => {
                for &id in ids {
                    if q.lb2_point(&self.points[id as usize]) > limit2(best.1) {
                        continue;
                    }
                    let d = (q.exact)(id);
                    if d < best.1 || (d == best.1 && id < best.0) {
                        *best = (id, d);
                    }
                }
            }
            Kind::Split {
                axis,
                value,
                children,
            } => {
                let first = usize::from(q.images[0][*axis] >= *value);
                self.search(children[first] as usize, q, best);
                self.search(children[1 - first] as usize, q, best);
            }
        }
    }

    /// The `k` ids nearest to the query into `out` (cleared first), sorted by exact
    /// distance, ties to the smallest id; arguments as for [`KdTree::nearest`]. False
    /// (and `out` empty) when the index is empty or unusable.
    pub fn k_nearest_into(
        &self,
        images: &[Embedded],
        exact: &dyn Fn(u32) -> f64,
        terms: EmbedTerms,
        k: usize,
        out: &mut Vec<(u32, f64)>,
    ) -> bool {
        out.clear();
        if self.nodes.is_empty() || self.unusable || images.is_empty() {
            return false;
        }
        if k > 0 {
            let q = Query {
                images,
                exact,
                dims: self.dims,
                terms,
            };
            self.k_search(0, &q, k, out);
        }
        true
    }

    fn k_search(&self, at: usize, q: &Query, k: usize, out: &mut Vec<(u32, f64)>) {
        let bound = |out: &Vec<(u32, f64)>| {
            if out.len() == k {
                out[k - 1].1
            } else {
                f64::INFINITY
            }
        };
        let n = &self.nodes[at];
        if q.lb2_box(n) > limit2(bound(out)) {
            return;
        }
        match &n.kind {
            Kind::Leaf(ids) => {
                for &id in ids {
                    if q.lb2_point(&self.points[id as usize]) > limit2(bound(out)) {
                        continue;
                    }
                    let d = (q.exact)(id);
                    let at = out.partition_point(|&(e_id, e)| e < d || (e == d && e_id < id));
                    if at < k {
                        if out.len() == k {
                            out.pop();
                        }
                        out.insert(at, (id, d));
                    }
                }
            }
            Kind::Split {
                axis,
                value,
                children,
            } => {
                let first = usize::from(q.images[0][*axis] >= *value);
                self.k_search(children[first] as usize, q, k, out);
                self.k_search(children[1 - first] as usize, q, k, out);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn euclid(p: &Embedded, q: &Embedded) -> f64 {
        dist2(EmbedTerms::EUCLIDEAN, EMBED_DIM, p, q).sqrt()
    }

    /// The sum of the Euclidean distances over coordinates `..2` and `2..`: the metric
    /// that `EmbedTerms { split: 2, combine: Combine::Sum }` bounds exactly.
    fn sum_of_groups(p: &Embedded, q: &Embedded) -> f64 {
        let g = |r: std::ops::Range<usize>| r.map(|i| (p[i] - q[i]).powi(2)).sum::<f64>();
        g(0..2).sqrt() + g(2..EMBED_DIM).sqrt()
    }

    #[test]
    fn euclidean_nearest_and_k_nearest_equal_brute_force() {
        nearest_and_k_nearest_equal_brute_force(EmbedTerms::EUCLIDEAN, euclid);
    }

    #[test]
    fn sum_of_terms_nearest_and_k_nearest_equal_brute_force() {
        let terms = EmbedTerms {
            split: 2,
            combine: Combine::Sum,
        };
        nearest_and_k_nearest_equal_brute_force(terms, sum_of_groups);
    }

    fn nearest_and_k_nearest_equal_brute_force(
        terms: EmbedTerms,
        metric: fn(&Embedded, &Embedded) -> f64,
    ) {
        // With the embedding itself as the metric, the bound is exact: every answer must
        // match sorting by (distance, id).
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut kd = KdTree::default();
        let mut points = Vec::new();
        for i in 0..3000 {
            let mut p = [0.0; EMBED_DIM];
            for v in p.iter_mut().take(4) {
                // Coarse values: many equal coordinates and some duplicate points.
                *v = f64::from(rng.random_range(0..20u8)) * 0.05;
            }
            if i % 7 == 0 {
                p = points.get(i / 2).copied().unwrap_or(p);
            }
            points.push(p);
            kd.insert(Some(p));
        }
        for _ in 0..200 {
            let mut q = [0.0; EMBED_DIM];
            for v in q.iter_mut().take(4) {
                *v = rng.random_range(-0.2..1.2);
            }
            let exact = |id: u32| metric(&points[id as usize], &q);
            let mut all: Vec<(u32, f64)> =
                (0..points.len() as u32).map(|i| (i, exact(i))).collect();
            all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            assert_eq!(kd.nearest(&[q], &exact, terms), Some(all[0]));
            let mut out = Vec::new();
            for k in [1, 3, 40] {
                assert!(kd.k_nearest_into(&[q], &exact, terms, k, &mut out));
                assert_eq!(out, all[..k].to_vec(), "k = {k}");
            }
        }
    }

    #[test]
    fn identical_points_stay_in_one_leaf_and_unusable_disables() {
        let mut kd = KdTree::default();
        for _ in 0..100 {
            kd.insert(Some([0.5; EMBED_DIM]));
        }
        let exact = |_: u32| 0.0;
        assert_eq!(
            kd.nearest(&[[0.0; EMBED_DIM]], &exact, EmbedTerms::EUCLIDEAN),
            Some((0, 0.0))
        );
        kd.insert(Some([f64::NAN; EMBED_DIM]));
        assert!(!kd.usable());
        assert_eq!(
            kd.nearest(&[[0.0; EMBED_DIM]], &exact, EmbedTerms::EUCLIDEAN),
            None
        );
        assert_eq!(kd.len(), 101);
    }
}
