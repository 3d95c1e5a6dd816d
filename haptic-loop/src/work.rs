//! What one tick does, counted where it is done: the kinds of work whose amount varies from
//! tick to tick (the contact search's) and the fixed stages, so that a test can hold every
//! tick to its caps by counting, not timing, and a bench can list what a slow tick did.
//!
//! Counting is a few integer additions a tick, on the RT thread, with no allocation.

use serde::Serialize;

/// The contact stage's work in one step (every level of detail it touched).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct ContactWork {
    /// Clearance checks: one voxmap clearance query each, for the whole object, a group of
    /// clusters or a cluster whose motion budget was used up.
    pub checks: u32,
    /// Motion budgets compared without a check: groups and clusters a near pass visited,
    /// and the points of the near clusters the search listed its candidates from. About a
    /// nanosecond each.
    pub compares: u32,
    /// Points looked up in the voxmap and passed through the force pass, in whole chunks of
    /// eight lanes (the padding of a search's last chunk costs as much as a point).
    pub look_ups: u32,
    /// Levels of detail searched: one, two while a change of level is blended.
    pub searches: u32,
    /// Near passes begun (a level's groups and clusters visited), whole or capped.
    pub near_passes: u32,
    /// Implicit Euler solves of the proxy and its coupling (a 6×6 Cholesky each).
    pub solves: u32,
}

impl ContactWork {
    /// The larger of each count of these and `other`'s.
    pub fn most_of_each(&self, other: &Self) -> Self {
        Self {
            checks: self.checks.max(other.checks),
            compares: self.compares.max(other.compares),
            look_ups: self.look_ups.max(other.look_ups),
            searches: self.searches.max(other.searches),
            near_passes: self.near_passes.max(other.near_passes),
            solves: self.solves.max(other.solves),
        }
    }
}

/// One tick's work.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct TickWork {
    /// The contact stage's (zero without contact rendering).
    pub contact: ContactWork,
    /// Device reads.
    pub device_reads: u32,
    /// Guidance samples taken from the source and rendered (fade, bounds, rate limit).
    pub guidance_renders: u32,
    /// Device writes.
    pub device_writes: u32,
    /// States published.
    pub publishes: u32,
}

impl TickWork {
    /// The larger of each count of these and `other`'s: over a run, each kind's own worst
    /// tick.
    pub fn most_of_each(&self, other: &Self) -> Self {
        Self {
            contact: self.contact.most_of_each(&other.contact),
            device_reads: self.device_reads.max(other.device_reads),
            guidance_renders: self.guidance_renders.max(other.guidance_renders),
            device_writes: self.device_writes.max(other.device_writes),
            publishes: self.publishes.max(other.publishes),
        }
    }
}

/// What remains of a tick's caps on the contact search's work while it runs: each near
/// pass, scan and look-up draws on it, and stops (leaving the rest for later ticks) when
/// its kind is used up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Allowance {
    /// Clearance checks.
    pub checks: u32,
    /// Compares.
    pub compares: u32,
    /// Look-up lanes.
    pub look_ups: u32,
}

impl Allowance {
    /// No limit (diagnostics and tests of the search alone).
    pub fn uncapped() -> Self {
        Self {
            checks: u32::MAX,
            compares: u32::MAX,
            look_ups: u32::MAX,
        }
    }

    /// A whole step's allowance under the contact stage's `caps`.
    pub fn of(caps: &ContactWork) -> Self {
        Self {
            checks: caps.checks,
            compares: caps.compares,
            look_ups: caps.look_ups,
        }
    }
}

/// The most work of each kind one tick may do (see ARCHITECTURE.md, "The bounded tick").
/// The contact search keeps to its caps by construction (it stops and leaves the rest to
/// later ticks, holding the proxy back meanwhile); the other stages run once a tick. Tests
/// hold every tick's counted work ([`TickWork`]) to these.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct WorkCaps {
    /// The contact stage's.
    pub contact: ContactWork,
    /// Device reads.
    pub device_reads: u32,
    /// Guidance renders.
    pub guidance_renders: u32,
    /// Device writes.
    pub device_writes: u32,
    /// States published.
    pub publishes: u32,
}

impl WorkCaps {
    /// A tick without contact rendering.
    pub const WITHOUT_CONTACT: Self = Self {
        contact: ContactWork {
            checks: 0,
            compares: 0,
            look_ups: 0,
            searches: 0,
            near_passes: 0,
            solves: 0,
        },
        device_reads: 1,
        guidance_renders: 1,
        device_writes: 1,
        publishes: 1,
    };

    /// The first kind of work in `work` over its cap, as `(kind, done, cap)`; `None` when
    /// every count is within its cap.
    pub fn excess(&self, work: &TickWork) -> Option<(&'static str, u32, u32)> {
        let (c, w) = (&self.contact, &work.contact);
        [
            ("clearance checks", w.checks, c.checks),
            ("compares", w.compares, c.compares),
            ("look-ups", w.look_ups, c.look_ups),
            ("searches", w.searches, c.searches),
            ("near passes", w.near_passes, c.near_passes),
            ("solves", w.solves, c.solves),
            ("device reads", work.device_reads, self.device_reads),
            (
                "guidance renders",
                work.guidance_renders,
                self.guidance_renders,
            ),
            ("device writes", work.device_writes, self.device_writes),
            ("publishes", work.publishes, self.publishes),
        ]
        .into_iter()
        .find(|(_, done, cap)| done > cap)
    }
}
