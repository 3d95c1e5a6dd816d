//! What a session reports at its end: printed as a table and written as JSON by
//! `--summary-json`.

use crate::runner::LoopReport;
use crate::stats::Percentiles;
use crate::tick::{GuidanceSource, StateSink, Tick};
use devices::HapticDevice;
use devices::sim::operator::{OperatorStats, SharedStats};
use ipc_types::Guidance;
use serde::Serialize;
use std::fmt;

use super::Watch;

/// The summary of one session.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// The planner published a solution while the loop ran.
    pub solved: bool,
    /// The planner proved there is no way from the start to the goal
    /// ([`ipc_types::GuidanceMode::NO_WAY`]); `demo` then ends with exit code 3.
    pub no_way: bool,
    /// Seconds from the loop's start to the first guidance sample that reported a solution.
    pub time_to_solve_s: Option<f64>,
    /// Waypoints of the received solution path.
    pub path_waypoints: u64,
    /// Weighted length of the received path.
    pub path_length: Option<f64>,
    /// Seconds the loop ran.
    pub run_s: f64,
    /// Ticks done.
    pub ticks: u64,
    /// Deadlines missed.
    pub deadline_misses: u64,
    /// Heap allocations per tick on the RT thread (`null` if not measured).
    pub allocations_per_tick: Option<f64>,
    /// Wake-up latency, µs.
    pub wake_latency_us: Percentiles,
    /// The loop's full report.
    pub loop_report: LoopReport,
    /// Planner iterations at the end (from its last guidance sample).
    pub planner_iterations: u64,
    /// Planner nodes at the end.
    pub planner_nodes: u64,
    /// Planner trees at the end (start, goal and local trees; their edges are nodes − trees).
    pub planner_trees: u32,
    /// `planner_id` of the planner followed at the end (0: none, or one that sets none).
    pub planner_id: u32,
    /// Times the loop moved from one planner's guidance to another's (several planners).
    pub planner_switches: u64,
    /// Contact rendering figures; `null` when contact was off.
    pub contact: Option<ContactSummary>,
    /// Seconds from the loop's start until the object (the proxy) first came within 5 mm
    /// and 0.1 rad of the goal: the operator's time to reach it; `null` if it did not.
    pub time_to_goal_s: Option<f64>,
    /// Largest change of the commanded device force between two consecutive fault-free
    /// ticks, N (a fault's fail-safe drop to zero is counted in `loop_report.faults`).
    pub max_force_step_n: f64,
    /// What the simulated operator did; `null` for a scripted operator or a real device.
    pub operator: Option<OperatorSummary>,
    /// The process's `oom_score_adj` in effect, and whether the binary's request to lower it
    /// was applied or refused and why; `null` when nothing was asked.
    pub oom_score_adj: Option<ipc_types::startup::OomScoreAdj>,
}

/// What a reacting simulated operator did in a session: the route step it was heading for
/// at the end (0 = the start) and its counts (`OperatorStats`, flattened into the JSON).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct OperatorSummary {
    /// Route step it was heading for at the end.
    pub step: u32,
    /// Steps reached, blocks, wrong turns and orientations, corrections, retries,
    /// hesitations.
    #[serde(flatten)]
    pub counts: OperatorStats,
}

impl OperatorSummary {
    /// The operator's counts as `stats` holds them now.
    pub fn of(stats: &SharedStats) -> Self {
        let (counts, step) = stats.read();
        OperatorSummary { step, counts }
    }
}

/// What contact rendering did during a session.
#[derive(Debug, Clone, Serialize)]
pub struct ContactSummary {
    /// Time spent in contact, s.
    pub contact_s: f64,
    /// Deepest penetration of the proxy into the scene, mm.
    pub max_penetration_mm: f64,
    /// Voxel size, mm.
    pub voxel_mm: f64,
    /// Pointshell points.
    pub points: usize,
    /// Voxmap memory, MB.
    pub voxmap_mb: f64,
    /// Voxmap build time, s.
    pub voxmap_build_s: f64,
    /// Level of detail rendered at the end (0 = every point).
    pub level: usize,
    /// Changes of level of detail (the point budget at work).
    pub level_changes: u64,
    /// Ticks whose work caps left contact work for later ticks (the proxy held back
    /// meanwhile: see ARCHITECTURE.md, "The bounded tick").
    pub deferred_ticks: u64,
}

impl ContactSummary {
    /// The contact figures of a finished `tick` (`None` without contact); `period_s` is the
    /// tick period, s.
    pub fn of<D: HapticDevice, G: GuidanceSource, S: StateSink>(
        tick: &Tick<D, G, S>,
        period_s: f64,
    ) -> Option<Self> {
        let stage = tick.contact()?;
        let model = stage.model();
        let report = model.voxmap().report();
        Some(Self {
            contact_s: tick.contact_ticks() as f64 * period_s,
            max_penetration_mm: tick.max_penetration_m() * 1e3,
            voxel_mm: report.voxel_m * 1e3,
            points: model.pointshell().len(),
            voxmap_mb: report.memory_bytes as f64 / 1e6,
            voxmap_build_s: report.build_time.as_secs_f64(),
            level: stage.level(),
            level_changes: stage.level_changes(),
            deferred_ticks: stage.deferred_steps(),
        })
    }
}

