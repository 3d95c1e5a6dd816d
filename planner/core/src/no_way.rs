//! A sound proof that the object has no way from start to goal, or no claim.
//!
//! The rule. Take a ball that lies wholly inside a closed part of the moving object: a
//! box's largest inscribed ball (at its centre, radius its smallest half extent), a
//! sphere, or for a mesh the planner holds solid (closed and wound outward, the repair's
//! [`Surface::ClosedOutward`]) a deep point found on a grid of its bounding box, with
//! radius its distance to the surface less [`MARGIN_M`]. Open sheets have no inside and
//! give no ball. Its centre sits at offset `o` from the reference point (object frame):
//! at `start·o` in the start pose, `goal·o` in the goal pose, and always within the
//! reference point's bounds grown by `|o|` on every side. Cover that box with cubic
//! cells. A cell is *blocked* when the ball collides wherever its centre lies in the cell:
//! with `h` the cell's half diagonal and `d` the distance from the cell's centre to the
//! obstacles, `d + h < r` (distance is 1-Lipschitz, so every point of the cell lies
//! nearer than `r` to an obstacle). Every other cell is open, even if only partly free.
//! Cells that touch (at a face, an edge or a corner) are joined. If the cells reached
//! from the start's cell through open cells do not include the goal's, the ball has no
//! way: a free path of its centre would pass from cell to touching cell through cells
//! each holding a free point, none blocked. Nor then has the object: it holds the ball,
//! so a free motion of the object carries the ball's centre along a free path. (Free as
//! solids are: the planner's checks agree along a continuous motion from a free start, as
//! the one overlap they pass, a closed mesh wholly inside another, cannot be entered
//! without crossing a surface.)
//!
//! The obstacles are the planner's, through its collision checker's shapes: primitives
//! and closed, outward meshes are solid, other meshes their triangles; touching counts as
//! a collision. `d` is the clearance of a ball of [`PROBE_RADIUS_M`] (the checker's own
//! query, exact for these pairs) plus that radius, an upper bound of the distance; a
//! blocked cell also keeps [`MARGIN_M`] below `r`.
//!
//! Cells have half diagonal `r / 2` (edge `r / √3`), larger where that would take more
//! than [`MAX_CELLS`]: still sound, only weaker (no cell can be blocked once `h ≥ r`, and
//! the ball is not tried). Cells are classified when the search first touches them,
//! through blocks of 2 to 32 cells a side certified blocked (`d + H < r`, `H` the block's
//! half diagonal) or open (no cell in it can be blocked) with one query, else split. The
//! search goes best-first towards the goal's cell, then breadth-first, and stops on
//! reaching it. The largest balls are tried, [`MAX_BALLS`] at most; one that cannot pass
//! is the proof.

use crate::collision::{CollisionChecker, DEFAULT_EDGE_RESOLUTION};
use crate::space::Weights;
use nalgebra::Vector3;
use parry3d_f64::math::{Pose, Vector};
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::TriMesh;
use scene::pose::Se3;
use scene::repair::Surface;
use scene::shapes::{part_shape, part_shapes};
use scene::{Part, Primitive, Scene};
use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};
use std::fmt;

/// Balls tried, largest first.
pub const MAX_BALLS: usize = 2;

/// Most cells of a ball's grid; a larger region takes larger cells.
pub const MAX_CELLS: usize = 1 << 22;

/// A cell's half diagonal per ball radius, when [`MAX_CELLS`] allows (edge `0.5·r·2/√3`).
pub const HALF_DIAGONAL_PER_RADIUS: f64 = 0.5;

/// What a mesh's ball keeps from its surface, and what a blocked cell keeps below the
/// ball's radius (m): room for rounding in the distances.
pub const MARGIN_M: f64 = 1e-6;

/// Radius of the ball whose clearance measures distance to the obstacles (m).
pub const PROBE_RADIUS_M: f64 = 1e-6;

/// Candidates per axis of the first grid over a mesh's bounding box.
const MESH_SAMPLES: usize = 16;

/// Refinements around the deepest mesh point so far, each 4× finer.
const MESH_REFINEMENTS: usize = 3;

/// Cells popped (or named) between two calls of the stop callback.
const STOP_EVERY: u64 = 4096;

/// Cells the flood fill takes best-first (towards the goal) before it takes the rest in
/// the cheapest order: a way is most often found within them, a proof needs them all.
const BEST_FIRST_CELLS: u64 = 1 << 16;

