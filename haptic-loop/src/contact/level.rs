//! Which level of detail of the pointshell the contact stage renders each tick: the bounded
//! contact stage's budget (issue 21).
//!
//! The search costs about the same per point looked at, so the tick's contact cost is set by
//! the number of points in clusters near the surface. [`ShellColumns::near_clusters`]
//! counts them at the level in use before any point is looked at; [`LevelChooser`] then
//! keeps to the finest level that fits the budget and changes level without a force step:
//!
//! * A change is a *blend*: for [`Resolution::BLEND_S`] both levels are searched and the
//!   rendered sums move linearly from the old level's to the new one's, so the wrench
//!   changes per tick by at most the difference between the two levels' wrenches divided
//!   by the blend's ticks. Both levels' sums are sums of point springs and dampers with
//!   non-negative weights, so every blend of them is too: passivity is kept.
//! * Coarser when the near points exceed `COARSEN` of the budget, finer when the finer
//!   level's would be at most `REFINE` of it (a half and a quarter; the finer level's near
//!   pass, which only counts, runs only when this level's points are under that share
//!   already, so it stays cheap): a blend (both levels
//!   together, about 1.25 times the finer's cost on a surface) then still fits while the
//!   patch keeps growing, and the factor 2 between the thresholds keeps a contact near one
//!   from switching back and forth. If a blend no longer fits, it ends at the coarser of
//!   its two levels at once.
//! * A level not searched for a while has all its motion budgets used up, and its first
//!   tick would check every cluster and look up every point near the surface (a tick of
//!   150–280 µs on the crossing planes). So a blend starts only once its new level is up to
//!   date: a capped share of that work is done in each tick before it ([`Levels`]).
//! * If the points grow past [`SLAM`] times the budget in one tick (an object slammed flat onto a
//!   face), the stage goes to the level that fits at once: being on time matters more.
//!   Between once and SLAM times the budget it stays, over budget, at the level in use
//!   (searched every tick, so cheaper than a stale one) until the coarser level is up to
//!   date, then goes there at once.
//!   With nothing near, nothing is rendered and the level returns to the finest at once.
//!
//! [`ShellColumns::near_clusters`]: super::near::ShellColumns::near_clusters

use super::lanes::LANES;
use super::pointshell::LEVELS;
use crate::work::ContactWork;

/// How finely the stage renders contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Resolution {
    /// Always level `0` (every point) up to `LEVELS − 1` (the coarsest), whatever it costs.
    Level(u8),
    /// The finest level whose points near the surface fit `points_per_ms` times the tick
    /// period (so a 4 kHz loop gets a quarter of a 1 kHz loop's points), never coarser than
    /// a spacing of `coarsest_spacing_m`: past that the budget is exceeded rather than the
    /// object's shape lost.
    Budget {
        /// Points near the surface the search may look at per millisecond of tick period.
        points_per_ms: f64,
        /// The coarsest point spacing used, m.
        coarsest_spacing_m: f64,
    },
}

impl Resolution {
    /// How long a change of level is blended, s.
    pub const BLEND_S: f64 = 0.02;

    /// The default budget: 3 000 points per millisecond, down to 4 mm spacing. It sets the
    /// tick's caps ([`caps`]), and 3 000 is what keeps their bound within 250 µs at 1 kHz
    /// with the costs measured with the caches emptied before each tick (ARCHITECTURE.md,
    /// "The bounded tick"; docs/benchmarks.md). It was 6 000 at first (about 11 ns per
    /// point looked at, ticks back to back), then 4 000 from the p99.9 of ticks paced as
    /// the loop paces them (`tick-budget --scene crossing-planes --newcomer --paced`:
    /// 123 µs at 6 000, 87 µs at 4 000), before the tick's worst case was bounded.
    pub const DEFAULT: Self = Self::budget(Self::DEFAULT_POINTS_PER_MS);

    /// The default budget's points per millisecond of tick period.
    pub const DEFAULT_POINTS_PER_MS: f64 = 3000.0;

    /// The coarsest spacing a budget goes down to by default, m: a few times the features
    /// the built-in scenes' clearances are made of, and where the torque test still holds.
    pub const COARSEST_SPACING_M: f64 = 0.004;

