//! Repairing meshes as CAD tools export them, so that contact rendering can tell inside
//! from outside wherever the triangles allow it.
//!
//! Exports are often double-sided (every triangle also with the opposite winding), wound
//! inconsistently or inward, open (panels, sheet metal), or soups with a vertex per
//! triangle corner (STL). [`repair`] welds vertices by exact position (as
//! [`Topology::of`](crate::topology::Topology::of) does), drops degenerate triangles, exact
//! duplicates and reversed twins (keeping the first of each), winds every component
//! (triangles connected through edges shared by exactly two of them) consistently by a
//! breadth-first walk over those edges, then turns each closed component outward:
//!
//! - **Nested shells**: a closed shell inside `k` other closed shells (the winding number
//!   of each about points of it) faces outward when `k` is even and inward when `k` is
//!   odd. A solid's skin faces out, a cavity's skin faces into the cavity (away from the
//!   material), a solid inside that cavity faces out again; a hollow solid's signed volume
//!   is then the outer shell's minus the cavity's. Shells that cross each other (parts of
//!   an assembly run into one another) are not inside one another: each faces out.
//! - **Open components** (with boundary edges) have no inside: they keep the winding most
//!   of their triangles had. Contact renders an open mesh as a thin shell, which needs no
//!   side; so edges on more than two triangles (walls meeting a panel, as in OMPL.app's
//!   Twistycool) do not stop an open mesh, they only end its components.
//! - **No inside, but a surface**: a mesh without boundary edges whose inside cannot be
//!   told (edges on more than two triangles once twins are dropped, as SolidWorks and
//!   MeshLab exports often have where two bodies meet along an edge; closed shells whose
//!   winding cannot be made consistent, a Möbius-like twist; closed shells that enclose no
//!   volume) is repaired as an open one and rendered as a thin shell, the report naming
//!   why and an example edge ([`RepairReport::no_inside`]).
//! - **Refused**: only what has no surface: no triangle with an area, non-finite vertices,
//!   indices out of range.
//!
//! Triangles keep their order and their first corner (a flip swaps the other two); a mesh
//! with nothing to repair comes back as it was, so planning on it is unchanged.
//!
//! Cost: expected O(n) in triangles (hash maps keyed by welded vertices), plus, for K
//! closed shells, K² bounding-box tests and one winding-number pass over a shell per other
//! shell whose sample point lies in its box (nested or interleaved shells only).

use crate::MeshData;
use crate::topology::MeshKind;
use crate::weld::{KeyMap, key_map, weld};
use nalgebra::Vector3;
use std::collections::hash_map::Entry;
use std::fmt;

/// What a mesh's triangles bound, and so how contact can render it.
#[derive(Debug, Clone, PartialEq)]
pub enum Surface {
    /// Closed, consistently wound, outward (cavities inward): containment and signed
    /// distances are right.
    ClosedOutward,
    /// No inside: boundary edges (holes, sheets, panels), or a closed surface whose inside
    /// cannot be told ([`RepairReport::no_inside`] says why). Contact renders it as a thin
    /// shell; its triangles are wound consistently where their component allows it.
    Open,
    /// No surface to render (no triangle with an area, invalid data), or a mesh never
    /// repaired that is not closed and outward: contact refuses it; planning still works
    /// on its triangles.
    Refused(Refusal),
}

impl Surface {
    /// What contact can make of a mesh that never went through [`repair`], from its
    /// topology alone: closed and outward, open when it has holes (a thin shell needs
    /// nothing more), else refused as not repaired.
    pub fn judged(t: &crate::topology::Topology) -> Surface {
        use crate::topology::MeshKind;
        match t.kind() {
            MeshKind::ClosedOutward => Surface::ClosedOutward,
            MeshKind::Open if t.boundary_edges > 0 => Surface::Open,
            kind => Surface::Refused(Refusal::NotRepaired { kind }),
        }
    }

    /// Whether contact refuses it.
    pub fn is_refused(&self) -> bool {
        matches!(self, Surface::Refused(_))
    }
}

/// Why a mesh is refused, or why a closed one has no inside. `Display` gives the reason
/// for a message.
#[derive(Debug, Clone, PartialEq)]
pub enum Refusal {
    /// A mesh without boundary edges with edges used by more than two triangles once
    /// twins and duplicates are gone: which side is inside cannot be told.
    NonManifold {
        /// How many such edges.
        edges: usize,
        /// The first one's ends (m, part frame).
        example_m: [Vector3<f64>; 2],
    },
    /// A closed shell whose winding cannot be made consistent: going round it turns it
    /// over (a Möbius-like twist, as in a Klein bottle).
    NonOrientable {
        /// Edges where neighbouring triangles disagree however they are wound.
        edges: usize,
        /// The first one's ends (m, part frame).
        example_m: [Vector3<f64>; 2],
    },
    /// Closed shells that enclose no volume (faces lying on each other).
    Flat {
        /// How many such shells.
        shells: usize,
    },
    /// Every triangle is degenerate.
    NoArea,
    /// Indices out of range or non-finite vertices (a mesh built without
    /// [`MeshData::new`]).
    Invalid {
        /// What is wrong.
        reason: String,
    },
    /// A mesh built in code that never went through [`repair`], judged from its
    /// [`Topology`](crate::topology::Topology).
    NotRepaired {
        /// What its topology says.
        kind: MeshKind,
    },
}

