//! The bridge's Zenoh session, its keys, and how samples are put on the wire.

use crate::BridgeConfig;
use crate::BridgeError;
use crate::clock::HostClock;
use crate::frame::{self, Carried};
use zenoh::Wait;
use zenoh::qos::{CongestionControl, Priority};

/// Zenoh key of `leaf` on `namespace`.
pub fn key(namespace: &str, leaf: &str) -> String {
    format!("hrrtc/{namespace}/{leaf}")
}

/// `v` framed for the wire, its stamps in the presented clock.
pub(crate) fn outgoing<T: Carried>(mut v: T, clock: &HostClock, id: u64) -> Vec<u8> {
    v.restamp(|t| clock.at(t));
    frame::encode(id, clock.now(), &v)
}

/// A publisher for `leaf`: newest wins, so it drops rather than queue behind a slow link,
/// and skips Zenoh's batching for the small, frequent samples.
pub(crate) fn declare_publisher(
    session: &zenoh::Session,
    keys: &str,
    leaf: &str,
) -> Result<zenoh::pubsub::Publisher<'static>, BridgeError> {
    let k = key(keys, leaf);
    session
        .declare_publisher(k.clone())
        .congestion_control(CongestionControl::Drop)
        .priority(Priority::InteractiveHigh)
        .express(leaf != "roadmap")
        .wait()
        .map_err(declare_error(&k))
}

/// The error of declaring a publisher or subscriber on `key`.
pub(crate) fn declare_error(key: &str) -> impl FnOnce(zenoh::Error) -> BridgeError + '_ {
    move |e| zenoh_session::declare_error(key)(e).into()
}

/// Opens this bridge's Zenoh peer session on the configured endpoints.
pub(crate) fn open_session(config: &BridgeConfig) -> Result<zenoh::Session, BridgeError> {
    let timeout_ms = (config.connect_timeout_s * 1e3).round() as i64;
    let settings = zenoh_session::Settings {
        listen: config.listen.clone(),
        connect: config.connect.clone(),
        extra: vec![
            // Explicit endpoints only: nothing is found by multicast, which many networks
            // (and network namespaces) do not carry.
            ("scouting/multicast/enabled", "false".to_owned()),
            ("connect/timeout_ms", timeout_ms.to_string()),
            ("connect/exit_on_failure", "true".to_owned()),
            ("connect/retry", zenoh_session::RETRY.to_owned()),
        ],
    };
    Ok(zenoh_session::open(&settings)?)
}

/// A random id for this bridge's frames: the low 64 bits of its Zenoh session id (random
/// per session).
pub(crate) fn session_id(session: &zenoh::Session) -> u64 {
    let zid = session.zid().to_le_bytes();
    let mut low = [0u8; 8];
    low.copy_from_slice(&zid[..8]);
    u64::from_le_bytes(low).max(1)
}
