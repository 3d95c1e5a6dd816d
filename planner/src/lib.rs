//! Core of the interactive motion planner (I-RRT / H-RRT-C): scenes, the SE(3)
//! configuration space, collision checking with parry, trees with I-RRT labels,
//! RRT-Connect, and the attractive pseudo-force F_a.
//!
//! The core is pure: deterministic for a seed and an input sequence, no I/O except
//! explicit scene loading (`Scene::load`), no clock reads, no threads. The process shell
//! (IPC, timing) lives outside these modules.
//!
//! Code map:
//! - [`space`]: weighted SE(3) distance (I-RRT eq. 2), interpolation, sampling, `delta`.
//! - [`collision`]: parry compounds, `is_free`, `edge_free` at a stated resolution.
//! - [`tree`]: tree arena, node labels, nearest / k-nearest, paths.
//! - [`sampling`]: CS, POS, PATH, +CS, H-RRT-C authority sharing and HapticSampling.
//! - [`rrt`]: RRT, RRT-Connect with I-RRT Extend and local trees, the `Planner` API.
//! - [`path`]: shortcut smoothing, CSV / JSON export.
//! - [`guidance`]: F_a (label-weighted barycenter) and solution-path following.
//! - [`params`]: `PlannerParams` and `PlannerError`.
#![warn(missing_docs)]
#![deny(unsafe_code)]

pub mod shell;

pub use planner_core::{
    Algorithm, CollisionChecker, Combine, ConfigSpace, Contact, Extend, ExtendA, IterReport,
    PlanarSpace, Planner, PlannerError, PlannerParams, Sampling, SamplingError, Scene, SceneError,
    Se3, Se3Space, Source, Space, Stats, UserInput, Weights,
};
pub use planner_core::{collision, guidance, params, path, rrt, sampling, space, tree};
