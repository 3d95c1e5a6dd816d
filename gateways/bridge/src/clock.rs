//! Time across hosts.
//!
//! Every stamp on the wire is `CLOCK_MONOTONIC` of the host that wrote it: two hosts'
//! clocks differ by an unknown offset (each counts from its own boot) and drift apart by
//! their crystals' tolerance. A stamp from another host is therefore never compared with
//! ours. Instead the sending bridge puts its own clock's reading in each frame
//! (`sent_ns`), so the receiver knows the sample's age at sending (`sent_ns − stamp`, both
//! on the sender's clock), and the receiving bridge re-stamps it on arrival:
//!
//! `local stamp = arrival (our clock) − age at sending − one-way delay`,
//!
//! with the one-way delay estimated as half the smallest round trip of the bridges'
//! probes over the last [`RTT_WINDOW`] probes (a queued probe only ever lengthens a round
//! trip, so the smallest is the least disturbed). An offset cancels exactly; a drift of
//! d ppm errs by d·10⁻⁶ × the age, nanoseconds for the milliseconds a sample is old. What
//! the local processes then see (the guidance time-to-live and fade, the planner's
//! staleness, latencies) is in local time. The error left is the path's asymmetry, at
//! most the one-way delay itself.
//!
//! Arithmetic wraps: a host booted a minute ago has stamps far below ours, and a
//! simulated clock an hour behind a machine up for less than an hour would go negative.

use std::collections::{HashMap, VecDeque};

/// Probes kept per peer for its round-trip minimum (at the default 10 Hz: 3.2 s).
pub const RTT_WINDOW: usize = 32;

/// This host's clock as the bridge presents it on the wire: `CLOCK_MONOTONIC`, or, to test
/// what another host's clock does, that plus an offset and a drift.
#[derive(Debug, Clone, Copy)]
pub struct HostClock {
    offset_ns: i64,
    drift: f64,
    origin_ns: u64,
}

impl HostClock {
    /// The real clock.
    pub fn real() -> Self {
        Self::simulated(0.0, 0.0)
    }

    /// A clock `offset_s` ahead of ours (negative: behind), running `drift_ppm` parts per
    /// million fast (negative: slow) from now.
    pub fn simulated(offset_s: f64, drift_ppm: f64) -> Self {
        Self {
            offset_ns: (offset_s * 1e9) as i64,
            drift: drift_ppm * 1e-6,
            origin_ns: ipc_types::monotonic_ns(),
        }
    }

    /// The presented clock's reading at local `CLOCK_MONOTONIC` time `local_ns`.
    pub fn at(&self, local_ns: u64) -> u64 {
        let since = local_ns.wrapping_sub(self.origin_ns) as i64;
        let drift_ns = (since as f64 * self.drift).round() as i64;
        local_ns
            .wrapping_add(self.offset_ns as u64)
            .wrapping_add(drift_ns as u64)
    }

    /// Its reading now.
    pub fn now(&self) -> u64 {
        self.at(ipc_types::monotonic_ns())
    }
}

/// A remote stamp in local time: `arrival_ns` (local) minus the age the sample had when
/// sent (`sent_ns − stamp_ns`, both remote) minus the one-way delay. The age is signed: a
/// stamp after `sent_ns` (the sender's clock ran back, or a bad sample) comes out after
/// arrival, and the reader's own future-stamp check applies.
pub fn to_local(stamp_ns: u64, sent_ns: u64, arrival_ns: u64, one_way_ns: u64) -> u64 {
    let age_at_send = sent_ns.wrapping_sub(stamp_ns) as i64;
    arrival_ns
        .wrapping_sub(age_at_send as u64)
        .wrapping_sub(one_way_ns)
}

/// The age a sample had when it was sent, ns (negative when stamped after sending).
pub fn age_at_send_ns(stamp_ns: u64, sent_ns: u64) -> i64 {
    sent_ns.wrapping_sub(stamp_ns) as i64
}

/// How recently a peer bridge must have answered this bridge's probes for its samples to be
/// handed on, ns: 20 probes at the default 10 Hz, so that a burst of lost probes on a busy
/// link does not cut a live peer off, while a peer that stopped answering (or never did)
/// is not listened to.
pub const ANSWERED_WITHIN_NS: u64 = 2_000_000_000;

/// Round trips to each peer bridge, by the peer's id, and when each last answered.
#[derive(Debug, Default)]
pub struct PeerDelays {
    peers: HashMap<u64, VecDeque<u64>>,
    answered_ns: HashMap<u64, u64>,
}

