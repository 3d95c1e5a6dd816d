//! The planner process: IPC and timing around the pure [`Planner`] core.
//!
//! Threads:
//! - *receiver*: polls the [`HapticState`] blackboard phase-locked to the loop's ticks
//!   ([`pacing::StatePacer`]: about one absolute-deadline wake-up per tick, just after
//!   the state is written; `state_poll_hz` until it has locked on), counts every new tick it
//!   sees (and those it skipped, from sequence gaps), and keeps the newest operator pose for
//!   the planning thread. Polling rather than an event: the haptic loop must not call
//!   `notify()` from its RT thread (see `ipc_types::services`).
//! - *main*: runs planner iterations as fast as they go and, independently of their speed,
//!   publishes [`Guidance`] at `guidance_rate_hz`, the [`Path`] once solved, and roadmap
//!   increments for viewers ([`ipc_types::Roadmap`], filled by
//!   [`roadmap::RoadmapFeed`]: O(1024) nodes per sample whatever the roadmap's
//!   size) at `roadmap_rate_hz`. Never waits for the haptic loop or a viewer: a roadmap
//!   sample that cannot be loaned is skipped, and a full viewer queue overflows safely.

pub mod pacing;
pub mod roadmap;

use roadmap::{FeedInfo, RoadmapFeed};
use crate::{Planner, PlannerParams, Scene, Se3};
use ipc_types::services::{self, GuidanceNotifier, GuidancePublisher, RoadmapPublisher};
use ipc_types::{Guidance, GuidanceMode, HapticState, Header, PATH_CAPACITY, Path, Pose};
use serde::Serialize;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Everything the planner process needs, validated.
#[derive(Debug, Clone)]
pub struct ShellConfig {
    /// IPC namespace shared with the haptic loop.
    pub namespace: String,
    /// The scene to plan in.
    pub scene: Scene,
    /// Core parameters.
    pub params: PlannerParams,
    /// RNG seed.
    pub seed: u64,
    /// Guidance publish rate, Hz.
    pub guidance_rate_hz: f64,
    /// k for the translational part of F_s, N/m.
    pub gain_n_per_m: f64,
    /// k for the rotational part of F_s, N·m/rad.
    pub gain_nm_per_rad: f64,
    /// Time-to-live written into each guidance sample, s.
    pub ttl_s: f64,
    /// How often the receiver thread polls the haptic state before it has locked onto the
    /// loop's ticks, and while no new state comes, Hz.
    pub state_poll_hz: f64,
    /// Half-width of the window around each predicted state in which the receiver spins
    /// instead of sleeping, µs (0: never spins).
    pub state_spin_us: f64,
    /// SCHED_FIFO priority of the state receiver thread (0: the normal scheduler).
    pub state_priority: u8,
    /// A haptic state older than this counts as "no operator", s.
    pub state_timeout_s: f64,
    /// Grow the trees also without an operator; otherwise idle until one appears.
    pub plan_without_operator: bool,
    /// Stop after this long (`None` = until SIGINT/SIGTERM).
    pub duration_s: Option<f64>,
    /// Roadmap increments published per second for viewers; 0 publishes none.
    pub roadmap_rate_hz: f64,
}

/// What a planner run did; written as JSON by `--json`.
#[derive(Debug, Clone, Serialize, Default)]
pub struct ShellReport {
    /// Seconds the process ran.
    pub run_s: f64,
    /// A solution was found.
    pub solved: bool,
    /// Seconds from start to solution.
    pub time_to_solve_s: Option<f64>,
    /// Planner iterations.
    pub iterations: u64,
    /// Nodes in all trees.
    pub nodes: u64,
    /// Collision checks.
    pub collision_checks: u64,
    /// Waypoints of the published path (0 if unsolved).
    pub path_waypoints: u64,
    /// Distinct haptic states received.
    pub states_received: u64,
    /// Haptic states the loop published that this process did not see (sequence gaps).
    pub states_skipped: u64,
    /// Received states per second, between the first and the last one received.
    pub state_rate_hz: f64,
    /// Guidance samples published.
    pub guidance_published: u64,
    /// Haptic states rejected as invalid (non-finite or non-unit pose).
    pub states_rejected: u64,
    /// Times a new haptic loop (restarted after a crash) was found and followed.
    pub loops_followed: u64,
    /// Seconds spent idle for want of an operator (no fresh haptic state).
    pub idle_s: f64,
    /// Publish → receive of each new haptic state: the loop's stamp just before its
    /// blackboard write (`published_ns`) → the receiver thread's read that first saw it, µs.
    /// Includes the receiver's own wake-up latency.
    pub state_latency_us: ipc_types::latency::Percentiles,
    /// Age of each new haptic state when the receiver first saw it: its header stamp (the
    /// loop's tick wake-up) → that read, µs: [`Self::state_latency_us`] plus the tick's
    /// compute before publishing.
    pub state_age_us: ipc_types::latency::Percentiles,
    /// Roadmap increments published.
    pub roadmap_published: u64,
    /// Roadmap increments skipped because no sample could be loaned.
    pub roadmap_skipped: u64,
    /// Mean time the main thread spent on one roadmap increment (loan, fill, send), µs.
    pub roadmap_publish_mean_us: f64,
    /// Longest time the main thread spent on one roadmap increment, µs.
    pub roadmap_publish_max_us: f64,
}

