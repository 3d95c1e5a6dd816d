"""`hrrtc-ros2` against rmw_zenoh's documented wire, with no ROS install: a Zenoh peer
(eclipse-zenoh) connected to the gateway decodes every topic with rosbags' CDR and message
definitions, checks keys, type hashes (rosbags' own RIHS01), liveliness tokens, QoS and
attachments against rmw_zenoh_format (the design document, written independently of the
gateway), reads the TRANSIENT_LOCAL topics as a late joiner through zenoh-ext's advanced
subscriber (what rmw_zenoh's subscriptions are), publishes guidance the loop renders and
malformed guidance it never sees, and plays a ROS 2 arm driver for `--device ros2:`.

Binaries come from $HRRTC_BIN_DIR (default: the repository's target/debug).
"""

import json
import math
import os
import pathlib
import socket
import subprocess
import time

import numpy as np
import pytest
import zenoh
import zenoh.ext
from rosbags.typesys import Stores, get_typestore

import hrrtc
import rmw_zenoh_format as rmw

REPO = pathlib.Path(__file__).resolve().parents[3]
BIN_DIR = pathlib.Path(os.environ.get("HRRTC_BIN_DIR", REPO / "target" / "debug"))
STORE = get_typestore(Stores.ROS2_JAZZY)
T = STORE.types
DOMAIN = 0


def cdr(msg, ros_type):
    """rosbags' CDR encoding of `msg` (bytes)."""
    return bytes(STORE.serialize_cdr(msg, ros_type))


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(what, timeout_s, f):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        v = f()
        if v is not None:
            return v
        time.sleep(0.005)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")


def exe(name):
    p = BIN_DIR / name
    assert p.exists(), f"{p} is missing: build it with `cargo build -p {name}`"
    return str(p)


def start_loop(ns, summary, *extra):
    return subprocess.Popen(
        [exe("haptic-loop"), "run", "--namespace", ns, "--priority", "0", "--no-mlock",
         "--no-contact", "--duration-s", "60", "--summary-json", str(summary), *extra],
        stdout=subprocess.DEVNULL,
    )


def stop(proc):
    proc.terminate()
    assert proc.wait(timeout=20) == 0


def session(port):
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    conf.insert_json5("listen/endpoints", "[]")
    return zenoh.open(conf)


def tokens(z):
    return [str(r.ok.key_expr) for r in z.liveliness().get(f"{rmw.ADMIN_SPACE}/{DOMAIN}/**")
            if r.ok is not None]


@pytest.fixture
def gateway(tmp_path):
    """A loop and `hrrtc-ros2 serve` on a namespace of their own; yields a dict with the
    namespace, the ROS namespace, the Zenoh port, the processes and their summaries."""
    tag = f"{os.getpid()}_{time.monotonic_ns() % 1_000_000}"
    ns, ros_ns, port = f"py_ros2_{tag}", f"/it{tag}", free_port()
    loop_summary, gw_summary = tmp_path / "loop.json", tmp_path / "gateway.json"
    log = open(tmp_path / "gateway.log", "w+")
    lp = start_loop(ns, loop_summary)
    gw = subprocess.Popen(
        [exe("hrrtc-ros2"), "serve", "--namespace", ns, "--ros-namespace", ros_ns,
         "--no-connect", "--listen", f"tcp/127.0.0.1:{port}", "--insecure", "--scene", "wall-hole",
         "--parent-frame", "world", "--duration-s", "60", "--summary-json", str(gw_summary)],
        stdout=subprocess.DEVNULL, stderr=log,
    )
    g = dict(ns=ns, ros_ns=ros_ns, port=port, loop=lp, gw=gw, loop_summary=loop_summary,
             gw_summary=gw_summary, log=log, prefix=ros_ns.strip("/") + "/")
    try:
        yield g
    finally:
        for p in (gw, lp):
            if p.poll() is None:
                p.kill()
                p.wait(timeout=20)
        log.close()


