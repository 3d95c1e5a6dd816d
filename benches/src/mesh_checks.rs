//! Per-check cost against triangle count for the `mesh-checks` harness: a bumpy closed
//! sphere (non-convex, star-shaped) as the moving object against another as the obstacle,
//! at random poses around contact, both meshes of about the same triangle count; the sphere
//! moving against a box and a box moving against the sphere (the mesh–primitive pairs); or
//! the parts of a scene file with a mesh (e.g. a CAD puzzle converted by
//! `benches/cad/convert.py`, or a CAD link passing a hole in boxes) at random poses in its
//! bounds.

use planner_core::{CollisionChecker, Scene, Se3, Weights};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use scene::{Bounds, MeshData, Part, Primitive, SpaceKind};
use serde::Serialize;
use std::f64::consts::PI;
use std::sync::Arc;
use std::time::Instant;

/// The cap of the far clearance columns (m): what the certification asks at an edge's
/// ends, the most any object point moves along it (a 5 cm step moves every point ≥ 5 cm).
pub const FAR_CAP_M: f64 = 0.05;

/// Radius of both spheres before their bumps (m).
pub const RADIUS_M: f64 = 0.05;

/// The bumpy sphere with about `triangles` triangles (at least 2·8·3 = 48).
pub fn bumpy_sphere_of(triangles: usize) -> MeshData {
    // 2·s·(s/2 − 1) ≈ s² triangles for `s` segments and `s/2` rings.
    let s = ((triangles as f64).sqrt().round() as u32).max(8);
    MeshData::bumpy_sphere("bumpy sphere", RADIUS_M, s / 2, s)
}

/// The two-sphere scene at about `triangles` triangles per mesh.
pub fn two_spheres(triangles: usize) -> Scene {
    let part = |mesh: MeshData| Part {
        primitive: Primitive::Mesh {
            mesh: Arc::new(mesh),
        },
        pose: Se3::identity(),
    };
    Scene {
        name: format!("bumpy-spheres-{triangles}"),
        obstacles: vec![part(bumpy_sphere_of(triangles))],
        moving_object: vec![part(bumpy_sphere_of(triangles))],
        bounds: Bounds {
            min_m: nalgebra::Vector3::repeat(-0.5),
            max_m: nalgebra::Vector3::repeat(0.5),
        },
        start: Se3::from_xyz(0.3, 0.0, 0.0),
        goal: Se3::from_xyz(-0.3, 0.0, 0.0),
        space: SpaceKind::Se3,
        route: Vec::new(),
    }
}

/// Which pair of the generated cases: the two spheres, or one sphere and a box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pair {
    /// A bumpy sphere against another.
    MeshMesh,
    /// The bumpy sphere moving against a box obstacle.
    MeshBox,
    /// A box moving against the bumpy sphere.
    BoxMesh,
}

impl Pair {
    /// Every pair, in table order.
    pub const ALL: [Pair; 3] = [Pair::MeshMesh, Pair::MeshBox, Pair::BoxMesh];

    /// `mesh-mesh`, `mesh-box`, `box-mesh` (the CLI spelling).
    pub fn name(self) -> &'static str {
        match self {
            Pair::MeshMesh => "mesh-mesh",
            Pair::MeshBox => "mesh-box",
            Pair::BoxMesh => "box-mesh",
        }
    }

    /// The CLI spelling back.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == s)
    }
}

/// Half extents of the box of the mesh–box pairs (m): a plate 80 × 60 × 20 mm, so the
/// centre distances of [`poses`] put it in contact with the sphere about half the time.
pub const BOX_HALF_M: [f64; 3] = [0.04, 0.03, 0.01];

