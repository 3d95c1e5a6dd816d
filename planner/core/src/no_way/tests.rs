use super::*;
use scene::{BUILTIN_NAMES, MeshData};
use std::cell::Cell;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

fn fixture(name: &str) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/scenes")
        .join(name);
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    scene.validate(name).expect("valid");
    scene
}

fn never() -> bool {
    false
}

/// The parts are the same up to rounding in the file's numbers.
fn same_parts(a: &[Part], b: &[Part]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(a, b)| match (&a.primitive, &b.primitive) {
                (Primitive::Box { half_extents_m: p }, Primitive::Box { half_extents_m: q }) => {
                    (p - q).norm() < 1e-12
                        && (a.pose.pos - b.pose.pos).norm() < 1e-12
                        && a.pose.rot.angle_to(&b.pose.rot) < 1e-12
                }
                _ => false,
            })
}

#[test]
fn the_fixtures_are_wall_hole_closed_and_with_a_22_mm_hole() {
    let wall_hole = Scene::wall_with_hole();
    let closed = fixture("wall-hole-closed.toml");
    assert!(same_parts(&closed.obstacles[..4], &wall_hole.obstacles));
    assert!(same_parts(
        &closed.obstacles[4..],
        &[Part::axis_box([0.01, 0.04, 0.04], [0.0; 3])]
    ));
    let narrow = fixture("wall-hole-22mm.toml");
    let built = Scene::wall_with_square_hole(0.022);
    assert!(same_parts(&narrow.obstacles, &built.obstacles));
    for s in [&closed, &narrow] {
        assert!(same_parts(&s.moving_object, &wall_hole.moving_object));
        assert_eq!(
            (s.bounds, s.start, s.goal),
            (wall_hole.bounds, wall_hole.start, wall_hole.goal)
        );
        assert!(s.route.is_empty());
        let c = CollisionChecker::new(s);
        assert!(c.is_free(&s.start) && c.is_free(&s.goal), "{}", s.name);
    }
}

#[test]
fn closed_wall_hole_has_certainly_no_way() {
    let scene = fixture("wall-hole-closed.toml");
    let t0 = Instant::now();
    let answer = prove(&scene, &never);
    eprintln!("wall-hole-closed: {:?}: {answer}", t0.elapsed());
    let NoWay::Certain(proof) = &answer else {
        panic!("{answer}");
    };
    assert!((proof.ball.radius_m - 0.01).abs() <= MARGIN_M, "{answer}");
    assert!(proof.cell_m <= proof.ball.radius_m / 3f64.sqrt() + 1e-12);
    // The wall's five boxes, the one closing the hole among them, and nothing else.
    let borders: Vec<usize> = proof.borders.iter().map(|o| o.index).collect();
    assert_eq!(borders, [0, 1, 2, 3, 4], "{answer}");
    assert_eq!(proof.borders[4].name, "obstacles[4] (box)");
    // The start's side of the wall: nearly half the grid.
    let reach = proof.ball.offset_m.norm();
    let cells = |extent: f64| ((extent + 2.0 * reach) / proof.cell_m).ceil();
    let share = proof.cells_reached as f64 / (cells(0.6) * cells(0.5) * cells(0.5));
    assert!(share > 0.4 && share < 0.5, "{share}: {answer}");
    let line = answer.to_string();
    assert!(
        line.starts_with("no way through: a ball of radius 10.0 mm"),
        "{line}"
    );
    assert!(line.contains("obstacles[4] (box)"), "{line}");
    // The planner's checker shares its shapes and gives the same proof.
    let checker = CollisionChecker::new(&scene);
    assert_eq!(prove_with(&scene, &checker, &never), answer);
}

#[test]
fn wall_hole_makes_no_claim_its_ball_passes() {
    let answer = prove(&Scene::wall_with_hole(), &never);
    let NoWay::NoClaim(NoClaim::Unproved(attempts)) = &answer else {
        panic!("{answer}");
    };
    assert_eq!(attempts.len(), MAX_BALLS);
    for a in attempts {
        assert!((a.ball.radius_m - 0.01).abs() < 1e-12);
        assert!(matches!(a.why, Unproved::GoalReached { .. }), "{answer}");
    }
    let line = answer.to_string();
    assert!(line.contains("reaches the goal"), "{line}");
}

