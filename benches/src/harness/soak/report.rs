//! What the soak reports: the loop's figures (from its own summary and from outside), the
//! planner restarts and whether each was followed, every process's memory by the minute,
//! the remote planner's report, and the goals, each PASS or FAIL. Printed as a table
//! (`Display`) and written as JSON.

use super::memory::{self, Sample, mb};
use ipc_types::latency::Percentiles;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::PathBuf;

/// The whole report of a soak.
#[derive(Debug, Clone, Serialize)]
pub struct SoakReport {
    /// Minutes asked for.
    pub minutes_planned: f64,
    /// Minutes it ran, from the moment every process served.
    pub minutes_run: f64,
    /// Stopped by Ctrl-C / SIGTERM before its end.
    pub interrupted: bool,
    /// The scene file.
    pub scene: String,
    /// The simulated operator.
    pub operator: String,
    /// Seconds between planner faults.
    pub restart_s: f64,
    /// Seconds within which a restarted planner must be followed.
    pub follow_s: f64,
    /// Processes that ended on their own while the soak ran (each with its status).
    pub ended_early: Vec<String>,
    /// The haptic loop.
    pub haptic_loop: LoopFigures,
    /// The local planner's restarts.
    pub restarts: Vec<Restart>,
    /// Every process's memory, at each minute.
    pub memory: Vec<Sample>,
    /// Minutes of the samples shown in the table.
    pub memory_shown: Vec<f64>,
    /// The planner across the bridge.
    pub remote_planner: RemoteFigures,
    /// The goals.
    pub goals: Vec<Goal>,
    /// The folder holding the processes' logs and reports.
    pub logs: PathBuf,
}

/// What the soak knows of the loop.
#[derive(Debug, Clone, Serialize)]
pub struct LoopFigures {
    /// The figures of its own summary (`haptic-loop run --summary-json`), `None` if it
    /// could not be read.
    pub summary: Option<LoopSummary>,
    /// Why the summary could not be read.
    pub summary_error: Option<String>,
    /// The newest tick number a state showed.
    pub ticks_seen: u64,
    /// Longest time between two new states on the blackboard, ms.
    pub longest_state_gap_ms: f64,
    /// Times its guidance went from fresh to lost.
    pub guidance_lost: u64,
    /// Times it came back.
    pub guidance_back: u64,
    /// Longest time from lost to fresh again, ms.
    pub longest_lost_ms: f64,
    /// Faults seen in its states, start-up excluded.
    pub faults_seen: Vec<String>,
}

/// The part of `haptic-loop run`'s summary the soak reports.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LoopSummary {
    /// Ticks done.
    pub ticks: u64,
    /// Seconds the loop ran.
    pub run_s: f64,
    /// Deadlines missed (overruns + preempted).
    pub deadline_misses: u64,
    /// Heap allocations per tick on the RT thread.
    pub allocations_per_tick: Option<f64>,
    /// Times the relay moved from one planner to another.
    pub planner_switches: u64,
    /// The loop's report.
    pub loop_report: LoopReportPart,
}

/// The part of the loop's `loop_report` the soak reports.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LoopReportPart {
    /// Deadlines missed by ticks whose own CPU time passed the period.
    pub overruns: u64,
    /// Deadlines missed by ticks whose CPU time fit: the machine's.
    pub preempted: u64,
    /// Faults latched.
    pub faults: u64,
    /// Heap allocations of the RT thread after set-up.
    pub rt_allocations: Option<u64>,
    /// CPU time per tick, µs.
    pub compute_cpu_us: Percentiles,
    /// Age of the guidance rendered, µs.
    pub guidance_age_us: Percentiles,
    /// The tick that used the most CPU time and its work counts (the summary's only
    /// per-tick work counts).
    pub slowest_tick: serde_json::Value,
    /// SCHED_FIFO was active.
    pub fifo: bool,
    /// Memory was locked.
    pub memory_locked: bool,
}

