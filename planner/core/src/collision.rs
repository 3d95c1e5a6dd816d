//! Collision checking of the moving object against the static scene with parry
//! (`parry3d-f64`), and validation of straight edges in configuration space.
//!
//! The primitives of the obstacles (scene frame) and of the moving object (object frame)
//! are parry `Compound`s of exact shapes (cuboids, balls): no convex-decomposition
//! approximation. Mesh parts are exact oriented `TriMesh`es kept beside the compounds
//! (parry forbids composite shapes inside a compound) and tested pair by pair. A
//! configuration is free when its reference point is inside the bounds and no object
//! part intersects an obstacle part; touching counts as a collision.
//!
//! parry's composite-vs-composite test walks the *first* shape's leaves against the
//! second shape's BVH, so the (small) moving object is passed first.

use crate::space::{ConfigSpace, Space, Weights};
use parry3d_f64::math::{Pose, Vector};
use parry3d_f64::query::{contact, intersection_test};
use parry3d_f64::shape::{Compound, SharedShape};
use scene::pose::Se3;
use scene::shapes::{part_shapes, to_parry};
use scene::{Bounds, Part, Primitive, Scene};
use std::cell::Cell;

/// Default edge-validation resolution (weighted m): 5 mm of translation, or 0.05 rad of
/// rotation with the default weights (no object point moves more than √2·5 ≈ 7 mm between
/// two checked configurations when the object fits in a 0.1 m sphere).
pub const DEFAULT_EDGE_RESOLUTION: f64 = 0.005;

/// The parts of one side (object or obstacles) as parry sees them.
struct Side {
    /// Every non-mesh part in one compound; `None` when there are none (parry's
    /// `Compound::new` panics on an empty list).
    primitives: Option<Compound>,
    /// Mesh parts (composite shapes may not nest in a compound).
    meshes: Vec<(Pose, SharedShape)>,
}

impl Side {
    fn new(parts: &[Part]) -> Self {
        let (mesh_parts, prim_parts): (Vec<Part>, Vec<Part>) = parts
            .iter()
            .cloned()
            .partition(|p| matches!(p.primitive, Primitive::Mesh { .. }));
        Side {
            primitives: (!prim_parts.is_empty()).then(|| Compound::new(part_shapes(&prim_parts))),
            meshes: part_shapes(&mesh_parts),
        }
    }

    fn is_empty(&self) -> bool {
        self.primitives.is_none() && self.meshes.is_empty()
    }

    /// `(pose in the parent frame, shape)` of each composite piece.
    fn pieces(&self) -> impl Iterator<Item = (Pose, &dyn parry3d_f64::shape::Shape)> {
        let prim = self
            .primitives
            .iter()
            .map(|c| (Pose::IDENTITY, c as &dyn parry3d_f64::shape::Shape));
        prim.chain(self.meshes.iter().map(|(p, s)| (*p, s.as_ref())))
    }
}

/// Collision checker for one scene. Not `Sync` (the check counter is a `Cell`); build one
/// per thread.
pub struct CollisionChecker {
    obstacles: Side,
    object: Side,
    space: Space,
    resolution: f64,
    checks: Cell<u64>,
    /// Interval queue of [`Self::edge_free_from`], reused.
    queue: Cell<Vec<(u64, u64)>>,
}

impl CollisionChecker {
    /// A checker with the default weights and [`DEFAULT_EDGE_RESOLUTION`].
    pub fn new(scene: &Scene) -> Self {
        Self::with_params(scene, Weights::default(), DEFAULT_EDGE_RESOLUTION)
    }

    /// A checker whose edge validation uses `weights` and `resolution` (weighted m, > 0;
    /// non-positive or non-finite values fall back to the default).
    pub fn with_params(scene: &Scene, weights: Weights, resolution: f64) -> Self {
        let resolution = if resolution.is_finite() && resolution > 0.0 {
            resolution
        } else {
            DEFAULT_EDGE_RESOLUTION
        };
        CollisionChecker {
            obstacles: Side::new(&scene.obstacles),
            object: Side::new(&scene.moving_object),
            space: Space::for_scene(scene, weights),
            resolution,
            checks: Cell::new(0),
            queue: Cell::new(Vec::new()),
        }
    }

