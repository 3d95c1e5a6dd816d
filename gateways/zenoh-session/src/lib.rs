//! The Zenoh session the gateways open: the bridge (`hrrtc-bridge`, peer to peer between
//! a loop's host and a planner's, or inside `planner serve`) and the ROS 2 gateway
//! (`hrrtc-ros2`, a peer of rmw_zenoh's router). Each says which settings it wants
//! ([`Settings`]); this crate merges them with the user's Zenoh configuration file and the
//! command line's security flags ([`Security`]), refuses links that are not mutually
//! authenticated unless told `--insecure` ([`judge`]), and opens the session. Its errors
//! name the endpoint, flag, file or key that failed.
//!
//! Precedence, lowest first: the gateway's built-in defaults, then the file, then what was
//! given explicitly on the command line. A default never overrides the file: a flag that
//! was not given is `None` here, not its default.

mod cli;
mod judge;
mod merge;
mod refusals;

pub use cli::SecurityArgs;
pub use judge::{Verdict, judge};
pub use merge::{Built, Origin, build};
pub use refusals::{Refusals, layer as refusal_counter};

use std::path::PathBuf;
use zenoh::Wait;

/// What can go wrong opening a session or declaring on it.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// A Zenoh endpoint does not parse.
    #[error("Zenoh endpoint '{endpoint}': {reason}")]
    Endpoint {
        /// As given.
        endpoint: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The Zenoh configuration file cannot be read or does not parse, or one of its keys is
    /// refused.
    #[error("Zenoh configuration {file}: {reason}")]
    ConfigFile {
        /// The file.
        file: PathBuf,
        /// What is wrong, naming the key where one is at fault.
        reason: String,
    },
    /// A security flag is unusable: a TLS file missing or unreadable, flags that go
    /// together given apart.
    #[error("{0}")]
    Flag(String),
    /// The merged configuration would open a link that is not mutually authenticated, and
    /// `--insecure` was not given.
    #[error("{0}")]
    Insecure(String),
    /// A gateway's own setting (a default or an override) was refused.
    #[error("Zenoh setting {key} = {value}: {reason}")]
    Setting {
        /// The key.
        key: String,
        /// The JSON5 value.
        value: String,
        /// What Zenoh said.
        reason: String,
    },
    /// Zenoh could not open the session: a setting was refused, an endpoint cannot be
    /// listened on, or none of the `connect` endpoints answered in time.
    #[error("Zenoh session (listen {listen:?}, connect {connect:?}): {reason}")]
    Open {
        /// Listen endpoints.
        listen: Vec<String>,
        /// Connect endpoints.
        connect: Vec<String>,
        /// What Zenoh said.
        reason: String,
    },
    /// A publisher, subscriber, queryable or token could not be declared.
    #[error("Zenoh key '{key}': {reason}")]
    Declare {
        /// The key expression.
        key: String,
        /// What Zenoh said.
        reason: String,
    },
}

/// How a gateway's links are secured, as its command line says ([`SecurityArgs`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Security {
    /// A Zenoh configuration file (JSON5, as rmw_zenoh's `ZENOH_SESSION_CONFIG_URI`): any
    /// Zenoh setting, above the gateway's defaults and below the flags.
    pub zenoh_config: Option<PathBuf>,
    /// Mutual TLS with these PEM files.
    pub tls: Option<TlsFiles>,
    /// Links that are not mutually authenticated TLS are allowed (plain TCP, TLS without
    /// client certificates).
    pub insecure: bool,
    /// What the gateway's security flags start with after `--` (`""` for `--tls-ca`,
    /// `"bridge-"` for `planner serve`'s `--bridge-tls-ca`), for messages.
    pub flag_prefix: &'static str,
}

/// The PEM files of mutual TLS: the lab's CA, and this host's certificate and key, which it
/// presents both when it listens and when it connects.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TlsFiles {
    /// The CA that signed every allowed host's certificate.
    pub ca: PathBuf,
    /// This host's certificate.
    pub cert: PathBuf,
    /// This host's private key.
    pub key: PathBuf,
}