/// The newest operator state as seen by the receiver thread.
#[derive(Debug, Default, Clone, Copy)]
struct Operator {
    state: Option<HapticState>,
    /// `Instant` of the last new state, for staleness.
    seen_at: Option<Instant>,
    received: u64,
    skipped: u64,
    rejected: u64,
    first_at: Option<Instant>,
    last_at: Option<Instant>,
    /// Times the receiver switched to a restarted loop's state.
    loop_generations: u64,
}

/// Runs the planner process until `stop` is set or the duration elapses.
pub fn run(config: &ShellConfig, stop: Arc<AtomicBool>) -> anyhow::Result<ShellReport> {
    let started = Instant::now();
    let node_name = format!("planner_{}", std::process::id());
    let (node, cleaned) = services::create_node(&node_name)?;
    if cleaned > 0 {
        tracing::info!("removed resources of {cleaned} dead iceoryx2 node(s)");
    }
    let guidance = services::guidance_publisher(&node, &config.namespace)?;
    let guidance_event = services::guidance_notifier(&node, &config.namespace)?;
    let path_pub = services::path_publisher(&node, &config.namespace)?;
    let roadmap_pub = if config.roadmap_rate_hz > 0.0 {
        Some(services::roadmap_publisher(&node, &config.namespace)?)
    } else {
        None
    };
    let mut feed = RoadmapFeed::new();
    let roadmap_period = Duration::from_secs_f64(1.0 / config.roadmap_rate_hz.max(1e-3));
    let mut next_roadmap = Instant::now();
    let mut roadmap_publish_total_us = 0.0;
    let state_source = services::StateFollower::open(&node, &config.namespace)?;
    let mut planner = Planner::new(&config.scene, config.params.clone(), config.seed)?;

    let operator = Arc::new(Mutex::new(Operator::default()));
    let receiver = {
        let operator = operator.clone();
        let stop = stop.clone();
        let poll_ns = (1e9 / config.state_poll_hz) as u64;
        let spin_ns = (config.state_spin_us * 1e3) as u64;
        let priority = config.state_priority;
        std::thread::Builder::new()
            .name("planner-rx".into())
            .spawn(move || {
                if priority > 0
                    && let Err(e) = ipc_types::set_thread_fifo_priority(priority)
                {
                    tracing::warn!("state receiver: {e}; it keeps the normal scheduler");
                }
                receive_states(state_source, operator, &stop, poll_ns, spin_ns)
            })?
    };

    let guidance_period = Duration::from_secs_f64(1.0 / config.guidance_rate_hz);
    let mut next_guidance = Instant::now();
    let mut report = ShellReport::default();
    let mut guidance_seq = 0u64;
    let mut path_seq = 0u64;
    let pid = std::process::id();
    let mut last_connection_update = Instant::now();
    let mut announced_operator = false;

    while !stop.load(Ordering::Acquire) {
        if config
            .duration_s
            .is_some_and(|d| started.elapsed().as_secs_f64() >= d)
        {
            break;
        }
        let op = *lock(&operator);
        let fresh = op
            .seen_at
            .is_some_and(|t| t.elapsed().as_secs_f64() < config.state_timeout_s);
        let q_user = op.state.filter(|_| fresh).and_then(|s| se3(&s.user_pose));
        if fresh != announced_operator {
            if fresh {
                tracing::info!("haptic loop present: following the operator");
            } else if config.plan_without_operator {
                tracing::info!("no fresh haptic state: planning without the operator");
            } else {
                tracing::info!("no fresh haptic state: idle until a haptic loop appears");
            }
            announced_operator = fresh;
        }

        let idle = !fresh && !config.plan_without_operator;
        if idle {
            // No operator to plan with: wake for the next guidance publication only.
            let t0 = Instant::now();
            std::thread::sleep(next_guidance.saturating_duration_since(t0));
            report.idle_s += t0.elapsed().as_secs_f64();
        } else if !planner.solved() {
            let input = op.state.filter(|_| fresh).and_then(|s| user_input(&s));
            planner.iterate_input(input.as_ref());
            if planner.solved() {
                let t = started.elapsed().as_secs_f64();
                report.time_to_solve_s = Some(t);
                if let Some(sol) = planner.solution() {
                    path_seq += 1;
                    let path = to_wire_path(sol, &planner, path_seq, pid);
                    report.path_waypoints = path.len;
                    if let Err(e) = path_pub.send_copy(path) {
                        tracing::warn!("cannot publish path: {e:?}");
                    }
                }
                let s = planner.stats();
                tracing::info!(
                    "solved after {t:.2} s: {} iterations, {} nodes, {} waypoints",
                    s.iterations,
                    s.nodes,
                    report.path_waypoints
                );
            }
        } else {
            // Solved: nothing to grow; wake for the next guidance publication only.
            std::thread::sleep(next_guidance.saturating_duration_since(Instant::now()));
        }

        let now = Instant::now();
        if now >= next_guidance {
            next_guidance += guidance_period;
            if next_guidance < now {
                next_guidance = now + guidance_period;
            }
            guidance_seq += 1;
            let g = make_guidance(config, &planner, q_user.as_ref(), &op, guidance_seq, pid);
            publish_guidance(&guidance, &guidance_event, g);
            report.guidance_published += 1;
        }
        if let Some(rp) = &roadmap_pub
            && now >= next_roadmap
        {
            next_roadmap = now + roadmap_period;
            let t0 = Instant::now();
            let sent = publish_roadmap(rp, &mut feed, &planner, pid);
            let us = t0.elapsed().as_secs_f64() * 1e6;
            roadmap_publish_total_us += us;
            report.roadmap_publish_max_us = report.roadmap_publish_max_us.max(us);
            if sent {
                report.roadmap_published += 1;
            } else {
                report.roadmap_skipped += 1;
            }
        }
        if last_connection_update.elapsed() > Duration::from_millis(200) {
            // Delivers the path history to subscribers that joined late.
            use iceoryx2::port::update_connections::UpdateConnections;
            let _ = path_pub.update_connections();
            last_connection_update = Instant::now();
        }
    }

    stop.store(true, Ordering::Release);
    if let Ok(latency) = receiver.join() {
        report.state_latency_us = latency.transport.percentiles_us();
        report.state_age_us = latency.age.percentiles_us();
    }
    let op = *lock(&operator);
    let s = planner.stats();
    report.run_s = started.elapsed().as_secs_f64();
    let attempts = report.roadmap_published + report.roadmap_skipped;
    if attempts > 0 {
        report.roadmap_publish_mean_us = roadmap_publish_total_us / attempts as f64;
    }
    report.solved = planner.solved();
    report.iterations = s.iterations;
    report.nodes = s.nodes as u64;
    report.collision_checks = s.collision_checks;
    report.states_received = op.received;
    report.states_skipped = op.skipped;
    report.states_rejected = op.rejected;
    report.loops_followed = op.loop_generations;
    report.state_rate_hz = match (op.first_at, op.last_at) {
        (Some(a), Some(b)) if b > a => (op.received - 1) as f64 / (b - a).as_secs_f64(),
        _ => 0.0,
    };
    Ok(report)
}