/// One restart of the local planner.
#[derive(Debug, Clone, Serialize)]
pub struct Restart {
    /// From 1.
    pub n: u32,
    /// When the fault was injected, s since the soak began.
    pub at_s: f64,
    /// `kill -9`, or hung (`SIGSTOP`) and then killed.
    pub kind: String,
    /// The planner faulted.
    pub old_pid: u32,
    /// The one started after it.
    pub new_pid: u32,
    /// Seconds from its start to its first fresh sample on the loop's guidance service.
    pub reached_after_s: Option<f64>,
    /// Seconds from its start to the first tick that rendered its guidance.
    pub rendered_after_s: Option<f64>,
    /// The loop rendered fresh guidance (this planner's or another's) within `follow_s`.
    pub loop_fresh: bool,
    /// Whose guidance the loop rendered `follow_s` after the start.
    pub loop_rendering: Option<String>,
    /// The new planner's distance to the goal then (what the relay's choice compares).
    pub new_distance: Option<f64>,
    /// The distance of the planner the loop rendered then.
    pub rendering_distance: Option<f64>,
    /// Followed: within `follow_s` its guidance reached the loop fresh, and the loop
    /// rendered fresh guidance, its own or that of another live planner the relay's choice
    /// keeps (the new one not nearer the goal by more than the choice's hysteresis).
    pub followed: bool,
}

/// What the soak knows of the remote planner.
#[derive(Debug, Clone, Serialize)]
pub struct RemoteFigures {
    /// Its process id.
    pub pid: u32,
    /// The memory bound asked for, MiB.
    pub bound_mb: u64,
    /// What its `RssAnon` may exceed the bound by (code is not anonymous memory; this is
    /// for stacks, the allocator's slack and what lies outside the planner's trees), MiB.
    pub allowance_mb: u64,
    /// Whether `--max-memory-mb` was passed (`planner serve` has it).
    pub bound_passed: bool,
    /// The `memory` object of its report (the bound and what was dropped), if it has one.
    pub memory: Option<serde_json::Value>,
    /// Its whole report (`planner serve --json`), if it could be read.
    pub report: Option<serde_json::Value>,
}

/// A goal and whether it was met.
#[derive(Debug, Clone, Serialize)]
pub struct Goal {
    /// What is asked.
    pub name: String,
    /// Met.
    pub pass: bool,
    /// The figures behind it.
    pub detail: String,
}

impl SoakReport {
    /// Whether every goal was met.
    pub fn passed(&self) -> bool {
        self.goals.iter().all(|g| g.pass)
    }

    /// Judges the goals from the figures.
    pub fn judge(&mut self) {
        self.goals = vec![
            self.remote_memory_goal(),
            self.loop_memory_goal(),
            self.faults_goal(),
            self.overruns_goal(),
            self.restarts_goal(),
            self.ran_goal(),
        ];
    }

    fn remote_memory_goal(&self) -> Goal {
        let r = &self.remote_planner;
        let limit_kb = (r.bound_mb + r.allowance_mb) * 1024;
        let name = format!(
            "remote planner RssAnon <= its bound {} MiB + {} MiB allowance",
            r.bound_mb, r.allowance_mb
        );
        let peak = self
            .memory
            .iter()
            .filter_map(|s| s.remote_planner.map(|m| (s.minute, m.anon_kb)))
            .max_by_key(|(_, kb)| *kb);
        match peak {
            Some((minute, kb)) => Goal {
                name,
                pass: kb <= limit_kb,
                detail: format!(
                    "largest {:.1} MiB, at minute {}",
                    mb(kb),
                    fmt_minute(minute)
                ),
            },
            None => Goal {
                name,
                pass: false,
                detail: "never sampled".into(),
            },
        }
    }

    fn loop_memory_goal(&self) -> Goal {
        let name = "loop RssAnon at the last sample = the first, within 1 MiB".to_owned();
        let loop_anon: Vec<(f64, u64)> = self
            .memory
            .iter()
            .filter_map(|s| s.haptic_loop.map(|m| (s.minute, m.anon_kb)))
            .collect();
        match (loop_anon.first(), loop_anon.last()) {
            (Some(&(m0, first)), Some(&(m1, last))) if loop_anon.len() >= 2 => Goal {
                name,
                pass: first.abs_diff(last) <= 1024,
                detail: format!(
                    "{:.2} MiB at minute {}, {:.2} MiB at minute {} ({:+} kB)",
                    mb(first),
                    fmt_minute(m0),
                    mb(last),
                    fmt_minute(m1),
                    last as i64 - first as i64
                ),
            },
            _ => Goal {
                name,
                pass: false,
                detail: format!("{} sample(s): two are needed", loop_anon.len()),
            },
        }
    }

    fn faults_goal(&self) -> Goal {
        let l = &self.haptic_loop;
        let name = "0 loop faults".to_owned();
        match &l.summary {
            Some(s) => Goal {
                name,
                pass: s.loop_report.faults == 0 && l.faults_seen.is_empty(),
                detail: format!(
                    "{} latched (its summary); seen in its states: {}",
                    s.loop_report.faults,
                    list_or_none(&l.faults_seen)
                ),
            },
            None => Goal {
                name,
                pass: false,
                detail: "the loop's summary could not be read".into(),
            },
        }
    }

