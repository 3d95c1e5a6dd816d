//! `planner`: the interactive motion planner's command line. Parses the arguments (one file
//! per command, `common` for the options the planning commands share), validates them
//! into a library config (`ShellConfig`, `ViewConfig`, ...), and runs it; the work is in the
//! `planner`, `view` and `lab` libraries. Exit codes: 0 done (for `solve`: solved), 1
//! `solve` did not solve in time, 2 an error (printed on stderr) or bad arguments, 3
//! `solve` proved there is no way from the start to the goal (`planner_core::no_way`),
//! 130 interrupted during start-up.

mod common;
mod experiment;
mod heap;
mod scenes;
mod serve;
mod solve;
mod view;

use self::view::{MergeArgs, ViewArgs};
use anyhow::Context;
use clap::{Parser, Subcommand};
use experiment::ExperimentArgs;
use scenes::ScenesArgs;
use serde::Serialize;
use serve::ServeArgs;
use solve::SolveArgs;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

#[global_allocator]
static HEAP: heap::HeapMeter = heap::HeapMeter;

/// Interactive motion planner (I-RRT / H-RRT-C) paired with the 1 kHz haptic loop.
#[derive(Debug, Parser)]
#[command(name = "planner", version, about, long_about = None)]
struct Cli {
    /// What to do.
    #[command(subcommand)]
    command: Command,
}

/// Planner subcommands.
#[derive(Debug, Subcommand)]
enum Command {
    /// Run next to a haptic loop: read its state over iceoryx2, grow the trees, publish
    /// guidance, the solution path and roadmap increments (for `planner view`). Stops on
    /// Ctrl-C / SIGTERM or after --duration-s.
    Serve(Box<ServeArgs>),
    /// Plan automatically (no operator) with RRT-Connect or RRT (--algorithm) and report.
    /// Exits 0 when solved, 1 when not in time, 3 when there is certainly no way through
    /// (a ball inside the object cannot pass from start to goal: said before planning).
    Solve(SolveArgs),
    /// List the built-in scenes, write them as TOML files (with OBJ meshes), or check
    /// and repair the meshes of scene files (`scenes check [--fix]`).
    Scenes(ScenesArgs),
    /// Rerun the papers' experiments with a simulated operator in lockstep and write
    /// runs.csv, summary.md and PNG plots.
    Experiment(ExperimentArgs),
    /// Live 3D view for Foxglove / Lichtblick (WebSocket, default ws://127.0.0.1:8765) of
    /// a running haptic loop and planner: scene, object and proxy, contact, forces,
    /// roadmap, paths. Optionally records the same channels to MCAP. Read-only: the loop
    /// and the planner never wait for it. Stops on Ctrl-C / SIGTERM or after --duration-s.
    View(ViewArgs),
    /// Merge MCAP recordings (e.g. `haptic-loop run --record` and `planner view --record`)
    /// into one file, messages ordered by log time.
    MergeRecordings(MergeArgs),
}

/// The flag SIGINT / SIGTERM set (`ipc_types::startup::stop_on_signal`): installed first
/// thing, so that a signal during long start-up work (reading a scene, building a
/// planner's collision trees) ends the process at once with exit code 130.
fn stop_on_signal() -> anyhow::Result<Arc<AtomicBool>> {
    ipc_types::startup::stop_on_signal("planner")
        .context("cannot install the SIGINT/SIGTERM handler")
}

/// The planner's `oom_score_adj`: the kernel's OOM killer takes it first of the system's
/// processes (the gateways are at 300, other processes at 0, the loop at -900). Its trees
/// and collision structures are the largest heap on the host and grow while it plans, so
/// it is the likeliest cause of memory pressure; and it is the cheapest to lose: the loop
/// fades a dead planner's guidance out and follows a restarted one.
const OOM_SCORE_ADJ: i32 = 500;

/// Raises this process's `oom_score_adj` to [`OOM_SCORE_ADJ`] (needs no rights; a higher
/// value in effect is kept), logs what is in effect and returns it for the command's
/// summary ([`with_oom`]). `serve` and `solve` call it first.
pub(crate) fn raise_oom_score_adj() -> ipc_types::startup::OomScoreAdj {
    let oom = ipc_types::startup::raise_oom_score_adj(OOM_SCORE_ADJ);
    tracing::info!("oom_score_adj {oom}");
    oom
}

/// `report` with an `oom_score_adj` field beside its own, for a command's `--json`.
pub(crate) fn with_oom<'a, R: Serialize>(
    report: &'a R,
    oom: &'a ipc_types::startup::OomScoreAdj,
) -> ipc_types::startup::WithOomScoreAdj<'a, R> {
    ipc_types::startup::WithOomScoreAdj {
        report,
        oom_score_adj: oom,
    }
}