fn lock(m: &Mutex<Operator>) -> std::sync::MutexGuard<'_, Operator> {
    // The receiver never panics while holding the lock; recover the data if it ever did.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// What the state receiver measured (see [`ShellReport`]'s `state_latency_us` and
/// `state_age_us`).
struct StateLatency {
    transport: ipc_types::latency::NsHistogram,
    age: ipc_types::latency::NsHistogram,
}

fn receive_states(
    mut source: services::StateFollower,
    operator: Arc<Mutex<Operator>>,
    stop: &AtomicBool,
    poll_ns: u64,
    spin_ns: u64,
) -> StateLatency {
    let mut latency = StateLatency {
        transport: ipc_types::latency::NsHistogram::new(),
        age: ipc_types::latency::NsHistogram::new(),
    };
    let mut last_seq = 0u64;
    let mut last_pid = 0u32;
    let mut pacer = pacing::StatePacer::new(poll_ns);
    // The pacer aims within microseconds; the default 50 µs timer slack would blur that.
    if !ipc_types::set_thread_timer_slack_ns(1_000) {
        tracing::debug!("cannot set the receiver's timer slack; its polls may be up to 50 µs late");
    }
    while !stop.load(Ordering::Acquire) {
        let s = source.get();
        let seq = s.header.sequence;
        let restarted = s.header.writer_pid != last_pid;
        let new_state = seq != 0 && (seq != last_seq || restarted);
        match source.after_read(new_state) {
            Ok(Some(generation)) => {
                tracing::info!(
                    "following the haptic state of a new loop (generation {generation})"
                );
                lock(&operator).loop_generations += 1;
            }
            Ok(None) => {}
            Err(e) => tracing::warn!("cannot follow a restarted haptic loop: {e}"),
        }
        if new_state {
            let now = ipc_types::monotonic_ns();
            latency
                .age
                .record(now.saturating_sub(s.header.timestamp_ns));
            // A loop older than the stamp publishes 0: nothing to measure.
            if s.published_ns != 0 {
                latency.transport.record(now.saturating_sub(s.published_ns));
            }
            let now = Instant::now();
            let mut op = lock(&operator);
            if !restarted && seq > last_seq + 1 && last_seq != 0 {
                op.skipped += seq - last_seq - 1;
            }
            if s.user_pose.is_valid() {
                op.state = Some(s);
                op.seen_at = Some(now);
            } else {
                op.rejected += 1;
            }
            op.received += 1;
            op.first_at.get_or_insert(now);
            op.last_at = Some(now);
            last_seq = seq;
            last_pid = s.header.writer_pid;
        }
        let stamp = new_state.then_some((seq, s.header.timestamp_ns));
        let next = pacer.next_poll(ipc_types::monotonic_ns(), stamp);
        if spin_ns > 0 && pacer.predicted() {
            // Wake a little early and watch the entry until the state comes or the window
            // closes: the state is read within a microsecond of its write, for about
            // 2 × `spin_ns` of CPU per tick.
            ipc_types::sleep_until_ns(next.saturating_sub(spin_ns));
            let end = next + spin_ns;
            while source.get().header.sequence == seq && ipc_types::monotonic_ns() < end {
                std::hint::spin_loop();
            }
        } else {
            ipc_types::sleep_until_ns(next);
        }
    }
    latency
}