def decode(sample):
    """(topic, ROS type, message, attachment) of a sample, checking its key and hash."""
    key = str(sample.key_expr)
    parts = key.split("/")
    assert parts[0] == str(DOMAIN), key
    ros_type = rmw.dds_to_ros(parts[-2])
    assert parts[-1] == STORE.hash_rihs01(ros_type), f"{key}: not rosbags' RIHS01 of {ros_type}"
    payload = sample.payload.to_bytes()
    assert payload[:4] == b"\x00\x01\x00\x00", f"{key}: encapsulation {payload[:4].hex()}"
    msg = STORE.deserialize_cdr(payload, ros_type)
    # Re-encoding the decoded message gives the same bytes: nothing left over, nothing
    # rosbags would write differently.
    assert cdr(msg, ros_type) == payload, key
    raw = sample.attachment.to_bytes() if sample.attachment is not None else None
    att = rmw.decode_attachment(raw)
    assert zenoh.ext.z_deserialize(
        tuple[zenoh.ext.Int64, zenoh.ext.Int64, bytes], sample.attachment) == att
    return "/" + "/".join(parts[1:-2]), ros_type, msg, att


def unit(q):
    return abs(math.sqrt(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2) - 1.0) < 1e-6


STATE_TOPICS = {
    "object_pose": ("geometry_msgs/msg/PoseStamped", "scene"),
    "hand_pose": ("geometry_msgs/msg/PoseStamped", "scene"),
    "device_pose": ("geometry_msgs/msg/PoseStamped", "device_base"),
    "commanded_wrench": ("geometry_msgs/msg/WrenchStamped", "device"),
    "guidance_wrench": ("geometry_msgs/msg/WrenchStamped", "object"),
    "contact_wrench": ("geometry_msgs/msg/WrenchStamped", "object"),
    "contact": ("std_msgs/msg/Float64MultiArray", None),
}


