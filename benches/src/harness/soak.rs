//! The soak (docs/benchmarks.md, "Soak"): the product's processes as they are deployed,
//! for an hour. Host A runs `haptic-loop run` (the simulated arm held by the newcomer, on a
//! scene with no way through, so that the planners plan all the while), a local `planner
//! serve` that is killed (`kill -9`) or hung (`SIGSTOP`, then killed) and restarted every
//! `restart_s`, and the loop-side `hrrtc-bridge`. "Host B" (a folder whose iceoryx2
//! configuration gives it a domain of its own, as the integration tests do) runs a second
//! `planner serve --bridge-connect quic/...` for the whole soak, over mutual TLS with the
//! lab's certificates of `hrrtc-bridge certs`: its memory is the one held to a bound.
//!
//! Every minute the soak samples each process's `RssAnon` and `RssShmem`; an observer thread
//! watches the loop's state and guidance service ([`watch`]); at the end the loop's own
//! summary and the remote planner's report are read back, and the goals judged
//! ([`SoakReport`]).

mod child;
pub mod memory;
mod report;
mod watch;

pub use report::{
    Goal, LoopFigures, LoopReportPart, LoopSummary, RemoteFigures, Restart, SoakReport,
};

use child::Proc;
use haptic_loop::relay::choice::HYSTERESIS;
use memory::{Rss, Sample};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use watch::{Seen, Watch};

/// How to run a soak (validated by the binary).
#[derive(Debug, Clone)]
pub struct SoakConfig {
    /// Minutes to run, from the moment every process serves.
    pub minutes: f64,
    /// Fault the local planner every this many seconds.
    pub restart_s: f64,
    /// How long a hung planner stays stopped before it is killed, s.
    pub hang_s: f64,
    /// A restarted planner must be followed within this, s.
    pub follow_s: f64,
    /// The scene file (absolute: host B's processes run in another folder).
    pub scene: PathBuf,
    /// The simulated operator (`haptic-loop run --operator`).
    pub operator: String,
    /// SCHED_FIFO priority of the loop's RT thread (0: normal scheduler).
    pub priority: u8,
    /// Voxel size of the loop's contact, mm.
    pub voxel_mm: f64,
    /// The remote planner's memory bound (`planner serve --max-memory-mb`), MiB.
    pub remote_max_memory_mb: u64,
    /// What the remote planner's `RssAnon` may exceed its bound by, MiB.
    pub remote_allowance_mb: u64,
    /// `haptic-loop`.
    pub loop_exe: PathBuf,
    /// `planner`.
    pub planner_exe: PathBuf,
    /// `hrrtc-bridge`.
    pub bridge_exe: PathBuf,
    /// The run's folder (absolute): logs, reports, certificates, host B.
    pub dir: PathBuf,
    /// How long start-up may take (the loop's voxmap build, the planners' start), s.
    pub start_timeout_s: f64,
}

/// Why a soak could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum SoakError {
    /// A process or thread could not be started.
    #[error("cannot start {what}: {error}")]
    Start {
        /// What.
        what: String,
        /// The OS error.
        error: std::io::Error,
    },
    /// A file or folder could not be made or read.
    #[error("{what}: {error}")]
    Io {
        /// What was being done.
        what: String,
        /// The OS error.
        error: std::io::Error,
    },
    /// Start-up went wrong: a process ended, or something did not come in time.
    #[error("{what}: {reason}")]
    Setup {
        /// What was awaited or made.
        what: String,
        /// What happened.
        reason: String,
    },
    /// The observer's iceoryx2 ports.
    #[error(transparent)]
    Ipc(#[from] ipc_types::services::ServiceError),
    /// Ctrl-C / SIGTERM before every process served.
    #[error("stopped during start-up")]
    Stopped,
}

/// The processes of a soak.
struct Processes {
    haptic_loop: Proc,
    bridge: Proc,
    remote: Proc,
    local: Proc,
    /// The local planners' pids, in order (incarnation n at index n − 1).
    local_pids: Vec<u32>,
}