impl PeerDelays {
    /// Records one round trip to `peer`, ns, whose answer arrived at `at_ns` (local
    /// monotonic clock).
    pub fn record(&mut self, peer: u64, rtt_ns: u64, at_ns: u64) {
        let w = self.peers.entry(peer).or_default();
        if w.len() == RTT_WINDOW {
            w.pop_front();
        }
        w.push_back(rtt_ns);
        let last = self.answered_ns.entry(peer).or_default();
        *last = (*last).max(at_ns);
    }

    /// Whether `peer` answered a probe within [`ANSWERED_WITHIN_NS`] before `now_ns` (local
    /// monotonic clock). A liveness check, not authentication: a frame's sender id is
    /// whatever the sender says, and only a peer that answers probes under it is heard.
    pub fn answered_recently(&self, peer: u64, now_ns: u64) -> bool {
        self.answered_ns
            .get(&peer)
            .is_some_and(|&t| now_ns.saturating_sub(t) <= ANSWERED_WITHIN_NS)
    }

    /// Smallest recent round trip to `peer`, ns; `None` before the first probe returned.
    pub fn min_rtt_ns(&self, peer: u64) -> Option<u64> {
        self.peers.get(&peer).and_then(|w| w.iter().copied().min())
    }

    /// The one-way delay from `peer`: half its smallest recent round trip; 0 until a probe
    /// returned (then re-stamping trusts the sample's age alone: the first few samples
    /// look younger by the network delay).
    pub fn one_way_ns(&self, peer: u64) -> u64 {
        self.min_rtt_ns(peer).map_or(0, |r| r / 2)
    }

    /// Smallest recent round trip to any peer, ns.
    pub fn min_rtt_overall_ns(&self) -> Option<u64> {
        self.peers.values().flat_map(|w| w.iter().copied()).min()
    }

    /// Peers heard from.
    pub fn peers(&self) -> usize {
        self.peers.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOUR_NS: u64 = 3_600_000_000_000;

    /// A sample stamped on a host whose clock is an hour ahead or behind (or wrapped below
    /// zero), 3 ms old when sent, with 0.5 ms on the way: 3.5 ms old in local time.
    #[test]
    fn an_offset_clock_cancels_out() {
        let local_now = 10 * HOUR_NS;
        for remote_offset in [HOUR_NS as i64, -(HOUR_NS as i64), -(20 * HOUR_NS as i64)] {
            let remote = |local: u64| local.wrapping_add(remote_offset as u64);
            let sent = remote(local_now - 500_000);
            let stamp = remote(local_now - 3_500_000);
            let local = to_local(stamp, sent, local_now, 500_000);
            // Exactly the true stamp in local time: the network delay was as estimated.
            assert_eq!(local, local_now - 3_500_000, "offset {remote_offset}");
            assert_eq!(age_at_send_ns(stamp, sent), 3_000_000);
        }
    }

    #[test]
    fn a_simulated_clock_runs_offset_and_drifts() {
        let c = HostClock::simulated(-3600.0, 100.0);
        let t0 = c.origin_ns;
        // An hour behind, wrapping below zero on a machine up for less than an hour.
        assert_eq!(c.at(t0), t0.wrapping_sub(HOUR_NS));
        // 100 ppm fast: 10 s later it reads 1 ms more than ten seconds on.
        let later = c.at(t0 + 10_000_000_000).wrapping_sub(c.at(t0));
        assert_eq!(later, 10_001_000_000);
    }

    #[test]
    fn the_one_way_delay_is_half_the_smallest_recent_round_trip() {
        let mut d = PeerDelays::default();
        assert_eq!(d.one_way_ns(1), 0);
        for rtt in [900, 400, 2_000] {
            d.record(1, rtt, 0);
        }
        assert_eq!(d.one_way_ns(1), 200);
        // The small one falls out of the window.
        for _ in 0..RTT_WINDOW {
            d.record(1, 1_000, 0);
        }
        assert_eq!(d.one_way_ns(1), 500);
        assert_eq!(d.one_way_ns(2), 0);
        assert_eq!(d.peers(), 1);
    }

    #[test]
    fn a_peer_is_heard_while_it_answers_probes() {
        let mut d = PeerDelays::default();
        let t = 50 * ANSWERED_WITHIN_NS;
        assert!(!d.answered_recently(7, t), "never answered");
        d.record(7, 1_000, t);
        assert!(d.answered_recently(7, t));
        assert!(d.answered_recently(7, t + ANSWERED_WITHIN_NS));
        assert!(
            !d.answered_recently(7, t + ANSWERED_WITHIN_NS + 1),
            "fell silent"
        );
        assert!(!d.answered_recently(8, t), "another id");
        // An answer that arrives late (recorded out of order) does not move it back.
        d.record(7, 1_000, t - 10);
        assert!(d.answered_recently(7, t + ANSWERED_WITHIN_NS));
    }
}
