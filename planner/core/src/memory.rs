//! The planner's memory bound: when to shed what grows, and how much.
//!
//! A planner's trees, their k-d indexes, the operator's travelled path and the
//! touch-retracted configurations grow for as long as it has not solved (about 170 bytes a
//! node). A process that must run all day bounds its heap: [`MemoryGuard`] reads the
//! process's live heap (the program installs a counting global allocator and passes its
//! reading as [`MemoryBound::live_bytes`]; the core itself never reads it, so planning stays
//! deterministic for a seed and an input sequence when no bound is reached), and above
//! [`SHED_AT`] of the bound it asks the planner to shed (`Planner::shed`,
//! `Portfolio::shed`) the share of its nodes that brings the heap back to [`SHED_TO`].
//!
//! Why these levels: the arenas grow by a quarter at a time (`tree::push_gently`), and
//! one tree's arena and index are at most about half the heap, so between two checks the
//! heap grows by at most an eighth of itself; shedding at three quarters keeps the peak
//! under the bound. Shedding to 55 % leaves room for a fifth of the bound before the next
//! shed, so sheds (each O(nodes)) stay rare.
//!
//! What is worth least goes first (see `Planner::shed`): local trees that have not grown
//! for a while, then leaves that uniform sampling never chose as a nearest node (the
//! interior of the explored region: a leaf's Voronoi cell is small when nothing lands
//! nearer to it than to its neighbours), oldest first. Never the roots, the newest nodes
//! (the operator's recent configurations among them) or a found path.

use serde::Serialize;

/// Shed when the live heap passes this share of the bound.
pub const SHED_AT: f64 = 0.75;

/// Shed down to this share of the bound.
pub const SHED_TO: f64 = 0.55;

/// The heap at start (scene, collision structures, the program's own) may take at most
/// this share of the bound: the rest is for the trees.
pub const BASELINE_MAX: f64 = 0.5;

/// A memory bound and how to read the heap it bounds.
#[derive(Clone, Copy, Debug)]
pub struct MemoryBound {
    /// The bound on the live heap, bytes.
    pub bound_bytes: usize,
    /// The process's live heap now, bytes (a counting global allocator's reading).
    pub live_bytes: fn() -> usize,
    /// The most the process's heap ever held at once, bytes (the same allocator's).
    pub peak_bytes: fn() -> usize,
}

/// What a bounded run's heap did; in the JSON reports as `memory`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct MemoryReport {
    /// The bound, bytes.
    pub bound_bytes: u64,
    /// The heap when the bound was armed, bytes.
    pub baseline_bytes: u64,
    /// The most the heap held at once over the whole run, bytes (start-up included).
    pub peak_bytes: u64,
    /// The heap at the end, bytes.
    pub live_bytes: u64,
    /// What the sheds dropped.
    pub dropped: Shed,
    /// Times planning stopped at the bound with nothing left to shed.
    pub full_stops: u64,
}

/// What sheds dropped (counts, summed over sheds).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Shed {
    /// Times the planner shed.
    pub sheds: u64,
    /// Tree nodes dropped (leaves, and the nodes of dropped local trees).
    pub nodes: u64,
    /// Whole local trees dropped.
    pub local_trees: u64,
    /// Old points of the operator's travelled path dropped.
    pub user_path: u64,
    /// Old touch-retracted configurations dropped.
    pub touched: u64,
}

impl Shed {
    /// Adds `other`'s counts.
    pub fn add(&mut self, other: &Shed) {
        self.sheds += other.sheds;
        self.nodes += other.nodes;
        self.local_trees += other.local_trees;
        self.user_path += other.user_path;
        self.touched += other.touched;
    }

    /// True when nothing was dropped.
    pub fn is_empty(&self) -> bool {
        self.nodes + self.local_trees + self.user_path + self.touched == 0
    }
}

