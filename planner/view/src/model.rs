//! The viewer's side of the roadmap stream: reassembles the planner's trees from
//! [`Roadmap`] increments (see `ipc_types::Roadmap` for the protocol).
//!
//! Nodes are grouped in chunks of [`CHUNK_NODES`] consecutive indices of one tree; the
//! view draws one scene entity per chunk and redraws only the chunks that changed.

use ipc_types::{NO_PARENT, Roadmap, TreeKind};
use std::collections::{BTreeMap, BTreeSet};

/// Nodes per drawn chunk.
pub const CHUNK_NODES: u32 = 1024;

/// A node as the view keeps it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewNode {
    /// Position of the object's reference point, scene frame, m.
    pub position_m: [f64; 3],
    /// Parent index in the same tree, `NO_PARENT` for the root.
    pub parent: u32,
    /// Distance label, weighted m.
    pub distance_to_goal: f64,
    /// Collision label: Laplace-smoothed share of extensions that made progress, (0, 1]
    /// (`tree::Labels::freedom`).
    pub freedom: f64,
}

/// One tree as the view knows it; `nodes[i]` is `None` until node `i` arrived.
#[derive(Debug, Clone, Default)]
pub struct ViewTree {
    /// Start, goal or local.
    pub kind: TreeKind,
    /// Nodes the planner says the tree has.
    pub len: u32,
    /// What arrived so far.
    pub nodes: Vec<Option<ViewNode>>,
    /// Nodes received (`Some` entries).
    pub known: usize,
}

/// What the view must erase after applying a sample.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Removal {
    /// A new planner process (or the first one): erase everything.
    All,
    /// These chunks `(tree id, chunk)` belong to trees that are gone.
    Chunks(Vec<(u32, u32)>),
}

/// The reassembled roadmap.
#[derive(Debug, Clone, Default)]
pub struct RoadmapModel {
    writer_pid: u32,
    last_sequence: u64,
    /// Trees by id.
    pub trees: BTreeMap<u32, ViewTree>,
    /// Planner iterations in the newest sample.
    pub iterations: u64,
    /// Nodes in all trees according to the newest sample.
    pub total_nodes: u64,
    /// The newest sample said a solution exists.
    pub solved: bool,
    /// Samples applied.
    pub samples: u64,
    /// Samples the planner sent that this view did not see (sequence gaps).
    pub samples_missed: u64,
    dirty: BTreeSet<(u32, u32)>,
    changed: bool,
}

impl RoadmapModel {
    /// An empty model.
    pub fn new() -> Self {
        Self::default()
    }

    /// Nodes received so far, over all trees.
    pub fn known_nodes(&self) -> usize {
        self.trees.values().map(|t| t.known).sum()
    }

    /// Applies one sample; returns what the view must erase (before drawing the dirty
    /// chunks).
    pub fn apply(&mut self, s: &Roadmap) -> Option<Removal> {
        let mut removal = None;
        if s.header.writer_pid != self.writer_pid || s.header.sequence < self.last_sequence {
            // A new planner: its trees have nothing to do with the old ones.
            self.trees.clear();
            self.dirty.clear();
            self.writer_pid = s.header.writer_pid;
            removal = Some(Removal::All);
            self.changed = true;
        } else if s.header.sequence > self.last_sequence + 1 {
            self.samples_missed += s.header.sequence - self.last_sequence - 1;
        }
        self.last_sequence = s.header.sequence;
        self.samples += 1;
        self.iterations = s.iterations;
        self.total_nodes = s.total_nodes;
        self.solved = s.solved != 0;

        if s.manifest_complete() {
            let live: BTreeSet<u32> = s.trees().iter().map(|t| t.id).collect();
            let gone: Vec<u32> = self
                .trees
                .keys()
                .filter(|id| !live.contains(id))
                .copied()
                .collect();
            let mut chunks = Vec::new();
            for id in gone {
                if let Some(t) = self.trees.remove(&id) {
                    let n = (t.nodes.len() as u32).div_ceil(CHUNK_NODES);
                    chunks.extend((0..n).map(|c| (id, c)));
                }
                self.dirty.retain(|(t, _)| *t != id);
            }
            if !chunks.is_empty() {
                self.changed = true;
                if removal.is_none() {
                    removal = Some(Removal::Chunks(chunks));
                }
            }
        }
        for t in s.trees() {
            let tree = self.trees.entry(t.id).or_default();
            tree.kind = t.kind;
            tree.len = t.len;
        }
        for n in s.nodes() {
            let Some(tree) = self.trees.get_mut(&n.tree_id) else {
                continue; // a tree the manifest does not list: stale, skip
            };
            let i = n.index as usize;
            if n.index >= tree.len {
                continue; // beyond the tree's length: corrupt, do not allocate for it
            }
            if tree.nodes.len() <= i {
                tree.nodes.resize(i + 1, None);
            }
            let view = ViewNode {
                position_m: n.pose.position_m,
                parent: n.parent,
                distance_to_goal: n.distance_to_goal,
                freedom: planner_core::tree::Labels {
                    distance_to_goal: n.distance_to_goal,
                    extension_attempts: n.extension_attempts,
                    collisions: n.collisions,
                    covered_distance: 0.0,
                }
                .freedom(),
            };
            let slot = &mut tree.nodes[i];
            if slot.is_none() {
                tree.known += 1;
            }
            if *slot != Some(view) {
                *slot = Some(view);
                self.changed = true;
                self.dirty.insert((n.tree_id, n.index / CHUNK_NODES));
            }
        }
        removal
    }

