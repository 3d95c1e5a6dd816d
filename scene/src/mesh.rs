//! Triangle meshes for scene parts, read from Wavefront OBJ (`tobj`) or STL ([`crate::stl`],
//! ASCII or binary).
//!
//! Vertices are in the part's local frame; a file's numbers are multiplied by `scale` to
//! give metres (e.g. `scale = 0.001` for a CAD file in millimetres). Triangles must be
//! wound counter-clockwise seen from outside (outward normals) for point containment and
//! signed distances to be right; [`MeshData::load`] reads them as they are, and loading a
//! scene repairs them ([`crate::repair`]).
//!
//! Every failure is a [`MeshError`] naming the file and, where the format allows, the line
//! (OBJ) or the triangle; nothing here panics on bad input.

use nalgebra::Vector3;
use std::io::BufReader;
use std::path::Path;

/// A validated triangle mesh: finite vertices (m, local frame), at least one triangle,
/// every index in range.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshData {
    /// Where it came from (a path, or a label for generated meshes).
    pub source: String,
    /// Vertices (m, part frame).
    pub vertices_m: Vec<Vector3<f64>>,
    /// Triangles as vertex indices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// What [`crate::repair::repair`] found and did, when these triangles came from it
    /// (a scene file's meshes do, on load); `None` for a mesh as built or read.
    pub repair: Option<Box<crate::repair::RepairReport>>,
}

/// Why a mesh could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The file could not be opened or read.
    #[error("{path}: cannot read mesh: {error}")]
    Io {
        /// Mesh file path.
        path: String,
        /// The I/O error.
        error: std::io::Error,
    },
    /// The file is not a valid mesh; `line` is the 1-based line when known.
    #[error("{path}{}: {reason}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Format {
        /// Mesh file path.
        path: String,
        /// 1-based line of the offending statement, when known (OBJ, ASCII STL; a binary
        /// STL's byte offset is in the reason).
        line: Option<usize>,
        /// What is wrong.
        reason: String,
    },
    /// The extension is neither `.obj` nor `.stl`.
    #[error("{path}: unknown mesh format (expected a .obj or .stl file)")]
    UnknownFormat {
        /// Mesh file path.
        path: String,
    },
}

/// Least and greatest corners of the axis-aligned box around `v` (m; (+∞, −∞) when `v`
/// is empty).
pub fn bounding_box(v: &[Vector3<f64>]) -> (Vector3<f64>, Vector3<f64>) {
    v.iter().fold(
        (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), p| (lo.inf(p), hi.sup(p)),
    )
}

