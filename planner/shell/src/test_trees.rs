//! Trees for the tests of both ends of the roadmap stream (this crate's feed, `view`'s
//! model): a fixture, not part of the API.

use planner_core::Se3;
use planner_core::tree::{NodeId, Tree};

/// A tree of `n` nodes in a line along x at height `y`, 1 mm apart.
pub fn chain(n: usize, y: f64) -> Tree {
    let mut t = Tree::new(Se3::from_xyz(0.0, y, 0.0), 1.0);
    for i in 1..n {
        t.add(
            NodeId(i as u32 - 1),
            Se3::from_xyz(i as f64 * 1e-3, y, 0.0),
            1.0,
        );
    }
    t
}
