//! The live view (`planner view`): a separate process that shows the haptic session live over the Foxglove
//! WebSocket protocol and can record the same channels to MCAP.
//!
//! It only reads: the `HapticState` blackboard (pose, proxy, forces, contact), the
//! `Guidance` and `Path` services, and the planner's `Roadmap` increments
//! (`ipc_types::services::ROADMAP`, filled by `planner_shell::feed::RoadmapFeed` in
//! the planner's main thread). Neither the haptic loop nor the planner waits for it: a blackboard reader is
//! invisible to the writer, and the publish-subscribe services overflow safely. The view
//! may start and stop at any time; a late view gets the whole roadmap from the rolling
//! window within a few seconds.
//!
//! Channels (all Foxglove well-known schemas, protobuf, except `/view/status`):
//!
//! | topic | schema | content | rate |
//! |---|---|---|---|
//! | `/view/scene` | `foxglove.SceneUpdate` | obstacles, start/goal ghosts, bounds | on subscribe, every 2 s |
//! | `/view/object` | `foxglove.SceneUpdate` | the object in frames `device` and `proxy` | on subscribe, every 2 s |
//! | `/view/tf` | `foxglove.FrameTransforms` | scene → device (device-mapped pose), scene → proxy | new states, ≤ `--rate-hz` |
//! | `/view/forces` | `foxglove.SceneUpdate` | contact point, normal n_c, contact force, F_s, f_u, F_a | new states, ≤ `--rate-hz` |
//! | `/view/roadmap/edges` | `foxglove.SceneUpdate` | one entity per 1024-node chunk, coloured by tree | changed chunks and one more (rolling refresh), 4 Hz; all on subscribe |
//! | `/view/roadmap/nodes` | `foxglove.PointCloud` | every node with `distance_to_goal`, `freedom`, `tree_kind` | ≤ 1 Hz when a node or label changed; on subscribe |
//! | `/view/trail` | `foxglove.SceneUpdate` | the operator's travelled path | 2 Hz when changed |
//! | `/view/path` | `foxglove.SceneUpdate` | the solution path | when it arrives, every 2 s |
//! | `/view/status` | `viewstatus.ViewStatus` (derived with `foxglove::Encode`) | counters: nodes, trees, solved, contact, fault | 1 Hz |
//!
//! Log times are `CLOCK_MONOTONIC` ns, the time base of the device recording
//! (`devices::record`), whose topics are under `/device/`: the two files merge into one
//! (`mcap merge`, or [`merge_mcap`]: `planner merge-recordings`).

#![warn(missing_docs)]

pub mod draw;
mod error;
mod merge;
pub mod model;
mod run;
#[cfg(test)]
mod tests;

pub use error::ViewError;
pub use merge::merge_mcap;
pub use run::{ViewConfig, ViewReport, ViewStatus, Viewer};

/// Every topic the view writes, in the order of the table above.
pub const TOPICS: [&str; 9] = [
    "/view/scene",
    "/view/object",
    "/view/tf",
    "/view/forces",
    "/view/roadmap/edges",
    "/view/roadmap/nodes",
    "/view/trail",
    "/view/path",
    "/view/status",
];
