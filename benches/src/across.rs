//! What the latency harnesses across processes share (`bridge-latency`, `ros2-latency`):
//! a loopback Zenoh peer (plain TCP or mutual TLS), a lab's certificates made by the
//! product's `hrrtc-bridge certs`, the product processes under test with their output kept,
//! the executable under test beside this one, and the CPU wake-up latency request that
//! keeps both paths' wake-ups alike.

use anyhow::{Context, bail};
use hrrtc_bridge::TlsFiles;
use ipc_types::latency::Percentiles;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use zenoh::Wait;

/// A Zenoh peer on loopback TCP: listening on `listen`, connecting to `connect` (ports), no
/// multicast scouting, so rounds never find each other's peers.
pub fn zenoh_session(listen: Option<u16>, connect: Option<u16>) -> anyhow::Result<zenoh::Session> {
    session(listen, connect, None)
}

/// The protocol of the harnesses' mutually authenticated links: `quic` (default) or `tls`
/// (`--secure-link`), set once at start.
static SECURE_LINK: std::sync::OnceLock<&'static str> = std::sync::OnceLock::new();

/// Sets the secure links' protocol (`quic` or `tls`) for this run.
pub fn set_secure_link(protocol: &str) -> anyhow::Result<()> {
    let p = match protocol {
        "quic" => "quic",
        "tls" => "tls",
        other => bail!("--secure-link {other}: expected quic or tls"),
    };
    let _ = SECURE_LINK.set(p);
    Ok(())
}

/// The secure links' protocol: `quic` unless [`set_secure_link`] said otherwise.
pub fn secure_link() -> &'static str {
    SECURE_LINK.get().copied().unwrap_or("quic")
}

/// As [`zenoh_session`], over mutual TLS (`quic/` or `tls/127.0.0.1:PORT`, [`secure_link`]) with `tls`: the CA checks
/// the other side, this side presents its certificate both when listening and connecting,
/// client certificates are required, and the name is checked on connecting (the product's
/// settings, see `zenoh_session::build`). No access control: the bare baseline.
pub fn zenoh_session_tls(
    listen: Option<u16>,
    connect: Option<u16>,
    tls: &TlsFiles,
) -> anyhow::Result<zenoh::Session> {
    session(listen, connect, Some(tls))
}

fn session(
    listen: Option<u16>,
    connect: Option<u16>,
    tls: Option<&TlsFiles>,
) -> anyhow::Result<zenoh::Session> {
    let proto = if tls.is_some() { secure_link() } else { "tcp" };
    let list =
        |p: Option<u16>| p.map_or("[]".to_owned(), |p| format!("[\"{proto}/127.0.0.1:{p}\"]"));
    let mut settings = vec![
        ("mode", "\"peer\"".to_owned()),
        ("scouting/multicast/enabled", "false".to_owned()),
        ("listen/endpoints", list(listen)),
        ("connect/endpoints", list(connect)),
    ];
    if let Some(t) = tls {
        let path = |p: &Path| serde_json::to_string(&p.to_string_lossy()).unwrap_or_default();
        let (ca, cert, key) = (path(&t.ca), path(&t.cert), path(&t.key));
        settings.extend([
            ("transport/link/tls/root_ca_certificate", ca),
            ("transport/link/tls/listen_certificate", cert.clone()),
            ("transport/link/tls/listen_private_key", key.clone()),
            ("transport/link/tls/connect_certificate", cert),
            ("transport/link/tls/connect_private_key", key),
            ("transport/link/tls/enable_mtls", "true".to_owned()),
            (
                "transport/link/tls/verify_name_on_connect",
                "true".to_owned(),
            ),
        ]);
    }
    let mut c = zenoh::Config::default();
    for (k, v) in settings {
        c.insert_json5(k, &v)
            .map_err(|e| anyhow::anyhow!("{k}: {e}"))?;
    }
    zenoh::open(c)
        .wait()
        .map_err(|e| anyhow::anyhow!("zenoh ({proto}): {e}"))
}

/// A run's scratch folder in the temporary directory (removed when dropped): a lab's
/// certificates made by `hrrtc-bridge certs`, and the output of the processes under test.
pub struct Lab {
    dir: PathBuf,
}

