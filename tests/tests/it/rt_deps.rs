//! Architecture invariant: the real-time binary links only what runs in real time or sets
//! it up. `haptic-loop`'s normal dependencies (those of its library and binary) may reach
//! the workspace crates `ipc-types`, `devices` and `scene` and no other, and none of the
//! crates below, which serve planning, viewing, plotting or networking. And the planner's
//! process shell, a library, links neither the viewer nor the laboratory nor the bridge
//! (the `planner` program does).

use std::collections::BTreeSet;
use std::process::Command;

/// Workspace crates the loop may depend on (DESIGN.md, "Crates").
const WORKSPACE_ALLOWED: [&str; 3] = ["ipc-types", "devices", "scene"];

/// Crates that have no place in the RT binary: async runtimes, the Foxglove server and its
/// WebSocket stack, plotting and image code, progress bars, networking.
const FORBIDDEN: [&str; 17] = [
    "tokio",
    "mio",
    "futures",
    "foxglove",
    "tungstenite",
    "tokio-tungstenite",
    "plotters",
    "plotters-bitmap",
    "image",
    "png",
    "ab_glyph",
    "indicatif",
    "zenoh",
    "hyper",
    "reqwest",
    "rayon",
    "mcap-foxglove",
];

/// `(name, source)` of every package in `package`'s normal dependency graph.
fn normal_packages(package: &str) -> Vec<(String, String)> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "tree",
            "--locked",
            "-p",
            package,
            "-e",
            "normal",
            "--prefix",
            "none",
            "--no-dedupe",
        ])
        .output()
        .expect("run cargo tree");
    assert!(
        out.status.success(),
        "cargo tree failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).expect("cargo tree prints UTF-8");
    let mut seen = BTreeSet::new();
    for line in text.lines() {
        // "name vX.Y.Z (source) (*)" or "name vX.Y.Z"
        let mut words = line.split_whitespace();
        let (Some(name), Some(_version)) = (words.next(), words.next()) else {
            continue;
        };
        let rest: Vec<&str> = words.collect();
        seen.insert((name.to_owned(), rest.join(" ")));
    }
    seen.into_iter().collect()
}

#[test]
fn the_rt_binary_reaches_no_planning_viewing_or_network_crate() {
    let packages = normal_packages("haptic-loop");
    let names: BTreeSet<&str> = packages.iter().map(|(n, _)| n.as_str()).collect();
    assert!(
        names.contains("haptic-loop") && names.contains("iceoryx2"),
        "cargo tree output not understood: {packages:?}"
    );
    let forbidden: Vec<&str> = FORBIDDEN
        .iter()
        .copied()
        .filter(|f| names.contains(f))
        .collect();
    assert!(
        forbidden.is_empty(),
        "haptic-loop's normal dependencies reach {forbidden:?} (see `cargo tree -p haptic-loop -e normal -i <crate>`)"
    );
    // Workspace crates are the ones cargo prints with a local path.
    let workspace: Vec<&str> = packages
        .iter()
        .filter(|(n, source)| source.contains('/') && n != "haptic-loop")
        .map(|(n, _)| n.as_str())
        .filter(|n| !WORKSPACE_ALLOWED.contains(n))
        .collect();
    assert!(
        workspace.is_empty(),
        "haptic-loop depends on workspace crates {workspace:?}; allowed: {WORKSPACE_ALLOWED:?}"
    );
}

#[test]
fn the_planner_shell_library_links_no_viewer_laboratory_or_bridge() {
    let packages = normal_packages("planner-shell");
    let names: BTreeSet<&str> = packages.iter().map(|(n, _)| n.as_str()).collect();
    assert!(
        names.contains("planner-shell") && names.contains("planner-core"),
        "cargo tree output not understood: {packages:?}"
    );
    let linked: Vec<&str> = ["view", "lab", "hrrtc-bridge", "foxglove", "mcap", "zenoh"]
        .into_iter()
        .filter(|f| names.contains(f))
        .collect();
    assert!(
        linked.is_empty(),
        "planner-shell's normal dependencies reach {linked:?} (see `cargo tree -p planner-shell -e normal -i <crate>`)"
    );
}