    /// A budget of `points_per_ms` down to [`Self::COARSEST_SPACING_M`].
    pub const fn budget(points_per_ms: f64) -> Self {
        Self::Budget {
            points_per_ms,
            coarsest_spacing_m: Self::COARSEST_SPACING_M,
        }
    }

    /// Checks the values; the error says which is wrong.
    pub fn validate(&self) -> Result<(), String> {
        match *self {
            Self::Level(l) if usize::from(l) >= LEVELS => Err(format!(
                "resolution level {l} does not exist (levels 0–{})",
                LEVELS - 1
            )),
            Self::Level(_) => Ok(()),
            Self::Budget {
                points_per_ms,
                coarsest_spacing_m,
            } => {
                if !(points_per_ms.is_finite() && points_per_ms >= 1.0) {
                    return Err(format!(
                        "contact point budget must be ≥ 1 point per ms, got {points_per_ms}"
                    ));
                }
                if !(coarsest_spacing_m.is_finite() && coarsest_spacing_m > 0.0) {
                    return Err(format!(
                        "coarsest point spacing must be > 0 m, got {coarsest_spacing_m}"
                    ));
                }
                Ok(())
            }
        }
    }

    /// The coarsest level allowed at point spacing `spacing_m`.
    pub fn coarsest_level(&self, spacing_m: f64) -> usize {
        match *self {
            Self::Level(l) => usize::from(l).min(LEVELS - 1),
            Self::Budget {
                coarsest_spacing_m, ..
            } => (0..LEVELS)
                .rev()
                .find(|&l| spacing_m * f64::from(1u32 << l) <= coarsest_spacing_m * (1.0 + 1e-9))
                .unwrap_or(0),
        }
    }
}

/// What to render this tick: `(1 − alpha)` of level `from`'s sums plus `alpha` of level
/// `to`'s; one level when `from == to`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Plan {
    pub from: usize,
    pub to: usize,
    pub alpha: f64,
}

impl Plan {
    /// Level `level` alone.
    pub fn at(level: usize) -> Self {
        Self {
            from: level,
            to: level,
            alpha: 0.0,
        }
    }
}

/// Coarser when the near points pass this share of the budget.
const COARSEN: f64 = 0.5;
/// Finer when the finer level's near points are at most this share of it.
const REFINE: f64 = 0.25;
/// Clearance checks a level's near pass may make in a tick while it is brought up to date
/// for a blend ([`Levels::near_within`]): about 35 ns each on the crossing planes (a stale
/// level-1 pass, 1 000 checks in 35 µs), so at most about 9 µs a tick.
pub(super) const WARM_CHECKS: u32 = 256;
/// Points whose budgets a level about to be blended in may renew in a tick, as a share of
/// the budget ([`Levels::renew_points`]): a sixteenth, so that renewing fits the look-up
/// cap beside a level in use at up to [`SLAM`] times the budget.
const WARM_SHARE: f64 = 1.0 / 16.0;
/// Ticks of renewing points after which a blend starts even if its level still has more
/// due points than a share: points within reach are due every tick, and a level with more
/// of them than a share will never have fewer.
const WARM_TICKS: u32 = 8;
/// Over this multiple of the budget the level changes at once, up to date or not (an object
/// slammed flat onto a face); under it, a level in use stays while the coarser one is
/// brought up to date. With [`WARM_SHARE`] it sets the look-up cap ([`caps`]).
pub(super) const SLAM: f64 = 1.25;