    /// Bounds of the reference point (m, scene frame).
    pub fn bounds(&self) -> &Bounds {
        self.space.bounds()
    }

    /// The configuration space edges are interpolated in.
    pub fn space(&self) -> &Space {
        &self.space
    }

    /// Edge resolution (weighted m).
    pub fn resolution(&self) -> f64 {
        self.resolution
    }

    /// Number of geometric collision checks performed so far (out-of-bounds rejections
    /// are not counted).
    pub fn collision_checks(&self) -> u64 {
        self.checks.get()
    }

    /// True when `q` is inside the bounds and the object does not touch any obstacle.
    pub fn is_free(&self, q: &Se3) -> bool {
        if !q.is_finite() || !self.space.contains(q) {
            return false;
        }
        if self.object.is_empty() || self.obstacles.is_empty() {
            return true;
        }
        self.checks.set(self.checks.get() + 1);
        let at = to_parry(q);
        for (obj_pose, obj) in self.object.pieces() {
            let obj_pose = at * obj_pose;
            for (obs_pose, obs) in self.obstacles.pieces() {
                // The object first (see module docs). An unsupported pair is treated as a
                // collision.
                let hit = intersection_test(&obj_pose, obj, &obs_pose, obs)
                    .map(|r| r.intersecting)
                    .unwrap_or(true);
                if hit {
                    return false;
                }
            }
        }
        true
    }

    /// Deepest penetration of the object into an obstacle at `q` (m, ≥ 0; 0 when
    /// separated or touching). Diagnostics only: costlier than [`Self::is_free`], not
    /// counted, and ignores the bounds.
    pub fn penetration_m(&self, q: &Se3) -> f64 {
        let at = to_parry(q);
        let mut depth: f64 = 0.0;
        for (obj_pose, obj) in self.object.pieces() {
            for (obs_pose, obs) in self.obstacles.pieces() {
                if let Ok(Some(c)) = contact(&(at * obj_pose), obj, &obs_pose, obs, 0.0) {
                    depth = depth.max(-c.dist);
                }
            }
        }
        depth
    }

    /// The deepest contact of the object at `q` with an obstacle: `(point on the obstacle
    /// surface (m), unit normal out of the obstacle, penetration depth (m))`, scene
    /// frame; `None` when separated. For simulated users; costlier than
    /// [`Self::is_free`] and not counted.
    pub fn deepest_contact(
        &self,
        q: &Se3,
    ) -> Option<(nalgebra::Vector3<f64>, nalgebra::Vector3<f64>, f64)> {
        let at = to_parry(q);
        let mut best: Option<(nalgebra::Vector3<f64>, nalgebra::Vector3<f64>, f64)> = None;
        let v = |p: Vector| nalgebra::Vector3::new(p.x, p.y, p.z);
        for (obj_pose, obj) in self.object.pieces() {
            for (obs_pose, obs) in self.obstacles.pieces() {
                if let Ok(Some(c)) = contact(&(at * obj_pose), obj, &obs_pose, obs, 0.0) {
                    let depth = -c.dist;
                    if depth >= 0.0 && best.is_none_or(|b| depth > b.2) {
                        best = Some((v(c.point2), v(c.normal2), depth));
                    }
                }
            }
        }
        best
    }

    /// True when `a`, `b` and the straight segment between them (see
    /// [`ConfigSpace::interpolate`]) are free, checked every `resolution` (weighted m).
    pub fn edge_free(&self, a: &Se3, b: &Se3) -> bool {
        self.is_free(a) && self.edge_free_from(a, b)
    }