#[test]
fn wall_hole_22mm_makes_no_claim_where_only_the_ball_passes() {
    // The S cannot pass a 22 mm hole, but its 10 mm ball can: the rule claims nothing.
    let scene = fixture("wall-hole-22mm.toml");
    let t0 = Instant::now();
    let answer = prove(&scene, &never);
    eprintln!("wall-hole-22mm: {:?}: {answer}", t0.elapsed());
    let NoWay::NoClaim(NoClaim::Unproved(attempts)) = &answer else {
        panic!("{answer}");
    };
    assert!(
        attempts
            .iter()
            .all(|a| matches!(a.why, Unproved::GoalReached { .. })),
        "{answer}"
    );
    // With an 8 mm hole the same ball is stopped.
    let mut closed = Scene::wall_with_square_hole(0.008);
    closed.route.clear();
    assert!(matches!(prove(&closed, &never), NoWay::Certain(_)));
}

/// A square sheet of two triangles, `half` m a side from its centre, in the x = 0 plane.
fn sheet(half: f64) -> MeshData {
    let v = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .map(|(y, z)| Vector3::new(0.0, y * half, z * half));
    MeshData::new("sheet.obj", v.to_vec(), vec![[0, 1, 2], [0, 2, 3]]).expect("valid")
}

fn mesh_part(mesh: MeshData) -> Part {
    Part {
        primitive: Primitive::Mesh {
            mesh: Arc::new(mesh),
        },
        pose: Se3::identity(),
    }
}

#[test]
fn an_object_of_open_sheets_makes_no_claim() {
    let mut scene = fixture("wall-hole-closed.toml");
    scene.moving_object = vec![mesh_part(sheet(0.02)), {
        let mut p = mesh_part(sheet(0.01));
        p.pose = Se3::from_xyz(0.03, 0.0, 0.0);
        p
    }];
    assert_eq!(scene.mesh_checks()[0].surface(), Surface::Open);
    assert!(inscribed_balls(&scene.moving_object).is_empty());
    let answer = prove(&scene, &never);
    assert_eq!(answer, NoWay::NoClaim(NoClaim::NoClosedPart));
    assert!(answer.to_string().contains("no closed part"), "{answer}");
    // A closed mesh of the same scale holds a ball (the deepest point the grid finds,
    // nearly the inscribed one), and that ball cannot pass.
    scene.moving_object = vec![mesh_part(MeshData::cuboid("box.obj", [0.02, 0.015, 0.012]))];
    let balls = inscribed_balls(&scene.moving_object);
    assert_eq!(balls.len(), 1);
    assert!(
        balls[0].radius_m <= 0.012 && balls[0].radius_m > 0.0119,
        "{:?}",
        balls[0]
    );
    assert!(balls[0].offset_m.z.abs() < 1e-4, "{:?}", balls[0]);
    assert!(matches!(prove(&scene, &never), NoWay::Certain(_)));
}

#[test]
fn balls_are_the_largest_of_closed_parts_first() {
    let parts = [
        Part::axis_box([0.05, 0.01, 0.02], [0.0, 0.1, 0.0]),
        mesh_part(sheet(0.2)),
        Part {
            primitive: Primitive::Sphere { radius_m: 0.015 },
            pose: Se3::from_xyz(0.0, 0.0, 0.03),
        },
        Part::axis_box([0.03, 0.015, 0.02], [0.0, 0.0, -0.02]),
    ];
    let balls = inscribed_balls(&parts);
    let got: Vec<(usize, f64)> = balls.iter().map(|b| (b.part, b.radius_m)).collect();
    // Two of 15 mm: the nearer the reference point first; the open sheet gives none.
    assert_eq!(got, [(3, 0.015), (2, 0.015), (0, 0.01)]);
    assert_eq!(balls[0].offset_m, Vector3::new(0.0, 0.0, -0.02));
}

