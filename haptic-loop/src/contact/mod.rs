//! Contact rendering: voxmap-pointshell (McNeely, Puterbaugh, Troy 1999; distance layers and
//! pre-contact braking from their 2006 paper) with a 6-DOF virtual coupling.
//!
//! * [`Voxmap`]: the static scene as a sparse signed-distance field (scene frame).
//! * [`Pointshell`]: the moving object as surface points with inward normals (object frame).
//! * [`ContactStage`]: the dynamic proxy object. Once per tick it sums the scene's penalty
//!   wrench on the pointshell, adds the coupling spring-damper towards the device-mapped
//!   pose, and integrates one step. The device receives the negated coupling wrench.
//!
//! # Force model (written down because the papers leave a choice)
//!
//! *Tangent-plane model on the distance field.* For a point at signed distance s < 0 the
//! depth is d = −s and the force is `k_p·d` along the field's gradient n at the point, i.e.
//! along the outward normal of the obstacle surface nearest the point, which on a locally
//! flat surface is exactly the tangent-plane force of VPS 1999 (the stored distance *is* the
//! distance to the tangent plane). Using the scene's normal, not the point's, makes the
//! total force agree with the geometric contact normal also for corners and edges of the
//! object. The point's inward normal culls points on the side of the object turned away
//! from that surface (n_inward · n < −0.5, i.e. more than 120°), which happen only after
//! tunnelling through thin features and would pull the object further in; points at right
//! angles to the surface (an edge of the object against a face) are kept.
//!
//! Per-point stiffness `k_p` is not averaged over the number of contacts (VPS 1999 divides by
//! N/10 for stability): the proxy is integrated with linearly implicit (backward) Euler using
//! the 6×6 contact stiffness Σ k_p JᵀJ (J = [nᵀ, (r×n)ᵀ]), which is stable for any number of
//! contacts and dissipates energy instead of creating it. What the hand feels is bounded by
//! the coupling, whose gains come from the device's stable stiffness and damping.
//!
//! *Travel bound* (VPS 2006's speed limit): a point entering contact has no stiffness in
//! the implicit solve until the next search sees it, so while any point is within reach of
//! a surface no point of the proxy travels more than `max_travel_voxels` (half a voxel) per
//! step; a hand far ahead of a blocked object, or a light object tipping over an edge, then
//! cannot carry a face deep into the scene in one step. The velocities are scaled down, which
//! only removes energy.
//!
//! Contact damping along each normal, and the pre-contact braking of points approaching the
//! surface inside the proximity layer (weighted by 1 − s/proximity so it fades in), are each
//! a total damping shared among the points that produce it, so a face touching with 2000
//! points brakes like an edge touching with 20. Neither term ever pulls.
//!
//! # Frames
//!
//! Everything here is in the scene frame except pointshell data (object frame). The proxy's
//! pose is the pose of the object's reference point; its dynamics are about the centre of
//! mass (the volume centroid of the object's parts, uniform density). The coupling joins the
//! centre of mass of the device-mapped object to the proxy's.
//!
//! # Files, by idea
//!
//! `config` ([`ContactConfig`], its checks, the coupling's gains); `model` (what start-up
//! builds: open meshes as shells, the voxmap cache); `stage` ([`ContactStage`], whose
//! `step` is a list of stages: search, coupling, implicit Euler, travel bound, integration,
//! contact state with hysteresis, output); `coherence` (the search's motion budgets: free
//! motion costs O(1), contact O(points near the surface), whatever the triangle count);
//! `pointshell` (sampling, clusters with bounding spheres, groups, levels of detail at
//! about 2, 4, 8, 16 spacings); `level` (which level a tick renders within its point
//! budget, changing through a 20 ms blend); `mesh` (a repaired mesh as the voxmap build
//! walks it: triangles in Morton order, each vertex's 1-ring, angle-weighted
//! pseudo-normals); `voxmap` (8³-cell blocks, `i16` distances in 1/256 voxel, a Chebyshev
//! block-distance transform) with `build`, `band` (a mesh's narrow band from its surface,
//! slabs on every core), `cache` (on disk under a SHA-256 of the build's inputs), `query`
//! and `avx2`; `near` (near clusters, candidate points, eight look-ups at a time) with
//! `force` (the branch-free force pass in `f32`) and `avx2` (both with gathers, the same
//! bits as the portable lanes, chosen at run time); `lanes` and `jtj` (the 6×6 sums).
//! Imports flow one way: `lanes` ← `voxmap` ← `near` ← `stage`, with `pointshell` ←
//! `near`, and `coherence`, `level`, `config`, `model` ← `stage`.

mod coherence;
mod config;
mod error;
mod jtj;
mod lanes;
mod level;
mod mesh;
mod model;
mod near;
mod pointshell;
mod stage;
#[cfg(test)]
mod tests;
mod voxmap;

pub use config::{ContactConfig, Coupling};
pub use error::ContactError;
pub use level::Resolution;
pub use model::ContactModel;
pub use pointshell::{Cluster, LEVELS, Pointshell};
pub use scene::progress::Progress;
pub use stage::ContactStage;
pub use voxmap::cache as voxmap_cache;
pub use voxmap::{Obstacle, Sample, Surface, Voxmap, VoxmapConfig, VoxmapError, VoxmapReport};

use ipc_types::ContactCode;
use nalgebra::{Isometry3, Vector3};

/// The motion of the device-mapped object this tick (scene frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Anchor {
    /// Pose of the reference point.
    pub pose: Isometry3<f64>,
    /// Linear velocity of the reference point, m/s.
    pub linear_velocity: Vector3<f64>,
    /// Angular velocity, rad/s.
    pub angular_velocity: Vector3<f64>,
}

/// What one contact step produces (scene frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactOutput {
    /// Proxy pose (reference point) after the step.
    pub proxy: Isometry3<f64>,
    /// Wrench of the scene on the proxy: force (N) and torque about the reference point (N·m).
    pub contact_force_n: Vector3<f64>,
    /// See `contact_force_n`.
    pub contact_torque_nm: Vector3<f64>,
    /// Wrench for the device: the negated coupling wrench, torque about the device-mapped
    /// reference point.
    pub device_force_n: Vector3<f64>,
    /// See `device_force_n`.
    pub device_torque_nm: Vector3<f64>,
    /// Coupling force on the proxy: what the operator pushes with (f_u), N.
    pub operator_force_n: Vector3<f64>,
    /// FREE, PROXIMITY or CONTACT.
    pub code: ContactCode,
    /// Normal of the first contact, held while contact lasts; zero when not in contact.
    pub normal: Vector3<f64>,
    /// Depth-weighted mean of the penetrating points projected on the surface, m; held
    /// while contact lasts without penetration; zero when not in contact.
    pub point_m: Vector3<f64>,
    /// Deepest penetration this tick, m.
    pub penetration_m: f64,
    /// Points that penetrate.
    pub contacts: u32,
    /// Points tested against the voxmap (after cluster culling), over both levels while
    /// a change of level is blended, and those of a level being brought up to date for one.
    pub points_tested: u32,
    /// Level of detail rendered (0 = every point; the new level while blending).
    pub level: u8,
}

/// The scene's wrench on an object held still at a pose (see [`ContactStage::probe`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Probe {
    /// Force, N.
    pub force_n: Vector3<f64>,
    /// Torque about the reference point, N·m.
    pub torque_nm: Vector3<f64>,
    /// Deepest penetration, m.
    pub penetration_m: f64,
    /// Penetrating points.
    pub contacts: u32,
    /// Depth-weighted mean contact point on the surface, m.
    pub point_m: Vector3<f64>,
}
