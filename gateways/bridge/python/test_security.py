"""Who the loop's bridge lets in, played by a foreign client: eclipse-zenoh from PyPI, with
the bridge's frames built from the Python wire layout (``hrrtc.wire``), as anyone could.

A loop runs with its bridge listening on mutual TLS (``--allow-peer planner``); each test
starts one Python peer that tries what a planner does for a few seconds: subscribe to the
state, answer the bridges' probes (so that the bridge's liveness check is passed and only
TLS and access control can keep it out), and publish guidance of 3 N. The loop's own
summary then says whether any of that guidance reached the arm
(``loop_report.guidance_latency_us.count``), and the peer says whether any state reached
it. The allowed peer, in the same set-up, is the positive control: a refusal counts only
beside it.

Binaries come from $HRRTC_BIN_DIR (default: the repository's target/debug).
"""

import ctypes
import json
import os
import pathlib
import socket
import struct
import subprocess
import threading
import time

import pytest
import zenoh

from hrrtc import wire

REPO = pathlib.Path(__file__).resolve().parents[3]
BIN_DIR = pathlib.Path(os.environ.get("HRRTC_BIN_DIR", REPO / "target" / "debug"))
MAGIC = b"HRB1"
STATE, GUIDANCE, PING, PONG = 1, 2, 5, 6
PEER_ID = 0x666_0000_0000_0666
# How long each peer tries, s: ~200 probes answered and ~1 000 guidance samples offered.
TRY_S = 5.0
# The link the bridge listens on: QUIC (TLS 1.3 over UDP). Zenoh 1.10's tls/ link shares one
# rustls connection between a reading and a writing task (eclipse-zenoh/zenoh#2557), which
# can crash a process when a link closes.
LINK = os.environ.get("HRRTC_TEST_LINK", "quic")


def exe(name):
    p = BIN_DIR / name
    assert p.exists(), f"{p} is missing: build it with `cargo build -p {name}`"
    return str(p)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(what, timeout_s, f):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        v = f()
        if v:
            return v
        time.sleep(0.02)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")


def certs(out, *names):
    """`hrrtc-bridge certs` into `out`: a CA of its own and one certificate per name."""
    args = [exe("hrrtc-bridge"), "certs", "--out", str(out)]
    for n in names:
        args += ["--name", n]
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
    return out


@pytest.fixture(scope="module")
def labs(tmp_path_factory):
    """The lab's CA with the loop, the allowed planner and an intruder; another lab's CA with
    a certificate named like the allowed planner."""
    lab = certs(tmp_path_factory.mktemp("lab"), "loop=127.0.0.1", "planner", "intruder")
    other = certs(tmp_path_factory.mktemp("other"), "planner")
    return lab, other


def frame(kind, sender, payload=b""):
    return MAGIC + struct.pack("<IQQ", kind, sender, time.monotonic_ns()) + payload


def guidance(seq):
    """3 N of guidance along x (0.01 m at 300 N/m) from planner id 666, fresh for 100 ms."""
    g = wire.Guidance()
    g.header.sequence = seq
    g.header.timestamp_ns = time.monotonic_ns()
    g.header.writer_pid = os.getpid()
    g.attractive[0] = 0.01
    g.gain_n_per_m = 300.0
    g.time_to_live_ns = 100_000_000
    g.mode = wire.GuidanceMode.ROADMAP
    g.planner_id = 666
    return bytes(g)


class Peer:
    """A Zenoh peer that plays a planner's bridge against `port` for TRY_S seconds."""

    def __init__(self, ns, port, tls, answer_probes=True):
        conf = zenoh.Config()
        conf.insert_json5("mode", '"peer"')
        conf.insert_json5("scouting/multicast/enabled", "false")
        conf.insert_json5("listen/endpoints", "[]")
        proto = LINK if tls is not None else "tcp"
        conf.insert_json5("connect/endpoints", json.dumps([f"{proto}/127.0.0.1:{port}"]))
        for key, value in (tls or {}).items():
            conf.insert_json5(f"transport/link/tls/{key}", json.dumps(value))
        self.ns = ns
        self.answer_probes = answer_probes
        self.states = 0
        self.pings = 0
        self.lock = threading.Lock()
        self.z = zenoh.open(conf)
        self.subs = [
            self.z.declare_subscriber(f"hrrtc/{ns}/state", self.on_state),
            self.z.declare_subscriber(f"hrrtc/{ns}/bridge/ping", self.on_ping),
        ]

    def on_state(self, sample):
        if sample.payload.to_bytes()[4:8] == struct.pack("<I", STATE):
            with self.lock:
                self.states += 1

    def on_ping(self, sample):
        b = sample.payload.to_bytes()
        if len(b) >= 24 and b[:4] == MAGIC and struct.unpack_from("<I", b, 4)[0] == PING:
            with self.lock:
                self.pings += 1
            if not self.answer_probes:
                return
            # The probe's header with the kind set to PONG, then this peer's id.
            pong = b[:4] + struct.pack("<I", PONG) + b[8:24] + struct.pack("<Q", PEER_ID)
            self.z.put(f"hrrtc/{self.ns}/bridge/pong", pong)

    def try_for(self, seconds):
        pub = self.z.declare_publisher(f"hrrtc/{self.ns}/guidance")
        end, seq = time.monotonic() + seconds, 0
        while time.monotonic() < end:
            seq += 1
            pub.put(frame(GUIDANCE, PEER_ID, guidance(seq)))
            time.sleep(0.005)
        pub.undeclare()
        return seq

    def close(self):
        for s in self.subs:
            s.undeclare()
        self.z.close()


