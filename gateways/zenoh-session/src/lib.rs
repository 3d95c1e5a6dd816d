//! The Zenoh session both gateways open: the bridge (`hrrtc-bridge`, peer to peer between
//! a loop's host and a planner's) and the ROS 2 gateway (`hrrtc-ros2`, a peer of
//! rmw_zenoh's router). Each says which settings it wants ([`Settings`]); this crate checks
//! the endpoints, applies the settings and opens the session, and its errors name the
//! endpoint, setting or key that failed.

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

/// A session's endpoints and the JSON5 settings (`path`, value) a gateway adds to Zenoh's
/// defaults. `mode`, `listen/endpoints` and `connect/endpoints` are set from the fields.
#[derive(Debug, Clone, Default)]
pub struct Settings {
    /// Endpoints to listen on, e.g. `tcp/0.0.0.0:7447`.
    pub listen: Vec<String>,
    /// Endpoints to connect to, e.g. `tcp/10.0.0.2:7447`.
    pub connect: Vec<String>,
    /// Further settings, applied in order after the endpoints.
    pub extra: Vec<(&'static str, String)>,
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

/// Opens a peer session with `settings`, its endpoints checked first.
pub fn open(settings: &Settings) -> Result<zenoh::Session, SessionError> {
    check_endpoints(settings.listen.iter().chain(&settings.connect))?;
    let open_error = |reason: String| SessionError::Open {
        listen: settings.listen.clone(),
        connect: settings.connect.clone(),
        reason,
    };
    let mut z = zenoh::Config::default();
    let endpoints = [
        ("mode", "\"peer\"".to_owned()),
        ("listen/endpoints", json_list(&settings.listen)),
        ("connect/endpoints", json_list(&settings.connect)),
    ];
    for (k, v) in endpoints.iter().chain(&settings.extra) {
        z.insert_json5(k, v)
            .map_err(|e| open_error(format!("setting {k} = {v}: {e}")))?;
    }
    zenoh::open(z).wait().map_err(|e| open_error(e.to_string()))
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

/// A JSON list of endpoint strings (they parsed as endpoints, so they hold no quote).
fn json_list(items: &[String]) -> String {
    let quoted: Vec<String> = items.iter().map(|s| format!("\"{s}\"")).collect();
    format!("[{}]", quoted.join(","))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_endpoint_is_named() {
        let s = Settings {
            connect: vec!["tcp/localhost:7447".into(), "nonsense".into()],
            ..Settings::default()
        };
        match open(&s) {
            Err(SessionError::Endpoint { endpoint, .. }) => assert_eq!(endpoint, "nonsense"),
            other => panic!("expected the endpoint named, got {other:?}"),
        }
    }

    #[test]
    fn a_bad_setting_is_named() {
        let s = Settings {
            extra: vec![("connect/timeout_ms", "\"soon\"".into())],
            ..Settings::default()
        };
        let e = open(&s).expect_err("a string timeout is refused");
        assert!(e.to_string().contains("connect/timeout_ms"), "{e}");
    }

    #[test]
    fn a_session_opens_on_a_free_port_and_lists_are_json() {
        assert_eq!(json_list(&["a".into(), "b".into()]), "[\"a\",\"b\"]");
        let s = Settings {
            listen: vec!["tcp/127.0.0.1:0".into()],
            extra: vec![("scouting/multicast/enabled", "false".into())],
            ..Settings::default()
        };
        let session = open(&s).expect("opens");
        let e = declare_error("hrrtc/x")(zenoh::Error::from("refused"));
        assert_eq!(e.to_string(), "Zenoh key 'hrrtc/x': refused");
        drop(session);
    }
}