    /// True when a node, a label or the set of trees changed since the last call (a
    /// rolling-window sample that re-sends known nodes unchanged changes nothing).
    pub fn take_changed(&mut self) -> bool {
        std::mem::take(&mut self.changed)
    }

    /// Chunks changed since the last call, `(tree id, chunk)`; clears the set.
    pub fn take_dirty(&mut self) -> Vec<(u32, u32)> {
        std::mem::take(&mut self.dirty).into_iter().collect()
    }

    /// Every chunk of every tree (to redraw all, e.g. for a client that just subscribed).
    pub fn all_chunks(&self) -> Vec<(u32, u32)> {
        self.trees
            .iter()
            .flat_map(|(id, t)| (0..(t.nodes.len() as u32).div_ceil(CHUNK_NODES)).map(|c| (*id, c)))
            .collect()
    }

    /// The edges `(parent position, child position)` of chunk `chunk` of tree `id` whose
    /// both ends are known.
    pub fn chunk_edges(&self, id: u32, chunk: u32) -> Vec<([f64; 3], [f64; 3])> {
        let Some(t) = self.trees.get(&id) else {
            return Vec::new();
        };
        let from = (chunk * CHUNK_NODES) as usize;
        let to = (from + CHUNK_NODES as usize).min(t.nodes.len());
        let mut out = Vec::new();
        for n in t.nodes.get(from..to).unwrap_or(&[]).iter().flatten() {
            if n.parent == NO_PARENT {
                continue;
            }
            if let Some(Some(p)) = t.nodes.get(n.parent as usize) {
                out.push((p.position_m, n.position_m));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use planner_shell::feed::{FeedInfo, RoadmapFeed};
    use planner_shell::test_trees::chain;

    fn info(pid: u32) -> FeedInfo {
        FeedInfo {
            iterations: 5,
            solved: false,
            pid,
            timestamp_ns: 1,
        }
    }

    #[test]
    fn a_late_viewer_that_misses_samples_still_gets_the_whole_roadmap() {
        let trees = vec![chain(3000, 0.0), chain(1200, 1.0), chain(40, 2.0)];
        let ids = [0, 1, 5];
        let mut feed = RoadmapFeed::new();
        let mut s = Box::new(Roadmap::EMPTY);
        // The viewer starts after 3 samples and sees only every other sample.
        for _ in 0..3 {
            feed.fill(&trees, &ids, info(9), &mut s);
        }
        let mut model = RoadmapModel::new();
        let mut applied = 0;
        for k in 0..40 {
            feed.fill(&trees, &ids, info(9), &mut s);
            if k % 2 == 0 {
                let r = model.apply(&s);
                assert_eq!(r.is_some(), applied == 0, "only the first sample resets");
                applied += 1;
            }
        }
        assert_eq!(model.known_nodes(), 4240);
        assert!(model.samples_missed > 0);
        let t0 = &model.trees[&0];
        assert_eq!(t0.kind, TreeKind::START);
        assert_eq!(t0.nodes[2999].expect("last").position_m[0], 2.999);
        // Every edge of a chain is drawn: 1023 in chunk 0 (the root has none), 1024 after.
        assert_eq!(model.chunk_edges(0, 0).len(), 1023);
        assert_eq!(model.chunk_edges(0, 1).len(), 1024);
        assert_eq!(model.all_chunks().len(), 3 + 2 + 1);
    }

    #[test]
    fn gone_trees_and_new_planners_are_erased() {
        let mut trees = vec![chain(3, 0.0), chain(2, 1.0), chain(4, 2.0)];
        let mut ids = vec![0, 1, 2];
        let mut feed = RoadmapFeed::new();
        let mut s = Box::new(Roadmap::EMPTY);
        let mut model = RoadmapModel::new();
        feed.fill(&trees, &ids, info(1), &mut s);
        assert_eq!(model.apply(&s), Some(Removal::All));
        assert_eq!(model.take_dirty(), vec![(0, 0), (1, 0), (2, 0)]);
        assert!(model.take_changed());
        // The same roadmap again (rolling window only): nothing changed.
        feed.fill(&trees, &ids, info(1), &mut s);
        assert_eq!(model.apply(&s), None);
        assert!(!model.take_changed() && model.take_dirty().is_empty());
        trees.pop();
        ids.pop();
        feed.fill(&trees, &ids, info(1), &mut s);
        assert_eq!(model.apply(&s), Some(Removal::Chunks(vec![(2, 0)])));
        assert!(
            model.take_dirty().is_empty(),
            "nothing changed in trees 0 and 1"
        );
        // A restarted planner (new pid) starts from scratch.
        let mut feed2 = RoadmapFeed::new();
        feed2.fill(&trees[..1], &ids[..1], info(2), &mut s);
        assert_eq!(model.apply(&s), Some(Removal::All));
        assert_eq!(model.known_nodes(), 3);
    }
}