def tls_of(lab, name, *, cert=True):
    t = {"root_ca_certificate": str(lab / "ca.pem")}
    if cert:
        t.update(connect_certificate=str(lab / f"{name}.pem"),
                 connect_private_key=str(lab / f"{name}.key"), enable_mtls=True)
    return t


def run_against_loop(tmp_path, lab, peer_tls, answer_probes=True):
    """A loop and its bridge (mutual TLS, only `planner` allowed), one peer trying for
    TRY_S s; the loop's summary, the bridge's output and what the peer received."""
    tag = f"{os.getpid()}_{time.monotonic_ns() % 1_000_000}"
    ns, port = f"py_sec_{tag}", free_port()
    summary = tmp_path / "loop.json"
    loop = subprocess.Popen(
        [exe("haptic-loop"), "run", "--namespace", ns, "--priority", "0", "--no-mlock",
         "--no-contact", "--duration-s", "60", "--summary-json", str(summary)],
        stdout=subprocess.DEVNULL)
    bridge = subprocess.Popen(
        [exe("hrrtc-bridge"), "--side", "loop", "--namespace", ns,
         "--listen", f"{LINK}/127.0.0.1:{port}", "--tls-ca", str(lab / "ca.pem"),
         "--tls-cert", str(lab / "loop.pem"), "--tls-key", str(lab / "loop.key"),
         "--allow-peer", "planner"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # The bridge's log, read as it comes: it says when it listens (a connection made to
    # find out would be a refused handshake of its own).
    err_lines = []
    reader = threading.Thread(target=lambda: err_lines.extend(bridge.stderr), daemon=True)
    reader.start()
    peer = None
    try:
        wait_for("the bridge to listen", 30, lambda: any("keys hrrtc/" in l for l in err_lines))
        peer = Peer(ns, port, peer_tls, answer_probes)
        offered = peer.try_for(TRY_S)
        with peer.lock:
            received = dict(states=peer.states, pings=peer.pings, offered=offered)
    finally:
        if peer is not None:
            peer.close()
        bridge.terminate()
        out = bridge.stdout.read()
        bridge.wait(timeout=20)
        reader.join(timeout=20)
        err = "".join(err_lines)
        loop.terminate()
        assert loop.wait(timeout=20) == 0
    assert bridge.returncode == 0, err
    return json.loads(summary.read_text()), out, received


def rendered(summary):
    return summary["loop_report"]["guidance_latency_us"]["count"]


def test_the_allowed_planner_receives_the_state_and_its_guidance_is_rendered(tmp_path, labs):
    lab, _ = labs
    summary, out, got = run_against_loop(tmp_path, lab, tls_of(lab, "planner"))
    assert got["states"] > 1000, (got, out)
    assert got["pings"] > 10, (got, out)
    assert rendered(summary) > 100, (summary["loop_report"], out)
    assert summary["planner_id"] == 666, summary
    assert "mutual TLS" in out, out
    assert "kept out: 0 TLS handshake(s) refused" in out and "), 0 peer(s)" in out, out


@pytest.mark.parametrize("who", ["no-certificate", "plain-tcp", "other-ca", "not-allowed"])
def test_a_peer_that_is_not_let_in_gets_nothing_and_moves_nothing(tmp_path, labs, who):
    lab, other = labs
    peer_tls = {
        "no-certificate": tls_of(lab, "planner", cert=False),
        "plain-tcp": None,
        "other-ca": tls_of(other, "planner") | {"root_ca_certificate": str(lab / "ca.pem")},
        "not-allowed": tls_of(lab, "intruder"),
    }[who]
    summary, out, got = run_against_loop(tmp_path, lab, peer_tls)
    assert got["offered"] > 100, got
    assert got["states"] == 0, (who, got, out)
    assert rendered(summary) == 0, (who, summary["loop_report"], out)
    assert summary["planner_id"] == 0, (who, summary)
    # Nothing of the peer was handed to the loop, not even as an unanswered sender's.
    assert "guidance:" not in out or "delivered 0" in out, out
    # And the bridge counted what Zenoh kept out.
    kept = next(l for l in out.splitlines() if "kept out:" in l)
    handshakes = int(kept.split("kept out:")[1].split()[0])
    not_allowed = int(kept.split("), ")[1].split()[0])
    if who == "not-allowed":
        assert not_allowed >= 1 and handshakes == 0, kept
    elif who == "plain-tcp" and LINK == "quic":
        # Nothing listens on TCP: the connection is refused before any handshake.
        assert handshakes == 0 and not_allowed == 0, kept
    else:
        assert handshakes >= 1 and not_allowed == 0, kept


def test_guidance_from_a_peer_that_does_not_answer_probes_is_not_handed_on(tmp_path, labs):
    """Allowed in, it reads the state; but its guidance, under an id that never answered the
    bridge's probes, is counted and dropped (a liveness check, not authentication)."""
    lab, _ = labs
    summary, out, got = run_against_loop(tmp_path, lab, tls_of(lab, "planner"),
                                         answer_probes=False)
    assert got["states"] > 1000 and got["pings"] > 10, (got, out)
    assert rendered(summary) == 0, (summary["loop_report"], out)
    line = next(l for l in out.splitlines() if l.strip().startswith("guidance:"))
    assert "delivered 0" in line, line
    unanswered = int(line.rsplit("from unanswered peers", 1)[1].strip())
    assert unanswered > 100, line
