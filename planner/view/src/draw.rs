//! Foxglove messages (well-known schemas) for the scene, the object, the forces, the
//! roadmap and the paths. Pure functions: the view process decides when to log them.
//!
//! Frames: `scene` (the scene frame, Z up, m), `device` (the device-mapped pose
//! `user_pose`) and `proxy` (the proxy object), the last two given by
//! [`frame_transforms`].

use crate::model::{CHUNK_NODES, RoadmapModel};
use foxglove::messages::{
    ArrowPrimitive, Color, CubePrimitive, FrameTransform, FrameTransforms, LinePrimitive,
    PackedElementField, Point3, PointCloud, Pose, Quaternion, SceneEntity, SceneEntityDeletion,
    SceneUpdate, SpherePrimitive, Timestamp, TriangleListPrimitive, Vector3, line_primitive,
    packed_element_field::NumericType, scene_entity_deletion,
};
use ipc_types::{HapticState, TreeKind};
use nalgebra::{UnitQuaternion, Vector3 as V3};
use scene::pose::Se3;
use scene::{Part, Primitive, Scene};

/// The scene frame's name.
pub const SCENE_FRAME: &str = "scene";
/// Frame of the device-mapped object pose (`HapticState::user_pose`).
pub const DEVICE_FRAME: &str = "device";
/// Frame of the proxy object (`HapticState::proxy_pose`).
pub const PROXY_FRAME: &str = "proxy";

/// Obstacles: grey.
pub const OBSTACLE: Color = rgba(0.62, 0.64, 0.68, 1.0);
/// The proxy object: orange, solid.
pub const PROXY: Color = rgba(0.95, 0.55, 0.1, 1.0);
/// The device-mapped object: blue, translucent.
pub const DEVICE: Color = rgba(0.2, 0.5, 1.0, 0.35);
/// Start tree edges.
pub const START_TREE: Color = rgba(0.15, 0.35, 0.9, 0.7);
/// Goal tree edges.
pub const GOAL_TREE: Color = rgba(0.1, 0.65, 0.25, 0.7);
/// Local tree edges (I-RRT local trees): magenta.
pub const LOCAL_TREE: Color = rgba(0.85, 0.15, 0.75, 0.8);
/// The solution path.
pub const SOLUTION: Color = rgba(1.0, 0.85, 0.0, 1.0);
/// The operator's travelled path.
pub const TRAIL: Color = rgba(0.0, 0.8, 0.9, 1.0);

/// A colour from components in [0, 1].
pub const fn rgba(r: f64, g: f64, b: f64, a: f64) -> Color {
    Color { r, g, b, a }
}

/// Edge colour of a tree kind.
pub fn tree_color(kind: TreeKind) -> Color {
    match kind {
        TreeKind::START => START_TREE,
        TreeKind::GOAL => GOAL_TREE,
        _ => LOCAL_TREE,
    }
}

