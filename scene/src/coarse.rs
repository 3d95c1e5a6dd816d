//! A person's coarse way from start to goal: what someone who sees the scene but does not
//! know the way would plan. Positions only, no orientations: the reference point's way
//! through the free space for a ball as wide as the object's thinnest part (a person sees
//! which openings the object might pass, not at which angle), found by A* over a grid of
//! the scene's bounds and shortened along straight lines of sight.
//!
//! The ball is a necessary condition only: every opening the object can pass, the ball
//! passes, but the ball passes some the object cannot (it must then be turned, or it does
//! not fit at all). That is the newcomer's handicap, on purpose.

use crate::shapes::{part_shape, to_parry};
use crate::{Primitive, Scene};
use nalgebra::Vector3;
use parry3d_f64::bounding_volume::BoundingVolume;
use parry3d_f64::math::Vector;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Grid nodes along the bounds' longest side (the others get the same spacing): at most
/// 96³ ≈ 885 k nodes, planned in well under a second.
pub const NODES_ALONG_LONGEST: usize = 96;

/// The coarse way and how it was found.
#[derive(Debug, Clone, PartialEq)]
pub struct CoarseWay {
    /// The reference point's way, scene frame, m: the start's position first, the goal's
    /// last, straight lines between.
    pub points_m: Vec<Vector3<f64>>,
    /// Radius of the ball planned for, m (half the object's thinnest width).
    pub body_radius_m: f64,
    /// Grid spacing, m.
    pub cell_m: f64,
    /// Grid nodes along x, y, z.
    pub nodes: [usize; 3],
    /// Nodes whose ball meets an obstacle.
    pub blocked_nodes: usize,
    /// False when the grid holds no way from start to goal: `points_m` is then the
    /// straight line (a person heads for the goal and feels their way).
    pub found: bool,
}