def test_every_topic_token_and_attachment_follows_rmw_zenoh(gateway):
    g = gateway
    prefix, ros_ns = g["prefix"], g["ros_ns"]
    node = hrrtc.create_node()
    reader = hrrtc.StateReader(node, g["ns"], timeout_s=30)
    wait_for("100 ticks", 30, lambda: (s := reader.read()) and s.header.sequence > 100 or None)
    # The planner of the `free` scene solves at once: a path and a roadmap to republish.
    planner = subprocess.Popen([exe("planner"), "serve", "--namespace", g["ns"], "--scene", "free"],
                               stdout=subprocess.DEVNULL)
    z = session(g["port"])
    try:
        # --- Liveliness: the node and each endpoint, parsed as rmw_zenoh parses them.
        expected_pubs = {f"{ros_ns}/{t}": ty for t, (ty, _) in STATE_TOPICS.items()}
        expected_pubs.update({
            "/tf": "tf2_msgs/msg/TFMessage", "/tf_static": "tf2_msgs/msg/TFMessage",
            f"{ros_ns}/path": "nav_msgs/msg/Path",
            f"{ros_ns}/scene_markers": "visualization_msgs/msg/MarkerArray",
            f"{ros_ns}/planner_markers": "visualization_msgs/msg/MarkerArray",
        })

        def all_tokens():
            ts = [rmw.parse_token(k) for k in tokens(z)]
            mine = [t for t in ts if t["namespace"] == ros_ns]
            return mine if len(mine) == 1 + len(expected_pubs) + 1 else None

        toks = wait_for("the gateway's liveliness tokens", 10, all_tokens)
        zids = {str(p) for p in z.info.peers_zid()}
        nodes = [t for t in toks if t["kind"] == "NN"]
        assert len(nodes) == 1 and nodes[0]["node"] == "hrrtc_gateway", nodes
        assert nodes[0]["zid"] in zids, (nodes[0], zids)
        assert nodes[0]["enclave"] == "/"
        pubs = {t["topic"]: t for t in toks if t["kind"] == "MP"}
        assert set(pubs) == set(expected_pubs), sorted(pubs)
        for topic, t in pubs.items():
            assert t["type"] == rmw.ros_to_dds(expected_pubs[topic]), t
            assert t["hash"] == STORE.hash_rihs01(expected_pubs[topic]), t
            assert t["zid"] == nodes[0]["zid"] and t["nid"] == nodes[0]["nid"], t
            assert t["qos"]["reliability"] == 1 and t["qos"]["history"] == 1, t
        transient = {"/tf_static", f"{ros_ns}/path", f"{ros_ns}/scene_markers"}
        for topic, t in pubs.items():
            assert t["qos"]["durability"] == (1 if topic in transient else 2), t
        subs = [t for t in toks if t["kind"] == "MS"]
        assert len(subs) == 1 and subs[0]["topic"] == f"{ros_ns}/guidance", subs
        assert subs[0]["type"] == "geometry_msgs::msg::dds_::WrenchStamped_"
        token_of = {rmw.demangle(k.split("/")[9]): k for k in tokens(z)
                    if k.split("/")[5] == "MP" and rmw.demangle(k.split("/")[7]) == ros_ns}

        # --- Every tick's topics, decoded, for a second: at the loop's rate.
        got = []
        sub = z.declare_subscriber(f"{DOMAIN}/**", lambda s: got.append(s))
        first = reader.read().header.sequence
        time.sleep(1.0)
        last = reader.read().header.sequence
        sub.undeclare()
        by_topic = {}
        now = time.time_ns()
        for s in list(got):
            topic, ros_type, msg, (seq, stamp, gid) = decode(s)
            assert gid == rmw.gid_of(token_of[topic]), f"{topic}: GID is not XXH3-128 of its token"
            assert abs(stamp - now) < 5e9, f"{topic}: source timestamp {stamp} is not now"
            by_topic.setdefault(topic, []).append((seq, ros_type, msg))
        ticks = last - first
        for t, (ty, frame) in STATE_TOPICS.items():
            samples = by_topic[f"{ros_ns}/{t}"]
            assert len(samples) >= 0.8 * ticks, f"{t}: {len(samples)} samples in {ticks} ticks"
            # From 1 per publisher, increasing (Zenoh drops rather than queue when the
            # machine is busy: rmw_zenoh's KEEP_LAST congestion control, so gaps may occur).
            seqs = [s[0] for s in samples]
            assert all(a < b for a, b in zip(seqs, seqs[1:])), f"{t}: sequence numbers not increasing"
            for _, ros_type, m in samples:
                assert ros_type == ty
                if frame is not None:
                    assert m.header.frame_id == prefix + frame, m.header.frame_id
                    assert abs(m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 - now * 1e-9) < 5
                if ty.endswith("PoseStamped"):
                    assert unit(m.pose.orientation)
                    p = m.pose.position
                    assert all(math.isfinite(v) for v in (p.x, p.y, p.z))
                if ty.endswith("WrenchStamped"):
                    f = m.wrench.force
                    assert all(math.isfinite(v) for v in (f.x, f.y, f.z))
                if ty.endswith("Float64MultiArray"):
                    assert len(m.data) == 10 and m.layout.dim[0].size == 10
                    assert m.layout.dim[0].label.split(",")[0] == "code"
                    assert m.data[0] == 0.0  # --no-contact: contact rendering off
        tf = by_topic["/tf"]
        assert len(tf) >= 0.8 * ticks
        children = [t.child_frame_id for t in tf[-1][2].transforms]
        assert children == [prefix + "object", prefix + "hand", prefix + "device"]
        assert all(unit(t.transform.rotation) for t in tf[-1][2].transforms)
        # The object's TF and its pose topic carry the same pose in the same tick (the
        # subscription ended inside a tick, so its last samples may have no partner).
        stamp = lambda t: (t.sec, t.nanosec)
        tf_at = {stamp(m.transforms[0].header.stamp): m.transforms[0] for _, _, m in tf}
        pairs = [(m, tf_at[stamp(m.header.stamp)]) for _, _, m in by_topic[f"{ros_ns}/object_pose"]
                 if stamp(m.header.stamp) in tf_at]
        assert len(pairs) >= 0.8 * ticks, f"{len(pairs)} ticks on both topics of {ticks}"
        for m, t in pairs:
            p, q = m.pose.position, t.transform.translation
            assert (p.x, p.y, p.z) == (q.x, q.y, q.z)

        # --- TRANSIENT_LOCAL topics, read as a late joiner by rmw_zenoh's subscription.
        def late(topic, ty):
            out = []
            key = rmw.topic_key(DOMAIN, topic, rmw.ros_to_dds(ty), STORE.hash_rihs01(ty))
            s = zenoh.ext.declare_advanced_subscriber(
                z, key, lambda s: out.append(s),
                history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1),
                subscriber_detection=True)
            try:
                return wait_for(f"{topic} from the publication cache", 10, lambda: out or None)
            finally:
                s.undeclare()

        static = decode(late("/tf_static", "tf2_msgs/msg/TFMessage")[0])[2]
        frames = {(t.header.frame_id, t.child_frame_id) for t in static.transforms}
        assert frames == {("world", prefix + "scene"), (prefix + "scene", prefix + "start"),
                          (prefix + "scene", prefix + "goal")}, frames
        markers = decode(late(f"{ros_ns}/scene_markers", "visualization_msgs/msg/MarkerArray")[0])[2]
        namespaces = {m.ns for m in markers.markers}
        assert namespaces == {"obstacles", "object", "hand", "goal"}, namespaces
        assert all(unit(m.pose.orientation) for m in markers.markers)
        path = decode(late(f"{ros_ns}/path", "nav_msgs/msg/Path")[0])[2]
        assert len(path.poses) >= 2 and path.header.frame_id == prefix + "scene"
        assert all(unit(p.pose.orientation) for p in path.poses)

        # The roadmap and path markers, at their rate.
        planner_markers = []
        key = rmw.topic_key(DOMAIN, f"{ros_ns}/planner_markers",
                            rmw.ros_to_dds("visualization_msgs/msg/MarkerArray"),
                            STORE.hash_rihs01("visualization_msgs/msg/MarkerArray"))
        s = z.declare_subscriber(key, lambda s: planner_markers.append(s))
        wait_for("planner markers", 10, lambda: planner_markers or None)
        s.undeclare()
        m = decode(planner_markers[0])[2]
        assert m.markers[0].action == 3  # DELETEALL first
        kinds = {x.ns for x in m.markers[1:]}
        assert kinds <= {"roadmap", "path"} and "roadmap" in kinds, kinds
    finally:
        planner.terminate()
        planner.wait(timeout=20)
        z.close()
    stop(g["gw"])
    report = json.loads(g["gw_summary"].read_text())
    assert report["paths"] >= 1 and report["ticks_published"] > 0
    assert all(t["failed"] == 0 for t in report["topics"]), report["topics"]
    stop(g["loop"])


