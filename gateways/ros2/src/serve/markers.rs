//! The scene, the planner's roadmap and its solution path as `visualization_msgs/MarkerArray`
//! for rviz2, and the path as `nav_msgs/Path`.
//!
//! `scene_markers` (marker namespaces): `obstacles` (each obstacle part in `scene`: a box, a
//! sphere, or a mesh as a triangle list; a mesh of more than `max_mesh_triangles` triangles
//! is drawn as its bounding box), `object` (the moving object's parts in the `object` frame,
//! frame-locked so rviz2 moves them with `/tf`), `hand` (the same, translucent, in `hand`),
//! `goal` (the same, translucent green, in `goal`).
//!
//! `planner_markers`: first a DELETEALL, then `roadmap` (one line list per live tree, edges
//! from each node to its parent: start tree blue, goal tree red, local trees grey) and `path`
//! (the solution as a line strip), all in `scene`.

use std::collections::HashMap;

use ipc_types::{NO_PARENT, Roadmap, TreeKind};
use scene::{Part, Primitive, Scene, Se3};

use crate::msgs::{self, Color, Header, Marker, MarkerArray, Pose, PoseStamped, Time, marker};
use crate::serve::topics::Frames;

const OBSTACLE: Color = Color {
    r: 0.62,
    g: 0.64,
    b: 0.68,
    a: 1.0,
};
const OBJECT: Color = Color {
    r: 0.95,
    g: 0.55,
    b: 0.1,
    a: 1.0,
};
const HAND: Color = Color {
    r: 0.3,
    g: 0.5,
    b: 0.95,
    a: 0.35,
};
const GOAL: Color = Color {
    r: 0.2,
    g: 0.8,
    b: 0.3,
    a: 0.35,
};
const PATH: Color = Color {
    r: 0.1,
    g: 0.85,
    b: 0.2,
    a: 1.0,
};

fn pose_of(p: &Se3) -> Pose {
    let q = p.rot.coords;
    Pose {
        position: p.pos.into(),
        orientation: [q.x, q.y, q.z, q.w],
    }
}

/// Markers of `parts` in `frame`, ids from `id`; meshes beyond `max_triangles` become boxes
/// (their names pushed to `boxed`).
#[allow(clippy::too_many_arguments)]
fn part_markers(
    parts: &[Part],
    header: &Header,
    ns: &str,
    color: Color,
    frame_locked: bool,
    max_triangles: usize,
    out: &mut Vec<Marker>,
    boxed: &mut Vec<String>,
) {
    for (i, part) in parts.iter().enumerate() {
        let mut m = Marker {
            header: header.clone(),
            ns: ns.to_owned(),
            id: i32::try_from(i).unwrap_or(i32::MAX),
            action: marker::ADD,
            pose: pose_of(&part.pose),
            color,
            frame_locked,
            ..Marker::default()
        };
        match &part.primitive {
            Primitive::Box { half_extents_m } => {
                m.kind = marker::CUBE;
                m.scale = (half_extents_m * 2.0).into();
            }
            Primitive::Sphere { radius_m } => {
                m.kind = marker::SPHERE;
                m.scale = [2.0 * radius_m; 3];
            }
            Primitive::Mesh { mesh } if mesh.triangles.len() <= max_triangles => {
                m.kind = marker::TRIANGLE_LIST;
                m.scale = [1.0; 3];
                m.points = mesh
                    .triangles
                    .iter()
                    .flat_map(|t| t.iter().map(|&v| mesh.vertices_m[v as usize].into()))
                    .collect();
            }
            Primitive::Mesh { mesh } => {
                let mut lo = [f64::INFINITY; 3];
                let mut hi = [f64::NEG_INFINITY; 3];
                for v in &mesh.vertices_m {
                    for k in 0..3 {
                        lo[k] = lo[k].min(v[k]);
                        hi[k] = hi[k].max(v[k]);
                    }
                }
                let centre = Se3::from_xyz(
                    (lo[0] + hi[0]) / 2.0,
                    (lo[1] + hi[1]) / 2.0,
                    (lo[2] + hi[2]) / 2.0,
                );
                m.kind = marker::CUBE;
                m.pose = pose_of(&part.pose.compose(&centre));
                m.scale = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
                boxed.push(format!(
                    "{} ({} triangles)",
                    mesh.source,
                    mesh.triangles.len()
                ));
            }
        }
        out.push(m);
    }
}