impl Security {
    /// One line for start-up logs and summaries: how the links are secured.
    pub fn describe(&self) -> String {
        let base = match (&self.tls, &self.zenoh_config) {
            (Some(t), _) => format!("mutual TLS, CA {}", t.ca.display()),
            (None, Some(f)) => format!("as {} says", f.display()),
            (None, None) => "no TLS".to_owned(),
        };
        if self.insecure {
            format!("{base}; INSECURE: unauthenticated links allowed (--insecure)")
        } else {
            base
        }
    }
}

/// A session's settings: the gateway's own defaults, what the command line gave, and its
/// security.
#[derive(Debug, Clone, Default)]
pub struct Settings {
    /// The gateway's defaults (`path`, JSON5 value), applied where the file does not name
    /// the key. `mode` defaults to `"peer"` unless listed here or in the file.
    pub defaults: Vec<(&'static str, String)>,
    /// Endpoints to listen on, given on the command line: replace the file's and the
    /// defaults' (`None`: not given). E.g. `tls/0.0.0.0:7447`.
    pub listen: Option<Vec<String>>,
    /// Endpoints to connect to, given on the command line (`None`: not given).
    pub connect: Option<Vec<String>>,
    /// Settings the gateway applies above the file (`path`, JSON5 value), e.g. the bridge's
    /// access control built from `--allow-peer`.
    pub overrides: Vec<(&'static str, String)>,
    /// The file, TLS and `--insecure`.
    pub security: Security,
}

/// `Err` naming the first endpoint of `endpoints` that does not parse.
pub fn check_endpoints<'a>(
    endpoints: impl IntoIterator<Item = &'a String>,
) -> Result<(), SessionError> {
    for e in endpoints {
        e.parse::<zenoh::config::EndPoint>()
            .map_err(|err| SessionError::Endpoint {
                endpoint: e.clone(),
                reason: err.to_string(),
            })?;
    }
    Ok(())
}

/// Builds the configuration ([`build`]), judges it ([`judge`]) and opens the session; the
/// verdict says which endpoints it listens on and connects to.
pub fn open(settings: &Settings) -> Result<(zenoh::Session, Verdict), SessionError> {
    let (built, verdict) = prepare(settings)?;
    let session = open_prepared(built, &verdict)?;
    Ok((session, verdict))
}

/// The configuration built and judged, for a gateway that checks more before opening.
pub fn prepare(settings: &Settings) -> Result<(Built, Verdict), SessionError> {
    let mut built = build(settings)?;
    let verdict = judge(&mut built, &settings.security)?;
    if let Some(e) = verdict
        .listen
        .iter()
        .chain(&verdict.connect)
        .find(|e| e.starts_with("tls/"))
    {
        tracing::warn!(
            "'{e}': Zenoh 1.10's tls/ link shares one TLS connection between a reading and a \
             writing task without a lock (eclipse-zenoh/zenoh#2557), which can crash this \
             process when a link closes; quic/ (the same certificates, over UDP) does not"
        );
    }
    Ok((built, verdict))
}

/// Opens a session on a [`prepare`]d configuration.
pub fn open_prepared(built: Built, verdict: &Verdict) -> Result<zenoh::Session, SessionError> {
    zenoh::open(built.config)
        .wait()
        .map_err(|e| SessionError::Open {
            listen: verdict.listen.clone(),
            connect: verdict.connect.clone(),
            reason: e.to_string(),
        })
}

/// The error of declaring something on `key`.
pub fn declare_error(key: &str) -> impl FnOnce(zenoh::Error) -> SessionError + '_ {
    move |e| SessionError::Declare {
        key: key.to_owned(),
        reason: e.to_string(),
    }
}

/// Zenoh's reconnection backoff for both gateways: 100 ms doubling to 1 s (Zenoh's default
/// backs off to 4 s, long for a link that dropped for a moment).
pub const RETRY: &str = "{period_init_ms: 100, period_max_ms: 1000, period_increase_factor: 2}";

/// A JSON list of strings.
pub fn json_list(items: &[String]) -> String {
    serde_json::to_string(items).unwrap_or_else(|_| "[]".to_owned())
}

#[cfg(test)]
mod tests;
