//! The bridge's Zenoh session, its keys, and how samples are put on the wire.

use crate::BridgeConfig;
use crate::clock::HostClock;
use crate::frame::{self, Carried};
use crate::{BridgeError, Side};
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

/// Opens this bridge's Zenoh peer session on the configured endpoints, secured as
/// `config.security` says, with access control for `config.allow_peers`.
pub(crate) fn open_session(config: &BridgeConfig) -> Result<zenoh::Session, BridgeError> {
    let timeout_ms = (config.connect_timeout_s * 1e3).round() as i64;
    let mut settings = zenoh_session::Settings {
        defaults: vec![
            // Explicit endpoints only: nothing is found by multicast, which many networks
            // (and network namespaces) do not carry; and nothing is listened on unless asked
            // (Zenoh's own default would listen on every interface).
            ("scouting/multicast/enabled", "false".to_owned()),
            ("listen/endpoints", "[]".to_owned()),
            ("connect/endpoints", "[]".to_owned()),
            ("connect/timeout_ms", timeout_ms.to_string()),
            ("connect/exit_on_failure", "true".to_owned()),
            ("connect/retry", zenoh_session::RETRY.to_owned()),
        ],
        listen: (!config.listen.is_empty()).then(|| config.listen.clone()),
        connect: (!config.connect.is_empty()).then(|| config.connect.clone()),
        overrides: Vec::new(),
        security: config.security.clone(),
    };
    if !config.allow_peers.is_empty() {
        let acl = crate::access::access_control(config.side, config.keys(), &config.allow_peers);
        settings.overrides.push(("access_control", acl));
    }
    let (built, verdict) = zenoh_session::prepare(&settings)?;
    // Without --allow-peer, the file must bring access control of its own.
    let file_acl = built.config.get_json("access_control/enabled").ok();
    if config.allow_peers.is_empty()
        && !config.security.insecure
        && file_acl.as_deref() != Some("true")
    {
        let p = config.security.flag_prefix;
        let whom = match config.side {
            Side::Loop => "each planner's host",
            Side::Planner => "the loop's host",
        };
        return Err(BridgeError::Config(format!(
            "name the peers allowed in with --{p}allow-peer CN (the common name in the \
             certificate of {whom}; repeatable), or give access control in the \
             --{p}zenoh-config file; --{p}insecure runs without either"
        )));
    }
    let session = zenoh_session::open_prepared(built, &verdict)?;
    tracing::info!(
        "links: {}; listening on {:?}, connecting to {:?}{}",
        config.security.describe(),
        verdict.listen,
        verdict.connect,
        if config.allow_peers.is_empty() {
            String::new()
        } else {
            format!("; peers allowed in: {}", config.allow_peers.join(", "))
        }
    );
    Ok(session)
}

/// A random id for this bridge's frames: the low 64 bits of its Zenoh session id (random
/// per session).
pub(crate) fn session_id(session: &zenoh::Session) -> u64 {
    let zid = session.zid().to_le_bytes();
    let mut low = [0u8; 8];
    low.copy_from_slice(&zid[..8]);
    u64::from_le_bytes(low).max(1)
}