/// What [`repair`] found and did. `Display` is one line for a log, e.g. "mesh 'alpha.obj':
/// double-sided: dropped 2016 reversed twins; closed, outward (1 component)".
#[derive(Debug, Clone, PartialEq)]
pub struct RepairReport {
    /// The mesh's source (its file).
    pub source: String,
    /// What the repaired triangles bound. Refused meshes are left as they were.
    pub surface: Surface,
    /// Triangles before.
    pub triangles_in: usize,
    /// Triangles after (as before when refused).
    pub triangles_out: usize,
    /// Triangles dropped because two corners weld together or they have no area.
    pub degenerate: usize,
    /// Triangles dropped because they repeat another with the same winding.
    pub duplicates: usize,
    /// Triangles dropped because they repeat another with the opposite winding.
    pub twins: usize,
    /// Kept triangles whose winding was reversed.
    pub flipped: usize,
    /// Components: triangles connected through edges shared by exactly two triangles.
    pub components: usize,
    /// Components without boundary edges.
    pub closed_components: usize,
    /// Closed shells inside an odd number of others, wound inward (cavities).
    pub cavities: usize,
    /// Closed shells turned inside out (most of their triangles faced the wrong way).
    pub inverted_components: usize,
    /// Edges used by one triangle only.
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub non_manifold_edges: usize,
    /// Edges of open components where the winding cannot be consistent (a Möbius strip);
    /// harmless for a thin shell.
    pub unorientable_edges: usize,
    /// Why a mesh without boundary edges has no inside (so is [`Surface::Open`], a thin
    /// shell), with an example edge.
    pub no_inside: Option<Refusal>,
}

impl RepairReport {
    /// Whether the repaired triangles differ from the mesh's (never for a refused mesh).
    pub fn changed(&self) -> bool {
        !self.surface.is_refused() && (self.triangles_out != self.triangles_in || self.flipped > 0)
    }

    /// Whether at least half of the mesh's triangles were reversed twins of the others.
    pub fn double_sided(&self) -> bool {
        self.twins > 0 && 2 * self.twins >= self.triangles_in - self.degenerate
    }

    fn unrepaired(mesh: &MeshData, surface: Surface) -> Self {
        RepairReport {
            source: mesh.source.clone(),
            surface,
            triangles_in: mesh.triangles.len(),
            triangles_out: mesh.triangles.len(),
            degenerate: 0,
            duplicates: 0,
            twins: 0,
            flipped: 0,
            components: 0,
            closed_components: 0,
            cavities: 0,
            inverted_components: 0,
            boundary_edges: 0,
            non_manifold_edges: 0,
            unorientable_edges: 0,
            no_inside: None,
        }
    }
}

/// A repaired mesh and what was done to it.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshRepair {
    /// The repaired mesh: kept triangles in their original order, each flipped one with
    /// its first corner kept, unused vertices dropped (the others keep their positions
    /// and order). The input as it was when refused or when nothing needed repair.
    pub mesh: MeshData,
    /// What was found and done.
    pub report: RepairReport,
}

impl MeshRepair {
    /// The repaired mesh carrying its report ([`MeshData::repair`]).
    pub fn into_mesh(self) -> MeshData {
        MeshData {
            repair: Some(Box::new(self.report)),
            ..self.mesh
        }
    }
}

/// No triangle, half-edge or component.
const NONE: u32 = u32::MAX;

/// Why `mesh` cannot even be looked at, if it cannot.
fn invalid(mesh: &MeshData) -> Option<String> {
    let n = mesh.vertices_m.len();
    // Half-edges are numbered 3·triangle + corner in a u32.
    if mesh.triangles.len() >= (NONE / 3) as usize || n >= NONE as usize {
        return Some(format!(
            "{} triangles and {n} vertices: more than this repair counts",
            mesh.triangles.len()
        ));
    }
    if let Some(i) = mesh
        .vertices_m
        .iter()
        .position(|v| !v.iter().all(|c| c.is_finite()))
    {
        return Some(format!("vertex {i} is not finite"));
    }
    if let Some(t) = mesh
        .triangles
        .iter()
        .position(|t| t.iter().any(|&i| i as usize >= n))
    {
        return Some(format!(
            "triangle {t} indexes a vertex beyond the {n} vertices"
        ));
    }
    None
}

/// The triangles worth keeping.
struct Kept {
    /// Index in the mesh of each kept triangle, increasing.
    index: Vec<u32>,
    /// Its corners as welded vertex ids.
    corners: Vec<[u32; 3]>,
    degenerate: usize,
    duplicates: usize,
    twins: usize,
}

impl Kept {
    fn select(mesh: &MeshData, welded: &[u32]) -> Kept {
        let n = mesh.triangles.len();
        let mut kept = Kept {
            index: Vec::with_capacity(n),
            corners: Vec::with_capacity(n),
            degenerate: 0,
            duplicates: 0,
            twins: 0,
        };
        // Sorted corners → whether the first triangle on them ran in sorted order's
        // rotation (even) or against it.
        let mut faces: KeyMap<[u32; 3], bool> = key_map(n);
        for (i, t) in mesh.triangles.iter().enumerate() {
            let w = t.map(|k| welded[k as usize]);
            let [pa, pb, pc] = t.map(|k| mesh.vertices_m[k as usize]);
            if w[0] == w[1]
                || w[1] == w[2]
                || w[0] == w[2]
                || (pb - pa).cross(&(pc - pa)) == Vector3::zeros()
            {
                kept.degenerate += 1;
                continue;
            }
            // Rotate the smallest corner first: the rest's order tells the winding.
            let r = (0..3).min_by_key(|&k| w[k]).unwrap_or(0);
            let (a, b, c) = (w[r], w[(r + 1) % 3], w[(r + 2) % 3]);
            let even = b < c;
            let key = if even { [a, b, c] } else { [a, c, b] };
            match faces.entry(key) {
                Entry::Occupied(e) => {
                    if *e.get() == even {
                        kept.duplicates += 1;
                    } else {
                        kept.twins += 1;
                    }
                }
                Entry::Vacant(e) => {
                    e.insert(even);
                    kept.index.push(i as u32);
                    kept.corners.push(w);
                }
            }
        }
        kept
    }
}

/// Half-edge `h` (3·triangle + corner) runs from corner `h % 3` to the next one. `mate[h]`
/// is the other half-edge on the same edge when exactly two triangles use it.
struct Edges {
    mate: Vec<u32>,
    boundary: usize,
    non_manifold: usize,
    /// The first half-edge (in order) found on a third triangle's edge.
    non_manifold_example: u32,
}

