//! The contact search and force pass over the points that may be near the surface
//! ([`ShellColumns::search`]).
//!
//! 1. *Candidates*: the clusters that may be near the surface ([`ShellColumns::near_clusters`],
//!    which also counts their points, so the caller can keep to its budget), then those of
//!    their points whose motion budget is used up (see `Coherence`), as a list of point
//!    indices. Each level of detail of the pointshell has its own columns and budgets.
//! 2. *Look-up*: [`LANES`] candidates at a time are moved into the scene and looked up in
//!    the voxmap; their budgets are renewed.
//! 3. *Force pass* ([`force_chunk`], in `force`), in the same chunk, for those within reach of a
//!    surface they face: penalty, braking and the implicit step's JᵀJ sums, each point's
//!    terms times its weight (the level-0 points it stands for), without branches.
//!
//! Steps 2 and 3 are written twice: lane by lane, each statement over all lanes and
//! choices as selections ([`ShellColumns::chunks`], portable, and the reference), and in
//! AVX2 registers with gathers ([`avx2`]), the same operations in the same order, so the
//! same bits (tested). The CPU's choice is made at run time. They compute in `f32` (twice
//! the lanes of `f64`):
//! positions relative to the scene's origin or the centre of mass are below a metre, where
//! `f32` resolves 0.1 µm, far below the voxmap's 1/256-voxel quantisation; sums are
//! returned in `f64`.

use super::lanes::{LANES, Lanes, axes, lanes};
use super::pointshell::{Cluster, ClusterGroup, Pointshell};
use super::voxmap::Voxmap;
use crate::work::{Allowance, ContactWork};

/// Calls `$m!($args; i: a b, ...)` with the 21 pairs (a, b) of J's rows whose products
/// JJᵀ's upper triangle sums, at their index i in [`JtJ`](super::jtj::JtJ)'s layout (see `PAIRS`): the
/// force passes spell the sums out pair by pair with constant indices, since a loop over
/// the pairs stays rolled and reads J back from memory.
macro_rules! jj_pairs {
    ($m:ident!($($args:tt)*)) => {
        $m!($($args)*; 0: 0 0, 1: 0 1, 2: 0 2, 3: 1 1, 4: 1 2, 5: 2 2,
            6: 3 0, 7: 3 1, 8: 3 2, 9: 4 0, 10: 4 1, 11: 4 2,
            12: 5 0, 13: 5 1, 14: 5 2,
            15: 3 3, 16: 3 4, 17: 3 5, 18: 4 4, 19: 4 5, 20: 5 5)
    };
}

#[cfg(target_arch = "x86_64")]
mod avx2;
mod force;
#[cfg(target_arch = "x86_64")]
use force::Sums;
use force::{Accumulators, ForceConsts, force_chunk};
pub(super) use force::{PassParams, Totals};
use nalgebra::{Matrix3, Vector3};

/// The upper triangle of a symmetric 6×6 matrix, in [`JtJ`](super::jtj::JtJ)'s layout (the force pass
/// spells the same list out): `nn` (6), `mn` (9), `mm` (6), with J = [n; m] as indices 0..3
/// and 3..6.
#[cfg(test)]
const PAIRS: [(usize, usize); 21] = [
    (0, 0),
    (0, 1),
    (0, 2),
    (1, 1),
    (1, 2),
    (2, 2),
    (3, 0),
    (3, 1),
    (3, 2),
    (4, 0),
    (4, 1),
    (4, 2),
    (5, 0),
    (5, 1),
    (5, 2),
    (3, 3),
    (3, 4),
    (3, 5),
    (4, 4),
    (4, 5),
    (5, 5),
];

/// The pointshell (one level of detail) as the search reads it: object-frame points (m),
/// inward normals and weights as `f32` columns, in the pointshell's order, and its
/// clusters and groups.
#[derive(Debug, Clone)]
pub(super) struct ShellColumns {
    point: [Vec<f32>; 3],
    normal: [Vec<f32>; 3],
    weight: Vec<f32>,
    /// Per point, the share of its look-ahead its budget takes ([`stagger`]).
    stagger: Vec<f32>,
    clusters: Vec<Cluster>,
    groups: Vec<ClusterGroup>,
}

/// A share in [0.5, 1) for item `index`, golden-ratio steps spreading the indices evenly
/// over it: a budget renewed at `ahead · stagger(index)` instead of `ahead` comes due
/// earlier (always safe), and items found together (the points of clusters that came near
/// in one tick, with about the same clearance) come due at different ticks instead of in
/// one burst of look-ups.
fn stagger(index: usize) -> f64 {
    0.5 + 0.5 * (index as f64 * 0.618_033_988_749_895).fract()
}

