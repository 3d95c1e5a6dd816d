//! Solution paths: shortcut smoothing with re-validation, and export as CSV or JSON.
//!
//! Shortcutting (the standard random-pair method): pick two waypoints `i < j` at random;
//! if the straight edge between them is free at the checker's resolution, drop the
//! waypoints in between. Every kept edge is validated by the same
//! [`CollisionChecker::edge_free`] that validated the tree's edges, so a smoothed path is
//! exactly as safe as the raw one.

use crate::collision::CollisionChecker;
use crate::space::ConfigSpace;
use rand::{Rng, RngCore};
use scene::pose::Se3;
use serde::Serialize;
use std::fmt::Write as _;

/// Shortcuts `path` with `attempts` random pairs; returns the shorter path (first and last
/// waypoints kept). Deterministic for a given `rng` state.
pub fn shortcut(
    checker: &CollisionChecker,
    path: &[Se3],
    attempts: u32,
    rng: &mut dyn RngCore,
) -> Vec<Se3> {
    let mut p = path.to_vec();
    for _ in 0..attempts {
        if p.len() < 3 {
            break;
        }
        let i = rng.random_range(0..p.len() - 2);
        let j = rng.random_range(i + 2..p.len());
        if checker.edge_free(&p[i], &p[j]) {
            p.drain(i + 1..j);
        }
    }
    p
}

/// One exported waypoint: position (m), quaternion `(w, x, y, z)` (the order used in
/// every export), and cumulative weighted length (I-RRT eq. 2) from the start.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct Waypoint {
    /// Position x, y, z (m, scene frame).
    pub position_m: [f64; 3],
    /// Orientation quaternion w, x, y, z.
    pub quaternion_wxyz: [f64; 4],
    /// Cumulative weighted length from the start (weighted m).
    pub arc_length: f64,
}

/// The waypoints of `path` for export.
pub fn waypoints(space: &dyn ConfigSpace, path: &[Se3]) -> Vec<Waypoint> {
    let mut s = 0.0;
    path.iter()
        .enumerate()
        .map(|(i, q)| {
            if i > 0 {
                s += space.distance(&path[i - 1], q);
            }
            let r = q.rot.quaternion();
            Waypoint {
                position_m: [q.pos.x, q.pos.y, q.pos.z],
                quaternion_wxyz: [r.w, r.i, r.j, r.k],
                arc_length: s,
            }
        })
        .collect()
}

/// CSV with header `x_m,y_m,z_m,qw,qx,qy,qz,arc_length`.
pub fn to_csv(space: &dyn ConfigSpace, path: &[Se3]) -> String {
    let mut out = String::from("x_m,y_m,z_m,qw,qx,qy,qz,arc_length\n");
    for w in waypoints(space, path) {
        let [x, y, z] = w.position_m;
        let [qw, qx, qy, qz] = w.quaternion_wxyz;
        let _ = writeln!(out, "{x},{y},{z},{qw},{qx},{qy},{qz},{}", w.arc_length);
    }
    out
}

/// JSON array of [`Waypoint`]s.
pub fn to_json(space: &dyn ConfigSpace, path: &[Se3]) -> String {
    serde_json::to_string_pretty(&waypoints(space, path)).unwrap_or_else(|_| "[]".into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::space::{Se3Space, Weights};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use scene::Scene;

    #[test]
    fn shortcut_removes_detours_but_not_through_walls() {
        let scene = Scene::wall_with_hole();
        let c = CollisionChecker::new(&scene);
        // A zig-zag on the start side: shortcut to its two ends.
        let zig: Vec<Se3> = (0..9)
            .map(|i| {
                Se3::from_xyz(
                    -0.25 + 0.01 * i as f64,
                    if i % 2 == 0 { 0.0 } else { 0.1 },
                    0.0,
                )
            })
            .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let s = shortcut(&c, &zig, 200, &mut rng);
        assert_eq!(s, vec![zig[0], zig[8]]);
        // Through a 300 mm hole from one corner to the other: the direct edge hits the
        // wall, so a waypoint stays, and every kept edge is free.
        let c = CollisionChecker::new(&Scene::wall_with_square_hole(0.3));
        let via = [
            Se3::from_xyz(-0.2, 0.2, 0.0),
            Se3::from_xyz(-0.15, 0.0, 0.0),
            Se3::from_xyz(0.15, 0.0, 0.0),
            Se3::from_xyz(0.2, 0.2, 0.0),
        ];
        assert!(via.windows(2).all(|w| c.edge_free(&w[0], &w[1])));
        assert!(!c.edge_free(&via[0], &via[3]));
        let s = shortcut(&c, &via, 200, &mut rng);
        assert!(s.len() == 3, "{s:?}");
        assert!(s.windows(2).all(|w| c.edge_free(&w[0], &w[1])));
        assert_eq!((s[0], s[2]), (via[0], via[3]));
    }

    #[test]
    fn exports_have_arc_length_and_quaternions() {
        let space = Se3Space::new(Scene::wall_with_hole().bounds, Weights::default());
        let p = [Se3::from_xyz(0.0, 0.0, 0.0), Se3::from_xyz(0.1, 0.0, 0.0)];
        let csv = to_csv(&space, &p);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "x_m,y_m,z_m,qw,qx,qy,qz,arc_length");
        assert_eq!(lines[2], "0.1,0,0,1,0,0,0,0.1");
        let json: serde_json::Value = serde_json::from_str(&to_json(&space, &p)).expect("json");
        assert_eq!(json[1]["arc_length"], 0.1);
        assert_eq!(json[0]["quaternion_wxyz"][0], 1.0);
    }
}