#[test]
fn cells_touching_at_an_edge_or_a_corner_are_joined() {
    // Open cells only along a diagonal: each touches the next at a corner (3-D) or an
    // edge (one layer). The fill joins them; with the middle one blocked it cannot.
    let corners = |c: [usize; 3]| !(c[0] == c[1] && c[1] == c[2]);
    let edges = |c: [usize; 3]| c[0] != c[1];
    assert_eq!(
        flood([3, 3, 3], [0; 3], [2; 3], corners, &never),
        Flood::Reached(3)
    );
    assert_eq!(
        flood([3, 3, 1], [0; 3], [2, 2, 0], edges, &never),
        Flood::Reached(3)
    );
    let middle = |c: [usize; 3]| corners(c) || c == [1; 3];
    let Flood::Exhausted { reached, border } = flood([3, 3, 3], [0; 3], [2; 3], middle, &never)
    else {
        panic!("the goal was reached through a blocked cell");
    };
    assert_eq!((reached, border.len()), (1, 7));
}

#[test]
fn blocked_cells_collide_wherever_the_ball_lies_in_them() {
    // The certificate, checked against the planner's own verdict: the ball at the corners
    // and the centre of every blocked cell (a sample of them) collides.
    for scene in [fixture("wall-hole-closed.toml"), Scene::bug_trap()] {
        let ball = inscribed_balls(&scene.moving_object)[0];
        let reach = Vector3::repeat(ball.offset_m.norm());
        let grid = Grid::new(
            scene.bounds.min_m - reach,
            scene.bounds.max_m + reach,
            ball.radius_m,
        );
        let probe = CollisionChecker::new(&probe_scene(&scene));
        let mut cells = Cells::new(&grid, &probe, ball.radius_m);
        let mut balls = scene.clone();
        balls.moving_object = vec![Part {
            primitive: Primitive::Sphere {
                radius_m: ball.radius_m,
            },
            pose: Se3::identity(),
        }];
        balls.bounds.min_m = Vector3::repeat(-10.0);
        balls.bounds.max_m = Vector3::repeat(10.0);
        let checker = CollisionChecker::new(&balls);
        let (mut blocked, mut open) = (0, 0);
        let [nx, ny, nz] = grid.n;
        for i in (0..nx * ny * nz).step_by(97) {
            let c = [i % nx, (i / nx) % ny, i / (nx * ny)];
            if !cells.blocked(c) {
                open += 1;
                continue;
            }
            blocked += 1;
            for corner in 0..9 {
                let p = if corner == 8 {
                    grid.centre(c, c.map(|k| k + 1))
                } else {
                    let d = [0, 1, 2].map(|a| c[a] + ((corner >> a) & 1));
                    grid.centre(d, d)
                };
                assert!(
                    !checker.is_free(&Se3::from_xyz(p.x, p.y, p.z)),
                    "{}: cell {c:?} at {p:?}",
                    scene.name
                );
            }
        }
        assert!(
            blocked > 50 && open > 50,
            "{}: {blocked} {open}",
            scene.name
        );
    }
}

#[test]
fn a_stop_request_cancels() {
    let scene = fixture("wall-hole-closed.toml");
    assert_eq!(prove(&scene, &|| true), NoWay::Cancelled);
    // Asked again during the search (not only before it), it stops there too.
    let calls = Cell::new(0);
    let later = || {
        calls.set(calls.get() + 1);
        calls.get() > 1
    };
    assert_eq!(prove(&scene, &later), NoWay::Cancelled);
    assert_eq!(calls.get(), 2);
    assert_eq!(NoWay::Cancelled.to_string(), "no claim: cancelled");
}

#[test]
fn every_builtin_scene_has_a_way_for_its_balls() {
    for name in BUILTIN_NAMES {
        let scene = Scene::builtin(name).expect("builtin");
        let t0 = Instant::now();
        let answer = prove(&scene, &never);
        eprintln!("{name}: {:?}: {answer}", t0.elapsed());
        let NoWay::NoClaim(NoClaim::Unproved(attempts)) = &answer else {
            panic!("{name}: {answer}");
        };
        assert!(!attempts.is_empty(), "{name}");
    }
}