impl MeshData {
    /// Builds and validates a mesh; `source` names it in errors.
    pub fn new(
        source: &str,
        vertices_m: Vec<Vector3<f64>>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<Self, MeshError> {
        let bad = |reason: String| MeshError::Format {
            path: source.to_owned(),
            line: None,
            reason,
        };
        if triangles.is_empty() {
            return Err(bad("mesh has no triangles".into()));
        }
        if let Some(i) = vertices_m
            .iter()
            .position(|v| !v.iter().all(|c| c.is_finite()))
        {
            return Err(bad(format!("vertex {i} is not finite")));
        }
        let n = vertices_m.len();
        if let Some(t) = triangles
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= n))
        {
            return Err(bad(format!(
                "triangle {t} indexes a vertex beyond the {n} vertices"
            )));
        }
        Ok(MeshData {
            source: source.to_owned(),
            vertices_m,
            triangles,
            repair: None,
        })
    }

    /// Loads `path` (`.obj` or `.stl`, case-insensitive), multiplying coordinates by
    /// `scale` (m per file unit, finite and > 0).
    pub fn load(path: &Path, scale: f64) -> Result<Self, MeshError> {
        let name = path.display().to_string();
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        let (vertices, triangles) = match ext.as_deref() {
            Some("obj") => read_obj(path, &name)?,
            Some("stl") => read_stl(path, &name)?,
            _ => return Err(MeshError::UnknownFormat { path: name }),
        };
        let vertices = vertices.into_iter().map(|v| v * scale).collect();
        Self::new(&name, vertices, triangles)
    }

    /// What contact can make of it: the repair's verdict when it went through
    /// [`crate::repair::repair`] (a scene file's meshes do, on load), else judged from its
    /// topology ([`crate::repair::Surface::judged`]).
    pub fn surface(&self) -> crate::repair::Surface {
        match &self.repair {
            Some(r) => r.surface.clone(),
            None => crate::repair::Surface::judged(&crate::topology::Topology::of(self)),
        }
    }

    /// Largest distance of a vertex from the local origin after `transform` (m).
    pub fn reach_m(&self, transform: impl Fn(&Vector3<f64>) -> Vector3<f64>) -> f64 {
        self.vertices_m
            .iter()
            .map(|v| transform(v).norm())
            .fold(0.0, f64::max)
    }

    /// A closed box mesh of half extents `h` (m), outward winding. Used by generated
    /// scenes and tests.
    pub fn cuboid(source: &str, h: [f64; 3]) -> Self {
        let mut v = Vec::with_capacity(8);
        for i in 0..8 {
            let s = |bit: u32| if i & (1 << bit) == 0 { -1.0 } else { 1.0 };
            v.push(Vector3::new(s(0) * h[0], s(1) * h[1], s(2) * h[2]));
        }
        // Faces (−x, +x, −y, +y, −z, +z) as two counter-clockwise triangles each.
        let t = vec![
            [0, 4, 6],
            [0, 6, 2],
            [1, 3, 7],
            [1, 7, 5],
            [0, 1, 5],
            [0, 5, 4],
            [2, 6, 7],
            [2, 7, 3],
            [0, 2, 3],
            [0, 3, 1],
            [4, 5, 7],
            [4, 7, 6],
        ];
        MeshData {
            source: source.to_owned(),
            vertices_m: v,
            triangles: t,
            repair: None,
        }
    }

    /// A closed, outward-wound sphere of radius `r` (m) with bumps of ±10 % (5 per half
    /// turn in latitude and longitude, so it is not convex): `rings` ≥ 2 latitude bands of
    /// `segments` ≥ 3, poles as fans, `2·segments·(rings − 1)` triangles. Dense meshes for
    /// tests and benchmarks.
    pub fn bumpy_sphere(source: &str, r: f64, rings: u32, segments: u32) -> Self {
        let (rings, segments) = (rings.max(2), segments.max(3));
        let at = |theta: f64, phi: f64| {
            let rho = r * (1.0 + 0.1 * (5.0 * theta).sin() * (5.0 * phi).sin());
            Vector3::new(
                rho * theta.sin() * phi.cos(),
                rho * theta.sin() * phi.sin(),
                rho * theta.cos(),
            )
        };
        let mut v = vec![Vector3::new(0.0, 0.0, r)];
        for i in 1..rings {
            for j in 0..segments {
                let theta = std::f64::consts::PI * f64::from(i) / f64::from(rings);
                v.push(at(
                    theta,
                    std::f64::consts::TAU * f64::from(j) / f64::from(segments),
                ));
            }
        }
        v.push(Vector3::new(0.0, 0.0, -r));
        let south = v.len() as u32 - 1;
        let ring = |i: u32, j: u32| 1 + (i - 1) * segments + j % segments;
        let mut t = Vec::with_capacity(2 * (segments * (rings - 1)) as usize);
        for j in 0..segments {
            t.push([0, ring(1, j), ring(1, j + 1)]);
            for i in 1..rings - 1 {
                t.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
                t.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
            }
            t.push([south, ring(rings - 1, j + 1), ring(rings - 1, j)]);
        }
        MeshData {
            source: source.to_owned(),
            vertices_m: v,
            triangles: t,
            repair: None,
        }
    }
}

/// The relief of [`MeshData::icosphere`]: its radius along each unit direction (x, y, z)
/// from the centre, as a factor of the nominal radius.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bumps {
    /// A sphere: 1.
    None,
    /// Those of [`MeshData::bumpy_sphere`]: 1 + 0.1·sin 5θ·sin 5φ (θ from +z, φ about z),
    /// ±10 %, not convex.
    Bench,
    /// Finer and shallower: 1 + 0.04·sin 12x·sin 9y + 0.02·sin 30z, within ±6 %.
    Fine,
}

