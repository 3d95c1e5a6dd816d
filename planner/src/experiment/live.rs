//! `planner experiment live`: real sessions of the two processes, one per scene × method ×
//! seed: `haptic-loop demo` runs the loop at its rate with contact on the simulated arm (or
//! SpaceMouse) held by the simulated operator, and starts this planner as its own process.
//! Sessions run scene by scene, and within a scene seed by seed with every method of a
//! seed back to back. Each session's `--summary-json` becomes a row of OUT/runs.csv
//! (written after every run, so an interrupted sweep keeps what it did); OUT/summary.md
//! and OUT/live.png at the end. A sweep run in parts (`--first-seed`) is reported together
//! with `--report-from`.
//! The methods, rows and reports are `lab::live`'s; this file starts and stops processes.

use super::ExperimentArgs;
use anyhow::{Context, bail};
use lab::LabError;
use lab::live::{self, LiveMethod, LiveRun};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Extra wall time a session may take beyond its planning limit (voxmap build, start-up,
/// the operator reaching the goal after the solution) before it is stopped, s.
const GRACE_S: f64 = 60.0;

/// A validated live sweep.
struct LiveSweep {
    /// The scenes as given (names in the reports).
    scenes: Vec<String>,
    /// What the demo is given for each scene: the scene itself, or its copy without a
    /// route (`--no-route`).
    scene_args: Vec<String>,
    /// The scenes keep their routes.
    route: bool,
    methods: Vec<LiveMethod>,
    seeds: u64,
    first_seed: u64,
    time_limit_s: f64,
    out: PathBuf,
    exe: PathBuf,
}

fn sweep_of(a: &ExperimentArgs) -> anyhow::Result<LiveSweep> {
    let time_limit_s = crate::common::positive("time-limit", a.time_limit.unwrap_or(30.0))?;
    let seeds = a.seeds.unwrap_or(3);
    if seeds == 0 {
        bail!("--seeds must be >= 1");
    }
    if a.first_seed == 0 || a.first_seed.checked_add(seeds).is_none() {
        bail!("--first-seed must be >= 1 (and leave room for --seeds)");
    }
    for &alpha in a.alphas.iter().chain(std::iter::once(&a.guide_alpha)) {
        if !(0.0..=1.0).contains(&alpha) {
            bail!("--alphas / --guide-alpha: α must be in [0, 1], got {alpha}");
        }
    }
    for s in &a.scenes {
        scene::Scene::by_name_or_path(s).with_context(|| format!("--scenes: {s}"))?;
    }
    let operator = a.operator.as_deref().unwrap_or(live::DEFAULT_OPERATOR);
    if operator.is_empty() || operator.contains(char::is_whitespace) {
        bail!("--operator {operator:?}: expected a preset name such as expert or novice");
    }
    let mut methods = Vec::new();
    for m in &a.live_methods {
        methods.extend(LiveMethod::parse(m, &a.alphas, a.guide_alpha, operator)?);
    }
    if methods.is_empty() {
        bail!("--live-methods: no method given");
    }
    let exe = match &a.haptic_loop_exe {
        Some(p) => p.clone(),
        None => std::env::current_exe()
            .context("cannot find the planner executable")?
            .parent()
            .context("the planner executable has no folder")?
            .join("haptic-loop"),
    };
    if !exe.is_file() {
        bail!(
            "{} not found: build it with `cargo build --release -p haptic-loop` (the same \
             profile as this planner) or give --haptic-loop-exe",
            exe.display()
        );
    }
    let scene_args = if a.no_route {
        let dir = a.out.join("scenes-no-route");
        a.scenes
            .iter()
            .map(|s| {
                live::write_without_route(s, &dir)
                    .map(|p| p.display().to_string())
                    .with_context(|| format!("--no-route: cannot write {s} without its route"))
            })
            .collect::<anyhow::Result<Vec<_>>>()?
    } else {
        a.scenes.clone()
    };
    Ok(LiveSweep {
        scenes: a.scenes.clone(),
        scene_args,
        route: !a.no_route,
        methods,
        seeds,
        first_seed: a.first_seed,
        time_limit_s,
        out: a.out.clone(),
        exe,
    })
}

/// Stops a session: SIGTERM (the demo stops its planner), then SIGKILL after 10 s.
fn stop(child: &mut Child) {
    // SAFETY: kill(2) on a child we spawned and have not reaped.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) };
    let deadline = Instant::now() + Duration::from_secs(10);
    while Instant::now() < deadline && matches!(child.try_wait(), Ok(None)) {
        std::thread::sleep(Duration::from_millis(50));
    }
    let _ = child.kill();
    let _ = child.wait();
}

/// One session; `Ok(None)` when it was stopped (time-out or Ctrl-C) without a summary.
fn session(
    sweep: &LiveSweep,
    scene: &str,
    scene_arg: &str,
    method: &LiveMethod,
    seed: u64,
    tag: &str,
    cancel: &std::sync::atomic::AtomicBool,
) -> anyhow::Result<Option<LiveRun>> {
    let summary = sweep.out.join("summaries").join(format!("{tag}.json"));
    let log = sweep.out.join("logs").join(format!("{tag}.log"));
    let _ = std::fs::remove_file(&summary);
    let log_file =
        std::fs::File::create(&log).with_context(|| format!("cannot write {}", log.display()))?;
    // Children from now on: a signal stops them in order (`ipc_types::startup`).
    ipc_types::startup::hold_resources();
    let mut cmd = Command::new(&sweep.exe);
    cmd.arg("demo")
        .args(["--scene", scene_arg])
        .args(["--seed", &seed.to_string()])
        .args(["--time-limit-s", &sweep.time_limit_s.to_string()])
        .args(["--until-goal", "--after-solve-s", "0.5"])
        .args(["--namespace", &format!("live{}x{tag}", std::process::id())])
        .arg("--summary-json")
        .arg(&summary)
        .args(method.demo_args())
        .stdin(Stdio::null())
        .stdout(log_file.try_clone()?)
        .stderr(log_file);
    let mut child = cmd
        .spawn()
        .with_context(|| format!("cannot start {}", sweep.exe.display()))?;
    let deadline = Instant::now() + Duration::from_secs_f64(sweep.time_limit_s + GRACE_S);
    let status = loop {
        if let Some(st) = child.try_wait()? {
            break Some(st);
        }
        if Instant::now() >= deadline || cancel.load(std::sync::atomic::Ordering::Acquire) {
            stop(&mut child);
            break None;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    match status {
        // 0: solved, 1: not solved in time; both wrote their summary.
        Some(st) if matches!(st.code(), Some(0 | 1)) => {
            let text = std::fs::read_to_string(&summary)
                .with_context(|| format!("{} wrote no summary ({})", tag, log.display()))?;
            let origin = summary.display().to_string();
            Ok(Some(LiveRun::from_summary(
                scene,
                sweep.route,
                method,
                seed,
                &text,
                &origin,
            )?))
        }
        Some(st) => bail!(
            "haptic-loop demo failed ({st}) for {scene} / {} / seed {seed}: {}(see {})",
            method.name,
            last_error(&log),
            log.display()
        ),
        None => Ok(None),
    }
}

/// The demo's own error line from its log (e.g. clap's on an unknown `--operator`), with
/// a trailing space; empty when there is none.
fn last_error(log: &Path) -> String {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    text.lines()
        .rev()
        .find(|l| l.starts_with("error:") || l.contains("haptic-loop: "))
        .map(|l| format!("{} ", l.trim()))
        .unwrap_or_default()
}

fn write(path: &Path, text: &str) -> anyhow::Result<()> {
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

/// A file-name-safe tag of a run.
fn tag(scene: &str, method: &str, seed: u64) -> String {
    let clean = |s: &str| -> String {
        s.chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect()
    };
    format!("{}-{}-{seed}", clean(scene), clean(method))
}

/// Writes OUT/summary.md (also printed) and OUT/live.png from `runs`.
fn reports(runs: &[LiveRun], time_limit_s: f64, out: &Path) -> anyhow::Result<()> {
    let summaries = live::summarize(runs, time_limit_s);
    let md = live::to_markdown(&summaries, time_limit_s);
    let md_path = out.join("summary.md");
    write(&md_path, &md)?;
    println!("{md}");
    println!("wrote {}", md_path.display());
    let png = out.join("live.png");
    match live::plot(runs, time_limit_s, &png) {
        Ok(()) => println!("wrote {}", png.display()),
        Err(LabError::NoFont) => {
            eprintln!("planner: no TrueType font found (DejaVuSans.ttf): plot skipped")
        }
        Err(e) => eprintln!("planner: {:#}", anyhow::Error::new(e)),
    }
    Ok(())
}

/// `--report-from`: the runs of earlier sweeps, reported together in OUT.
fn report_from(a: &ExperimentArgs) -> anyhow::Result<i32> {
    let time_limit_s = crate::common::positive("time-limit", a.time_limit.unwrap_or(30.0))?;
    let mut runs = Vec::new();
    for dir in &a.report_from {
        let path = dir.join("runs.csv");
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("--report-from: cannot read {}", path.display()))?;
        runs.extend(live::from_csv(&text, &path.display().to_string())?);
    }
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;
    let csv = a.out.join("runs.csv");
    write(&csv, &live::to_csv(&runs))?;
    println!(
        "{} runs from {} sweeps; wrote {}",
        runs.len(),
        a.report_from.len(),
        csv.display()
    );
    reports(&runs, time_limit_s, &a.out)?;
    Ok(0)
}

/// Runs the live sweep; see the module docs. Exit code 0 (also when runs were unsolved).
pub fn run(a: &ExperimentArgs) -> anyhow::Result<i32> {
    if !a.report_from.is_empty() {
        return report_from(a);
    }
    let sweep = sweep_of(a)?;
    for dir in ["summaries", "logs"] {
        let d = sweep.out.join(dir);
        std::fs::create_dir_all(&d).with_context(|| format!("cannot create {}", d.display()))?;
    }
    let cancel = crate::stop_on_signal()?;
    let total = sweep.scenes.len() as u64 * sweep.methods.len() as u64 * sweep.seeds;
    let bar = if a.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(total)
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{elapsed_precise} [{bar:40}] {pos}/{len} sessions, eta {eta} {msg}",
        )
        .context("progress template")?,
    );
    let csv = sweep.out.join("runs.csv");
    let mut runs: Vec<LiveRun> = Vec::new();
    // Every method of a seed back to back: a change of the machine's load (it is shared)
    // then falls on all methods alike rather than on one.
    'all: for (scene, scene_arg) in sweep.scenes.iter().zip(&sweep.scene_args) {
        for seed in sweep.first_seed..sweep.first_seed + sweep.seeds {
            for method in &sweep.methods {
                if cancel.load(std::sync::atomic::Ordering::Acquire) {
                    break 'all;
                }
                let t = tag(scene, &method.name, seed);
                match session(&sweep, scene, scene_arg, method, seed, &t, &cancel)? {
                    Some(r) => {
                        bar.set_message(format!(
                            "{scene} {} seed {seed}: {}",
                            method.name,
                            if r.solved {
                                format!("{:.2} s", r.time_to_solve_s)
                            } else {
                                "unsolved".into()
                            }
                        ));
                        runs.push(r);
                        write(&csv, &live::to_csv(&runs))?;
                    }
                    None => bar.println(format!(
                        "{scene} {} seed {seed}: stopped without a summary (see {})",
                        method.name,
                        sweep.out.join("logs").join(format!("{t}.log")).display()
                    )),
                }
                bar.inc(1);
            }
        }
    }
    bar.finish();
    println!("wrote {}", csv.display());
    reports(&runs, sweep.time_limit_s, &sweep.out)?;
    Ok(0)
}