/// Where the search runs.
#[derive(Debug, Clone, Copy)]
pub(super) struct SearchParams {
    /// Rotation of the object frame into the scene frame.
    pub rotation: Matrix3<f64>,
    /// Origin of the object frame in the scene frame, m.
    pub translation: Vector3<f64>,
    /// Points farther from the surface than this are not kept, m.
    pub reach_m: f64,
    /// The running motion total of the budgets (see `Coherence`), m.
    pub moved_m: f64,
}

/// A group's or cluster's motion budget (see `Coherence`): until the running motion total reaches
/// `check_at` (m), a far cluster is skipped and a `near` one has its points looked at
/// without a new clearance check.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct ClusterBudget {
    pub check_at: f64,
    pub near: bool,
}

/// The search's scratch: the near clusters' and the candidate points' indices, and what a
/// near pass keeps for the next (its list and each group's part of it). Room for every
/// group, cluster and point of the shell, allocated once, so the search never allocates.
#[derive(Debug, Clone, Default)]
pub(super) struct Scratch {
    near: Vec<u32>,
    near_count: usize,
    /// The previous near pass's list (swapped with `near` at each pass).
    previous: Vec<u32>,
    /// Per group: where its near clusters are in the list of the pass that wrote it.
    spans: Vec<Span>,
    /// Per group: the least budget (`check_at`, m) of its clusters at its last visit of
    /// them: until the motion total reaches it, none of them is due, and its near clusters
    /// are the ones it listed then.
    members_check_at: Vec<f64>,
    /// Near passes run on this level (their number stamps the spans they write).
    passes: u32,
    candidates: Vec<u32>,
}

/// A group's near clusters in a near pass's list.
#[derive(Debug, Clone, Copy, Default)]
struct Span {
    /// The pass that wrote it; only the previous pass's spans index `Scratch::previous`.
    pass: u32,
    start: u32,
    len: u32,
    /// Points of those clusters.
    points: u32,
}

impl Scratch {
    /// Pads the first `count` candidates to whole chunks with copies of the first one and
    /// returns the padded length. Padding lanes repeat the first candidate's look-up bit
    /// for bit (so they store its budget again) and are never kept (it would count twice).
    fn pad(&mut self, count: usize) -> usize {
        let padded = count.div_ceil(LANES) * LANES;
        let filler = self.candidates.first().copied().unwrap_or(0);
        self.candidates[count..padded].fill(filler);
        padded
    }

    /// Room for `groups` groups, `clusters` clusters and `points` points.
    pub(super) fn with_capacity(groups: usize, clusters: usize, points: usize) -> Self {
        Self {
            near: vec![0; clusters],
            near_count: 0,
            previous: vec![0; clusters],
            spans: vec![Span::default(); groups],
            members_check_at: vec![0.0; groups],
            passes: 0,
            candidates: vec![0; points.div_ceil(LANES) * LANES],
        }
    }

    /// Forgets what the passes kept (the budgets were reset: every member is due).
    pub(super) fn reset(&mut self) {
        self.near_count = 0;
        self.members_check_at.fill(0.0);
    }
}

/// A point is left out when its inward normal turns away from the surface's normal (the
/// field's gradient) by more than 120°, i.e. n·ĝ < −`AWAY_COS`: such points are on the far
/// side of the object after it tunnelled through a thin feature and would pull it further
/// in. Not 90°: at an edge of the object the points of the face perpendicular to the
/// surface have n·ĝ ≈ 0, and a cut at 0 let a rotation of a hundredth of a degree drop a
/// whole row of them while they were a voxel deep (seen on the crossing planes, where the
/// object's edge then sank into a slot's side).
pub(super) const AWAY_COS: f32 = 0.5;

/// What one search found.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub(super) struct Found {
    /// The sums of the force pass.
    pub totals: Totals,
    /// Points looked up in the voxmap.
    pub tested: u32,
    /// Points within reach of a surface they face.
    pub near: u32,
    /// How far past their budgets the object has moved for the points the search and its
    /// near pass left undone (see [`NearPass::overdue_m`]): 0 when nothing was, infinite
    /// when near points may have been (a near cluster not scanned, a due point not looked
    /// up).
    pub overdue_m: f64,
}