impl Bumps {
    /// The radius factor along unit direction `u`.
    fn factor(self, u: &Vector3<f64>) -> f64 {
        match self {
            Bumps::None => 1.0,
            Bumps::Bench => {
                let (theta, phi) = (u.z.clamp(-1.0, 1.0).acos(), u.y.atan2(u.x));
                1.0 + 0.1 * (5.0 * theta).sin() * (5.0 * phi).sin()
            }
            Bumps::Fine => {
                1.0 + 0.04 * (12.0 * u.x).sin() * (9.0 * u.y).sin() + 0.02 * (30.0 * u.z).sin()
            }
        }
    }
}

impl MeshData {
    /// A closed, outward-wound sphere of radius `r` (m) whose triangles are all about the
    /// same size: an icosahedron whose triangles are each cut into four `subdivisions`
    /// times (20·4^s triangles, 10·4^s + 2 vertices), every vertex then at `r` times
    /// `bumps`' factor along its direction. Triangles are stored as the subdivision makes
    /// them (each one's four children in its place: a quadtree order on each of the 20
    /// faces), vertices in the order they were made (the 12 corners, then each level's
    /// midpoints). Dense meshes for tests and benchmarks, unlike
    /// [`Self::bumpy_sphere`]'s slivers at the poles.
    pub fn icosphere(source: &str, r: f64, subdivisions: u32, bumps: Bumps) -> Self {
        let g = (1.0 + 5f64.sqrt()) / 2.0;
        let mut dirs: Vec<Vector3<f64>> = [
            [-1.0, g, 0.0],
            [1.0, g, 0.0],
            [-1.0, -g, 0.0],
            [1.0, -g, 0.0],
            [0.0, -1.0, g],
            [0.0, 1.0, g],
            [0.0, -1.0, -g],
            [0.0, 1.0, -g],
            [g, 0.0, -1.0],
            [g, 0.0, 1.0],
            [-g, 0.0, -1.0],
            [-g, 0.0, 1.0],
        ]
        .iter()
        .map(|c| Vector3::from(*c).normalize())
        .collect();
        let mut t: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..subdivisions {
            let mut mid = std::collections::HashMap::with_capacity(t.len() * 3 / 2);
            let mut midpoint = |a: u32, b: u32, dirs: &mut Vec<Vector3<f64>>| {
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    dirs.push((dirs[a as usize] + dirs[b as usize]).normalize());
                    dirs.len() as u32 - 1
                })
            };
            let mut next = Vec::with_capacity(t.len() * 4);
            for &[a, b, c] in &t {
                let ab = midpoint(a, b, &mut dirs);
                let bc = midpoint(b, c, &mut dirs);
                let ca = midpoint(c, a, &mut dirs);
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            t = next;
        }
        MeshData {
            source: source.to_owned(),
            vertices_m: dirs.iter().map(|u| u * (r * bumps.factor(u))).collect(),
            triangles: t,
            repair: None,
        }
    }
}