impl Edges {
    fn link(corners: &[[u32; 3]]) -> Edges {
        let halves = 3 * corners.len();
        let mut mate = vec![NONE; halves];
        // Undirected edge → (first half-edge, second half-edge, uses).
        let mut edges: KeyMap<u64, (u32, u32, u32)> = key_map(halves / 2 + 16);
        let mut non_manifold = 0;
        let mut non_manifold_example = NONE;
        for h in 0..halves {
            let (t, k) = (h / 3, h % 3);
            let (a, b) = (corners[t][k], corners[t][(k + 1) % 3]);
            let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
            match edges.entry(key) {
                Entry::Vacant(e) => {
                    e.insert((h as u32, NONE, 1));
                }
                Entry::Occupied(mut e) => {
                    let v = e.get_mut();
                    v.2 += 1;
                    if v.2 == 2 {
                        v.1 = h as u32;
                        mate[v.0 as usize] = h as u32;
                        mate[h] = v.0;
                    } else if v.2 == 3 {
                        // Which two of three belong together cannot be told: link none.
                        mate[v.0 as usize] = NONE;
                        mate[v.1 as usize] = NONE;
                        non_manifold += 1;
                        if non_manifold_example == NONE {
                            non_manifold_example = h as u32;
                        }
                    }
                }
            }
        }
        let boundary = edges.values().filter(|v| v.2 == 1).count();
        Edges {
            mate,
            boundary,
            non_manifold,
            non_manifold_example,
        }
    }
}

/// One component: triangles connected through manifold edges.
struct Component {
    /// Its first triangle (kept index).
    first: u32,
    triangles: usize,
    /// Has a half-edge with no mate.
    open: bool,
    /// Edges whose two triangles disagree however the walk winds them.
    conflicts: usize,
    conflict_example: u32,
    /// Triangles the walk reversed.
    flipped: usize,
    /// Six times the signed volume as the walk wound it, m³, about the mesh's centre.
    volume6: f64,
    /// Its box, m, about the mesh's centre.
    lo: Vector3<f64>,
    hi: Vector3<f64>,
    /// Its corners on the box's faces (lowest x, highest x, lowest y, ...), m, about the
    /// mesh's centre: points that leave another shell if any do, in practice.
    extremes: [Vector3<f64>; 6],
    /// Turn the whole component over after the walk.
    invert: bool,
}

/// Winds each component consistently by a breadth-first walk from its first triangle:
/// returns the component of every kept triangle, whether the walk reversed it, and the
/// components.
fn orient(corners: &[[u32; 3]], mate: &[u32]) -> (Vec<u32>, Vec<bool>, Vec<Component>) {
    let m = corners.len();
    let mut comp = vec![NONE; m];
    let mut flip = vec![false; m];
    let mut components = Vec::new();
    let mut queue: Vec<u32> = Vec::with_capacity(m);
    for seed in 0..m {
        if comp[seed] != NONE {
            continue;
        }
        let c = components.len() as u32;
        let mut k = Component {
            first: seed as u32,
            triangles: 0,
            open: false,
            conflicts: 0,
            conflict_example: NONE,
            flipped: 0,
            volume6: 0.0,
            lo: Vector3::repeat(f64::INFINITY),
            hi: Vector3::repeat(f64::NEG_INFINITY),
            extremes: [Vector3::zeros(); 6],
            invert: false,
        };
        comp[seed] = c;
        queue.clear();
        queue.push(seed as u32);
        let mut head = 0;
        while let Some(&t) = queue.get(head) {
            head += 1;
            let t = t as usize;
            for corner in 0..3 {
                let h = 3 * t + corner;
                let o = mate[h];
                if o == NONE {
                    k.open = true;
                    continue;
                }
                let (u, uc) = (o as usize / 3, o as usize % 3);
                // Neighbours agree when they run along their edge in opposite directions.
                let same_direction = corners[t][corner] == corners[u][uc];
                let want = flip[t] ^ same_direction;
                if comp[u] == NONE {
                    comp[u] = c;
                    flip[u] = want;
                    queue.push(u as u32);
                } else if flip[u] != want && (h as u32) < o {
                    // Both sides see the disagreement: count it from the lower half-edge.
                    if k.conflicts == 0 {
                        k.conflict_example = h as u32;
                    }
                    k.conflicts += 1;
                }
            }
        }
        components.push(k);
    }
    (comp, flip, components)
}

/// Solid angle of triangle `abc` seen from the origin, signed by its winding (Van
/// Oosterom and Strackee, 1983), sr.
fn solid_angle(a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>) -> f64 {
    let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
    let num = a.dot(&b.cross(&c));
    let den = la * lb * lc + a.dot(&b) * lc + a.dot(&c) * lb + b.dot(&c) * la;
    2.0 * num.atan2(den)
}