/// The scene of `pair` at about `triangles` triangles per mesh: a bumpy sphere at the
/// origin as the obstacle and the moving object about it.
pub fn pair_scene(pair: Pair, triangles: usize) -> Scene {
    let mesh = |mesh: MeshData| Part {
        primitive: Primitive::Mesh {
            mesh: Arc::new(mesh),
        },
        pose: Se3::identity(),
    };
    let plate = || Part::axis_box(BOX_HALF_M, [0.0; 3]);
    let (obstacle, object) = match pair {
        Pair::MeshMesh => (
            mesh(bumpy_sphere_of(triangles)),
            mesh(bumpy_sphere_of(triangles)),
        ),
        Pair::MeshBox => (plate(), mesh(bumpy_sphere_of(triangles))),
        Pair::BoxMesh => (mesh(bumpy_sphere_of(triangles)), plate()),
    };
    let mut scene = two_spheres(triangles);
    scene.name = format!("{}-{triangles}", pair.name());
    scene.obstacles = vec![obstacle];
    scene.moving_object = vec![object];
    scene
}

/// The triangles of a scene's meshes, object and obstacles.
pub fn mesh_triangles(parts: &[Part]) -> usize {
    parts
        .iter()
        .map(|p| match &p.primitive {
            Primitive::Mesh { mesh } => mesh.triangles.len(),
            _ => 0,
        })
        .sum()
}

/// Per-check cost at one mesh size.
#[derive(Debug, Clone, Serialize)]
pub struct MeshPoint {
    /// Triangles per mesh.
    pub triangles: usize,
    /// Poses checked (each timed `repeats` times).
    pub poses: usize,
    /// Share of those poses in collision.
    pub colliding: f64,
    /// Mean `is_free` time, µs (meshes by the simultaneous traversal).
    pub is_free_us: f64,
    /// Mean time of the same check by parry's composite test, µs.
    pub parry_us: f64,
    /// Mean clearance query time capped at 5 mm (what certification asks), µs.
    pub clearance_us: f64,
    /// The same clearance by parry's closest points, µs.
    pub clearance_parry_us: f64,
    /// Mean clearance query capped at [`FAR_CAP_M`] (the sweep of a long edge), µs.
    pub far_clearance_us: f64,
    /// Mean of the certification's lower bound of it (relative tolerance
    /// `planner_core::collision::CERTIFIED_CLEARANCE_REL_TOLERANCE`), µs.
    pub far_bound_us: f64,
}

impl MeshPoint {
    /// The table cells from the colliding share on (headed by [`CELLS_HEADER`]).
    pub fn cells(&self) -> String {
        format!(
            "{:.0} % | {:.2} | {:.2} | {:.1}× | {:.2} | {:.2} | {:.2} | {:.2}",
            100.0 * self.colliding,
            self.is_free_us,
            self.parry_us,
            self.parry_us / self.is_free_us,
            self.clearance_us,
            self.clearance_parry_us,
            self.far_clearance_us,
            self.far_bound_us
        )
    }
}

/// The header of [`MeshPoint::cells`] (eight columns).
pub const CELLS_HEADER: &str = "colliding | is_free µs | parry's mesh test µs | speed-up | \
    clearance (≤ 5 mm) µs | parry's clearance µs | clearance (≤ 50 mm) µs | \
    certification's bound (≤ 50 mm) µs";

/// `poses` random poses about the obstacle at the origin, random orientations, seed
/// fixed, with the centres apart by what puts about half of `pair`'s in collision: 0.085–
/// 0.115 m for two spheres (their radii sum to 0.1 m ± their bumps), 0.05–0.1 m for the
/// sphere and the plate.
pub fn poses_for(pair: Pair, poses: usize) -> Vec<Se3> {
    match pair {
        Pair::MeshMesh => poses_between(poses, 0.085, 0.115),
        Pair::MeshBox | Pair::BoxMesh => poses_between(poses, 0.05, 0.1),
    }
}

/// [`poses_for`] the two spheres.
pub fn poses(poses: usize) -> Vec<Se3> {
    poses_for(Pair::MeshMesh, poses)
}

