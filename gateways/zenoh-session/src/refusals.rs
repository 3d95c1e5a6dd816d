//! Counting what Zenoh refuses. Zenoh exposes no counters for it (only its `stats` feature
//! would, through the admin space), but it logs each refusal once per connection attempt:
//! a TLS handshake that fails (no client certificate, one from another CA, not TLS at all)
//! as a warning of its TLS or QUIC listener (which adds a hint about the open-file limit, meant for
//! the listener's own errors: those name an OS error, and are not counted), and a peer whose certificate matches no subject of the
//! access control (every message of it denied) at info level in its access control. The
//! [`layer`] counts those events whatever the log prints, and [`Refusals`] reads the counts.
//! Matched on Zenoh 1.10's messages; the bridge's security tests check the counts, so a
//! change of wording fails there.

use std::sync::atomic::{AtomicU64, Ordering};
use tracing::field::{Field, Visit};
use tracing_subscriber::filter::Targets;
use tracing_subscriber::layer::Context;

/// Zenoh's modules that accept TLS and QUIC connections.
const TLS_TARGET: &str = "zenoh_link_tls::unicast";
const QUIC_TARGET: &str = "zenoh_link_commons::quic::unicast";
/// What it adds to every failed accept, a refused handshake or an OS error.
const TLS_ACCEPT_FAILED: &str = "Hint: increase the system open file limit";
/// What a failed accept that is not a refusal says: an OS error, or the QUIC endpoint
/// closing at shutdown.
const NOT_REFUSALS: [&str; 2] = ["(os error", "acceptor closed"];
/// Zenoh's access control.
const ACL_TARGET: &str = "zenoh::net::routing::interceptor::access_control";
/// What it logs when a peer matches no subject.
const ACL_NO_SUBJECT: &str = "did not match any configured ACL subject";

static TLS_HANDSHAKES: AtomicU64 = AtomicU64::new(0);
static PEERS_WITHOUT_SUBJECT: AtomicU64 = AtomicU64::new(0);

/// Refusals counted since the process started.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Refusals {
    /// TLS handshakes refused: no certificate, a certificate of another CA, or not TLS.
    pub tls_handshakes: u64,
    /// Peers let in by TLS but matching no access-control subject (their certificate's
    /// name is not allowed): every message of theirs is denied.
    pub peers_not_allowed: u64,
}

impl Refusals {
    /// The counts now.
    pub fn now() -> Self {
        Refusals {
            tls_handshakes: TLS_HANDSHAKES.load(Ordering::Relaxed),
            peers_not_allowed: PEERS_WITHOUT_SUBJECT.load(Ordering::Relaxed),
        }
    }

    /// Whether nothing was refused.
    pub fn is_none(&self) -> bool {
        *self == Refusals::default()
    }
}

impl std::fmt::Display for Refusals {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} TLS handshake(s) refused (no certificate, another CA's, or not TLS), {} peer(s) \
             whose certificate name is not allowed",
            self.tls_handshakes, self.peers_not_allowed
        )
    }
}

/// The layer that counts Zenoh's refusals (give it to
/// `ipc_types::startup::init_logging_with`). It enables only the two kinds of event it
/// counts, which Zenoh logs once per connection attempt, not per message.
pub fn layer<S>() -> impl tracing_subscriber::Layer<S> + Send + Sync + 'static
where
    S: tracing::Subscriber + for<'a> tracing_subscriber::registry::LookupSpan<'a>,
{
    use tracing_subscriber::Layer;
    let targets = Targets::new()
        .with_target(TLS_TARGET, tracing::Level::WARN)
        .with_target(QUIC_TARGET, tracing::Level::WARN)
        .with_target(ACL_TARGET, tracing::Level::INFO);
    Counter.with_filter(targets)
}

/// Counts the matching events.
struct Counter;

impl<S: tracing::Subscriber> tracing_subscriber::Layer<S> for Counter {
    fn on_event(&self, event: &tracing::Event<'_>, _ctx: Context<'_, S>) {
        let mut message = Message(String::new());
        event.record(&mut message);
        count(event.metadata().target(), &message.0);
    }
}

/// Counts one event of `target` saying `message`, if it is a refusal.
fn count(target: &str, message: &str) {
    let accept_failed = (target == TLS_TARGET || target == QUIC_TARGET)
        && message.contains(TLS_ACCEPT_FAILED)
        && !NOT_REFUSALS.iter().any(|n| message.contains(n));
    if accept_failed {
        TLS_HANDSHAKES.fetch_add(1, Ordering::Relaxed);
    } else if target == ACL_TARGET && message.contains(ACL_NO_SUBJECT) {
        PEERS_WITHOUT_SUBJECT.fetch_add(1, Ordering::Relaxed);
    }
}

/// An event's `message` field as text.
struct Message(String);

impl Visit for Message {
    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            self.0 = format!("{value:?}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_zenohs_refusals_are_counted() {
        let before = Refusals::now();
        let hint = "Hint: increase the system open file limit.";
        count(
            TLS_TARGET,
            &format!("invalid peer certificate: UnknownIssuer. {hint}"),
        );
        count(
            TLS_TARGET,
            &format!("Too many open files (os error 24). {hint}"),
        );
        count(
            QUIC_TARGET,
            &format!("QUIC acceptor failed: ConnectionLost {hint}"),
        );
        count(
            QUIC_TARGET,
            &format!("Can not accept QUIC connections: acceptor closed {hint}"),
        );
        count(
            ACL_TARGET,
            "4a2f did not match any configured ACL subject. Default permission `Deny` will be applied on all messages",
        );
        count(TLS_TARGET, "Accepted TLS connection on 127.0.0.1:7447");
        count("elsewhere", &format!("peer sent no certificates. {hint}"));
        let after = Refusals::now();
        assert_eq!(after.tls_handshakes - before.tls_handshakes, 2);
        assert_eq!(after.peers_not_allowed - before.peers_not_allowed, 1);
        assert!(after.to_string().contains("TLS handshake"));
    }
}