/// Repairs `mesh` (see the module docs). Never panics; a mesh whose inside cannot be told
/// comes back unchanged with [`Surface::Refused`].
pub fn repair(mesh: &MeshData) -> MeshRepair {
    let refuse = |refusal: Refusal| MeshRepair {
        mesh: mesh.clone(),
        report: RepairReport::unrepaired(mesh, Surface::Refused(refusal)),
    };
    if let Some(reason) = invalid(mesh) {
        return refuse(Refusal::Invalid { reason });
    }
    let welded = weld(&mesh.vertices_m);
    let kept = Kept::select(mesh, &welded);
    if kept.index.is_empty() {
        return refuse(Refusal::NoArea);
    }
    let edges = Edges::link(&kept.corners);
    let (comp, mut flip, mut components) = orient(&kept.corners, &edges.mate);

    let corner_m =
        |j: usize, k: usize| mesh.vertices_m[mesh.triangles[kept.index[j] as usize][k] as usize];
    let (lo, hi) = crate::bounding_box(&mesh.vertices_m);
    // Volumes about the centre: far from the origin, products of coordinates would lose
    // the digits the sum needs.
    let centre = 0.5 * (lo + hi);
    for (j, &c) in comp.iter().enumerate() {
        let k = &mut components[c as usize];
        let [a, b, c] = [0, 1, 2].map(|i| corner_m(j, i) - centre);
        let v6 = a.dot(&b.cross(&c));
        k.volume6 += if flip[j] { -v6 } else { v6 };
        k.flipped += usize::from(flip[j]);
        k.triangles += 1;
        for p in [a, b, c] {
            for i in 0..3 {
                if p[i] < k.lo[i] {
                    (k.lo[i], k.extremes[2 * i]) = (p[i], p);
                }
                if p[i] > k.hi[i] {
                    (k.hi[i], k.extremes[2 * i + 1]) = (p[i], p);
                }
            }
        }
    }

    let example = |h: u32| {
        let (j, k) = (h as usize / 3, h as usize % 3);
        [corner_m(j, k), corner_m(j, (k + 1) % 3)]
    };
    // A surface whose inside cannot be told is still a surface: its components ending at
    // edges on more than two triangles are open already, and twisted or flat shells are
    // made open here, so the mesh is rendered as a thin shell, the report saying why.
    let mut no_inside = None;
    if edges.non_manifold > 0 && edges.boundary == 0 {
        no_inside = Some(Refusal::NonManifold {
            edges: edges.non_manifold,
            example_m: example(edges.non_manifold_example),
        });
    }
    let twisted: Vec<usize> = (0..components.len())
        .filter(|&c| !components[c].open && components[c].conflicts > 0)
        .collect();
    if let Some(&first) = twisted.first() {
        no_inside.get_or_insert(Refusal::NonOrientable {
            edges: twisted.iter().map(|&c| components[c].conflicts).sum(),
            example_m: example(components[first].conflict_example),
        });
    }
    let flat: Vec<usize> = (0..components.len())
        .filter(|&c| {
            let k = &components[c];
            !k.open && k.volume6.abs() <= 1e-12 * (k.hi - k.lo).norm().powi(3)
        })
        .collect();
    if !flat.is_empty() {
        no_inside.get_or_insert(Refusal::Flat { shells: flat.len() });
    }
    for &c in twisted.iter().chain(&flat) {
        components[c].open = true;
    }

    let closed: Vec<usize> = (0..components.len())
        .filter(|&c| !components[c].open)
        .collect();
    let depths = nesting(&closed, &components, &comp, &flip, |j, i| {
        corner_m(j, i) - centre
    });
    let (mut cavities, mut inverted) = (0, 0);
    for (&c, depth) in closed.iter().zip(depths) {
        let k = &mut components[c];
        let outward = depth % 2 == 0;
        k.invert = (k.volume6 > 0.0) != outward;
        cavities += usize::from(!outward);
        let flipped = if k.invert {
            k.triangles - k.flipped
        } else {
            k.flipped
        };
        inverted += usize::from(2 * flipped > k.triangles);
    }
    for k in components.iter_mut().filter(|k| k.open) {
        // No inside: keep the winding most triangles had.
        k.invert = 2 * k.flipped > k.triangles;
    }

    for (j, &c) in comp.iter().enumerate() {
        flip[j] ^= components[c as usize].invert;
    }
    let flipped = flip.iter().filter(|&&f| f).count();
    let report = RepairReport {
        source: mesh.source.clone(),
        surface: if components.iter().any(|k| k.open) {
            Surface::Open
        } else {
            Surface::ClosedOutward
        },
        triangles_in: mesh.triangles.len(),
        triangles_out: kept.index.len(),
        degenerate: kept.degenerate,
        duplicates: kept.duplicates,
        twins: kept.twins,
        flipped,
        components: components.len(),
        closed_components: components.iter().filter(|k| !k.open).count(),
        cavities,
        inverted_components: inverted,
        boundary_edges: edges.boundary,
        non_manifold_edges: edges.non_manifold,
        unorientable_edges: components
            .iter()
            .filter(|k| k.open)
            .map(|k| k.conflicts)
            .sum(),
        no_inside,
    };
    if !report.changed() {
        return MeshRepair {
            mesh: mesh.clone(),
            report,
        };
    }
    MeshRepair {
        mesh: rebuild(mesh, &kept.index, &flip),
        report,
    }
}

/// How many other closed shells contain each of `closed`: those whose box holds its box
/// and whose winding number is ±1 about its first triangle's centroid and its corners on
/// its box's faces. Shells that cross each other (parts of an assembly run into one
/// another) contain none of those points wholly, and so are each wound outward.
/// `corner(j, i)`: corner `i` of kept triangle `j`, m, about the mesh's centre.
fn nesting(
    closed: &[usize],
    components: &[Component],
    comp: &[u32],
    flip: &[bool],
    corner: impl Fn(usize, usize) -> Vector3<f64>,
) -> Vec<usize> {
    let mut depths = vec![0; closed.len()];
    if closed.len() < 2 {
        return depths;
    }
    // Kept triangles grouped by component (a counting sort), for the winding sums.
    let mut start = vec![0usize; components.len() + 1];
    for &c in comp {
        start[c as usize + 1] += 1;
    }
    for c in 0..components.len() {
        start[c + 1] += start[c];
    }
    let mut next = start.clone();
    let mut by_component = vec![0u32; comp.len()];
    for (j, &c) in comp.iter().enumerate() {
        by_component[next[c as usize]] = j as u32;
        next[c as usize] += 1;
    }
    let winding = |d: usize, p: &Vector3<f64>| {
        let mut omega = 0.0;
        for &j in &by_component[start[d]..start[d + 1]] {
            let j = j as usize;
            let [a, b, e] = [0, 1, 2].map(|i| corner(j, i) - p);
            let w = solid_angle(a, b, e);
            omega += if flip[j] { -w } else { w };
        }
        omega / (4.0 * std::f64::consts::PI)
    };
    for (depth, &c) in depths.iter_mut().zip(closed) {
        let k = &components[c];
        let f = k.first as usize;
        let centroid = (corner(f, 0) + corner(f, 1) + corner(f, 2)) / 3.0;
        for &d in closed {
            let outer = &components[d];
            let in_box = (0..3).all(|i| k.lo[i] >= outer.lo[i] && k.hi[i] <= outer.hi[i]);
            if d == c || !in_box {
                continue;
            }
            // ±1 inside (either winding), 0 outside.
            let inside = |p: &Vector3<f64>| winding(d, p).abs() > 0.5;
            *depth += usize::from(inside(&centroid) && k.extremes.iter().all(inside));
        }
    }
    depths
}