fn poses_between(poses: usize, near_m: f64, far_m: f64) -> Vec<Se3> {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    (0..poses)
        .map(|_| {
            let dir = loop {
                let d = nalgebra::Vector3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                );
                let n: f64 = d.norm();
                if n > 0.1 && n <= 1.0 {
                    break d / n;
                }
            };
            let rot = nalgebra::UnitQuaternion::from_scaled_axis(
                nalgebra::Vector3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                ) * PI,
            );
            Se3::new(dir * rng.random_range(near_m..far_m), rot)
        })
        .collect()
}

/// Times `is_free` (and parry's test of the same) and the capped clearance over `poses` at
/// about `triangles` triangles per mesh of `pair`. Panics if the two tests disagree on a
/// pose, or the two clearances by more than 1 nm: a wrong fast test must not report a
/// time.
pub fn measure(pair: Pair, triangles: usize, poses: &[Se3], repeats: usize) -> MeshPoint {
    measure_scene(&pair_scene(pair, triangles), poses, repeats).expect("every pair has a mesh")
}

/// The box (scene frame, m) that holds the obstacle part `part`.
fn part_box(part: &Part) -> (nalgebra::Vector3<f64>, nalgebra::Vector3<f64>) {
    let points: Vec<nalgebra::Vector3<f64>> = match &part.primitive {
        Primitive::Mesh { mesh } => mesh
            .vertices_m
            .iter()
            .map(|v| part.pose.transform_point(v))
            .collect(),
        Primitive::Box { half_extents_m: h } => (0..8)
            .map(|i| {
                let s = |bit: u32| if i & (1 << bit) == 0 { -1.0 } else { 1.0 };
                part.pose.transform_point(&nalgebra::Vector3::new(
                    s(0) * h.x,
                    s(1) * h.y,
                    s(2) * h.z,
                ))
            })
            .collect(),
        Primitive::Sphere { radius_m } => {
            let r = nalgebra::Vector3::repeat(*radius_m);
            vec![part.pose.pos - r, part.pose.pos + r]
        }
    };
    let first = points.first().copied().unwrap_or_default();
    points
        .iter()
        .fold((first, first), |(a, b), p| (a.inf(p), b.sup(p)))
}

/// `n` configurations drawn as the planner draws them (position uniform in the bounds,
/// rotation uniform), seed fixed; with `near`, only those whose object's bounding sphere
/// reaches into the box of an obstacle part, where a check must descend the trees.
pub fn scene_poses(scene: &Scene, n: usize, near: bool) -> Vec<Se3> {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (lo, hi) = (scene.bounds.min_m, scene.bounds.max_m);
    let reach = scene.object_radius_m();
    let boxes: Vec<_> = scene.obstacles.iter().map(part_box).collect();
    let mut out = Vec::with_capacity(n);
    // Bounded, so a scene whose obstacle lies outside its bounds ends with fewer poses
    // instead of looping.
    for _ in 0..1000 * n.max(1) {
        if out.len() == n {
            break;
        }
        let p = nalgebra::Vector3::from_fn(|i, _| {
            if hi[i] > lo[i] {
                rng.random_range(lo[i]..hi[i])
            } else {
                lo[i]
            }
        });
        let reaches = |(box_lo, box_hi): &(nalgebra::Vector3<f64>, nalgebra::Vector3<f64>)| {
            let gap = (box_lo - p)
                .sup(&(p - box_hi))
                .sup(&nalgebra::Vector3::zeros());
            gap.norm() <= reach
        };
        if !near || boxes.iter().any(reaches) {
            out.push(Se3::new(p, planner_core::space::uniform_rotation(&mut rng)));
        }
    }
    out
}

