//! What a bridge counts ([`Counters`], per frame kind) and reports ([`BridgeReport`]).

use crate::clock::PeerDelays;
use crate::frame::Kind;
use crate::lock;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Counts per frame kind (indexed by `Kind.0`).
#[derive(Debug, Default)]
pub(crate) struct Counters {
    pub(crate) sent: [AtomicU64; 7],
    pub(crate) received: [AtomicU64; 7],
    pub(crate) delivered: [AtomicU64; 7],
    pub(crate) rejected: [AtomicU64; 7],
    pub(crate) dropped: [AtomicU64; 7],
    pub(crate) unverified: [AtomicU64; 7],
}

/// Counts one sample of `kind`.
pub(crate) fn bump(counter: &[AtomicU64; 7], kind: Kind) {
    if let Some(c) = counter.get(kind.0 as usize) {
        c.fetch_add(1, Ordering::Relaxed);
    }
}

/// What one kind of sample did in a bridge.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct KindReport {
    /// Put on Zenoh.
    pub sent: u64,
    /// Arrived from Zenoh.
    pub received: u64,
    /// Handed to local processes.
    pub delivered: u64,
    /// Arrived malformed, oversized or invalid: never handed on.
    pub rejected: u64,
    /// Lost to a full queue or a failed local send (never waited for).
    pub dropped: u64,
    /// Well formed, but from a bridge that has not answered this bridge's probes lately:
    /// never handed on.
    pub unverified: u64,
}

/// What a bridge did, at its end.
#[derive(Debug, Clone, Default)]
pub struct BridgeReport {
    /// `(kind name, counts)` for state, guidance, path, roadmap.
    pub kinds: Vec<(&'static str, KindReport)>,
    /// Peer bridges whose probes came back.
    pub peers: usize,
    /// Smallest round trip to any peer, µs.
    pub min_rtt_us: Option<f64>,
    /// Seconds run.
    pub seconds: f64,
    /// What Zenoh kept out (in this process) since it started.
    pub refused: zenoh_session::Refusals,
}

impl BridgeReport {
    /// The counts of `kind` (`state`, `guidance`, `path`, `roadmap`).
    pub fn kind(&self, kind: &str) -> KindReport {
        self.kinds
            .iter()
            .find(|(k, _)| *k == kind)
            .map_or_else(KindReport::default, |(_, r)| *r)
    }
}

/// The counts so far, and the peers' round trips.
pub(crate) fn report(
    counters: &Counters,
    delays: &Mutex<PeerDelays>,
    started: Instant,
) -> BridgeReport {
    let kinds = [Kind::STATE, Kind::GUIDANCE, Kind::PATH, Kind::ROADMAP]
        .into_iter()
        .map(|k| {
            let i = k.0 as usize;
            let get = |c: &[AtomicU64; 7]| c[i].load(Ordering::Relaxed);
            (
                k.name(),
                KindReport {
                    sent: get(&counters.sent),
                    received: get(&counters.received),
                    delivered: get(&counters.delivered),
                    rejected: get(&counters.rejected),
                    dropped: get(&counters.dropped),
                    unverified: get(&counters.unverified),
                },
            )
        })
        .collect();
    let d = lock(delays);
    let min_rtt_us = d.min_rtt_overall_ns().map(|r| r as f64 / 1e3);
    BridgeReport {
        kinds,
        peers: d.peers(),
        min_rtt_us,
        seconds: started.elapsed().as_secs_f64(),
        refused: zenoh_session::Refusals::now(),
    }
}

/// One log line of the counts so far.
pub(crate) fn log_progress(r: &BridgeReport) {
    let parts: Vec<String> = r
        .kinds
        .iter()
        .filter(|(_, k)| k.sent + k.received > 0)
        .map(|(name, k)| {
            format!(
                "{name}: {} sent, {} received, {} delivered, {} rejected, {} dropped, {} \
                 from unanswered peers",
                k.sent, k.received, k.delivered, k.rejected, k.dropped, k.unverified
            )
        })
        .collect();
    let rtt = r.min_rtt_us.map_or("no peer answered yet".to_owned(), |v| {
        format!("{} peer(s), round trip ≥ {v:.0} µs", r.peers)
    });
    let refused = if r.refused.is_none() {
        String::new()
    } else {
        format!("; kept out: {}", r.refused)
    };
    tracing::info!("{}; {rtt}{refused}", parts.join("; "));
}