impl Scene {
    /// The object's thinnest width, m: the smallest side of any of its parts' boxes (a
    /// box's smallest full extent, a sphere's diameter, a mesh's smallest side of its box
    /// in the part's frame). What a person judges an opening by.
    pub fn object_thinnest_width_m(&self) -> f64 {
        self.moving_object
            .iter()
            .map(|p| match &p.primitive {
                Primitive::Box { half_extents_m: h } => 2.0 * h.min(),
                Primitive::Sphere { radius_m } => 2.0 * radius_m,
                Primitive::Mesh { mesh } => {
                    let mut lo = Vector3::repeat(f64::INFINITY);
                    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
                    for v in &mesh.vertices_m {
                        lo = lo.inf(v);
                        hi = hi.sup(v);
                    }
                    (hi - lo).min()
                }
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The coarse way of a person who sees this scene (see the module docs). Never fails:
    /// without a way through the grid it gives the straight line, `found` false.
    pub fn coarse_way(&self) -> CoarseWay {
        let radius = 0.5 * self.object_thinnest_width_m();
        let (lo, hi) = (self.bounds.min_m, self.bounds.max_m);
        let extent = hi - lo;
        let cell = (extent.max() / (NODES_ALONG_LONGEST - 1) as f64).max(1e-6);
        let nodes = [0, 1, 2].map(|i| (extent[i] / cell).floor() as usize + 1);
        let grid = Grid { lo, cell, n: nodes };
        // A node is blocked when the ball there meets an obstacle, with half a cell of
        // slack so that an opening the ball just fits is not lost between nodes.
        let clearance = (radius - 0.5 * cell).max(0.0);
        let mut blocked = vec![false; grid.len()];
        for part in &self.obstacles {
            let shape = part_shape(part);
            let pose = to_parry(&part.pose);
            let aabb = shape.compute_aabb(&pose).loosened(clearance);
            let (a, b) = (grid.index_range(aabb.mins), grid.index_range(aabb.maxs));
            let query = |p: Vector3<f64>| {
                let q = shape.project_point(&pose, Vector::new(p.x, p.y, p.z), false);
                let d = (q.point - Vector::new(p.x, p.y, p.z)).length();
                (q.is_inside, d)
            };
            grid.mark(&query, clearance, &mut blocked, a, b);
        }
        let blocked_nodes = blocked.iter().filter(|b| **b).count();
        let (start, goal) = (self.start.pos, self.goal.pos);
        let (s, g) = (grid.nearest(&start), grid.nearest(&goal));
        // Start and goal are free configurations: their nodes count as free whatever the
        // rounding to the grid says.
        blocked[grid.id(s)] = false;
        blocked[grid.id(g)] = false;
        let (points_m, found) = match grid.a_star(&blocked, s, g) {
            Some(path) => {
                let mut points = vec![start];
                points.extend(
                    grid.shortened(&blocked, &path)
                        .into_iter()
                        .map(|n| grid.point(n)),
                );
                points.push(goal);
                points.dedup_by(|a, b| (*a - *b).norm() < 1e-9);
                (points, true)
            }
            None => (vec![start, goal], false),
        };
        CoarseWay {
            points_m,
            body_radius_m: radius,
            cell_m: cell,
            nodes,
            blocked_nodes,
            found,
        }
    }
}

struct Grid {
    lo: Vector3<f64>,
    cell: f64,
    n: [usize; 3],
}

impl Grid {
    fn len(&self) -> usize {
        self.n[0] * self.n[1] * self.n[2]
    }

    fn id(&self, c: [usize; 3]) -> usize {
        (c[2] * self.n[1] + c[1]) * self.n[0] + c[0]
    }

    fn point(&self, c: [usize; 3]) -> Vector3<f64> {
        self.lo + Vector3::new(c[0] as f64, c[1] as f64, c[2] as f64) * self.cell
    }

    fn nearest(&self, p: &Vector3<f64>) -> [usize; 3] {
        [0, 1, 2].map(|i| {
            let x = ((p[i] - self.lo[i]) / self.cell).round();
            (x.max(0.0) as usize).min(self.n[i] - 1)
        })
    }

    /// The node indices around `v` (parry vector), clamped to the grid.
    fn index_range(&self, v: Vector) -> [usize; 3] {
        let v = [v.x, v.y, v.z];
        [0, 1, 2].map(|i| {
            let x = ((v[i] - self.lo[i]) / self.cell).round();
            (x.max(0.0) as usize).min(self.n[i] - 1)
        })
    }

    /// A* over the 26-neighbourhood, Euclidean costs and heuristic; the nodes from `s` to
    /// `g`, or `None` when no free way joins them.
    fn a_star(&self, blocked: &[bool], s: [usize; 3], g: [usize; 3]) -> Option<Vec<[usize; 3]>> {
        let h = |c: [usize; 3]| {
            let d = [0, 1, 2].map(|i| c[i] as f64 - g[i] as f64);
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
        };
        let mut cost = vec![f64::INFINITY; self.len()];
        let mut from = vec![usize::MAX; self.len()];
        let mut closed = vec![false; self.len()];
        let mut open = BinaryHeap::new();
        cost[self.id(s)] = 0.0;
        // Non-negative f64s order like their bit patterns.
        open.push(Reverse((h(s).to_bits(), self.id(s))));
        let goal = self.id(g);
        while let Some(Reverse((_, id))) = open.pop() {
            if id == goal {
                let mut path = vec![g];
                let mut at = id;
                while from[at] != usize::MAX {
                    at = from[at];
                    path.push(self.coords(at));
                }
                path.reverse();
                return Some(path);
            }
            if std::mem::replace(&mut closed[id], true) {
                continue;
            }
            let c = self.coords(id);
            for dz in -1i64..=1 {
                for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        if dx == 0 && dy == 0 && dz == 0 {
                            continue;
                        }
                        let d = [dx, dy, dz];
                        let mut m = [0usize; 3];
                        let mut inside = true;
                        for i in 0..3 {
                            let v = c[i] as i64 + d[i];
                            inside &= v >= 0 && v < self.n[i] as i64;
                            m[i] = v.max(0) as usize;
                        }
                        if !inside || blocked[self.id(m)] {
                            continue;
                        }
                        let step = ((dx * dx + dy * dy + dz * dz) as f64).sqrt();
                        let next = cost[id] + step;
                        let mid = self.id(m);
                        if next < cost[mid] {
                            cost[mid] = next;
                            from[mid] = id;
                            open.push(Reverse(((next + h(m)).to_bits(), mid)));
                        }
                    }
                }
            }
        }
        None
    }

    /// Marks the nodes in the box of nodes `a..=b` whose ball of radius `clearance` meets
    /// the shape, `query(p)` giving (inside, distance to the surface) at a point. One query
    /// at a box's centre settles the whole box when the surface is farther than the box's
    /// half diagonal (all inside, or all clear); else the box is split in eight: the cost
    /// follows the surface, not the volume (a 1.3 M-triangle sphere of 0.25 m in a 96³ grid:
    /// 0.3 s, against 7.7 s node by node).
    fn mark(
        &self,
        query: &impl Fn(Vector3<f64>) -> (bool, f64),
        clearance: f64,
        blocked: &mut [bool],
        a: [usize; 3],
        b: [usize; 3],
    ) {
        let (pa, pb) = (self.point(a), self.point(b));
        let half_diagonal = 0.5 * (pb - pa).norm();
        let (inside, d) = query(0.5 * (pa + pb));
        if a == b {
            let id = self.id(a);
            blocked[id] |= inside || d < clearance;
            return;
        }
        let settled = if inside {
            d >= half_diagonal
        } else {
            d - clearance >= half_diagonal
        };
        if settled {
            if inside {
                for k in a[2]..=b[2] {
                    for j in a[1]..=b[1] {
                        for i in a[0]..=b[0] {
                            blocked[self.id([i, j, k])] = true;
                        }
                    }
                }
            }
            return;
        }
        // Split each axis that has more than one node: halves a..=m and m+1..=b.
        let halves = |i: usize| {
            let m = (a[i] + b[i]) / 2;
            if a[i] == b[i] {
                [(a[i], b[i]), (a[i], b[i])]
            } else {
                [(a[i], m), (m + 1, b[i])]
            }
        };
        let (hx, hy, hz) = (halves(0), halves(1), halves(2));
        for (zi, z) in hz.iter().enumerate() {
            if zi == 1 && a[2] == b[2] {
                continue;
            }
            for (yi, y) in hy.iter().enumerate() {
                if yi == 1 && a[1] == b[1] {
                    continue;
                }
                for (xi, x) in hx.iter().enumerate() {
                    if xi == 1 && a[0] == b[0] {
                        continue;
                    }
                    self.mark(query, clearance, blocked, [x.0, y.0, z.0], [x.1, y.1, z.1]);
                }
            }
        }
    }

    fn coords(&self, id: usize) -> [usize; 3] {
        let i = id % self.n[0];
        let j = (id / self.n[0]) % self.n[1];
        [i, j, id / (self.n[0] * self.n[1])]
    }

    /// True when the straight line between two nodes stays on free nodes (checked every
    /// quarter cell, at the nearest node).
    fn sight(&self, blocked: &[bool], a: [usize; 3], b: [usize; 3]) -> bool {
        let (pa, pb) = (self.point(a), self.point(b));
        let steps = ((pb - pa).norm() / (0.25 * self.cell)).ceil().max(1.0) as usize;
        (0..=steps).all(|k| {
            let p = pa + (pb - pa) * (k as f64 / steps as f64);
            !blocked[self.id(self.nearest(&p))]
        })
    }

    /// The path's nodes where it must turn: from each kept node, the farthest node in
    /// sight. Drops the first and last node (the caller puts start and goal there).
    fn shortened(&self, blocked: &[bool], path: &[[usize; 3]]) -> Vec<[usize; 3]> {
        let mut kept = Vec::new();
        let mut at = 0;
        while at + 1 < path.len() {
            let mut next = at + 1;
            for j in (at + 2..path.len()).rev() {
                if self.sight(blocked, path[at], path[j]) {
                    next = j;
                    break;
                }
            }
            if next + 1 < path.len() {
                kept.push(path[next]);
            }
            at = next;
        }
        kept
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Part, Se3};

    /// Every segment of the way keeps the ball (less the grid's half-cell slack) off the
    /// box, checked every millimetre.
    fn clear_of_box(way: &CoarseWay) -> bool {
        let clearance = way.body_radius_m - 0.5 * way.cell_m;
        way.points_m.windows(2).all(|w| {
            let n = ((w[1] - w[0]).norm() / 1e-3).ceil() as usize;
            (0..=n).all(|k| {
                let p = w[0] + (w[1] - w[0]) * (k as f64 / n.max(1) as f64);
                let out = (p.abs() - Vector3::new(0.03, 0.08, 0.08)).map(|v| v.max(0.0));
                out.norm() >= clearance - 1e-3
            })
        })
    }

    #[test]
    fn the_way_goes_around_a_box_between_start_and_goal() {
        let scene = Scene::box_between();
        let way = scene.coarse_way();
        assert!(way.found);
        assert!((way.body_radius_m - 0.01).abs() < 1e-12);
        assert_eq!(way.points_m.first(), Some(&scene.start.pos));
        assert_eq!(way.points_m.last(), Some(&scene.goal.pos));
        // Around the box: at least one turn, and the way is longer than the straight line
        // by about the detour (past a 0.08 m half side, ±1 cm of grid and shortening).
        assert!(way.points_m.len() >= 3, "{:?}", way.points_m);
        let length: f64 = way.points_m.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
        let detour = 2.0 * (0.15f64.hypot(0.08 + 0.01) - 0.15);
        assert!(length > 0.3 + 0.5 * detour, "{length}");
        assert!(length < 0.3 + 2.0 * detour + 0.1, "{length}");
        assert!(clear_of_box(&way), "{:?}", way.points_m);
        assert!(way.blocked_nodes > 0);
    }

    #[test]
    fn an_opening_narrower_than_the_object_s_thinnest_part_is_not_taken() {
        // The wall-hole's wall, its 80 mm hole closed down to 15 mm: a 20 mm stick does not
        // pass, so there is no way and the straight line is given.
        let closed = Scene::wall_with_square_hole(0.015);
        let way = closed.coarse_way();
        assert!((closed.object_thinnest_width_m() - 0.02).abs() < 1e-12);
        assert!(!way.found);
        assert_eq!(way.points_m, vec![closed.start.pos, closed.goal.pos]);
        // The 80 mm hole: a way through it, within its frame.
        let open = Scene::wall_with_hole();
        let way = open.coarse_way();
        assert!(way.found);
        for w in way.points_m.windows(2) {
            if w[0].x < 0.0 && w[1].x > 0.0 {
                let t = -w[0].x / (w[1].x - w[0].x);
                let at_wall = w[0] + (w[1] - w[0]) * t;
                assert!(
                    at_wall.y.abs() < 0.04 && at_wall.z.abs() < 0.04,
                    "{at_wall:?}"
                );
            }
        }
    }

    #[test]
    fn a_closed_mesh_is_blocked_inside_and_gone_around() {
        let mut scene = Scene::box_between();
        let sphere = crate::MeshData::bumpy_sphere("sphere.obj", 0.1, 16, 32);
        scene.obstacles = vec![Part {
            primitive: Primitive::Mesh {
                mesh: std::sync::Arc::new(sphere),
            },
            pose: Se3::identity(),
        }];
        let way = scene.coarse_way();
        assert!(way.found);
        // Its inside counts, not only a shell around its surface: at least the nodes of
        // a 0.09 m ball.
        let inner = 4.0 / 3.0 * std::f64::consts::PI * 0.09f64.powi(3) / way.cell_m.powi(3);
        assert!(
            way.blocked_nodes as f64 > inner,
            "{} {inner}",
            way.blocked_nodes
        );
        // Around it: no point of the way within 8 cm of its centre.
        for w in way.points_m.windows(2) {
            for k in 0..=100 {
                let p = w[0] + (w[1] - w[0]) * (f64::from(k) / 100.0);
                assert!(p.norm() > 0.08, "{p:?} on {:?}", way.points_m);
            }
        }
    }

    #[test]
    fn no_obstacle_gives_the_straight_line() {
        let free = Scene::free();
        let way = free.coarse_way();
        assert!(way.found);
        assert_eq!(way.points_m, vec![free.start.pos, free.goal.pos]);
        assert_eq!(way.blocked_nodes, 0);
    }
}
