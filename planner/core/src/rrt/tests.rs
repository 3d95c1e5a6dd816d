//! Tests of the RRT-Connect planner (kept beside `rrt.rs` for length).

use super::*;
use crate::collision::EdgeCheck;
use crate::space::Weights;
use std::time::Instant;

/// Runs until solved or `max_iter`; returns the iterations used.
fn run(planner: &mut Planner, max_iter: u64, user: Option<&Se3>) -> Option<u64> {
    for _ in 0..max_iter {
        if planner.iterate(user).solved {
            return Some(planner.stats().iterations);
        }
    }
    None
}

fn easy() -> Scene {
    Scene::wall_with_square_hole(0.30)
}

#[test]
fn solves_an_easy_scene_with_valid_path() {
    let scene = easy();
    for seed in 1..=4 {
        let mut p = Planner::new(&scene, PlannerParams::default(), seed).expect("planner");
        let iters = run(&mut p, 2_000, None).unwrap_or_else(|| panic!("seed {seed} unsolved"));
        let path = p.solution().expect("solution");
        assert_eq!(path.first(), Some(&scene.start));
        assert_eq!(path.last(), Some(&scene.goal));
        for w in path.windows(2) {
            assert!(p.checker().edge_free(&w[0], &w[1]), "seed {seed}: bad edge");
        }
        let raw = p.raw_solution().expect("raw");
        for w in raw.windows(2) {
            assert!(
                p.checker().edge_free(&w[0], &w[1]),
                "seed {seed}: bad raw edge"
            );
            assert!(p.space().distance(&w[0], &w[1]) <= p.params().step + 1e-12);
        }
        let len = |q: &[Se3]| crate::space::path_length(p.space(), q);
        assert!(len(path) <= len(raw) + 1e-12 && path.len() <= raw.len());
        let s = p.stats();
        assert_eq!(
            (s.iterations, s.trees, s.best_distance_to_goal),
            (iters, 2, 0.0)
        );
        assert!(s.collision_checks > 0 && s.nodes >= path.len());
        // Solved: further iterations do nothing.
        let r = p.iterate(None);
        assert!(r.solved && r.sample.is_none() && r.nodes_added == 0);
    }
}

#[test]
fn same_seed_same_trees_different_seed_differs() {
    let scene = easy();
    let grow = |seed| {
        let mut p = Planner::new(&scene, PlannerParams::default(), seed).expect("planner");
        for _ in 0..30 {
            p.iterate(None);
        }
        p
    };
    let (a, b, c) = (grow(11), grow(11), grow(12));
    assert_eq!(a.trees(), b.trees());
    assert_eq!(a.stats(), b.stats());
    assert_eq!(a.solution(), b.solution());
    assert_ne!(a.trees(), c.trees());
}

#[test]
fn extend_labels_and_reports() {
    let scene = Scene::wall_with_hole();
    let mut p = Planner::new(&scene, PlannerParams::default(), 5).expect("planner");
    // Extending the start tree straight into the wall: partial progress, then blocked.
    let (e, last, added) = p.extend(START, &Se3::from_xyz(0.0, 0.2, 0.0));
    assert_eq!(e, Extend::Obstacle);
    assert!(added >= 1 && last != NodeId(0));
    let l = p.trees()[START].node(NodeId(0)).labels;
    assert_eq!((l.extension_attempts, l.collisions), (1, 0));
    assert!(l.covered_distance > 0.0);
    // Again from the blocked tip: nothing added.
    let (e, _, added) = p.extend(START, &Se3::from_xyz(0.0, 0.2, 0.0));
    assert_eq!((e, added), (Extend::Collision, 0));
    let l = p.trees()[START].node(last).labels;
    assert_eq!((l.extension_attempts, l.collisions), (1, 1));
    // Reaching a free nearby target.
    let (e, _, added) = p.extend(GOAL, &Se3::from_xyz(0.2, 0.07, 0.0));
    assert_eq!((e, added), (Extend::Success, 2));
    let r = p.iterate(None);
    assert_eq!((r.iteration, r.a_is_start), (1, true));
    assert_eq!(r.connect.is_some(), r.extend != Some(Extend::Collision));
}

