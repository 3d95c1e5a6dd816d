//! The contact search's temporal coherence ([`Coherence`]): motion budgets that let it skip
//! what cannot have come within reach since it was last looked at.

use super::near::{ClusterBudget, Scratch};
use super::pointshell::Pointshell;
use nalgebra::{Isometry3, Point3, Vector3};

/// Temporal coherence of the contact search: the whole object, each group, cluster and
/// point carry the total proxy motion (m, any point's worst-case travel, summed over steps)
/// at which they can first come within reach of the surface. Until the running total passes
/// it, they are skipped without a voxmap look-up; a point 5 mm from the wall is looked at
/// again only after the object has moved 1.5–3 mm (a share of its look-ahead staggered by
/// its index, so that points found together are not all due in one tick). Each level of
/// detail keeps its own budgets; one not searched for a while finds them used up and
/// checks again, which is always safe. Preallocated; reset on `place`.
#[derive(Debug, Clone, Default)]
pub(super) struct Coherence {
    /// Running total of the bound on any point's motion, m.
    pub(super) motion_m: f64,
    /// Pose at the last search.
    pub(super) last: Option<Isometry3<f64>>,
    pub(super) object: f64,
    pub(super) levels: Vec<LevelCache>,
    /// Nothing was recorded since it was made or reset: a reset has nothing to forget.
    pub(super) fresh: bool,
}

/// One level of detail's budgets (see [`Coherence`]) and the search's scratch.
#[derive(Debug, Clone, Default)]
pub(super) struct LevelCache {
    pub(super) groups: Vec<ClusterBudget>,
    pub(super) clusters: Vec<ClusterBudget>,
    pub(super) points: Vec<f64>,
    pub(super) scratch: Scratch,
}

impl Coherence {
    pub(super) fn new(shells: &[Pointshell]) -> Self {
        Self {
            motion_m: 0.0,
            last: None,
            object: 0.0,
            levels: shells
                .iter()
                .map(|s| LevelCache {
                    groups: vec![ClusterBudget::default(); s.groups().len()],
                    clusters: vec![ClusterBudget::default(); s.clusters().len()],
                    points: vec![0.0; s.len()],
                    scratch: Scratch::with_capacity(s.groups().len(), s.clusters().len(), s.len()),
                })
                .collect(),
            fresh: true,
        }
    }

    /// Forget everything (the object jumped). O(points) unless nothing was recorded yet:
    /// the stage's first step places its proxy and resets a fresh cache, on the RT thread.
    pub(super) fn reset(&mut self) {
        if self.fresh {
            return;
        }
        self.fresh = true;
        self.motion_m = 0.0;
        self.last = None;
        self.object = 0.0;
        for l in &mut self.levels {
            l.groups.fill(ClusterBudget::default());
            l.clusters.fill(ClusterBudget::default());
            l.scratch.reset();
            l.points.fill(0.0);
        }
    }

    /// Adds the motion from the last search to `pose`: the centre of mass's travel plus
    /// the rotation angle times the object's radius about it bounds every point's travel.
    pub(super) fn advance(
        &mut self,
        pose: &Isometry3<f64>,
        com_local: &Vector3<f64>,
        radius_m: f64,
    ) {
        self.fresh = false;
        if let Some(last) = self.last {
            let c0 = last.transform_point(&Point3::from(*com_local));
            let c1 = pose.transform_point(&Point3::from(*com_local));
            let angle = last.rotation.angle_to(&pose.rotation);
            self.motion_m += (c1 - c0).norm() + angle * radius_m;
        }
        self.last = Some(*pose);
    }
}
