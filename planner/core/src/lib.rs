//! The pure core of the interactive motion planner (I-RRT / H-RRT-C): the SE(3) and planar
//! configuration spaces, collision checking with parry, trees with I-RRT labels, the
//! samplers, RRT and RRT-Connect with I-RRT local trees, paths, and the attractive
//! pseudo-force F_a.
//!
//! Architecture invariant: this crate is deterministic for a seed and an input sequence.
//! It reads no clock, does no I/O and starts no threads; it depends on no IPC crate. Time,
//! IPC and files are the business of the crates around it (`planner-shell`, `view`,
//! `lab`), which pass in what it needs.
//!
//! Code map:
//! - [`space`]: weighted SE(3) and planar (x, y, θ) distances (I-RRT eq. 2), interpolation,
//!   sampling, `delta`.
//! - [`collision`]: parry compounds, `is_free`, `edge_free` at a stated resolution.
//! - [`tree`]: tree arena, node labels, a k-d tree for nearest / k-nearest, paths.
//! - [`aligned`]: obstacle-aligned orientations for machine samples (narrow slots).
//! - [`sampling`]: CS, POS, PATH, +CS, H-RRT-C authority sharing and HapticSampling.
//! - [`authority`]: H-RRT-C's fixed α, and the authority that adapts to a stuck operator.
//! - [`rrt`]: RRT, RRT-Connect with I-RRT Extend and local trees, the `Planner` API.
//! - [`retraction`]: small-step retraction (plan a thinned object, carry the path back).
//! - [`portfolio`]: the narrow-passage methods taking turns with the operator, time shared
//!   by what each gives per check.
//! - [`path`]: shortcut smoothing, CSV / JSON export.
//! - [`guidance`]: F_a (label-weighted barycenter) and, once solved, the lead along the
//!   path (a saturating spring towards a carrot ahead, force and torque).
//! - [`params`]: `PlannerParams` and `PlannerError`.
#![warn(missing_docs)]
#![deny(unsafe_code)]

pub mod aligned;
pub mod authority;
pub mod collision;
pub mod guidance;
pub mod memory;
pub mod no_way;
pub mod params;
pub mod path;
pub mod portfolio;
pub mod retraction;
pub mod rrt;
pub mod sampling;
pub mod space;
pub mod tree;

pub use authority::{AdaptiveAuthority, Authority, AuthorityState};
pub use collision::{CollisionChecker, EdgeCheck};
pub use params::{Algorithm, ExtendA, HumanMode, MachineSampler, PlannerError, PlannerParams};
pub use rrt::{Extend, IterReport, Planner, Source, Stats};
pub use sampling::{Contact, Sampling, SamplingError, UserInput};
pub use scene::pose::Se3;
pub use scene::{Scene, SceneError};
pub use space::{Combine, ConfigSpace, PlanarSpace, Se3Space, Space, Weights};