/// What [`LevelChooser::plan`] asks of the search about level `l`. Each level's near pass
/// runs at most once a tick, whichever asks first.
///
/// A level not searched for a while has every motion budget used up: its first near pass
/// checks every group and the clusters of the near ones, and its first search looks at
/// every point of its near clusters. At the start of a blend that was a tick of 150–280
/// µs (a coarsening blend on the crossing planes, against 10–60 µs for the ticks around
/// it). So the chooser brings the level up to date over the ticks before a blend, within
/// a capped share of each ([`Self::near_within`], [`Self::renew_points`]), and starts the
/// blend once it is.
pub(super) trait Levels {
    /// The points in level `l`'s near clusters: its whole near pass.
    fn near(&mut self, l: usize) -> u32;
    /// The same from a near pass of at most [`WARM_CHECKS`] clearance checks; `None`
    /// while that did not get through the level (the next call goes on from there).
    fn near_within(&mut self, l: usize) -> Option<u32>;
    /// After a whole near pass at `l` this tick: renews the budgets of at most `max` of
    /// the points its search would look at, starting `skip` places into them, and returns
    /// how many were due.
    fn renew_points(&mut self, l: usize, skip: u32, max: u32) -> u32;
}

/// Counts per level alone, every level up to date (tests, and nothing near).
impl<F: FnMut(usize) -> u32> Levels for F {
    fn near(&mut self, l: usize) -> u32 {
        self(l)
    }

    fn near_within(&mut self, l: usize) -> Option<u32> {
        Some(self(l))
    }

    fn renew_points(&mut self, _: usize, _: u32, _: u32) -> u32 {
        0
    }
}

/// The level in use and a blend in progress (see the module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct LevelChooser {
    current: usize,
    /// Target level and ticks of the blend done.
    blend: Option<(usize, u32)>,
    /// A level being brought up to date for a blend, and the ticks of renewing its points
    /// so far.
    warming: Option<(usize, u32)>,
}

impl LevelChooser {
    /// Starts at `level` with no blend.
    pub fn at(level: usize) -> Self {
        Self {
            current: level,
            blend: None,
            warming: None,
        }
    }

    /// Where `resolution` starts: its level, or level 0 for a budget.
    pub fn starting(resolution: &Resolution) -> Self {
        Self::at(match *resolution {
            Resolution::Level(l) => usize::from(l).min(LEVELS - 1),
            Resolution::Budget { .. } => 0,
        })
    }

    /// Whether a change of level is being blended.
    pub fn blending(&self) -> bool {
        self.blend.is_some()
    }

    /// The level rendered (the blend's target while blending).
    pub fn level(&self) -> usize {
        self.blend.map_or(self.current, |(to, _)| to)
    }

    /// The plan for a tick whose near clusters hold `levels.near(l)` points at level `l`
    /// (asked for the level in use, a blend's target, the next finer level when this one
    /// holds few points, and the coarser ones a jump passes), with `budget` points, levels
    /// up to `coarsest`, and blends of `blend_ticks` ticks. A blend starts once its new
    /// level is up to date ([`Levels`]); a jump goes at once to the finest level whose
    /// counted points fit ([`fitting`]).
    pub fn plan(
        &mut self,
        levels: &mut dyn Levels,
        budget: f64,
        coarsest: usize,
        last_resort: usize,
        blend_ticks: u32,
    ) -> Plan {
        if let Some((to, done)) = self.blend {
            if f64::from(levels.near(self.current)) + f64::from(levels.near(to)) > budget {
                // Both no longer fit: settle at the coarser of the two, or coarser still
                // if that alone does not fit either.
                self.blend = None;
                self.current = fitting(levels, self.current.max(to), budget, coarsest, last_resort);
                return Plan::at(self.current);
            }
            let done = done + 1;
            if done >= blend_ticks {
                self.current = to;
                self.blend = None;
                return Plan::at(to);
            }
            self.blend = Some((to, done));
            return Plan {
                from: self.current,
                to,
                alpha: f64::from(done) / f64::from(blend_ticks),
            };
        }
        let c = self.current.min(last_resort.max(coarsest));
        let n = f64::from(levels.near(c));
        if n == 0.0 {
            // Nothing rendered: the finest level costs nothing either.
            self.current = 0;
            self.warming = None;
            return Plan::at(0);
        }
        if n > budget {
            if c < coarsest && n <= SLAM * budget && !self.warmed(levels, c + 1, budget) {
                // A little over budget at a level in use costs less than the first tick
                // at one not searched for a while: stay while the coarser one is brought
                // up to date.
                return Plan::at(c);
            }
            // Over budget now: no time to blend.
            self.warming = None;
            self.current = fitting(levels, c, budget, coarsest, last_resort);
            return Plan::at(self.current);
        }
        self.current = c;
        let to = if c < coarsest && n > COARSEN * budget {
            c + 1
        } else if c > coarsest
            && levels
                .near_within(c - 1)
                .is_some_and(|m| f64::from(m) <= budget)
        {
            // Back from the last resort as soon as the spacing's coarsest fits.
            c - 1
        } else if c > 0
            && n <= REFINE * budget
            && levels
                .near_within(c - 1)
                .is_some_and(|m| f64::from(m) <= REFINE * budget)
        {
            c - 1
        } else {
            self.warming = None;
            return Plan::at(c);
        };
        if !self.warmed(levels, to, budget) {
            return Plan::at(c);
        }
        if blend_ticks <= 1 {
            self.current = to;
            return Plan::at(to);
        }
        self.blend = Some((to, 1));
        Plan {
            from: c,
            to,
            alpha: 1.0 / f64::from(blend_ticks),
        }
    }

