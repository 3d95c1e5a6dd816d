//! `planner experiment`: the papers' sweeps with a simulated operator in lockstep, then
//! runs.csv, summary.md and plots.

use crate::common::positive;
use anyhow::{Context, bail};
use clap::Args;
use std::path::PathBuf;

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

/// Runs `planner experiment`: the sweep, then runs.csv, summary.md and plots in `--out`.
pub fn run(a: &ExperimentArgs) -> anyhow::Result<i32> {
    use lab::experiment::{self as ex, report};
    let limit = positive("time-limit", a.time_limit)?;
    if a.seeds == 0 {
        bail!("--seeds must be >= 1");
    }
    let specs = if a.sweep == "irrt" {
        let methods = a
            .methods
            .iter()
            .map(|m| {
                planner::Sampling::parse(m, a.beta, 0.5)
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
                    planner::Sampling::Hrrtc { alpha } => format!("-alpha{alpha}"),
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
    Ok(0)
}