/// The scene's markers; the second value names meshes drawn as their bounding boxes.
pub fn scene_markers(
    scene: &Scene,
    frames: &Frames,
    stamp: Time,
    max_mesh_triangles: usize,
) -> (MarkerArray, Vec<String>) {
    let header = |frame: &str| Header {
        stamp,
        frame_id: frame.to_owned(),
    };
    let mut markers = Vec::new();
    let mut boxed = Vec::new();
    let t = max_mesh_triangles;
    part_markers(
        &scene.obstacles,
        &header(&frames.scene),
        "obstacles",
        OBSTACLE,
        false,
        t,
        &mut markers,
        &mut boxed,
    );
    for (ns, frame, color) in [
        ("object", &frames.object, OBJECT),
        ("hand", &frames.hand, HAND),
        ("goal", &frames.goal, GOAL),
    ] {
        part_markers(
            &scene.moving_object,
            &header(frame),
            ns,
            color,
            true,
            t,
            &mut markers,
            &mut boxed,
        );
    }
    (MarkerArray { markers }, boxed)
}

/// The roadmap as the planner's increments describe it (see `ipc_types::Roadmap`): live
/// trees and the known nodes' positions and parents, at most `max_nodes` of them.
#[derive(Debug, Default)]
pub struct RoadmapModel {
    writer_pid: u32,
    last_sequence: u64,
    trees: HashMap<u32, TreeKind>,
    nodes: HashMap<(u32, u32), ([f64; 3], u32)>,
    max_nodes: usize,
    /// Nodes not kept because the model was full.
    pub dropped: u64,
}

impl RoadmapModel {
    /// An empty model keeping at most `max_nodes` nodes.
    pub fn new(max_nodes: usize) -> Self {
        RoadmapModel {
            max_nodes,
            ..RoadmapModel::default()
        }
    }

    /// Applies one increment.
    pub fn apply(&mut self, r: &Roadmap) {
        if r.header.sequence == 0 {
            return;
        }
        if r.header.writer_pid != self.writer_pid || r.header.sequence < self.last_sequence {
            self.trees.clear();
            self.nodes.clear();
            self.writer_pid = r.header.writer_pid;
        }
        self.last_sequence = r.header.sequence;
        if r.manifest_complete() {
            self.trees
                .retain(|id, _| r.trees().iter().any(|t| t.id == *id));
            self.nodes
                .retain(|(t, _), _| r.trees().iter().any(|l| l.id == *t));
        }
        for t in r.trees() {
            self.trees.insert(t.id, t.kind);
        }
        for n in r.nodes() {
            if !self.trees.contains_key(&n.tree_id) || !n.pose.is_valid() {
                continue;
            }
            let key = (n.tree_id, n.index);
            if self.nodes.len() >= self.max_nodes && !self.nodes.contains_key(&key) {
                self.dropped += 1;
                continue;
            }
            self.nodes.insert(key, (n.pose.position_m, n.parent));
        }
    }

    /// Nodes known.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True before any node arrived.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Each live tree's edges (node to parent, both known) as point pairs, by tree id.
    pub fn edges(&self) -> Vec<(u32, TreeKind, Vec<[f64; 3]>)> {
        let mut trees: Vec<(u32, TreeKind, Vec<[f64; 3]>)> = self
            .trees
            .iter()
            .map(|(id, kind)| (*id, *kind, Vec::new()))
            .collect();
        trees.sort_by_key(|t| t.0);
        for ((tree, _), (p, parent)) in &self.nodes {
            if *parent == NO_PARENT {
                continue;
            }
            if let (Some((q, _)), Ok(i)) = (
                self.nodes.get(&(*tree, *parent)),
                trees.binary_search_by_key(tree, |t| t.0),
            ) {
                trees[i].2.push(*q);
                trees[i].2.push(*p);
            }
        }
        trees
    }
}

/// The waypoints of a solution path as a `nav_msgs/Path` in `scene`.
pub fn path_message(path: &ipc_types::Path, frames: &Frames, stamp: Time) -> msgs::Path {
    let header = Header {
        stamp,
        frame_id: frames.scene.clone(),
    };
    msgs::Path {
        poses: path
            .waypoints()
            .iter()
            .map(|w| PoseStamped {
                header: header.clone(),
                pose: Pose::from(*w),
            })
            .collect(),
        header,
    }
}

