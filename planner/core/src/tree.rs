//! Tree arena for RRT-style planners: nodes with configuration, parent and I-RRT labels
//! ("Node labelling"), nearest and k-nearest queries, and paths to the root.
//!
//! [`Tree::nearest`] and [`Tree::k_nearest_into`] use a k-d tree over the space's
//! lower-bounding embedding ([`kd`], [`ConfigSpace::embed`]) on trees of at least
//! [`INDEX_MIN_NODES`] nodes, and a linear scan otherwise or when the space has no
//! embedding; both give the same answer. The index is brought up to date lazily by the
//! queries (nodes are added without a space), so every query on one tree must pass the
//! same space.

pub mod kd;

/// Pushes `x`, growing a full vector by a quarter (at least 64) rather than doubling it:
/// the arenas and indexes of a planner under a memory bound ([`crate::memory`]) then
/// never ask for twice what they hold at once.
pub(crate) fn push_gently<T>(v: &mut Vec<T>, x: T) {
    if v.len() == v.capacity() {
        v.reserve_exact((v.len() / 4).max(64));
    }
    v.push(x);
}

/// Below this many nodes the linear scan is cheaper than the index.
pub const INDEX_MIN_NODES: usize = 64;

use crate::space::{ConfigSpace, Embedded};
use scene::pose::Se3;
use std::cell::RefCell;

/// Index of a node in its tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(pub u32);

impl NodeId {
    /// The index as `usize`.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// I-RRT node labels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Labels {
    /// Distance label: weighted distance from the node to the goal (weighted m).
    pub distance_to_goal: f64,
    /// Collision label input: extensions attempted from this node.
    pub extension_attempts: u32,
    /// Collision label input: attempts from this node that added nothing (Collision).
    pub collisions: u32,
    /// Collision label input: total distance covered by extensions from this node
    /// (weighted m).
    pub covered_distance: f64,
}

impl Labels {
    /// Fresh labels for a node at `distance_to_goal` (weighted m).
    pub fn new(distance_to_goal: f64) -> Self {
        Labels {
            distance_to_goal,
            extension_attempts: 0,
            collisions: 0,
            covered_distance: 0.0,
        }
    }

    /// Laplace-smoothed share of extension attempts that made progress, in (0, 1]:
    /// `(attempts − collisions + 1) / (attempts + 1)`; 1 for an untried node, falling
    /// towards 0 as collisions accumulate.
    pub fn freedom(&self) -> f64 {
        let a = f64::from(self.extension_attempts);
        let c = f64::from(self.collisions.min(self.extension_attempts));
        (a - c + 1.0) / (a + 1.0)
    }
}

/// One node.
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    /// Configuration (scene frame).
    pub config: Se3,
    /// Parent node; `None` for the root.
    pub parent: Option<NodeId>,
    /// I-RRT labels.
    pub labels: Labels,
}

/// A rooted tree stored as an arena (nodes are never removed).
#[derive(Clone, Debug, Default)]
pub struct Tree {
    nodes: Vec<Node>,
    /// Nearest-neighbour index of the first `index.len()` nodes (see the module docs).
    index: RefCell<kd::KdTree>,
}

/// Trees are equal when their nodes are (the index is a cache).
impl PartialEq for Tree {
    fn eq(&self, other: &Self) -> bool {
        self.nodes == other.nodes
    }
}

impl Tree {
    /// A tree with a single root at `root`, labelled with `distance_to_goal` (weighted m).
    pub fn new(root: Se3, distance_to_goal: f64) -> Self {
        Tree {
            nodes: vec![Node {
                config: root,
                parent: None,
                labels: Labels::new(distance_to_goal),
            }],
            index: RefCell::default(),
        }
    }

    /// Number of nodes (≥ 1).
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Always false: a tree has its root.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// All nodes, in insertion order (index = `NodeId`).
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The node `id`. Panics on an id from another tree that is out of range.
    pub fn node(&self, id: NodeId) -> &Node {
        &self.nodes[id.index()]
    }

