//! [`Roadmap`]: roadmap increments from the planner, for viewers and recorders.
//!
//! The planner's trees grow to tens of thousands of nodes; no fixed-size sample holds them
//! all. Each sample therefore carries
//!
//! 1. a **manifest** of the live trees (`trees`): stable tree id, kind, node count. A
//!    viewer forgets every tree that is not listed (local trees disappear when they are
//!    merged into a main tree or dropped); a new `header.writer_pid` means a new planner
//!    whose roadmap starts from scratch;
//! 2. up to [`ROADMAP_NODES`] nodes: first the nodes added since the previous sample
//!    (`new_nodes` of them, in tree order, each tree's in index order so parents come
//!    before children), then a **rolling window** that re-sends older nodes with their
//!    current labels, sweeping the whole roadmap over and over.
//!
//! A viewer that starts late, or loses samples because it was slow (the service overflows
//! safely: the planner never waits), has the whole roadmap after one sweep of the rolling
//! window; the planner keeps a quarter of every sample for it, so a sweep of N nodes takes
//! at most N / (ROADMAP_NODES / 4) samples.
//!
//! A node is identified by `(tree_id, index)`: main trees have ids [`TreeKind::START`] (0)
//! and [`TreeKind::GOAL`] (1); local trees get ids from 2 upwards, never reused by one
//! planner process. Indices are stable: trees only grow; a merged local tree's nodes
//! reappear as new nodes of the main tree.

use crate::{Header, Pose};
use iceoryx2::prelude::ZeroCopySend;

/// Most nodes in one [`Roadmap`] sample.
pub const ROADMAP_NODES: usize = 1024;
/// Most trees in one [`Roadmap`] manifest.
pub const ROADMAP_TREES: usize = 64;
/// `RoadmapNode::parent` of a root.
pub const NO_PARENT: u32 = u32::MAX;

/// Which kind of tree a roadmap tree is.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, ZeroCopySend)]
#[type_name("hrrtc::TreeKind.v1")]
pub struct TreeKind(pub u32);

impl TreeKind {
    /// The tree rooted at the start configuration.
    pub const START: Self = Self(0);
    /// The tree rooted at the goal configuration.
    pub const GOAL: Self = Self(1);
    /// An I-RRT local tree rooted where the operator went.
    pub const LOCAL: Self = Self(2);

    /// A short lower-case name; `"unknown"` for codes this build does not know.
    pub fn name(self) -> &'static str {
        match self {
            Self::START => "start",
            Self::GOAL => "goal",
            Self::LOCAL => "local",
            _ => "unknown",
        }
    }
}

/// One live tree in a [`Roadmap`] manifest.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ZeroCopySend)]
#[type_name("hrrtc::RoadmapTree.v1")]
pub struct RoadmapTree {
    /// Stable id (see the module docs).
    pub id: u32,
    /// [`TreeKind`].
    pub kind: TreeKind,
    /// Nodes in the tree now (indices `0..len`).
    pub len: u32,
    /// Reserved, zero.
    pub reserved: u32,
}

/// One node of a planner tree with its I-RRT labels.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("hrrtc::RoadmapNode.v1")]
pub struct RoadmapNode {
    /// Configuration: pose of the moving object's reference point, scene frame.
    pub pose: Pose,
    /// Distance label: weighted distance to the goal (I-RRT eq. 2 metric: 1 per m).
    pub distance_to_goal: f64,
    /// Id of the tree holding the node.
    pub tree_id: u32,
    /// Index of the node in its tree.
    pub index: u32,
    /// Index of the parent in the same tree, [`NO_PARENT`] for the root.
    pub parent: u32,
    /// Collision label input: extensions attempted from this node.
    pub extension_attempts: u32,
    /// Collision label input: attempts from this node that added nothing.
    pub collisions: u32,
    /// Reserved, zero.
    pub reserved: u32,
}

impl RoadmapNode {
    /// An all-zero node at the identity pose (the filler of unused slots).
    pub const EMPTY: Self = Self {
        pose: Pose::IDENTITY,
        distance_to_goal: 0.0,
        tree_id: 0,
        index: 0,
        parent: NO_PARENT,
        extension_attempts: 0,
        collisions: 0,
        reserved: 0,
    };
}