/// `mesh` with only the `kept` triangles, those marked in `flip` reversed (first corner
/// kept), and only the vertices they use, in their original order.
fn rebuild(mesh: &MeshData, kept: &[u32], flip: &[bool]) -> MeshData {
    let mut new_index = vec![NONE; mesh.vertices_m.len()];
    for &i in kept {
        for &v in &mesh.triangles[i as usize] {
            new_index[v as usize] = 0;
        }
    }
    let mut vertices_m = Vec::new();
    for (old, slot) in new_index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = vertices_m.len() as u32;
            vertices_m.push(mesh.vertices_m[old]);
        }
    }
    let triangles = kept
        .iter()
        .zip(flip)
        .map(|(&i, &f)| {
            let [a, b, c] = mesh.triangles[i as usize].map(|v| new_index[v as usize]);
            if f { [a, c, b] } else { [a, b, c] }
        })
        .collect();
    MeshData {
        source: mesh.source.clone(),
        vertices_m,
        triangles,
        repair: None,
    }
}

fn plural(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

fn edge(e: &[Vector3<f64>; 2]) -> String {
    // To single precision, as mesh files give them: 0.1 rather than 0.10000000149011612.
    let p = |v: &Vector3<f64>| format!("({}, {}, {})", v.x as f32, v.y as f32, v.z as f32);
    format!("{}–{} m", p(&e[0]), p(&e[1]))
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::NonManifold { edges, example_m } => write!(
                f,
                "{} shared by more than two triangles (after dropping reversed twins and \
                 duplicates) in a mesh without holes, e.g. {}: which side is inside cannot \
                 be told",
                plural(*edges, "edge", "edges"),
                edge(example_m)
            ),
            Refusal::NonOrientable { edges, example_m } => write!(
                f,
                "a closed shell cannot be wound consistently (a Möbius-like twist): {} \
                 where neighbours disagree however they are wound, e.g. {}",
                plural(*edges, "edge", "edges"),
                edge(example_m)
            ),
            Refusal::Flat { shells } => write!(
                f,
                "{} enclose no volume (faces lying on each other)",
                plural(*shells, "closed shell", "closed shells")
            ),
            Refusal::NoArea => write!(f, "no triangle has an area"),
            Refusal::Invalid { reason } => write!(f, "invalid mesh: {reason}"),
            Refusal::NotRepaired { kind } => write!(
                f,
                "{}, and not repaired (scene files' meshes are repaired on load; \
                 `Scene::repair_meshes` repairs a scene built in code)",
                kind.name()
            ),
        }
    }
}