    /// Mutable labels of node `id`.
    pub fn labels_mut(&mut self, id: NodeId) -> &mut Labels {
        &mut self.nodes[id.index()].labels
    }

    /// Adds a child of `parent` at `config`; returns its id.
    pub fn add(&mut self, parent: NodeId, config: Se3, distance_to_goal: f64) -> NodeId {
        let id = NodeId(self.nodes.len() as u32);
        push_gently(
            &mut self.nodes,
            Node {
                config,
                parent: Some(parent),
                labels: Labels::new(distance_to_goal),
            },
        );
        id
    }

    /// The node nearest to `q` under the space's weighted distance, and that distance.
    /// Ties go to the oldest node.
    pub fn nearest(&self, space: &dyn ConfigSpace, q: &Se3) -> (NodeId, f64) {
        if let Some((images, n)) = self.indexed_query(space, q) {
            let exact = |id: u32| space.distance(&self.nodes[id as usize].config, q);
            let terms = space.embed_terms();
            if let Some((id, d)) = self.index.borrow().nearest(&images[..n], &exact, terms) {
                return (NodeId(id), d);
            }
        }
        self.nearest_linear(space, q)
    }

    /// The query's images in the embedding, with the index caught up with the nodes;
    /// `None` when the tree is small or the space or `q` has no (finite) embedding.
    fn indexed_query(&self, space: &dyn ConfigSpace, q: &Se3) -> Option<([Embedded; 2], usize)> {
        if self.nodes.len() < INDEX_MIN_NODES || !q.is_finite() {
            return None;
        }
        let e = space.embed(q)?;
        let mut index = self.index.borrow_mut();
        for n in &self.nodes[index.len()..] {
            index.insert(space.embed(&n.config));
        }
        if !index.usable() {
            return None;
        }
        Some(match space.embed_mirror(q) {
            Some(m) => ([e, m], 2),
            None => ([e, e], 1),
        })
    }

    /// [`Tree::nearest`] by a linear scan (the reference the k-d tree is tested against).
    pub fn nearest_linear(&self, space: &dyn ConfigSpace, q: &Se3) -> (NodeId, f64) {
        let mut best = (NodeId(0), f64::INFINITY);
        for (i, n) in self.nodes.iter().enumerate() {
            if let Some(d) = space.distance_below(&n.config, q, best.1) {
                best = (NodeId(i as u32), d);
            }
        }
        best
    }

    /// Fills `out` with the `k` nodes nearest to `q`, sorted by increasing distance
    /// (weighted m); ties go to the oldest node. `out` is cleared first (reuse it).
    pub fn k_nearest_into(
        &self,
        space: &dyn ConfigSpace,
        q: &Se3,
        k: usize,
        out: &mut Vec<(NodeId, f64)>,
    ) {
        out.clear();
        if k == 0 {
            return;
        }
        if let Some((images, n)) = self.indexed_query(space, q) {
            let exact = |id: u32| space.distance(&self.nodes[id as usize].config, q);
            let mut ids = Vec::with_capacity(k);
            if self.index.borrow().k_nearest_into(
                &images[..n],
                &exact,
                space.embed_terms(),
                k,
                &mut ids,
            ) {
                out.extend(ids.into_iter().map(|(id, d)| (NodeId(id), d)));
                return;
            }
        }
        self.k_nearest_linear_into(space, q, k, out);
    }

    /// [`Tree::k_nearest_into`] by a linear scan (the reference the k-d tree is tested against).
    pub fn k_nearest_linear_into(
        &self,
        space: &dyn ConfigSpace,
        q: &Se3,
        k: usize,
        out: &mut Vec<(NodeId, f64)>,
    ) {
        out.clear();
        if k == 0 {
            return;
        }
        for (i, n) in self.nodes.iter().enumerate() {
            let bound = if out.len() == k {
                out[k - 1].1
            } else {
                f64::INFINITY
            };
            let Some(d) = space.distance_below(&n.config, q, bound) else {
                continue;
            };
            let at = out.partition_point(|&(_, e)| e <= d);
            if out.len() == k {
                out.pop();
            }
            out.insert(at, (NodeId(i as u32), d));
        }
    }