    /// Whether level `to` is up to date for a blend into it: its near pass got through,
    /// and its due points fit one [`WARM_SHARE`] of the budget, or have been renewed a share
    /// a tick for [`WARM_TICKS`] ticks. Renews a share of them otherwise.
    fn warmed(&mut self, levels: &mut dyn Levels, to: usize, budget: f64) -> bool {
        let ticks = match self.warming {
            Some((l, ticks)) if l == to => ticks,
            _ => 0,
        };
        self.warming = Some((to, ticks));
        if levels.near_within(to).is_none() {
            return false;
        }
        let share = (WARM_SHARE * budget).max(1.0) as u32;
        let due = levels.renew_points(to, ticks * share, share);
        if due <= share || ticks + 1 >= WARM_TICKS {
            self.warming = None;
            return true;
        }
        self.warming = Some((to, ticks + 1));
        false
    }
}

/// The finest level from `level` up to `coarsest` whose near points fit `budget`, by their
/// counts (each level's near pass; a quarter per level holds on a flat patch, not near
/// edges and corners, where a level can hold half of the finer one's points or more, and
/// a tick rendered at a guess could search twice the budget). If none fits, `coarsest`
/// while its points stay within [`SLAM`] times the budget (what a level in use may hold,
/// see [`caps`]), else `last_resort`: the coarsest level whose points all fit that, past
/// the spacing `coarsest` keeps to, so that a tick's look-ups stay within their cap
/// whatever touches.
fn fitting(
    levels: &mut dyn Levels,
    level: usize,
    budget: f64,
    coarsest: usize,
    last_resort: usize,
) -> usize {
    if let Some(l) = (level..coarsest).find(|&l| f64::from(levels.near(l)) <= budget) {
        return l;
    }
    let c = coarsest.max(level);
    if c >= last_resort || f64::from(levels.near(c)) <= SLAM * budget {
        c
    } else {
        last_resort
    }
}

/// Clearance checks a tick may make, per point of its budget: 251 at 1 kHz (3 000 points,
/// with the object's own check).
const CHECKS_PER_POINT: f64 = 1.0 / 12.0;
/// Compares a tick may make, per point of its budget: 12 000 at 1 kHz.
const COMPARES_PER_POINT: f64 = 4.0;