#[test]
fn extend_step_grows_tree_a_by_one_node_and_solves() {
    let scene = easy();
    let params = PlannerParams {
        extend_a: ExtendA::Step,
        ..Default::default()
    };
    let mut p = Planner::new(&scene, params.clone(), 3).expect("planner");
    let (mut advanced, mut solved) = (0, false);
    for _ in 0..5_000 {
        let r = p.iterate(None);
        // Tree A takes one step: it cannot stop part-way after several.
        match r.extend {
            Some(Extend::Advanced) => advanced += 1,
            Some(Extend::Obstacle) => panic!("a one-step Extend cannot be partial"),
            _ => {}
        }
        if r.extend != Some(Extend::Success) {
            // Without reaching the sample, A grew by at most one node; B connects
            // greedily (any number).
            assert!(r.connect.is_some() || r.nodes_added == 0);
        }
        if r.solved {
            solved = true;
            break;
        }
    }
    assert!(solved && advanced > 0);
    let raw = p.raw_solution().expect("raw");
    for w in raw.windows(2) {
        assert!(p.checker().edge_free(&w[0], &w[1]));
        assert!(p.space().distance(&w[0], &w[1]) <= p.params().step + 1e-12);
    }
    // Deterministic, and not the greedy planner's trees.
    let grow = |params: PlannerParams| {
        let mut p = Planner::new(&scene, params, 3).expect("planner");
        for _ in 0..40 {
            p.iterate(None);
        }
        p
    };
    assert_eq!(grow(params.clone()).trees(), grow(params.clone()).trees());
    assert_ne!(grow(params).trees(), grow(PlannerParams::default()).trees());
    // One step from the start towards a far free target: one node, Advanced.
    let mut p = Planner::new(&scene, PlannerParams::default(), 1).expect("planner");
    let s = scene.start.pos;
    let far = Se3::from_xyz(s.x, s.y + 0.175, s.z);
    assert!(p.checker().edge_free(&scene.start, &far));
    let (e, last, added, _) = p.extend_at_most(START, &far, 1);
    assert_eq!((e, added), (Extend::Advanced, 1));
    let d = p
        .space()
        .distance(&scene.start, &p.trees()[START].node(last).config);
    assert!((d - p.params().step).abs() < 1e-12);
    let (e, _, added) = p.extend(START, &far);
    assert_eq!((e, added), (Extend::Success, 3));
}

#[test]
fn pos_samples_around_the_user() {
    let scene = easy();
    let params = PlannerParams {
        sampling: crate::Sampling::Pos { beta: None },
        ..Default::default()
    };
    let mut p = Planner::new(&scene, params, 3).expect("planner");
    let user = Se3::from_xyz(0.1, 0.1, 0.0);
    for _ in 0..50 {
        let r = p.iterate(Some(&user));
        if r.solved {
            break;
        }
        assert!(r.from_user);
        let q = r.sample.expect("sample");
        assert!((q.pos - user.pos).norm() < 0.2, "{q:?}");
    }
    // Non-finite user input is ignored.
    let mut p = Planner::new(&scene, p.params().clone(), 3).expect("planner");
    let r = p.iterate(Some(&Se3::from_xyz(f64::NAN, 0.0, 0.0)));
    assert!(!r.from_user);
}

#[test]
fn attractive_force_before_and_after_solution() {
    let scene = easy();
    let mut p = Planner::new(&scene, PlannerParams::default(), 2).expect("planner");
    // Only the roots exist: F_a points to the root of the nearer tree.
    let f = p.attractive_force(&Se3::from_xyz(-0.15, 0.0, 0.1));
    assert!(
        (f - Vector6::new(-0.05, 0.0, -0.1, 0.0, 0.0, 0.0)).norm() < 1e-12,
        "{f}"
    );
    let f = p.attractive_force(&Se3::from_xyz(0.25, 0.0, 0.0));
    assert!((f.x + 0.05).abs() < 1e-12);
    assert_eq!(
        p.attractive_force(&Se3::from_xyz(f64::NAN, 0.0, 0.0)),
        Vector6::zeros()
    );
    run(&mut p, 2_000, None).expect("solved");
    // On the (smoothed) path: F_a leads forward along it, the pull at most
    // `lead_saturation_m` long and the turn at most `lead_saturation_rad`.
    let path = p.solution().expect("path").to_vec();
    let mid = p.space().interpolate(&path[0], &path[1], 0.5);
    let f = p.attractive_force(&mid);
    let next = path[1];
    let towards = p.space().delta(&mid, &next);
    assert!(f.dot(&towards) > 0.0, "{f} vs {towards}");
    let (pull, turn) = (f.fixed_rows::<3>(0).norm(), f.fixed_rows::<3>(3).norm());
    assert!(
        pull > 0.0 && pull <= p.params().lead_saturation_m + 1e-12,
        "{pull}"
    );
    assert!(turn <= p.params().lead_saturation_rad + 1e-12, "{turn}");
    assert!(p.attractive_force(&scene.goal).norm() < 1e-12);
}

#[test]
fn rejects_colliding_start_and_bad_params() {
    let mut scene = Scene::wall_with_hole();
    scene.start = Se3::identity();
    assert!(matches!(
        Planner::new(&scene, PlannerParams::default(), 1),
        Err(PlannerError::StartInCollision(_))
    ));
    let params = PlannerParams {
        neighbours: 0,
        ..Default::default()
    };
    assert!(Planner::new(&Scene::wall_with_hole(), params, 1).is_err());
}