/// A Foxglove timestamp from `CLOCK_MONOTONIC` ns (the time base of every hrrtc recording).
pub fn stamp(ns: u64) -> Timestamp {
    Timestamp::new((ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32)
}

fn point(p: &V3<f64>) -> Point3 {
    Point3 {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

fn point_a(p: [f64; 3]) -> Point3 {
    Point3 {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

fn quat(q: &UnitQuaternion<f64>) -> Quaternion {
    Quaternion {
        x: q.i,
        y: q.j,
        z: q.k,
        w: q.w,
    }
}

/// A Foxglove pose of a planner pose.
pub fn pose(q: &Se3) -> Pose {
    Pose {
        position: Some(Vector3 {
            x: q.pos.x,
            y: q.pos.y,
            z: q.pos.z,
        }),
        orientation: Some(quat(&q.rot)),
    }
}

fn entity(id: &str, frame: &str, ns: u64) -> SceneEntity {
    SceneEntity {
        timestamp: Some(stamp(ns)),
        frame_id: frame.into(),
        id: id.into(),
        ..SceneEntity::default()
    }
}

/// Adds `part` (placed by `at ∘ part.pose`) to `e` in colour `color`.
fn add_part(e: &mut SceneEntity, part: &Part, at: &Se3, color: Color) {
    let q = at.compose(&part.pose);
    match &part.primitive {
        Primitive::Box { half_extents_m: h } => e.cubes.push(CubePrimitive {
            pose: Some(pose(&q)),
            size: Some(Vector3 {
                x: 2.0 * h.x,
                y: 2.0 * h.y,
                z: 2.0 * h.z,
            }),
            color: Some(color),
        }),
        Primitive::Sphere { radius_m } => e.spheres.push(SpherePrimitive {
            pose: Some(pose(&q)),
            size: Some(Vector3 {
                x: 2.0 * radius_m,
                y: 2.0 * radius_m,
                z: 2.0 * radius_m,
            }),
            color: Some(color),
        }),
        Primitive::Mesh { mesh } => e.triangles.push(TriangleListPrimitive {
            pose: Some(pose(&q)),
            points: mesh.vertices_m.iter().map(point).collect(),
            color: Some(color),
            colors: Vec::new(),
            indices: mesh.triangles.iter().flatten().copied().collect(),
        }),
    }
}

/// `/view/scene`: the obstacles, the start and goal poses of the object (ghosts) and the
/// bounds of its reference point.
pub fn scene_update(scene: &Scene, ns: u64) -> SceneUpdate {
    let mut obstacles = entity("obstacles", SCENE_FRAME, ns);
    for part in &scene.obstacles {
        add_part(&mut obstacles, part, &Se3::identity(), OBSTACLE);
    }
    let mut ends = entity("start-goal", SCENE_FRAME, ns);
    for (q, c) in [
        (&scene.start, rgba(0.15, 0.35, 0.9, 0.25)),
        (&scene.goal, rgba(0.1, 0.65, 0.25, 0.25)),
    ] {
        for part in &scene.moving_object {
            add_part(&mut ends, part, q, c);
        }
    }
    let (lo, hi) = (scene.bounds.min_m, scene.bounds.max_m);
    let mut bounds = entity("bounds", SCENE_FRAME, ns);
    let corner = |i: u32| {
        V3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    let mut points = Vec::new();
    for a in 0..8u32 {
        for bit in [1u32, 2, 4] {
            if a & bit == 0 {
                points.push(point(&corner(a)));
                points.push(point(&corner(a | bit)));
            }
        }
    }
    bounds.lines.push(LinePrimitive {
        r#type: line_primitive::Type::LineList as i32,
        pose: Some(pose(&Se3::identity())),
        thickness: 1.0,
        scale_invariant: true,
        points,
        color: Some(rgba(0.5, 0.5, 0.5, 0.6)),
        ..LinePrimitive::default()
    });
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![obstacles, ends, bounds],
    }
}

/// `/view/object`: the moving object in the `device` frame (translucent) and in the
/// `proxy` frame (solid). Frame-locked: they follow [`frame_transforms`].
pub fn object_update(scene: &Scene, ns: u64) -> SceneUpdate {
    let mut out = SceneUpdate::default();
    for (id, frame, color) in [
        ("device-object", DEVICE_FRAME, DEVICE),
        ("proxy-object", PROXY_FRAME, PROXY),
    ] {
        let mut e = entity(id, frame, ns);
        e.frame_locked = true;
        for part in &scene.moving_object {
            add_part(&mut e, part, &Se3::identity(), color);
        }
        out.entities.push(e);
    }
    out
}

fn transform(child: &str, p: &ipc_types::Pose, ns: u64) -> FrameTransform {
    let [x, y, z] = p.position_m;
    let [qx, qy, qz, qw] = p.orientation_xyzw;
    FrameTransform {
        timestamp: Some(stamp(ns)),
        parent_frame_id: SCENE_FRAME.into(),
        child_frame_id: child.into(),
        translation: Some(Vector3 { x, y, z }),
        rotation: Some(Quaternion {
            x: qx,
            y: qy,
            z: qz,
            w: qw,
        }),
    }
}

/// `/view/tf`: scene → device (the device-mapped pose) and scene → proxy.
pub fn frame_transforms(s: &HapticState, ns: u64) -> FrameTransforms {
    FrameTransforms {
        transforms: vec![
            transform(DEVICE_FRAME, &s.user_pose, ns),
            transform(PROXY_FRAME, &s.proxy_pose, ns),
        ],
    }
}

/// An arrow from `tail` along `v` (scene frame, m), `None` when `v` is too short to see
/// or not finite.
pub fn arrow(tail: [f64; 3], v: [f64; 3], diameter_m: f64, color: Color) -> Option<ArrowPrimitive> {
    let v = V3::from(v);
    let len = v.norm();
    if !len.is_finite() || len < 1e-4 || tail.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let rot = UnitQuaternion::rotation_between(&V3::x(), &v)
        .unwrap_or_else(|| UnitQuaternion::from_axis_angle(&V3::z_axis(), std::f64::consts::PI));
    let head = (0.3 * len).min(4.0 * diameter_m);
    Some(ArrowPrimitive {
        pose: Some(pose(&Se3::new(V3::from(tail), rot))),
        shaft_length: len - head,
        shaft_diameter: diameter_m,
        head_length: head,
        head_diameter: 2.5 * diameter_m,
        color: Some(color),
    })
}

/// Arrow scales of `/view/forces`.
#[derive(Debug, Clone, Copy)]
pub struct ForceScale {
    /// Arrow length per newton, m/N.
    pub m_per_n: f64,
    /// Length of the contact normal arrow, m.
    pub normal_m: f64,
}

/// `/view/forces`, one entity `forces`: the contact point (sphere), the contact normal
/// n_c (white, fixed length) and the contact force (red) at the contact point; the
/// guidance force F_s actually rendered (green) and the operator force f_u (cyan) at the
/// proxy; F_a (yellow, a displacement in m, drawn 1:1) at the device-mapped pose.
/// `attractive` is F_a of the newest guidance, if any.
pub fn forces_update(
    s: &HapticState,
    attractive: Option<[f64; 6]>,
    scale: ForceScale,
    ns: u64,
) -> SceneUpdate {
    let mut e = entity("forces", SCENE_FRAME, ns);
    let k = scale.m_per_n;
    let mul = |v: [f64; 3], k: f64| [v[0] * k, v[1] * k, v[2] * k];
    let proxy = s.proxy_pose.position_m;
    let in_contact = s.contact == ipc_types::ContactCode::CONTACT;
    if in_contact {
        let c = s.contact_point_m;
        e.spheres.push(SpherePrimitive {
            pose: Some(pose(&Se3::from_xyz(c[0], c[1], c[2]))),
            size: Some(Vector3 {
                x: 0.008,
                y: 0.008,
                z: 0.008,
            }),
            color: Some(rgba(1.0, 0.1, 0.1, 1.0)),
        });
        e.arrows.extend(arrow(
            c,
            mul(s.contact_normal, scale.normal_m),
            0.003,
            rgba(1.0, 1.0, 1.0, 1.0),
        ));
        e.arrows.extend(arrow(
            c,
            mul(s.contact_wrench.force_n, k),
            0.004,
            rgba(0.95, 0.1, 0.1, 1.0),
        ));
    }
    e.arrows.extend(arrow(
        proxy,
        mul(s.guidance_wrench.force_n, k),
        0.004,
        rgba(0.1, 0.85, 0.2, 1.0),
    ));
    e.arrows.extend(arrow(
        proxy,
        mul(s.operator_force_n, k),
        0.003,
        rgba(0.0, 0.8, 0.9, 1.0),
    ));
    if let Some(fa) = attractive {
        e.arrows.extend(arrow(
            s.user_pose.position_m,
            [fa[0], fa[1], fa[2]],
            0.003,
            rgba(1.0, 0.85, 0.0, 1.0),
        ));
    }
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![e],
    }
}

/// Entity id of a roadmap chunk.
pub fn chunk_id(tree: u32, chunk: u32) -> String {
    format!("tree{tree}/chunk{chunk}")
}

/// `/view/roadmap/edges`: one entity per changed chunk (edges child → parent as a line
/// list in the tree's colour), after the deletions.
pub fn edges_update(
    model: &RoadmapModel,
    chunks: &[(u32, u32)],
    deletions: Vec<SceneEntityDeletion>,
    ns: u64,
) -> SceneUpdate {
    let mut entities = Vec::with_capacity(chunks.len());
    for &(tree, chunk) in chunks {
        let Some(t) = model.trees.get(&tree) else {
            continue;
        };
        let mut e = entity(&chunk_id(tree, chunk), SCENE_FRAME, ns);
        let edges = model.chunk_edges(tree, chunk);
        let mut points = Vec::with_capacity(2 * edges.len());
        for (a, b) in edges {
            points.push(point_a(a));
            points.push(point_a(b));
        }
        e.lines.push(LinePrimitive {
            r#type: line_primitive::Type::LineList as i32,
            pose: Some(pose(&Se3::identity())),
            thickness: if t.kind == TreeKind::LOCAL { 2.0 } else { 1.0 },
            scale_invariant: true,
            points,
            color: Some(tree_color(t.kind)),
            ..LinePrimitive::default()
        });
        e.metadata.push(foxglove::messages::KeyValuePair {
            key: "tree".into(),
            value: format!(
                "{} {} nodes {}..{}",
                t.kind.name(),
                tree,
                chunk * CHUNK_NODES,
                (chunk + 1) * CHUNK_NODES
            ),
        });
        entities.push(e);
    }
    SceneUpdate {
        deletions,
        entities,
    }
}

/// A deletion of one entity, or of all (`id = None`), at `ns`.
pub fn deletion(id: Option<String>, ns: u64) -> SceneEntityDeletion {
    SceneEntityDeletion {
        timestamp: Some(stamp(ns)),
        r#type: if id.is_some() {
            scene_entity_deletion::Type::MatchingId as i32
        } else {
            scene_entity_deletion::Type::All as i32
        },
        id: id.unwrap_or_default(),
    }
}

/// Bytes per point of [`nodes_cloud`].
pub const NODE_STRIDE: u32 = 24;

/// `/view/roadmap/nodes`: every known node as a point with float32 fields `x`, `y`, `z`
/// (m), `distance_to_goal` (distance label, weighted m), `freedom` (collision label in
/// (0, 1]: share of extensions from the node that made progress) and `tree_kind` (0 start,
/// 1 goal, 2 local). The layout colours by `distance_to_goal`; pick `freedom` in the
/// panel to colour by the collision label.
pub fn nodes_cloud(model: &RoadmapModel, ns: u64) -> PointCloud {
    let mut data = Vec::with_capacity(model.known_nodes() * NODE_STRIDE as usize);
    for t in model.trees.values() {
        for n in t.nodes.iter().flatten() {
            for v in [
                n.position_m[0],
                n.position_m[1],
                n.position_m[2],
                n.distance_to_goal,
                n.freedom,
                f64::from(t.kind.0),
            ] {
                data.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
    }
    let field = |name: &str, offset: u32| PackedElementField {
        name: name.into(),
        offset,
        r#type: NumericType::Float32 as i32,
    };
    PointCloud {
        timestamp: Some(stamp(ns)),
        frame_id: SCENE_FRAME.into(),
        pose: Some(pose(&Se3::identity())),
        point_stride: NODE_STRIDE,
        fields: vec![
            field("x", 0),
            field("y", 4),
            field("z", 8),
            field("distance_to_goal", 12),
            field("freedom", 16),
            field("tree_kind", 20),
        ],
        data: data.into(),
    }
}

/// A polyline entity `id` through `points` (scene frame) in `color`, `px` pixels wide.
pub fn polyline_update(
    id: &str,
    points: &[[f64; 3]],
    color: Color,
    px: f64,
    ns: u64,
) -> SceneUpdate {
    let mut e = entity(id, SCENE_FRAME, ns);
    if points.len() >= 2 {
        e.lines.push(LinePrimitive {
            r#type: line_primitive::Type::LineStrip as i32,
            pose: Some(pose(&Se3::identity())),
            thickness: px,
            scale_invariant: true,
            points: points.iter().map(|p| point_a(*p)).collect(),
            color: Some(color),
            ..LinePrimitive::default()
        });
    }
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![e],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arrows_point_along_their_vector() {
        let a = arrow([1.0, 0.0, 0.0], [0.0, 0.0, 0.2], 0.01, PROXY).expect("arrow");
        let q = a.pose.expect("pose").orientation.expect("q");
        let rot = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z));
        let dir = rot * V3::x();
        assert!((dir - V3::z()).norm() < 1e-9, "{dir}");
        assert!((a.shaft_length + a.head_length - 0.2).abs() < 1e-12);
        // Opposite to +x still works; zero and NaN give no arrow.
        assert!(arrow([0.0; 3], [-1.0, 0.0, 0.0], 0.01, PROXY).is_some());
        assert!(arrow([0.0; 3], [0.0; 3], 0.01, PROXY).is_none());
        assert!(arrow([0.0; 3], [f64::NAN, 0.0, 0.0], 0.01, PROXY).is_none());
    }

    #[test]
    fn scene_has_one_primitive_per_part() {
        let scene = Scene::wall_with_hole();
        let u = scene_update(&scene, 5);
        assert_eq!(u.entities[0].cubes.len(), scene.obstacles.len());
        assert_eq!(u.entities[1].cubes.len(), 2 * scene.moving_object.len());
        assert_eq!(u.entities[2].lines[0].points.len(), 24, "12 box edges");
        let o = object_update(&scene, 5);
        assert!(o.entities.iter().all(|e| e.frame_locked));
        assert_eq!(stamp(3_000_000_007), Timestamp::new(3, 7));
    }
}