impl MeshData {
    /// A stand-in for a CAD part as exported (for tests and benchmarks of the loop's
    /// worst case): 20 040 triangles in open components, 160 × 83 × 80 mm about its
    /// bounding box's centre, metres:
    ///
    /// * a housing: a 160 × 80 × 50 mm box without its top, each face cut into 2 mm
    ///   squares (18 400 triangles, each face a grid of its own: welding on load joins
    ///   what coincides);
    /// * a boss under it: a tube of radius 15 mm and height 30 mm, no caps, in 200 facets
    ///   of one band (slivers 0.47 mm wide and 30 mm long);
    /// * a disc on its −y face: radius 20 mm, a fan of 600 slivers from its centre;
    /// * a flange round the open top: two 2 mm wide strips along the long sides, each face
    ///   of each strip its own component (a sheet exported double-sided, not closed).
    pub fn cad_like_part() -> Self {
        let mut v: Vec<Vector3<f64>> = Vec::new();
        let mut t: Vec<[u32; 3]> = Vec::new();
        // A grid of `nu` × `nv` squares spanning origin + u·[0, 1] + w·[0, 1], wound so its
        // normal is u × w.
        let mut grid =
            |origin: Vector3<f64>, u: Vector3<f64>, w: Vector3<f64>, nu: u32, nv: u32| {
                let base = v.len() as u32;
                for j in 0..=nv {
                    for i in 0..=nu {
                        v.push(
                            origin
                                + u * (f64::from(i) / f64::from(nu))
                                + w * (f64::from(j) / f64::from(nv)),
                        );
                    }
                }
                let at = |i: u32, j: u32| base + j * (nu + 1) + i;
                for j in 0..nv {
                    for i in 0..nu {
                        t.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                        t.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
                    }
                }
            };
        let (hx, hy, h) = (0.08, 0.04, 0.05);
        let (x, y, z) = (Vector3::x(), Vector3::y(), Vector3::z());
        // Housing: bottom at z = 0 (normal −z), four walls, open at z = h.
        grid(
            Vector3::new(-hx, -hy, 0.0),
            y * 2.0 * hy,
            x * 2.0 * hx,
            40,
            80,
        );
        grid(Vector3::new(-hx, -hy, 0.0), x * 2.0 * hx, z * h, 80, 25);
        grid(Vector3::new(hx, hy, 0.0), -x * 2.0 * hx, z * h, 80, 25);
        grid(Vector3::new(hx, -hy, 0.0), y * 2.0 * hy, z * h, 40, 25);
        grid(Vector3::new(-hx, hy, 0.0), -y * 2.0 * hy, z * h, 40, 25);
        // Flange strips along the long sides at the rim, top and bottom faces apart.
        for side in [-1.0, 1.0] {
            let inner = Vector3::new(-hx, side * hy, h);
            let out = y * (side * 0.002);
            grid(inner, x * 2.0 * hx, out, 80, 1);
            grid(inner + out, x * 2.0 * hx, -out, 80, 1);
        }
        // Boss: an open tube below the bottom, one band of 200 facets.
        let (r, hb, n) = (0.015, 0.03, 200u32);
        let base = v.len() as u32;
        for k in 0..n {
            let a = std::f64::consts::TAU * f64::from(k) / f64::from(n);
            v.push(Vector3::new(r * a.cos(), r * a.sin(), 0.0));
            v.push(Vector3::new(r * a.cos(), r * a.sin(), -hb));
        }
        for k in 0..n {
            let (a0, b0) = (base + 2 * k, base + 2 * k + 1);
            let (a1, b1) = (base + 2 * ((k + 1) % n), base + 2 * ((k + 1) % n) + 1);
            t.push([a0, b0, b1]);
            t.push([a0, b1, a1]);
        }
        // Disc on the −y face, 1 mm off it: a fan of slivers.
        let (rd, m) = (0.02, 600u32);
        let centre = v.len() as u32;
        v.push(Vector3::new(0.0, -hy - 0.001, 0.5 * h));
        for k in 0..m {
            let a = std::f64::consts::TAU * f64::from(k) / f64::from(m);
            v.push(Vector3::new(
                rd * a.cos(),
                -hy - 0.001,
                0.5 * h + rd * a.sin(),
            ));
        }
        for k in 0..m {
            t.push([centre, centre + 1 + (k + 1) % m, centre + 1 + k]);
        }
        // About the bounding box's centre (z from −30 to 50 mm, y from −41 to 42 mm).
        let (lo, hi) = bounding_box(&v);
        let mid = (lo + hi) * 0.5;
        for p in &mut v {
            *p -= mid;
        }
        MeshData {
            source: "cad-like-part (generated)".into(),
            vertices_m: v,
            triangles: t,
            repair: None,
        }
    }
}

/// Vertices (file units) and triangles as read, before scaling and validation.
type RawMesh = (Vec<Vector3<f64>>, Vec<[u32; 3]>);

