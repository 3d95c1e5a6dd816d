//! The planner's laboratory: runs outside a live session, against the wall clock, whose
//! results go to files. The papers' experiments (simulated operators in lockstep with the
//! planner, sweeps, CSV / markdown / PNG reports) and top-down pictures of a roadmap.
//!
//! It reads the clock and writes files, so it stays outside the pure core
//! (`planner-core`), which it drives through the same API as the live planner.
#![warn(missing_docs)]
#![deny(unsafe_code)]

pub mod experiment;
pub mod picture;

pub use experiment::report::register_font;
