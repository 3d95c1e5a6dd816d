//! Command line of the planner process: parsed here, validated into a [`ShellConfig`], run by
//! [`crate::shell`]. Lives in the library so the haptic loop's demo can start the very same
//! planner as a child process of its own binary.

use crate::shell::{self, ShellConfig};
use crate::{Planner, PlannerParams, Scene};
use anyhow::{Context, bail};
use clap::{Args, Parser, Subcommand};
use ipc_types::services;
use serde::Serialize;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Interactive motion planner (I-RRT / H-RRT-C) paired with the 1 kHz haptic loop.
#[derive(Debug, Parser)]
#[command(name = "planner", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Planner subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run next to a haptic loop: read its state over iceoryx2, grow the trees, publish
    /// guidance, the solution path and roadmap increments (for `planner view`). Stops on
    /// Ctrl-C / SIGTERM or after --duration-s.
    Serve(ServeArgs),
    /// Plan automatically (no operator) with RRT-Connect or RRT (--algorithm) and report.
    Solve(SolveArgs),
    /// List the built-in scenes, or write them as TOML files (with OBJ meshes).
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
    /// Validates the arguments into a [`crate::view::ViewConfig`] (loads the scene).
    pub fn to_config(&self) -> anyhow::Result<crate::view::ViewConfig> {
        services::validate_namespace(&self.namespace)
            .map_err(|e| anyhow::anyhow!("--namespace: {e}"))?;
        if self.no_server && self.record.is_none() {
            bail!("--no-server without --record would show and record nothing");
        }
        Ok(crate::view::ViewConfig {
            namespace: self.namespace.clone(),
            scene: Scene::by_name_or_path(&self.scene)?,
            host: self.host.clone(),
            port: (!self.no_server).then_some(self.port),
            record: self.record.clone(),
            rate_hz: positive("rate-hz", self.rate_hz)?,
            m_per_n: positive("m-per-n", self.m_per_n)?,
            duration_s: self
                .duration_s
                .map(|d| positive("duration-s", d))
                .transpose()?,
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

/// Options of `planner experiment`.
#[derive(Debug, Args, Clone)]
pub struct ExperimentArgs {
    /// `irrt`: sampling method × σ × ε_v on the maze with a pass-through operator (I-RRT
    /// §6). `hrrtc`: α on narrow tunnels and crossing planes with a contact-seeking
    /// operator, beside automatic RRT-Connect (H-RRT-C Tables I and III).
    #[arg(value_parser = ["irrt", "hrrtc"])]
    pub sweep: String,
    /// Runs (seeds 1..=N) per configuration.
    #[arg(long, default_value_t = 5)]
    pub seeds: u64,
    /// Wall-clock limit per run, s (unsolved runs count at the limit in medians).
    #[arg(long, default_value_t = 10.0)]
    pub time_limit: f64,
    /// Output directory (created).
    #[arg(long, default_value = "experiment-out")]
    pub out: PathBuf,
    /// irrt: scene (a built-in with an operator path).
    #[arg(long, default_value = "maze")]
    pub scene: String,
    /// irrt: methods, comma-separated, from pos, pos+cs, path, path+cs, cs.
    #[arg(long, default_value = "pos,pos+cs,path,path+cs", value_delimiter = ',')]
    pub methods: Vec<String>,
    /// irrt: σ values (weighted m), comma-separated.
    #[arg(long, default_value = "0.01,0.05", value_delimiter = ',')]
    pub sigmas: Vec<f64>,
    /// irrt: ε_v values (operator speed, weighted m per iteration), comma-separated.
    #[arg(long, default_value = "0.0002,0.001,0.005", value_delimiter = ',')]
    pub eps: Vec<f64>,
    /// irrt: β of the +CS methods (one uniform sample in β).
    #[arg(long, default_value_t = 3.0)]
    pub beta: f64,
    /// hrrtc: scenes, comma-separated built-ins.
    #[arg(long, default_value = "tunnels,crossing-planes", value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// hrrtc: α values (share of machine samples), comma-separated.
    #[arg(long, default_value = "0,0.1,0.5,0.9", value_delimiter = ',')]
    pub alphas: Vec<f64>,
    /// hrrtc: operator speed ε_v, weighted m per iteration.
    #[arg(long, default_value_t = 0.001)]
    pub hrrtc_eps: f64,
    /// hrrtc: σ of the operator's orientation error, rad per axis (its dexterity).
    #[arg(long, default_value_t = 0.1)]
    pub error_sigma: f64,
    /// hrrtc: operator samples that cannot connect to a tree start I-RRT local trees,
    /// merged when they connect (as `planner serve --local-trees`).
    #[arg(long)]
    pub local_trees: bool,
    /// Also draw the final roadmap of each configuration's first seed, top-down with
    /// the operator's path and the solution, into OUT/roadmaps/*.png.
    #[arg(long)]
    pub pictures: bool,
    /// Hide the progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Options of `planner scenes`.
#[derive(Debug, Args, Clone)]
pub struct ScenesArgs {
    /// Write every built-in scene to DIR/<name>.toml and its meshes to DIR/meshes/.
    #[arg(long, value_name = "DIR")]
    pub write: Option<PathBuf>,
}

/// Options shared by every planning command.
#[derive(Debug, Args, Clone)]
pub struct CoreArgs {
    /// Scene: a built-in name (`wall-hole` alias `default`, `maze`, `tunnels`,
    /// `tunnels-1axis`, `tunnels-2axes`, `crossing-planes`, `silencer`, `free`; see
    /// `planner scenes`) or a TOML scene file.
    #[arg(long, default_value = "wall-hole")]
    pub scene: String,
    /// RNG seed: the same seed and inputs give the same trees.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Extension step, weighted m (I-RRT eq. 2 metric: 1 per m, 0.01 per rad²).
    #[arg(long, default_value_t = 0.05)]
    pub step: f64,
    /// Edge validation resolution, weighted m.
    #[arg(long, default_value_t = 0.005)]
    pub edge_resolution: f64,
    /// p: nearest nodes in F_a's barycenter (I-RRT uses 5).
    #[arg(long, default_value_t = 5)]
    pub neighbours: usize,
    /// Tree algorithm: `rrt-connect` (two trees, greedy I-RRT Extend) or `rrt` (one tree,
    /// one step per iteration, 5 % goal bias).
    #[arg(long, default_value = "rrt-connect", value_parser = ["rrt-connect", "rrt"])]
    pub algorithm: String,
    /// Random shortcut attempts on the solution path (0 keeps the raw tree path).
    #[arg(long, default_value_t = 100)]
    pub shortcut_attempts: u32,
    /// RRT-Connect: how the tree extended towards the sample grows, `greedy` (I-RRT
    /// Extend: steps until reached or blocked) or `step` (one step, as OMPL's
    /// RRTConnect); the other tree always connects greedily.
    #[arg(long, default_value = "greedy", value_parser = ["greedy", "step"])]
    pub extend: String,
    /// How the distance (used for nearest nodes, steps and edge resolution) combines
    /// translation and rotation: `euclidean` (I-RRT eq. 2, √(|Δp|² + (0.1 m·θ)²)) or
    /// `sum` (|Δp| + 0.1 m·θ, as OMPL's SE(2)/SE(3) spaces).
    #[arg(long, default_value = "euclidean", value_parser = ["euclidean", "sum"])]
    pub metric: String,
}

/// Operator-driven sampling options (I-RRT §4.2.2 and §6, H-RRT-C Algorithms 1–2).
#[derive(Debug, Args, Clone)]
pub struct SamplingArgs {
    /// Sampling method: `cs` (uniform), `pos` (Gaussian around the operator along F_r),
    /// `path` (Gaussian around the operator's travelled path), `pos+cs` / `path+cs` (one
    /// uniform sample in β), `hrrtc` (H-RRT-C: uniform with probability α else the
    /// operator's configuration; HapticSampling on the contact plane while in contact).
    #[arg(long, default_value = "hrrtc",
          value_parser = ["cs", "pos", "path", "pos+cs", "path+cs", "hrrtc"])]
    pub sampling: String,
    /// α of H-RRT-C: share of machine (uniform) samples in free space, in [0, 1].
    #[arg(long, default_value_t = 0.5)]
    pub alpha: f64,
    /// β of the +CS methods: one sample in β is uniform (I-RRT uses 3), >= 1.
    #[arg(long, default_value_t = 3.0)]
    pub beta: f64,
    /// σ: standard deviation of the POS and PATH Gaussians, weighted m (m, or rad × 0.1).
    #[arg(long, default_value_t = 0.05)]
    pub sigma: f64,
    /// α of I-RRT eq. 1, F_r = α·F_u + (1−α)·F_a, in [0, 1].
    #[arg(long, default_value_t = 0.5)]
    pub fr_alpha: f64,
    /// Grow I-RRT local trees at operator samples the main trees cannot reach.
    #[arg(long)]
    pub local_trees: bool,
}

impl SamplingArgs {
    /// Applies the options to `params` and validates them.
    pub fn apply(&self, params: &mut PlannerParams) -> anyhow::Result<()> {
        params.sampling = crate::Sampling::parse(&self.sampling, self.beta, self.alpha)
            .with_context(|| format!("unknown --sampling {}", self.sampling))?;
        params.user_sigma = self.sigma;
        params.fr_alpha = self.fr_alpha;
        params.local_trees = self.local_trees;
        params.validate()?;
        Ok(())
    }
}

/// Options of `planner serve`.
#[derive(Debug, Args, Clone)]
pub struct ServeArgs {
    /// Scene, seed and tree parameters.
    #[command(flatten)]
    pub core: CoreArgs,
    /// IPC namespace; must match the haptic loop's.
    #[arg(long, default_value = ipc_types::services::DEFAULT_NAMESPACE)]
    pub namespace: String,
    /// Guidance publish rate, Hz, independent of iteration speed.
    #[arg(long, default_value_t = 100.0)]
    pub guidance_rate_hz: f64,
    /// k for the force part of F_s = k·F_a, N per scene metre.
    #[arg(long, default_value_t = 20.0)]
    pub gain_n_per_m: f64,
    /// k for the torque part of F_s = k·F_a, N·m per rad.
    #[arg(long, default_value_t = 0.05)]
    pub gain_nm_per_rad: f64,
    /// Time-to-live of each guidance sample, ms; the loop fades it out after that.
    #[arg(long, default_value_t = 100.0)]
    pub ttl_ms: f64,
    /// How the operator's input drives sampling.
    #[command(flatten)]
    pub sampling: SamplingArgs,
    /// How often to poll the haptic state until the receiver has locked onto the loop's
    /// ticks (then it polls once per tick, just after each state is written) and while no
    /// new state comes, Hz.
    #[arg(long, default_value_t = 2000.0)]
    pub poll_hz: f64,
    /// Spin this long before and after each state's predicted time instead of sleeping, µs
    /// (reads the state within ~1 µs of its write for ~2 × this much CPU per tick; 0: only
    /// sleep, adding the thread's wake-up latency, ~5–20 µs).
    #[arg(long, default_value_t = 10.0)]
    pub state_spin_us: f64,
    /// SCHED_FIFO priority of the thread that receives the haptic state (below the haptic
    /// loop's, 80 by default), so that it wakes on time on a busy machine and catches each
    /// state as it is written; it sleeps but for the spin window. 0 keeps the normal
    /// scheduler; without permission (see README "Real-time permissions") it is kept too,
    /// with a warning.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u8).range(0..=98))]
    pub state_priority: u8,
    /// Roadmap increments per second for `planner view` (1024 nodes each; a late viewer
    /// gets the whole roadmap from a rolling window); 0 publishes none.
    #[arg(long, default_value_t = 20.0)]
    pub roadmap_rate_hz: f64,
    /// Stop after this many seconds.
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Keep growing the trees while no haptic loop publishes a fresh state (by default
    /// the planner idles then, and resumes when a loop appears).
    #[arg(long)]
    pub plan_without_operator: bool,
    /// Write a JSON report here on exit.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Options of `planner solve`.
#[derive(Debug, Args, Clone)]
pub struct SolveArgs {
    /// Scene, seed and tree parameters.
    #[command(flatten)]
    pub core: CoreArgs,
    /// Give up after this many seconds (wall clock).
    #[arg(long, default_value_t = 60.0)]
    pub time_limit: f64,
    /// Write the result as JSON here: solved, time_s, iterations, nodes,
    /// collision_checks, path_length (weighted m), path_waypoints.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the (smoothed) solution path here as CSV: x_m,y_m,z_m,qw,qx,qy,qz,arc_length.
    #[arg(long)]
    pub path_csv: Option<PathBuf>,
    /// Write the (smoothed) solution path here as JSON waypoints.
    #[arg(long)]
    pub path_json: Option<PathBuf>,
    /// Draw the scene, the roadmap (nodes coloured by --png-color) and the path, projected
    /// on --png-plane, into this PNG file (like I-RRT Fig. 9). Drawn solved or not.
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
    /// Node colour of --png: `distance` (distance label) or `collision` (collision label).
    #[arg(long, default_value = "distance", value_parser = ["distance", "collision"])]
    pub png_color: String,
    /// Projection plane of --png: `xy` (top-down), `xz` or `yz`.
    #[arg(long, default_value = "xy", value_parser = ["xy", "xz", "yz"])]
    pub png_plane: String,
}

fn positive(name: &str, v: f64) -> anyhow::Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        bail!("--{name} must be a finite number > 0, got {v}")
    }
}

impl CoreArgs {
    fn load(&self) -> anyhow::Result<(Scene, PlannerParams)> {
        let scene = Scene::by_name_or_path(&self.scene)?;
        let params = PlannerParams {
            step: self.step,
            edge_resolution: self.edge_resolution,
            neighbours: self.neighbours,
            algorithm: if self.algorithm == "rrt" {
                crate::Algorithm::Rrt
            } else {
                crate::Algorithm::RrtConnect
            },
            shortcut_attempts: self.shortcut_attempts,
            extend_a: if self.extend == "step" {
                crate::params::ExtendA::Step
            } else {
                crate::params::ExtendA::Greedy
            },
            weights: crate::Weights {
                combine: if self.metric == "sum" {
                    crate::Combine::Sum
                } else {
                    crate::Combine::Euclidean
                },
                ..crate::Weights::default()
            },
            ..PlannerParams::default()
        };
        params.validate()?;
        Ok((scene, params))
    }
}

impl ServeArgs {
    /// Validates the arguments into a [`ShellConfig`] (loads the scene).
    pub fn to_config(&self) -> anyhow::Result<ShellConfig> {
        let (scene, mut params) = self.core.load()?;
        self.sampling.apply(&mut params)?;
        let gain = |name: &str, v: f64| -> anyhow::Result<f64> {
            if v.is_finite() && v >= 0.0 {
                Ok(v)
            } else {
                bail!("--{name} must be a finite number >= 0, got {v}")
            }
        };
        services::validate_namespace(&self.namespace)
            .map_err(|e| anyhow::anyhow!("--namespace: {e}"))?;
        Ok(ShellConfig {
            namespace: self.namespace.clone(),
            scene,
            params,
            seed: self.core.seed,
            guidance_rate_hz: positive("guidance-rate-hz", self.guidance_rate_hz)?,
            gain_n_per_m: gain("gain-n-per-m", self.gain_n_per_m)?,
            gain_nm_per_rad: gain("gain-nm-per-rad", self.gain_nm_per_rad)?,
            ttl_s: positive("ttl-ms", self.ttl_ms)? / 1000.0,
            state_poll_hz: positive("poll-hz", self.poll_hz)?,
            state_spin_us: {
                let v = gain("state-spin-us", self.state_spin_us)?;
                if v > 500.0 {
                    bail!("--state-spin-us must be at most 500 (half a tick at 1 kHz), got {v}");
                }
                v
            },
            state_priority: self.state_priority,
            state_timeout_s: 0.5,
            plan_without_operator: self.plan_without_operator,
            roadmap_rate_hz: if self.roadmap_rate_hz == 0.0 {
                0.0
            } else {
                positive("roadmap-rate-hz", self.roadmap_rate_hz)?
            },
            duration_s: self
                .duration_s
                .map(|d| positive("duration-s", d))
                .transpose()?,
        })
    }
}

/// Result of `planner solve`.
#[derive(Debug, Serialize)]
pub struct SolveReport {
    /// Scene name.
    pub scene: String,
    /// Seed.
    pub seed: u64,
    /// Solved within the time limit.
    pub solved: bool,
    /// Seconds spent (to the solution, or the limit).
    pub time_s: f64,
    /// Iterations.
    pub iterations: u64,
    /// Nodes in all trees.
    pub nodes: u64,
    /// Collision checks.
    pub collision_checks: u64,
    /// Weighted length of the solution path (I-RRT eq. 2), if solved.
    pub path_length: Option<f64>,
    /// Waypoints of the solution path, if solved.
    pub path_waypoints: Option<usize>,
}

/// Runs `planner solve`.
pub fn solve(args: &SolveArgs) -> anyhow::Result<SolveReport> {
    let (scene, params) = args.core.load()?;
    let limit = positive("time-limit", args.time_limit)?;
    let color_by = crate::picture::ColorBy::parse(&args.png_color)
        .with_context(|| format!("--png-color: unknown `{}`", args.png_color))?;
    let plane = crate::picture::Plane::parse(&args.png_plane)
        .with_context(|| format!("--png-plane: unknown `{}`", args.png_plane))?;
    let mut planner = Planner::new(&scene, params, args.core.seed)?;
    let started = Instant::now();
    while !planner.solved() && started.elapsed().as_secs_f64() < limit {
        planner.iterate(None);
    }
    let time_s = started.elapsed().as_secs_f64();
    let s = planner.stats();
    let path_length = planner
        .solution()
        .map(|p| crate::space::path_length(planner.space(), p));
    if let Some(p) = planner.solution() {
        let write = |file: &Option<PathBuf>, text: String| -> anyhow::Result<()> {
            if let Some(f) = file {
                std::fs::write(f, text).with_context(|| format!("cannot write {}", f.display()))?;
            }
            Ok(())
        };
        write(&args.path_csv, crate::path::to_csv(planner.space(), p))?;
        write(&args.path_json, crate::path::to_json(planner.space(), p))?;
    }
    if let Some(file) = &args.png {
        if !crate::experiment::report::register_font() {
            tracing::warn!("no TrueType font found (DejaVuSans.ttf): the PNG has no text");
        }
        let label = format!("{} seed {}", scene.name, args.core.seed);
        crate::picture::draw_planner_png(
            &scene,
            &planner,
            &label,
            color_by,
            plane,
            file,
            (1000, 1000),
        )
        .map_err(anyhow::Error::msg)?;
    }
    Ok(SolveReport {
        scene: scene.name.clone(),
        seed: args.core.seed,
        solved: planner.solved(),
        time_s,
        iterations: s.iterations,
        nodes: s.nodes as u64,
        collision_checks: s.collision_checks,
        path_length,
        path_waypoints: planner.solution().map(<[_]>::len),
    })
}

fn write_json(path: &std::path::Path, value: &impl Serialize) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    std::fs::write(path, text + "\n").with_context(|| format!("cannot write {}", path.display()))
}

/// Sets up logging to stderr (`RUST_LOG` overrides `info`).
pub fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
}