def wrench_stamped(frame, force, stamp_ns):
    return T["geometry_msgs/msg/WrenchStamped"](
        header=T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9),
            frame_id=frame),
        wrench=T["geometry_msgs/msg/Wrench"](
            force=T["geometry_msgs/msg/Vector3"](x=force[0], y=force[1], z=force[2]),
            torque=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)))


def test_ros2_guidance_is_rendered_and_malformed_guidance_never_reaches_the_arm(gateway):
    g = gateway
    node = hrrtc.create_node()
    reader = hrrtc.StateReader(node, g["ns"], timeout_s=30)
    # Past the loop's start-up ramp (forces come back through a ramp).
    wait_for("1500 ticks", 30, lambda: (s := reader.read()) and s.header.sequence > 1500 or None)
    z = session(g["port"])
    ty = "geometry_msgs/msg/WrenchStamped"
    topic = f"{g['ros_ns']}/guidance"
    key = rmw.topic_key(DOMAIN, topic, rmw.ros_to_dds(ty), STORE.hash_rihs01(ty))
    pub = z.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)
    scene = g["prefix"] + "scene"
    gid = bytes(range(16))
    seq = [0]

    def put(payload, attachment=True, publisher=pub):
        seq[0] += 1
        att = rmw.encode_attachment(seq[0], time.time_ns(), gid) if attachment else None
        publisher.put(payload, attachment=att)

    try:
        wait_for("the gateway's guidance subscription", 10,
                 lambda: any(k.split("/")[5] == "MS" for k in tokens(z)) or None)
        good = lambda: cdr(wrench_stamped(scene, (0.3, 0.0, 0.0), time.time_ns()), ty)
        last = [-1.0]

        def rendered():
            if time.monotonic() - last[0] >= 0.05:
                put(good())
                last[0] = time.monotonic()
            s = reader.read()
            fresh = s.guidance_freshness == hrrtc.GuidanceFreshness.FRESH
            f = s.guidance_wrench.force_n[:]
            return s if fresh and abs(f[0] - 0.3) < 1e-9 and abs(f[1]) + abs(f[2]) < 1e-9 else None

        wait_for("the loop renders guidance from ROS 2", 10, rendered)

        # Malformed samples, each kind three times, 20 ms apart; the state is watched between.
        other = "geometry_msgs/msg/PoseStamped"
        wrong_key = rmw.topic_key(DOMAIN, topic, rmw.ros_to_dds(other), STORE.hash_rihs01(other))
        wrong_pub = z.declare_publisher(wrong_key, congestion_control=zenoh.CongestionControl.BLOCK)
        pose = T[other](header=T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id=scene),
            pose=T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
        big_endian = bytearray(good())
        big_endian[1] = 0
        bad = {
            "wrong_type": lambda: put(cdr(pose, other), publisher=wrong_pub),
            "attachment": lambda: put(good(), attachment=False),
            "cdr": lambda: put(good()[:-8]),
            "frame": lambda: put(cdr(wrench_stamped("map", (0.3, 0, 0), time.time_ns()), ty)),
            "future": lambda: put(cdr(wrench_stamped(scene, (0.3, 0, 0), time.time_ns() + 10**9), ty)),
            "stale": lambda: put(cdr(wrench_stamped(scene, (0.3, 0, 0), time.time_ns() - 10**9), ty)),
            "invalid": lambda: put(cdr(wrench_stamped(scene, (math.nan, 0, 0), time.time_ns()), ty)),
        }
        huge = lambda: put(cdr(wrench_stamped(scene, (1e12, 0, 0), time.time_ns()), ty))
        be = lambda: put(bytes(big_endian))
        sent = {k: 0 for k in bad}
        for _ in range(3):
            for kind, send in list(bad.items()) + [("invalid", huge), ("cdr", be)]:
                send()
                sent[kind] += 1
                end = time.monotonic() + 0.02
                while time.monotonic() < end:
                    s = reader.read()
                    f = s.guidance_wrench.force_n[:]
                    assert all(math.isfinite(v) for v in f), f
                    # Never more than the last valid sample's 0.3 N (held, then faded).
                    assert math.sqrt(sum(v * v for v in f)) <= 0.3 + 1e-9, f
        last[0] = -1.0
        wait_for("good guidance after bad", 10, rendered)
    finally:
        z.close()
    stop(g["gw"])
    report = json.loads(g["gw_summary"].read_text())["guidance"]
    assert report["rejected"] == sent, report
    assert report["delivered"] >= 2 and report["dropped"] == 0, report
    g["log"].seek(0)
    log = g["log"].read()
    for kind in sent:
        assert f"rejected a guidance sample ({kind})" in log, (kind, log[-2000:])
    stop(g["loop"])
    # Nothing malformed reached the loop.
    assert json.loads(g["loop_summary"].read_text())["loop_report"]["guidance_rejected"] == 0


