//! Who the kernel's OOM killer takes first: the gateways raise their own `oom_score_adj`
//! (no rights needed), a driver process keeps the value it inherits (killing it faults the
//! loop), and the loop lowers its own where `CAP_SYS_RESOURCE` allows it, else keeps it
//! and says so. Checked by the values in /proc and the summaries, never by timing.

use std::io::Read;
use std::process::{Command, Stdio};
use std::time::Duration;
use tests::{Proc, bin, free_port, one_loop_at_a_time, tls_args, unique_namespace, wait_for};

/// `oom_score_adj` of process `pid`, `None` once it is gone.
fn oom_score_adj_of(pid: u32) -> Option<i32> {
    std::fs::read_to_string(format!("/proc/{pid}/oom_score_adj"))
        .ok()?
        .trim()
        .parse()
        .ok()
}

/// This test process's `oom_score_adj`: what its children inherit.
fn own() -> i32 {
    ipc_types::startup::oom_score_adj().expect("/proc/self/oom_score_adj")
}

/// Whether this process holds `CAP_SYS_RESOURCE` (bit 24 of `CapEff`); children started
/// without ambient capabilities hold what it holds when it runs as root, else nothing.
fn has_cap_sys_resource() -> bool {
    ipc_types::startup::has_cap_sys_resource().expect("CapEff in /proc/self/status")
}

/// Starts `program args` with stdout captured (stderr shown on failure).
fn spawn_captured(program: &std::path::Path, args: &[String]) -> Proc {
    let child = Command::new(program)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {}: {e}", program.display()));
    Proc {
        child,
        name: program.display().to_string(),
    }
}

#[test]
fn the_bridge_raises_its_oom_score_adj_and_its_summary_says_so() {
    if ipc_types::startup::oom_score_adj().is_none() {
        eprintln!("no /proc/self/oom_score_adj here: nothing to check");
        return;
    }
    let inherited = own();
    let expected = inherited.max(300);
    let ns = unique_namespace("oom_bridge");
    let listen = format!("quic/127.0.0.1:{}", free_port());
    let mut args: Vec<String> = ["--side", "loop", "--namespace", &ns, "--listen", &listen]
        .map(String::from)
        .to_vec();
    args.extend(tls_args("", "loop"));
    args.extend(["--allow-peer", "planner", "--duration-s", "2"].map(String::from));
    let mut bridge = spawn_captured(&bin("hrrtc-bridge"), &args);
    let pid = bridge.child.id();
    let seen = wait_for(
        "the bridge's raised oom_score_adj",
        Duration::from_secs(30),
        || match oom_score_adj_of(pid) {
            Some(v) if v == expected => Some(v),
            // Gone (or going) without showing it.
            _ if !bridge.is_running() => Some(oom_score_adj_of(pid).unwrap_or(i32::MIN)),
            _ => None,
        },
    );
    assert_eq!(seen, expected, "inherited {inherited}");
    let status = bridge
        .wait_timeout(Duration::from_secs(60))
        .expect("the bridge stops after --duration-s");
    assert!(status.success(), "{status}");
    let mut stdout = String::new();
    bridge
        .child
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut stdout)
        .unwrap();
    let line = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("oom_score_adj:"))
        .unwrap_or_else(|| panic!("no oom_score_adj in the summary: {stdout}"));
    let want = match inherited < 300 {
        true => format!("oom_score_adj: 300 (raised from {inherited})"),
        false => format!("oom_score_adj: {inherited} (kept: "),
    };
    assert!(line.contains(&want), "{line:?}, want {want:?}");
}

#[test]
fn a_driver_process_keeps_the_oom_score_adj_it_inherits() {
    if ipc_types::startup::oom_score_adj().is_none() {
        eprintln!("no /proc/self/oom_score_adj here: nothing to check");
        return;
    }
    // A value of its own to inherit (one above this process's: raising needs no rights),
    // so that neither the gateways' 300 nor the default 0 could pass for it.
    let inherited = (own() + 1).min(1000);
    let ns = unique_namespace("oom_device");
    let port = free_port();
    let listen = format!("tcp/127.0.0.1:{port}");
    let (pose, wrench) = (format!("/{ns}/pose"), format!("/{ns}/wrench"));
    let script = format!("echo {inherited} > /proc/self/oom_score_adj && exec \"$0\" \"$@\"");
    let ros2 = bin("hrrtc-ros2");
    let args = [
        "-c",
        &script,
        ros2.to_str().unwrap(),
        "device",
        "--namespace",
        &ns,
        "--pose-topic",
        &pose,
        "--wrench-topic",
        &wrench,
        "--no-connect",
        "--listen",
        &listen,
        "--insecure",
        "--duration-s",
        "60",
    ];
    let mut device = Proc::spawn(std::path::Path::new("/bin/sh"), &args);
    // Up: its ROS 2 side listens (past everything it does at start).
    wait_for(
        "hrrtc-ros2 device listening",
        Duration::from_secs(30),
        || {
            assert!(device.is_running(), "hrrtc-ros2 device ended early");
            std::net::TcpStream::connect(("127.0.0.1", port))
                .ok()
                .map(|_| ())
        },
    );
    let pid = device.child.id();
    let value = oom_score_adj_of(pid).expect("the device gateway runs");
    assert!(device.is_running());
    assert_eq!(
        value, inherited,
        "the driver process changed its oom_score_adj"
    );
}

#[test]
fn the_loop_lowers_its_oom_score_adj_or_keeps_it_and_says_why() {
    if ipc_types::startup::oom_score_adj().is_none() {
        eprintln!("no /proc/self/oom_score_adj here: nothing to check");
        return;
    }
    let _serial = one_loop_at_a_time();
    let inherited = own();
    let ns = unique_namespace("oom_loop");
    let json = std::env::temp_dir().join(format!("{ns}.json"));
    let out = tests::loop_command(
        &ns,
        &[
            "--priority",
            "0",
            "--no-contact",
            "--duration-s",
            "0.5",
            "--summary-json",
            json.to_str().unwrap(),
        ],
    )
    .output()
    .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let _ = std::fs::remove_file(&json);
    let oom = &summary["oom_score_adj"];
    assert_eq!(oom["requested"], -900, "{oom}");
    assert_eq!(oom["before"], inherited, "{oom}");
    let (outcome, value) = (oom["outcome"].as_str().unwrap(), &oom["value"]);
    if inherited <= -900 {
        assert_eq!((outcome, value.as_i64()), ("kept", Some(inherited.into())));
    } else if has_cap_sys_resource() {
        assert_eq!((outcome, value.as_i64()), ("applied", Some(-900)), "{oom}");
    } else {
        assert_eq!(
            (outcome, value.as_i64()),
            ("refused", Some(inherited.into())),
            "{oom}"
        );
        let why = oom["reason"].as_str().unwrap();
        assert!(why.contains("CAP_SYS_RESOURCE"), "{why}");
    }
    // The printed summary says the same.
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout
        .lines()
        .find(|l| l.starts_with("oom_score_adj:"))
        .unwrap_or_else(|| panic!("no oom_score_adj line: {stdout}"));
    let printed = line.split_whitespace().nth(1);
    assert_eq!(printed, Some(value.to_string().as_str()), "{line} vs {oom}");
}
