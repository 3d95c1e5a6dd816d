//! [`Planner::shed`]: what a planner drops to stay inside its memory bound
//! ([`crate::memory`]).

use super::Planner;
use crate::memory::Shed;

/// The newest nodes of each tree that are never dropped: the operator's recent
/// configurations and the trees' growing tips are among them.
pub const KEEP_NEWEST_NODES: usize = 1024;

/// Points of the operator's travelled path kept (PATH sampling draws among them).
pub const KEEP_USER_PATH: usize = 4096;

/// Touch-retracted configurations kept (the raw path's waypoints are counted among them).
pub const KEEP_TOUCHED: usize = 4096;

/// A local tree that has not grown for this many iterations (or a tenth of all so far,
/// if more) may be dropped whole.
pub const STALE_ITERATIONS: u64 = 2000;

/// Passes of leaf dropping in one shed (each may make new leaves of the last one's
/// parents).
const LEAF_PASSES: usize = 8;

impl Planner {
    /// Drops about `fraction` (in (0, 1)) of the nodes, worth least first, and the oldest
    /// points of the operator's path and touch-retracted configurations beyond the newest
    /// ones kept. Nothing once solved (the path is found; the trees no longer grow).
    ///
    /// The order (see [`crate::memory`]): local trees that have not grown for
    /// [`STALE_ITERATIONS`], stalest first; then, in every tree, leaves by how often
    /// they were the nearest node of an extension (never first: interior), oldest first.
    /// Roots and the newest [`KEEP_NEWEST_NODES`] of each tree stay. A tree that lost
    /// nodes takes a new stable id, so a roadmap viewer receives it again.
    pub fn shed(&mut self, fraction: f64) -> Shed {
        let mut out = Shed::default();
        if self.solved() || fraction.is_nan() || fraction <= 0.0 {
            return out;
        }
        let fraction = fraction.min(1.0);
        out.user_path = drop_oldest(&mut self.user_path, KEEP_USER_PATH, fraction);
        out.touched = drop_oldest(&mut self.touched, KEEP_TOUCHED, fraction);

        let total: usize = self.trees.iter().map(|t| t.len()).sum();
        let target = (fraction * total as f64).ceil() as usize;
        let mut dropped = 0usize;

        // Stale local trees, stalest first.
        let stale_for = STALE_ITERATIONS.max(self.iterations / 10);
        while dropped < target {
            let stalest = (2..self.trees.len())
                .filter(|&t| self.grown[t] + stale_for < self.iterations)
                .min_by_key(|&t| self.grown[t]);
            let Some(t) = stalest else { break };
            dropped += self.remove_tree(t).len();
            out.local_trees += 1;
        }

        // Leaves, from every tree in proportion to its size.
        if dropped < target {
            let left = (target - dropped) as f64 / (total - dropped).max(1) as f64;
            for t in 0..self.trees.len() {
                let want = (left * self.trees[t].len() as f64).ceil() as usize;
                let n = self.drop_leaves(t, want);
                if n > 0 {
                    self.tree_ids[t] = self.new_tree_id();
                }
                dropped += n;
            }
        }
        self.local_cursor = 0;
        out.nodes = dropped as u64;
        out
    }

    /// Drops up to `want` nodes of tree `t` that are leaves (or become leaves in a later
    /// pass), by fewest extension attempts, then oldest. Returns how many.
    fn drop_leaves(&mut self, t: usize, want: usize) -> usize {
        let mut dropped = 0;
        for _ in 0..LEAF_PASSES {
            if dropped >= want {
                break;
            }
            let tree = &self.trees[t];
            let n = tree.len();
            let keep_from = n.saturating_sub(KEEP_NEWEST_NODES);
            let mut children = vec![0u32; n];
            for node in tree.nodes() {
                if let Some(p) = node.parent {
                    children[p.index()] += 1;
                }
            }
            // (attempts, id) of the droppable leaves: never the root, nor the newest.
            let mut leaves: Vec<(u32, u32)> = (1..keep_from)
                .filter(|&i| children[i] == 0)
                .map(|i| (tree.nodes()[i].labels.extension_attempts, i as u32))
                .collect();
            drop(children);
            if leaves.is_empty() {
                break;
            }
            let take = (want - dropped).min(leaves.len());
            if take < leaves.len() {
                leaves.select_nth_unstable(take);
            }
            let mut mark = vec![false; n];
            for &(_, i) in &leaves[..take] {
                mark[i as usize] = true;
            }
            drop(leaves);
            dropped += self.trees[t].prune(&mark);
        }
        dropped
    }
}