impl ShellColumns {
    pub(super) fn new(shell: &Pointshell) -> Self {
        // The search's gathers rely on it (see `gather`).
        let points = shell.points().len();
        assert!(
            shell
                .clusters()
                .iter()
                .all(|c| c.start <= c.end && c.end as usize <= points),
            "clusters index the pointshell's points"
        );
        let column = |v: &[Vector3<f64>], a: usize| v.iter().map(|p| p[a] as f32).collect();
        Self {
            point: std::array::from_fn(|a| column(shell.points(), a)),
            normal: std::array::from_fn(|a| column(shell.normals(), a)),
            // Weights are whole numbers below 2^24: exact in f32.
            weight: shell.weights().iter().map(|&w| w as f32).collect(),
            stagger: (0..points).map(|i| stagger(i) as f32).collect(),
            clusters: shell.clusters().to_vec(),
            groups: shell.groups().to_vec(),
        }
    }

    /// Step 1a: the groups, then the clusters of near groups, whose budgets in
    /// `group_budgets` and `cluster_budgets` are used up are checked against the voxmap's
    /// clearance and their budgets renewed; the clusters that may be within reach are
    /// listed in `scratch`.
    ///
    /// The pass draws on the tick's `allow`ance: at most `max_checks` clearance checks
    /// (and what the allowance has left), a compare per group and cluster it visits. Past
    /// the checks it goes on visiting without checking: a due group or cluster then keeps
    /// what its last check found, and the pass says how far past its budget the object has
    /// moved ([`NearPass::overdue_m`]); one that was near stays listed. Past the compares
    /// it stops, and nothing is known of the rest. What it checked keeps its renewed
    /// budget, so the next call skips it by a compare: a level not searched for a while
    /// (every budget used up) is brought up to date over several ticks instead of in one.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn near_clusters(
        &self,
        group_budgets: &mut [ClusterBudget],
        cluster_budgets: &mut [ClusterBudget],
        k: &SearchParams,
        vox: &Voxmap,
        scratch: &mut Scratch,
        max_checks: u32,
        allow: &mut Allowance,
        work: &mut ContactWork,
    ) -> NearPass {
        let mut points = 0;
        let mut count = 0;
        let mut visit = Visit {
            max_checks: max_checks.min(allow.checks),
            checks: 0,
            compares: 0,
            max_compares: allow.compares,
            unchecked: false,
            overdue_m: 0.0,
        };
        // The last pass's list becomes `previous`; this pass writes `near`.
        std::mem::swap(&mut scratch.near, &mut scratch.previous);
        scratch.passes = scratch.passes.wrapping_add(1);
        let (pass, moved) = (scratch.passes, k.moved_m);
        let mut stopped = false;
        'groups: for (g, (group, budget)) in
            self.groups.iter().zip(group_budgets.iter_mut()).enumerate()
        {
            let Some(near) = visit.sphere(budget, g, &group.centre, group.radius_m, k, vox) else {
                stopped = true;
                break;
            };
            let start = count as u32;
            if !near {
                // Its members are not visited while it is far: when it is near again they
                // are, whatever their budgets.
                scratch.members_check_at[g] = f64::NEG_INFINITY;
                scratch.spans[g] = Span {
                    pass,
                    start,
                    len: 0,
                    points: 0,
                };
                continue;
            }
            let last = scratch.spans[g];
            if last.pass == pass.wrapping_sub(1) && moved < scratch.members_check_at[g] {
                // No member is due: its near clusters are those the last pass listed.
                let from = last.start as usize..(last.start + last.len) as usize;
                if !visit.compare(last.len) {
                    stopped = true;
                    break;
                }
                scratch.near[count..count + from.len()].copy_from_slice(&scratch.previous[from]);
                count += last.len as usize;
                points += last.points;
                scratch.spans[g] = Span {
                    pass,
                    start,
                    ..last
                };
                continue;
            }
            let range = group.start as usize..group.end as usize;
            let members = self.clusters[range.clone()]
                .iter()
                .zip(&mut cluster_budgets[range.clone()]);
            let mut members_check_at = f64::INFINITY;
            let mut span_points = 0;
            for (index, (cl, budget)) in range.zip(members) {
                let Some(near) = visit.sphere(budget, index, &cl.centre, cl.radius_m, k, vox)
                else {
                    stopped = true;
                    break 'groups;
                };
                members_check_at = members_check_at.min(budget.check_at);
                if near {
                    scratch.near[count] = index as u32;
                    count += 1;
                    span_points += cl.end - cl.start;
                }
            }
            points += span_points;
            scratch.members_check_at[g] = members_check_at;
            scratch.spans[g] = Span {
                pass,
                start,
                len: count as u32 - start,
                points: span_points,
            };
        }
        scratch.near_count = count;
        work.near_passes += 1;
        work.checks += visit.checks;
        work.compares += visit.compares;
        allow.checks -= visit.checks;
        allow.compares -= visit.compares;
        NearPass {
            points,
            whole: !stopped && !visit.unchecked,
            overdue_m: if stopped {
                f64::INFINITY
            } else {
                visit.overdue_m
            },
            compares: visit.compares,
        }
    }

    /// The search and the force pass over the near clusters [`Self::near_clusters`] listed
    /// in `scratch`: their points whose own budget (`point_budgets`) is used up are looked
    /// up in the voxmap and their budgets renewed; those within reach of a surface they
    /// face go through the force pass ([`force_chunk`]) in the same chunk, with their
    /// weights. Draws on `allow` (a compare per point of the near clusters, a look-up per
    /// lane); what it leaves undone makes [`Found::overdue_m`] infinite.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn search(
        &self,
        point_budgets: &mut [f64],
        k: &SearchParams,
        pass: &PassParams,
        vox: &Voxmap,
        scratch: &mut Scratch,
        allow: &mut Allowance,
        work: &mut ContactWork,
    ) -> Found {
        let (due, scanned) = self.candidates(point_budgets, k, scratch, allow, work);
        work.searches += 1;
        let count = due.min(lanes_within(allow.look_ups));
        let mut found = self.look_up(count, point_budgets, k, pass, vox, scratch, allow, work);
        if !scanned || count < due {
            found.overdue_m = f64::INFINITY;
        }
        found
    }

    /// Renews the budgets of at most `max` of the points [`Self::search`] would look at
    /// (those of the near clusters a whole near pass listed in `scratch`), starting `skip`
    /// places into their list (cyclically, so that calls with a growing `skip` reach every
    /// one), and returns how many were due. What they would render is dropped: this brings
    /// a level about to be blended in up to date, so that its first search looks at the
    /// points within reach and not at every point of its near clusters (see `LevelChooser`).
    /// Draws on `allow` as the search does.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn renew_points(
        &self,
        point_budgets: &mut [f64],
        k: &SearchParams,
        pass: &PassParams,
        vox: &Voxmap,
        scratch: &mut Scratch,
        skip: u32,
        max: u32,
        allow: &mut Allowance,
        work: &mut ContactWork,
    ) -> u32 {
        let (due, _) = self.candidates(point_budgets, k, scratch, allow, work);
        let count = due.min(max as usize).min(lanes_within(allow.look_ups));
        if count < due {
            scratch.candidates[..due].rotate_left(skip as usize % due);
        }
        self.look_up(count, point_budgets, k, pass, vox, scratch, allow, work);
        due as u32
    }

    /// Steps 2 and 3 over the first `count` candidates in `scratch` (padded to whole
    /// chunks here; `count` leaves room for the padding in `allow`).
    #[allow(clippy::too_many_arguments)]
    fn look_up(
        &self,
        count: usize,
        point_budgets: &mut [f64],
        k: &SearchParams,
        pass: &PassParams,
        vox: &Voxmap,
        scratch: &mut Scratch,
        allow: &mut Allowance,
        work: &mut ContactWork,
    ) -> Found {
        let padded = scratch.pad(count);
        work.look_ups += padded as u32;
        allow.look_ups -= padded as u32;
        let chunks = Chunks {
            candidates: &scratch.candidates[..padded],
            count,
            weight: &self.weight,
            search: k,
            force: ForceConsts::new(pass),
            com: pass.com.map(|x| x as f32),
        };
        #[cfg(target_arch = "x86_64")]
        let (acc, kept) = if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            unsafe { avx2::chunks(self, &chunks, point_budgets, vox) }
        } else {
            self.chunks(&chunks, point_budgets, vox)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let (acc, kept) = self.chunks(&chunks, point_budgets, vox);
        Found {
            totals: acc.reduce(pass),
            tested: count as u32,
            near: kept,
            overdue_m: 0.0,
        }
    }

    /// Step 1b: lists the points of the near clusters in `scratch` whose budget is used up
    /// and returns their number, and whether every near cluster was scanned: a compare per
    /// point, while `allow` has them.
    fn candidates(
        &self,
        point_budgets: &[f64],
        k: &SearchParams,
        scratch: &mut Scratch,
        allow: &mut Allowance,
        work: &mut ContactWork,
    ) -> (usize, bool) {
        let moved = k.moved_m;
        let mut count = 0;
        let mut scanned = 0;
        let mut whole = true;
        for &c in &scratch.near[..scratch.near_count] {
            let cl = &self.clusters[c as usize];
            let n = cl.end - cl.start;
            if scanned + n > allow.compares {
                whole = false;
                break;
            }
            scanned += n;
            // Branch-free: every index is written, and kept by advancing `count`
            // (`count` ≤ the points seen so far, so the write stays in the list).
            let budgets = &point_budgets[cl.start as usize..cl.end as usize];
            for (i, budget) in (cl.start..cl.end).zip(budgets) {
                scratch.candidates[count] = i;
                count += usize::from(moved >= *budget);
            }
        }
        work.compares += scanned;
        allow.compares -= scanned;
        (count, whole)
    }

    /// Steps 2 and 3, lane by lane (see the module docs); [`avx2::chunks`] is the same in
    /// AVX2 registers. Returns the force pass's sums and the number of points kept.
    fn chunks(&self, c: &Chunks, point_budgets: &mut [f64], vox: &Voxmap) -> (Accumulators, u32) {
        let k = c.search;
        let moved = k.moved_m;
        let mut acc = Accumulators::default();
        let mut kept = 0;
        let r: [[f32; 3]; 3] =
            std::array::from_fn(|a| std::array::from_fn(|b| k.rotation[(a, b)] as f32));
        let t = k.translation.map(|x| x as f32);
        let reach = k.reach_m as f32;
        for (chunk, idx) in c.candidates.chunks_exact(LANES).enumerate() {
            let x: [Lanes; 3] = axes(|a| lanes(|l| self.point[a][idx[l] as usize]));
            let nl: [Lanes; 3] = axes(|a| lanes(|l| self.normal[a][idx[l] as usize]));
            let rotate = |v: &[Lanes; 3], a: usize| {
                let [r0, r1, r2] = r[a];
                lanes(|l| r0 * v[0][l] + r1 * v[1][l] + r2 * v[2][l])
            };
            let p: [Lanes; 3] = axes(|a| {
                let rx = rotate(&x, a);
                lanes(|l| rx[l] + t[a])
            });
            let n: [Lanes; 3] = axes(|a| rotate(&nl, a));
            let s = vox.sample_lanes(&p);
            let g = &s.gradient;
            let g2 = lanes(|l| g[0][l] * g[0][l] + g[1][l] * g[1][l] + g[2][l] * g[2][l]);
            let facing = lanes(|l| n[0][l] * g[0][l] + n[1][l] * g[1][l] + n[2][l] * g[2][l]);
            let stored = lanes(|l| s.stored[l] != 0);
            // Within reach; a direction (the field is flat midway inside a thin plate);
            // not turned away from the surface (see `AWAY_COS`); not padding.
            let real = c.count - chunk * LANES;
            let keep = lanes(|l| {
                stored[l]
                    & (s.distance_m[l] < reach)
                    & (g2[l] >= 1e-18)
                    & (facing[l] + AWAY_COS * g2[l].sqrt() >= 0.0)
                    & (l < real)
            });
            // The budget: the distance the point can move before it may be in reach, a
            // staggered share of it (see `stagger`).
            let ahead = lanes(|l| {
                let ahead = if stored[l] {
                    s.distance_m[l] - reach
                } else {
                    s.clearance_m[l] - reach
                };
                ahead * self.stagger[idx[l] as usize]
            });
            for l in 0..LANES {
                point_budgets[idx[l] as usize] = moved + f64::from(ahead[l]);
            }
            if keep.iter().any(|&k| k) {
                kept += keep.iter().filter(|&&k| k).count() as u32;
                // Lanes not kept become points beyond every layer with a unit gradient:
                // every selection in the force pass is false for them.
                let r = axes(|a| lanes(|l| if keep[l] { p[a][l] - c.com[a] } else { 0.0 }));
                let unit = |a: usize| if a == 0 { 1.0 } else { 0.0 };
                let g = axes(|a| lanes(|l| if keep[l] { g[a][l] } else { unit(a) }));
                let sd = lanes(|l| {
                    if keep[l] {
                        s.distance_m[l]
                    } else {
                        f32::INFINITY
                    }
                });
                let w = lanes(|l| c.weight[idx[l] as usize]);
                force_chunk(&mut acc, &r, &g, &sd, &w, &c.force);
            }
        }
        (acc, kept)
    }
}