impl std::fmt::Display for Shed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} sheds dropped {} nodes ({} whole local trees), {} points of the operator's path, {} touch-retracted configurations",
            self.sheds, self.nodes, self.local_trees, self.user_path, self.touched
        )
    }
}

/// The bound is smaller than the heap the planner needs before it grows anything.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "the memory bound of {bound_mb} MB is too small: the scene, its collision structures and the program already take {baseline_mb} MB of heap, and the trees need at least as much again (give at least {need_mb} MB)"
)]
pub struct BoundTooSmall {
    /// The bound, MB.
    pub bound_mb: u64,
    /// The heap when the bound was armed, MB.
    pub baseline_mb: u64,
    /// The least bound that would do, MB.
    pub need_mb: u64,
}

/// Watches the heap against a bound and decides when to shed and how much.
#[derive(Clone, Debug)]
pub struct MemoryGuard {
    bound: MemoryBound,
    /// The live heap when armed, bytes: what shedding cannot give back.
    baseline: usize,
    /// The live heap after the last shed that could not reach [`SHED_TO`]: no shed again
    /// until the heap grows past it by a twentieth of the bound.
    stuck_at: Option<usize>,
    dropped: Shed,
    /// The largest live heap seen by a check, bytes.
    peak_seen: usize,
    full_stops: u64,
}

/// What a check decided.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    /// Under the bound's shedding level: plan on.
    Room,
    /// Shed this share of the nodes (in (0, 1)), then plan on.
    Shed(f64),
    /// Nothing more can be shed and the heap is at the bound: stop growing.
    Full,
}

impl MemoryGuard {
    /// Arms `bound` with the live heap now as the baseline; an error when the baseline
    /// takes more than [`BASELINE_MAX`] of the bound.
    pub fn new(bound: MemoryBound) -> Result<Self, BoundTooSmall> {
        let baseline = (bound.live_bytes)();
        if baseline as f64 > BASELINE_MAX * bound.bound_bytes as f64 {
            const MB: usize = 1 << 20;
            return Err(BoundTooSmall {
                bound_mb: (bound.bound_bytes / MB) as u64,
                baseline_mb: baseline.div_ceil(MB) as u64,
                need_mb: (baseline as f64 / BASELINE_MAX / MB as f64).ceil() as u64 + 1,
            });
        }
        Ok(MemoryGuard {
            bound,
            baseline,
            stuck_at: None,
            dropped: Shed::default(),
            peak_seen: baseline,
            full_stops: 0,
        })
    }

    /// The bound, bytes.
    pub fn bound_bytes(&self) -> usize {
        self.bound.bound_bytes
    }

    /// The live heap when armed, bytes.
    pub fn baseline_bytes(&self) -> usize {
        self.baseline
    }

    /// The largest live heap a check saw, bytes.
    pub fn peak_seen_bytes(&self) -> usize {
        self.peak_seen
    }

    /// What the sheds so far dropped.
    pub fn dropped(&self) -> &Shed {
        &self.dropped
    }

    /// Reads the heap and decides ([`Verdict`]). Cheap: one atomic read when there is room.
    pub fn check(&mut self) -> Verdict {
        let live = (self.bound.live_bytes)();
        self.peak_seen = self.peak_seen.max(live);
        let bound = self.bound.bound_bytes as f64;
        if (live as f64) <= SHED_AT * bound {
            self.stuck_at = None;
            return Verdict::Room;
        }
        if let Some(at) = self.stuck_at
            && (live as f64) < at as f64 + 0.05 * bound
        {
            return if (live as f64) < bound * 0.95 {
                Verdict::Room
            } else {
                Verdict::Full
            };
        }
        let sheddable = live.saturating_sub(self.baseline).max(1) as f64;
        let excess = live as f64 - SHED_TO * bound;
        Verdict::Shed((excess / sheddable).clamp(0.05, 0.9))
    }