    /// Grafts every node of `other` into this tree, joining `other`'s node `other_at` to
    /// this tree's node `at` (same configuration: `other_at` itself is not copied). The
    /// other tree is re-rooted at `other_at`: edges keep their endpoints, parents flip
    /// where needed. Labels are copied; the distance label is recomputed by `to_goal`.
    /// Returns the new ids of `other`'s nodes, indexed by their old ids.
    pub fn graft(
        &mut self,
        at: NodeId,
        other: &Tree,
        other_at: NodeId,
        to_goal: impl Fn(&Se3) -> f64,
    ) -> Vec<NodeId> {
        let n = other.len();
        let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (i, node) in other.nodes.iter().enumerate() {
            if let Some(p) = node.parent {
                adj[i].push(p.0);
                adj[p.index()].push(i as u32);
            }
        }
        let mut map = vec![NodeId(u32::MAX); n];
        map[other_at.index()] = at;
        let mut stack = vec![other_at.0];
        while let Some(u) = stack.pop() {
            for &v in &adj[u as usize] {
                if map[v as usize].0 != u32::MAX {
                    continue;
                }
                let src = &other.nodes[v as usize];
                let id = self.add(map[u as usize], src.config, to_goal(&src.config));
                let l = self.labels_mut(id);
                l.extension_attempts = src.labels.extension_attempts;
                l.collisions = src.labels.collisions;
                l.covered_distance = src.labels.covered_distance;
                map[v as usize] = id;
                stack.push(v);
            }
        }
        map
    }

    /// Removes the nodes `drop` marks (indexed by id) and renumbers the rest in their
    /// order; a dropped node's children must be dropped too, and the root never is.
    /// Returns how many were dropped. The index is rebuilt by the next query, and the
    /// arena gives back what it no longer needs ([`crate::memory`]).
    pub fn prune(&mut self, drop: &[bool]) -> usize {
        debug_assert_eq!(drop.len(), self.nodes.len());
        debug_assert!(!drop.first().copied().unwrap_or(false), "the root stays");
        // New id of each kept node; u32::MAX for a dropped one.
        let mut new_id = Vec::with_capacity(self.nodes.len());
        let mut kept = 0u32;
        for &d in drop {
            new_id.push(if d { u32::MAX } else { kept });
            kept += u32::from(!d);
        }
        let mut next = 0;
        for old in 0..self.nodes.len() {
            if drop.get(old).copied().unwrap_or(false) {
                continue;
            }
            let mut node = self.nodes[old].clone();
            node.parent = node.parent.map(|p| NodeId(new_id[p.index()]));
            debug_assert!(node.parent.is_none_or(|p| p.0 != u32::MAX));
            self.nodes[next] = node;
            next += 1;
        }
        let dropped = self.nodes.len() - next;
        self.nodes.truncate(next);
        self.nodes.shrink_to_fit();
        *self.index.borrow_mut() = kd::KdTree::default();
        dropped
    }