/// Measures the cost of one collision check in the default scene (both argument orders)
/// and prints it. Run in release: `cargo test -p planner --lib --release -- --ignored
/// collision_check_cost --nocapture`.
#[test]
#[ignore = "timing report, run in release"]
fn collision_check_cost() {
    use parry3d_f64::math::Pose;
    use parry3d_f64::query::intersection_test;
    use parry3d_f64::shape::{Compound, SharedShape};
    use rand::SeedableRng;
    use scene::shapes::to_parry;
    let scene = Scene::wall_with_hole();
    let checker = CollisionChecker::new(&scene);
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    // Configurations near the wall (|x| < 0.1) are the expensive ones.
    let space = crate::space::Se3Space::new(
        scene::Bounds {
            min_m: nalgebra::Vector3::new(-0.1, -0.25, -0.25),
            max_m: nalgebra::Vector3::new(0.1, 0.25, 0.25),
        },
        Default::default(),
    );
    let qs: Vec<Se3> = (0..200_000)
        .map(|_| space.sample_uniform(&mut rng))
        .collect();
    let t0 = Instant::now();
    let free = qs.iter().filter(|q| checker.is_free(q)).count();
    let per = t0.elapsed().as_secs_f64() / qs.len() as f64;
    println!(
        "is_free (object first): {:.3} us/check, {free} free of {}",
        per * 1e6,
        qs.len()
    );
    let part = |p: &scene::Part| {
        let scene::Primitive::Box { half_extents_m: h } = p.primitive else {
            unreachable!()
        };
        (to_parry(&p.pose), SharedShape::cuboid(h.x, h.y, h.z))
    };
    let obj = Compound::new(scene.moving_object.iter().map(part).collect());
    let obs = Compound::new(scene.obstacles.iter().map(part).collect());
    let t0 = Instant::now();
    let mut hits = 0;
    for q in &qs {
        let r = intersection_test(&Pose::IDENTITY, &obs, &to_parry(q), &obj);
        hits += usize::from(r.map(|r| r.intersecting).unwrap_or(true));
    }
    let per2 = t0.elapsed().as_secs_f64() / qs.len() as f64;
    println!(
        "obstacles first: {:.3} us/check, {} free",
        per2 * 1e6,
        qs.len() - hits
    );
    assert_eq!(qs.len() - hits, free);
}

#[test]
fn planner_can_move_to_a_worker_thread() {
    fn assert_send<T: Send>() {}
    assert_send::<Planner>();
}

fn with(sampling: crate::Sampling) -> PlannerParams {
    PlannerParams {
        sampling,
        ..Default::default()
    }
}

#[test]
fn hrrtc_authority_and_contact_mode() {
    use crate::sampling::{Contact, UserInput};
    use nalgebra::Vector3;
    let scene = Scene::wall_with_hole();
    let user = Se3::from_xyz(-0.1, 0.1, 0.0);
    // α = 0, as the paper writes it: every free-space sample is q_device itself.
    let every = PlannerParams {
        human_mode: crate::HumanMode::Every,
        ..with(crate::Sampling::Hrrtc { alpha: 0.0 })
    };
    let mut p = Planner::new(&scene, every, 1).expect("p");
    for _ in 0..20 {
        let r = p.iterate(Some(&user));
        assert_eq!((r.sample, r.source), (Some(user), Source::User));
    }
    // Fresh (the default): q_device once; while it stays put, samples near its path; a
    // moved q_device is sampled again.
    let mut p = Planner::new(&scene, with(crate::Sampling::Hrrtc { alpha: 0.0 }), 1).expect("p");
    assert_eq!(p.iterate(Some(&user)).sample, Some(user));
    for _ in 0..20 {
        let r = p.iterate(Some(&user));
        let q = r.sample.expect("a sample");
        assert_eq!(r.source, Source::User);
        assert_ne!(q, user);
        assert!((q.pos - user.pos).norm() < 0.3, "{q:?}");
    }
    let moved = Se3::from_xyz(-0.1, 0.1, 0.002);
    assert_eq!(p.iterate(Some(&moved)).sample, Some(moved));
    // α = 1: always uniform.
    let mut p = Planner::new(&scene, with(crate::Sampling::Hrrtc { alpha: 1.0 }), 1).expect("p");
    assert!((0..20).all(|_| p.iterate(Some(&user)).source == Source::Uniform));
    // α = 0.3: about 30 % uniform.
    let mut p = Planner::new(&scene, with(crate::Sampling::Hrrtc { alpha: 0.3 }), 1).expect("p");
    let uniform = (0..400)
        .filter(|_| p.iterate(Some(&user)).source == Source::Uniform)
        .count();
    assert!((80..160).contains(&uniform), "{uniform}");
    // In contact: HapticSampling whatever α, near the proxy on the wall's face.
    let proxy = Se3::from_xyz(-0.0605, 0.0, 0.0);
    let contact = Contact {
        point_m: Vector3::new(-0.01, 0.0, 0.0),
        normal: -Vector3::x(),
        force_n: Vector3::new(5.0, 0.0, 2.0),
        displacement_m: Vector3::new(0.0, 0.0, 0.001),
        proxy,
    };
    let input = UserInput {
        contact: Some(contact),
        ..UserInput::free(Se3::from_xyz(-0.05, 0.0, 0.0))
    };
    let mut p = Planner::new(&scene, with(crate::Sampling::Hrrtc { alpha: 1.0 }), 4).expect("p");
    for _ in 0..50 {
        let r = p.iterate_input(Some(&input));
        assert_eq!(r.source, Source::Contact);
        let q = r.sample.expect("sample");
        // Lifted 2 mm off the face, spread more along z (the motion) than along y.
        assert!((q.pos.x - (proxy.pos.x - 0.002)).abs() < 1e-12, "{q:?}");
    }
    // Shared authority: in contact too, a share α of machine samples (α = 0.3: about 30 %).
    let mut shared = with(crate::Sampling::Hrrtc { alpha: 0.3 });
    shared.contact.shared_authority = true;
    let mut p = Planner::new(&scene, shared, 4).expect("p");
    let sources: Vec<Source> = (0..400)
        .map(|_| p.iterate_input(Some(&input)).source)
        .collect();
    let machine = sources.iter().filter(|s| **s == Source::Uniform).count();
    assert!((80..160).contains(&machine), "{machine}");
    assert_eq!(
        sources.iter().filter(|s| **s == Source::Contact).count(),
        400 - machine
    );
}