/// Block levels: cells, then blocks of 2, 4, …, 32 cells a side.
const LEVELS: usize = 6;

/// A ball inside the moving object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ball {
    /// The part of the object (index into `Scene::moving_object`) that holds it.
    pub part: usize,
    /// Radius, m.
    pub radius_m: f64,
    /// Its centre from the reference point, object frame (m).
    pub offset_m: Vector3<f64>,
}

/// An obstacle, by its place in `Scene::obstacles` (parts carry no names).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Obstacle {
    /// Index into `Scene::obstacles`.
    pub index: usize,
    /// `obstacles[i] (box)`, `(sphere)`, or `(mesh <file name>)`.
    pub name: String,
}

/// Why there is certainly no way.
#[derive(Clone, Debug, PartialEq)]
pub struct Proof {
    /// The ball that cannot pass.
    pub ball: Ball,
    /// Edge of the grid's cells (m).
    pub cell_m: f64,
    /// Open cells reachable from the start's cell.
    pub cells_reached: u64,
    /// The obstacles nearest to the blocked cells that touch reached ones, by index,
    /// deduplicated.
    pub borders: Vec<Obstacle>,
}

/// Why one ball proves nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unproved {
    /// The search reached the goal's cell (the ball may pass; the object may not).
    GoalReached {
        /// Cells reached on the way.
        cells_reached: u64,
    },
    /// The cells [`MAX_CELLS`] allows are too large to block anything (`h ≥ r`).
    GridTooCoarse,
    /// The cell of the ball's start or goal is blocked: the scene's start or goal
    /// collides.
    EndInCollision,
}

/// One ball tried and why it proves nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Attempt {
    /// The ball.
    pub ball: Ball,
    /// Edge of its grid's cells (m).
    pub cell_m: f64,
    /// Why it proves nothing.
    pub why: Unproved,
}

/// Why no claim is made.
#[derive(Clone, Debug, PartialEq)]
pub enum NoClaim {
    /// No part of the object is closed (only open sheets, or meshes whose inside cannot
    /// be told): no ball lies inside it.
    NoClosedPart,
    /// Every ball tried (largest first) may pass, or could not be tested.
    Unproved(Vec<Attempt>),
}

/// The answer of [`prove`].
#[derive(Clone, Debug, PartialEq)]
pub enum NoWay {
    /// There is certainly no way.
    Certain(Proof),
    /// Perhaps there is a way; nothing is claimed.
    NoClaim(NoClaim),
    /// The stop callback asked to stop.
    Cancelled,
}

/// Whether `scene`'s object certainly has no way from start to goal (see the module
/// docs). Builds the collision checker's obstacle shapes; `stop` is asked every few
/// thousand cells.
pub fn prove(scene: &Scene, stop: &dyn Fn() -> bool) -> NoWay {
    prove_by(scene, stop, || CollisionChecker::new(&probe_scene(scene)))
}

/// [`prove`] with the obstacle shapes of `checker`, built for `scene`'s obstacles,
/// shared rather than built again.
pub fn prove_with(scene: &Scene, checker: &CollisionChecker, stop: &dyn Fn() -> bool) -> NoWay {
    prove_by(scene, stop, || {
        checker.sharing_obstacles(
            &probe_scene(scene),
            Weights::default(),
            DEFAULT_EDGE_RESOLUTION,
        )
    })
}

/// The balls that lie wholly inside closed parts, one per part, largest first (then
/// nearest the reference point).
pub fn inscribed_balls(parts: &[Part]) -> Vec<Ball> {
    let mut balls: Vec<Ball> = parts
        .iter()
        .enumerate()
        .filter_map(|(i, p)| part_ball(i, p))
        .collect();
    balls.sort_by(|a, b| {
        b.radius_m
            .total_cmp(&a.radius_m)
            .then(a.offset_m.norm().total_cmp(&b.offset_m.norm()))
            .then(a.part.cmp(&b.part))
    });
    balls
}

fn probe_scene(scene: &Scene) -> Scene {
    Scene {
        moving_object: vec![Part {
            primitive: Primitive::Sphere {
                radius_m: PROBE_RADIUS_M,
            },
            pose: Se3::identity(),
        }],
        route: Vec::new(),
        ..scene.clone()
    }
}

