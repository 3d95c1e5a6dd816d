//! What a bridge is told ([`BridgeConfig`]) and what can stop it from starting
//! ([`BridgeError`]).

use crate::clock::HostClock;
use ipc_types::services::{self, ServiceError};

/// Which host the bridge runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The haptic loop's host: sends the state, receives guidance, paths and roadmaps.
    Loop,
    /// A planner's host: receives the state, sends guidance, paths and roadmaps.
    Planner,
}

impl Side {
    /// `loop` or `planner`.
    pub fn name(self) -> &'static str {
        match self {
            Side::Loop => "loop",
            Side::Planner => "planner",
        }
    }
}

/// What a bridge process does.
#[derive(Debug, Clone)]
pub struct BridgeConfig {
    /// This host's role.
    pub side: Side,
    /// The iceoryx2 namespace bridged.
    pub namespace: String,
    /// The Zenoh key prefix is `hrrtc/<key_namespace>/`; `None`: the namespace. (Two
    /// bridges of one host on different namespaces can so be joined, e.g. to measure the
    /// bridge with one clock.)
    pub key_namespace: Option<String>,
    /// Zenoh endpoints to listen on, e.g. `tls/0.0.0.0:7447`.
    pub listen: Vec<String>,
    /// Zenoh endpoints of the other bridges to connect to, e.g. `tls/10.0.0.2:7447`.
    pub connect: Vec<String>,
    /// The Zenoh file, mutual TLS and `--insecure` ([`zenoh_session::Security`]).
    pub security: zenoh_session::Security,
    /// Common names of the certificates of the peers allowed in ([`crate::access`]):
    /// planners on the loop's side, the loop on a planner's. Required with TLS unless the
    /// Zenoh file brings its own access control.
    pub allow_peers: Vec<String>,
    /// How long to try the `connect` endpoints at start before failing, s.
    pub connect_timeout_s: f64,
    /// Loop side: send at most this many states per second (`None`: every new tick).
    pub state_rate_hz: Option<f64>,
    /// Loop side: how often the state blackboard is polled, µs (the loop does not notify),
    /// until the bridge has locked onto a real-time loop's ticks (`ipc_types::pacing`), and
    /// for a loop without real-time rights.
    pub state_poll_us: u64,
    /// Carry roadmap increments (about 90 KB each, 20 per second per planner).
    pub roadmap: bool,
    /// The clock this bridge presents on the wire (real, or offset and drifting in tests).
    pub clock: HostClock,
    /// Round-trip probes per second.
    pub probe_hz: f64,
    /// Stop after this long, s (`None`: until the stop flag).
    pub duration_s: Option<f64>,
}

impl BridgeConfig {
    /// Defaults for `side` on `namespace` with no endpoints.
    pub fn new(side: Side, namespace: &str) -> Self {
        Self {
            side,
            namespace: namespace.to_owned(),
            key_namespace: None,
            listen: Vec::new(),
            connect: Vec::new(),
            security: zenoh_session::Security::default(),
            allow_peers: Vec::new(),
            connect_timeout_s: 10.0,
            state_rate_hz: None,
            state_poll_us: 100,
            roadmap: true,
            clock: HostClock::real(),
            probe_hz: 10.0,
            duration_s: None,
        }
    }

    /// Checks what the bridge cannot start with: the namespaces, the endpoints, the rates.
    pub fn validate(&self) -> Result<(), BridgeError> {
        services::validate_namespace(&self.namespace)?;
        if let Some(k) = &self.key_namespace {
            services::validate_namespace(k)?;
        }
        zenoh_session::check_endpoints(self.listen.iter().chain(&self.connect))?;
        if let Some(bad) = self
            .allow_peers
            .iter()
            .find(|cn| cn.trim().is_empty() || cn.contains(['"', '\\']))
        {
            return Err(BridgeError::Config(format!(
                "--allow-peer {bad:?}: not a certificate common name"
            )));
        }
        if let Some(r) = self.state_rate_hz
            && !(r.is_finite() && r > 0.0)
        {
            return Err(BridgeError::Config(format!(
                "state rate {r} Hz: must be a positive number"
            )));
        }
        if !(self.probe_hz.is_finite() && self.probe_hz > 0.0) {
            return Err(BridgeError::Config(format!(
                "probe rate {} Hz: must be a positive number",
                self.probe_hz
            )));
        }
        Ok(())
    }

    /// The Zenoh key namespace: `key_namespace`, else the namespace.
    pub fn keys(&self) -> &str {
        self.key_namespace.as_ref().unwrap_or(&self.namespace)
    }
}

/// What can stop a bridge from starting.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// The namespace cannot name services.
    #[error("namespace: {0}")]
    Namespace(#[from] services::NamespaceError),
    /// A Zenoh endpoint does not parse, the session could not be opened (an endpoint
    /// cannot be listened on, or none of the `connect` endpoints answered in time), or a
    /// publisher or subscriber could not be declared.
    #[error(transparent)]
    Zenoh(#[from] zenoh_session::SessionError),
    /// An iceoryx2 node, service or port could not be opened.
    #[error(transparent)]
    Ipc(#[from] ServiceError),
    /// A bad setting.
    #[error("{0}")]
    Config(String),
    /// A thread could not be started.
    #[error("cannot start the bridge's {thread} thread: {reason}")]
    Thread {
        /// Which.
        thread: &'static str,
        /// Why.
        reason: String,
    },
}
