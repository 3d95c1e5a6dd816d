//! The parry (`parry3d-f64`) shapes of scene parts: the one conversion from [`crate::Part`]
//! to parry, shared by the planner's collision checker and the haptic loop's voxmap and
//! pointshell. parry 0.31's math is glam-based (`Pose`, `Vector`, `Rot3`), not nalgebra.

use crate::pose::Se3;
use crate::{Part, Primitive};
use parry3d_f64::math::{Pose, Rot3, Vector};
use parry3d_f64::shape::{SharedShape, TriMeshFlags};

/// Converts a pose to parry's glam-based `Pose`.
pub fn to_parry(q: &Se3) -> Pose {
    let r = &q.rot;
    Pose::from_parts(
        Vector::new(q.pos.x, q.pos.y, q.pos.z),
        Rot3::from_xyzw(r.i, r.j, r.k, r.w),
    )
}

/// The parry shape of one part, in the part's local frame. Meshes become `TriMesh`es
/// with [`TriMeshFlags::ORIENTED`] (pseudo-normals, so point containment and signed
/// distances with `solid = false` work on closed, outward-wound meshes) and merged
/// duplicate vertices (STL repeats them per triangle).
pub fn part_shape(part: &Part) -> SharedShape {
    match &part.primitive {
        Primitive::Box { half_extents_m: h } => SharedShape::cuboid(h.x, h.y, h.z),
        Primitive::Sphere { radius_m } => SharedShape::ball(*radius_m),
        Primitive::Mesh { mesh } => {
            let vertices = mesh
                .vertices_m
                .iter()
                .map(|v| Vector::new(v.x, v.y, v.z))
                .collect();
            let flags = TriMeshFlags::ORIENTED | TriMeshFlags::MERGE_DUPLICATE_VERTICES;
            // The only builder error is an empty index list, which `MeshData` and
            // `Scene::validate` rule out; should one get here anyway, a bounding ball
            // keeps the conversion total.
            SharedShape::trimesh_with_flags(vertices, mesh.triangles.clone(), flags)
                .unwrap_or_else(|_| SharedShape::ball(mesh.reach_m(|v| *v).max(1e-6)))
        }
    }
}

/// Every part as (pose in the parent frame, shape): the one conversion from scene parts to
/// parry, shared by the collision checker and the haptic loop's voxmap and pointshell.
pub fn part_shapes(parts: &[Part]) -> Vec<(Pose, SharedShape)> {
    parts
        .iter()
        .map(|p| (to_parry(&p.pose), part_shape(p)))
        .collect()
}