fn prove_by(
    scene: &Scene,
    stop: &dyn Fn() -> bool,
    probe: impl FnOnce() -> CollisionChecker,
) -> NoWay {
    let balls = inscribed_balls(&scene.moving_object);
    if balls.is_empty() {
        return NoWay::NoClaim(NoClaim::NoClosedPart);
    }
    if stop() {
        return NoWay::Cancelled;
    }
    let probe = probe();
    let mut attempts = Vec::new();
    for ball in balls.into_iter().take(MAX_BALLS) {
        match try_ball(scene, &probe, ball, stop) {
            Tried::Proof(proof) => return NoWay::Certain(proof),
            Tried::Unproved(attempt) => attempts.push(attempt),
            Tried::Cancelled => return NoWay::Cancelled,
        }
    }
    NoWay::NoClaim(NoClaim::Unproved(attempts))
}

fn part_ball(part: usize, p: &Part) -> Option<Ball> {
    let (centre, radius_m) = match &p.primitive {
        Primitive::Box { half_extents_m } => (Vector3::zeros(), half_extents_m.min()),
        Primitive::Sphere { radius_m } => (Vector3::zeros(), *radius_m),
        Primitive::Mesh { mesh } => {
            if mesh.surface() != Surface::ClosedOutward {
                return None;
            }
            let shape = part_shape(p);
            let (c, depth) = deepest_point(shape.as_trimesh()?)?;
            (Vector3::new(c.x, c.y, c.z), depth - MARGIN_M)
        }
    };
    (radius_m > 0.0).then(|| Ball {
        part,
        radius_m,
        offset_m: p.pose.transform_point(&centre),
    })
}

/// The inside point of `mesh` (closed, outward) farthest from its surface that a grid
/// over its bounding box and refinements around the best find, with that distance (m).
fn deepest_point(mesh: &TriMesh) -> Option<(Vector, f64)> {
    let consider = |best: &mut Option<(Vector, f64)>, p: Vector| {
        let proj = mesh.project_local_point(p, false);
        let depth = (proj.point - p).length();
        if proj.is_inside && best.is_none_or(|(_, d)| depth > d) {
            *best = Some((p, depth));
        }
    };
    let aabb = mesh.local_aabb();
    let mut best = None;
    consider(&mut best, aabb.center());
    let mut step = (aabb.maxs - aabb.mins) / MESH_SAMPLES as f64;
    let at = |i: usize| i as f64 + 0.5;
    for i in 0..MESH_SAMPLES {
        for j in 0..MESH_SAMPLES {
            for k in 0..MESH_SAMPLES {
                let p = aabb.mins + Vector::new(at(i), at(j), at(k)) * step;
                consider(&mut best, p);
            }
        }
    }
    for _ in 0..MESH_REFINEMENTS {
        let (c, _) = best?;
        step /= 4.0;
        for i in -4..=4 {
            for j in -4..=4 {
                for k in -4..=4 {
                    let p = c + Vector::new(i as f64, j as f64, k as f64) * step;
                    consider(&mut best, p);
                }
            }
        }
    }
    best
}

/// One ball's answer.
enum Tried {
    Proof(Proof),
    Unproved(Attempt),
    Cancelled,
}

fn try_ball(scene: &Scene, probe: &CollisionChecker, ball: Ball, stop: &dyn Fn() -> bool) -> Tried {
    let reach = Vector3::repeat(ball.offset_m.norm());
    let grid = Grid::new(
        scene.bounds.min_m - reach,
        scene.bounds.max_m + reach,
        ball.radius_m,
    );
    let attempt = |why| {
        Tried::Unproved(Attempt {
            ball,
            cell_m: grid.cell_m,
            why,
        })
    };
    if grid.half_diagonal_m() >= ball.radius_m - MARGIN_M {
        return attempt(Unproved::GridTooCoarse);
    }
    let start = grid.cell_of(&scene.start.transform_point(&ball.offset_m));
    let goal = grid.cell_of(&scene.goal.transform_point(&ball.offset_m));
    let mut cells = Cells::new(&grid, probe, ball.radius_m);
    if cells.blocked(start) || cells.blocked(goal) {
        return attempt(Unproved::EndInCollision);
    }
    match flood(grid.n, start, goal, |c| cells.blocked(c), stop) {
        Flood::Reached(cells_reached) => attempt(Unproved::GoalReached { cells_reached }),
        Flood::Cancelled => Tried::Cancelled,
        Flood::Exhausted { reached, border } => match bordering(scene, &grid, &border, stop) {
            Some(borders) => Tried::Proof(Proof {
                ball,
                cell_m: grid.cell_m,
                cells_reached: reached,
                borders,
            }),
            None => Tried::Cancelled,
        },
    }
}