fn make_guidance(
    config: &ShellConfig,
    planner: &Planner,
    q_user: Option<&Se3>,
    op: &Operator,
    seq: u64,
    pid: u32,
) -> Guidance {
    let s = planner.stats();
    let (attractive, mode) = match q_user {
        Some(q) => {
            let fa = planner.attractive_force(q);
            let mode = if planner.solved() {
                GuidanceMode::PATH
            } else {
                GuidanceMode::ROADMAP
            };
            (fa.into(), mode)
        }
        None => ([0.0; 6], GuidanceMode::NONE),
    };
    Guidance {
        header: Header {
            sequence: seq,
            timestamp_ns: ipc_types::monotonic_ns(),
            writer_pid: pid,
            reserved: 0,
        },
        attractive,
        gain_n_per_m: config.gain_n_per_m,
        gain_nm_per_rad: config.gain_nm_per_rad,
        time_to_live_ns: (config.ttl_s * 1e9) as u64,
        state_sequence: op.state.map_or(0, |s| s.header.sequence),
        mode,
        solved: u32::from(planner.solved()),
        iterations: s.iterations,
        nodes: s.nodes as u64,
        trees: s.trees as u32,
        reserved: 0,
        distance_to_goal: s.best_distance_to_goal,
        collision_checks: s.collision_checks,
    }
}

/// Fills a loaned sample in place and sends it; false (and a debug log) when no sample
/// could be loaned or sent: skipped, never waited for.
fn publish_roadmap(
    publisher: &RoadmapPublisher,
    feed: &mut RoadmapFeed,
    planner: &Planner,
    pid: u32,
) -> bool {
    let mut sample = match publisher.loan() {
        Ok(s) => s,
        Err(e) => {
            tracing::debug!("roadmap sample skipped: {e:?}");
            return false;
        }
    };
    let info = FeedInfo {
        iterations: planner.stats().iterations,
        solved: planner.solved(),
        pid,
        timestamp_ns: ipc_types::monotonic_ns(),
    };
    feed.fill(
        planner.trees(),
        planner.tree_ids(),
        info,
        sample.payload_mut(),
    );
    match sample.send() {
        Ok(_) => true,
        Err(e) => {
            tracing::debug!("roadmap sample not sent: {e:?}");
            false
        }
    }
}

