//! The planner's side of the roadmap stream: fills [`Roadmap`] samples from the trees
//! (the planner's shell sends them; `view::model` is the reading side, and its tests
//! drive this feed).
//!
//! Protocol (see `ipc_types::Roadmap`): a manifest of the live trees, then the nodes added
//! since the previous sample (at most three quarters of the sample, starting at a
//! different tree each time so no tree starves), then a rolling window that re-sends the
//! roadmap from where the previous sample stopped. Work per sample is O(trees +
//! [`ROADMAP_NODES`]), whatever the roadmap's size.

use ipc_types::{
    Header, NO_PARENT, ROADMAP_NODES, ROADMAP_TREES, Roadmap, RoadmapNode, RoadmapTree, TreeKind,
};
use planner_core::tree::Tree;

/// Slots of each sample kept for new nodes; the rest (at least a quarter) carry the
/// rolling window.
pub const NEW_NODE_SLOTS: usize = ROADMAP_NODES - ROADMAP_NODES / 4;

/// Where the stream stands: per tree, how many nodes went out as new, and the rolling
/// window's cursor.
#[derive(Debug, Default, Clone)]
pub struct RoadmapFeed {
    /// `(tree id, nodes sent as new)` for the live trees.
    sent: Vec<(u32, u32)>,
    /// Rolling window: position in the tree list and node index.
    roll_tree: usize,
    roll_index: u32,
    sequence: u64,
    /// Complete sweeps of the rolling window so far.
    sweeps: u64,
}

/// What the planner reports alongside its trees.
#[derive(Debug, Clone, Copy)]
pub struct FeedInfo {
    /// Planner iterations so far.
    pub iterations: u64,
    /// A solution exists.
    pub solved: bool,
    /// Writer process id.
    pub pid: u32,
    /// `CLOCK_MONOTONIC` time of the sample, ns.
    pub timestamp_ns: u64,
}

impl RoadmapFeed {
    /// A feed that has sent nothing.
    pub fn new() -> Self {
        Self::default()
    }

    /// Complete sweeps of the rolling window so far.
    pub fn sweeps(&self) -> u64 {
        self.sweeps
    }

    /// Nodes of `trees` not yet sent as new.
    pub fn backlog(&self, trees: &[Tree], ids: &[u32]) -> usize {
        trees
            .iter()
            .zip(ids)
            .map(|(t, id)| t.len() - self.sent_of(*id) as usize)
            .sum()
    }

    fn sent_of(&self, id: u32) -> u32 {
        self.sent
            .iter()
            .find(|(i, _)| *i == id)
            .map_or(0, |&(_, n)| n)
    }

    /// Fills `out` (every field) with the next sample for `trees` with stable ids `ids`
    /// (`Planner::trees` and `Planner::tree_ids`).
    pub fn fill(&mut self, trees: &[Tree], ids: &[u32], info: FeedInfo, out: &mut Roadmap) {
        debug_assert_eq!(trees.len(), ids.len());
        let n_trees = trees.len().min(ids.len());
        self.sequence += 1;
        out.header = Header::new(self.sequence, info.timestamp_ns, info.pid);
        out.iterations = info.iterations;
        out.total_nodes = trees.iter().map(|t| t.len() as u64).sum();
        out.solved = u32::from(info.solved);
        out.reserved = 0;
        out.trees_total = n_trees as u32;
        out.trees_len = n_trees.min(ROADMAP_TREES) as u32;
        for (k, slot) in out.trees.iter_mut().enumerate() {
            *slot = if k < out.trees_len as usize {
                RoadmapTree {
                    id: ids[k],
                    kind: kind_of(k),
                    len: trees[k].len() as u32,
                    reserved: 0,
                }
            } else {
                RoadmapTree::default()
            };
        }

        // Forget trees that are gone; start new ones at zero.
        self.sent.retain(|(id, _)| ids[..n_trees].contains(id));
        for id in &ids[..n_trees] {
            if !self.sent.iter().any(|(i, _)| i == id) {
                self.sent.push((*id, 0));
            }
        }

        let mut len = 0usize;
        // New nodes, starting at a different tree each sample.
        for k in 0..n_trees {
            let t = (k + self.sequence as usize) % n_trees;
            let (id, tree) = (ids[t], &trees[t]);
            let Some(entry) = self.sent.iter_mut().find(|(i, _)| *i == id) else {
                continue;
            };
            while (entry.1 as usize) < tree.len() && len < NEW_NODE_SLOTS {
                out.nodes[len] = wire_node(tree, id, entry.1);
                entry.1 += 1;
                len += 1;
            }
        }
        out.new_nodes = len as u32;

        // Rolling window over everything, from where the previous sample stopped.
        let total: usize = trees[..n_trees].iter().map(Tree::len).sum();
        let mut visited = 0usize;
        while len < ROADMAP_NODES && visited < total {
            if self.roll_tree >= n_trees {
                self.roll_tree = 0;
                self.roll_index = 0;
                self.sweeps += 1;
            }
            let tree = &trees[self.roll_tree];
            if self.roll_index as usize >= tree.len() {
                self.roll_tree += 1;
                self.roll_index = 0;
                continue;
            }
            out.nodes[len] = wire_node(tree, ids[self.roll_tree], self.roll_index);
            self.roll_index += 1;
            len += 1;
            visited += 1;
        }
        out.nodes_len = len as u32;
        for slot in &mut out.nodes[len..] {
            *slot = RoadmapNode::EMPTY;
        }
    }
}