/// Parses `args` (the first is the program name) and runs the command. Returns the process
/// exit code: 0 on success (for `solve`: solved), 1 when `solve` did not solve in time.
pub fn main_with_args<I, T>(args: I) -> anyhow::Result<i32>
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
    init_logging();
    match cli.command {
        Command::Serve(a) => {
            let config = a.to_config()?;
            let stop = Arc::new(AtomicBool::new(false));
            {
                let stop = stop.clone();
                ctrlc::set_handler(move || stop.store(true, Ordering::Release))
                    .context("cannot install the SIGINT/SIGTERM handler")?;
            }
            tracing::info!(
                "planner serving scene '{}' in namespace '{}' (seed {})",
                config.scene.name,
                config.namespace,
                config.seed
            );
            let report = shell::run(&config, stop)?;
            tracing::info!(
                "planner done: solved {}, {} iterations, {} nodes, states {:.0} Hz",
                report.solved,
                report.iterations,
                report.nodes,
                report.state_rate_hz
            );
            if let Some(p) = &a.json {
                write_json(p, &report)?;
            }
            Ok(0)
        }
        Command::Solve(a) => {
            let report = solve(&a)?;
            println!(
                "{}: solved {} in {:.3} s, {} iterations, {} nodes, {} collision checks",
                report.scene,
                report.solved,
                report.time_s,
                report.iterations,
                report.nodes,
                report.collision_checks
            );
            if let Some(p) = &a.json {
                write_json(p, &report)?;
            }
            Ok(if report.solved { 0 } else { 1 })
        }
        Command::Experiment(a) => {
            experiment(&a)?;
            Ok(0)
        }
        Command::View(a) => {
            let config = a.to_config()?;
            let stop = Arc::new(AtomicBool::new(false));
            {
                let stop = stop.clone();
                ctrlc::set_handler(move || stop.store(true, Ordering::Release))
                    .context("cannot install the SIGINT/SIGTERM handler")?;
            }
            let viewer = crate::view::Viewer::new(&config)?;
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
            if let Some(p) = &a.json {
                write_json(p, &report)?;
            }
            Ok(0)
        }
        Command::MergeRecordings(a) => {
            let n = crate::view::merge_mcap(&a.inputs, &a.out)?;
            println!("wrote {} messages to {}", n, a.out.display());
            Ok(0)
        }
        Command::Scenes(a) => {
            for name in scene::BUILTIN_NAMES {
                if name == "default" {
                    continue;
                }
                let scene = Scene::builtin(name).context("built-in scene")?;
                match &a.write {
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
    }
}

/// Runs `planner experiment`: the sweep, then runs.csv, summary.md and plots in `--out`.
pub fn experiment(a: &ExperimentArgs) -> anyhow::Result<()> {
    use crate::experiment::{self as ex, report};
    let limit = positive("time-limit", a.time_limit)?;
    if a.seeds == 0 {
        bail!("--seeds must be >= 1");
    }
    let specs = if a.sweep == "irrt" {
        let methods = a
            .methods
            .iter()
            .map(|m| {
                crate::Sampling::parse(m, a.beta, 0.5)
                    .with_context(|| format!("unknown method `{m}` in --methods"))
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        ex::irrt_specs(&a.scene, &methods, &a.sigmas, &a.eps, a.seeds, limit)
    } else {
        ex::hrrtc_specs(
            &a.scenes,
            &a.alphas,
            a.hrrtc_eps,
            a.error_sigma,
            a.local_trees,
            a.seeds,
            limit,
        )
    };
    for s in &specs {
        s.params.validate()?;
        if scene::Scene::builtin(&s.scene).is_none() {
            bail!("`{}` is not a built-in scene", s.scene);
        }
    }
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;
    let bar = if a.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(specs.len() as u64)
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{elapsed_precise} [{bar:40}] {pos}/{len} runs, eta {eta} {msg}",
        )
        .context("progress template")?,
    );
    let pictures = a.pictures && report::register_font();
    if a.pictures && !pictures {
        eprintln!("planner: no TrueType font found (DejaVuSans.ttf): pictures skipped");
    }
    let roadmaps = a.out.join("roadmaps");
    if pictures {
        std::fs::create_dir_all(&roadmaps)
            .with_context(|| format!("cannot create {}", roadmaps.display()))?;
    }
    let mut results = Vec::with_capacity(specs.len());
    for s in &specs {
        let png = (pictures && s.seed == 1).then(|| {
            let method = match s.user {
                ex::UserModel::None => "auto",
                _ => s.params.sampling.name(),
            };
            roadmaps.join(format!(
                "{}-{}-sigma{}-{}.png",
                s.scene,
                method.replace('+', "_"),
                s.params.user_sigma,
                match s.user {
                    ex::UserModel::PassThrough { eps_v }
                    | ex::UserModel::ContactSeeking { eps_v, .. } => format!("eps{eps_v}"),
                    ex::UserModel::None => "auto".into(),
                } + &match s.params.sampling {
                    crate::Sampling::Hrrtc { alpha } => format!("-alpha{alpha}"),
                    _ => String::new(),
                }
            ))
        });
        let (r, drawn) = ex::run_drawn(s, png.as_deref())?;
        if let Err(e) = drawn {
            eprintln!("planner: {e}");
        }
        bar.set_message(format!(
            "{} {} seed {}: {}",
            r.scene,
            r.method,
            r.seed,
            if r.solved {
                format!("{:.2} s", r.time_s)
            } else {
                "unsolved".into()
            }
        ));
        bar.inc(1);
        results.push(r);
    }
    bar.finish();
    let summaries = report::summarize(&results, limit);
    let csv = a.out.join("runs.csv");
    std::fs::write(&csv, report::to_csv(&results))?;
    let md = a.out.join("summary.md");
    let header = format!(
        "# `planner experiment {}`: {} runs, {} seeds per configuration, {} s limit\n\n",
        a.sweep,
        results.len(),
        a.seeds,
        limit
    );
    std::fs::write(&md, header + &report::to_markdown(&summaries))?;
    println!("{}", report::to_markdown(&summaries));
    println!("wrote {} and {}", csv.display(), md.display());
    if report::register_font() {
        let png = a.out.join(format!("{}.png", a.sweep));
        let drawn = if a.sweep == "irrt" {
            report::plot_irrt(&summaries, limit, &png)
        } else {
            report::plot_hrrtc(&summaries, limit, &png)
        };
        match drawn {
            Ok(()) => println!("wrote {}", png.display()),
            Err(e) => eprintln!("planner: cannot draw {}: {e}", png.display()),
        }
    } else {
        eprintln!("planner: no TrueType font found (DejaVuSans.ttf): plots skipped");
    }
    Ok(())
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
}
