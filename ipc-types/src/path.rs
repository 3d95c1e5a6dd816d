//! [`Path`]: the planner's solution.

use crate::{Header, Pose};
use iceoryx2::prelude::ZeroCopySend;

/// Most waypoints a [`Path`] carries. A longer solution is resampled by the planner to fit.
pub const PATH_CAPACITY: usize = 512;

/// A solution path of the moving object's reference point, start to goal, scene frame.
///
/// Semantics: event-like with history 1 (see [`crate::services::PATH`]): published when a
/// solution is found or improved; a late subscriber still receives the newest one.
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("hrrtc::Path.v1")]
pub struct Path {
    /// Sequence from 1 per planner process.
    pub header: Header,
    /// Number of valid entries in `waypoints`, at most [`PATH_CAPACITY`].
    pub len: u64,
    /// Total weighted length of the path (I-RRT eq. 2 metric).
    pub length: f64,
    /// Waypoints; only the first `len` are meaningful. Consecutive waypoints are joined by
    /// straight segments (linear position, slerp orientation) that the planner validated.
    pub waypoints: [Pose; PATH_CAPACITY],
}

impl Path {
    /// An empty path.
    pub const EMPTY: Self = Self {
        header: Header::new(0, 0, 0),
        len: 0,
        length: 0.0,
        waypoints: [Pose::IDENTITY; PATH_CAPACITY],
    };

    /// The valid waypoints; a `len` beyond capacity (a corrupt sample) is clamped.
    pub fn waypoints(&self) -> &[Pose] {
        let n = usize::try_from(self.len)
            .unwrap_or(PATH_CAPACITY)
            .min(PATH_CAPACITY);
        &self.waypoints[..n]
    }
}

impl Default for Path {
    fn default() -> Self {
        Self::EMPTY
    }
}

const _: () = {
    assert!(core::mem::size_of::<Path>() == 24 + 8 + 8 + 56 * PATH_CAPACITY);
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corrupt_length_is_clamped() {
        let mut p = Path::EMPTY;
        p.len = u64::MAX;
        assert_eq!(p.waypoints().len(), PATH_CAPACITY);
        p.len = 3;
        assert_eq!(p.waypoints().len(), 3);
    }
}