    /// Checks, sheds through `shed` when asked to, and records what it dropped; false when
    /// the planner must stop growing ([`Verdict::Full`]).
    pub fn keep(&mut self, shed: impl FnOnce(f64) -> Shed) -> bool {
        match self.check() {
            Verdict::Room => true,
            Verdict::Shed(fraction) => {
                let s = shed(fraction);
                self.record(&s);
                true
            }
            Verdict::Full => {
                self.full_stops += 1;
                false
            }
        }
    }

    /// What the run's heap did.
    pub fn report(&self) -> MemoryReport {
        MemoryReport {
            bound_bytes: self.bound.bound_bytes as u64,
            baseline_bytes: self.baseline as u64,
            peak_bytes: (self.bound.peak_bytes)().max(self.peak_seen) as u64,
            live_bytes: (self.bound.live_bytes)() as u64,
            dropped: self.dropped,
            full_stops: self.full_stops,
        }
    }

    /// Records what a shed the last [`Verdict::Shed`] asked for dropped.
    pub fn record(&mut self, shed: &Shed) {
        let mut s = *shed;
        s.sheds = 1;
        self.dropped.add(&s);
        let live = (self.bound.live_bytes)();
        if (live as f64) > SHED_AT * self.bound.bound_bytes as f64 {
            self.stuck_at = Some(live);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    static LIVE: AtomicUsize = AtomicUsize::new(0);
    fn live() -> usize {
        LIVE.load(Ordering::Relaxed)
    }

    #[test]
    fn the_guard_sheds_above_three_quarters_down_to_the_level_and_stops_when_stuck() {
        const MB: usize = 1 << 20;
        LIVE.store(20 * MB, Ordering::Relaxed);
        let bound = MemoryBound {
            bound_bytes: 100 * MB,
            live_bytes: live,
            peak_bytes: live,
        };
        let mut g = MemoryGuard::new(bound).expect("room");
        assert_eq!(g.baseline_bytes(), 20 * MB);
        LIVE.store(75 * MB, Ordering::Relaxed);
        assert_eq!(g.check(), Verdict::Room);
        LIVE.store(80 * MB, Ordering::Relaxed);
        // 25 MB over the 55 MB level, of 60 MB above the baseline.
        let Verdict::Shed(f) = g.check() else {
            panic!("should shed")
        };
        assert!((f - 25.0 / 60.0).abs() < 1e-9, "{f}");
        // A shed that freed nothing: no new shed until the heap grows by 5 MB...
        g.record(&Shed::default());
        LIVE.store(84 * MB, Ordering::Relaxed);
        assert_eq!(g.check(), Verdict::Room);
        LIVE.store(86 * MB, Ordering::Relaxed);
        assert!(matches!(g.check(), Verdict::Shed(_)));
        LIVE.store(93 * MB, Ordering::Relaxed);
        g.record(&Shed {
            nodes: 3,
            ..Shed::default()
        });
        // ... and near the bound with nothing more to shed, stop growing.
        LIVE.store(96 * MB, Ordering::Relaxed);
        assert_eq!(g.check(), Verdict::Full);
        assert_eq!(g.dropped().sheds, 2);
        assert_eq!(g.dropped().nodes, 3);
        assert_eq!(g.peak_seen_bytes(), 96 * MB);
    }

    #[test]
    fn a_bound_under_twice_the_baseline_is_refused_with_what_would_do() {
        const MB: usize = 1 << 20;
        static BIG: AtomicUsize = AtomicUsize::new(30 * MB);
        let e = MemoryGuard::new(MemoryBound {
            bound_bytes: 40 * MB,
            live_bytes: || BIG.load(Ordering::Relaxed),
            peak_bytes: || BIG.load(Ordering::Relaxed),
        })
        .expect_err("too small");
        assert_eq!((e.bound_mb, e.baseline_mb, e.need_mb), (40, 30, 61));
        assert!(e.to_string().contains("give at least 61 MB"), "{e}");
    }
}