/// The most points whole chunks of lanes can hold within `look_ups` lanes.
fn lanes_within(look_ups: u32) -> usize {
    look_ups as usize / LANES * LANES
}

/// What one near pass found (see [`ShellColumns::near_clusters`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct NearPass {
    /// Points of the clusters it listed.
    pub points: u32,
    /// Whether it checked every group and cluster whose budget was used up: only then does
    /// its list hold every cluster that may be within reach.
    pub whole: bool,
    /// How far (m, in the budgets' measure of motion) the object has moved past the budget
    /// of the farthest-overdue group or cluster it left unchecked that was not near at its
    /// last check; infinite if it stopped before visiting them all. Every point of such a
    /// group or cluster is at least the reach minus this from the surface (see
    /// `ContactStage::bound_travel`).
    pub overdue_m: f64,
    /// Compares it drew.
    pub compares: u32,
}

/// A near pass's visits of groups and clusters, and what it drew from the allowance.
struct Visit {
    max_checks: u32,
    checks: u32,
    /// Visits without a check.
    compares: u32,
    max_compares: u32,
    /// Some due group or cluster was left unchecked.
    unchecked: bool,
    overdue_m: f64,
}

impl Visit {
    /// Draws `n` compares (copying a group's listed clusters), if they are left.
    fn compare(&mut self, n: u32) -> bool {
        if self.compares + n > self.max_compares {
            return false;
        }
        self.compares += n;
        true
    }

