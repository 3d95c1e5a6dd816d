//! What the latency harnesses across processes share (`bridge-latency`, `ros2-latency`):
//! a loopback Zenoh peer, the executable under test beside this one, and the CPU wake-up
//! latency request that keeps both paths' wake-ups alike.

use anyhow::{Context, bail};
use std::path::{Path, PathBuf};
use zenoh::Wait;

/// A Zenoh peer on loopback TCP: listening on `listen`, connecting to `connect` (ports), no
/// multicast scouting, so rounds never find each other's peers.
pub fn zenoh_session(listen: Option<u16>, connect: Option<u16>) -> anyhow::Result<zenoh::Session> {
    let mut c = zenoh::Config::default();
    let list = |p: Option<u16>| p.map_or("[]".to_owned(), |p| format!("[\"tcp/127.0.0.1:{p}\"]"));
    for (k, v) in [
        ("mode", "\"peer\"".to_owned()),
        ("scouting/multicast/enabled", "false".to_owned()),
        ("listen/endpoints", list(listen)),
        ("connect/endpoints", list(connect)),
    ] {
        c.insert_json5(k, &v)
            .map_err(|e| anyhow::anyhow!("{k}: {e}"))?;
    }
    zenoh::open(c)
        .wait()
        .map_err(|e| anyhow::anyhow!("zenoh: {e}"))
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
