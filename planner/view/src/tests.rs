//! The viewer against real iceoryx2 services fed by this test: a Foxglove WebSocket client
//! subscribes and checks the scene and the roadmap against the planner's trees; the MCAP
//! recording of the same run is read back. No wall-clock timing is asserted: waits are
//! bounded only so that a broken view fails instead of hanging.

use crate::{TOPICS, ViewConfig, ViewReport, Viewer};
use foxglove::Decode;
use foxglove::messages::{PointCloud, SceneUpdate};
use ipc_types::services;
use ipc_types::{Guidance, HapticState, Header, Path, monotonic_ns};
use planner_core::{Planner, PlannerParams, Scene};
use planner_shell::feed::{FeedInfo, RoadmapFeed};
use std::collections::BTreeMap;
use std::net::TcpStream;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use tungstenite::Message;
use tungstenite::client::IntoClientRequest;

/// A channel the server advertised: id, topic, schema name.
#[derive(Debug, Clone)]
struct Advertised {
    id: u64,
    topic: String,
    schema_name: String,
    encoding: String,
}

fn header(seq: u64) -> Header {
    Header::new(seq, monotonic_ns(), 4242)
}

#[test]
fn live_view_and_recording_match_the_planner() {
    let ns = format!("test_view_{}", std::process::id());
    let dir = std::env::temp_dir().join(&ns);
    std::fs::create_dir_all(&dir).expect("dir");
    let record = dir.join("view.mcap");

    // A planner with a roadmap of a few thousand nodes, frozen for the test.
    let scene = Scene::wall_with_hole();
    let mut planner = Planner::new(&scene, PlannerParams::default(), 3).expect("planner");
    let nodes = |p: &Planner| p.trees().iter().map(|t| t.len()).sum::<usize>();
    while nodes(&planner) < 2500 && !planner.solved() {
        planner.iterate(None);
    }
    let total = nodes(&planner);
    assert!(total > 1500, "{total} nodes");

    let (node, _) = services::create_node("view_test").expect("node");
    let state_w = services::state_writer(&node, &ns).expect("state writer");
    let roadmap_p =
        services::publisher::<ipc_types::Roadmap>(&node, &ns).expect("roadmap publisher");
    let path_p = services::publisher::<ipc_types::Path>(&node, &ns).expect("path publisher");
    let guidance_p =
        services::publisher::<ipc_types::Guidance>(&node, &ns).expect("guidance publisher");

    let config = ViewConfig {
        namespace: ns.clone(),
        scene: scene.clone(),
        host: "127.0.0.1".into(),
        port: Some(0),
        record: Some(record.clone()),
        rate_hz: 50.0,
        m_per_n: 0.02,
        duration_s: None,
    };
    let stop = Arc::new(AtomicBool::new(false));
    let (port_tx, port_rx) = std::sync::mpsc::channel();
    let viewer = {
        let stop = stop.clone();
        std::thread::spawn(move || -> Result<ViewReport, crate::ViewError> {
            let v = Viewer::new(&config)?;
            let _ = port_tx.send(v.port());
            v.run(&stop)
        })
    };
    let port = port_rx
        .recv_timeout(Duration::from_secs(30))
        .expect("the viewer starts")
        .expect("a port");

    // Connect as Foxglove does (subprotocol foxglove.sdk.v1).
    let tcp = TcpStream::connect(("127.0.0.1", port)).expect("tcp");
    tcp.set_read_timeout(Some(Duration::from_millis(10)))
        .expect("timeout");
    let mut req = format!("ws://127.0.0.1:{port}/")
        .into_client_request()
        .expect("request");
    req.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.sdk.v1".parse().expect("header"),
    );
    let (mut ws, _) = tungstenite::client(req, tcp).expect("handshake");

    // The start tree's first chunk has min(len, 1024) nodes; all but the root have an edge.
    let chunk0_want = 2 * (planner.trees()[0].len().min(1024) - 1);
    let mut feed = RoadmapFeed::new();
    let mut channels: BTreeMap<u64, Advertised> = BTreeMap::new();
    let mut subscribed = false;
    let mut obstacles_cubes = None;
    let mut cloud: Option<PointCloud> = None;
    let mut chunk0_points = None;
    let mut seq = 0u64;
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut next_publish = Instant::now();
    while cloud.as_ref().is_none_or(|c| c.data.len() / 24 < total)
        || obstacles_cubes.is_none()
        || chunk0_points != Some(chunk0_want)
    {
        assert!(Instant::now() < deadline, "the view never sent it all");
        if Instant::now() >= next_publish {
            next_publish = Instant::now() + Duration::from_millis(20);
            seq += 1;
            // The operator moves along x, 3 mm per state.
            let mut s = HapticState {
                header: header(seq),
                ..HapticState::default()
            };
            s.user_pose.position_m = [-0.2 + 0.003 * seq as f64, 0.0, 0.0];
            s.proxy_pose = s.user_pose;
            s.guidance_wrench.force_n = [1.0, 0.0, 0.0];
            state_w.update_with_copy(s);
            let mut sample = roadmap_p.loan().expect("loan");
            let info = FeedInfo {
                iterations: 400,
                solved: false,
                pid: 4242,
                timestamp_ns: monotonic_ns(),
            };
            feed.fill(
                planner.trees(),
                planner.tree_ids(),
                info,
                sample.payload_mut(),
            );
            sample.send().expect("send");
            guidance_p
                .send_copy(Guidance::roadmap(
                    header(seq),
                    [0.01, 0.0, 0.0, 0.0, 0.0, 0.0],
                    20.0,
                    0.0,
                    10_000_000_000,
                ))
                .expect("guidance");
            if seq == 3 {
                let mut p = Path::EMPTY;
                p.header = header(1);
                p.len = 3;
                p.waypoints[0].position_m = [-0.2, 0.0, 0.0];
                p.waypoints[1].position_m = [0.0, 0.0, 0.0];
                p.waypoints[2].position_m = [0.2, 0.0, 0.0];
                path_p.send_copy(p).expect("path");
            }
        }
        let msg = match ws.read() {
            Ok(m) => m,
            Err(tungstenite::Error::Io(e))
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                continue;
            }
            Err(e) => panic!("websocket: {e}"),
        };
        match msg {
            Message::Text(t) => {
                let v: serde_json::Value = serde_json::from_str(&t).expect("json");
                if v["op"] == "advertise" {
                    for c in v["channels"].as_array().expect("channels") {
                        let a = Advertised {
                            id: c["id"].as_u64().expect("id"),
                            topic: c["topic"].as_str().expect("topic").into(),
                            schema_name: c["schemaName"].as_str().unwrap_or("").into(),
                            encoding: c["encoding"].as_str().unwrap_or("").into(),
                        };
                        channels.insert(a.id, a);
                    }
                }
                if !subscribed && channels.len() >= TOPICS.len() {
                    // Subscription id = channel id.
                    let subs: Vec<serde_json::Value> = channels
                        .keys()
                        .map(|id| serde_json::json!({"id": id, "channelId": id}))
                        .collect();
                    let m = serde_json::json!({"op": "subscribe", "subscriptions": subs});
                    ws.send(Message::Text(m.to_string().into()))
                        .expect("subscribe");
                    subscribed = true;
                }
            }
            Message::Binary(b) => {
                assert_eq!(b[0], 1, "message data opcode");
                let sub = u32::from_le_bytes(b[1..5].try_into().expect("4 bytes")) as u64;
                let payload = &b[13..];
                let topic = channels[&sub].topic.as_str();
                match topic {
                    "/view/scene" => {
                        let u = SceneUpdate::decode(payload).expect("scene update");
                        let e = u
                            .entities
                            .iter()
                            .find(|e| e.id == "obstacles")
                            .expect("obstacles entity");
                        obstacles_cubes = Some(e.cubes.len());
                    }
                    "/view/roadmap/nodes" => {
                        cloud = Some(PointCloud::decode(payload).expect("point cloud"));
                    }
                    "/view/roadmap/edges" => {
                        let u = SceneUpdate::decode(payload).expect("edges");
                        if let Some(e) = u.entities.iter().find(|e| e.id == "tree0/chunk0") {
                            chunk0_points = Some(e.lines[0].points.len());
                        }
                    }
                    _ => {}
                }
            }
            _ => {}
        }
    }

    // What the client saw matches the planner.
    let topics: Vec<&str> = channels.values().map(|c| c.topic.as_str()).collect();
    for t in TOPICS {
        assert!(topics.contains(&t), "{t} advertised: {topics:?}");
    }
    let scene_ch = channels
        .values()
        .find(|c| c.topic == "/view/scene")
        .expect("scene");
    assert_eq!(scene_ch.schema_name, "foxglove.SceneUpdate");
    assert_eq!(scene_ch.encoding, "protobuf");
    assert_eq!(obstacles_cubes, Some(scene.obstacles.len()));
    let cloud = cloud.expect("cloud");
    assert_eq!(cloud.point_stride, 24);
    assert_eq!(cloud.data.len() / 24, total, "every node, each once");
    let points: Vec<[f32; 3]> = cloud
        .data
        .chunks_exact(24)
        .map(|p| {
            let f = |k: usize| f32::from_le_bytes(p[4 * k..4 * k + 4].try_into().expect("4"));
            [f(0), f(1), f(2)]
        })
        .collect();
    for tree in planner.trees() {
        for n in [tree.nodes().first(), tree.nodes().last()]
            .into_iter()
            .flatten()
        {
            let want = [
                n.config.pos.x as f32,
                n.config.pos.y as f32,
                n.config.pos.z as f32,
            ];
            assert!(points.contains(&want), "node at {want:?} is in the cloud");
        }
    }

    // Stop: the recording is closed and read back.
    stop.store(true, Ordering::Release);
    let report = viewer.join().expect("viewer thread").expect("viewer run");
    assert_eq!(report.nodes_known as usize, total);
    assert_eq!(report.path_waypoints, 3);
    assert!(report.states_seen > 0 && report.roadmap_samples > 0);
    let bytes = std::fs::read(&record).expect("recording");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("a summary section");
    let mut counts: BTreeMap<String, u64> = BTreeMap::new();
    let mut schemas: BTreeMap<String, String> = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).expect("stream") {
        let m = m.expect("message");
        *counts.entry(m.channel.topic.clone()).or_default() += 1;
        assert_eq!(m.channel.message_encoding, "protobuf");
        let name = m.channel.schema.as_ref().map(|s| s.name.clone());
        schemas.insert(m.channel.topic.clone(), name.unwrap_or_default());
    }
    assert_eq!(summary.channels.len(), TOPICS.len());
    for t in TOPICS {
        assert!(
            counts.get(t).copied().unwrap_or(0) > 0,
            "{t} recorded: {counts:?}"
        );
    }
    assert_eq!(
        counts, report.messages,
        "the file holds every message logged"
    );
    let want = [
        ("/view/scene", "foxglove.SceneUpdate"),
        ("/view/object", "foxglove.SceneUpdate"),
        ("/view/tf", "foxglove.FrameTransforms"),
        ("/view/forces", "foxglove.SceneUpdate"),
        ("/view/roadmap/edges", "foxglove.SceneUpdate"),
        ("/view/roadmap/nodes", "foxglove.PointCloud"),
        ("/view/trail", "foxglove.SceneUpdate"),
        ("/view/path", "foxglove.SceneUpdate"),
    ];
    for (topic, schema) in want {
        assert_eq!(schemas[topic], schema, "{topic}");
    }
    assert!(
        schemas["/view/status"].ends_with("ViewStatus"),
        "{schemas:?}"
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn merged_recordings_keep_every_channel_and_message_in_time_order() {
    let dir = std::env::temp_dir().join(format!("view_merge_{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let write = |name: &str, topic: &str, times: &[u64]| {
        let p = dir.join(name);
        let mut w = mcap::Writer::new(std::io::BufWriter::new(
            std::fs::File::create(&p).expect("create"),
        ))
        .expect("writer");
        let s = w.add_schema("s", "jsonschema", b"{}").expect("schema");
        let c = w
            .add_channel(s, topic, "json", &BTreeMap::new())
            .expect("channel");
        for (i, t) in times.iter().enumerate() {
            w.write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: c,
                    sequence: i as u32,
                    log_time: *t,
                    publish_time: *t,
                },
                b"{}",
            )
            .expect("write");
        }
        w.finish().expect("finish");
        p
    };
    let a = write("device.mcap", "/device/state", &[1, 3, 5]);
    let b = write("view.mcap", "/view/status", &[2, 4]);
    let out = dir.join("both.mcap");
    assert_eq!(crate::merge_mcap(&[a, b], &out).expect("merge"), 5);
    let bytes = std::fs::read(&out).expect("read");
    let got: Vec<(String, u64)> = mcap::MessageStream::new(&bytes)
        .expect("stream")
        .map(|m| {
            let m = m.expect("message");
            (m.channel.topic.clone(), m.log_time)
        })
        .collect();
    let topic = |t: u64| {
        if t % 2 == 1 {
            "/device/state"
        } else {
            "/view/status"
        }
    };
    let want: Vec<(String, u64)> = (1..=5).map(|t| (topic(t).to_string(), t)).collect();
    assert_eq!(got, want);
    // A file that is not MCAP is an error naming it.
    let bad = dir.join("bad.mcap");
    std::fs::write(&bad, b"not mcap").expect("write");
    let e = crate::merge_mcap(std::slice::from_ref(&bad), &dir.join("x.mcap")).unwrap_err();
    assert!(format!("{e:#}").contains("bad.mcap"), "{e:#}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn the_shipped_layout_names_only_topics_the_view_writes() {
    let text = include_str!("../layout.json");
    let v: serde_json::Value = serde_json::from_str(text).expect("layout.json is JSON");
    let panel = &v["configById"]["3D!hrrtc-view"];
    let topics = panel["topics"].as_object().expect("3D topics");
    assert!(!topics.is_empty());
    for t in topics.keys() {
        assert!(TOPICS.contains(&t.as_str()), "{t}");
    }
    assert_eq!(panel["followTf"], draw_frame());
    assert_eq!(
        topics["/view/roadmap/nodes"]["colorField"], "distance_to_goal",
        "a field of the nodes cloud"
    );
    assert_eq!(
        v["configById"]["RawMessages!hrrtc-status"]["topicPath"],
        "/view/status"
    );
}

fn draw_frame() -> &'static str {
    crate::draw::SCENE_FRAME
}
