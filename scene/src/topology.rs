//! What a mesh's triangles say about the surface they bound: whether it is closed, wound
//! consistently and outward, or open, double-sided or inconsistently wound, as CAD exports
//! often are.
//!
//! Triangle intersection tests (the planner's collision checks) work on any triangle soup;
//! point containment and signed distance (the haptic loop's voxmap, the pointshell's
//! inward normals) need a closed surface wound outward. Vertices are welded by exact
//! position first (STL repeats them per triangle), so that shared edges are recognised.

use crate::MeshData;
use crate::weld::{KeyMap, key_map, weld};
use std::fmt;

/// Edge and winding statistics of one mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Topology {
    /// Triangles.
    pub triangles: usize,
    /// Triangles with two equal (welded) corners or no area.
    pub degenerate: usize,
    /// Edges used by one triangle only: holes in the surface.
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub non_manifold_edges: usize,
    /// Edges two triangles traverse in the same direction: the winding flips between them.
    pub misoriented_edges: usize,
    /// Triangles that repeat another one's corners (either winding): a double-sided mesh
    /// has one for every triangle.
    pub duplicate_triangles: usize,
    /// Signed volume enclosed, m³ (positive for a closed, outward-wound surface; near zero
    /// for a double-sided one).
    pub signed_volume_m3: f64,
}

/// The verdict on a mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshKind {
    /// Closed, consistently and outward wound: containment and signed distances work.
    ClosedOutward,
    /// Closed and consistent but wound inward (normals point in): containment inverted.
    ClosedInward,
    /// Every triangle also present with the opposite winding: no inside or outside.
    DoubleSided,
    /// Closed, but the winding flips between neighbouring triangles.
    Inconsistent,
    /// Holes (boundary edges) or edges shared by more than two triangles.
    Open,
}

impl MeshKind {
    /// A short name, e.g. `open`.
    pub fn name(self) -> &'static str {
        match self {
            MeshKind::ClosedOutward => "closed, outward",
            MeshKind::ClosedInward => "closed but wound inward",
            MeshKind::DoubleSided => "double-sided",
            MeshKind::Inconsistent => "inconsistently wound",
            MeshKind::Open => "open",
        }
    }
}

/// How to repair a mesh that is not closed and outward, for messages.
pub const REPAIR_HINT: &str = "repair it so that it is closed and wound outward (delete \
duplicate or back faces, close holes, recalculate normals outside: e.g. MeshLab's \
'Cleaning and Repairing' filters, or Blender's Mesh > Clean Up and Normals > Recalculate \
Outside)";

impl Topology {
    /// The topology of `mesh`.
    pub fn of(mesh: &MeshData) -> Topology {
        // Weld by exact position (with -0.0 == 0.0).
        let ids = weld(&mesh.vertices_m);
        let mut degenerate = 0;
        let mut volume6 = 0.0;
        // Directed edge (a, b) → times used; unordered triangle corners → times seen.
        let n = mesh.triangles.len();
        let mut directed: KeyMap<(u32, u32), u32> = key_map(3 * n);
        let mut faces: KeyMap<[u32; 3], u32> = key_map(n);
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| ids[i as usize]);
            let [pa, pb, pc] = t.map(|i| mesh.vertices_m[i as usize]);
            let cross = (pb - pa).cross(&(pc - pa));
            if a == b || b == c || a == c || cross.norm() == 0.0 {
                degenerate += 1;
                continue;
            }
            volume6 += pa.dot(&(pb.cross(&pc)));
            for e in [(a, b), (b, c), (c, a)] {
                *directed.entry(e).or_insert(0) += 1;
            }
            let mut corners = [a, b, c];
            corners.sort_unstable();
            *faces.entry(corners).or_insert(0) += 1;
        }
        let mut undirected: KeyMap<(u32, u32), (u32, u32)> = key_map(directed.len());
        for (&(a, b), &n) in &directed {
            let (lo, hi, forward) = if a < b { (a, b, true) } else { (b, a, false) };
            let e = undirected.entry((lo, hi)).or_insert((0, 0));
            if forward {
                e.0 += n;
            } else {
                e.1 += n;
            }
        }
        let (mut boundary_edges, mut non_manifold_edges, mut misoriented_edges) = (0, 0, 0);
        for &(forward, backward) in undirected.values() {
            match forward + backward {
                1 => boundary_edges += 1,
                2 if forward != 1 => misoriented_edges += 1,
                2 => {}
                _ => non_manifold_edges += 1,
            }
        }
        Topology {
            triangles: mesh.triangles.len(),
            degenerate,
            boundary_edges,
            non_manifold_edges,
            misoriented_edges,
            duplicate_triangles: faces.values().map(|&n| n as usize - 1).sum(),
            signed_volume_m3: volume6 / 6.0,
        }
    }

    /// The verdict: double-sided first (its edges also look non-manifold), then open, then
    /// winding.
    pub fn kind(&self) -> MeshKind {
        let faces = self.triangles - self.degenerate;
        if self.duplicate_triangles > 0 && 2 * self.duplicate_triangles >= faces {
            MeshKind::DoubleSided
        } else if self.boundary_edges > 0
            || self.non_manifold_edges > 0
            || self.duplicate_triangles > 0
        {
            MeshKind::Open
        } else if self.misoriented_edges > 0 {
            MeshKind::Inconsistent
        } else if self.signed_volume_m3 > 0.0 {
            MeshKind::ClosedOutward
        } else {
            MeshKind::ClosedInward
        }
    }

    /// Whether point containment and signed distances are right for this mesh.
    pub fn is_closed_outward(&self) -> bool {
        self.kind() == MeshKind::ClosedOutward
    }
}