    /// Whether a sphere of `radius_m` about `centre` (object frame) may be within reach,
    /// by its `budget`: when the budget is used up, checked against the voxmap's clearance
    /// and the budget renewed, while checks are left; past them, what the last check found.
    /// `None` once the compares are used up (the sphere is not visited). A near sphere is
    /// checked again only after moving between half a reach and a reach, staggered by its
    /// `index` so that the near spheres of a sliding contact, found together, are not all
    /// checked again in one tick: what a near sphere holds carries its own budgets, so any
    /// check interval costs compares, never a missed contact.
    #[inline(always)]
    fn sphere(
        &mut self,
        budget: &mut ClusterBudget,
        index: usize,
        centre: &Vector3<f64>,
        radius_m: f64,
        k: &SearchParams,
        vox: &Voxmap,
    ) -> Option<bool> {
        let moved = k.moved_m;
        if moved < budget.check_at || self.checks >= self.max_checks {
            if self.compares >= self.max_compares {
                return None;
            }
            self.compares += 1;
            if moved >= budget.check_at {
                self.unchecked = true;
                if !budget.near {
                    self.overdue_m = self.overdue_m.max(moved - budget.check_at);
                }
            }
            return Some(budget.near);
        }
        self.checks += 1;
        let centre = k.rotation * centre + k.translation;
        let slack = vox.clearance(&centre) - radius_m - k.reach_m;
        budget.near = slack <= 0.0;
        budget.check_at = moved
            + if budget.near {
                k.reach_m * stagger(index)
            } else {
                slack
            };
        Some(budget.near)
    }
}

