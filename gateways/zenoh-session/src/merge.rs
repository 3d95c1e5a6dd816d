//! The merged configuration: Zenoh's defaults, then the gateway's, then the user's file,
//! then the command line.

use crate::{SessionError, Settings, TlsFiles, check_endpoints, json_list};
use serde_json::Value;
use std::path::Path;

/// Where a session's listen or connect endpoints came from, for messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// The gateway's built-in default.
    Default,
    /// The `--zenoh-config` file.
    File,
    /// The command line.
    Flag,
}

impl Origin {
    /// As said in a message.
    pub fn describe(self) -> &'static str {
        match self {
            Origin::Default => "the built-in default",
            Origin::File => "from the Zenoh configuration file",
            Origin::Flag => "given on the command line",
        }
    }
}

/// A merged configuration and where its endpoints came from.
pub struct Built {
    /// What Zenoh will be given (before [`crate::judge`] restricts the link protocols).
    pub config: zenoh::Config,
    /// Where `listen/endpoints` came from.
    pub listen: Origin,
    /// Where `connect/endpoints` came from.
    pub connect: Origin,
}

impl std::fmt::Debug for Built {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Built")
            .field("listen", &self.listen)
            .field("connect", &self.connect)
            .finish_non_exhaustive()
    }
}

/// Merges `settings` into one Zenoh configuration: Zenoh's defaults, the gateway's defaults
/// where the file does not name the key, the file, the endpoints and TLS files given on the
/// command line, the gateway's overrides. Nothing is judged yet.
pub fn build(settings: &Settings) -> Result<Built, SessionError> {
    for given in [&settings.listen, &settings.connect].into_iter().flatten() {
        check_endpoints(given)?;
    }
    let mut z = zenoh::Config::default();
    let file = match &settings.security.zenoh_config {
        Some(path) => {
            let value = read_file(path)?;
            apply_file(&mut z, path, &value)?;
            Some(value)
        }
        None => None,
    };
    let in_file = |key: &str| file.as_ref().is_some_and(|v| names(v, key));
    let mode_default = [("mode", "\"peer\"".to_owned())];
    let defaults = settings.defaults.iter().chain(
        mode_default
            .iter()
            .filter(|_| !settings.defaults.iter().any(|(k, _)| *k == "mode")),
    );
    for (k, v) in defaults {
        if !in_file(k) {
            insert(&mut z, k, v)?;
        }
    }
    let origin = |given: bool, key: &str| match (given, in_file(key)) {
        (true, _) => Origin::Flag,
        (false, true) => Origin::File,
        (false, false) => Origin::Default,
    };
    let built_listen = origin(settings.listen.is_some(), "listen/endpoints");
    let built_connect = origin(settings.connect.is_some(), "connect/endpoints");
    if let Some(l) = &settings.listen {
        insert(&mut z, "listen/endpoints", &json_list(l))?;
    }
    if let Some(c) = &settings.connect {
        insert(&mut z, "connect/endpoints", &json_list(c))?;
    }
    if let Some(tls) = &settings.security.tls {
        apply_tls(&mut z, tls, settings.security.flag_prefix)?;
    }
    for (k, v) in &settings.overrides {
        insert(&mut z, k, v)?;
    }
    Ok(Built {
        config: z,
        listen: built_listen,
        connect: built_connect,
    })
}

/// Sets `key` to the JSON5 `value`, or an error naming both.
fn insert(z: &mut zenoh::Config, key: &str, value: &str) -> Result<(), SessionError> {
    z.insert_json5(key, value)
        .map_err(|e| SessionError::Setting {
            key: key.to_owned(),
            value: value.to_owned(),
            reason: e.to_string(),
        })
}

/// The file's JSON5 as a value.
fn read_file(path: &Path) -> Result<Value, SessionError> {
    let error = |reason: String| SessionError::ConfigFile {
        file: path.to_owned(),
        reason,
    };
    let text = std::fs::read_to_string(path).map_err(|e| error(e.to_string()))?;
    let value: Value = json5::from_str(&text).map_err(|e| error(format!("not JSON5: {e}")))?;
    if !value.is_object() {
        return Err(error("not a JSON5 object".into()));
    }
    Ok(value)
}

/// Inserts each of the file's top-level keys as Zenoh reads a whole file (what a key leaves
/// out of its section takes Zenoh's default); a key Zenoh refuses is named, down to the
/// deepest part of it that is refused on its own.
fn apply_file(z: &mut zenoh::Config, path: &Path, file: &Value) -> Result<(), SessionError> {
    let Some(top) = file.as_object() else {
        return Ok(());
    };
    for (k, v) in top {
        if let Err(e) = z.insert_json5(k, &v.to_string()) {
            let (key, reason) = narrow(k, v, e.to_string());
            return Err(SessionError::ConfigFile {
                file: path.to_owned(),
                reason: format!("key `{key}`: {reason}"),
            });
        }
    }
    Ok(())
}

/// The deepest key under `key` (value `v`) that Zenoh refuses on its own, and why; `key`
/// itself when none of its parts is refused alone.
fn narrow(key: &str, v: &Value, reason: String) -> (String, String) {
    if let Some(children) = v.as_object() {
        for (ck, cv) in children {
            let child = format!("{key}/{ck}");
            let mut scratch = zenoh::Config::default();
            if let Err(e) = scratch.insert_json5(&child, &cv.to_string()) {
                return narrow(&child, cv, e.to_string());
            }
        }
    }
    (key.to_owned(), reason)
}

/// Whether the file's `value` names `key` (`a/b/c`).
fn names(value: &Value, key: &str) -> bool {
    let mut v = value;
    for part in key.split('/') {
        match v.get(part) {
            Some(child) => v = child,
            None => return false,
        }
    }
    true
}

/// Mutual TLS from the flags: the CA checks the other side's certificate, this host's
/// certificate and key are presented both ways, and client certificates are required.
fn apply_tls(z: &mut zenoh::Config, tls: &TlsFiles, prefix: &str) -> Result<(), SessionError> {
    let path_json = |flag: &str, path: &Path, begins: &str| -> Result<String, SessionError> {
        let flag = format!("--{prefix}{flag}");
        let bad =
            |reason: String| SessionError::Flag(format!("{flag} {}: {reason}", path.display()));
        let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
        if !text.contains(begins) {
            return Err(bad(format!("not a PEM file (no `{begins}`)")));
        }
        let Some(s) = path.to_str() else {
            return Err(bad("the path is not UTF-8".into()));
        };
        Ok(serde_json::to_string(s).unwrap_or_default())
    };
    let ca = path_json("tls-ca", &tls.ca, "-----BEGIN CERTIFICATE-----")?;
    let cert = path_json("tls-cert", &tls.cert, "-----BEGIN CERTIFICATE-----")?;
    let key = path_json("tls-key", &tls.key, "PRIVATE KEY-----")?;
    for (k, v) in [
        ("transport/link/tls/root_ca_certificate", &ca),
        ("transport/link/tls/listen_certificate", &cert),
        ("transport/link/tls/listen_private_key", &key),
        ("transport/link/tls/connect_certificate", &cert),
        ("transport/link/tls/connect_private_key", &key),
        ("transport/link/tls/enable_mtls", &"true".to_owned()),
        (
            "transport/link/tls/verify_name_on_connect",
            &"true".to_owned(),
        ),
    ] {
        insert(z, k, v)?;
    }
    Ok(())
}