/// Cubic cells over a box, indexed `x + nx·(y + ny·z)`.
struct Grid {
    /// Lower corner (m).
    origin: Vector3<f64>,
    /// Edge (m).
    cell_m: f64,
    /// Cells per axis.
    n: [usize; 3],
}

impl Grid {
    /// Cells of half diagonal `HALF_DIAGONAL_PER_RADIUS · radius_m`, or larger to keep to
    /// [`MAX_CELLS`], covering `lo..hi`.
    fn new(lo: Vector3<f64>, hi: Vector3<f64>, radius_m: f64) -> Self {
        let extent = (hi - lo).map(|e| e.max(0.0));
        let mut cell_m = 2.0 * HALF_DIAGONAL_PER_RADIUS * radius_m / 3f64.sqrt();
        let count = |cell: f64| extent.map(|e| ((e / cell).ceil() as usize).max(1));
        let mut n = count(cell_m);
        while n.iter().map(|&k| k as f64).product::<f64>() > MAX_CELLS as f64 {
            let over = n.iter().map(|&k| k as f64).product::<f64>() / MAX_CELLS as f64;
            cell_m *= over.cbrt().max(1.0 + 1e-6);
            n = count(cell_m);
        }
        Grid {
            origin: lo,
            cell_m,
            n: [n.x, n.y, n.z],
        }
    }

    fn half_diagonal_m(&self) -> f64 {
        0.5 * 3f64.sqrt() * self.cell_m
    }

    /// The cell holding `p` (m), clamped to the grid.
    fn cell_of(&self, p: &Vector3<f64>) -> [usize; 3] {
        let mut c = [0; 3];
        for (a, c) in c.iter_mut().enumerate() {
            let i = ((p[a] - self.origin[a]) / self.cell_m).floor();
            *c = (i.max(0.0) as usize).min(self.n[a] - 1);
        }
        c
    }

    /// Centre of the cells `lo..hi` (m).
    fn centre(&self, lo: [usize; 3], hi: [usize; 3]) -> Vector3<f64> {
        Vector3::from_fn(|a, _| self.origin[a] + 0.5 * (lo[a] + hi[a]) as f64 * self.cell_m)
    }
}

const UNKNOWN: u8 = 0;
const OPEN: u8 = 1;
const BLOCKED: u8 = 2;
const MIXED: u8 = 3;

/// The cells of a grid, classified when first asked, through blocks of `2^l` cells a side.
struct Cells<'a> {
    grid: &'a Grid,
    probe: &'a CollisionChecker,
    radius_m: f64,
    /// Per level: blocks per axis and their states.
    levels: Vec<([usize; 3], Vec<u8>)>,
}

impl<'a> Cells<'a> {
    fn new(grid: &'a Grid, probe: &'a CollisionChecker, radius_m: f64) -> Self {
        let levels = (0..LEVELS)
            .map(|l| {
                let n = grid.n.map(|k| k.div_ceil(1 << l));
                (n, vec![UNKNOWN; n[0] * n[1] * n[2]])
            })
            .collect();
        Cells {
            grid,
            probe,
            radius_m,
            levels,
        }
    }

    /// The ball collides wherever its centre lies in cell `c` (by the certificate).
    fn blocked(&mut self, c: [usize; 3]) -> bool {
        for l in (0..LEVELS).rev() {
            let (n, _) = self.levels[l];
            let b = c.map(|k| k >> l);
            let i = b[0] + n[0] * (b[1] + n[1] * b[2]);
            let mut state = self.levels[l].1[i];
            if state == UNKNOWN {
                state = self.classify(l, b);
                self.levels[l].1[i] = state;
            }
            match state {
                OPEN => return false,
                BLOCKED => return true,
                _ => {}
            }
        }
        false
    }

