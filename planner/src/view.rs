//! `planner view` (the live Foxglove view, validated into a [`ViewConfig`]) and
//! `planner merge-recordings`.

use crate::common::{positive, positive_opt};
use ::view::{ViewConfig, Viewer};
use anyhow::bail;
use clap::Args;
use ipc_types::services;
use planner_core::Scene;
use std::path::PathBuf;

/// Options of `planner view`.
#[derive(Debug, Args, Clone)]
pub struct ViewArgs {
    /// IPC namespace of the haptic loop and the planner.
    #[arg(long, default_value = ipc_types::services::DEFAULT_NAMESPACE)]
    pub namespace: String,
    /// The scene they run: a built-in name or a TOML scene file (as for `serve`).
    #[arg(long, default_value = "wall-hole")]
    pub scene: String,
    /// Address of the WebSocket server (0.0.0.0 to reach it from other hosts).
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
    /// Port of the WebSocket server; 0 picks a free port (logged at start).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// Run no WebSocket server (recording only; needs --record).
    #[arg(long)]
    pub no_server: bool,
    /// Record every channel to this MCAP file (lz4 chunks; overwritten).
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// Most object-pose and force-arrow updates per second.
    #[arg(long, default_value_t = 30.0)]
    pub rate_hz: f64,
    /// Force arrows: metres of arrow per newton.
    #[arg(long, default_value_t = 0.02)]
    pub m_per_n: f64,
    /// Stop after this many seconds.
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Write a JSON report (messages per topic, nodes received...) here on exit.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

impl ViewArgs {
    /// Validates the arguments into a [`ViewConfig`] (loads the scene).
    pub fn to_config(&self) -> anyhow::Result<ViewConfig> {
        services::validate_namespace(&self.namespace)
            .map_err(|e| anyhow::anyhow!("--namespace: {e}"))?;
        if self.no_server && self.record.is_none() {
            bail!("--no-server without --record would show and record nothing");
        }
        Ok(ViewConfig {
            namespace: self.namespace.clone(),
            scene: Scene::by_name_or_path(&self.scene)?,
            host: self.host.clone(),
            port: (!self.no_server).then_some(self.port),
            record: self.record.clone(),
            rate_hz: positive("rate-hz", self.rate_hz)?,
            m_per_n: positive("m-per-n", self.m_per_n)?,
            duration_s: positive_opt("duration-s", self.duration_s)?,
        })
    }
}

/// Options of `planner merge-recordings`.
#[derive(Debug, Args, Clone)]
pub struct MergeArgs {
    /// The merged file (overwritten).
    #[arg(long, short, value_name = "FILE")]
    pub out: PathBuf,
    /// The recordings to merge.
    #[arg(required = true, num_args = 1.., value_name = "INPUT")]
    pub inputs: Vec<PathBuf>,
}

/// Runs `planner view` until Ctrl-C / SIGTERM or --duration-s; the exit code is 0.
pub fn run(args: &ViewArgs) -> anyhow::Result<i32> {
    let config = args.to_config()?;
    let stop = crate::stop_on_signal()?;
    let viewer = Viewer::new(&config)?;
    if let Some(port) = viewer.port() {
        tracing::info!(
            "view of namespace '{}' (scene '{}'): open ws://{}:{port} in Foxglove or Lichtblick, layout planner/view/layout.json",
            config.namespace,
            config.scene.name,
            config.host
        );
    }
    if let Some(r) = &config.record {
        tracing::info!("recording to {}", r.display());
    }
    let report = viewer.run(&stop)?;
    tracing::info!(
        "view done: {} states, {} roadmap samples ({} missed), {} of {} nodes",
        report.states_seen,
        report.roadmap_samples,
        report.roadmap_samples_missed,
        report.nodes_known,
        report.planner_nodes
    );
    if let Some(p) = &args.json {
        crate::write_json(p, &report)?;
    }
    Ok(0)
}

/// Runs `planner merge-recordings`; the exit code is 0.
pub fn merge(args: &MergeArgs) -> anyhow::Result<i32> {
    let n = ::view::merge_mcap(&args.inputs, &args.out)?;
    println!("wrote {} messages to {}", n, args.out.display());
    Ok(0)
}
