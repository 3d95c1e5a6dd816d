//! The planner's laboratory: runs outside a live session, against the wall clock, whose
//! results go to files.
//!
//! Code map:
//! - [`solve`]: one automatic run against a time limit (`planner solve`): report, solution
//!   path files, a picture.
//! - [`experiment`]: the papers' experiments, a simulated operator ([`experiment::user`])
//!   in lockstep with the planner; [`experiment::sweep`] runs a whole sweep
//!   (`planner experiment`) and [`experiment::report`] summarises it (CSV, markdown, plots).
//! - [`live`]: live experiments' methods, run records and reports (the sessions
//!   themselves are started by `planner experiment live`).
//! - [`picture`]: top-down pictures of a roadmap, its solution and the operator's path.
//! - [`LabError`]: what failed, naming the scene or the file.
//!
//! API boundary: it reads the clock and writes files, so it stays outside the pure core
//! (`planner-core`), which it drives through the same `Planner` API as the live planner.
//! It knows nothing about IPC or the command line.
#![warn(missing_docs)]
#![deny(unsafe_code)]

pub mod error;
pub mod experiment;
pub mod live;
pub mod picture;
pub mod solve;

pub use error::LabError;
pub use experiment::report::register_font;
