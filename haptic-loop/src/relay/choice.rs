//! Which planner's guidance the loop renders when several serve it (OR-parallel planning:
//! same query, own seeds, any hosts). Decided on the relay thread, never the RT thread.
//!
//! The rule, applied to every sample that arrives:
//!
//! 1. A planner is *alive* while its newest sample is within its time-to-live.
//! 2. Once any alive planner has solved, the one that solved first is followed (its path
//!    is the one the operator was first led along; a later solver does not take over).
//! 3. Until then, the alive planner whose start tree is nearest the goal
//!    (`distance_to_goal`, I-RRT eq. 2) is followed; the current choice is kept unless
//!    another is nearer by more than [`HYSTERESIS`], and for at least [`MIN_HOLD_NS`], so
//!    two planners at similar distances do not trade the operator back and forth.
//! 4. When no planner is alive, the last choice stays (its guidance fades out in the
//!    loop).
//!
//! A switch reaches the hand through the loop's blend (`GuidanceConfig::switch_s`): no
//! force step. Planners silent for [`FORGET_NS`] are forgotten (a restarted planner is a
//! new one: new pid and planner id).

use ipc_types::Guidance;

/// Another planner must be nearer the goal by more than this fraction to take over.
pub const HYSTERESIS: f64 = 0.1;
/// A choice is kept at least this long before a nearer planner takes over, ns.
pub const MIN_HOLD_NS: u64 = 500_000_000;
/// A planner not heard from for this long is forgotten, ns.
pub const FORGET_NS: u64 = 10_000_000_000;

/// Who wrote a sample (its planner id and process id).
pub type Source = (u32, u32);

fn source(g: &Guidance) -> Source {
    (g.planner_id, g.header.writer_pid)
}

#[derive(Debug, Clone, Copy)]
struct Candidate {
    newest: Guidance,
    /// When its first solved sample arrived, ns (the loop's clock).
    solved_at_ns: Option<u64>,
}

impl Candidate {
    fn alive(&self, now_ns: u64) -> bool {
        now_ns.saturating_sub(self.newest.header.timestamp_ns) <= self.newest.time_to_live_ns
    }
}

/// The planners heard from and the one followed.
#[derive(Debug, Default)]
pub struct PlannerChoice {
    candidates: Vec<Candidate>,
    chosen: Option<Source>,
    chosen_at_ns: u64,
    switches: u64,
}

impl PlannerChoice {
    /// Takes a validated sample that arrived at `now_ns` (the loop's clock, which the
    /// samples' stamps are in) and returns the sample to render now: the chosen planner's
    /// newest.
    pub fn offer(&mut self, g: Guidance, now_ns: u64) -> Option<Guidance> {
        let s = source(&g);
        match self.candidates.iter_mut().find(|c| source(&c.newest) == s) {
            Some(c) => c.newest = g,
            None => self.candidates.push(Candidate {
                newest: g,
                solved_at_ns: None,
            }),
        }
        if let Some(c) = self.candidates.iter_mut().find(|c| source(&c.newest) == s)
            && g.solved != 0
            && c.solved_at_ns.is_none()
        {
            c.solved_at_ns = Some(now_ns);
        }
        // Forget the long silent, but never the one that just spoke or the one followed.
        self.candidates.retain(|c| {
            let k = source(&c.newest);
            now_ns.saturating_sub(c.newest.header.timestamp_ns) < FORGET_NS
                || k == s
                || Some(k) == self.chosen
        });
        let pick = self.pick(now_ns);
        if pick != self.chosen && pick.is_some() {
            if self.chosen.is_some() {
                self.switches += 1;
            }
            self.chosen = pick;
            self.chosen_at_ns = now_ns;
        }
        self.chosen.and_then(|c| self.get(c)).map(|c| c.newest)
    }

    fn get(&self, s: Source) -> Option<&Candidate> {
        self.candidates.iter().find(|c| source(&c.newest) == s)
    }