fn read_obj(path: &Path, name: &str) -> Result<RawMesh, MeshError> {
    let text = std::fs::read_to_string(path).map_err(|error| MeshError::Io {
        path: name.to_owned(),
        error,
    })?;
    // tobj reports what went wrong but not where: find the line ourselves first.
    if let Some((line, reason)) = obj_first_bad_line(&text) {
        return Err(MeshError::Format {
            path: name.to_owned(),
            line: Some(line),
            reason,
        });
    }
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let mut reader = BufReader::new(text.as_bytes());
    // Materials are irrelevant to collision: ignore any `mtllib`.
    let (models, _) =
        tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::GenericFailure)).map_err(
            |e| MeshError::Format {
                path: name.to_owned(),
                line: None,
                reason: format!("OBJ: {e}"),
            },
        )?;
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for m in &models {
        let base = vertices.len() as u32;
        for p in m.mesh.positions.chunks_exact(3) {
            vertices.push(Vector3::new(
                f64::from(p[0]),
                f64::from(p[1]),
                f64::from(p[2]),
            ));
        }
        for t in m.mesh.indices.chunks_exact(3) {
            triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    Ok((vertices, triangles))
}

/// The first `v` line with other than 3–4 finite numbers, or `f` line with fewer than 3
/// vertices or an index outside the vertices defined so far (1-based, negative relative).
fn obj_first_bad_line(text: &str) -> Option<(usize, String)> {
    let mut nv: i64 = 0;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let nums: Vec<Option<f64>> = it.map(|s| s.parse::<f64>().ok()).collect();
                let ok = (3..=7).contains(&nums.len())
                    && nums.iter().take(3).all(|n| n.is_some_and(f64::is_finite))
                    && nums.iter().all(Option::is_some);
                if !ok {
                    return Some((i + 1, "vertex needs 3 finite numbers".into()));
                }
                nv += 1;
            }
            Some("f") => {
                let mut count = 0;
                for tok in it {
                    count += 1;
                    let idx = tok.split('/').next().and_then(|s| s.parse::<i64>().ok());
                    let ok = match idx {
                        Some(k) if k > 0 => k <= nv,
                        Some(k) if k < 0 => -k <= nv,
                        _ => false,
                    };
                    if !ok {
                        return Some((
                            i + 1,
                            format!("face index `{tok}` is not one of the {nv} vertices so far"),
                        ));
                    }
                }
                if count < 3 {
                    return Some((i + 1, "face needs at least 3 vertices".into()));
                }
            }
            _ => {}
        }
    }
    None
}