impl Processes {
    /// Who process `pid` is, for the report.
    fn name(&self, pid: u32) -> String {
        if pid == self.remote.pid() {
            return "the remote planner".into();
        }
        match self.local_pids.iter().position(|&p| p == pid) {
            Some(i) => format!("local planner {}", i + 1),
            None => format!("planner pid {pid}"),
        }
    }

    fn sample(&self, minute: f64) -> Sample {
        Sample {
            minute,
            haptic_loop: Rss::of(self.haptic_loop.pid()),
            local_planner: Rss::of(self.local.pid()),
            bridge: Rss::of(self.bridge.pid()),
            remote_planner: Rss::of(self.remote.pid()),
        }
    }
}

/// Runs the soak until its end or until `stop` is set (then it stops early and reports
/// what ran).
pub fn run(config: &SoakConfig, stop: &AtomicBool) -> Result<SoakReport, SoakError> {
    let ns = format!("soak_{}", std::process::id());
    let host_b = host_b(&config.dir)?;
    make_certs(config)?;
    let port = free_udp_port()?;
    let bound_passed = planner_has_max_memory(&config.planner_exe);
    let deadline = Instant::now() + Duration::from_secs_f64(config.start_timeout_s);

    let mut haptic_loop = Proc::spawn(loop_command(config, &ns), &config.dir, "haptic-loop")?;
    wait_for(
        stop,
        deadline,
        "the loop's state",
        &mut [&mut haptic_loop],
        || ipc_types::services::newest_state_generation(&ns).is_some(),
    )?;
    let watch = Watch::start(&ns)?;
    wait_for(
        stop,
        deadline,
        "the loop's first tick",
        &mut [&mut haptic_loop],
        || watch.seen().ticks > 0,
    )?;
    let mut bridge = Proc::spawn(bridge_command(config, &ns, port), &config.dir, "bridge")?;
    let mut remote_cmd = remote_command(config, &ns, port, bound_passed);
    remote_cmd.current_dir(&host_b);
    let mut remote = Proc::spawn(remote_cmd, &config.dir, "remote-planner")?;
    let mut local = Proc::spawn(
        local_command(config, &ns, 1),
        &config.dir,
        "local-planner-1",
    )?;
    let (local_pid, remote_pid) = (local.pid(), remote.pid());
    wait_for(
        stop,
        deadline,
        "both planners' guidance, fresh on the loop's host",
        &mut [&mut haptic_loop, &mut bridge, &mut remote, &mut local],
        || {
            let s = watch.seen();
            let fresh = |pid| s.planner(pid).is_some_and(|p| p.first_fresh.is_some());
            fresh(local_pid) && (fresh(remote_pid) || s.planners.iter().any(|p| p.pid != local_pid))
        },
    )?;
    eprintln!(
        "soak: every process serves (loop pid {}, local planner {}, bridge {}, remote planner {}); {} min, a planner fault every {} s; logs in {}",
        haptic_loop.pid(),
        local.pid(),
        bridge.pid(),
        remote.pid(),
        config.minutes,
        config.restart_s,
        config.dir.display()
    );
    let mut procs = Processes {
        haptic_loop,
        bridge,
        remote,
        local,
        local_pids: vec![local_pid],
    };
    let ran = supervise(config, &ns, stop, &mut procs, &watch);
    finish(config, procs, watch, ran, bound_passed)
}

/// What the supervision of the running soak leaves for the report.
struct Ran {
    minutes: f64,
    interrupted: bool,
    ended_early: Vec<String>,
    samples: Vec<Sample>,
    restarts: Vec<Restart>,
    /// When each restart's planner was started (to judge those not judged yet).
    started: Vec<Instant>,
}

/// A fault of the local planner in progress: hung since `at`, to be killed at `until`.
struct Hang {
    at_s: f64,
    until: Instant,
}