    fn overruns_goal(&self) -> Goal {
        let name = "0 overruns whose tick did more than ordinary work".to_owned();
        let Some(s) = &self.haptic_loop.summary else {
            return Goal {
                name,
                pass: false,
                detail: "the loop's summary could not be read".into(),
            };
        };
        let r = &s.loop_report;
        if r.overruns == 0 {
            return Goal {
                name,
                pass: true,
                detail: format!(
                    "0 overruns ({} deadlines missed, all preempted)",
                    r.preempted
                ),
            };
        }
        Goal {
            name,
            pass: false,
            detail: format!(
                "{} overruns; the loop's summary gives work counts for its slowest tick only \
                 ({}), so whether each overrun did more than ordinary work cannot be told: \
                 every overrun counts",
                r.overruns,
                slowest(&r.slowest_tick)
            ),
        }
    }

    fn restarts_goal(&self) -> Goal {
        let followed = self.restarts.iter().filter(|r| r.followed).count();
        Goal {
            name: format!("every restart followed within {} s", self.follow_s),
            pass: followed == self.restarts.len(),
            detail: format!("{followed} of {}", self.restarts.len()),
        }
    }

    fn ran_goal(&self) -> Goal {
        Goal {
            name: "every process ran the whole soak".into(),
            pass: self.ended_early.is_empty() && self.haptic_loop.summary.is_some(),
            detail: match (&self.ended_early[..], &self.haptic_loop.summary_error) {
                ([], None) => "yes".into(),
                (ended, error) => {
                    let mut parts: Vec<String> = ended.to_vec();
                    parts.extend(error.iter().map(|e| format!("loop summary: {e}")));
                    parts.join("; ")
                }
            },
        }
    }
}

fn list_or_none(items: &[String]) -> String {
    if items.is_empty() {
        "none".into()
    } else {
        items.join(", ")
    }
}

/// The slowest tick of the loop's summary in one line: its number, CPU time and every work
/// count it lists.
fn slowest(tick: &serde_json::Value) -> String {
    fn counts(prefix: &str, v: &serde_json::Value, out: &mut Vec<String>) {
        if let Some(map) = v.as_object() {
            for (k, v) in map {
                let name = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                counts(&name, v, out);
            }
        } else {
            out.push(format!("{prefix} {v}"));
        }
    }
    let mut work = Vec::new();
    counts("", &tick["work"], &mut work);
    format!(
        "#{} {} µs CPU, {} µs wall: {}",
        tick["tick"],
        tick["compute_cpu_us"]
            .as_f64()
            .map_or("?".into(), |v| format!("{v:.0}")),
        tick["compute_us"]
            .as_f64()
            .map_or("?".into(), |v| format!("{v:.0}")),
        work.join(", ")
    )
}

fn opt_s(v: Option<f64>) -> String {
    v.map_or("-".into(), |v| format!("{v:.1} s"))
}