/// Drops the oldest `fraction` of `v`'s entries beyond its newest `keep`; returns how many.
fn drop_oldest<T>(v: &mut Vec<T>, keep: usize, fraction: f64) -> u64 {
    let spare = v.len().saturating_sub(keep);
    let n = ((spare as f64) * fraction).ceil() as usize;
    let n = n.min(spare);
    v.drain(..n);
    v.shrink_to_fit();
    n as u64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PlannerParams;
    use crate::tree::NodeId;
    use scene::pose::Se3;
    use scene::{Part, Scene};

    /// Wall-hole with its hole closed: no way through, so the trees grow for good.
    fn closed() -> Scene {
        let mut s = Scene::wall_with_hole();
        s.obstacles
            .push(Part::axis_box([0.01, 0.04, 0.04], [0.0, 0.0, 0.0]));
        s.route.clear();
        s
    }

    fn grown(iterations: u64, local_trees: bool) -> Planner {
        let params = PlannerParams {
            local_trees,
            ..PlannerParams::default()
        };
        let mut p = Planner::new(&closed(), params, 3).expect("planner");
        // An operator wandering in front of the wall feeds the local trees.
        for i in 0..iterations {
            let t = i as f64 * 0.01;
            let user = Se3::from_xyz(-0.1, 0.1 * t.sin(), 0.1 * t.cos());
            let r = p.iterate(local_trees.then_some(&user));
            assert!(!r.solved);
        }
        p
    }

    /// Every parent precedes its child, and each tree's first node is its root.
    fn well_formed(p: &Planner) {
        for t in p.trees() {
            assert!(t.nodes()[0].parent.is_none());
            for (i, n) in t.nodes().iter().enumerate().skip(1) {
                let parent = n.parent.expect("a parent").index();
                assert!(parent < i);
            }
        }
    }

    #[test]
    fn a_shed_drops_the_share_asked_keeps_roots_and_newest_and_planning_goes_on() {
        let mut p = grown(6000, false);
        let before = p.stats().nodes;
        assert!(before > 4 * KEEP_NEWEST_NODES, "{before} nodes");
        let newest: Vec<Vec<Se3>> = p
            .trees()
            .iter()
            .map(|t| {
                let n = t.len();
                t.nodes()[n - KEEP_NEWEST_NODES..]
                    .iter()
                    .map(|n| n.config)
                    .collect()
            })
            .collect();
        let ids = p.tree_ids().to_vec();
        let heap_before: usize = p.trees().iter().map(|t| t.heap_bytes()).sum();
        let shed = p.shed(0.3);
        let after = p.stats().nodes;
        assert_eq!(before - after, shed.nodes as usize);
        let want = (0.3 * before as f64).ceil() as usize;
        assert!(shed.nodes as usize >= want * 9 / 10, "{shed:?} of {want}");
        assert!(shed.nodes as usize <= want, "{shed:?} of {want}");
        well_formed(&p);
        let scene = closed();
        assert_eq!(p.trees()[0].node(NodeId(0)).config, scene.start);
        assert_eq!(p.trees()[1].node(NodeId(0)).config, scene.goal);
        for (t, keep) in p.trees().iter().zip(&newest) {
            let n = t.len();
            let now: Vec<Se3> = t.nodes()[n - KEEP_NEWEST_NODES..]
                .iter()
                .map(|n| n.config)
                .collect();
            assert_eq!(&now, keep, "the newest nodes stay, in order");
        }
        assert!(p.tree_ids().iter().zip(&ids).all(|(a, b)| a != b));
        let heap_after: usize = p.trees().iter().map(|t| t.heap_bytes()).sum();
        assert!(
            heap_after < heap_before * 8 / 10,
            "{heap_after} of {heap_before}"
        );
        // The index is rebuilt: nearest agrees with the linear scan, and planning goes on.
        let space = p.space().clone();
        let q = Se3::from_xyz(-0.05, 0.02, -0.03);
        for t in p.trees() {
            assert_eq!(t.nearest(&space, &q), t.nearest_linear(&space, &q));
        }
        for _ in 0..500 {
            p.iterate(None);
        }
        assert!(p.stats().nodes > after);
        well_formed(&p);
    }

    #[test]
    fn stale_local_trees_go_first_and_a_solved_planner_sheds_nothing() {
        let mut p = grown(STALE_ITERATIONS + 100, false);
        // Three local trees that grew last at iteration 0, and one growing now.
        let chain = |p: &mut Planner, y: f64, grown: u64| {
            let mut t = crate::tree::Tree::new(Se3::from_xyz(-0.1, y, 0.1), 0.3);
            for k in 1..50u32 {
                t.add(
                    NodeId(k - 1),
                    Se3::from_xyz(-0.1, y, 0.1 - 1e-3 * f64::from(k)),
                    0.3,
                );
            }
            p.trees.push(t);
            let id = p.new_tree_id();
            p.tree_ids.push(id);
            p.grown.push(grown);
        };
        for y in [-0.1, 0.0, 0.1] {
            chain(&mut p, y, 0);
        }
        let now = p.iterations;
        chain(&mut p, 0.2, now);
        let fresh = *p.tree_ids.last().expect("a local tree");
        let nodes = p.stats().nodes;
        // A share the stale trees alone cover: they go, nothing else does.
        let shed = p.shed(150.0 / nodes as f64);
        assert_eq!((shed.local_trees, shed.nodes), (3, 150), "{shed:?}");
        assert_eq!(p.tree_ids().len(), 3);
        assert_eq!(p.tree_ids()[2], fresh);
        well_formed(&p);

        let mut solved = Planner::new(
            &Scene::wall_with_square_hole(0.30),
            PlannerParams::default(),
            1,
        )
        .expect("planner");
        while !solved.iterate(None).solved {}
        let nodes = solved.stats().nodes;
        assert!(solved.shed(0.5).is_empty());
        assert_eq!(solved.stats().nodes, nodes);
    }
}
