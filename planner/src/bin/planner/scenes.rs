//! `planner scenes`: list the built-in scenes, write them as TOML files, or check the
//! meshes of scene files.

use anyhow::Context;
use clap::{Args, Subcommand};
use planner::Scene;
use std::path::PathBuf;

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
    /// Load scenes and say, for each mesh part, whether it is closed and wound outward
    /// (what contact rendering needs) or open, double-sided or inconsistently wound, with
    /// its boundary-edge count. Exit code 0 when every mesh is closed and outward, 1 when
    /// one is not.
    Check {
        /// Scene files (or built-in names).
        #[arg(required = true, value_name = "SCENE")]
        scenes: Vec<String>,
    },
}

/// Runs the command; the exit code is 0, or 1 when `check` found a mesh to repair.
pub fn run(args: &ScenesArgs) -> anyhow::Result<i32> {
    if let Some(ScenesCommand::Check { scenes }) = &args.command {
        return check(scenes);
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

fn check(scenes: &[String]) -> anyhow::Result<i32> {
    let mut to_repair = 0;
    for arg in scenes {
        let scene = Scene::by_name_or_path(arg)?;
        let checks = scene.mesh_checks();
        println!("{arg}: scene '{}', {} mesh parts", scene.name, checks.len());
        for c in &checks {
            let verdict = if c.is_ok() { "ok" } else { "REPAIR" };
            println!("  {verdict:6} {c}");
            to_repair += usize::from(!c.is_ok());
        }
    }
    if to_repair > 0 {
        println!(
            "{to_repair} mesh(es) are not closed and wound outward: planning works on them, \
             contact rendering refuses them; {}",
            scene::topology::REPAIR_HINT
        );
    }
    Ok(i32::from(to_repair > 0))
}
