//! Samples the gateways refuse, counted by kind and logged at most once a second per kind,
//! so a flood of bad samples cannot flood the log. Shared by the device gateway's poses and
//! serve's guidance; Zenoh's callback threads count through `&self`.

use std::collections::BTreeMap;
use std::marker::PhantomData;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Shortest gap between two log lines of one kind, ns.
const LOG_EVERY_NS: u64 = 1_000_000_000;

/// Why a sample was refused, as one of a fixed set of kinds.
pub trait Rejected: std::fmt::Display {
    /// What was refused, for the log ("pose sample").
    const WHAT: &'static str;
    /// Every kind, in the order reported.
    const KINDS: &'static [&'static str];
    /// This rejection's kind, one of [`Self::KINDS`].
    fn kind(&self) -> &'static str;
}

/// The count of each kind of `R`, and when each was last logged.
#[derive(Debug)]
pub struct Rejections<R> {
    counts: Box<[AtomicU64]>,
    /// When each kind was last logged, ns after `start` plus 1 (0: never).
    logged: Box<[AtomicU64]>,
    start: Instant,
    kind: PhantomData<fn(&R)>,
}

impl<R: Rejected> Default for Rejections<R> {
    fn default() -> Self {
        let zeros = || R::KINDS.iter().map(|_| AtomicU64::new(0)).collect();
        Rejections {
            counts: zeros(),
            logged: zeros(),
            start: Instant::now(),
            kind: PhantomData,
        }
    }
}

impl<R: Rejected> Rejections<R> {
    /// Counts `rejection` of a sample on `key`, and logs it unless its kind was logged
    /// within the last second.
    pub fn count(&self, rejection: &R, key: &str) {
        let kind = rejection.kind();
        let i = R::KINDS.iter().position(|k| *k == kind).unwrap_or(0);
        self.counts[i].fetch_add(1, Ordering::Relaxed);
        if self.due(i, self.start.elapsed().as_nanos() as u64) {
            tracing::warn!("rejected a {} ({kind}) on {key}: {rejection}", R::WHAT);
        }
    }

    /// Whether kind `i` may be logged at `now_ns` (after `start`); if so, claims it, so of
    /// two threads only one logs.
    fn due(&self, i: usize, now_ns: u64) -> bool {
        let last = self.logged[i].load(Ordering::Relaxed);
        let due = last == 0 || now_ns + 1 >= last + LOG_EVERY_NS;
        due && self.logged[i]
            .compare_exchange(last, now_ns + 1, Ordering::Relaxed, Ordering::Relaxed)
            .is_ok()
    }

    /// Each kind with its count.
    pub fn counts(&self) -> BTreeMap<&'static str, u64> {
        R::KINDS
            .iter()
            .zip(&self.counts)
            .map(|(k, c)| (*k, c.load(Ordering::Relaxed)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug)]
    enum Bad {
        Short,
        Late,
    }

    impl std::fmt::Display for Bad {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str(self.kind())
        }
    }

    impl Rejected for Bad {
        const WHAT: &'static str = "test sample";
        const KINDS: &'static [&'static str] = &["short", "late"];
        fn kind(&self) -> &'static str {
            match self {
                Bad::Short => "short",
                Bad::Late => "late",
            }
        }
    }

    #[test]
    fn each_kind_is_counted() {
        let r = Rejections::<Bad>::default();
        for e in [Bad::Late, Bad::Short, Bad::Late] {
            r.count(&e, "key");
        }
        assert_eq!(
            r.counts().into_iter().collect::<Vec<_>>(),
            [("late", 2), ("short", 1)]
        );
    }

    #[test]
    fn each_kind_is_logged_at_most_once_a_second() {
        let r = Rejections::<Bad>::default();
        assert!(r.due(0, 5));
        assert!(!r.due(0, 6), "the same kind again at once");
        assert!(r.due(1, 7), "another kind has its own second");
        assert!(!r.due(0, 5 + LOG_EVERY_NS - 1));
        assert!(r.due(0, 5 + LOG_EVERY_NS));
        assert!(!r.due(0, 5 + LOG_EVERY_NS + 1));
    }
}
