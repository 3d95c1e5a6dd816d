//! Wire ⇄ planner conversions at the shell's edge: a haptic state into the core's operator
//! input, planner poses and the solution into wire poses and a wire path.

use ipc_types::{HapticState, Header, PATH_CAPACITY, Path, Pose};
use planner_core::space::path_length;
use planner_core::{Contact, Planner, Se3, UserInput};

/// The operator input of one haptic state: `q_user` from `proxy_pose`, the object as the
/// operator holds and sees it (the loop keeps it out of obstacles when it renders contact;
/// without contact it is the hand's mapped pose, `user_pose`, which is also the fallback),
/// and contact (H-RRT-C contact mode) while the loop reports `ContactCode::CONTACT` with a
/// unit normal, at the state's stamp (the tick's `CLOCK_MONOTONIC` wake-up, in s: the
/// adaptive authority's clock). `None` when no pose is valid.
pub fn user_input(s: &HapticState) -> Option<UserInput> {
    let q_user = operator_pose(s)?;
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
            Some(Contact {
                point_m: v(s.contact_point_m),
                normal,
                force_n: v(s.operator_force_n),
                displacement_m: v(s.displacement_m),
                proxy: se3(&s.proxy_pose)?,
            })
        })
        .flatten();
    Some(UserInput {
        q_user,
        contact,
        time_s: s.header.timestamp_ns as f64 * 1e-9,
    })
}

/// The held object's configuration in a haptic state: the proxy, else the hand's mapped
/// pose (H-RRT-C's q_device).
pub fn operator_pose(s: &HapticState) -> Option<Se3> {
    se3(&s.proxy_pose).or_else(|| se3(&s.user_pose))
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
pub(super) fn to_wire_path(sol: &[Se3], planner: &Planner, seq: u64, pid: u32) -> Path {
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
    path.length = path_length(planner.space(), sol);
    path.header = Header::new(seq, ipc_types::monotonic_ns(), pid);
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
        s.header.timestamp_ns = 2_500_000_000;
        let free = user_input(&s).expect("valid");
        assert_eq!(free.time_s, 2.5);
        // q_device is the object as held (the proxy), not the hand inside the wall.
        assert!(free.contact.is_none() && (free.q_user.pos.x - 0.09).abs() < 1e-12);
        let mut no_proxy = s;
        no_proxy.proxy_pose.orientation_xyzw = [f64::NAN; 4];
        let q_hand = user_input(&no_proxy).expect("valid").q_user;
        assert!((q_hand.pos - q.pos).norm() < 1e-12);
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