    /// Bytes this tree holds on the heap (its arena and index, by capacity).
    pub fn heap_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>() + self.index.borrow().heap_bytes()
    }

    /// The configurations from `id` up to the root, `id` first.
    pub fn path_to_root(&self, id: NodeId) -> Vec<Se3> {
        let mut out = Vec::new();
        let mut cur = Some(id);
        while let Some(c) = cur {
            let n = self.node(c);
            out.push(n.config);
            cur = n.parent;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::space::tests::space;
    use crate::space::{Se3Space, Weights};
    use scene::Scene;

    fn line_tree() -> Tree {
        // Root at x = 0, then 0.1, 0.2, 0.3 in a chain, and a branch at y = 0.05 off node 1.
        let mut t = Tree::new(Se3::from_xyz(0.0, 0.0, 0.0), 0.3);
        let a = t.add(NodeId(0), Se3::from_xyz(0.1, 0.0, 0.0), 0.2);
        let b = t.add(a, Se3::from_xyz(0.2, 0.0, 0.0), 0.1);
        t.add(b, Se3::from_xyz(0.3, 0.0, 0.0), 0.0);
        t.add(a, Se3::from_xyz(0.1, 0.05, 0.0), 0.2);
        t
    }

    #[test]
    fn nearest_and_k_nearest_agree_with_brute_force() {
        let (s, t) = (space(), line_tree());
        let q = Se3::from_xyz(0.12, 0.04, 0.0);
        assert_eq!(t.nearest(&s, &q).0, NodeId(4));
        let mut out = Vec::new();
        t.k_nearest_into(&s, &q, 3, &mut out);
        let ids: Vec<u32> = out.iter().map(|(i, _)| i.0).collect();
        assert_eq!(ids, vec![4, 1, 2]);
        assert!(out.windows(2).all(|w| w[0].1 <= w[1].1));
        t.k_nearest_into(&s, &q, 10, &mut out);
        assert_eq!(out.len(), 5);
        t.k_nearest_into(&s, &q, 0, &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn path_to_root_walks_parents() {
        let t = line_tree();
        let p = t.path_to_root(NodeId(3));
        let xs: Vec<f64> = p.iter().map(|q| q.pos.x).collect();
        assert_eq!(xs, vec![0.3, 0.2, 0.1, 0.0]);
        assert_eq!(t.path_to_root(NodeId(0)).len(), 1);
    }

    #[test]
    fn freedom_falls_with_collisions() {
        let mut l = Labels::new(1.0);
        assert_eq!(l.freedom(), 1.0);
        l.extension_attempts = 3;
        l.collisions = 3;
        assert_eq!(l.freedom(), 0.25);
        l.collisions = 0;
        assert_eq!(l.freedom(), 1.0);
    }

    #[test]
    fn graft_re_roots_and_keeps_edges() {
        let mut main = Tree::new(Se3::from_xyz(-0.3, 0.0, 0.0), 1.0);
        let other = line_tree(); // 0 – 1 – 2 – 3, and 4 off 1
        // Join other's node 2 onto main's root.
        let map = main.graft(NodeId(0), &other, NodeId(2), |q| q.pos.x.abs());
        assert_eq!(main.len(), 1 + 4);
        assert_eq!(map[2], NodeId(0));
        // Every edge of `other` is an edge of `main` (in one direction or the other).
        for (i, node) in other.nodes().iter().enumerate() {
            if let Some(p) = node.parent {
                let (a, b) = (map[i], map[p.index()]);
                assert!(
                    main.node(a).parent == Some(b) || main.node(b).parent == Some(a),
                    "edge {i}-{}",
                    p.0
                );
            }
        }
        // From old node 0 (the old root) the path now runs 0 → 1 → 2(= main root).
        let path = main.path_to_root(map[0]);
        let xs: Vec<f64> = path.iter().map(|q| q.pos.x).collect();
        assert_eq!(xs, vec![0.0, 0.1, -0.3]);
        assert_eq!(main.node(map[4]).labels.distance_to_goal, 0.1);
    }

    /// Grows a clustered tree in `s` (nodes near earlier nodes, like a grown tree) and
    /// checks, while it grows, that the indexed queries equal the linear scans.
    fn index_equals_linear_scan(s: &dyn ConfigSpace, seed: u64, near_sigma: f64, indexed: bool) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut t = Tree::new(s.sample_uniform(&mut rng), 1.0);
        let mut checked = 0;
        for i in 1..2000u32 {
            let base = t.node(NodeId(i / 2)).config;
            let mut q = s.sample_near(&base, near_sigma, &mut rng);
            if i % 5 == 0 {
                // Both quaternion signs of a rotation occur in a tree.
                q.rot = nalgebra::UnitQuaternion::new_unchecked(-q.rot.into_inner());
            }
            t.add(NodeId(i / 2), q, 1.0);
            if i % 10 == 0 {
                // Duplicates exercise the tie rule.
                let dup = t.node(NodeId(i / 3)).config;
                t.add(NodeId(0), dup, 1.0);
            }
            if i % 40 != 0 {
                continue;
            }
            for _ in 0..8 {
                let q = match rng.random_range(0..3) {
                    0 => s.sample_uniform(&mut rng),
                    1 => {
                        let near = t.node(NodeId(rng.random_range(0..t.len() as u32))).config;
                        s.sample_near(&near, 0.01, &mut rng)
                    }
                    _ => t.node(NodeId(rng.random_range(0..t.len() as u32))).config,
                };
                assert_eq!(t.nearest(s, &q), t.nearest_linear(s, &q), "{q:?}");
                for k in [1, 5, 40] {
                    let (mut indexed, mut linear) = (Vec::new(), Vec::new());
                    t.k_nearest_into(s, &q, k, &mut indexed);
                    t.k_nearest_linear_into(s, &q, k, &mut linear);
                    assert_eq!(indexed, linear, "k = {k}, {q:?}");
                }
                checked += 1;
            }
            if indexed && t.len() >= INDEX_MIN_NODES {
                // Not vacuous: the index was used and is up to date.
                let index = t.index.borrow();
                assert!(index.usable() && index.len() == t.len());
            }
        }
        assert!(checked > 300);
        let dup = t.node(NodeId(10)).config;
        let first = t.nodes().iter().position(|n| n.config == dup).unwrap() as u32;
        assert_eq!(
            t.nearest(s, &dup).0,
            NodeId(first),
            "ties go to the oldest node"
        );
        let mut two = Vec::new();
        t.k_nearest_into(s, &dup, 2, &mut two);
        assert_eq!(two[0].0, NodeId(first));
    }

    #[test]
    fn indexed_nearest_and_k_nearest_equal_linear_scans_planar() {
        let maze = Scene::maze();
        let s = crate::space::PlanarSpace::new(maze.bounds, Weights::default(), &maze.start);
        index_equals_linear_scan(&s, 4, 0.05, true);
    }

    #[test]
    fn indexed_nearest_and_k_nearest_equal_linear_scans_se3() {
        index_equals_linear_scan(&space(), 5, 0.05, true);
        // Rotation-dominated: small moves, large turns (σ 0.05 weighted m = 0.5 rad).
        let s = Se3Space::new(Scene::tunnels(1, 0).bounds, Weights::default());
        index_equals_linear_scan(&s, 6, 0.02, true);
    }

    #[test]
    fn indexed_queries_equal_linear_scans_with_the_sum_metric() {
        // The index prunes by the sum of the two terms' bounds (`EmbedTerms`).
        let w = Weights {
            combine: crate::space::Combine::Sum,
            ..Weights::default()
        };
        let maze = Scene::maze();
        let planar = crate::space::PlanarSpace::new(maze.bounds, w, &maze.start);
        index_equals_linear_scan(&planar, 7, 0.05, true);
        let se3 = Se3Space::new(Scene::tunnels(1, 0).bounds, w);
        index_equals_linear_scan(&se3, 8, 0.02, true);
    }

    #[test]
    fn a_space_without_embedding_scans_linearly() {
        struct NoEmbed(Se3Space);
        impl ConfigSpace for NoEmbed {
            fn distance(&self, a: &Se3, b: &Se3) -> f64 {
                self.0.distance(a, b)
            }
            fn interpolate(&self, a: &Se3, b: &Se3, t: f64) -> Se3 {
                self.0.interpolate(a, b, t)
            }
            fn sample_uniform(&self, rng: &mut dyn rand::RngCore) -> Se3 {
                self.0.sample_uniform(rng)
            }
            fn sample_near(&self, c: &Se3, sigma: f64, rng: &mut dyn rand::RngCore) -> Se3 {
                self.0.sample_near(c, sigma, rng)
            }
            fn contains(&self, q: &Se3) -> bool {
                self.0.contains(q)
            }
            fn delta(&self, from: &Se3, to: &Se3) -> nalgebra::Vector6<f64> {
                self.0.delta(from, to)
            }
        }
        let s = NoEmbed(space());
        index_equals_linear_scan(&s, 7, 0.05, false);
        assert!(s.embed(&Se3::identity()).is_none());
    }
}
