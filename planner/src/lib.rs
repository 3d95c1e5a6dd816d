//! The interactive motion planner (I-RRT / H-RRT-C) as a process next to the haptic loop:
//! the pure planning core, re-exported from `planner-core` at the same paths, and the
//! process shell around it.
//!
//! Code map:
//! - The core ([`space`], [`collision`], [`tree`], [`sampling`], [`rrt`] with the
//!   [`Planner`] API, [`path`], [`guidance`], [`params`]): see `planner_core`. Pure:
//!   deterministic for a seed and an input sequence, no clock reads, no I/O, no threads.
//! - [`shell`]: the planner process. Its threads read the haptic state over iceoryx2
//!   ([`shell::pacing`] decides when), iterate the planner and publish guidance, the
//!   solution path and roadmap increments (`view::feed`); [`shell::convert`] turns
//!   wire types into core types and back at the edge. Configured by a validated
//!   [`shell::ShellConfig`]; fails with [`shell::ShellError`].
//!
//! Architecture invariant: [`shell`] is the only part of this library that does IPC or
//! reads the clock; the core is handed time and operator input as values.
//!
//! Around it, not in it: the binary (`src/bin/planner`: flags, logging, signals, exit
//! codes), the live view (crate `view`) and the laboratory (crate `lab`: `solve`,
//! experiments, pictures). This library holds no command-line code.
#![warn(missing_docs)]
#![deny(unsafe_code)]

pub mod shell;

pub use planner_core::{
    AdaptiveAuthority, Algorithm, Authority, AuthorityState, CollisionChecker, Combine,
    ConfigSpace, Contact, EdgeCheck, Extend, ExtendA, HumanMode, IterReport, MachineSampler,
    PlanarSpace, Planner, PlannerError, PlannerParams, Sampling, SamplingError, Scene, SceneError,
    Se3, Se3Space, Source, Space, Stats, UserInput, Weights,
};
pub use planner_core::{
    aligned, authority, collision, guidance, params, path, portfolio, retraction, rrt, sampling,
    space, tree,
};