    fn pick(&self, now_ns: u64) -> Option<Source> {
        let alive = || self.candidates.iter().filter(|c| c.alive(now_ns));
        let current = self.chosen.and_then(|s| self.get(s));
        // 2: the first to solve.
        if let Some(first) = alive()
            .filter_map(|c| c.solved_at_ns.map(|t| (t, c)))
            .min_by_key(|(t, _)| *t)
        {
            return Some(source(&first.1.newest));
        }
        // 3: nearest the goal, with hysteresis and a minimum hold.
        let nearest = alive().min_by(|a, b| {
            a.newest
                .distance_to_goal
                .total_cmp(&b.newest.distance_to_goal)
        });
        match (current.filter(|c| c.alive(now_ns)), nearest) {
            (Some(cur), Some(best)) => {
                let held = now_ns.saturating_sub(self.chosen_at_ns) < MIN_HOLD_NS;
                let much_nearer =
                    best.newest.distance_to_goal < cur.newest.distance_to_goal * (1.0 - HYSTERESIS);
                if !held && much_nearer {
                    Some(source(&best.newest))
                } else {
                    Some(source(&cur.newest))
                }
            }
            (None, Some(best)) => Some(source(&best.newest)),
            // 4: nobody alive: keep the last choice, or take the newest there is.
            (_, None) => self.chosen.or_else(|| {
                self.candidates
                    .iter()
                    .max_by_key(|c| c.newest.header.timestamp_ns)
                    .map(|c| source(&c.newest))
            }),
        }
    }

    /// The planner followed.
    pub fn chosen(&self) -> Option<Source> {
        self.chosen
    }

    /// Times the choice moved from one planner to another.
    pub fn switches(&self) -> u64 {
        self.switches
    }

    /// Planners alive at `now_ns`.
    pub fn alive(&self, now_ns: u64) -> usize {
        self.candidates.iter().filter(|c| c.alive(now_ns)).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipc_types::{GuidanceMode, Header};

    const MS: u64 = 1_000_000;

    fn g(planner: u32, t_ms: u64, distance: f64, solved: bool) -> Guidance {
        Guidance {
            header: Header::new(t_ms + 1, t_ms * MS, 100 + planner),
            planner_id: planner,
            time_to_live_ns: 100 * MS,
            distance_to_goal: distance,
            solved: u32::from(solved),
            mode: GuidanceMode::ROADMAP,
            ..Guidance::default()
        }
    }

    fn chosen_after(c: &mut PlannerChoice, g: Guidance) -> u32 {
        let t = g.header.timestamp_ns;
        c.offer(g, t).map(|g| g.planner_id).unwrap()
    }

    #[test]
    fn nearest_to_goal_is_followed_with_hysteresis_and_hold() {
        let mut c = PlannerChoice::default();
        assert_eq!(chosen_after(&mut c, g(1, 0, 1.0, false)), 1);
        // Nearer, but within the first 500 ms of the choice: held.
        assert_eq!(chosen_after(&mut c, g(2, 10, 0.5, false)), 1);
        // After the hold, only 5 % nearer: kept.
        assert_eq!(chosen_after(&mut c, g(1, 600, 0.52, false)), 1);
        assert_eq!(chosen_after(&mut c, g(2, 610, 0.50, false)), 1);
        // 20 % nearer: taken over.
        assert_eq!(chosen_after(&mut c, g(2, 620, 0.40, false)), 2);
        assert_eq!(c.switches(), 1);
        assert_eq!(c.alive(620 * MS), 2);
    }

    #[test]
    fn the_first_to_solve_is_followed_and_a_later_solver_does_not_take_over() {
        let mut c = PlannerChoice::default();
        chosen_after(&mut c, g(1, 0, 0.2, false));
        // Planner 2 is farther but solves first: followed at once (no hold for solving).
        assert_eq!(chosen_after(&mut c, g(2, 10, 0.9, true)), 2);
        assert_eq!(chosen_after(&mut c, g(1, 20, 0.0, true)), 2);
        assert_eq!(chosen_after(&mut c, g(2, 30, 0.0, true)), 2);
        // The first solver dies (silent past its time-to-live): the other solver follows.
        assert_eq!(chosen_after(&mut c, g(1, 200, 0.0, true)), 1);
    }

    #[test]
    fn a_dead_choice_is_replaced_by_a_live_planner_and_kept_when_none_lives() {
        let mut c = PlannerChoice::default();
        chosen_after(&mut c, g(1, 0, 0.1, false));
        chosen_after(&mut c, g(2, 1, 0.9, false));
        // Planner 1 silent for 300 ms (> time-to-live): planner 2 is followed, though farther.
        assert_eq!(chosen_after(&mut c, g(2, 300, 0.9, false)), 2);
        // Both silent: the last choice stays and its guidance fades in the loop.
        assert_eq!(
            c.offer(g(1, 0, 0.1, false), 5_000 * MS)
                .map(|g| g.planner_id),
            Some(2)
        );
        // Forgotten after 10 s of silence, except the choice itself.
        let _ = c.offer(g(2, 20_000, 0.9, false), 20_000 * MS);
        assert_eq!(c.candidates.len(), 1);
    }
}