/// The contact stage's caps for a tick of `budget` points (the point budget times the
/// period; see ARCHITECTURE.md, "The bounded tick") on an object whose coarsest level of
/// detail has `coarsest_points` points:
///
/// * look-ups: a level in use may hold up to [`SLAM`] times the budget while a coarser one
///   is brought up to date, which renews up to [`WARM_SHARE`] of the budget a tick (a blend
///   holds at most the budget in both levels, [`fitting`]'s level at most the budget or,
///   past the spacing's coarsest, SLAM times it), plus the padding of three searches'
///   last chunks; and at least the whole coarsest level with a renewal beside it, so that
///   the last resort always fits (a big part at 4 kHz: the Panda link's 3 500 points at
///   8 mm against 1 007);
/// * clearance checks and compares: a share of the budget, so that they too scale with the
///   period;
/// * two searches (a blend), two near passes a level (a capped one, then the rest), one
///   solve.
pub(super) fn caps(budget: f64, coarsest_points: u32) -> ContactWork {
    let budget = budget.max(1.0);
    let share = (WARM_SHARE * budget).max(1.0) as u32;
    let padding = 3 * LANES as u32;
    ContactWork {
        checks: (budget * CHECKS_PER_POINT).ceil() as u32 + 1,
        compares: (budget * COMPARES_PER_POINT).ceil() as u32,
        look_ups: ((SLAM * budget) as u32).max(coarsest_points) + share + padding,
        searches: 2,
        near_passes: 2 * LEVELS as u32,
        solves: 1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Near points of a flat patch of `n` level-0 points: a quarter per level.
    fn patch(n: u32) -> [u32; LEVELS] {
        std::array::from_fn(|l| n >> (2 * l))
    }

    #[test]
    fn a_growing_patch_coarsens_through_blends_and_stays_within_budget() {
        let mut c = LevelChooser::default();
        let budget = 4000.0;
        let mut previous = Plan::at(0);
        let mut seen_blend = false;
        // A patch growing by 50 points per tick to 40 000 points, then shrinking back.
        let sizes: Vec<u32> = (0..800)
            .map(|i| i * 50)
            .chain((0..800).rev().map(|i| i * 50))
            .collect();
        for &size in &sizes {
            let near = patch(size);
            let p = c.plan(&mut |l| near[l], budget, 3, 3, 20);
            // Never over budget (both levels while blending), except where even the
            // coarsest level does not fit.
            let cost = f64::from(near[p.from])
                + if p.from == p.to {
                    0.0
                } else {
                    f64::from(near[p.to])
                };
            assert!(
                cost <= budget || p.from == 3,
                "size {size}: {p:?} costs {cost}"
            );
            // Levels change only through blends of adjacent levels, alpha rising by a
            // twentieth per tick.
            if p.from != p.to {
                seen_blend = true;
                assert_eq!(p.from.abs_diff(p.to), 1);
                let step = if previous.from == p.from && previous.to == p.to {
                    p.alpha - previous.alpha
                } else {
                    p.alpha
                };
                assert!((step - 0.05).abs() < 1e-12, "{previous:?} → {p:?}");
            } else if previous.from != previous.to {
                assert_eq!(p.from, previous.to, "a blend ends at its target");
                assert!(previous.alpha > 0.94);
            } else {
                assert_eq!(
                    p.from, previous.from,
                    "size {size}: jumped {previous:?} → {p:?}"
                );
            }
            previous = p;
        }
        assert!(seen_blend);
        assert_eq!(c.level(), 0, "back to the finest level");
    }

    #[test]
    fn a_patch_over_budget_at_once_jumps_to_the_level_that_fits() {
        let mut c = LevelChooser::default();
        let p = c.plan(&mut |l| patch(30_000)[l], 4000.0, 3, 3, 20);
        assert_eq!(p, Plan::at(2));
        // The coarsest allowed level caps it.
        let mut c = LevelChooser::default();
        assert_eq!(
            c.plan(&mut |l| patch(1_000_000)[l], 4000.0, 2, 2, 20),
            Plan::at(2)
        );
        // Leaving contact returns to the finest level at once.
        assert_eq!(c.plan(&mut |_| 0, 4000.0, 2, 2, 20), Plan::at(0));
    }

    #[test]
    fn a_jump_keeps_to_the_budget_where_levels_do_not_thin_by_a_quarter() {
        // Near an edge each level holds half of the finer one's points: 30 000, 15 000,
        // 7 500, 3 750. A guess of a quarter per level would render level 2 (7 500 points,
        // nearly twice the budget); the counts say level 3.
        let mut edge = |l: usize| 30_000u32 >> l;
        let mut c = LevelChooser::default();
        assert_eq!(c.plan(&mut edge, 4000.0, 3, 3, 20), Plan::at(3));
        // A blend that no longer fits settles where the points fit.
        let mut c = LevelChooser::at(1);
        let mut small = |l: usize| [800u32, 200, 50, 12][l];
        let p = c.plan(&mut small, 4000.0, 3, 3, 20);
        assert_eq!((p.from, p.to), (1, 0), "refining starts a blend");
        let mut grown = |l: usize| [20_000u32, 10_000, 5_000, 2_500][l];
        assert_eq!(c.plan(&mut grown, 4000.0, 3, 3, 20), Plan::at(3));
        // Nothing fits: the coarsest allowed level.
        let mut c = LevelChooser::default();
        assert_eq!(
            c.plan(&mut |l| 90_000u32 >> l, 4000.0, 2, 2, 20),
            Plan::at(2)
        );
    }

    #[test]
    fn past_twice_the_budget_at_the_coarsest_spacing_the_last_resort_keeps_the_cap() {
        // A big part pressed flat: 256 000 near points at level 0, 16 000 at level 2 (the
        // coarsest the spacing allows), 4 000 at level 3. SLAM times the budget is 5 000:
        // level 2 would break the look-up cap, so the last resort (level 3) renders it.
        let big = |l: usize| patch(256_000)[l];
        let mut c = LevelChooser::default();
        assert_eq!(c.plan(&mut |l| big(l), 4000.0, 2, 3, 20), Plan::at(3));
        // Staying there while it holds; back to level 2 as soon as level 2 fits the budget.
        assert_eq!(c.plan(&mut |l| big(l), 4000.0, 2, 3, 20), Plan::at(3));
        let smaller = |l: usize| patch(200_000)[l];
        assert_eq!(c.plan(&mut |l| smaller(l), 4000.0, 2, 3, 20), Plan::at(3));
        let fits = |l: usize| patch(60_000)[l];
        let p = c.plan(&mut |l| fits(l), 4000.0, 2, 3, 20);
        assert_eq!(
            (p.from, p.to),
            (3, 2),
            "a blend back to the spacing's coarsest: {p:?}"
        );
        // Between the budget and SLAM times it at the coarsest, it stays there (over
        // budget).
        let mut c = LevelChooser::at(2);
        assert_eq!(
            c.plan(&mut |l| patch(76_000)[l], 4000.0, 2, 3, 20),
            Plan::at(2)
        );
    }

    /// Levels not searched for a while: level l's near pass gets through only after
    /// `passes[l]` capped passes (a whole one brings it up to date at once), and its due
    /// points fall by what each renewal looks at, down to those within reach (due every
    /// tick).
    struct Stale {
        counts: [u32; LEVELS],
        passes: [u32; LEVELS],
        due: [u32; LEVELS],
        in_reach: [u32; LEVELS],
    }

    impl Stale {
        fn new(counts: [u32; LEVELS]) -> Self {
            Self {
                counts,
                passes: [0; LEVELS],
                due: [0; LEVELS],
                in_reach: [0; LEVELS],
            }
        }
    }

    impl Levels for Stale {
        fn near(&mut self, l: usize) -> u32 {
            self.passes[l] = 0;
            self.counts[l]
        }

        fn near_within(&mut self, l: usize) -> Option<u32> {
            if self.passes[l] > 0 {
                self.passes[l] -= 1;
                return None;
            }
            Some(self.counts[l])
        }

        fn renew_points(&mut self, l: usize, _skip: u32, max: u32) -> u32 {
            assert_eq!(self.passes[l], 0, "points renewed before a whole near pass");
            let due = self.due[l];
            self.due[l] = (due - due.min(max)).max(self.in_reach[l]);
            due
        }
    }

    #[test]
    fn a_blend_starts_once_its_level_is_up_to_date() {
        // Level 0 holds 2 400 near points, over half the budget: coarser. Level 1's near
        // pass needs 3 capped passes, then 1 000 due points at 250 a tick (a sixteenth of
        // the budget) leave 250, a share, after 3 ticks: the blend starts in the 7th tick.
        let mut levels = Stale::new([2400, 700, 200, 50, 12]);
        levels.passes[1] = 3;
        levels.due[1] = 1000;
        levels.in_reach[1] = 100;
        let mut c = LevelChooser::default();
        let plans: Vec<Plan> = (0..7)
            .map(|_| c.plan(&mut levels, 4000.0, 3, 3, 20))
            .collect();
        assert_eq!(plans[..6], [Plan::at(0); 6]);
        assert_eq!(
            plans[6],
            Plan {
                from: 0,
                to: 1,
                alpha: 0.05
            }
        );
        // Refining waits for the finer level's near pass too.
        let mut levels = Stale::new([3000, 900, 200, 50, 12]);
        levels.passes[1] = 2;
        let mut c = LevelChooser::at(2);
        assert_eq!(c.plan(&mut levels, 4000.0, 3, 3, 20), Plan::at(2));
        assert_eq!(c.plan(&mut levels, 4000.0, 3, 3, 20), Plan::at(2));
        assert_eq!(c.plan(&mut levels, 4000.0, 3, 3, 20).to, 1);
    }

    #[test]
    fn a_level_with_more_points_within_reach_than_a_share_blends_after_a_few_ticks() {
        let mut levels = Stale::new([2400, 1800, 500, 100, 25]);
        levels.due[1] = 1800;
        levels.in_reach[1] = 1500;
        let mut c = LevelChooser::default();
        let waited = (0..100)
            .take_while(|_| c.plan(&mut levels, 4000.0, 3, 3, 20) == Plan::at(0))
            .count();
        assert_eq!(waited as u32, WARM_TICKS - 1);
        assert_eq!(c.level(), 1);
    }

    #[test]
    fn a_little_over_budget_waits_for_the_coarser_level_a_slam_does_not() {
        // 5 000 points against 4 000: level 0 stays while level 1's near pass gets
        // through (2 ticks), then the stage goes to level 1 at once.
        let mut levels = Stale::new([5000, 1300, 330, 80, 20]);
        levels.passes[1] = 2;
        let mut c = LevelChooser::default();
        assert_eq!(c.plan(&mut levels, 4000.0, 3, 3, 20), Plan::at(0));
        assert_eq!(c.plan(&mut levels, 4000.0, 3, 3, 20), Plan::at(0));
        assert_eq!(c.plan(&mut levels, 4000.0, 3, 3, 20), Plan::at(1));
        // 9 000 points (over SLAM times the budget): level 2 (2 200 points) at once.
        let mut levels = Stale::new([9000, 4500, 2200, 550, 137]);
        levels.passes = [0, 5, 5, 5, 5];
        let mut c = LevelChooser::default();
        assert_eq!(c.plan(&mut levels, 4000.0, 3, 3, 20), Plan::at(2));
    }

    #[test]
    fn a_patch_between_the_thresholds_does_not_switch() {
        let mut c = LevelChooser::at(1);
        for _ in 0..100 {
            // Level 1 holds 1 500 points (≤ 0.5 · 4 000), level 0 would hold 6 000
            // (> 0.25 · 4 000): stay.
            assert_eq!(
                c.plan(&mut |l| patch(6000)[l], 4000.0, 3, 3, 20),
                Plan::at(1)
            );
        }
    }

    #[test]
    fn resolutions_are_validated_and_cap_the_level_by_spacing() {
        assert!(Resolution::Level(LEVELS as u8).validate().is_err());
        assert!(Resolution::Level(0).validate().is_ok());
        let budget = |p: f64, s: f64| Resolution::Budget {
            points_per_ms: p,
            coarsest_spacing_m: s,
        };
        assert!(budget(f64::NAN, 0.004).validate().is_err());
        assert!(budget(0.0, 0.004).validate().is_err());
        assert!(budget(100.0, -1.0).validate().is_err());
        assert!(Resolution::DEFAULT.validate().is_ok());
        assert_eq!(Resolution::DEFAULT.coarsest_level(0.001), 2);
        assert_eq!(Resolution::DEFAULT.coarsest_level(0.0005), 3);
        assert_eq!(Resolution::DEFAULT.coarsest_level(0.002), 1);
        assert_eq!(Resolution::DEFAULT.coarsest_level(0.005), 0);
        assert_eq!(Resolution::Level(2).coarsest_level(0.001), 2);
    }
}