    /// Like [`Self::edge_free`] but assumes `a` is already known to be free (a tree node).
    /// Checks `b` first, then the interior in bisection (van der Corput) order: the
    /// midpoint, then the quarter points, and so on.
    pub fn edge_free_from(&self, a: &Se3, b: &Se3) -> bool {
        if !self.is_free(b) {
            return false;
        }
        let d = self.space.distance(a, b);
        let n = (d / self.resolution).ceil();
        // NaN-safe: a NaN distance compares as "not greater", like d == 0.
        if n.partial_cmp(&1.0) != Some(std::cmp::Ordering::Greater) {
            return true;
        }
        let n = n as u64;
        let edge = self.space.geodesic(a, b);
        // A FIFO of intervals in a buffer kept between calls: no allocation per edge.
        let mut queue = self.queue.take();
        queue.clear();
        queue.push((0u64, n));
        let mut next = 0;
        let mut free = true;
        while let Some(&(lo, hi)) = queue.get(next) {
            next += 1;
            if hi - lo < 2 {
                continue;
            }
            let mid = lo + (hi - lo) / 2;
            if !self.is_free(&edge.at(mid as f64 / n as f64)) {
                free = false;
                break;
            }
            queue.push((lo, mid));
            queue.push((mid, hi));
        }
        self.queue.set(queue);
        free
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn default_scene_geometry() {
        let scene = Scene::wall_with_hole();
        let c = CollisionChecker::new(&scene);
        assert!(c.is_free(&scene.start) && c.is_free(&scene.goal));
        // Centred in the wall plane: the 100 mm S cannot fit the 80 mm hole.
        assert!(!c.is_free(&Se3::from_xyz(0.0, 0.0, 0.0)));
        // Shifted so the x-stick (at y = z = −0.04 in the object) is centred in the
        // hole: threaded through, the other sticks clear the wall face at x = 0.01.
        assert!(c.is_free(&Se3::from_xyz(0.0, 0.04, 0.04)));
        // Pushed back by 3 cm, the y-stick reaches into the wall.
        assert!(!c.is_free(&Se3::from_xyz(-0.03, 0.04, 0.04)));
        // The cube's x-min face at the wall face x = 0.01 touches (touching collides).
        assert!(!c.is_free(&Se3::from_xyz(0.0595, 0.0, 0.0)));
        assert!(c.is_free(&Se3::from_xyz(0.0605, 0.0, 0.0)));
        assert!(c.is_free(&Se3::from_xyz(0.25, 0.2, -0.2)));
        // The cube's x-min face 0.5 mm inside the wall face.
        let depth = c.penetration_m(&Se3::from_xyz(0.0595, 0.0, 0.0));
        assert!((depth - 0.0005).abs() < 1e-9, "{depth}");
        let (point, normal, d) = c
            .deepest_contact(&Se3::from_xyz(0.0595, 0.0, 0.0))
            .expect("contact");
        assert!(
            (d - 0.0005).abs() < 1e-9 && (normal.x - 1.0).abs() < 1e-9,
            "{normal}"
        );
        assert!((point.x - 0.01).abs() < 1e-9, "{point}");
        assert!(c.deepest_contact(&scene.start).is_none());
        assert_eq!(c.penetration_m(&scene.start), 0.0);
        // Out of bounds is never free.
        assert!(!c.is_free(&Se3::from_xyz(0.31, 0.0, 0.0)));
        assert!(c.collision_checks() > 0);
    }

    #[test]
    fn bound_edges_never_clear_the_wall_plane() {
        let scene = Scene::wall_with_hole();
        let c = CollisionChecker::new(&scene);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let lim = 0.25;
        for i in 0..400 {
            let s = -lim + 2.0 * lim * (i as f64 / 399.0);
            let pos = [[0.0, lim, s], [0.0, -lim, s], [0.0, s, lim], [0.0, s, -lim]][i % 4];
            let rot = crate::space::uniform_rotation(&mut rng);
            let q = Se3::new(Vector3::from(pos), rot);
            assert!(!c.is_free(&q), "free at the bound edge: {q:?}");
        }
    }

    #[test]
    fn edge_validation_detects_thin_obstacle() {
        // A 2 mm plate at x = 0 and a 2 mm ball crossing it.
        let mut scene = Scene::wall_with_hole();
        scene.obstacles = vec![Part::axis_box([0.001, 0.3, 0.3], [0.0, 0.0, 0.0])];
        scene.moving_object = vec![Part {
            primitive: Primitive::Sphere { radius_m: 0.001 },
            pose: Se3::identity(),
        }];
        let c = CollisionChecker::with_params(&scene, Weights::default(), 0.003);
        let (a, b) = (Se3::from_xyz(-0.2, 0.0, 0.0), Se3::from_xyz(0.2, 0.0, 0.0));
        assert!(c.is_free(&a) && c.is_free(&b));
        assert!(!c.edge_free(&a, &b));
        let before = c.collision_checks();
        // The midpoint collides: found at the second check (after `b`).
        assert!(!c.edge_free_from(&a, &b));
        assert_eq!(c.collision_checks() - before, 2);
        // A parallel edge beside the plate is free.
        let (a2, b2) = (
            Se3::from_xyz(-0.2, 0.0, 0.0),
            Se3::from_xyz(-0.01, 0.0, 0.0),
        );
        assert!(c.edge_free(&a2, &b2));
        // A pure rotation edge stays free too.
        let r = Se3::new(a2.pos, UnitQuaternion::from_euler_angles(0.0, 3.0, 0.0));
        assert!(c.edge_free(&a2, &r));
    }

    #[test]
    fn free_edges_cost_one_check_per_resolution_step() {
        // Far from the obstacles: every point is free, so an edge of length d costs
        // ceil(d / resolution) checks (the end and the interior points), once each.
        for scene in [Scene::wall_with_hole(), Scene::maze()] {
            let c = CollisionChecker::with_params(&scene, Weights::default(), 0.004);
            let space = c.space().clone();
            let a = scene.start;
            let mut rng = ChaCha8Rng::seed_from_u64(2);
            let mut tried = 0;
            for _ in 0..50 {
                let b = space.steer(&a, &space.sample_near(&a, 0.05, &mut rng), 0.06);
                if !c.edge_free(&a, &b) {
                    continue;
                }
                let before = c.collision_checks();
                assert!(c.edge_free_from(&a, &b));
                let n = (space.distance(&a, &b) / 0.004).ceil().max(1.0) as u64;
                assert_eq!(c.collision_checks() - before, n, "{}", scene.name);
                tried += 1;
            }
            assert!(tried > 10, "{}: {tried}", scene.name);
        }
    }

    #[test]
    fn empty_obstacles_are_free_in_bounds() {
        let mut scene = Scene::wall_with_hole();
        scene.obstacles.clear();
        let c = CollisionChecker::new(&scene);
        assert!(c.is_free(&Se3::identity()));
        assert!(!c.is_free(&Se3::from_xyz(1.0, 0.0, 0.0)));
    }

    #[test]
    fn mesh_parts_collide_like_the_boxes_they_replace() {
        use scene::MeshData;
        use std::sync::Arc;
        let boxes = Scene::wall_with_hole();
        let mut meshes = boxes.clone();
        for part in meshes
            .obstacles
            .iter_mut()
            .chain(meshes.moving_object.iter_mut())
        {
            let Primitive::Box { half_extents_m: h } = part.primitive else {
                panic!("boxes")
            };
            part.primitive = Primitive::Mesh {
                mesh: Arc::new(MeshData::cuboid("box", [h.x, h.y, h.z])),
            };
        }
        let (a, b) = (
            CollisionChecker::new(&boxes),
            CollisionChecker::new(&meshes),
        );
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let space = crate::space::Se3Space::new(boxes.bounds, Weights::default());
        let mut disagreements = 0;
        let mut collisions = 0;
        for _ in 0..300 {
            let q = space.sample_uniform(&mut rng);
            collisions += u32::from(!a.is_free(&q));
            // A mesh is hollow, but a box wholly inside another is impossible here; only
            // exact touching could differ, which random samples do not hit.
            disagreements += u32::from(a.is_free(&q) != b.is_free(&q));
        }
        assert!(collisions > 20, "{collisions}");
        assert_eq!(disagreements, 0);
        // The oriented mesh answers point containment (the haptic voxmap relies on it).
        let shapes = part_shapes(&meshes.obstacles);
        let (pose, shape) = &shapes[0];
        let centre = pose.translation;
        let inside = shape.project_point(pose, centre, false);
        assert!(inside.is_inside, "centre of an obstacle box must be inside");
        let outside = shape.project_point(pose, centre + Vector::new(0.0, 0.0, 1.0), false);
        assert!(!outside.is_inside);
    }

    #[test]
    fn builtin_scenes_have_free_start_and_goal_and_blocked_shortcuts() {
        for name in scene::BUILTIN_NAMES {
            let s = Scene::builtin(name).expect("builtin");
            s.validate(name).expect("valid");
            let c = CollisionChecker::new(&s);
            assert!(c.is_free(&s.start), "{name}: start collides");
            assert!(c.is_free(&s.goal), "{name}: goal collides");
            // Every scene but `free` needs more than the straight segment.
            let straight = c.edge_free(&s.start, &s.goal);
            assert_eq!(
                straight,
                name == "free",
                "{name}: straight line free = {straight}"
            );
        }
    }

    #[test]
    fn narrow_passages_admit_the_right_orientation_only() {
        use std::f64::consts::FRAC_PI_2;
        // Maze: the 45 mm passage at x = 0 takes the 60 × 30 mm block turned by 90°.
        let maze = Scene::maze();
        let c = CollisionChecker::new(&maze);
        let turned = Se3::new(
            Vector3::zeros(),
            UnitQuaternion::from_euler_angles(0.0, 0.0, FRAC_PI_2),
        );
        assert!(c.is_free(&turned));
        assert!(!c.is_free(&Se3::identity()));
        // Crossing planes: flat in the first slit, upright in the second.
        let cp = Scene::crossing_planes();
        let c = CollisionChecker::new(&cp);
        let upright = UnitQuaternion::from_euler_angles(FRAC_PI_2, 0.0, 0.0);
        assert!(c.is_free(&Se3::from_xyz(-0.165, 0.0, 0.0)));
        assert!(!c.is_free(&Se3::new(Vector3::new(-0.165, 0.0, 0.0), upright)));
        assert!(c.is_free(&Se3::new(Vector3::new(0.165, 0.0, 0.0), upright)));
        assert!(!c.is_free(&Se3::from_xyz(0.165, 0.0, 0.0)));
        // Tunnels: the bar passes plate A (x = 0.15) only rolled to the slot's 35°.
        let t = Scene::tunnels(1, 2);
        let c = CollisionChecker::new(&t);
        let rolled = UnitQuaternion::from_euler_angles(35f64.to_radians(), 0.0, 0.0);
        assert!(c.is_free(&Se3::new(Vector3::new(0.15, 0.0, 0.0), rolled)));
        assert!(!c.is_free(&Se3::from_xyz(0.15, 0.0, 0.0)));
        // Silencer: it cannot drop straight out (crossmember), but can beside it.
        let sil = Scene::silencer();
        let c = CollisionChecker::new(&sil);
        assert!(!c.is_free(&Se3::from_xyz(0.0, 0.0, -0.15)));
        assert!(c.is_free(&Se3::from_xyz(-0.3, 0.0, 0.06)));
        assert!(c.is_free(&Se3::from_xyz(-0.3, 0.0, -0.15)));
        assert!(c.edge_free(
            &Se3::from_xyz(-0.3, 0.0, 0.06),
            &Se3::from_xyz(-0.3, 0.0, -0.15)
        ));
    }
}
