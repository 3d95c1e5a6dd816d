//! The fill of the published [`HapticState`] from one tick's results.

use super::PrevTiming;
use crate::contact::ContactOutput;
use crate::guidance::RenderedGuidance;
use devices::{DeviceState, Wrench};
use ipc_types::convert as wire;
use ipc_types::{ContactCode, FaultCode, HapticState, Header};
use nalgebra::{Isometry3, Vector3};

/// What one tick computed, as [`fill`] publishes it.
pub(super) struct TickResults<'a> {
    /// The tick's sequence number (1 for the first).
    pub sequence: u64,
    /// Start of the tick, ns.
    pub now_ns: u64,
    /// The writing process.
    pub pid: u32,
    /// The device state the tick used (the last good one while the device fails).
    pub device: &'a DeviceState,
    /// The device-mapped pose in the scene.
    pub user: &'a Isometry3<f64>,
    /// The proxy's pose (the user's pose without contact rendering).
    pub proxy: &'a Isometry3<f64>,
    /// The wrench written to the device.
    pub commanded: &'a Wrench,
    /// The contact stage's output, when contact rendering is on.
    pub contact: Option<&'a ContactOutput>,
    /// The guidance wrench rendered.
    pub guidance: &'a RenderedGuidance,
    /// The tick's fault.
    pub fault: FaultCode,
    /// The proxy's motion since the previous tick, m.
    pub displacement: Vector3<f64>,
    /// Timing of the previous tick.
    pub prev: PrevTiming,
}

/// Writes every field of `s` from `r`. Allocation-free.
#[inline]
pub(super) fn fill(s: &mut HapticState, r: &TickResults) {
    let (device, g, prev) = (r.device, r.guidance, &r.prev);
    s.header = Header::new(r.sequence, r.now_ns, r.pid);
    s.device_pose = wire::pose(&device.pose);
    s.device_twist = wire::twist(&device.linear_velocity, &device.angular_velocity);
    s.user_pose = wire::pose(r.user);
    s.proxy_pose = wire::pose(r.proxy);
    s.commanded_wrench = wire::wrench(&r.commanded.force, &r.commanded.torque);
    match r.contact {
        Some(c) => {
            s.contact_wrench = wire::wrench(&c.contact_force_n, &c.contact_torque_nm);
            s.contact = c.code;
            s.contact_normal = c.normal.into();
            s.contact_point_m = c.point_m.into();
            s.operator_force_n = c.operator_force_n.into();
            s.penetration_m = c.penetration_m;
        }
        None => {
            s.contact_wrench = ipc_types::Wrench::ZERO;
            s.contact = ContactCode::DISABLED;
            s.contact_normal = [0.0; 3];
            s.contact_point_m = [0.0; 3];
            s.operator_force_n = [0.0; 3];
            s.penetration_m = 0.0;
        }
    }
    s.guidance_wrench = wire::wrench(&g.force_n, &g.torque_nm);
    s.fault = r.fault;
    s.buttons = device.buttons;
    s.guidance_freshness = g.freshness;
    s.displacement_m = r.displacement.into();
    s.guidance_sequence = g.sequence;
    s.prev_wake_latency_ns = prev.wake_latency_ns;
    s.prev_compute_ns = prev.compute_ns;
    s.prev_period_ns = prev.period_ns;
    s.deadline_misses = prev.deadline_misses;
}