impl fmt::Display for SoakReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "── soak ────────────────────────────────────────────────"
        )?;
        writeln!(
            f,
            "ran:               {:.1} of {} min{} (scene {}, operator {}); logs in {}",
            self.minutes_run,
            self.minutes_planned,
            if self.interrupted {
                ", interrupted"
            } else {
                ""
            },
            self.scene,
            self.operator,
            self.logs.display()
        )?;
        let l = &self.haptic_loop;
        match &l.summary {
            Some(s) => {
                let r = &s.loop_report;
                writeln!(
                    f,
                    "loop:              {} ticks in {:.1} s; {} deadline misses ({} overruns, {} preempted); {} faults latched",
                    s.ticks, s.run_s, s.deadline_misses, r.overruns, r.preempted, r.faults
                )?;
                writeln!(
                    f,
                    "allocations/tick:  {} ({} on the RT thread); SCHED_FIFO {}, memory locked {}",
                    s.allocations_per_tick
                        .map_or("not measured".into(), |a| a.to_string()),
                    r.rt_allocations.map_or("?".into(), |a| a.to_string()),
                    r.fifo,
                    r.memory_locked
                )?;
                writeln!(
                    f,
                    "compute CPU µs:    p50 {:.1}  p99 {:.1}  p99.9 {:.1}  max {:.1}",
                    r.compute_cpu_us.p50,
                    r.compute_cpu_us.p99,
                    r.compute_cpu_us.p999,
                    r.compute_cpu_us.max
                )?;
                writeln!(
                    f,
                    "slowest tick:      {} (the summary lists the work of its slowest tick only, not of each overrun)",
                    slowest(&r.slowest_tick)
                )?;
                writeln!(
                    f,
                    "guidance age µs:   p50 {:.0}  p99 {:.0}  max {:.0}; the relay switched planners {} times",
                    r.guidance_age_us.p50,
                    r.guidance_age_us.p99,
                    r.guidance_age_us.max,
                    s.planner_switches
                )?;
            }
            None => writeln!(
                f,
                "loop:              no summary ({}); {} ticks seen",
                l.summary_error.as_deref().unwrap_or("?"),
                l.ticks_seen
            )?,
        }
        writeln!(
            f,
            "guidance:          lost {} times, back {} times (longest lost {:.0} ms); longest gap between states {:.1} ms; faults seen: {}",
            l.guidance_lost,
            l.guidance_back,
            l.longest_lost_ms,
            l.longest_state_gap_ms,
            list_or_none(&l.faults_seen)
        )?;
        let followed = self.restarts.iter().filter(|r| r.followed).count();
        writeln!(
            f,
            "planner restarts:  {} (every {} s), followed {followed} of them within {} s",
            self.restarts.len(),
            self.restart_s,
            self.follow_s
        )?;
        if !self.restarts.is_empty() {
            writeln!(
                f,
                "  #    at s  fault                       pid old → new    reached  rendered  the loop then renders"
            )?;
        }
        for r in &self.restarts {
            let then = match (&r.loop_rendering, r.rendering_distance, r.new_distance) {
                (Some(who), Some(d), Some(n)) => {
                    format!("{who} (distance to goal {d:.3}; the new one's {n:.3})")
                }
                (Some(who), _, _) => who.clone(),
                (None, _, _) if r.loop_fresh => "fresh guidance".into(),
                (None, _, _) => "no fresh guidance".into(),
            };
            writeln!(
                f,
                "  {:<3} {:>6.1}  {:<27} {:>7} → {:<7}  {:>7}  {:>8}  {then}{}",
                r.n,
                r.at_s,
                r.kind,
                r.old_pid,
                r.new_pid,
                opt_s(r.reached_after_s),
                opt_s(r.rendered_after_s),
                if r.followed { "" } else { "  NOT FOLLOWED" }
            )?;
        }
        let rp = &self.remote_planner;
        writeln!(
            f,
            "remote planner:    pid {}, bound {} MiB ({}), allowance {} MiB",
            rp.pid,
            rp.bound_mb,
            if rp.bound_passed {
                "passed as --max-memory-mb"
            } else {
                "NOT passed: this planner serve has no --max-memory-mb"
            },
            rp.allowance_mb
        )?;
        match &rp.memory {
            Some(m) => writeln!(f, "  its report's memory: {m}")?,
            None => writeln!(
                f,
                "  its report has no memory object{}",
                if rp.report.is_none() {
                    " (no report read)"
                } else {
                    ""
                }
            )?,
        }
        writeln!(f, "{}", MemoryTable(self))?;
        writeln!(f, "goals:")?;
        for g in &self.goals {
            writeln!(
                f,
                "  {}  {}: {}",
                if g.pass { "PASS" } else { "FAIL" },
                g.name,
                g.detail
            )?;
        }
        Ok(())
    }
}

/// The memory table: one row per process, one column per sample shown.
struct MemoryTable<'a>(&'a SoakReport);

impl fmt::Display for MemoryTable<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = self.0;
        let shown: Vec<&Sample> = memory::reported(&r.memory)
            .into_iter()
            .map(|i| &r.memory[i])
            .collect();
        write!(f, "{:<24}", "RSS MiB (anon / shmem)")?;
        for s in &shown {
            write!(f, "{:>16}", format!("minute {}", fmt_minute(s.minute)))?;
        }
        for row in 0..4 {
            writeln!(f)?;
            write!(f, "{:<24}", Sample::NAMES[row])?;
            for s in &shown {
                let cell = s.processes()[row].1.map_or("-".into(), |m| m.describe());
                write!(f, "{cell:>16}")?;
            }
        }
        Ok(())
    }
}