#[test]
fn rrt_baseline_solves_the_free_scene() {
    let scene = Scene::free();
    let params = PlannerParams {
        algorithm: crate::Algorithm::Rrt,
        ..Default::default()
    };
    let mut p = Planner::new(&scene, params, 1).expect("p");
    run(&mut p, 5_000, None).expect("solved");
    let raw = p.raw_solution().expect("raw");
    assert_eq!(
        (raw[0], *raw.last().expect("last")),
        (scene.start, scene.goal)
    );
    assert!(raw.windows(2).all(|w| p.checker().edge_free(&w[0], &w[1])));
    assert_eq!(p.stats().trees, 2);
}

#[test]
fn local_trees_grow_at_unreachable_user_samples_and_merge() {
    // A user on the far side of the wall: when the start tree extends towards its
    // samples it cannot reach them, so they root local trees, which the goal tree (same
    // side) then absorbs.
    let scene = Scene::wall_with_square_hole(0.2);
    let params = PlannerParams {
        sampling: crate::Sampling::Pos { beta: None },
        local_trees: true,
        user_sigma: 0.01,
        fr_alpha: 1.0, // no F_a pull: samples stay around the user
        ..Default::default()
    };
    let mut p = Planner::new(&scene, params, 2).expect("p");
    let behind = Se3::from_xyz(0.12, 0.18, 0.0);
    let mut saw_local = false;
    let mut max_id = 1;
    for _ in 0..30 {
        p.iterate(Some(&behind));
        saw_local |= p.stats().trees > 2;
        // Tree ids stay parallel to the trees: 0, 1, then increasing never-reused ids.
        let ids = p.tree_ids();
        assert_eq!(ids.len(), p.trees().len());
        assert_eq!(&ids[..2], &[0, 1]);
        assert!(ids[2..].windows(2).all(|w| w[0] < w[1]), "{ids:?}");
        max_id = max_id.max(*ids.last().expect("ids"));
    }
    assert!(!saw_local || max_id >= 2);
    assert!(saw_local || p.stats().merges > 0, "a local tree was rooted");
    let merged_behind = p.stats().merges;
    assert!(p.stats().trees <= 2 + p.params().max_local_trees);
    // Walking the user from the start through the hole to the goal: the local trees get
    // merged and the problem is solved.
    let mut merges = 0;
    for i in 0..3000 {
        let t = (i as f64 / 1000.0).min(1.0);
        let q = p.space().interpolate(&scene.start, &scene.goal, t);
        merges += p.iterate(Some(&q)).merged;
        if p.solved() {
            break;
        }
    }
    assert!(p.solved());
    assert!(merged_behind > 0 && p.stats().merges >= merged_behind + u64::from(merges));
    let path = p.solution().expect("path");
    assert!(path.windows(2).all(|w| p.checker().edge_free(&w[0], &w[1])));
}

#[test]
fn path_sampling_follows_the_travelled_path() {
    let scene = easy();
    let mut p = Planner::new(&scene, with(crate::Sampling::Path { beta: None }), 5).expect("p");
    // The user walks along y at x = −0.2; samples come from around that segment.
    for i in 0..40 {
        let q = Se3::from_xyz(-0.2, -0.2 + 0.01 * i as f64, 0.0);
        let r = p.iterate(Some(&q));
        if r.solved {
            break;
        }
        let s = r.sample.expect("sample");
        assert_eq!(r.source, Source::User);
        assert!((s.pos.x + 0.2).abs() < 0.2 && s.pos.y < -0.2 + 0.01 * i as f64 + 0.2);
    }
    assert!(p.user_path().len() > 5);
}