fn read_stl(path: &Path, name: &str) -> Result<RawMesh, MeshError> {
    let bytes = std::fs::read(path).map_err(|error| MeshError::Io {
        path: name.to_owned(),
        error,
    })?;
    crate::stl::parse(&bytes).map_err(|e| MeshError::Format {
        path: name.to_owned(),
        line: e.line,
        reason: e.reason,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str, contents: &[u8]) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("planner-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp dir");
        let p = dir.join(name);
        std::fs::write(&p, contents).expect("write");
        p
    }

    const TETRA_OBJ: &str = "# tetrahedron\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n\
f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

    #[test]
    fn obj_loads_and_scales() {
        let p = tmp("tetra.obj", TETRA_OBJ.as_bytes());
        let m = MeshData::load(&p, 0.001).expect("loads");
        assert_eq!(m.vertices_m.len(), 4);
        assert_eq!(m.triangles.len(), 4);
        assert!((m.reach_m(|v| *v) - 0.001).abs() < 1e-12);
    }

    #[test]
    fn obj_errors_name_file_and_line() {
        let p = tmp("bad-v.obj", b"v 0 0 0\nv 1 x 0\nf 1 2 1\n");
        let e = MeshData::load(&p, 1.0).unwrap_err().to_string();
        assert!(e.contains("bad-v.obj:2") && e.contains("vertex"), "{e}");
        let p = tmp("bad-f.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 9\n");
        let e = MeshData::load(&p, 1.0).unwrap_err().to_string();
        assert!(e.contains("bad-f.obj:5") && e.contains("`9`"), "{e}");
        let p = tmp("empty.obj", b"# nothing\n");
        let e = MeshData::load(&p, 1.0).unwrap_err().to_string();
        assert!(e.contains("empty.obj") && e.contains("no triangles"), "{e}");
        let e = MeshData::load(Path::new("/nonexistent/m.obj"), 1.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/m.obj"), "{e}");
        let p = tmp("m.ply", b"ply\n");
        assert!(matches!(
            MeshData::load(&p, 1.0),
            Err(MeshError::UnknownFormat { .. })
        ));
    }

    #[test]
    fn stl_ascii_and_binary_load() {
        let ascii = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n\
vertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        let m = MeshData::load(&tmp("t.stl", ascii.as_bytes()), 2.0).expect("ascii");
        assert_eq!(m.triangles.len(), 1);
        assert!((m.reach_m(|v| *v) - 2.0).abs() < 1e-12);
        // One triangle, binary: header, count, normal, corners, attribute.
        let mut bin = vec![0u8; 80];
        bin.extend(1u32.to_le_bytes());
        let floats = [0f32, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        bin.extend(floats.iter().flat_map(|x| x.to_le_bytes()));
        bin.extend([0u8, 0]);
        let m = MeshData::load(&tmp("b.STL", &bin), 1.0).expect("binary");
        assert_eq!(m.triangles.len(), 1);
        // Truncated binary and garbage ASCII are errors, not panics.
        let e = MeshData::load(&tmp("cut.stl", &bin[..100]), 1.0).unwrap_err();
        assert!(
            e.to_string().contains("cut.stl") && e.to_string().contains("134 bytes"),
            "{e}"
        );
        let e = MeshData::load(&tmp("junk.stl", b"solid x\nfacet nonsense\n"), 1.0).unwrap_err();
        assert!(e.to_string().contains("junk.stl:2:"), "{e}");
    }

    #[test]
    fn icospheres_are_closed_outward_with_20_times_4_to_the_s_triangles() {
        use crate::topology::{MeshKind, Topology};
        for (s, bumps) in [(0, Bumps::None), (2, Bumps::Bench), (3, Bumps::Fine)] {
            let m = MeshData::icosphere("ico", 0.25, s, bumps);
            assert_eq!(m.triangles.len(), 20 * 4usize.pow(s), "{s}");
            assert_eq!(m.vertices_m.len(), 10 * 4usize.pow(s) + 2, "{s}");
            assert_eq!(
                Topology::of(&m).kind(),
                MeshKind::ClosedOutward,
                "{s} {bumps:?}"
            );
            let reach = m.reach_m(|v| *v);
            let most = match bumps {
                Bumps::None => 1.0,
                Bumps::Bench => 1.1,
                Bumps::Fine => 1.06,
            };
            assert!(reach <= 0.25 * most + 1e-12, "{s} {bumps:?}: {reach}");
        }
        // Every triangle about the same size: within a factor of 2 in area at s = 4.
        let m = MeshData::icosphere("ico", 1.0, 4, Bumps::None);
        let areas: Vec<f64> = m
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.vertices_m[i as usize]);
                0.5 * (b - a).cross(&(c - a)).norm()
            })
            .collect();
        let (lo, hi) = areas
            .iter()
            .fold((f64::INFINITY, 0f64), |(l, h), &x| (l.min(x), h.max(x)));
        assert!(hi < 2.0 * lo, "{lo} .. {hi}");
    }

    #[test]
    fn new_rejects_bad_data() {
        let v = vec![Vector3::zeros(), Vector3::x(), Vector3::y()];
        assert!(MeshData::new("m", v.clone(), vec![[0, 1, 2]]).is_ok());
        assert!(MeshData::new("m", v.clone(), vec![[0, 1, 3]]).is_err());
        assert!(MeshData::new("m", v.clone(), vec![]).is_err());
        let mut nan = v;
        nan[1].x = f64::NAN;
        assert!(MeshData::new("m", nan, vec![[0, 1, 2]]).is_err());
    }
}
