//! The options of `planner experiment` (the lockstep sweeps and the live one share them).

use clap::Args;
use std::path::PathBuf;

/// Options of `planner experiment`.
#[derive(Debug, Args, Clone)]
pub struct ExperimentArgs {
    /// `irrt`: sampling method × σ × ε_v on the maze with a pass-through operator (I-RRT
    /// §6). `hrrtc`: α on narrow tunnels and crossing planes with a contact-seeking
    /// operator, beside automatic RRT-Connect (H-RRT-C Tables I and III); both in lockstep.
    /// `live`: real sessions of `haptic-loop demo` (loop, contact, simulated operator,
    /// planner process) per scene × method × seed.
    #[arg(value_parser = ["irrt", "hrrtc", "live"])]
    pub sweep: String,
    /// Runs (seeds 1..=N) per configuration [default: 5; live: 3].
    #[arg(long)]
    pub seeds: Option<u64>,
    /// Wall-clock limit per run, s (unsolved runs count at the limit in medians)
    /// [default: 10; live: 30].
    #[arg(long)]
    pub time_limit: Option<f64>,
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
    /// hrrtc, live: scenes, comma-separated built-ins (live: or scene files with a route).
    #[arg(long, default_value = "tunnels,crossing-planes", value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// hrrtc, live: α values (share of machine samples), comma-separated.
    #[arg(long, default_value = "0,0.1,0.5,0.9", value_delimiter = ',')]
    pub alphas: Vec<f64>,
    /// live: methods, comma-separated: operator-alone (no planner), rrt-connect
    /// (automatic; its path's guidance then leads the operator), hrrtc-fixed (the paper's
    /// fixed α) and hrrtc-adaptive (authority that adapts to a stuck operator), one run
    /// per --alphas each; pos+cs, path (I-RRT), irrtc-mouse (contact sampling at α = 0 with
    /// the SpaceMouse operator), hrrtc (fixed α, as hrrtc-fixed, the name of the earlier
    /// sweeps), hrrtc-paper (the same with the paper's human mode, `--human-mode every`),
    /// hrrtc-noguide, hrrtc-novice, hrrtc-novice-noguide, hrrtc-mouse, hrrtc-shared (the
    /// novice, keeping α in contact) (at --guide-alpha). `NAME=α` runs a method at that α
    /// only (e.g. `hrrtc-fixed=0.5,hrrtc-adaptive=0.9`).
    #[arg(
        long,
        default_value = "rrt-connect,pos+cs,path,irrtc-mouse,hrrtc,hrrtc-noguide",
        value_delimiter = ','
    )]
    pub live_methods: Vec<String>,
    /// live: α of hrrtc-noguide, hrrtc-novice(-noguide), hrrtc-mouse and hrrtc-shared.
    #[arg(long, default_value_t = 0.5)]
    pub guide_alpha: f64,
    /// live: the haptic-loop executable [default: `haptic-loop` beside this executable].
    #[arg(long)]
    pub haptic_loop_exe: Option<PathBuf>,
    /// live: the simulated operator of every method that does not name its own (the
    /// -novice ones), passed on to `haptic-loop demo --operator`, which checks the name
    /// (expert, novice, ...) [default: expert].
    #[arg(long, value_name = "NAME")]
    pub operator: Option<String>,
    /// live: the first seed: a sweep run in parts takes seeds --first-seed ..
    /// --first-seed + --seeds − 1.
    #[arg(long, default_value_t = 1)]
    pub first_seed: u64,
    /// live: run no session; read the runs.csv of these earlier sweeps' output folders
    /// (comma-separated) and write their reports together into OUT (give the --time-limit
    /// they ran with).
    #[arg(long, value_delimiter = ',')]
    pub report_from: Vec<PathBuf>,
    /// live: run each scene without its `[[route]]`, as a user's own scene: copies of the
    /// scenes without it are written to OUT/scenes-no-route/ and the sessions run on them.
    #[arg(long)]
    pub no_route: bool,
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