/// Writes `value` as pretty JSON (and a newline) to `path`.
fn write_json(path: &std::path::Path, value: &impl Serialize) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    std::fs::write(path, text + "\n").with_context(|| format!("cannot write {}", path.display()))
}

/// Parses `args` (the first is the program name) and runs the command. Returns the process
/// exit code: 0 on success (for `solve`: solved), 1 when `solve` did not solve in time, 3
/// when it proved there is no way.
fn main_with_args<I, T>(args: I) -> anyhow::Result<i32>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            // --help and --version are not errors.
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return Ok(code);
        }
    };
    ipc_types::startup::init_logging_with("info", hrrtc_bridge::refusal_counter());
    match cli.command {
        Command::Serve(a) => serve::run(&a),
        Command::Solve(a) => solve::run(&a),
        Command::Experiment(a) => experiment::run(&a),
        Command::View(a) => view::run(&a),
        Command::MergeRecordings(a) => view::merge(&a),
        Command::Scenes(a) => scenes::run(&a),
    }
}

fn main() -> std::process::ExitCode {
    heap::return_freed_memory();
    // Before anything that takes long (loading a big scene): see `stop_on_signal`.
    if let Err(e) = stop_on_signal() {
        eprintln!("planner: error: {e:#}");
        return std::process::ExitCode::from(2);
    }
    match main_with_args(std::env::args_os()) {
        Ok(code) => std::process::ExitCode::from(code.clamp(0, 255) as u8),
        Err(e) => {
            eprintln!("planner: error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn every_option_has_help() {
        let cmd = Cli::command();
        cmd.clone().debug_assert();
        for sub in cmd.get_subcommands() {
            assert!(sub.get_about().is_some(), "{} has no about", sub.get_name());
            for arg in sub.get_arguments() {
                assert!(
                    arg.get_help().is_some() || arg.get_long_help().is_some(),
                    "`{} --{}` has no help",
                    sub.get_name(),
                    arg.get_id()
                );
            }
        }
    }

    #[test]
    fn solve_writes_json_and_paths() {
        let dir = std::env::temp_dir().join(format!("planner-cli-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let (json, csv, pj) = (dir.join("r.json"), dir.join("p.csv"), dir.join("p.json"));
        let argv = [
            "planner",
            "solve",
            "--scene",
            "free",
            "--seed",
            "3",
            "--time-limit",
            "5",
            "--json",
        ];
        let mut args: Vec<String> = argv.iter().map(|s| s.to_string()).collect();
        args.push(json.display().to_string());
        args.extend(["--path-csv".into(), csv.display().to_string()]);
        args.extend(["--path-json".into(), pj.display().to_string()]);
        assert_eq!(main_with_args(args).expect("runs"), 0);
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
        assert_eq!(v["solved"], true);
        for key in ["time_s", "nodes", "collision_checks", "path_length"] {
            assert!(v[key].is_number(), "{key}: {v}");
        }
        let rows = std::fs::read_to_string(&csv).expect("csv");
        assert!(
            rows.starts_with("x_m,y_m,z_m,qw,qx,qy,qz,arc_length\n") && rows.lines().count() >= 3
        );
        let wp: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&pj).expect("pj")).expect("parse");
        assert!(wp.as_array().is_some_and(|a| a.len() >= 2));
        // A bad scene is an error naming it, not a panic.
        let bad = ["planner", "solve", "--scene", "/nonexistent.toml"];
        let e = main_with_args(bad).unwrap_err().to_string();
        assert!(e.contains("/nonexistent.toml"), "{e}");
    }

    /// Issue 20 item 4: `planner solve --thinning` plans by small-step retraction and says
    /// what it did; bad scales are errors naming the option.
    #[test]
    fn solve_by_thinning_reports_its_work_and_checks_its_options() {
        let dir = std::env::temp_dir().join(format!("planner-thin-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let json = dir.join("thin.json").display().to_string();
        let argv = [
            "planner",
            "solve",
            "--scene",
            "wall-hole",
            "--seed",
            "2",
            "--time-limit",
            "60",
            "--thinning",
            "0.5",
            "--thinning-step",
            "0.25",
            "--json",
            &json,
        ];
        assert_eq!(main_with_args(argv).expect("runs"), 0);
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
        assert_eq!(v["solved"], true);
        for key in ["retracted", "joins", "retries", "restarts", "replans"] {
            assert!(v["thinning"][key].is_u64(), "{key}: {v}");
        }
        for (first, step) in [("1.5", "0.05"), ("0.5", "0"), ("nan", "0.1")] {
            let bad = [
                "planner",
                "solve",
                "--scene",
                "free",
                "--thinning",
                first,
                "--thinning-step",
                step,
            ];
            let e = format!("{:#}", main_with_args(bad).unwrap_err());
            assert!(e.contains("--thinning"), "{e}");
        }
    }

    /// Issue 20: `planner scenes check` names an open mesh and its boundary edges; the
    /// shipped silencer (a closed mesh body) passes. Since issue 36 an open mesh is not
    /// fatal (contact renders it as a thin shell): exit code 0.
    #[test]
    fn issue_20_scenes_check_tells_an_open_mesh_from_a_closed_one() {
        let dir = std::env::temp_dir().join(format!("planner-check-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let closed = scene::MeshData::cuboid("plate", [0.05, 0.2, 0.2]);
        let open = scene::MeshData::new(
            "plate",
            closed.vertices_m.clone(),
            closed.triangles[..10].to_vec(),
        )
        .expect("mesh");
        std::fs::write(dir.join("open.obj"), open.to_obj()).expect("obj");
        let toml = with_mesh_obstacle(&dir, "open", "open.obj");
        let path = toml.display().to_string();
        assert_eq!(
            main_with_args(["planner", "scenes", "check", &path]).expect("runs"),
            0
        );
        let silencer =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scene/scenes/silencer.toml");
        let silencer = silencer.display().to_string();
        assert_eq!(
            main_with_args(["planner", "scenes", "check", &silencer]).expect("runs"),
            0
        );
        let checks = planner_core::Scene::load(&toml)
            .expect("loads")
            .mesh_checks();
        assert_eq!(checks.len(), 1);
        assert_eq!(checks[0].surface(), scene::repair::Surface::Open);
        let line = checks[0].to_string();
        assert!(
            line.contains("open.obj") && line.contains("4 boundary edges"),
            "{line}"
        );
    }

    /// `free.toml` with one mesh obstacle, `file`, written as `dir/<name>.toml`.
    fn with_mesh_obstacle(dir: &std::path::Path, name: &str, file: &str) -> std::path::PathBuf {
        let toml = dir.join(format!("{name}.toml"));
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scene/scenes/free.toml"),
        )
        .expect("free.toml")
            + &format!(
                "\n[[obstacles]]\nshape = \"mesh\"\nfile = \"{file}\"\nposition_m = [0.1, 0.0, 0.0]\n"
            );
        std::fs::write(&toml, text).expect("toml");
        toml
    }

    /// Issue 36: `planner scenes check --fix` writes a double-sided mesh's repair beside
    /// it and a scene using it; a closed mesh whose inside cannot be told is open, not
    /// refused (issue 45).
    #[test]
    fn issue_36_scenes_check_fix_writes_the_repaired_mesh_and_keeps_the_untellable_as_a_shell() {
        let dir = std::env::temp_dir().join(format!("planner-fix-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let cube = scene::MeshData::cuboid("plate", [0.05, 0.2, 0.2]);
        let mut t = cube.triangles.clone();
        t.extend(cube.triangles.iter().map(|&[a, b, c]| [a, c, b]));
        let double = scene::MeshData::new("plate", cube.vertices_m.clone(), t).expect("mesh");
        std::fs::write(dir.join("double.obj"), double.to_obj()).expect("obj");
        let toml = with_mesh_obstacle(&dir, "double", "double.obj");
        let path = toml.display().to_string();
        assert_eq!(
            main_with_args(["planner", "scenes", "check", "--fix", &path]).expect("runs"),
            0
        );
        let fixed = planner_core::Scene::load(&dir.join("double.repaired.toml")).expect("loads");
        let checks = fixed.mesh_checks();
        assert!(
            checks[0].source.ends_with("double.repaired.obj"),
            "{}",
            checks[0]
        );
        assert!(checks[0].is_ok() && !checks[0].repair.as_ref().expect("ran").changed());
        // A closed box with a wall inside on a diagonal plane: three triangles on four of
        // its edges and no hole, so no inside can be told. It has a surface, so it is not
        // refused (issue 45): a thin shell, exit code 0, nothing to write.
        let mut t = cube.triangles.clone();
        t.extend([[0, 3, 7], [0, 7, 4]]);
        let walled = scene::MeshData::new("walled", cube.vertices_m.clone(), t).expect("mesh");
        std::fs::write(dir.join("walled.obj"), walled.to_obj()).expect("obj");
        let toml = with_mesh_obstacle(&dir, "walled", "walled.obj");
        let path = toml.display().to_string();
        assert_eq!(
            main_with_args(["planner", "scenes", "check", "--fix", &path]).expect("runs"),
            0
        );
        let loaded = planner_core::Scene::load(&toml).expect("loads");
        assert_eq!(
            loaded.mesh_checks()[0].surface(),
            scene::repair::Surface::Open
        );
        assert!(!dir.join("walled.repaired.toml").exists());
    }
}