impl Lab {
    /// Makes the folder and, with the `hrrtc-bridge` executable `bridge`, the lab's CA and a
    /// certificate per name (`NAME` or `NAME=HOST,...`, as `hrrtc-bridge certs --name`).
    pub fn make(bridge: &Path, tag: &str, names: &[&str]) -> anyhow::Result<Self> {
        let dir = std::env::temp_dir().join(format!("hrrtc-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).with_context(|| format!("making {}", dir.display()))?;
        let lab = Lab { dir };
        let mut cmd = Command::new(bridge);
        cmd.args(["certs", "--out"]).arg(lab.dir.join("certs"));
        for n in names {
            cmd.args(["--name", n]);
        }
        let out = cmd
            .output()
            .with_context(|| format!("running {} certs", bridge.display()))?;
        if !out.status.success() {
            bail!(
                "{} certs: {}",
                bridge.display(),
                String::from_utf8_lossy(&out.stderr).trim()
            );
        }
        Ok(lab)
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The CA, certificate and key of the lab's host `name`.
    pub fn tls(&self, name: &str) -> TlsFiles {
        lab_tls(&self.dir, name)
    }

    /// `--tls-ca`, `--tls-cert` and `--tls-key` for the lab's host `name`.
    pub fn tls_args(&self, name: &str) -> Vec<PathBuf> {
        let t = self.tls(name);
        vec![
            "--tls-ca".into(),
            t.ca,
            "--tls-cert".into(),
            t.cert,
            "--tls-key".into(),
            t.key,
        ]
    }
}

/// The CA, certificate and key of host `name` of the lab in folder `dir` ([`Lab::dir`]; for
/// a child process of the harness).
pub fn lab_tls(dir: &Path, name: &str) -> TlsFiles {
    let certs = dir.join("certs");
    TlsFiles {
        ca: certs.join("ca.pem"),
        cert: certs.join(format!("{name}.pem")),
        key: certs.join(format!("{name}.key")),
    }
}

impl Drop for Lab {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// A process under test (a bridge, a gateway), its standard output and error going to
/// files of a [`Lab`]; stopped with SIGTERM (as Ctrl-C) by [`Product::stop`] or when
/// dropped.
pub struct Product {
    child: Option<Child>,
    name: String,
    stdout: PathBuf,
    stderr: PathBuf,
}

/// What a stopped [`Product`] printed.
#[derive(Debug, Clone)]
pub struct Ended {
    /// Its exit code (`None`: killed by a signal).
    pub code: Option<i32>,
    /// Its standard output.
    pub stdout: String,
    /// Its standard error (its log).
    pub stderr: String,
}

impl Product {
    /// Starts `cmd` as `name` (a file name: its output is `name.out` and `name.err` in
    /// `lab`).
    pub fn start(mut cmd: Command, lab: &Lab, name: &str) -> anyhow::Result<Self> {
        let stdout = lab.dir().join(format!("{name}.out"));
        let stderr = lab.dir().join(format!("{name}.err"));
        let file = |p: &Path| {
            std::fs::File::create(p).with_context(|| format!("creating {}", p.display()))
        };
        let child = cmd
            .stdin(Stdio::null())
            .stdout(file(&stdout)?)
            .stderr(file(&stderr)?)
            .spawn()
            .with_context(|| format!("starting {name} ({cmd:?})"))?;
        Ok(Product {
            child: Some(child),
            name: name.to_owned(),
            stdout,
            stderr,
        })
    }

    /// `Err` with its log when it has already exited.
    pub fn check_running(&mut self) -> anyhow::Result<()> {
        if let Some(c) = &mut self.child
            && let Some(status) = c.try_wait()?
        {
            let err = std::fs::read_to_string(&self.stderr).unwrap_or_default();
            bail!("{} exited early ({status}): {}", self.name, err.trim());
        }
        Ok(())
    }

    /// Stops it (SIGTERM), waits, and reads what it printed; `Err` with its log unless it
    /// exited with 0.
    pub fn stop(mut self) -> anyhow::Result<Ended> {
        let code = self.terminate()?;
        let read = |p: &Path| std::fs::read_to_string(p).unwrap_or_default();
        let ended = Ended {
            code,
            stdout: read(&self.stdout),
            stderr: read(&self.stderr),
        };
        if code != Some(0) {
            bail!("{} ended with {code:?}: {}", self.name, ended.stderr.trim());
        }
        Ok(ended)
    }

    fn terminate(&mut self) -> anyhow::Result<Option<i32>> {
        let Some(mut c) = self.child.take() else {
            return Ok(None);
        };
        if c.try_wait()?.is_none() {
            // SAFETY: kill(2) on our own child, not yet reaped.
            unsafe { libc::kill(c.id() as libc::pid_t, libc::SIGTERM) };
        }
        Ok(c.wait()?.code())
    }
}

impl Drop for Product {
    fn drop(&mut self) {
        let _ = self.terminate();
    }
}

/// `given`, else the executable `name` in this executable's folder; an error saying how to
/// build it (`package`) when it is not there.
pub fn sibling_exe(
    given: Option<&Path>,
    name: &str,
    package: &str,
    option: &str,
) -> anyhow::Result<PathBuf> {
    let exe = match given {
        Some(p) => p.to_path_buf(),
        None => std::env::current_exe()?
            .parent()
            .context("this executable's folder")?
            .join(name),
    };
    if !exe.exists() {
        bail!(
            "{} not found: build it (`cargo build --release -p {package}`) or give {option}",
            exe.display()
        );
    }
    Ok(exe)
}

/// The CPU wake-up latency request (0 µs) held while the harness runs, unless `off`; when
/// it cannot be made, says so and goes on without.
pub fn cpu_latency_request(off: bool) -> Option<haptic_loop::rt::CpuLatencyRequest> {
    if off {
        return None;
    }
    match haptic_loop::rt::CpuLatencyRequest::open(0) {
        Ok(r) => Some(r),
        Err(e) => {
            eprintln!("no CPU wake-up latency request (/dev/cpu_dma_latency: {e})");
            None
        }
    }
}

/// How wide a path's name is in the harnesses' tables.
pub const NAME_WIDTH: usize = 42;

/// A path's name, and how to read its latencies from a round.
pub type PathOf<R> = (&'static str, fn(&R) -> Percentiles);

/// A path over all rounds, µs.
#[derive(Debug, serde::Serialize)]
pub struct PathSummary {
    /// The path's name.
    pub path: &'static str,
    /// Median of the rounds' p50.
    pub median_p50: f64,
    /// Median of the rounds' p99.
    pub median_p99: f64,
    /// The largest p99 of a round.
    pub max_p99: f64,
    /// The largest latency seen in any round.
    pub max: f64,
    /// Samples over all rounds.
    pub count: u64,
}

/// The median of `f` over `rounds` (the upper one of an even count).
pub fn median<R>(rounds: &[R], f: impl Fn(&R) -> f64) -> f64 {
    let mut v: Vec<f64> = rounds.iter().map(f).collect();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Each path's figures over all rounds.
pub fn summarize<R>(rounds: &[R], paths: &[PathOf<R>]) -> Vec<PathSummary> {
    paths
        .iter()
        .map(|(name, get)| {
            let max_of =
                |f: fn(&Percentiles) -> f64| rounds.iter().map(|r| f(&get(r))).fold(0.0, f64::max);
            PathSummary {
                path: name,
                median_p50: median(rounds, |r| get(r).p50),
                median_p99: median(rounds, |r| get(r).p99),
                max_p99: max_of(|p| p.p99),
                max: max_of(|p| p.max),
                count: rounds.iter().map(|r| get(r).count).sum(),
            }
        })
        .collect()
}

/// Prints one round's table: each path's percentiles, max and count, µs.
pub fn print_round_table<R>(round: &R, paths: &[PathOf<R>]) {
    println!(
        "  {:<NAME_WIDTH$} {:>8} {:>8} {:>8} {:>8} {:>7}",
        "µs", "p50", "p99", "p99.9", "max", "count"
    );
    for (name, get) in paths {
        let p = get(round);
        println!(
            "  {name:<NAME_WIDTH$} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>7}",
            p.p50, p.p99, p.p999, p.max, p.count
        );
    }
}

/// Prints the table over all rounds.
pub fn print_summary_table(paths: &[PathSummary], rounds: usize) {
    println!("over {rounds} rounds:");
    println!(
        "  {:<NAME_WIDTH$} {:>10} {:>10} {:>8} {:>8}",
        "µs", "median p50", "median p99", "max p99", "max"
    );
    for p in paths {
        println!(
            "  {:<NAME_WIDTH$} {:>10.1} {:>10.1} {:>8.1} {:>8.1}",
            p.path, p.median_p50, p.median_p99, p.max_p99, p.max
        );
    }
}
