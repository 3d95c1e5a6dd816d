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
