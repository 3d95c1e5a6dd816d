//! Any bytes as a frame from another bridge: what the receiving bridge runs on every sample.
//!
//! The receive path (`import::accept`, private to the bridge) is built from public pieces,
//! which are checked here the way it puts them together: `frame::decode::<T>` for each kind
//! it carries, then the re-stamping into local time (`clock::age_at_send_ns` against the
//! 100 ms future limit, then `clock::to_local` on every stamp); and the probes' handling
//! (`probe.rs`): a ping is answered with a pong of its own header, a pong's payload is read
//! as the answering bridge's id (`[u8; 8]`) and its round trip recorded.
//!
//! Payloads of paths (28 KB) and roadmaps (91 KB) are far beyond what a fuzzer mutates
//! well, so a frame whose payload is shorter than its kind's value is decoded twice: as it
//! came (a size error) and completed to the full size with the bytes of an empty value,
//! so that a short input reaches every check of the value's leading fields.

use hrrtc_bridge::clock::{self, PeerDelays};
use hrrtc_bridge::frame::{self, Carried, FrameError, FrameHeader, HEADER_LEN, Kind};
use ipc_types::{Guidance, HapticState, Path, Roadmap};

/// A stamp this far (ns) after the frame's `sent_ns` is rejected (`import::to_local_time`).
const MAX_FUTURE_NS: i64 = 100_000_000;
/// Round trips a pong is accepted with, below this (ns; `probe.rs`).
const MAX_RTT_NS: u64 = 10_000_000_000;
/// Local arrival times (ns) each accepted sample is re-stamped at: just booted, a day up,
/// and the far ends of the clock (arithmetic must wrap, never overflow).
const ARRIVALS_NS: [u64; 4] = [1, 86_400_000_000_000, u64::MAX / 2, u64::MAX];
/// One-way delays (ns): none measured yet, 250 µs, and the largest a probe gives.
const ONE_WAYS_NS: [u64; 3] = [0, 250_000, MAX_RTT_NS / 2];
/// The receiving bridge's id.
const OUR_ID: u64 = 0x5eed_b41d_9e00_0001;

/// Any bytes received as a bridge frame: decoding never panics; a value that decodes passes
/// its kind's checks, re-encodes to the same bytes, and re-stamps into local time by the
/// formula, with wrapping arithmetic, its unset stamps left unset and its checks still
/// passed; pings are answered with a pong that decodes to the ping's header and our id, and
/// pongs time round trips within bounds.
pub fn bridge_frame(data: &[u8]) {
    let raw = frame::decode_raw(data);
    check_raw(data, &raw);
    receive::<HapticState>(data);
    receive::<Guidance>(data);
    receive::<Path>(data);
    receive::<Roadmap>(data);
    probe(data);
    if let Ok((header, payload)) = raw {
        let full = match header.kind {
            Kind::STATE => completed(header, payload, &HapticState::default()),
            Kind::GUIDANCE => completed(header, payload, &Guidance::default()),
            Kind::PATH => completed(header, payload, &Path::EMPTY),
            Kind::ROADMAP => completed(header, payload, &Roadmap::EMPTY),
            _ => None,
        };
        if let Some(full) = full {
            match header.kind {
                Kind::STATE => receive::<HapticState>(&full),
                Kind::GUIDANCE => receive::<Guidance>(&full),
                Kind::PATH => receive::<Path>(&full),
                _ => receive::<Roadmap>(&full),
            }
        }
    }
}

/// The header split off, or an error that says why.
fn check_raw(data: &[u8], raw: &Result<(FrameHeader, &[u8]), FrameError>) {
    match raw {
        Ok((header, payload)) => {
            assert_eq!(payload.len() + HEADER_LEN, data.len());
            assert_eq!(
                frame::encode_raw(*header, payload),
                data,
                "header re-encoded"
            );
        }
        Err(FrameError::TooShort { len }) => assert!(*len == data.len() && *len < HEADER_LEN),
        Err(FrameError::BadMagic(magic)) => assert_ne!(*magic, frame::MAGIC),
        Err(e) => panic!("decode_raw: {e}"),
    }
}

/// `payload` with the bytes of `empty` after it up to the size of a `T`, framed with
/// `header`; `None` if it is not shorter.
fn completed<T: Carried>(header: FrameHeader, payload: &[u8], empty: &T) -> Option<Vec<u8>> {
    let rest = empty
        .as_bytes()
        .get(payload.len()..)
        .filter(|r| !r.is_empty())?;
    let mut full = payload.to_vec();
    full.extend_from_slice(rest);
    Some(frame::encode_raw(header, &full))
}