impl Default for RoadmapNode {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// A roadmap increment. See the module docs for the protocol.
///
/// Semantics: publish-subscribe, safe overflow (see [`crate::services::ROADMAP`]); a
/// subscriber that misses samples catches up through the rolling window.
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("hrrtc::Roadmap.v1")]
pub struct Roadmap {
    /// Sequence from 1 per planner process; timestamp = when the sample was filled.
    pub header: Header,
    /// Planner iterations so far.
    pub iterations: u64,
    /// Nodes in all trees now (also those not in the manifest when it is truncated).
    pub total_nodes: u64,
    /// Valid entries of `trees`, at most [`ROADMAP_TREES`].
    pub trees_len: u32,
    /// Live trees in the planner; more than `trees_len` means the manifest was truncated
    /// and a reader must not forget unlisted trees.
    pub trees_total: u32,
    /// Valid entries of `nodes`, at most [`ROADMAP_NODES`].
    pub nodes_len: u32,
    /// The first `new_nodes` entries of `nodes` are new; the rest re-send older nodes.
    pub new_nodes: u32,
    /// 1 once a solution exists, else 0.
    pub solved: u32,
    /// Reserved, zero.
    pub reserved: u32,
    /// The live trees; only the first `trees_len` are meaningful.
    pub trees: [RoadmapTree; ROADMAP_TREES],
    /// Nodes; only the first `nodes_len` are meaningful.
    pub nodes: [RoadmapNode; ROADMAP_NODES],
}

impl Roadmap {
    /// A sample with no trees and no nodes.
    pub const EMPTY: Self = Self {
        header: Header::new(0, 0, 0),
        iterations: 0,
        total_nodes: 0,
        trees_len: 0,
        trees_total: 0,
        nodes_len: 0,
        new_nodes: 0,
        solved: 0,
        reserved: 0,
        trees: [RoadmapTree {
            id: 0,
            kind: TreeKind::START,
            len: 0,
            reserved: 0,
        }; ROADMAP_TREES],
        nodes: [RoadmapNode::EMPTY; ROADMAP_NODES],
    };

    /// The valid manifest entries; a length beyond capacity (a corrupt sample) is clamped.
    pub fn trees(&self) -> &[RoadmapTree] {
        &self.trees[..(self.trees_len as usize).min(ROADMAP_TREES)]
    }

    /// The valid nodes; a length beyond capacity (a corrupt sample) is clamped.
    pub fn nodes(&self) -> &[RoadmapNode] {
        &self.nodes[..(self.nodes_len as usize).min(ROADMAP_NODES)]
    }

    /// True when the manifest lists every live tree (a reader may forget unlisted trees).
    pub fn manifest_complete(&self) -> bool {
        self.trees_total as usize <= self.trees().len()
    }
}

impl Default for Roadmap {
    fn default() -> Self {
        Self::EMPTY
    }
}

const _: () = {
    assert!(core::mem::size_of::<TreeKind>() == 4);
    assert!(core::mem::size_of::<RoadmapTree>() == 16);
    assert!(core::mem::size_of::<RoadmapNode>() == 56 + 8 + 6 * 4);
    assert!(
        core::mem::size_of::<Roadmap>()
            == 24 + 8 + 8 + 6 * 4 + 16 * ROADMAP_TREES + 88 * ROADMAP_NODES
    );
    assert!(core::mem::align_of::<Roadmap>() == 8);
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corrupt_lengths_are_clamped_and_truncation_is_visible() {
        let mut r = Roadmap::EMPTY;
        r.trees_len = u32::MAX;
        r.nodes_len = u32::MAX;
        assert_eq!(r.trees().len(), ROADMAP_TREES);
        assert_eq!(r.nodes().len(), ROADMAP_NODES);
        r.trees_len = 2;
        r.trees_total = 2;
        assert!(r.manifest_complete());
        r.trees_total = 3;
        assert!(!r.manifest_complete());
        assert_eq!(TreeKind(9).name(), "unknown");
        assert_eq!(TreeKind::LOCAL.name(), "local");
    }
}
