//! Round-trip probes between bridges: each bridge pings on `bridge/ping` at `probe_hz` and
//! answers the others' pings at once on `bridge/pong`; the round trips give each peer's
//! one-way delay ([`PeerDelays`]), which re-stamps its samples into local time.

use crate::clock::{HostClock, PeerDelays};
use crate::frame::{self, FrameHeader, Kind};
use crate::session::{declare_error, key};
use crate::{BridgeError, lock};
use std::sync::{Arc, Mutex};
use zenoh::Wait;
use zenoh::pubsub::Subscriber;

/// The two subscribers of the probes: undeclared when dropped.
pub(crate) struct Probes {
    _ping: Subscriber<()>,
    _pong: Subscriber<()>,
}

impl Probes {
    /// Answers other bridges' pings (on Zenoh's thread, at once) and times the answers to
    /// this bridge's (`id`), into `delays`.
    pub(crate) fn declare(
        session: &zenoh::Session,
        keys: &str,
        id: u64,
        clock: HostClock,
        delays: &Arc<Mutex<PeerDelays>>,
    ) -> Result<Self, BridgeError> {
        let pong_key = key(keys, "bridge/pong");
        let ping = {
            let replier = session.clone();
            let pong_key = pong_key.clone();
            session
                .declare_subscriber(key(keys, "bridge/ping"))
                .callback(move |sample| {
                    let bytes = sample.payload().to_bytes();
                    if let Ok((h, _)) = frame::decode_raw(&bytes)
                        && h.kind == Kind::PING
                        && h.sender != id
                    {
                        let pong = frame::encode_raw(
                            FrameHeader {
                                kind: Kind::PONG,
                                ..h
                            },
                            &id.to_le_bytes(),
                        );
                        let _ = replier.put(&pong_key, pong).wait();
                    }
                })
                .wait()
                .map_err(declare_error(&key(keys, "bridge/ping")))?
        };
        let pong = {
            let delays = delays.clone();
            session
                .declare_subscriber(&pong_key)
                .callback(move |sample| {
                    let now = clock.now();
                    let bytes = sample.payload().to_bytes();
                    if let Ok((h, payload)) = frame::decode_raw(&bytes)
                        && h.kind == Kind::PONG
                        && h.sender == id
                        && let Ok(peer) = <[u8; 8]>::try_from(payload)
                    {
                        let rtt = now.wrapping_sub(h.sent_ns);
                        // A reply to a probe of a previous life of this id would be absurd.
                        if rtt < 10_000_000_000 {
                            lock(&delays).record(
                                u64::from_le_bytes(peer),
                                rtt,
                                ipc_types::monotonic_ns(),
                            );
                        }
                    }
                })
                .wait()
                .map_err(declare_error(&pong_key))?
        };
        Ok(Probes {
            _ping: ping,
            _pong: pong,
        })
    }
}

/// A ping of bridge `id`, stamped now in `clock`.
pub(crate) fn ping(id: u64, clock: &HostClock) -> Vec<u8> {
    frame::encode_raw(
        FrameHeader {
            kind: Kind::PING,
            sender: id,
            sent_ns: clock.now(),
        },
        &[],
    )
}
