//! `planner scenes`: list the built-in scenes, write them as TOML files, or check (and
//! with `--fix` write repaired copies of) the meshes of scene files.

use anyhow::Context;
use clap::{Args, Subcommand};
use planner_core::Scene;
use scene::repair::Surface;
use std::path::{Path, PathBuf};

/// Options of `planner scenes`.
#[derive(Debug, Args, Clone)]
pub struct ScenesArgs {
    /// Write every built-in scene to DIR/<name>.toml and its meshes to DIR/meshes/.
    #[arg(long, value_name = "DIR")]
    pub write: Option<PathBuf>,
    /// What else to do with scenes.
    #[command(subcommand)]
    pub command: Option<ScenesCommand>,
}

/// `planner scenes` subcommands.
#[derive(Debug, Subcommand, Clone)]
pub enum ScenesCommand {
    /// Load scenes and say, for each mesh part, what loading makes of it: OK (closed and
    /// wound outward as it is), REPAIRED (what was dropped or flipped to make it so: twins
    /// of a double-sided export, duplicates, degenerate triangles, inconsistent or inward
    /// winding), OPEN (holes, a sheet, or a closed surface whose inside cannot be told,
    /// with the reason: contact renders it as a thin shell) or REFUSED (no surface: no
    /// triangle with an area, or invalid data). Exit code 1 when a mesh is refused, else 0.
    Check {
        /// Also write each repaired mesh beside its original as `<stem>.repaired.obj` (in
        /// metres) and a copy of the scene file pointing at them, `<stem>.repaired.toml`.
        /// Never writes over an input.
        #[arg(long)]
        fix: bool,
        /// Scene files (or built-in names), or mesh files (`.stl`, `.obj`) to check alone.
        #[arg(required = true, value_name = "SCENE")]
        scenes: Vec<String>,
    },
}

/// Runs the command; the exit code is 0, or 1 when `check` found a mesh it refuses.
pub fn run(args: &ScenesArgs) -> anyhow::Result<i32> {
    if let Some(ScenesCommand::Check { fix, scenes }) = &args.command {
        return check(scenes, *fix);
    }
    for name in scene::BUILTIN_NAMES {
        if name == "default" {
            continue; // an alias of wall-hole
        }
        let scene = Scene::builtin(name).context("built-in scene")?;
        match &args.write {
            Some(dir) => {
                let path = scene
                    .write_to_dir(dir)
                    .with_context(|| format!("cannot write into {}", dir.display()))?;
                println!("{}", path.display());
            }
            None => println!(
                "{name}: {} obstacles, {} object parts, {:?} space",
                scene.obstacles.len(),
                scene.moving_object.len(),
                scene.space
            ),
        }
    }
    Ok(0)
}

/// The verdict of a mesh's check, as `check` prints it.
fn verdict(surface: &Surface, changed: bool) -> &'static str {
    match surface {
        Surface::ClosedOutward if changed => "REPAIRED",
        Surface::ClosedOutward => "OK",
        Surface::Open => "OPEN",
        Surface::Refused(_) => "REFUSED",
    }
}

/// Whether `arg` names a mesh file rather than a scene.
fn is_mesh_file(arg: &str) -> bool {
    Path::new(arg)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("stl") || e.eq_ignore_ascii_case("obj"))
}

fn check(scenes: &[String], fix: bool) -> anyhow::Result<i32> {
    let mut refused = 0;
    for arg in scenes {
        if is_mesh_file(arg) {
            // A mesh alone: what loading it into a scene would make of it.
            let mesh = scene::MeshData::load(Path::new(arg), 1.0)?;
            let r = scene::repair::repair(&mesh);
            println!(
                "  {:8} {}",
                verdict(&r.report.surface, r.report.changed()),
                r.report
            );
            refused += usize::from(r.report.surface.is_refused());
            continue;
        }
        let scene = Scene::by_name_or_path(arg)?;
        let checks = scene.mesh_checks();
        println!("{arg}: scene '{}', {} mesh parts", scene.name, checks.len());
        let mut repaired = 0;
        for c in &checks {
            let surface = c.surface();
            let changed = c.repair.as_ref().is_some_and(|r| r.changed());
            let verdict = verdict(&surface, changed);
            repaired += usize::from(changed);
            refused += usize::from(surface.is_refused());
            match (&c.repair, &surface) {
                (Some(r), _) => println!("  {verdict:8} {}: {r}", c.field),
                (None, Surface::Refused(why)) => println!("  {verdict:8} {c}: {why}"),
                (None, _) => println!("  {verdict:8} {c}"),
            }
        }
        if !fix {
            if repaired > 0 {
                println!(
                    "  loading repairs {repaired} mesh(es) like this every time; `--fix` writes \
                     the repaired copies"
                );
            }
        } else if Scene::builtin(arg).is_some() {
            println!("  a built-in scene: nothing to write");
        } else {
            let written = scene
                .write_repaired(Path::new(arg))
                .with_context(|| format!("cannot write the repaired files of {arg}"))?;
            if written.is_empty() {
                println!("  nothing changed: no files written");
            }
            for p in written {
                println!("  wrote {}", p.display());
            }
        }
    }
    if refused > 0 {
        println!(
            "{refused} mesh(es) refused: planning works on them, contact rendering does \
             not; {}",
            scene::topology::REPAIR_HINT
        );
    }
    Ok(i32::from(refused > 0))
}
