//! Issue 16: what a user saw of the restructured binaries. The demo starts the `planner`
//! executable and says how to build it when it is missing; `run`'s summary reports a
//! solution the planner published; a scene whose start and goal do not fit the arm at the
//! default scale gets a scale that fits; log lines carry no colour codes when not on a
//! terminal, and iceoryx2 does not warn about its missing config file.

use std::process::Command;
use std::time::Duration;
use tests::{Proc, bin, one_loop_at_a_time, unique_namespace};

#[test]
fn issue_16_demo_names_the_build_command_when_the_planner_is_missing() {
    let out = Command::new(bin("haptic-loop"))
        .args([
            "demo",
            "--planner-exe",
            "/nonexistent/planner",
            "--no-contact",
        ])
        .output()
        .expect("run haptic-loop demo");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("/nonexistent/planner")
            && stderr.contains("cargo build --release -p planner"),
        "{stderr}"
    );
}

/// `haptic-loop run` beside a `planner serve` that solves the `free` scene at once: the
/// summary says solved, with the time and the path, as the progress lines do. On the
/// `tunnels` scene, which does not fit the arm at scale 3, the loop runs at a scale that
/// fits. The loop's stderr holds neither ANSI escapes nor iceoryx2's config warning.
#[test]
fn issue_16_run_reports_the_solution_and_fits_the_scale_quietly() {
    let _serial = one_loop_at_a_time();
    for scene in ["free", "tunnels"] {
        let ns = unique_namespace("i16");
        let json = std::env::temp_dir().join(format!("{ns}.json"));
        let json_arg = json.to_str().unwrap().to_string();
        let mut planner = Proc::spawn(
            &bin("planner"),
            &["serve", "--namespace", &ns, "--scene", scene],
        );
        let out = tests::loop_command(&ns, &["--scene", scene])
            .args(["--priority", "0", "--no-contact"])
            .args(["--duration-s", "4", "--summary-json", &json_arg])
            .output()
            .expect("run haptic-loop run");
        planner.signal(libc::SIGTERM);
        let _ = planner.wait_timeout(Duration::from_secs(10));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{scene}: {stderr}");
        assert!(
            !stderr.contains('\u{1b}'),
            "{scene}: ANSI escapes in {stderr}"
        );
        assert!(
            !stderr.contains("No config file was loaded"),
            "{scene}: iceoryx2 warned: {stderr}"
        );
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let _ = std::fs::remove_file(&json);
        if scene == "free" {
            let stdout = String::from_utf8_lossy(&out.stdout);
            assert_eq!(s["solved"], true, "{s}");
            assert!(
                s["time_to_solve_s"].as_f64().is_some_and(|t| t > 0.0),
                "{s}"
            );
            assert!(s["path_waypoints"].as_u64().is_some_and(|n| n >= 2), "{s}");
            assert!(stdout.contains("solved:            yes"), "{stdout}");
        } else {
            assert!(
                stderr.contains("scale"),
                "the fitted scale is logged: {stderr}"
            );
            assert!(s["ticks"].as_u64().is_some_and(|n| n > 1000), "{s}");
        }
    }
}