#[test]
fn planar_maze_trees_stay_planar_and_runs_are_deterministic() {
    let scene = Scene::maze();
    let grow = || {
        let mut p =
            Planner::new(&scene, with(crate::Sampling::Pos { beta: Some(3.0) }), 9).expect("p");
        for i in 0..200 {
            let q = Se3::from_rpy(
                nalgebra::Vector3::new(-0.35 + 0.001 * i as f64, -0.35, 0.02),
                0.1,
                0.0,
                0.3,
            );
            p.iterate(Some(&q));
        }
        p
    };
    let (a, b) = (grow(), grow());
    assert_eq!(a.trees(), b.trees());
    for t in a.trees() {
        for n in t.nodes() {
            assert_eq!(n.config.pos.z, 0.0);
            let axis = n.config.rot.axis();
            assert!(
                axis.is_none_or(|v| v.z.abs() > 1.0 - 1e-9),
                "{:?}",
                n.config
            );
        }
    }
    assert!(a.stats().nodes > 20);
}

/// Edges of `path` with a colliding configuration when re-checked every `spacing`
/// (weighted m) by a checker of its own.
fn colliding_edges(scene: &Scene, path: &[Se3], spacing: f64) -> usize {
    let dense = CollisionChecker::with_params(scene, Weights::default(), spacing)
        .with_edge_check(EdgeCheck::Discrete);
    path.windows(2)
        .filter(|w| !dense.edge_free(&w[0], &w[1]))
        .count()
}

#[test]
fn certified_paths_are_free_everywhere_on_a_dense_recheck() {
    // At 4× the default edge spacing, discretely checked paths step over obstacle corners
    // (3 of these 6 seeds do); certified ones (the raw tree path and the shortcut one)
    // never do. A 130 mm hole for the 100 mm S: tight enough to graze, quick to solve.
    let scene = Scene::wall_with_square_hole(0.13);
    let mut grazing_discrete = 0;
    for seed in 1..=6 {
        for check in [EdgeCheck::Discrete, EdgeCheck::Certified] {
            let params = PlannerParams {
                edge_resolution: 0.02,
                edge_check: check,
                ..PlannerParams::default()
            };
            let mut p = Planner::new(&scene, params, seed).expect("planner");
            if run(&mut p, 20_000, None).is_none() {
                panic!("seed {seed} {check:?} unsolved: {:?}", p.stats());
            }
            let bad = colliding_edges(&scene, p.solution().expect("path"), 1e-4)
                + colliding_edges(&scene, p.raw_solution().expect("raw"), 1e-4);
            match check {
                EdgeCheck::Discrete => grazing_discrete += bad,
                EdgeCheck::Certified => {
                    assert_eq!(bad, 0, "seed {seed}: a certified path collides");
                    assert!(p.stats().clearance_queries > 0);
                }
            }
        }
    }
    assert!(grazing_discrete > 0, "{grazing_discrete}");
}

#[test]
fn bridge_samples_are_free_and_hug_the_obstacles() {
    // Every bridge sample is free; they lie much closer to the obstacles than the free
    // uniform samples do (the midpoints of two colliding configurations σ apart).
    let scene = Scene::bug_trap();
    let params = PlannerParams {
        machine_sampler: MachineSampler::BridgeTest {
            share: 1.0,
            sigma: 0.01,
        },
        ..PlannerParams::default()
    };
    let mut p = Planner::new(&scene, params, 3).expect("planner");
    let mut bridge = Vec::new();
    for _ in 0..2000 {
        let r = p.iterate(None);
        if r.source == Source::BridgeTest {
            let q = r.sample.expect("a sample");
            assert!(p.checker().is_free(&q), "bridge sample collides: {q:?}");
            bridge.push(p.checker().clearance_m(&q));
        }
    }
    // About 3 % of the samples: most bridge tests fail within their 32 tries here.
    assert!(bridge.len() > 30, "{} bridge samples", bridge.len());
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut uniform: Vec<f64> = (0..4000)
        .map(|_| p.space().sample_uniform(&mut rng))
        .filter(|q| p.checker().is_free(q))
        .map(|q| p.checker().clearance_m(&q))
        .collect();
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (b, u) = (median(&mut bridge), median(&mut uniform));
    assert!(
        b < 0.25 * u,
        "median clearance: bridge {b} m, uniform {u} m"
    );
}