/// Sends `g` and wakes the loop's relay thread, which then hands it to the next tick.
fn publish_guidance(publisher: &GuidancePublisher, event: &GuidanceNotifier, g: Guidance) {
    if let Err(e) = publisher.send_copy(g) {
        tracing::warn!("cannot publish guidance: {e:?}");
        return;
    }
    // Without the wake-up the relay still polls: a failed notification only costs latency.
    if let Err(e) = event.notify() {
        tracing::debug!("cannot notify the guidance event: {e:?}");
    }
}

/// The operator input of one haptic state: `q_user` from `user_pose`, and contact (H-RRT-C
/// contact mode) while the loop reports `ContactCode::CONTACT` with a unit normal. `None`
/// when the pose is invalid.
pub fn user_input(s: &HapticState) -> Option<crate::UserInput> {
    let q_user = se3(&s.user_pose)?;
    let v = |a: [f64; 3]| nalgebra::Vector3::new(a[0], a[1], a[2]);
    let normal = v(s.contact_normal);
    let finite = [
        s.contact_normal,
        s.contact_point_m,
        s.operator_force_n,
        s.displacement_m,
    ]
    .iter()
    .flatten()
    .all(|x| x.is_finite());
    let contact = (s.contact == ipc_types::ContactCode::CONTACT
        && finite
        && (normal.norm() - 1.0).abs() < 1e-3)
        .then(|| {
            Some(crate::Contact {
                point_m: v(s.contact_point_m),
                normal,
                force_n: v(s.operator_force_n),
                displacement_m: v(s.displacement_m),
                proxy: se3(&s.proxy_pose)?,
            })
        })
        .flatten();
    Some(crate::UserInput { q_user, contact })
}

/// The planner's pose type from a wire pose; `None` if invalid.
pub fn se3(p: &Pose) -> Option<Se3> {
    ipc_types::convert::isometry(p).map(|iso| Se3::from_isometry(&iso))
}

/// The wire pose of a planner pose.
pub fn pose(q: &Se3) -> Pose {
    ipc_types::convert::pose(&q.to_isometry())
}

/// The solution as a wire [`Path`], resampled to at most [`PATH_CAPACITY`] waypoints by
/// keeping evenly spaced ones (always the first and the last).
fn to_wire_path(sol: &[Se3], planner: &Planner, seq: u64, pid: u32) -> Path {
    let mut path = Path::EMPTY;
    let n = sol.len();
    let keep = n.min(PATH_CAPACITY);
    for i in 0..keep {
        let src = if keep <= 1 {
            0
        } else {
            i * (n - 1) / (keep - 1)
        };
        path.waypoints[i] = pose(&sol[src]);
    }
    path.len = keep as u64;
    path.length = crate::space::path_length(planner.space(), sol);
    path.header = Header {
        sequence: seq,
        timestamp_ns: ipc_types::monotonic_ns(),
        writer_pid: pid,
        reserved: 0,
    };
    path
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contact_state_becomes_contact_input() {
        let mut s = HapticState::default();
        let q = Se3::from_xyz(0.1, 0.0, 0.0);
        s.user_pose = pose(&q);
        s.proxy_pose = pose(&Se3::from_xyz(0.09, 0.0, 0.0));
        let free = user_input(&s).expect("valid");
        assert!(free.contact.is_none() && (free.q_user.pos - q.pos).norm() < 1e-12);
        s.contact = ipc_types::ContactCode::CONTACT;
        s.contact_normal = [-1.0, 0.0, 0.0];
        s.operator_force_n = [3.0, 0.0, 0.0];
        s.displacement_m = [0.0, 0.001, 0.0];
        let c = user_input(&s).expect("valid").contact.expect("contact");
        assert_eq!(c.force_n.x, 3.0);
        assert!((c.proxy.pos.x - 0.09).abs() < 1e-12);
        // A zero normal (not yet filled) or NaN is no contact.
        s.contact_normal = [0.0; 3];
        assert!(user_input(&s).expect("valid").contact.is_none());
        s.contact_normal = [f64::NAN, 0.0, 0.0];
        assert!(user_input(&s).expect("valid").contact.is_none());
    }
}