/// `data` received where a `T` belongs.
fn receive<T: Carried>(data: &[u8]) {
    let (header, value) = match frame::decode::<T>(data) {
        Ok(ok) => ok,
        Err(e) => {
            // Every rejection is logged: its message must not panic.
            assert!(!e.to_string().is_empty());
            return;
        }
    };
    let kind = T::KIND.name();
    assert_eq!(header.kind, T::KIND);
    if let Err(reason) = value.check() {
        panic!("a {kind} that decodes fails its own check: {reason}");
    }
    assert_eq!(
        frame::encode(header.sender, header.sent_ns, &value),
        data,
        "a {kind} re-encoded"
    );
    let age_ns = clock::age_at_send_ns(value.stamp(), header.sent_ns);
    if age_ns < -MAX_FUTURE_NS {
        return; // rejected: stamped after it was sent
    }
    for arrival_ns in ARRIVALS_NS {
        for one_way_ns in ONE_WAYS_NS {
            let mut local = value;
            local.restamp(|t| clock::to_local(t, header.sent_ns, arrival_ns, one_way_ns));
            if value.stamp() == 0 {
                assert_eq!(local.stamp(), 0, "an unset {kind} stamp set by re-stamping");
            } else {
                // local = arrival − age at sending − one-way delay (mod 2⁶⁴).
                assert_eq!(
                    arrival_ns.wrapping_sub(local.stamp()),
                    (age_ns as u64).wrapping_add(one_way_ns),
                    "a {kind} re-stamped"
                );
            }
            if let Err(reason) = local.check() {
                panic!("a {kind} fails its own check after re-stamping: {reason}");
            }
        }
    }
}

/// `data` received on the probes' keys, as `probe.rs` handles it.
fn probe(data: &[u8]) {
    let Ok((header, _)) = frame::decode_raw(data) else {
        return;
    };
    if header.kind == Kind::PING && header.sender != OUR_ID {
        let answer = FrameHeader {
            kind: Kind::PONG,
            ..header
        };
        let pong = frame::encode_raw(answer, &OUR_ID.to_le_bytes());
        let (back, peer) = frame::decode_raw(&pong).expect("our pong decodes");
        assert_eq!((back, peer), (answer, &OUR_ID.to_le_bytes()[..]));
        // The pinger times our answer.
        assert_eq!(pong_received(&pong, header.sender), Some(OUR_ID));
    }
    if header.kind == Kind::PONG {
        pong_received(data, header.sender);
        // A pong for another bridge's ping is ignored.
        assert_eq!(pong_received(data, header.sender.wrapping_add(1)), None);
    }
}

/// What bridge `id` does with a pong: the answering peer's id when it is a pong to one of
/// its pings, after recording its round trip at a few arrival times.
fn pong_received(data: &[u8], id: u64) -> Option<u64> {
    let (header, payload) = frame::decode_raw(data).ok()?;
    if header.kind != Kind::PONG || header.sender != id {
        return None;
    }
    let peer = u64::from_le_bytes(<[u8; 8]>::try_from(payload).ok()?);
    let mut delays = PeerDelays::default();
    let arrivals = [header.sent_ns, header.sent_ns.wrapping_add(1_000_000)];
    let mut last_answer_ns = 0;
    for now_ns in ARRIVALS_NS.into_iter().chain(arrivals) {
        let rtt_ns = now_ns.wrapping_sub(header.sent_ns);
        if rtt_ns < MAX_RTT_NS {
            // The local clock when it arrived: the presented clock's reading, here.
            delays.record(peer, rtt_ns, now_ns);
            last_answer_ns = last_answer_ns.max(now_ns);
            let min = delays.min_rtt_ns(peer).expect("a round trip was recorded");
            assert!(min <= rtt_ns);
            assert_eq!(delays.one_way_ns(peer), min / 2);
            assert_eq!(delays.min_rtt_overall_ns(), Some(min));
            assert!(delays.answered_recently(peer, last_answer_ns));
            if let Some(later) = last_answer_ns.checked_add(clock::ANSWERED_WITHIN_NS + 1) {
                assert!(
                    !delays.answered_recently(peer, later),
                    "a silent peer heard"
                );
            }
        }
    }
    // A pong answered at once was recorded, whatever the stamps.
    assert_eq!(delays.peers(), 1);
    let one_way_ns = delays.one_way_ns(peer);
    assert!(one_way_ns < MAX_RTT_NS / 2);
    let _ = clock::to_local(header.sent_ns, header.sent_ns, u64::MAX, one_way_ns);
    Some(peer)
}