    /// Block `b` of level `l`: blocked, open (no cell in it can be blocked) or mixed;
    /// a cell (level 0) is blocked or open.
    fn classify(&self, l: usize, b: [usize; 3]) -> u8 {
        let (g, r) = (self.grid, self.radius_m);
        let lo = b.map(|k| k << l);
        let hi = [0, 1, 2].map(|a| ((b[a] + 1) << l).min(g.n[a]));
        let count = Vector3::from_fn(|a, _| (hi[a] - lo[a]) as f64);
        // Half diagonals of the block and of its cells' centres (m).
        let block = 0.5 * g.cell_m * count.norm();
        let centres = 0.5 * g.cell_m * count.map(|k| k - 1.0).norm();
        let cap = r + centres;
        let c = g.centre(lo, hi);
        let clearance = self
            .probe
            .clearance_up_to_m(&Se3::from_xyz(c.x, c.y, c.z), cap);
        // The distance from the centre to the obstacles: at most `near` below the cap
        // (at or above it nothing is blocked); exactly `near` when the probe is clear.
        let near = clearance + PROBE_RADIUS_M;
        if near + block < r - MARGIN_M {
            BLOCKED
        } else if l == 0 || (clearance > 0.0 && near - centres + g.half_diagonal_m() >= r) {
            OPEN
        } else {
            MIXED
        }
    }
}

/// How a flood fill ended.
#[derive(Debug, PartialEq)]
enum Flood {
    /// The goal's cell was reached, after this many cells.
    Reached(u64),
    /// Every reachable cell was reached without the goal's: their count, and the blocked
    /// cells touching them.
    Exhausted {
        reached: u64,
        border: Vec<u32>,
    },
    Cancelled,
}

/// The 26 cells that touch a cell: at a face, an edge or a corner.
const NEIGHBOURS: [[isize; 3]; 26] = {
    let mut out = [[0; 3]; 26];
    let mut k = 0;
    let mut i = 0;
    while i < 27 {
        let d = [i % 3 - 1, (i / 3) % 3 - 1, i / 9 - 1];
        if i != 13 {
            out[k] = [d[0] as isize, d[1] as isize, d[2] as isize];
            k += 1;
        }
        i += 1;
    }
    out
};

/// Flood fill over the open cells of an `n` grid (26 neighbours) from `start` until it
/// reaches `goal`: best-first by distance to `goal` for the first [`BEST_FIRST_CELLS`],
/// then breadth-first (the order no longer matters once the whole region may be needed,
/// and a queue is cheaper than a heap).
/// `blocked` is asked once per cell touched.
fn flood(
    n: [usize; 3],
    start: [usize; 3],
    goal: [usize; 3],
    mut blocked: impl FnMut([usize; 3]) -> bool,
    stop: &dyn Fn() -> bool,
) -> Flood {
    const REACHED: u8 = 1;
    const BORDER: u8 = 2;
    let index = |c: [usize; 3]| c[0] + n[0] * (c[1] + n[1] * c[2]);
    let coords = |i: usize| [i % n[0], (i / n[0]) % n[1], i / (n[0] * n[1])];
    let key = |c: [usize; 3]| -> u64 {
        let d = [0, 1, 2].map(|a| c[a].abs_diff(goal[a]) as u64);
        d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    };
    if start == goal {
        return Flood::Reached(1);
    }
    let mut marks = vec![0u8; n[0] * n[1] * n[2]];
    let mut heap = BinaryHeap::new();
    let mut queue = VecDeque::new();
    let mut border = Vec::new();
    marks[index(start)] = REACHED;
    heap.push(Reverse((key(start), index(start) as u32)));
    let mut reached = 1u64;
    let mut popped = 0u64;
    loop {
        let best_first = popped < BEST_FIRST_CELLS;
        let next = if best_first {
            heap.pop().map(|Reverse((_, i))| i)
        } else {
            queue.extend(heap.drain().map(|Reverse((_, i))| i));
            queue.pop_front()
        };
        let Some(i) = next else {
            return Flood::Exhausted { reached, border };
        };
        popped += 1;
        if popped.is_multiple_of(STOP_EVERY) && stop() {
            return Flood::Cancelled;
        }
        let c = coords(i as usize);
        for d in NEIGHBOURS {
            let mut m = [0; 3];
            let inside = (0..3).all(|a| match c[a].checked_add_signed(d[a]) {
                Some(k) if k < n[a] => {
                    m[a] = k;
                    true
                }
                _ => false,
            });
            if !inside || marks[index(m)] != 0 {
                continue;
            }
            let j = index(m);
            if blocked(m) {
                marks[j] = BORDER;
                border.push(j as u32);
                continue;
            }
            if m == goal {
                return Flood::Reached(reached + 1);
            }
            marks[j] = REACHED;
            reached += 1;
            if best_first {
                heap.push(Reverse((key(m), j as u32)));
            } else {
                queue.push_back(j as u32);
            }
        }
    }
}