/// The roadmap and the path (if any) as markers, after a DELETEALL.
pub fn planner_markers(
    roadmap: &RoadmapModel,
    path: Option<&ipc_types::Path>,
    frames: &Frames,
    stamp: Time,
) -> MarkerArray {
    let header = Header {
        stamp,
        frame_id: frames.scene.clone(),
    };
    let mut markers = vec![Marker {
        header: header.clone(),
        action: marker::DELETEALL,
        ..Marker::default()
    }];
    for (id, kind, points) in roadmap.edges() {
        if points.is_empty() {
            continue;
        }
        let color = match kind {
            TreeKind::START => Color {
                r: 0.2,
                g: 0.4,
                b: 1.0,
                a: 0.8,
            },
            TreeKind::GOAL => Color {
                r: 1.0,
                g: 0.25,
                b: 0.2,
                a: 0.8,
            },
            _ => Color {
                r: 0.6,
                g: 0.6,
                b: 0.6,
                a: 0.6,
            },
        };
        markers.push(Marker {
            header: header.clone(),
            ns: "roadmap".into(),
            id: i32::try_from(id).unwrap_or(i32::MAX),
            kind: marker::LINE_LIST,
            action: marker::ADD,
            pose: Pose {
                orientation: [0.0, 0.0, 0.0, 1.0],
                ..Pose::default()
            },
            scale: [0.001, 0.0, 0.0],
            color,
            points,
            ..Marker::default()
        });
    }
    if let Some(p) = path.filter(|p| p.waypoints().len() >= 2) {
        markers.push(Marker {
            header,
            ns: "path".into(),
            id: 0,
            kind: marker::LINE_STRIP,
            action: marker::ADD,
            pose: Pose {
                orientation: [0.0, 0.0, 0.0, 1.0],
                ..Pose::default()
            },
            scale: [0.003, 0.0, 0.0],
            color: PATH,
            points: p.waypoints().iter().map(|w| w.position_m).collect(),
            ..Marker::default()
        });
    }
    MarkerArray { markers }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipc_types::{RoadmapNode, RoadmapTree};

    fn frames() -> Frames {
        Frames::new("/hrrtc")
    }

    #[test]
    fn the_scene_becomes_shapes_in_their_frames() {
        let scene = Scene::by_name_or_path("wall-hole").unwrap();
        let (a, boxed) = scene_markers(&scene, &frames(), Time::default(), 100_000);
        assert!(boxed.is_empty());
        let count = |ns: &str| a.markers.iter().filter(|m| m.ns == ns).count();
        assert_eq!(count("obstacles"), scene.obstacles.len());
        assert_eq!(count("object"), scene.moving_object.len());
        assert_eq!(count("hand"), scene.moving_object.len());
        assert_eq!(count("goal"), scene.moving_object.len());
        for m in &a.markers {
            assert!(m.scale.iter().all(|s| *s > 0.0), "{m:?}");
            let q: f64 = m.pose.orientation.iter().map(|v| v * v).sum();
            assert!((q - 1.0).abs() < 1e-9);
            let frame = match m.ns.as_str() {
                "obstacles" => "hrrtc/scene",
                "object" => "hrrtc/object",
                "hand" => "hrrtc/hand",
                _ => "hrrtc/goal",
            };
            assert_eq!(m.header.frame_id, frame);
            assert_eq!(m.frame_locked, m.ns != "obstacles");
        }
        // The encoding is a MarkerArray rosbags reads (checked in the Python test); here it
        // round-trips through our own reader.
        let bytes = msgs::Message::encode(&a);
        assert_eq!(<MarkerArray as msgs::Message>::decode(&bytes).unwrap(), a);
    }

    #[test]
    fn large_meshes_are_drawn_as_their_bounding_boxes() {
        let scene = Scene::by_name_or_path("silencer").unwrap();
        let meshes = scene
            .obstacles
            .iter()
            .chain(&scene.moving_object)
            .filter(|p| matches!(p.primitive, Primitive::Mesh { .. }))
            .count();
        assert!(meshes > 0, "the silencer has meshes");
        let (a, boxed) = scene_markers(&scene, &frames(), Time::default(), 0);
        assert!(!boxed.is_empty());
        assert!(a.markers.iter().all(|m| m.kind != marker::TRIANGLE_LIST));
        let (a, _) = scene_markers(&scene, &frames(), Time::default(), usize::MAX);
        let tri = a
            .markers
            .iter()
            .find(|m| m.kind == marker::TRIANGLE_LIST)
            .unwrap();
        assert_eq!(tri.points.len() % 3, 0);
    }

    fn roadmap(
        pid: u32,
        seq: u64,
        trees: &[(u32, TreeKind)],
        nodes: &[(u32, u32, u32, f64)],
    ) -> Box<Roadmap> {
        let mut r = Box::new(Roadmap::default());
        r.header.sequence = seq;
        r.header.writer_pid = pid;
        r.trees_len = trees.len() as u32;
        r.trees_total = trees.len() as u32;
        for (i, (id, kind)) in trees.iter().enumerate() {
            r.trees[i] = RoadmapTree {
                id: *id,
                kind: *kind,
                len: 100,
                reserved: 0,
            };
        }
        r.nodes_len = nodes.len() as u32;
        for (i, (tree, index, parent, x)) in nodes.iter().enumerate() {
            r.nodes[i] = RoadmapNode {
                tree_id: *tree,
                index: *index,
                parent: *parent,
                pose: ipc_types::Pose {
                    position_m: [*x, 0.0, 0.0],
                    ..ipc_types::Pose::IDENTITY
                },
                ..RoadmapNode::EMPTY
            };
        }
        r
    }

    #[test]
    fn the_roadmap_model_follows_increments_trees_and_restarts() {
        let mut m = RoadmapModel::new(1000);
        m.apply(&roadmap(
            7,
            1,
            &[(0, TreeKind::START), (5, TreeKind::LOCAL)],
            &[
                (0, 0, NO_PARENT, 0.0),
                (0, 1, 0, 1.0),
                (5, 0, NO_PARENT, 5.0),
                (5, 1, 0, 6.0),
            ],
        ));
        let e = m.edges();
        assert_eq!(e.len(), 2);
        assert_eq!(e[0].2, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]);
        // The local tree is gone from the manifest: forgotten.
        m.apply(&roadmap(7, 2, &[(0, TreeKind::START)], &[(0, 2, 1, 2.0)]));
        let e = m.edges();
        assert_eq!(e.len(), 1);
        assert_eq!(e[0].2.len(), 4);
        // A new planner: a new roadmap.
        m.apply(&roadmap(
            8,
            1,
            &[(1, TreeKind::GOAL)],
            &[(1, 0, NO_PARENT, 9.0)],
        ));
        assert_eq!(m.len(), 1);
        let a = planner_markers(&m, None, &frames(), Time::default());
        assert_eq!(a.markers[0].action, marker::DELETEALL);
        // A tree with no edge yet draws nothing.
        assert_eq!(a.markers.len(), 1);
        // Full: further nodes are counted, not kept.
        let mut small = RoadmapModel::new(1);
        small.apply(&roadmap(
            1,
            1,
            &[(0, TreeKind::START)],
            &[(0, 0, NO_PARENT, 0.0), (0, 1, 0, 1.0)],
        ));
        assert_eq!((small.len(), small.dropped), (1, 1));
    }

    #[test]
    fn the_path_is_a_nav_path_and_a_line_strip() {
        let mut p = ipc_types::Path::EMPTY;
        p.header.sequence = 1;
        p.len = 3;
        for (i, w) in p.waypoints[..3].iter_mut().enumerate() {
            w.position_m = [i as f64 * 0.1, 0.0, 0.0];
        }
        let msg = path_message(&p, &frames(), Time::default());
        assert_eq!(msg.poses.len(), 3);
        assert_eq!(msg.poses[2].pose.position, [0.2, 0.0, 0.0]);
        assert_eq!(msg.header.frame_id, "hrrtc/scene");
        let a = planner_markers(&RoadmapModel::new(10), Some(&p), &frames(), Time::default());
        let line = a.markers.iter().find(|m| m.ns == "path").unwrap();
        assert_eq!(line.kind, marker::LINE_STRIP);
        assert_eq!(line.points.len(), 3);
    }
}