fn fmt_minute(m: f64) -> String {
    if (m - m.round()).abs() < 0.05 {
        format!("{}", m.round())
    } else {
        format!("{m:.1}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::soak::memory::Rss;

    fn rss(anon_kb: u64) -> Option<Rss> {
        Some(Rss {
            pid: 1,
            anon_kb,
            shmem_kb: 100,
        })
    }

    fn sample(minute: f64, loop_kb: u64, remote_kb: u64) -> Sample {
        Sample {
            minute,
            haptic_loop: rss(loop_kb),
            local_planner: rss(1000),
            bridge: rss(1000),
            remote_planner: rss(remote_kb),
        }
    }

    fn summary(overruns: u64, faults: u64) -> LoopSummary {
        LoopSummary {
            ticks: 60_000,
            run_s: 60.0,
            deadline_misses: overruns + 3,
            allocations_per_tick: Some(0.0),
            planner_switches: 1,
            loop_report: LoopReportPart {
                overruns,
                preempted: 3,
                faults,
                rt_allocations: Some(0),
                compute_cpu_us: Percentiles::default(),
                guidance_age_us: Percentiles::default(),
                slowest_tick: serde_json::json!({
                    "tick": 7, "compute_cpu_us": 1500.0, "compute_us": 1500.0,
                    "work": {"contact": {"checks": 3}, "publishes": 1}
                }),
                fifo: true,
                memory_locked: true,
            },
        }
    }

    fn restart(followed: bool) -> Restart {
        Restart {
            n: 1,
            at_s: 60.0,
            kind: "kill -9".into(),
            old_pid: 10,
            new_pid: 11,
            reached_after_s: Some(0.1),
            rendered_after_s: None,
            loop_fresh: true,
            loop_rendering: Some("the remote planner".into()),
            new_distance: Some(0.27),
            rendering_distance: Some(0.26),
            followed,
        }
    }

    fn report(
        memory: Vec<Sample>,
        loop_summary: LoopSummary,
        restarts: Vec<Restart>,
    ) -> SoakReport {
        let mut r = SoakReport {
            minutes_planned: 2.0,
            minutes_run: 2.0,
            interrupted: false,
            scene: "wall-hole-22mm.toml".into(),
            operator: "newcomer".into(),
            restart_s: 30.0,
            follow_s: 10.0,
            ended_early: Vec::new(),
            haptic_loop: LoopFigures {
                summary: Some(loop_summary),
                summary_error: None,
                ticks_seen: 60_000,
                longest_state_gap_ms: 2.0,
                guidance_lost: 0,
                guidance_back: 0,
                longest_lost_ms: 0.0,
                faults_seen: Vec::new(),
            },
            restarts,
            memory_shown: Vec::new(),
            memory,
            remote_planner: RemoteFigures {
                pid: 2,
                bound_mb: 256,
                allowance_mb: 64,
                bound_passed: true,
                memory: None,
                report: None,
            },
            goals: Vec::new(),
            logs: PathBuf::from("/tmp"),
        };
        r.judge();
        r
    }

    fn passed(r: &SoakReport) -> Vec<bool> {
        r.goals.iter().map(|g| g.pass).collect()
    }

    #[test]
    fn a_clean_run_meets_every_goal_and_prints_its_table() {
        let r = report(
            vec![sample(1.0, 80_000, 100_000), sample(2.0, 80_900, 300_000)],
            summary(0, 0),
            vec![restart(true), restart(true)],
        );
        assert!(r.passed(), "{r}");
        let table = r.to_string();
        assert!(
            table.contains("minute 1") && table.contains("remote planner"),
            "{table}"
        );
        assert!(table.contains("PASS  every restart followed"), "{table}");
    }

    #[test]
    fn each_goal_fails_on_its_own_figure() {
        // Remote planner past 256 + 64 MiB; the loop's RssAnon grew by more than 1 MiB.
        let r = report(
            vec![
                sample(1.0, 80_000, 100_000),
                sample(2.0, 81_100, 321 * 1024),
            ],
            summary(0, 0),
            vec![restart(true)],
        );
        assert_eq!(passed(&r), [false, false, true, true, true, true]);
        // A fault, an overrun (its work unknown: it counts), a restart not followed.
        let r = report(
            vec![sample(1.0, 80_000, 100_000), sample(2.0, 80_000, 100_000)],
            summary(2, 1),
            vec![restart(true), restart(false)],
        );
        assert_eq!(passed(&r), [true, true, false, false, false, true]);
        assert!(
            r.goals[3].detail.contains("contact.checks 3"),
            "{}",
            r.goals[3].detail
        );
        // One sample cannot show the loop's memory holding.
        let r = report(
            vec![sample(1.0, 80_000, 100_000)],
            summary(0, 0),
            Vec::new(),
        );
        assert_eq!(passed(&r), [true, false, true, true, true, true]);
    }
}
