//! The security flags of `hrrtc-bridge` and `hrrtc-ros2` (`planner serve` has the same ones
//! for its in-process bridge, named `--bridge-*`).

use crate::{Security, TlsFiles};
use std::path::PathBuf;

/// How the links to other hosts are secured.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct SecurityArgs {
    /// Zenoh configuration file (JSON5, the format of rmw_zenoh's ZENOH_SESSION_CONFIG_URI):
    /// any Zenoh setting, above this program's defaults; the flags here apply on top of it.
    #[arg(long, value_name = "FILE")]
    pub zenoh_config: Option<PathBuf>,
    /// The lab's CA certificate (PEM): mutual TLS, the other side's certificate must be
    /// signed by it. With --tls-cert and --tls-key; endpoints are then quic/HOST:PORT (or
    /// tls/HOST:PORT, see the guide).
    #[arg(long, value_name = "FILE", requires_all = ["tls_cert", "tls_key"])]
    pub tls_ca: Option<PathBuf>,
    /// This host's certificate (PEM), signed by the CA, presented when listening and when
    /// connecting. Its subject alternative names must include the host others connect to.
    #[arg(long, value_name = "FILE", requires_all = ["tls_ca", "tls_key"])]
    pub tls_cert: Option<PathBuf>,
    /// This host's private key (PEM); keep it readable by this user only.
    #[arg(long, value_name = "FILE", requires_all = ["tls_ca", "tls_cert"])]
    pub tls_key: Option<PathBuf>,
    /// Allow links that are not mutually authenticated TLS (plain tcp/ endpoints, loopback
    /// included). Anyone who can reach such a port can read the operator's state and push
    /// on the arm: for a trusted, isolated network or a single-user machine only.
    #[arg(long)]
    pub insecure: bool,
}

impl SecurityArgs {
    /// The security these flags ask for (the flags are named `--<flag_prefix>tls-ca`, ...
    /// in messages).
    pub fn security(&self, flag_prefix: &'static str) -> Security {
        let tls = match (&self.tls_ca, &self.tls_cert, &self.tls_key) {
            (Some(ca), Some(cert), Some(key)) => Some(TlsFiles {
                ca: ca.clone(),
                cert: cert.clone(),
                key: key.clone(),
            }),
            _ => None,
        };
        Security {
            zenoh_config: self.zenoh_config.clone(),
            tls,
            insecure: self.insecure,
            flag_prefix,
        }
    }
}
