//! Shared fixtures of the benchmarks (criterion benches in `benches/`, harness binaries in
//! `src/bin/`).

pub mod across;
pub mod contact_fixture;
pub mod edges;
mod error;
pub mod face_contact;
pub mod harness;
pub mod ipc;
pub mod mesh_checks;
pub mod pressing;
pub mod scaling;

pub use error::BenchError;