impl Summary {
    /// The summary of a session: the loop's `report` over `run_s` seconds, what `watch` saw
    /// of the planner, and the contact figures.
    pub fn new(
        report: LoopReport,
        run_s: f64,
        watch: &Watch,
        contact: Option<ContactSummary>,
    ) -> Self {
        let guidance: Guidance = watch.newest_guidance();
        let path = watch.path();
        Self {
            solved: watch.solved_at().is_some(),
            no_way: watch.no_way_at().is_some(),
            time_to_solve_s: watch.solved_at().map(|d| d.as_secs_f64()),
            path_waypoints: path.map_or(0, |p| p.0),
            path_length: path.map(|p| p.1),
            run_s,
            ticks: report.ticks,
            deadline_misses: report.deadline_misses,
            allocations_per_tick: report.allocations_per_tick,
            wake_latency_us: report.wake_latency_us,
            planner_iterations: guidance.iterations,
            planner_nodes: guidance.nodes,
            planner_trees: guidance.trees,
            planner_id: guidance.planner_id,
            planner_switches: watch.planner_switches(),
            loop_report: report,
            contact,
            time_to_goal_s: None,
            max_force_step_n: 0.0,
            operator: None,
            oom_score_adj: None,
        }
    }
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let w = &self.wake_latency_us;
        let c = &self.loop_report.compute_us;
        writeln!(
            f,
            "── summary ─────────────────────────────────────────────"
        )?;
        match (self.solved, self.time_to_solve_s) {
            (true, Some(t)) => {
                write!(f, "solved:            yes, after {t:.2} s")?;
                match self.path_length {
                    Some(len) => {
                        writeln!(f, " ({} waypoints, length {len:.3})", self.path_waypoints)?
                    }
                    None => writeln!(f, " (no path received)")?,
                }
            }
            _ if self.no_way => writeln!(f, "solved:            no way through (proved)")?,
            _ => writeln!(f, "solved:            no")?,
        }
        write!(
            f,
            "planner:           {} iterations, {} nodes",
            self.planner_iterations, self.planner_nodes
        )?;
        match self.planner_switches {
            0 => writeln!(f)?,
            n => writeln!(
                f,
                " (planner {:08x}; {n} switches between planners)",
                self.planner_id
            )?,
        }
        writeln!(
            f,
            "ticks:             {} in {:.1} s",
            self.ticks, self.run_s
        )?;
        writeln!(
            f,
            "wake latency µs:   p50 {:.1}  p99 {:.1}  p99.9 {:.1}  max {:.1}",
            w.p50, w.p99, w.p999, w.max
        )?;
        writeln!(
            f,
            "compute µs:        p50 {:.1}  p99 {:.1}  p99.9 {:.1}  max {:.1}",
            c.p50, c.p99, c.p999, c.max
        )?;
        let cpu = &self.loop_report.compute_cpu_us;
        writeln!(
            f,
            "compute CPU µs:    p50 {:.1}  p99 {:.1}  p99.9 {:.1}  max {:.1}",
            cpu.p50, cpu.p99, cpu.p999, cpu.max
        )?;
        let slow = &self.loop_report.slowest_tick;
        let w = &slow.work.contact;
        writeln!(
            f,
            "slowest tick:      #{} {:.1} µs CPU ({:.1} µs wall): {} clearance checks, {} compares, {} look-ups, {} levels searched",
            slow.tick,
            slow.compute_cpu_us,
            slow.compute_us,
            w.checks,
            w.compares,
            w.look_ups,
            w.searches
        )?;
        writeln!(
            f,
            "deadline misses:   {} ({} overruns: the tick's own CPU time passed the period; {} preempted: the machine's)",
            self.deadline_misses, self.loop_report.overruns, self.loop_report.preempted
        )?;
        match &self.contact {
            Some(c) => writeln!(
                f,
                "contact:           {:.2} s in contact, max penetration {:.3} mm ({} points, {} mm voxels; level of detail {} at the end, {} changes; {} ticks left work to later ones)",
                c.contact_s,
                c.max_penetration_mm,
                c.points,
                c.voxel_mm,
                c.level,
                c.level_changes,
                c.deferred_ticks
            )?,
            None => writeln!(f, "contact:           off")?,
        }
        match self.time_to_goal_s {
            Some(t) => writeln!(f, "object at goal:    after {t:.2} s")?,
            None => writeln!(f, "object at goal:    not reached")?,
        }
        writeln!(
            f,
            "force step:        largest {:.3} N between ticks",
            self.max_force_step_n
        )?;
        if let Some(OperatorSummary { step, counts: o }) = &self.operator {
            writeln!(
                f,
                "operator:          at route step {} ({} reached); {} blocks, {} corrections, {} retries, {} hesitations; {} wrong turns, {} wrong orientations",
                step,
                o.steps_reached,
                o.blocks,
                o.corrections,
                o.retries,
                o.hesitations,
                o.wrong_turns,
                o.wrong_orientations
            )?;
        }
        match self.allocations_per_tick {
            Some(a) => writeln!(
                f,
                "allocations/tick:  {a} ({} on the RT thread)",
                self.loop_report.rt_allocations.unwrap_or(0)
            )?,
            None => writeln!(
                f,
                "allocations/tick:  not measured (counting allocator not installed)"
            )?,
        }
        if let Some(oom) = &self.oom_score_adj {
            writeln!(f, "oom_score_adj:     {oom}")?;
        }
        write!(
            f,
            "real-time:         SCHED_FIFO {}, pinned {}, memory locked {}, CPU wake-up latency request {}",
            self.loop_report.fifo,
            self.loop_report.pinned,
            self.loop_report.memory_locked,
            match self.loop_report.cpu_latency_us {
                Some(us) => format!("{us} µs"),
                None => "none".to_owned(),
            }
        )
    }
}