impl fmt::Display for Topology {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: {} triangles, {} boundary edges, {} non-manifold edges, {} misoriented edges, {} duplicate triangles, {} degenerate, signed volume {:.3e} m³",
            self.kind().name(),
            self.triangles,
            self.boundary_edges,
            self.non_manifold_edges,
            self.misoriented_edges,
            self.duplicate_triangles,
            self.degenerate,
            self.signed_volume_m3
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> MeshData {
        MeshData::cuboid("cube", [0.1, 0.2, 0.3])
    }

    fn with_triangles(m: &MeshData, triangles: Vec<[u32; 3]>) -> MeshData {
        MeshData::new("test", m.vertices_m.clone(), triangles).expect("valid")
    }

    #[test]
    fn a_closed_outward_box_is_recognised_with_its_volume() {
        let t = Topology::of(&cube());
        assert_eq!(t.kind(), MeshKind::ClosedOutward, "{t}");
        assert!((t.signed_volume_m3 - 0.2 * 0.4 * 0.6).abs() < 1e-12, "{t}");
        assert_eq!(
            (t.boundary_edges, t.misoriented_edges, t.duplicate_triangles),
            (0, 0, 0)
        );
    }

    #[test]
    fn open_double_sided_flipped_and_inconsistent_meshes_are_told_apart() {
        let c = cube();
        // Open: the +z face (two triangles) removed leaves a square hole of 4 edges.
        let open = with_triangles(&c, c.triangles[..10].to_vec());
        let t = Topology::of(&open);
        assert_eq!((t.kind(), t.boundary_edges), (MeshKind::Open, 4), "{t}");
        // Double-sided: every triangle again with the opposite winding.
        let mut both = c.triangles.clone();
        both.extend(c.triangles.iter().map(|&[a, b, c]| [a, c, b]));
        let t = Topology::of(&with_triangles(&c, both));
        assert_eq!(t.kind(), MeshKind::DoubleSided, "{t}");
        assert!(t.signed_volume_m3.abs() < 1e-12);
        // Flipped: closed and consistent, negative volume.
        let flipped: Vec<_> = c.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect();
        let t = Topology::of(&with_triangles(&c, flipped));
        assert_eq!(t.kind(), MeshKind::ClosedInward, "{t}");
        // Inconsistent: one triangle flipped: its 3 edges are traversed twice one way.
        let mut one = c.triangles.clone();
        one[0] = [one[0][0], one[0][2], one[0][1]];
        let t = Topology::of(&with_triangles(&c, one));
        assert_eq!(
            (t.kind(), t.misoriented_edges),
            (MeshKind::Inconsistent, 3),
            "{t}"
        );
    }

    #[test]
    fn stl_style_repeated_vertices_are_welded() {
        // Every triangle with vertices of its own, as STL stores them.
        let c = cube();
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        for t in &c.triangles {
            let base = vertices.len() as u32;
            vertices.extend(t.iter().map(|&i| c.vertices_m[i as usize]));
            triangles.push([base, base + 1, base + 2]);
        }
        let soup = MeshData::new("soup", vertices, triangles).expect("valid");
        assert_eq!(Topology::of(&soup).kind(), MeshKind::ClosedOutward);
    }
}