/// The obstacles nearest to the centres of the `border` cells, by index; `None` when
/// `stop` asks to stop.
fn bordering(
    scene: &Scene,
    grid: &Grid,
    border: &[u32],
    stop: &dyn Fn() -> bool,
) -> Option<Vec<Obstacle>> {
    let shapes = part_shapes(&scene.obstacles);
    let boxes: Vec<_> = shapes
        .iter()
        .map(|(pose, shape)| shape.compute_aabb(pose))
        .collect();
    let mut seen = vec![false; shapes.len()];
    let [nx, ny, _] = grid.n;
    for (k, &i) in border.iter().enumerate() {
        if (k as u64 + 1).is_multiple_of(STOP_EVERY) && stop() {
            return None;
        }
        let i = i as usize;
        let c = [i % nx, (i / nx) % ny, i / (nx * ny)];
        let p = grid.centre(c, c.map(|k| k + 1));
        let p = Vector::new(p.x, p.y, p.z);
        let mut nearest = (f64::INFINITY, None);
        for (o, ((pose, shape), aabb)) in shapes.iter().zip(&boxes).enumerate() {
            if aabb.distance_to_point(&Pose::IDENTITY, p, true) >= nearest.0 {
                continue;
            }
            let d = shape.distance_to_point(pose, p, true);
            if d < nearest.0 {
                nearest = (d, Some(o));
            }
        }
        if let (_, Some(o)) = nearest {
            seen[o] = true;
        }
    }
    Some(
        seen.iter()
            .enumerate()
            .filter(|(_, s)| **s)
            .map(|(index, _)| Obstacle {
                index,
                name: obstacle_name(index, &scene.obstacles[index]),
            })
            .collect(),
    )
}

fn obstacle_name(i: usize, part: &Part) -> String {
    match &part.primitive {
        Primitive::Box { .. } => format!("obstacles[{i}] (box)"),
        Primitive::Sphere { .. } => format!("obstacles[{i}] (sphere)"),
        Primitive::Mesh { mesh } => {
            let file = std::path::Path::new(&mesh.source)
                .file_name()
                .map_or(mesh.source.clone(), |f| f.to_string_lossy().into_owned());
            format!("obstacles[{i}] (mesh {file})")
        }
    }
}

impl fmt::Display for Ball {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "a ball of radius {:.1} mm inside the object (moving_object[{}])",
            self.radius_m * 1e3,
            self.part
        )
    }
}

impl fmt::Display for Proof {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<&str> = self.borders.iter().map(|o| o.name.as_str()).collect();
        write!(
            f,
            "no way through: {} cannot pass from start to goal (its reachable region, {} cells of {:.1} mm, is bordered by obstacles: {})",
            self.ball,
            self.cells_reached,
            self.cell_m * 1e3,
            names.join(", ")
        )
    }
}

impl fmt::Display for Attempt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let grid = self.cell_m * 1e3;
        match self.why {
            Unproved::GoalReached { cells_reached } => write!(
                f,
                "{} reaches the goal on a {grid:.1} mm grid ({cells_reached} cells)",
                self.ball
            ),
            Unproved::GridTooCoarse => {
                write!(f, "{}: a {grid:.1} mm grid is too coarse for it", self.ball)
            }
            Unproved::EndInCollision => {
                write!(f, "{} collides at the start or the goal", self.ball)
            }
        }
    }
}

impl fmt::Display for NoClaim {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NoClaim::NoClosedPart => write!(
                f,
                "no claim: the object has no closed part (open sheets only), so no ball lies inside it"
            ),
            NoClaim::Unproved(attempts) => {
                let each: Vec<String> = attempts.iter().map(Attempt::to_string).collect();
                write!(f, "no claim: {}", each.join("; "))
            }
        }
    }
}

impl fmt::Display for NoWay {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NoWay::Certain(proof) => proof.fmt(f),
            NoWay::NoClaim(why) => why.fmt(f),
            NoWay::Cancelled => write!(f, "no claim: cancelled"),
        }
    }
}

#[cfg(test)]
mod tests;
