//! `planner scenes`: list the built-in scenes, or write them as TOML files.

use anyhow::Context;
use clap::Args;
use planner::Scene;
use std::path::PathBuf;

/// Options of `planner scenes`.
#[derive(Debug, Args, Clone)]
pub struct ScenesArgs {
    /// Write every built-in scene to DIR/<name>.toml and its meshes to DIR/meshes/.
    #[arg(long, value_name = "DIR")]
    pub write: Option<PathBuf>,
}

/// Runs the command; the exit code is 0.
pub fn run(args: &ScenesArgs) -> anyhow::Result<i32> {
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