impl fmt::Display for RepairReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "mesh '{}': ", self.source)?;
        if let Surface::Refused(why) = &self.surface {
            return write!(f, "refused, left as loaded: {why}");
        }
        let mut done = Vec::new();
        if self.twins > 0 {
            let prefix = if self.double_sided() {
                "double-sided: "
            } else {
                ""
            };
            done.push(format!(
                "{prefix}dropped {}",
                plural(self.twins, "reversed twin", "reversed twins")
            ));
        }
        if self.duplicates > 0 {
            done.push(format!(
                "dropped {}",
                plural(self.duplicates, "duplicate triangle", "duplicate triangles")
            ));
        }
        if self.degenerate > 0 {
            done.push(format!(
                "dropped {}",
                plural(
                    self.degenerate,
                    "degenerate triangle",
                    "degenerate triangles"
                )
            ));
        }
        if self.flipped > 0 {
            let mut s = format!(
                "flipped {} of {} triangles",
                self.flipped, self.triangles_out
            );
            if self.inverted_components > 0 {
                s += &format!(
                    " ({} turned outward)",
                    plural(self.inverted_components, "shell", "shells")
                );
            }
            done.push(s);
        }
        if !done.is_empty() {
            write!(f, "{}; ", done.join(", "))?;
        }
        let components = plural(self.components, "component", "components");
        match self.surface {
            Surface::Open => {
                write!(
                    f,
                    "open: {} ({components}, {} closed)",
                    plural(self.boundary_edges, "boundary edge", "boundary edges"),
                    self.closed_components
                )?;
                if self.non_manifold_edges > 0 {
                    write!(
                        f,
                        ", {} on more than two triangles",
                        plural(self.non_manifold_edges, "edge", "edges")
                    )?;
                }
                if self.unorientable_edges > 0 {
                    write!(
                        f,
                        ", {} cannot be wound consistently",
                        plural(self.unorientable_edges, "edge", "edges")
                    )?;
                }
                if let Some(why) = &self.no_inside {
                    write!(f, "; no inside: {why}")?;
                }
                write!(f, "; contact renders it as a thin shell")
            }
            _ => {
                write!(f, "closed, outward ({components}")?;
                if self.cavities > 0 {
                    write!(
                        f,
                        ", {} wound inward",
                        plural(self.cavities, "cavity", "cavities")
                    )?;
                }
                write!(f, ")")?;
                if done.is_empty() {
                    write!(f, ", unchanged")?;
                }
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::Topology;

    /// A 0.2 × 0.4 × 0.6 m box, closed and outward: 0.048 m³.
    fn cube() -> MeshData {
        MeshData::cuboid("cube", [0.1, 0.2, 0.3])
    }

    fn with(m: &MeshData, triangles: Vec<[u32; 3]>) -> MeshData {
        MeshData::new("test", m.vertices_m.clone(), triangles).expect("valid")
    }

    fn reversed([a, b, c]: [u32; 3]) -> [u32; 3] {
        [a, c, b]
    }

    fn volume(m: &MeshData) -> f64 {
        Topology::of(m).signed_volume_m3
    }

    /// `m`'s triangles then another mesh's, its vertices renumbered after `m`'s.
    fn merged(m: &MeshData, other: &MeshData) -> MeshData {
        let base = m.vertices_m.len() as u32;
        let mut vertices = m.vertices_m.clone();
        vertices.extend(&other.vertices_m);
        let mut triangles = m.triangles.clone();
        triangles.extend(other.triangles.iter().map(|t| t.map(|i| i + base)));
        MeshData::new("merged", vertices, triangles).expect("valid")
    }

    #[test]
    fn a_double_sided_closed_cube_keeps_one_of_each_twin_wound_outward() {
        let c = cube();
        // The reversed twins first: the triangles kept face inward and must be turned.
        let mut both: Vec<_> = c.triangles.iter().map(|&t| reversed(t)).collect();
        both.extend(&c.triangles);
        let r = repair(&with(&c, both));
        assert_eq!(r.report.surface, Surface::ClosedOutward, "{}", r.report);
        assert_eq!((r.report.twins, r.report.triangles_out), (12, 12));
        assert_eq!((r.report.flipped, r.report.inverted_components), (12, 1));
        assert_eq!(r.mesh.triangles, c.triangles);
        assert!((volume(&r.mesh) - 0.048).abs() < 1e-15);
        assert!(Topology::of(&r.mesh).is_closed_outward());
        // Originals first: they are kept as they are.
        let mut both = c.triangles.clone();
        both.extend(c.triangles.iter().map(|&t| reversed(t)));
        let r = repair(&with(&c, both));
        assert_eq!(r.mesh.triangles, c.triangles);
        assert_eq!(
            r.report.to_string(),
            "mesh 'test': double-sided: dropped 12 reversed twins; closed, outward (1 component)"
        );
    }

    #[test]
    fn a_flipped_patch_is_wound_back() {
        let c = cube();
        let mut t = c.triangles.clone();
        // The −x and +x faces.
        for tri in &mut t[..4] {
            *tri = reversed(*tri);
        }
        assert_eq!(Topology::of(&with(&c, t.clone())).misoriented_edges, 8);
        let r = repair(&with(&c, t));
        assert_eq!(r.report.surface, Surface::ClosedOutward);
        assert_eq!((r.report.flipped, r.report.inverted_components), (4, 0));
        assert_eq!(r.mesh.triangles, c.triangles);
        assert!(r.report.to_string().contains("flipped 4 of 12 triangles"));
    }

    #[test]
    fn a_cube_wound_inward_is_turned_outward() {
        let c = cube();
        let inward = with(&c, c.triangles.iter().map(|&t| reversed(t)).collect());
        assert!(volume(&inward) < 0.0);
        let r = repair(&inward);
        assert_eq!(r.report.surface, Surface::ClosedOutward);
        assert_eq!((r.report.flipped, r.report.inverted_components), (12, 1));
        assert!((volume(&r.mesh) - 0.048).abs() < 1e-15);
        assert!(r.report.to_string().contains("(1 shell turned outward)"));
    }

    #[test]
    fn a_cube_with_a_hole_is_open_and_wound_as_most_of_it() {
        let c = cube();
        // The +z face removed: a square hole of 4 edges.
        let holed = with(&c, c.triangles[..10].to_vec());
        let r = repair(&holed);
        assert_eq!(r.report.surface, Surface::Open);
        assert_eq!((r.report.boundary_edges, r.report.components), (4, 1));
        assert!(!r.report.changed() && r.mesh == holed);
        assert!(r.report.to_string().contains("thin shell"), "{}", r.report);
        // The first triangle (where the walk starts) flipped: turned back to agree with
        // the other nine.
        let mut t = c.triangles[..10].to_vec();
        t[0] = reversed(t[0]);
        let r = repair(&with(&c, t));
        assert_eq!(
            (r.report.surface.clone(), r.report.flipped),
            (Surface::Open, 1)
        );
        assert_eq!(r.mesh.triangles, c.triangles[..10]);
    }

    fn square() -> MeshData {
        let v = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        MeshData::new(
            "sheet",
            v.iter().map(|&p| Vector3::from(p)).collect(),
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .expect("valid")
    }

    #[test]
    fn single_and_double_sided_sheets_are_open() {
        let s = square();
        let r = repair(&s);
        assert_eq!(r.report.surface, Surface::Open);
        assert_eq!(r.report.boundary_edges, 4);
        assert!(!r.report.changed());
        let double = with(&s, vec![[0, 1, 2], [0, 2, 1], [0, 2, 3], [0, 3, 2]]);
        let r = repair(&double);
        assert_eq!(r.report.surface, Surface::Open);
        assert_eq!((r.report.twins, r.report.triangles_out), (2, 2));
        assert_eq!(Topology::of(&r.mesh).misoriented_edges, 0);
        assert!(r.report.to_string().starts_with(
            "mesh 'test': double-sided: dropped 2 reversed twins; open: 4 boundary edges"
        ));
    }

    #[test]
    fn a_hollow_cube_gets_its_cavity_wound_inward() {
        let outer = MeshData::cuboid("outer", [0.1, 0.1, 0.1]);
        let inner = MeshData::cuboid("inner", [0.05, 0.05, 0.05]);
        let core = MeshData::cuboid("core", [0.01, 0.01, 0.01]);
        let inward = |m: &MeshData| with(m, m.triangles.iter().map(|&t| reversed(t)).collect());
        // Both shells of the hollow cube wrong (outer inward, cavity outward), and a solid
        // core in the cavity wound inward.
        let hollow = merged(&merged(&inward(&outer), &inner), &inward(&core));
        let r = repair(&hollow);
        assert_eq!(r.report.surface, Surface::ClosedOutward, "{}", r.report);
        assert_eq!((r.report.components, r.report.cavities), (3, 1));
        assert_eq!(r.report.flipped, 36);
        let want = 0.2f64.powi(3) - 0.1f64.powi(3) + 0.02f64.powi(3);
        assert!(
            (volume(&r.mesh) - want).abs() < 1e-15,
            "{}",
            volume(&r.mesh)
        );
        assert!(r.report.to_string().contains("1 cavity wound inward"));
        // Already right: nothing changes.
        let right = merged(&merged(&outer, &inward(&inner)), &core);
        let r = repair(&right);
        assert!(!r.report.changed() && r.mesh == right, "{}", r.report);
    }

    #[test]
    fn shells_that_cross_each_other_are_each_wound_outward() {
        use parry3d_f64::math::Vector;
        // A 20 mm cube run half into a bumpy sphere: its box lies in the sphere's box and
        // its first triangle's centroid inside the sphere, but it is no cavity.
        let sphere = MeshData::bumpy_sphere("sphere", 0.1, 48, 96);
        let h = 0.01;
        let u: Vector3<f64> = Vector3::new(1.0, 0.5, 0.3).normalize();
        let (theta, phi) = (u.z.acos(), u.y.atan2(u.x));
        let rho = 0.1 * (1.0 + 0.1 * (5.0 * theta).sin() * (5.0 * phi).sin());
        let mut cube = MeshData::cuboid("cube", [h, h, h]);
        for v in &mut cube.vertices_m {
            *v += rho * u;
        }
        let shape = crate::shapes::part_shape(&crate::Part {
            primitive: crate::Primitive::Mesh {
                mesh: std::sync::Arc::new(sphere.clone()),
            },
            pose: crate::Se3::identity(),
        });
        let inside = |p: Vector3<f64>| shape.contains_local_point(Vector::new(p.x, p.y, p.z));
        let first: Vector3<f64> = cube.triangles[0]
            .iter()
            .map(|&i| cube.vertices_m[i as usize])
            .sum::<Vector3<f64>>()
            / 3.0;
        assert!(inside(first) && !inside(cube.vertices_m[7]), "the premise");
        let (s, c) = (Topology::of(&sphere), Topology::of(&cube));
        let r = repair(&merged(&sphere, &cube));
        assert_eq!(r.report.surface, Surface::ClosedOutward, "{}", r.report);
        assert_eq!(
            (r.report.components, r.report.cavities),
            (2, 0),
            "{}",
            r.report
        );
        let want = s.signed_volume_m3 + c.signed_volume_m3;
        assert!((volume(&r.mesh) - want).abs() < 1e-15);
        assert!(!r.report.changed());
    }

    #[test]
    fn three_triangles_on_an_edge_make_a_closed_mesh_a_shell_that_says_why() {
        // A cube with a wall inside on its diagonal plane x/0.1 = y/0.2: the wall puts a
        // third triangle on four of the cube's edges and leaves no edge on one triangle.
        // Vertices read in single precision, as OBJ and STL files give them: the edge is
        // named as the file has it.
        let c = cube();
        let v: Vec<_> = c
            .vertices_m
            .iter()
            .map(|p| p.map(|x| f64::from(x as f32)))
            .collect();
        let mut t = c.triangles.clone();
        t.extend([[0, 3, 7], [0, 7, 4]]);
        let walled = MeshData::new("walled", v, t).expect("valid");
        assert_eq!(Topology::of(&walled).boundary_edges, 0);
        let r = repair(&walled);
        assert_eq!(r.report.surface, Surface::Open, "{}", r.report);
        assert!(
            matches!(
                r.report.no_inside,
                Some(Refusal::NonManifold { edges: 4, .. })
            ),
            "{:?}",
            r.report.no_inside
        );
        let line = r.report.to_string();
        assert!(
            line.contains("no inside: 4 edges shared by more than two triangles")
                && line.contains("e.g. (-0.1, -0.2, -0.3)–(0.1, 0.2, -0.3) m")
                && line.contains("thin shell"),
            "{line}"
        );
        // Every triangle kept: a shell of the cube and its wall.
        assert_eq!(r.report.triangles_out, walled.triangles.len());
        // Three triangles on the edge (0, 0, 0)–(1, 1, 0) of an open fan: a thin shell
        // needs no inside.
        let s = square();
        let mut v = s.vertices_m.clone();
        v.push(Vector3::new(0.5, 0.5, 1.0));
        v.push(Vector3::new(0.5, 0.5, -1.0));
        let fan = MeshData::new("fan", v, vec![[0, 1, 2], [0, 2, 4], [0, 5, 2]]).expect("valid");
        let r = repair(&fan);
        assert_eq!(r.report.surface, Surface::Open, "{}", r.report);
        assert_eq!((r.report.non_manifold_edges, r.report.components), (1, 3));
        assert!(
            r.report
                .to_string()
                .contains("1 edge on more than two triangles"),
            "{}",
            r.report
        );
        // A fin on a closed cube's edge: open too.
        let mut v = c.vertices_m.clone();
        v.push(Vector3::new(0.0, -1.0, -1.0));
        let mut t = c.triangles.clone();
        t.push([0, 1, 8]);
        let r = repair(&MeshData::new("fin", v, t).expect("valid"));
        assert_eq!(r.report.surface, Surface::Open, "{}", r.report);
    }

    #[test]
    fn stl_style_unwelded_vertices_are_welded() {
        // Every triangle with vertices of its own, double-sided, one face flipped.
        let c = cube();
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        let mut faces = c.triangles.clone();
        faces[10] = reversed(faces[10]);
        faces[11] = reversed(faces[11]);
        let twins: Vec<_> = faces.iter().map(|&t| reversed(t)).collect();
        faces.extend(twins);
        for t in &faces {
            let base = vertices.len() as u32;
            vertices.extend(t.iter().map(|&i| c.vertices_m[i as usize]));
            triangles.push([base, base + 1, base + 2]);
        }
        let soup = MeshData::new("soup", vertices, triangles).expect("valid");
        let r = repair(&soup);
        assert_eq!(r.report.surface, Surface::ClosedOutward, "{}", r.report);
        assert_eq!((r.report.twins, r.report.flipped), (12, 2));
        // Only the kept triangles' vertices remain, at their positions.
        assert_eq!(r.mesh.vertices_m.len(), 36);
        assert!((volume(&r.mesh) - 0.048).abs() < 1e-15);
    }

    #[test]
    fn a_double_sided_partly_flipped_bumpy_sphere_comes_back_closed_and_outward() {
        let sphere = MeshData::bumpy_sphere("sphere", 0.1, 24, 48);
        let mut t: Vec<_> = sphere
            .triangles
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                if i % 7 == 0 || i < 100 {
                    reversed(t)
                } else {
                    t
                }
            })
            .collect();
        let twins: Vec<_> = t.iter().map(|&t| reversed(t)).collect();
        t.extend(twins);
        let broken = with(&sphere, t);
        assert!(!Topology::of(&broken).is_closed_outward());
        let r = repair(&broken);
        assert_eq!(r.report.surface, Surface::ClosedOutward, "{}", r.report);
        assert_eq!(r.report.twins, sphere.triangles.len());
        assert_eq!(r.mesh.triangles, sphere.triangles);
        assert_eq!(r.mesh.vertices_m, sphere.vertices_m);
        assert!((volume(&r.mesh) - volume(&sphere)).abs() < 1e-15);
        assert_eq!(repair(&broken), r, "deterministic");
    }

    #[test]
    fn a_closed_surface_that_cannot_be_oriented_and_a_moebius_strip_are_shells() {
        // The 6-vertex real projective plane: closed (every edge on two triangles) and
        // one-sided. Generic positions give every triangle an area.
        let v: Vec<_> = (0..6)
            .map(|i| {
                let a = f64::from(i);
                Vector3::new(a.cos(), a.sin(), 0.3 * a * a - a)
            })
            .collect();
        let t = [
            [0, 1, 2],
            [0, 2, 3],
            [0, 3, 4],
            [0, 4, 5],
            [0, 5, 1],
            [1, 2, 4],
            [2, 3, 5],
            [3, 4, 1],
            [4, 5, 2],
            [5, 1, 3],
        ];
        let rp2 = MeshData::new("rp2", v, t.to_vec()).expect("valid");
        assert_eq!(Topology::of(&rp2).boundary_edges, 0);
        let r = repair(&rp2);
        assert_eq!(r.report.surface, Surface::Open, "{}", r.report);
        let Some(Refusal::NonOrientable { edges, .. }) = r.report.no_inside else {
            panic!("not found non-orientable: {}", r.report);
        };
        assert!(edges > 0);
        assert!(
            r.report
                .to_string()
                .contains("cannot be wound consistently")
        );
        // A Möbius strip: a band of 5 quads glued with a half twist. Open, and a thin
        // shell needs no side.
        let n = 5;
        let mut v = Vec::new();
        for i in 0..n {
            let a = std::f64::consts::TAU * f64::from(i) / f64::from(n);
            let w = 0.3 * (0.5 * a).cos();
            let h = 0.3 * (0.5 * a).sin();
            for s in [-1.0, 1.0] {
                v.push(Vector3::new(
                    (1.0 + s * w) * a.cos(),
                    (1.0 + s * w) * a.sin(),
                    s * h,
                ));
            }
        }
        let mut t = Vec::new();
        for i in 0..n {
            let (a, b) = (2 * i, 2 * i + 1);
            // The last quad joins the first one's edge the other way round.
            let (c, d) = if i + 1 < n { (a + 2, b + 2) } else { (1, 0) };
            t.push([a, c, d]);
            t.push([a, d, b]);
        }
        let strip = MeshData::new("moebius", v, t).expect("valid");
        let r = repair(&strip);
        assert_eq!(r.report.surface, Surface::Open, "{}", r.report);
        assert_eq!(r.report.components, 1);
        assert!(r.report.unorientable_edges > 0, "{}", r.report);
    }

    #[test]
    fn degenerate_and_duplicate_triangles_are_dropped() {
        let c = cube();
        let mut t = c.triangles.clone();
        t.insert(3, [0, 0, 1]); // two corners the same
        t.push(c.triangles[5]); // an exact duplicate
        let mut v = c.vertices_m.clone();
        v.push(c.vertices_m[0]); // a vertex repeated at the same position
        t.push([0, 8, 2]); // ... welded into a degenerate triangle
        v.push(0.5 * (c.vertices_m[0] + c.vertices_m[1]));
        t.push([0, 1, 9]); // three corners on a line
        let r = repair(&MeshData::new("t", v, t).expect("valid"));
        assert_eq!(r.report.surface, Surface::ClosedOutward);
        assert_eq!((r.report.degenerate, r.report.duplicates), (3, 1));
        assert_eq!(r.mesh.triangles, c.triangles);
        assert_eq!(
            r.mesh.vertices_m, c.vertices_m,
            "the unused vertices dropped"
        );
        assert!(
            r.report
                .to_string()
                .contains("dropped 1 duplicate triangle, dropped 3 degenerate triangles"),
            "{}",
            r.report
        );
    }

    #[test]
    fn closed_outward_meshes_come_back_unchanged() {
        let meshes = [
            cube(),
            MeshData::bumpy_sphere("sphere", 0.1, 16, 32),
            crate::Scene::silencer_body_mesh(),
        ];
        for m in meshes {
            let r = repair(&m);
            assert!(!r.report.changed(), "{}", r.report);
            assert_eq!(r.mesh, m);
            assert!(
                r.report
                    .to_string()
                    .ends_with("closed, outward (1 component), unchanged")
            );
        }
    }

    #[test]
    fn only_what_has_no_surface_is_refused_and_bad_data_is_not_panicked_on() {
        let c = cube();
        let bad = MeshData {
            triangles: vec![[0, 1, 99]],
            ..c.clone()
        };
        let r = repair(&bad);
        assert!(matches!(
            r.report.surface,
            Surface::Refused(Refusal::Invalid { .. })
        ));
        let mut nan = c.clone();
        nan.vertices_m[2].y = f64::NAN;
        assert!(repair(&nan).report.surface.is_refused());
        let flat = with(&c, vec![[0, 0, 1], [1, 1, 1]]);
        assert_eq!(
            repair(&flat).report.surface,
            Surface::Refused(Refusal::NoArea)
        );
        // A closed pillow of no thickness: a square, each side split on another diagonal.
        let s = square();
        let pillow = with(&s, vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]]);
        assert_eq!(Topology::of(&pillow).boundary_edges, 0);
        // A surface all the same: a thin shell, saying why.
        let r = repair(&pillow);
        assert_eq!(r.report.surface, Surface::Open);
        assert_eq!(r.report.no_inside, Some(Refusal::Flat { shells: 1 }));
    }
}
