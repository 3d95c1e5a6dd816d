//! Secure by default: the merged configuration, not the flags, is judged. Every listen and
//! connect endpoint must be TLS (`tls/`, or QUIC, `quic/`, which is TLS 1.3 over UDP and
//! takes the same `transport/link/tls` settings) with client certificates required and a CA
//! to check the other side against, and only those links may be opened at all
//! (`transport/link/protocols`, which also binds peers found by scouting); otherwise the
//! session is refused unless `--insecure` was given.

use crate::merge::Built;
use crate::{Security, SessionError};
use serde_json::Value;

/// What the judged configuration opens.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Verdict {
    /// `peer`, `client` or `router`.
    pub mode: String,
    /// The endpoints listened on (for this mode).
    pub listen: Vec<String>,
    /// The endpoints connected to (for this mode).
    pub connect: Vec<String>,
    /// Every link is mutually authenticated TLS.
    pub mutual_tls: bool,
}

/// Checks `built` against the rules above (skipped when `security.insecure`), and restricts
/// the link protocols to TLS where the configuration leaves them open.
pub fn judge(built: &mut Built, security: &Security) -> Result<Verdict, SessionError> {
    let z = &built.config;
    let mode = match get(z, "mode") {
        Value::String(m) => m,
        _ => "peer".to_owned(),
    };
    let listen = endpoints(z, "listen/endpoints", &mode);
    let connect = endpoints(z, "connect/endpoints", &mode);
    let tls_only = listen
        .iter()
        .chain(&connect)
        .all(|e| authenticated(protocol(e)));
    let mtls = get(z, "transport/link/tls/enable_mtls") == Value::Bool(true);
    let mut verdict = Verdict {
        mode,
        listen,
        connect,
        mutual_tls: tls_only && mtls,
    };
    if security.insecure {
        return Ok(verdict);
    }
    let p = security.flag_prefix;
    let remedy = format!(
        "use tls/HOST:PORT or quic/HOST:PORT endpoints with --{p}tls-ca, --{p}tls-cert and --{p}tls-key (a lab CA \
         and certificates: `hrrtc-bridge certs`) or a --{p}zenoh-config that sets them, or give \
         --{p}insecure to allow unauthenticated links"
    );
    for (verb, list, origin) in [
        ("listen on", &verdict.listen, built.listen),
        ("connect to", &verdict.connect, built.connect),
    ] {
        if let Some(e) = list.iter().find(|e| !authenticated(protocol(e))) {
            return Err(SessionError::Insecure(format!(
                "refusing to {verb} '{e}' ({}): a `{}` link is not mutually authenticated, so \
                 anyone who can reach it could read the operator's state or push on the arm; \
                 {remedy}",
                origin.describe(),
                protocol(e)
            )));
        }
    }
    if !verdict.listen.is_empty() || !verdict.connect.is_empty() {
        let mut missing = Vec::new();
        if !mtls {
            missing.push("transport/link/tls/enable_mtls = true");
        }
        if !set(z, "root_ca_certificate") {
            missing.push("transport/link/tls/root_ca_certificate");
        }
        // Each side that is used presents this host's certificate.
        let pair = |side: &str| {
            set(z, &format!("{side}_certificate")) && set(z, &format!("{side}_private_key"))
        };
        if !verdict.listen.is_empty() && !pair("listen") {
            missing.push("transport/link/tls/listen_certificate and listen_private_key");
        }
        if !verdict.connect.is_empty() && !pair("connect") {
            missing.push("transport/link/tls/connect_certificate and connect_private_key");
        }
        if !missing.is_empty() {
            return Err(SessionError::Insecure(format!(
                "TLS without mutual authentication: {} not set; {remedy}",
                missing.join(", ")
            )));
        }
    }
    match get(z, "transport/link/protocols") {
        Value::Null => {
            let only = serde_json::to_string(&AUTHENTICATED).unwrap_or_default();
            built
                .config
                .insert_json5("transport/link/protocols", &only)
                .map_err(|e| SessionError::Setting {
                    key: "transport/link/protocols".into(),
                    value: only,
                    reason: e.to_string(),
                })?;
        }
        Value::Array(list) => {
            if let Some(other) = list.iter().find(|p| !p.as_str().is_some_and(authenticated)) {
                return Err(SessionError::Insecure(format!(
                    "transport/link/protocols allows {other}: only \"tls\" and \"quic\" \
                     links are mutually authenticated; {remedy}"
                )));
            }
        }
        other => {
            return Err(SessionError::Insecure(format!(
                "transport/link/protocols = {other}: expected a list; {remedy}"
            )));
        }
    }
    verdict.mutual_tls = true;
    Ok(verdict)
}

/// The link protocols that carry TLS (with client certificates when `enable_mtls`).
const AUTHENTICATED: [&str; 2] = ["tls", "quic"];

/// Whether links of `protocol` carry TLS.
fn authenticated(protocol: &str) -> bool {
    AUTHENTICATED.contains(&protocol)
}

/// A key's value as JSON (`Null` when unset or unreadable).
fn get(z: &zenoh::Config, key: &str) -> Value {
    z.get_json(key)
        .ok()
        .and_then(|s| serde_json::from_str(&s).ok())
        .unwrap_or(Value::Null)
}

/// Whether the TLS file `name` is given, as a path or inline (`name_base64`).
fn set(z: &zenoh::Config, name: &str) -> bool {
    let key = format!("transport/link/tls/{name}");
    !get(z, &key).is_null() || !get(z, &format!("{key}_base64")).is_null()
}

/// The endpoints under `key` for `mode`: a list, or one list per mode.
fn endpoints(z: &zenoh::Config, key: &str, mode: &str) -> Vec<String> {
    let v = get(z, key);
    let list = match &v {
        Value::Object(per_mode) => per_mode.get(mode).cloned().unwrap_or(Value::Null),
        other => other.clone(),
    };
    list.as_array()
        .map(|l| {
            l.iter()
                .filter_map(|e| e.as_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default()
}

/// An endpoint's protocol: what comes before the first `/`.
fn protocol(endpoint: &str) -> &str {
    endpoint.split('/').next().unwrap_or(endpoint)
}