def test_a_ros2_driver_is_the_loops_device(tmp_path):
    """Python plays an arm's ROS 2 driver: its PoseStamped reaches the loop as the device pose
    and the loop's WrenchStamped commands come back; a NaN pose faults the loop at once with
    zero force, and a driver that stops is a fault too."""
    tag = f"{os.getpid()}_{time.monotonic_ns() % 1_000_000}"
    ns, port = f"py_ros2dev_{tag}", free_port()
    pose_topic, wrench_topic = f"/arm{tag}/pose", f"/arm{tag}/wrench"
    z = None
    summary = tmp_path / "loop.json"
    # The loop starts hrrtc-ros2 beside itself; it listens, Python connects.
    lp = start_loop(ns, summary, "--device",
                    f"ros2:pose={pose_topic},wrench={wrench_topic},max_force=4,workspace=0.1,"
                    f"stale_ms=100,listen=tcp/127.0.0.1:{port},insecure=true")
    commands = []
    stop_driver = [False]
    try:
        conf_deadline = time.monotonic() + 30
        while z is None:
            try:
                z = session(port)
                if not list(z.info.peers_zid()):
                    z.close()
                    z = None
                    raise ConnectionError
            except Exception:
                assert time.monotonic() < conf_deadline, "hrrtc-ros2 device never listened"
                time.sleep(0.1)
        ps = "geometry_msgs/msg/PoseStamped"
        ws = "geometry_msgs/msg/WrenchStamped"
        pub = z.declare_publisher(rmw.topic_key(DOMAIN, pose_topic, rmw.ros_to_dds(ps), STORE.hash_rihs01(ps)))
        wkey = rmw.topic_key(DOMAIN, wrench_topic, rmw.ros_to_dds(ws), STORE.hash_rihs01(ws))
        sub = z.declare_subscriber(wkey, lambda s: commands.append(s))
        x = [0.01]
        n = [0]

        def publish(position=None):
            n[0] += 1
            px = x[0] if position is None else position
            msg = T[ps](header=T["std_msgs/msg/Header"](
                stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id="arm_base"),
                pose=T["geometry_msgs/msg/Pose"](
                    position=T["geometry_msgs/msg/Point"](x=px, y=0.0, z=0.0),
                    orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
            pub.put(cdr(msg, ps),
                    attachment=rmw.encode_attachment(n[0], time.time_ns(), bytes(16)))

        node = hrrtc.create_node()
        deadline = time.monotonic() + 30
        reader = None
        while reader is None:
            publish()
            time.sleep(0.002)
            try:
                reader = hrrtc.StateReader(node, ns, timeout_s=0.01)
            except TimeoutError:
                assert time.monotonic() < deadline, "the loop never opened the ROS 2 device"

        def running(pred, what, seconds=15, step=0.0):
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                x[0] += step
                publish()
                time.sleep(0.002)
                s = reader.read()
                if s is not None and s.header.sequence and pred(s):
                    return s
            raise AssertionError(f"timed out waiting for {what}")

        running(lambda s: abs(s.device_pose.position_m[0] - x[0]) < 1e-12, "the device pose")
        # The arm moves (5 mm/s, well within what the loop believes an arm can do).
        start = x[0]
        running(lambda s: s.device_pose.position_m[0] > start + 1e-3, "the pose to move", step=1e-5)
        running(lambda s: s.fault == hrrtc.FaultCode.NONE, "forces on (past the start-up hold)")
        assert commands, "no wrench command came back"
        topic, ty, w, att = decode(commands[-1])
        assert (topic, ty) == (wrench_topic, ws)
        assert w.header.frame_id == "arm_base"
        f = w.wrench.force
        assert all(math.isfinite(v) for v in (f.x, f.y, f.z))
        assert math.sqrt(f.x ** 2 + f.y ** 2 + f.z ** 2) <= 4.0 + 1e-9

        # One NaN pose among good ones: the gateway answers it with a FAULT state, and the
        # loop latches a read fault (not a stale one: good poses keep coming) with zero force.
        publish(position=math.nan)
        s = running(lambda s: s.fault != hrrtc.FaultCode.NONE, "a fault after the NaN pose", 5)
        assert s.fault == hrrtc.FaultCode.DEVICE_READ, hrrtc.FaultCode.name_of(s.fault)
        assert list(s.commanded_wrench.force_n) == [0.0] * 3
        # Good poses again: forces return (through the loop's ramp).
        running(lambda s: s.fault == hrrtc.FaultCode.NONE, "forces back after the fault")
        # The driver stops: stale, a fault, zero force.
        end = time.monotonic() + 5
        while (s := reader.read()).fault != hrrtc.FaultCode.DEVICE_DISCONNECTED:
            assert time.monotonic() < end, hrrtc.FaultCode.name_of(s.fault)
            time.sleep(0.002)
        assert list(s.commanded_wrench.force_n) == [0.0] * 3
        sub.undeclare()
    finally:
        if z is not None:
            z.close()
    stop(lp)


def test_the_rviz_config_shows_the_gateways_topics_in_its_frames():
    """gateways/ros2/rviz/hrrtc.rviz (for the default ROS namespace /hrrtc) names only topics
    the gateway publishes, with their durability, and the scene as the fixed frame."""
    from ruamel.yaml import YAML

    config = YAML(typ="safe").load((REPO / "gateways/ros2/rviz/hrrtc.rviz").read_text())
    manager = config["Visualization Manager"]
    assert manager["Global Options"]["Fixed Frame"] == "hrrtc/scene"
    published = {f"/hrrtc/{t}" for t in STATE_TOPICS} | {
        "/hrrtc/path", "/hrrtc/scene_markers", "/hrrtc/planner_markers"}
    transient = {"/hrrtc/path", "/hrrtc/scene_markers"}
    topics = [d["Topic"] for d in manager["Displays"] if "Topic" in d]
    assert len(topics) >= 5
    for t in topics:
        assert t["Value"] in published, t
        expected = "Transient Local" if t["Value"] in transient else "Volatile"
        assert t["Durability Policy"] == expected, t
