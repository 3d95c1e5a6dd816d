//! Secure by default: every program that links hosts refuses, at start and with exit code 2,
//! a link that is not mutually authenticated TLS, unless told `--insecure`; the message
//! names the flags that fix it. (Peers that are refused or let in, played by a foreign
//! Zenoh client, are tested in `gateways/bridge/python/test_security.py`.)

use std::process::Command;
use tests::{bin, free_port, lab, tls_args, unique_namespace};

/// Runs `program` with `args`; its exit code and stderr.
fn run(program: &str, args: &[String]) -> (Option<i32>, String) {
    let out = Command::new(bin(program))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{program}: {e}"));
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn strings(args: &[&str]) -> Vec<String> {
    args.iter().map(|s| s.to_string()).collect()
}

/// Exit 2, naming the TLS flags and `--insecure` (each after `prefix`) and `also`.
fn assert_refused(program: &str, args: &[String], prefix: &str, also: &str) {
    let (code, stderr) = run(program, args);
    assert_eq!(code, Some(2), "{program} {args:?}: {stderr}");
    for flag in ["tls-ca", "tls-cert", "tls-key", "insecure"] {
        let flag = format!("--{prefix}{flag}");
        assert!(
            stderr.contains(&flag),
            "{program} {args:?}: no {flag} in {stderr}"
        );
    }
    assert!(
        stderr.contains(also),
        "{program} {args:?}: no {also:?} in {stderr}"
    );
}

#[test]
fn plain_tcp_is_refused_on_loopback_and_any_address_unless_insecure() {
    let port = free_port().to_string();
    let ns = unique_namespace("plain");
    for endpoint in [
        format!("tcp/127.0.0.1:{port}"),
        format!("tcp/0.0.0.0:{port}"),
    ] {
        for (side, dir) in [("loop", "--listen"), ("planner", "--connect")] {
            let args = strings(&["--side", side, "--namespace", &ns, dir, &endpoint]);
            assert_refused("hrrtc-bridge", &args, "", &endpoint);
        }
    }
    let endpoint = format!("tcp/127.0.0.1:{port}");
    for dir in ["--bridge-connect", "--bridge-listen"] {
        let args = strings(&[
            "serve",
            "--namespace",
            &ns,
            "--scene",
            "wall-hole",
            dir,
            &endpoint,
        ]);
        assert_refused("planner", &args, "bridge-", &endpoint);
    }
    // The ROS 2 gateway's default is rmw_zenoh's router on plain TCP: refused too.
    let serve = strings(&["serve", "--namespace", &ns, "--scene", "none"]);
    assert_refused("hrrtc-ros2", &serve, "", "tcp/localhost:");
    let device = strings(&[
        "device",
        "--namespace",
        &ns,
        "--pose-topic",
        "/a",
        "--wrench-topic",
        "/b",
    ]);
    assert_refused("hrrtc-ros2", &device, "", "tcp/localhost:");
    // A Zenoh file that opens plain TCP is judged as the flags are.
    let file = std::env::temp_dir().join(format!("{ns}.json5"));
    std::fs::write(
        &file,
        format!("{{ listen: {{ endpoints: ['tcp/127.0.0.1:{port}'] }} }}"),
    )
    .unwrap();
    let args = strings(&[
        "--side",
        "loop",
        "--namespace",
        &ns,
        "--zenoh-config",
        file.to_str().unwrap(),
    ]);
    assert_refused("hrrtc-bridge", &args, "", "Zenoh configuration file");
    let _ = std::fs::remove_file(file);
    // With --insecure the bridge starts on the same endpoint (and stops after its duration),
    // and says so in its summary.
    let args = strings(&[
        "--side",
        "loop",
        "--namespace",
        &ns,
        "--listen",
        &endpoint,
        "--insecure",
        "--duration-s",
        "0.5",
    ]);
    let out = Command::new(bin("hrrtc-bridge"))
        .args(&args)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("INSECURE"), "{stdout}");
}

#[test]
fn tls_needs_the_peers_named_and_every_file_readable() {
    let port = free_port().to_string();
    let ns = unique_namespace("tlsargs");
    let listen = format!("tls/127.0.0.1:{port}");
    let base = strings(&["--side", "loop", "--namespace", &ns, "--listen", &listen]);
    // No --allow-peer: nobody could be let in; said so.
    let args = [base.clone(), tls_args("", "loop")].concat();
    let (code, stderr) = run("hrrtc-bridge", &args);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("--allow-peer"), "{stderr}");
    // A key file that is not there is named with its flag.
    let mut tls = tls_args("", "loop");
    tls[5] = lab().join("nobody.key").to_string_lossy().into_owned();
    let args = [base.clone(), tls, strings(&["--allow-peer", "planner"])].concat();
    let (code, stderr) = run("hrrtc-bridge", &args);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("--tls-key") && stderr.contains("nobody.key"),
        "{stderr}"
    );
    // The three files go together.
    let args = [
        base,
        strings(&["--tls-ca", "ca.pem", "--allow-peer", "planner"]),
    ]
    .concat();
    let (code, stderr) = run("hrrtc-bridge", &args);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("--tls-cert"), "{stderr}");
}

/// What a local user of another account could write: iceoryx2 creates every segment of the
/// loop's services (state, guidance, paths, events) readable and writable by the loop's
/// user only, and its folders writable by no one else. The one exception, by iceoryx2's
/// design, is the domain's node counter (`*.global_mgmt`, 4 bytes that number new nodes),
/// which carries no data of the loop's.
#[test]
fn the_loops_shared_memory_is_its_users_alone() {
    use std::os::unix::fs::MetadataExt;
    let ns = unique_namespace("shm");
    let started = std::time::SystemTime::now() - std::time::Duration::from_secs(2);
    let (node, _) = ipc_types::services::create_node("it_shm_watch").unwrap();
    let state = ipc_types::services::state_reader(&node, &ns).unwrap();
    let mut lp = tests::start_loop(
        &ns,
        &["--priority", "0", "--no-contact", "--duration-s", "30"],
    );
    tests::wait_for(
        "the loop publishes",
        std::time::Duration::from_secs(30),
        || (state.get().header.sequence > 100).then_some(()),
    );
    let mut checked = 0;
    let mut walk = vec![std::path::PathBuf::from("/dev/shm"), "/tmp/iceoryx2".into()];
    while let Some(path) = walk.pop() {
        let Ok(meta) = std::fs::symlink_metadata(&path) else {
            continue;
        };
        let name = path
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        if meta.is_dir() {
            if path.starts_with("/tmp/iceoryx2") {
                assert_eq!(
                    meta.mode() & 0o022,
                    0,
                    "{}: others may write",
                    path.display()
                );
            }
            for entry in std::fs::read_dir(&path).unwrap().flatten() {
                walk.push(entry.path());
            }
            continue;
        }
        let ours = meta.modified().is_ok_and(|m| m >= started) && meta.uid() == unsafe_uid();
        if !name.starts_with("iox2_") || !ours || name.ends_with(".global_mgmt") {
            continue;
        }
        assert_eq!(
            meta.mode() & 0o077,
            0,
            "{}: not owner-only ({:o})",
            path.display(),
            meta.mode()
        );
        checked += 1;
    }
    assert!(checked >= 5, "found {checked} of the loop's iceoryx2 files");
    lp.signal(libc::SIGTERM);
    lp.wait_timeout(std::time::Duration::from_secs(20))
        .expect("loop stops");
}

/// This process's user id.
fn unsafe_uid() -> u32 {
    // SAFETY: getuid has no preconditions and cannot fail.
    unsafe { libc::getuid() }
}