/// [`measure`] on any scene with a mesh (`None` otherwise); `triangles` reports the
/// obstacles' count, or the object's when the obstacles have none.
pub fn measure_scene(scene: &Scene, poses: &[Se3], repeats: usize) -> Option<MeshPoint> {
    let triangles = match mesh_triangles(&scene.obstacles) {
        0 => mesh_triangles(&scene.moving_object),
        n => n,
    };
    if triangles == 0 {
        return None;
    }
    let c = CollisionChecker::with_params(scene, Weights::default(), 0.005);
    let free: Vec<bool> = poses.iter().map(|q| c.is_free(q)).collect();
    assert!(
        poses
            .iter()
            .zip(&free)
            .all(|(q, f)| *f == c.is_free_by_parry(q)),
        "the two mesh tests disagree"
    );
    for q in poses {
        let (ours, parry) = (
            c.clearance_up_to_m(q, 0.005),
            c.clearance_up_to_m_by_parry(q, 0.005),
        );
        assert!(
            (ours - parry).abs() < 1e-9,
            "the two clearances disagree: {ours} against {parry} m"
        );
    }
    let colliding = free.iter().filter(|f| !**f).count();
    let time = |f: &dyn Fn(&Se3) -> bool| {
        let t = Instant::now();
        for _ in 0..repeats {
            for q in poses {
                std::hint::black_box(f(std::hint::black_box(q)));
            }
        }
        t.elapsed().as_secs_f64() * 1e6 / (repeats * poses.len()).max(1) as f64
    };
    Some(MeshPoint {
        triangles,
        poses: poses.len(),
        colliding: colliding as f64 / poses.len().max(1) as f64,
        is_free_us: time(&|q| c.is_free(q)),
        parry_us: time(&|q| c.is_free_by_parry(q)),
        clearance_us: time(&|q| c.clearance_up_to_m(q, 0.005) > 0.0),
        clearance_parry_us: time(&|q| c.clearance_up_to_m_by_parry(q, 0.005) > 0.0),
        far_clearance_us: time(&|q| c.clearance_up_to_m(q, FAR_CAP_M) > 0.0),
        far_bound_us: time(&|q| c.clearance_bound_up_to_m(q, FAR_CAP_M) > 0.0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene::topology::{MeshKind, Topology};

    #[test]
    fn the_bumpy_sphere_is_closed_outward_with_the_stated_count() {
        let m = MeshData::bumpy_sphere("test", RADIUS_M, 6, 12);
        assert_eq!(m.triangles.len(), 2 * 12 * 5);
        assert_eq!(Topology::of(&m).kind(), MeshKind::ClosedOutward);
        let n = bumpy_sphere_of(2000).triangles.len();
        assert!((1800..=2200).contains(&n), "{n}");
    }

    #[test]
    fn scene_poses_lie_in_the_bounds_and_near_ones_reach_the_obstacle() {
        let scene = two_spheres(300);
        let reach = scene.object_radius_m();
        let uniform = scene_poses(&scene, 200, false);
        let near = scene_poses(&scene, 200, true);
        assert_eq!((uniform.len(), near.len()), (200, 200));
        assert!(uniform.iter().all(|q| scene.bounds.contains(&q.pos)));
        // The obstacle sphere's box is within 0.055 m of the origin.
        assert!(near.iter().all(|q| q.pos.amax() <= 0.055 + reach + 1e-12));
        assert!(uniform.iter().any(|q| q.pos.amax() > 0.055 + reach));
        // Only scenes with a mesh are measured.
        assert!(measure_scene(&Scene::wall_with_hole(), &near, 1).is_none());
        let p = measure_scene(&scene, &near, 1).expect("two meshes");
        assert!(p.colliding > 0.0 && p.far_bound_us > 0.0);
    }

    #[test]
    fn about_half_the_poses_collide() {
        for pair in Pair::ALL {
            let p = measure(pair, 500, &poses_for(pair, 200), 1);
            assert!(
                (0.2..0.8).contains(&p.colliding),
                "{pair:?}: {}",
                p.colliding
            );
            assert!(p.is_free_us > 0.0 && p.clearance_us > 0.0);
            assert_eq!(Pair::parse(pair.name()), Some(pair));
        }
        // The box–mesh pairs meet a box and a mesh.
        let s = pair_scene(Pair::BoxMesh, 500);
        assert_eq!(mesh_triangles(&s.moving_object), 0);
        assert!(mesh_triangles(&s.obstacles) > 400);
    }
}