#[test]
fn bridge_parameters_are_checked() {
    for (share, sigma, name) in [
        (1.5, 0.01, "machine_sampler.share"),
        (0.5, 0.0, "machine_sampler.sigma"),
        (0.5, f64::NAN, "machine_sampler.sigma"),
    ] {
        let params = PlannerParams {
            machine_sampler: MachineSampler::BridgeTest { share, sigma },
            ..PlannerParams::default()
        };
        match params.validate() {
            Err(PlannerError::InvalidParam { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{share} {sigma}: {other:?}"),
        }
    }
    assert_eq!(
        MachineSampler::parse("bridge-test", 0.3, 0.02),
        Some(MachineSampler::BridgeTest {
            share: 0.3,
            sigma: 0.02
        })
    );
    assert_eq!(MachineSampler::parse("obstacle", 0.3, 0.02), None);
}

#[test]
fn aligned_samples_are_square_to_an_obstacle_and_uniform_ones_are_not() {
    // With every machine sample aligned, each uniform-source sample's orientation lies
    // within a few jitters of a candidate; with none, almost none does.
    let scene = Scene::bug_trap();
    let candidates = crate::aligned::AlignedOrientations::of(&scene);
    let near_candidate = |q: &Se3| {
        candidates
            .candidates()
            .iter()
            .map(|c| scene::pose::angle_between(c, &q.rot))
            .fold(f64::INFINITY, f64::min)
    };
    for (share, expect_aligned) in [(1.0, true), (0.0, false)] {
        let params = PlannerParams {
            aligned_share: share,
            aligned_jitter_rad: 0.01,
            ..PlannerParams::default()
        };
        let mut p = Planner::new(&scene, params, 5).expect("planner");
        let mut n = 0;
        let mut aligned = 0;
        for _ in 0..300 {
            let r = p.iterate(None);
            assert!(!r.from_user, "a machine sample counts as the operator's");
            let q = r.sample.expect("a sample");
            n += 1;
            aligned += usize::from(near_candidate(&q) < 0.06);
        }
        if expect_aligned {
            assert_eq!(
                aligned, n,
                "share 1: every sample within 6 σ of a candidate"
            );
        } else {
            assert!(
                aligned * 50 < n,
                "share 0: {aligned} of {n} near a candidate"
            );
        }
    }
}

#[test]
fn aligned_parameters_are_checked() {
    for (share, jitter, name) in [
        (-0.1, 0.02, "aligned_share"),
        (1.5, 0.02, "aligned_share"),
        (0.5, -0.01, "aligned_jitter_rad"),
        (0.5, f64::INFINITY, "aligned_jitter_rad"),
    ] {
        let params = PlannerParams {
            aligned_share: share,
            aligned_jitter_rad: jitter,
            ..PlannerParams::default()
        };
        match params.validate() {
            Err(PlannerError::InvalidParam { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{share} {jitter}: {other:?}"),
        }
    }
}

/// The proxy of the S pressed on the wall-hole's wall beside the hole, wiggling by up to
/// 1 mm: an operator who does not advance. One haptic state per millisecond.
fn pressed_on_the_wall(t_s: f64) -> crate::UserInput {
    use nalgebra::Vector3;
    let wiggle = 0.001 * (t_s * 7.0).sin();
    let proxy = Se3::from_xyz(-0.0605, 0.12 + wiggle, 0.0);
    crate::UserInput {
        contact: Some(crate::Contact {
            point_m: Vector3::new(-0.01, 0.12 + wiggle, 0.0),
            normal: -Vector3::x(),
            force_n: Vector3::new(4.0, 0.0, 0.5),
            displacement_m: Vector3::new(0.0, 0.0002, 0.0),
            proxy,
        }),
        ..crate::UserInput::free(proxy)
    }
    .at(t_s)
}

fn adaptive(alpha: f64) -> PlannerParams {
    PlannerParams {
        authority: crate::Authority::Adaptive(crate::AdaptiveAuthority::default()),
        ..with(crate::Sampling::Hrrtc { alpha })
    }
}

/// Iterates with `input(t)` for `ms` milliseconds from `from_s`, `per_ms` iterations per
/// haptic state; returns the sources of the samples.
fn feed(
    p: &mut Planner,
    from_s: f64,
    ms: u32,
    per_ms: u32,
    input: impl Fn(f64) -> crate::UserInput,
) -> Vec<Source> {
    let mut sources = Vec::new();
    for k in 0..ms {
        let u = input(from_s + f64::from(k) * 1e-3);
        for _ in 0..per_ms {
            sources.push(p.iterate_input(Some(&u)).source);
        }
    }
    sources
}

#[test]
fn adaptive_authority_takes_over_from_an_operator_pressed_on_a_wall() {
    let scene = Scene::wall_with_hole();
    // The paper's fixed α: contact samples only, for as long as the contact lasts.
    let mut fixed =
        Planner::new(&scene, with(crate::Sampling::Hrrtc { alpha: 0.5 }), 3).expect("p");
    let sources = feed(&mut fixed, 0.0, 4000, 1, pressed_on_the_wall);
    assert!(sources.iter().all(|s| *s == Source::Contact));
    assert!(!fixed.solved());
    assert_eq!(fixed.authority().machine_share_contact, 0.0);
    // Adaptive: full trust for the patience (0.5 s) after the last progress or fruit, then
    // the machine share rises to its cap (1) over the ramp (0.5 s).
    let rule = crate::AdaptiveAuthority::default();
    let mut p = Planner::new(&scene, adaptive(0.5), 3).expect("p");
    let mut last_progress_s = 0.0;
    let mut capped_at_s = None;
    for k in 0..4000u32 {
        let t = f64::from(k) * 1e-3;
        p.iterate_input(Some(&pressed_on_the_wall(t)));
        let a = p.authority();
        if a.stagnant_s == 0.0 {
            last_progress_s = t;
        }
        // The share follows the stated rule, from α (0.5) to the cap 1.
        let expected = 0.5 + 0.5 * (1.0 - rule.trust_after(a.stagnant_s));
        assert!(
            (a.machine_share_contact - expected).abs() < 1e-12,
            "{t}: {a:?}"
        );
        if a.machine_share_contact == 1.0 && capped_at_s.is_none() {
            capped_at_s = Some(t);
        }
    }
    // The trees stop finding new ground at the wall early on: the cap comes patience +
    // ramp (1 s) after the last fruit, within the first 2 s of pressing.
    let capped = capped_at_s.expect("the machine share reached its cap");
    assert!(last_progress_s < 1.0, "last fruit at {last_progress_s} s");
    let full_after_s = rule.patience_s + rule.ramp_s;
    assert_eq!(full_after_s, 1.0);
    assert!(
        (capped - last_progress_s - full_after_s).abs() < 2e-3,
        "capped at {capped} s, last progress {last_progress_s} s"
    );
    // From then on every sample is the machine's.
    let sources = feed(&mut p, 4.0, 500, 1, pressed_on_the_wall);
    assert!(sources.iter().all(|s| *s == Source::Uniform), "{sources:?}");
}

#[test]
fn adaptive_authority_gives_the_share_back_when_the_operator_progresses() {
    let scene = Scene::wall_with_hole();
    let mut p = Planner::new(&scene, adaptive(0.5), 3).expect("p");
    feed(&mut p, 0.0, 4000, 1, pressed_on_the_wall);
    assert_eq!(p.authority().machine_share_contact, 1.0);
    // It slides 8 cm along the wall (new ground): its share (1 − α) is back at once, the
    // contact samples return.
    let slid = |t: f64| {
        let mut u = pressed_on_the_wall(t);
        let c = u.contact.as_mut().expect("contact");
        c.proxy.pos.y -= 0.08;
        c.point_m.y -= 0.08;
        u.q_user = c.proxy;
        u
    };
    let sources = feed(&mut p, 4.0, 1, 1, slid);
    let a = p.authority();
    assert_eq!((a.trust, a.machine_share_contact), (1.0, 0.5), "{a:?}");
    assert!(a.restores >= 1);
    // Within the patience (0.5 s) the trust holds: about half the samples are the
    // operator's contact samples.
    let more = feed(&mut p, 4.001, 400, 1, slid);
    let contact = sources
        .iter()
        .chain(&more)
        .filter(|s| **s == Source::Contact)
        .count();
    assert!(
        (120..=280).contains(&contact),
        "{contact} of 401 contact samples"
    );
    // Free space at full trust: the machine share is α again.
    let free = |t: f64| crate::UserInput::free(Se3::from_xyz(-0.15, 0.04, 0.0)).at(t);
    feed(&mut p, 4.001, 1, 1, free);
    assert_eq!(p.authority().machine_share_free, 0.5);
}

#[test]
fn adaptive_authority_is_the_papers_while_the_operator_advances_and_is_deterministic() {
    // An operator walking towards the hole at 10 cm/s (progress every 0.1 s): the adaptive
    // planner draws the very samples of the fixed one.
    let scene = Scene::wall_with_hole();
    let walking = |t: f64| crate::UserInput::free(Se3::from_xyz(-0.2 + 0.1 * t, 0.0, 0.0)).at(t);
    let run = |params: PlannerParams| {
        let mut p = Planner::new(&scene, params, 5).expect("p");
        let mut reports = Vec::new();
        for k in 0..1000u32 {
            let u = walking(f64::from(k) * 1e-3);
            for _ in 0..3 {
                reports.push(p.iterate_input(Some(&u)));
            }
        }
        (reports, p.stats().nodes)
    };
    let (fixed, fixed_nodes) = run(with(crate::Sampling::Hrrtc { alpha: 0.5 }));
    let (adapt, adapt_nodes) = run(adaptive(0.5));
    assert_eq!(fixed_nodes, adapt_nodes);
    assert!(fixed.iter().zip(&adapt).all(|(f, a)| f.sample == a.sample));
    // Deterministic per seed and input sequence, stuck or not.
    let stuck = |seed: u64| {
        let mut p = Planner::new(&scene, adaptive(0.5), seed).expect("p");
        let sources = feed(&mut p, 0.0, 2500, 2, pressed_on_the_wall);
        (sources, p.stats().nodes, p.authority())
    };
    assert_eq!(stuck(8), stuck(8));
    assert_ne!(stuck(8).1, stuck(9).1);
}

#[test]
fn an_operator_sample_that_opens_new_ground_restores_the_trust() {
    // The operator holds still in front of the wall (no progress), then turns the object
    // 0.6 rad away from the goal's orientation in place: no progress towards the goal, no
    // new ground, but q_device is now 0.06 weighted m (more than a step) from every node,
    // and the start tree reaches it: fruit.
    let scene = Scene::wall_with_hole();
    let params = PlannerParams {
        human_mode: crate::HumanMode::Every,
        ..adaptive(0.0)
    };
    let mut p = Planner::new(&scene, params, 2).expect("p");
    let held = |t: f64| crate::UserInput::free(Se3::from_xyz(-0.15, 0.1, 0.0)).at(t);
    // Still for the patience and half the ramp: its trust is down to 1/2.
    let rule = crate::AdaptiveAuthority::default();
    let still_ms = (1e3 * (rule.patience_s + 0.5 * rule.ramp_s)) as u32;
    feed(&mut p, 0.0, still_ms, 2, held);
    let a = p.authority();
    assert!(a.trust < 1.0 && a.trust > 0.0, "{a:?}");
    let now = f64::from(still_ms) * 1e-3;
    let turned = |t: f64| {
        let rot = nalgebra::UnitQuaternion::from_euler_angles(0.0, 0.0, 0.6);
        crate::UserInput::free(Se3::new(nalgebra::Vector3::new(-0.15, 0.1, 0.0), rot)).at(t)
    };
    // Half the samples are the machine's by now (trust 1/2), and tree A alternates.
    let mut novel = false;
    for _ in 0..20 {
        let r = p.iterate_input(Some(&turned(now)));
        novel |= r.novel && r.from_user;
    }
    assert!(novel, "the start tree reached the turned q_device");
    let a = p.authority();
    assert_eq!((a.trust, a.stagnant_s), (1.0, 0.0), "{a:?}");
    assert_eq!(a.restores, 1);
}

/// Issue 46: the operator's configuration touching a wall (0.5 mm in, as an operator's pose
/// in a slot is) is pushed out to a free configuration beside it and used, with touch
/// retraction on (1 mm); a deep one, a free one, or any with it off (the default) is not.
#[test]
fn an_operator_sample_in_shallow_collision_is_pushed_out_and_used() {
    use crate::sampling::UserInput;
    let scene = Scene::wall_with_hole();
    let params = |touch_depth_m: f64| PlannerParams {
        sampling: crate::Sampling::Hrrtc { alpha: 0.0 },
        touch_depth_m,
        ..Default::default()
    };
    // The S's x-max face 0.5 mm into the wall's face x = −0.01, beside the hole.
    let pressed = Se3::from_xyz(-0.0595, 0.15, 0.0);
    let mut p = Planner::new(&scene, params(0.001), 1).expect("planner");
    assert!(!p.checker().is_free(&pressed));
    let r = p.iterate_input(Some(&UserInput::free(pressed)));
    assert!(r.from_user && r.touched, "{r:?}");
    let q = r.sample.expect("a sample");
    assert!(p.checker().is_free(&q), "{q:?}");
    // Out along the wall's normal (−x) by the depth and the margin, nothing else.
    let moved = q.pos - pressed.pos;
    assert!(
        (moved.x + 0.0005 + TOUCH_MARGIN_M).abs() < 1e-9 && moved.y.abs() < 1e-12,
        "{moved}"
    );
    assert_eq!(q.rot, pressed.rot);
    // The tree reaches it (the way from the start to the wall's face is free): a node.
    assert_eq!(r.extend, Some(Extend::Success));
    let s = p.stats();
    assert_eq!((s.touched, s.touched_nodes), (1, 1));
    // Not touched: a sample 5 mm deep, a free one, and any with the retraction off.
    let deep = Se3::from_xyz(-0.055, 0.15, 0.0);
    let free = Se3::from_xyz(-0.07, 0.15, 0.0);
    for (depth, q_user) in [(0.001, deep), (0.001, free), (0.0, pressed)] {
        let mut p = Planner::new(&scene, params(depth), 1).expect("planner");
        let r = p.iterate_input(Some(&UserInput::free(q_user)));
        assert!(r.from_user && !r.touched, "{q_user:?} {depth}: {r:?}");
        assert_eq!(r.sample, Some(q_user));
        assert_eq!(p.stats().touched, 0);
    }
    // Off by default.
    assert_eq!(PlannerParams::default().touch_depth_m, 0.0);
    // A bad limit is refused.
    assert!(Planner::new(&scene, params(-1.0), 1).is_err());
    assert!(Planner::new(&scene, params(f64::NAN), 1).is_err());
}