fn kind_of(position: usize) -> TreeKind {
    match position {
        0 => TreeKind::START,
        1 => TreeKind::GOAL,
        _ => TreeKind::LOCAL,
    }
}

fn wire_node(tree: &Tree, tree_id: u32, index: u32) -> RoadmapNode {
    let n = tree.node(planner_core::tree::NodeId(index));
    RoadmapNode {
        pose: ipc_types::convert::pose(&n.config.to_isometry()),
        distance_to_goal: n.labels.distance_to_goal,
        tree_id,
        index,
        parent: n.parent.map_or(NO_PARENT, |p| p.0),
        extension_attempts: n.labels.extension_attempts,
        collisions: n.labels.collisions,
        reserved: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_trees::chain;

    fn info() -> FeedInfo {
        FeedInfo {
            iterations: 1,
            solved: false,
            pid: 7,
            timestamp_ns: 1,
        }
    }

    #[test]
    fn new_nodes_go_out_once_then_the_window_sweeps_everything() {
        let trees = vec![chain(1500, 0.0), chain(300, 1.0), chain(5, 2.0)];
        let ids = [0, 1, 9];
        let mut feed = RoadmapFeed::new();
        let mut out = Box::new(Roadmap::EMPTY);
        let mut seen = std::collections::HashSet::new();
        let mut new_total = 0;
        for _ in 0..4 {
            feed.fill(&trees, &ids, info(), &mut out);
            assert_eq!(out.trees().len(), 3);
            assert_eq!(out.trees()[2].kind, TreeKind::LOCAL);
            assert_eq!(out.trees()[2].id, 9);
            assert!(out.new_nodes as usize <= NEW_NODE_SLOTS);
            assert_eq!(out.nodes().len(), ROADMAP_NODES);
            new_total += out.new_nodes as usize;
            for n in out.nodes() {
                seen.insert((n.tree_id, n.index));
                let want = if n.index == 0 { NO_PARENT } else { n.index - 1 };
                assert_eq!(n.parent, want);
            }
        }
        assert_eq!(new_total, 1805, "every node goes out as new exactly once");
        assert_eq!(feed.backlog(&trees, &ids), 0);
        assert_eq!(seen.len(), 1805);
        // Nothing new: the whole sample is rolling window.
        feed.fill(&trees, &ids, info(), &mut out);
        assert_eq!(out.new_nodes, 0);
        assert_eq!(out.nodes().len(), ROADMAP_NODES);
    }

    #[test]
    fn small_roadmaps_are_sent_whole_and_gone_trees_are_forgotten() {
        let mut trees = vec![chain(3, 0.0), chain(2, 1.0), chain(4, 2.0)];
        let mut ids = vec![0, 1, 2];
        let mut feed = RoadmapFeed::new();
        let mut out = Box::new(Roadmap::EMPTY);
        feed.fill(&trees, &ids, info(), &mut out);
        assert_eq!((out.new_nodes, out.nodes_len), (9, 18), "new + one sweep");
        assert_eq!(out.header.sequence, 1);
        assert_eq!(out.header.writer_pid, 7);
        // Local tree 2 merged away; a new local tree 3 appears.
        trees[2] = chain(2, 3.0);
        ids[2] = 3;
        feed.fill(&trees, &ids, info(), &mut out);
        assert_eq!(out.new_nodes, 2);
        assert!(out.nodes()[..2].iter().all(|n| n.tree_id == 3));
        assert_eq!(
            out.trees().iter().map(|t| t.id).collect::<Vec<_>>(),
            [0, 1, 3]
        );
        assert!(out.manifest_complete());
    }
}