/// The soak proper: samples memory every minute, faults the local planner every
/// `restart_s`, judges each restart `follow_s` after it, until the end, an interruption, or
/// a process ending on its own.
fn supervise(
    config: &SoakConfig,
    ns: &str,
    stop: &AtomicBool,
    p: &mut Processes,
    watch: &Watch,
) -> Ran {
    let t0 = Instant::now();
    let total = Duration::from_secs_f64(config.minutes * 60.0);
    let end = t0 + total;
    let every = Duration::from_secs_f64(config.restart_s);
    let follow = Duration::from_secs_f64(config.follow_s);
    let hang = Duration::from_secs_f64(config.hang_s);
    let mut ran = Ran {
        minutes: 0.0,
        interrupted: false,
        ended_early: Vec::new(),
        samples: Vec::new(),
        restarts: Vec::new(),
        started: Vec::new(),
    };
    let mut next_sample = t0 + Duration::from_secs(60);
    let mut next_fault = t0 + every;
    let mut hung: Option<Hang> = None;
    let mut judged = 0;
    loop {
        let now = Instant::now();
        let since = |t: Instant| t.duration_since(t0).as_secs_f64();
        if stop.load(Ordering::Acquire) {
            ran.interrupted = true;
            break;
        }
        for proc in [&mut p.haptic_loop, &mut p.bridge, &mut p.remote] {
            if let Some(status) = proc.exited() {
                ran.ended_early
                    .push(format!("{} ended on its own ({status})", proc.name));
            }
        }
        if hung.is_none()
            && let Some(status) = p.local.exited()
        {
            ran.ended_early
                .push(format!("{} ended on its own ({status})", p.local.name));
        }
        if !ran.ended_early.is_empty() {
            break;
        }
        if now >= next_sample {
            let sample = p.sample(since(next_sample) / 60.0);
            progress(&sample, ran.restarts.len(), &watch.seen());
            ran.samples.push(sample);
            next_sample += Duration::from_secs(60);
        }
        if now >= end {
            if ran
                .samples
                .last()
                .is_none_or(|s| s.minute < config.minutes - 1e-6)
            {
                let sample = p.sample(config.minutes);
                progress(&sample, ran.restarts.len(), &watch.seen());
                ran.samples.push(sample);
            }
            break;
        }
        // Fault the local planner: kill it, or hang it and kill it `hang_s` later; then
        // start the next. None so late that its successor could not be judged in time.
        let restart_due = match &hung {
            Some(h) => (now >= h.until).then_some(h.at_s),
            None if now >= next_fault => {
                next_fault += every;
                let room = end.saturating_duration_since(now);
                if room <= hang + follow {
                    None
                } else if ran.restarts.len().is_multiple_of(2) {
                    Some(since(now))
                } else {
                    p.local.signal(libc::SIGSTOP);
                    hung = Some(Hang {
                        at_s: since(now),
                        until: now + hang,
                    });
                    None
                }
            }
            None => None,
        };
        if let Some(at_s) = restart_due {
            let kind = if hung.take().is_some() {
                format!("SIGSTOP, kill -9 {} s later", config.hang_s)
            } else {
                "kill -9".to_owned()
            };
            let old_pid = p.local.pid();
            p.local.kill();
            let n = p.local_pids.len() + 1;
            match Proc::spawn(
                local_command(config, ns, n),
                &config.dir,
                &format!("local-planner-{n}"),
            ) {
                Ok(new) => p.local = new,
                Err(e) => {
                    ran.ended_early.push(format!("local planner {n}: {e}"));
                    break;
                }
            }
            p.local_pids.push(p.local.pid());
            ran.started.push(Instant::now());
            ran.restarts.push(Restart {
                n: n as u32 - 1,
                at_s,
                kind,
                old_pid,
                new_pid: p.local.pid(),
                reached_after_s: None,
                rendered_after_s: None,
                loop_fresh: false,
                loop_rendering: None,
                new_distance: None,
                rendering_distance: None,
                followed: false,
            });
        }
        while judged < ran.restarts.len() && now >= ran.started[judged] + follow {
            judge(
                &mut ran.restarts[judged],
                ran.started[judged],
                follow,
                &watch.seen(),
                p,
            );
            judged += 1;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    ran.minutes = (t0.elapsed().as_secs_f64() / 60.0).min(config.minutes);
    // Stopped early (Ctrl-C, a process ended): the memory of this moment too.
    if ran
        .samples
        .last()
        .is_none_or(|s| s.minute < ran.minutes - 0.01)
    {
        let sample = p.sample(ran.minutes);
        progress(&sample, ran.restarts.len(), &watch.seen());
        ran.samples.push(sample);
    }
    let seen = watch.seen();
    for i in judged..ran.restarts.len() {
        judge(&mut ran.restarts[i], ran.started[i], follow, &seen, p);
    }
    ran
}

/// Whether restart `r`, whose planner started at `started`, was followed: within `follow`
/// its guidance reached the loop's guidance service fresh (what the relay reads), the loop
/// rendered fresh guidance, and that guidance was the new planner's, or that of another
/// live planner the relay's choice keeps (`haptic_loop::relay::choice`: a planner is taken
/// over only by one nearer the goal by more than [`HYSTERESIS`]; the remote planner, whose
/// tree has grown the longest, usually is the nearer). Judged `follow` after the start.
fn judge(r: &mut Restart, started: Instant, follow: Duration, seen: &Seen, p: &Processes) {
    let new = seen.planner(r.new_pid);
    let after = |t: Option<Instant>| t.map(|t| t.saturating_duration_since(started));
    let reached = after(new.and_then(|n| n.first_fresh));
    let rendered = after(new.and_then(|n| n.first_rendered));
    r.reached_after_s = reached.map(|d| d.as_secs_f64());
    r.rendered_after_s = rendered.map(|d| d.as_secs_f64());
    r.loop_fresh = seen.last_fresh.is_some_and(|t| t >= started);
    r.loop_rendering = seen.rendering.map(|pid| p.name(pid));
    r.new_distance = new.map(|n| n.distance_to_goal);
    r.rendering_distance = seen
        .rendering
        .and_then(|pid| seen.planner(pid))
        .map(|q| q.distance_to_goal);
    let in_time = |d: Option<Duration>| d.is_some_and(|d| d <= follow);
    // Another live planner kept by the relay's rule: the new one is not nearer the goal by
    // more than the hysteresis.
    let kept = seen
        .rendering
        .is_some_and(|pid| pid != r.old_pid && pid != r.new_pid)
        && matches!((r.new_distance, r.rendering_distance),
            (Some(new), Some(kept)) if new >= kept * (1.0 - HYSTERESIS));
    r.followed = in_time(reached) && r.loop_fresh && (in_time(rendered) || kept);
}

/// The minute's progress line.
fn progress(sample: &Sample, restarts: usize, seen: &Seen) {
    let rss: Vec<String> = ["loop", "local", "bridge", "remote"]
        .iter()
        .zip(sample.processes())
        .map(|(short, (_, m))| format!("{short} {}", m.map_or("-".into(), |m| m.describe())))
        .collect();
    eprintln!(
        "[{:>5.1} min] restarts {restarts}, loop {} ticks ({} deadline misses), guidance lost {} / back {} | RSS MiB anon / shmem: {}",
        sample.minute,
        seen.ticks,
        seen.deadline_misses,
        seen.guidance_lost,
        seen.guidance_back,
        rss.join(", ")
    );
}

/// Stops every process (the loop first: its summary covers the whole soak), reads the
/// loop's summary and the remote planner's report, and judges the goals.
fn finish(
    config: &SoakConfig,
    mut p: Processes,
    watch: Watch,
    ran: Ran,
    bound_passed: bool,
) -> Result<SoakReport, SoakError> {
    let seen = watch.finish();
    let grace = Duration::from_secs(30);
    let (loop_status, loop_in_time) = p.haptic_loop.stop(grace);
    p.local.stop(Duration::from_secs(10));
    let (_, remote_in_time) = p.remote.stop(grace);
    p.bridge.stop(Duration::from_secs(10));
    let loop_json = config.dir.join("haptic-loop.json");
    let (summary, summary_error) = match read_json::<LoopSummary>(&loop_json) {
        Ok(s) => (Some(s), None),
        Err(e) => {
            let why = if loop_in_time {
                format!("{e} (the loop ended with {loop_status:?})")
            } else {
                format!(
                    "{e} (the loop did not stop within {} s of SIGTERM)",
                    grace.as_secs()
                )
            };
            (None, Some(why))
        }
    };
    let remote_report = read_json::<serde_json::Value>(&config.dir.join("remote-planner.json"));
    if remote_report.is_err() && !remote_in_time {
        eprintln!(
            "soak: the remote planner did not stop within {} s of SIGTERM",
            grace.as_secs()
        );
    }
    let remote_report = remote_report.ok();
    let mut report = SoakReport {
        minutes_planned: config.minutes,
        minutes_run: ran.minutes,
        interrupted: ran.interrupted,
        scene: config.scene.display().to_string(),
        operator: config.operator.clone(),
        restart_s: config.restart_s,
        follow_s: config.follow_s,
        ended_early: ran.ended_early,
        haptic_loop: LoopFigures {
            summary,
            summary_error,
            ticks_seen: seen.ticks,
            longest_state_gap_ms: seen.longest_state_gap_ms,
            guidance_lost: seen.guidance_lost,
            guidance_back: seen.guidance_back,
            longest_lost_ms: seen.longest_lost_ms,
            faults_seen: seen.faults.clone(),
        },
        restarts: ran.restarts,
        memory_shown: memory::reported(&ran.samples)
            .into_iter()
            .map(|i| ran.samples[i].minute)
            .collect(),
        memory: ran.samples,
        remote_planner: RemoteFigures {
            pid: p.remote.pid(),
            bound_mb: config.remote_max_memory_mb,
            allowance_mb: config.remote_allowance_mb,
            bound_passed,
            memory: remote_report
                .as_ref()
                .and_then(|r| r.get("memory").cloned()),
            report: remote_report,
        },
        goals: Vec::new(),
        logs: config.dir.clone(),
    };
    report.judge();
    Ok(report)
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Polls `ready` every 50 ms until it holds; an error when `stop` is set, one of `procs`
/// ends, or `deadline` passes.
fn wait_for(
    stop: &AtomicBool,
    deadline: Instant,
    what: &str,
    procs: &mut [&mut Proc],
    mut ready: impl FnMut() -> bool,
) -> Result<(), SoakError> {
    loop {
        if ready() {
            return Ok(());
        }
        if stop.load(Ordering::Acquire) {
            return Err(SoakError::Stopped);
        }
        for p in procs.iter_mut() {
            if let Some(status) = p.exited() {
                return Err(SoakError::Setup {
                    what: format!("waiting for {what}"),
                    reason: format!(
                        "{} ended ({status}); its log ({}) ends:\n{}",
                        p.name,
                        p.log.display(),
                        p.log_tail(20)
                    ),
                });
            }
        }
        if Instant::now() >= deadline {
            return Err(SoakError::Setup {
                what: format!("waiting for {what}"),
                reason: "start-up took longer than --start-timeout-s".into(),
            });
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Host B's folder: processes started in it read `config/iceoryx2.toml`, which gives their
/// iceoryx2 another file prefix, so they see none of host A's services or shared memory.
fn host_b(dir: &Path) -> Result<PathBuf, SoakError> {
    let host = dir.join("host-b");
    let io = |what: String| move |error| SoakError::Io { what, error };
    std::fs::create_dir_all(host.join("config"))
        .map_err(io(format!("making {}", host.display())))?;
    let config = host.join("config/iceoryx2.toml");
    std::fs::write(
        &config,
        format!("[global]\nprefix = \"iox2_soakb{}_\"\n", std::process::id()),
    )
    .map_err(io(format!("writing {}", config.display())))?;
    Ok(host)
}

/// The lab's certificates: `loop` (valid for 127.0.0.1, which host B connects to) and
/// `planner`, by `hrrtc-bridge certs`.
fn make_certs(config: &SoakConfig) -> Result<(), SoakError> {
    let out = Command::new(&config.bridge_exe)
        .args(["certs", "--out"])
        .arg(config.dir.join("certs"))
        .args(["--name", "loop=127.0.0.1", "--name", "planner"])
        .output()
        .map_err(|error| SoakError::Start {
            what: format!("{} certs", config.bridge_exe.display()),
            error,
        })?;
    if !out.status.success() {
        return Err(SoakError::Setup {
            what: "the lab's certificates (hrrtc-bridge certs)".into(),
            reason: String::from_utf8_lossy(&out.stderr).trim().to_owned(),
        });
    }
    Ok(())
}

/// A UDP port on loopback free a moment ago (QUIC runs over UDP).
fn free_udp_port() -> Result<u16, SoakError> {
    std::net::UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .map(|a| a.port())
        .map_err(|error| SoakError::Io {
            what: "finding a free UDP port".into(),
            error,
        })
}

/// Whether this `planner serve` takes `--max-memory-mb`.
fn planner_has_max_memory(planner: &Path) -> bool {
    Command::new(planner)
        .args(["serve", "--help"])
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).contains("--max-memory-mb"))
}

fn cert(config: &SoakConfig, file: &str) -> PathBuf {
    config.dir.join("certs").join(file)
}

/// `haptic-loop run` on the simulated arm: no planner of its own, until SIGTERM.
fn loop_command(config: &SoakConfig, ns: &str) -> Command {
    let mut c = Command::new(&config.loop_exe);
    c.args(["run", "--namespace", ns, "--scene"])
        .arg(&config.scene)
        .args(["--operator", &config.operator])
        .args(["--priority", &config.priority.to_string()])
        .args(["--voxel-mm", &config.voxel_mm.to_string()])
        .arg("--summary-json")
        .arg(config.dir.join("haptic-loop.json"));
    c
}

/// The loop-side bridge: listens on QUIC as the lab's `loop`, lets `planner` in.
fn bridge_command(config: &SoakConfig, ns: &str, port: u16) -> Command {
    let mut c = Command::new(&config.bridge_exe);
    c.args(["--side", "loop", "--namespace", ns])
        .args(["--listen", &format!("quic/127.0.0.1:{port}")])
        .arg("--tls-ca")
        .arg(cert(config, "ca.pem"))
        .arg("--tls-cert")
        .arg(cert(config, "loop.pem"))
        .arg("--tls-key")
        .arg(cert(config, "loop.key"))
        .args(["--allow-peer", "planner"]);
    c
}

/// The remote planner with host B's side of the bridge in its process (start it in host
/// B's folder).
fn remote_command(config: &SoakConfig, ns: &str, port: u16, bound: bool) -> Command {
    let mut c = Command::new(&config.planner_exe);
    c.args(["serve", "--namespace", ns, "--scene"])
        .arg(&config.scene)
        .args(["--seed", "1000", "--json"])
        .arg(config.dir.join("remote-planner.json"))
        .args(["--bridge-connect", &format!("quic/127.0.0.1:{port}")])
        .args([
            "--bridge-connect-timeout-s",
            "60",
            "--bridge-allow-peer",
            "loop",
        ])
        .arg("--bridge-tls-ca")
        .arg(cert(config, "ca.pem"))
        .arg("--bridge-tls-cert")
        .arg(cert(config, "planner.pem"))
        .arg("--bridge-tls-key")
        .arg(cert(config, "planner.key"));
    if bound {
        c.args(["--max-memory-mb", &config.remote_max_memory_mb.to_string()]);
    }
    c
}

/// Incarnation `n` of the local planner (seed `n`).
fn local_command(config: &SoakConfig, ns: &str, n: usize) -> Command {
    let mut c = Command::new(&config.planner_exe);
    c.args(["serve", "--namespace", ns, "--scene"])
        .arg(&config.scene)
        .args(["--seed", &n.to_string(), "--json"])
        .arg(config.dir.join(format!("local-planner-{n}.json")));
    c
}