/// What steps 2 and 3 work on.
struct Chunks<'a> {
    /// Candidate point indices, padded to whole chunks (see [`ShellColumns::candidates`]).
    candidates: &'a [u32],
    /// Real candidates.
    count: usize,
    /// The weights, one per point.
    weight: &'a [f32],
    search: &'a SearchParams,
    force: ForceConsts,
    /// Centre of mass, scene frame, m.
    com: Vector3<f32>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::jtj::JtJ;
    use nalgebra::Vector6;

    /// A point for the force pass: position, gradient, signed distance (m), weight.
    type TestPoint = (Vector3<f64>, Vector3<f64>, f64, f64);

    /// [`force_chunk`] over `points`, chunk by chunk, the last one padded as the search
    /// pads it.
    fn force_pass(points: &[TestPoint], k: &PassParams) -> Totals {
        let consts = ForceConsts::new(k);
        let mut acc = Accumulators::default();
        for chunk in points.chunks(LANES) {
            let at = |l: usize| chunk.get(l);
            let r = axes(|a| lanes(|l| at(l).map_or(0.0, |(p, _, _, _)| (p[a] - k.com[a]) as f32)));
            let g = axes(|a| {
                lanes(|l| at(l).map_or(if a == 0 { 1.0 } else { 0.0 }, |(_, g, _, _)| g[a] as f32))
            });
            let sd = lanes(|l| at(l).map_or(f32::INFINITY, |(_, _, sd, _)| *sd as f32));
            let w = lanes(|l| at(l).map_or(1.0, |(_, _, _, w)| *w as f32));
            force_chunk(&mut acc, &r, &g, &sd, &w, &consts);
        }
        acc.reduce(k)
    }

    /// The same sums point by point, written the obvious way: each point's terms times its
    /// weight.
    fn reference(points: &[TestPoint], k: &PassParams) -> Totals {
        let mut t = Totals::default();
        let mut contacts = 0.0;
        let mut braking = 0.0;
        for &(ref p, ref g, ref sd, w) in points {
            let n = g.normalize();
            let m = (p - k.com).cross(&n);
            let vn = k.velocity.dot(&n) + k.angular_velocity.dot(&m);
            let jv = Vector6::new(n.x, n.y, n.z, m.x, m.y, m.z);
            let add = |jj: &mut JtJ, w: f64| {
                let full = jv * jv.transpose() * w;
                for (i, &(a, b)) in PAIRS.iter().enumerate() {
                    match i {
                        0..6 => jj.nn[i] += full[(a, b)],
                        6..15 => jj.mn[i - 6] += full[(a, b)],
                        _ => jj.mm[i - 15] += full[(a, b)],
                    }
                }
            };
            if *sd < 0.0 {
                let d = -sd;
                let push =
                    (k.point_stiffness_n_per_m * d - k.contact_damping_n_s_per_m * vn).max(0.0);
                t.wrench += jv * push * w;
                add(&mut t.contact_jj, w);
                add(&mut t.damping_jj, k.contact_damping_n_s_per_m * w);
                contacts += w;
                t.weighted_point += w * d * (p + d * n);
                t.weight += w * d;
                t.normal_sum += w * d * n;
                t.max_depth = t.max_depth.max(d);
            } else if *sd < k.proximity_m && vn < 0.0 {
                let b = w * (1.0 - sd / k.proximity_m);
                t.wrench += jv * (-k.braking_n_s_per_m * b * vn);
                add(&mut t.damping_jj, k.braking_n_s_per_m * b);
                braking += w;
            }
            t.within_release |= *sd < k.release_m;
        }
        t.contacts = contacts as u32;
        t.braking_points = braking as u32;
        t
    }

    #[test]
    fn lanes_agree_with_the_point_by_point_sums() {
        let k = PassParams {
            com: Vector3::new(0.21, -0.12, 0.33),
            velocity: Vector3::new(0.05, -0.1, 0.02),
            angular_velocity: Vector3::new(0.3, 0.1, -0.2),
            point_stiffness_n_per_m: 2000.0,
            contact_damping_n_s_per_m: 0.5,
            braking_n_s_per_m: 0.2,
            proximity_m: 0.002,
            release_m: 0.0005,
        };
        // 19 points (not a multiple of LANES): penetrating, braking, receding, far.
        let points: Vec<_> = (0..19)
            .map(|i| {
                let f = f64::from(i);
                let p = k.com + Vector3::new(0.01 * f.sin(), 0.02 * f.cos(), 0.003 * f - 0.03);
                let g = Vector3::new(0.3 + 0.1 * f, 1.0 - 0.05 * f, (0.7 * f).sin());
                let sd = -0.001 + 0.00017 * f;
                // Weights as the levels give them: whole numbers of level-0 points.
                let w = f64::from(1 + (i % 4) * 5);
                (p, g, sd, w)
            })
            .collect();
        let got = force_pass(&points, &k);
        let want = reference(&points, &k);
        {
            assert_eq!(got.contacts, want.contacts);
            assert_eq!(got.braking_points, want.braking_points);
            assert!(want.contacts > 0 && want.braking_points > 0);
            assert_eq!(got.within_release, want.within_release);
            // f32 arithmetic: relative to the size of each quantity.
            let check = |what: &str, got: &[f64], want: &[f64]| {
                let scale = want.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
                assert!(scale > 0.0, "{what} is all zero");
                for (g, w) in got.iter().zip(want) {
                    assert!((g - w).abs() <= 1e-5 * scale, "{what}: {got:?} vs {want:?}");
                }
            };
            check("wrench", got.wrench.as_slice(), want.wrench.as_slice());
            for (name, g, w) in [
                ("contact JJ", &got.contact_jj, &want.contact_jj),
                ("damping JJ", &got.damping_jj, &want.damping_jj),
            ] {
                check(name, &[g.nn, g.mm].concat(), &[w.nn, w.mm].concat());
                check(name, &g.mn, &w.mn);
            }
            check(
                "weighted point",
                got.weighted_point.as_slice(),
                want.weighted_point.as_slice(),
            );
            check(
                "normal sum",
                got.normal_sum.as_slice(),
                want.normal_sum.as_slice(),
            );
            check("weight", &[got.weight], &[want.weight]);
            check("max depth", &[got.max_depth], &[want.max_depth]);
        }
    }

    #[test]
    fn nothing_near_sums_to_zero() {
        let k = PassParams {
            com: Vector3::zeros(),
            velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
            point_stiffness_n_per_m: 1.0,
            contact_damping_n_s_per_m: 1.0,
            braking_n_s_per_m: 1.0,
            proximity_m: 1.0,
            release_m: 1.0,
        };
        assert_eq!(force_pass(&[], &k), Totals::default());
    }

    /// Every sum of `acc`, as bits.
    fn bits(acc: &Accumulators) -> Vec<u32> {
        let Accumulators {
            wrench,
            k,
            b,
            point,
            normal,
            weight,
            max_depth,
            contacts,
            braking,
            release,
        } = acc;
        [wrench.as_slice(), k, b, point, normal]
            .into_iter()
            .flatten()
            .chain([weight, max_depth, contacts, braking, release])
            .flatten()
            .map(|x| x.to_bits())
            .collect()
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_chunks_give_the_same_bits_as_the_lane_by_lane_ones() {
        use nalgebra::{Isometry3, Translation3, UnitQuaternion};
        use parry3d_f64::math::Pose;
        use parry3d_f64::shape::SharedShape;
        use rand::{Rng, SeedableRng};
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("no AVX2 on this CPU: nothing to compare");
            return;
        }
        // A 40 mm cube over a slab whose top face is z = 0, at 1 mm.
        let slab = [(
            Pose::translation(0.0, 0.0, -0.01),
            SharedShape::cuboid(0.1, 0.1, 0.01),
        )];
        let vox = Voxmap::build(&slab, &super::super::voxmap::VoxmapConfig::default()).unwrap();
        let cube = [(Pose::IDENTITY, SharedShape::cuboid(0.02, 0.02, 0.02))];
        let levels: Vec<ShellColumns> = Pointshell::build(&cube, 0.001)
            .unwrap()
            .with_coarser()
            .iter()
            .map(ShellColumns::new)
            .collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let (mut contacts, mut braking) = (0.0, 0.0);
        for _ in 0..200 {
            // Every level of detail, weights and all.
            let shell = &levels[rng.random_range(0..levels.len())];
            let points = shell.point[0].len();
            // Tilted a little, its lowest corner between 2 mm above and 1.5 mm into the
            // slab: penetrating, braking and far points together.
            let rotation = UnitQuaternion::from_euler_angles(
                rng.random_range(-0.3..0.3),
                rng.random_range(-0.3..0.3),
                rng.random_range(-3.0..3.0),
            );
            let lowest = (0..points)
                .map(|i| {
                    (rotation * Vector3::from(shell.point.each_ref().map(|c| f64::from(c[i])))).z
                })
                .fold(f64::INFINITY, f64::min);
            let z = rng.random_range(-0.0015..0.002) - lowest;
            let pose = Isometry3::from_parts(
                Translation3::new(
                    rng.random_range(-0.05..0.05),
                    rng.random_range(-0.05..0.05),
                    z,
                ),
                rotation,
            );
            let k = SearchParams {
                rotation: pose.rotation.to_rotation_matrix().into_inner(),
                translation: pose.translation.vector,
                reach_m: 0.003,
                moved_m: 0.0,
            };
            let pass = PassParams {
                com: pose.translation.vector,
                velocity: Vector3::from_fn(|_, _| rng.random_range(-0.2..0.2)),
                angular_velocity: Vector3::from_fn(|_, _| rng.random_range(-2.0..2.0)),
                point_stiffness_n_per_m: 2000.0,
                contact_damping_n_s_per_m: 0.5,
                braking_n_s_per_m: 0.2,
                proximity_m: 0.002,
                release_m: 0.0005,
            };
            let mut scratch =
                Scratch::with_capacity(shell.groups.len(), shell.clusters.len(), points);
            let mut groups = vec![ClusterBudget::default(); shell.groups.len()];
            let mut clusters = vec![ClusterBudget::default(); shell.clusters.len()];
            let mut budgets = vec![0.0; points];
            let work = &mut ContactWork::default();
            let allow = &mut Allowance::uncapped();
            shell.near_clusters(
                &mut groups,
                &mut clusters,
                &k,
                &vox,
                &mut scratch,
                u32::MAX,
                allow,
                work,
            );
            let (count, _) = shell.candidates(&budgets, &k, &mut scratch, allow, work);
            let padded = scratch.pad(count);
            let chunks = Chunks {
                candidates: &scratch.candidates[..padded],
                count,
                weight: &shell.weight,
                search: &k,
                force: ForceConsts::new(&pass),
                com: pass.com.map(|x| x as f32),
            };
            let mut budgets_avx2 = budgets.clone();
            let (plain, kept) = shell.chunks(&chunks, &mut budgets, &vox);
            // SAFETY: the CPU has AVX2, checked above.
            let (fast, kept_avx2) =
                unsafe { avx2::chunks(shell, &chunks, &mut budgets_avx2, &vox) };
            assert_eq!(kept, kept_avx2);
            assert_eq!(bits(&plain), bits(&fast));
            assert_eq!(
                budgets.iter().map(|b| b.to_bits()).collect::<Vec<_>>(),
                budgets_avx2.iter().map(|b| b.to_bits()).collect::<Vec<_>>()
            );
            let totals = plain.reduce(&pass);
            contacts += f64::from(totals.contacts);
            braking += f64::from(totals.braking_points);
        }
        assert!(
            contacts > 1000.0 && braking > 1000.0,
            "{contacts} contacts, {braking} braking"
        );
    }
}
