//! The bridge's wire format on Zenoh, and what a received sample must pass before it is
//! handed to local processes.
//!
//! A frame is a 24-byte header (little-endian: magic `HRB1`, [`Kind`], the sending
//! bridge's id, the sender's clock when it sent, ns) followed by one wire type's bytes
//! exactly as `ipc-types` lays it out (`#[repr(C)]`, fixed-width fields, no padding). Both
//! hosts must be little-endian (x86-64 and AArch64 are); the build refuses others.

use ipc_types::{Guidance, HapticState, Path, Roadmap};

#[cfg(not(target_endian = "little"))]
compile_error!("the bridge's frames carry native little-endian wire types");

/// `HRB1`: frames of this format.
pub const MAGIC: u32 = u32::from_le_bytes(*b"HRB1");
/// Bytes before the payload.
pub const HEADER_LEN: usize = 24;

/// What a frame carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Kind(pub u32);

impl Kind {
    /// A [`HapticState`] (loop's host → planners' hosts).
    pub const STATE: Self = Self(1);
    /// A [`Guidance`] sample (planner's host → loop's host).
    pub const GUIDANCE: Self = Self(2);
    /// A solution [`Path`].
    pub const PATH: Self = Self(3);
    /// A [`Roadmap`] increment.
    pub const ROADMAP: Self = Self(4);
    /// A round-trip probe; no payload.
    pub const PING: Self = Self(5);
    /// The answer to a probe: the probe's header with its sender and stamp, then the
    /// answering bridge's id (8 bytes).
    pub const PONG: Self = Self(6);

    /// A short name for messages.
    pub fn name(self) -> &'static str {
        match self {
            Self::STATE => "state",
            Self::GUIDANCE => "guidance",
            Self::PATH => "path",
            Self::ROADMAP => "roadmap",
            Self::PING => "ping",
            Self::PONG => "pong",
            _ => "unknown",
        }
    }
}

/// The header of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameHeader {
    /// What follows.
    pub kind: Kind,
    /// Random id of the bridge that sent it (fixed for the bridge's life).
    pub sender: u64,
    /// The sender's clock when it sent the frame, ns. Comparable only with the other
    /// stamps of the same frame (its host's clock, not ours).
    pub sent_ns: u64,
}

/// Why a received frame was rejected. Each is counted; none is handed on.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// Shorter than a header.
    #[error("{len} bytes: shorter than the {HEADER_LEN}-byte frame header")]
    TooShort {
        /// Bytes received.
        len: usize,
    },
    /// Not a frame of this format.
    #[error("bad magic {0:#010x}: not an hrrtc-bridge frame (or another version)")]
    BadMagic(u32),
    /// A frame of another kind on this key.
    #[error("a {got} frame where a {expected} frame belongs")]
    WrongKind {
        /// The key's kind.
        expected: &'static str,
        /// The frame's kind.
        got: &'static str,
    },
    /// The payload is not exactly one wire value.
    #[error("{kind} payload of {got} bytes, expected {expected}")]
    Size {
        /// The frame's kind.
        kind: &'static str,
        /// Size of the wire type.
        expected: usize,
        /// Payload bytes received.
        got: usize,
    },
    /// The value fails its checks.
    #[error("invalid {kind}: {reason}")]
    Invalid {
        /// The frame's kind.
        kind: &'static str,
        /// Which check failed.
        reason: String,
    },
}

/// Writes a frame header and `payload` into a new buffer.
pub fn encode_raw(header: FrameHeader, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_LEN + payload.len());
    out.extend_from_slice(&MAGIC.to_le_bytes());
    out.extend_from_slice(&header.kind.0.to_le_bytes());
    out.extend_from_slice(&header.sender.to_le_bytes());
    out.extend_from_slice(&header.sent_ns.to_le_bytes());
    out.extend_from_slice(payload);
    out
}

/// Splits a frame into its header and payload.
pub fn decode_raw(bytes: &[u8]) -> Result<(FrameHeader, &[u8]), FrameError> {
    if bytes.len() < HEADER_LEN {
        return Err(FrameError::TooShort { len: bytes.len() });
    }
    let u32_at =
        |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    let u64_at = |i: usize| u64::from(u32_at(i)) | (u64::from(u32_at(i + 4)) << 32);
    let magic = u32_at(0);
    if magic != MAGIC {
        return Err(FrameError::BadMagic(magic));
    }
    let header = FrameHeader {
        kind: Kind(u32_at(4)),
        sender: u64_at(8),
        sent_ns: u64_at(16),
    };
    Ok((header, &bytes[HEADER_LEN..]))
}

/// A wire type the bridge carries as raw bytes.
///
/// # Safety
///
/// Implement only for `#[repr(C)]` types made of `u32`, `u64`, `f64` and arrays and
/// structs of them with no padding bytes (checked for every implementer against
/// `ipc_types::layout` in the tests), so that the value's bytes are all initialised and
/// every byte pattern is a value of the type.
pub unsafe trait Carried: Copy + 'static {
    /// The frame kind that carries it.
    const KIND: Kind;
    /// Its `ipc_types::layout` name.
    const LAYOUT_NAME: &'static str;

    /// The checks a sample from another host must pass (beyond its size).
    fn check(&self) -> Result<(), String>;

    /// Rewrites every `CLOCK_MONOTONIC` stamp it carries with `f` (0, "not stamped", stays 0).
    fn restamp(&mut self, f: impl Fn(u64) -> u64);

    /// Its main stamp, `header.timestamp_ns`.
    fn stamp(&self) -> u64;

    /// Its bytes.
    fn as_bytes(&self) -> &[u8] {
        // SAFETY: `Carried` types have no padding, so all `size_of::<Self>()` bytes behind
        // `self` are initialised; the slice borrows `self`.
        unsafe {
            core::slice::from_raw_parts((self as *const Self).cast::<u8>(), size_of::<Self>())
        }
    }

    /// The value in `payload`, which must be exactly its size, then checked.
    fn from_payload(payload: &[u8]) -> Result<Self, FrameError> {
        if payload.len() != size_of::<Self>() {
            return Err(FrameError::Size {
                kind: Self::KIND.name(),
                expected: size_of::<Self>(),
                got: payload.len(),
            });
        }
        // SAFETY: the length is checked above, `read_unaligned` needs no alignment, and
        // every byte pattern is a value of a `Carried` type.
        let value = unsafe { core::ptr::read_unaligned(payload.as_ptr().cast::<Self>()) };
        value.check().map_err(|reason| FrameError::Invalid {
            kind: Self::KIND.name(),
            reason,
        })?;
        Ok(value)
    }
}

fn restamp_field(t: &mut u64, f: &impl Fn(u64) -> u64) {
    if *t != 0 {
        *t = f(*t);
    }
}

fn never_written(sequence: u64) -> Result<(), String> {
    if sequence == 0 {
        Err("sequence 0 (never written)".into())
    } else {
        Ok(())
    }
}

// SAFETY: `HapticState` is `#[repr(C)]` of u32/u64/f64 fields and arrays (poses, wrenches,
// codes are structs of them), with no padding (layout test below).
unsafe impl Carried for HapticState {
    const KIND: Kind = Kind::STATE;
    const LAYOUT_NAME: &'static str = "HapticState";

    fn check(&self) -> Result<(), String> {
        never_written(self.header.sequence)?;
        if !self.user_pose.is_valid() || !self.proxy_pose.is_valid() {
            return Err("user or proxy pose is not finite with a unit quaternion".into());
        }
        if !self.penetration_m.is_finite() {
            return Err("penetration is not finite".into());
        }
        Ok(())
    }

    fn restamp(&mut self, f: impl Fn(u64) -> u64) {
        restamp_field(&mut self.header.timestamp_ns, &f);
        restamp_field(&mut self.published_ns, &f);
    }

    fn stamp(&self) -> u64 {
        self.header.timestamp_ns
    }
}

// SAFETY: `#[repr(C)]` of u32/u64/f64 fields and arrays, no padding (layout test below).
unsafe impl Carried for Guidance {
    const KIND: Kind = Kind::GUIDANCE;
    const LAYOUT_NAME: &'static str = "Guidance";

    fn check(&self) -> Result<(), String> {
        // The checks the loop applies before rendering; the loop applies them again.
        self.validate().map_err(|e| format!("{e:?}"))
    }

    fn restamp(&mut self, f: impl Fn(u64) -> u64) {
        restamp_field(&mut self.header.timestamp_ns, &f);
    }

    fn stamp(&self) -> u64 {
        self.header.timestamp_ns
    }
}

// SAFETY: `#[repr(C)]` of u32/u64/f64 fields and an array of poses, no padding (layout
// test below).
unsafe impl Carried for Path {
    const KIND: Kind = Kind::PATH;
    const LAYOUT_NAME: &'static str = "Path";

    fn check(&self) -> Result<(), String> {
        never_written(self.header.sequence)?;
        if self.len > ipc_types::PATH_CAPACITY as u64 {
            return Err(format!(
                "{} waypoints, more than the capacity {}",
                self.len,
                ipc_types::PATH_CAPACITY
            ));
        }
        if !self.length.is_finite() || self.length < 0.0 {
            return Err(format!("length {} is not a finite distance", self.length));
        }
        match self.waypoints().iter().position(|p| !p.is_valid()) {
            Some(i) => Err(format!("waypoint {i} is not a valid pose")),
            None => Ok(()),
        }
    }

    fn restamp(&mut self, f: impl Fn(u64) -> u64) {
        restamp_field(&mut self.header.timestamp_ns, &f);
    }

    fn stamp(&self) -> u64 {
        self.header.timestamp_ns
    }
}

// SAFETY: `#[repr(C)]` of u32/u64/f64 fields and arrays of node and tree records made of
// them, no padding (layout test below).
unsafe impl Carried for Roadmap {
    const KIND: Kind = Kind::ROADMAP;
    const LAYOUT_NAME: &'static str = "Roadmap";

    fn check(&self) -> Result<(), String> {
        never_written(self.header.sequence)?;
        if self.trees_len as usize > ipc_types::ROADMAP_TREES
            || self.nodes_len as usize > ipc_types::ROADMAP_NODES
        {
            return Err(format!(
                "{} trees and {} nodes, beyond the capacities {} and {}",
                self.trees_len,
                self.nodes_len,
                ipc_types::ROADMAP_TREES,
                ipc_types::ROADMAP_NODES
            ));
        }
        match self.nodes().iter().position(|n| !n.pose.is_valid()) {
            Some(i) => Err(format!("node {i} has no valid pose")),
            None => Ok(()),
        }
    }

    fn restamp(&mut self, f: impl Fn(u64) -> u64) {
        restamp_field(&mut self.header.timestamp_ns, &f);
    }

    fn stamp(&self) -> u64 {
        self.header.timestamp_ns
    }
}

/// A frame carrying `value`.
pub fn encode<T: Carried>(sender: u64, sent_ns: u64, value: &T) -> Vec<u8> {
    encode_raw(
        FrameHeader {
            kind: T::KIND,
            sender,
            sent_ns,
        },
        value.as_bytes(),
    )
}

/// The header and value of a frame that must carry a `T`.
pub fn decode<T: Carried>(bytes: &[u8]) -> Result<(FrameHeader, T), FrameError> {
    let (header, payload) = decode_raw(bytes)?;
    if header.kind != T::KIND {
        return Err(FrameError::WrongKind {
            expected: T::KIND.name(),
            got: header.kind.name(),
        });
    }
    Ok((header, T::from_payload(payload)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipc_types::Header;

    /// Every wire struct's fields cover its bytes without a gap (so the `Carried` types,
    /// and the structs inside them, have no padding: `as_bytes` reads only initialised
    /// memory), and each `Carried` type is one of them.
    #[test]
    fn carried_types_have_no_padding() {
        let layout = ipc_types::layout::layout();
        for ty in &layout.structs {
            let mut end = 0;
            for f in &ty.fields {
                assert_eq!(f.offset, end, "{}.{}: a gap before it", ty.name, f.name);
                end = f.offset + f.size;
            }
            assert_eq!(end, ty.size, "{}: padding at the end", ty.name);
        }
        fn listed<T: Carried>(layout: &ipc_types::layout::Layout) {
            let ty = layout.structs.iter().find(|t| t.name == T::LAYOUT_NAME);
            assert_eq!(
                ty.map(|t| t.size),
                Some(size_of::<T>()),
                "{}",
                T::LAYOUT_NAME
            );
        }
        listed::<HapticState>(&layout);
        listed::<Guidance>(&layout);
        listed::<Path>(&layout);
        listed::<Roadmap>(&layout);
    }

    fn guidance() -> Guidance {
        Guidance {
            planner_id: 7,
            ..Guidance::roadmap(
                Header::new(3, 1_000, 42),
                [0.1, 0.0, -0.2, 0.0, 0.01, 0.0],
                20.0,
                0.0,
                0,
            )
        }
    }

    #[test]
    fn a_value_survives_the_round_trip() {
        let g = guidance();
        let bytes = encode(99, 1_500, &g);
        assert_eq!(bytes.len(), HEADER_LEN + size_of::<Guidance>());
        let (h, back) = decode::<Guidance>(&bytes).unwrap();
        assert_eq!(back, g);
        assert_eq!(h.sender, 99);
        assert_eq!(h.sent_ns, 1_500);
        assert_eq!(h.kind, Kind::GUIDANCE);
    }

    #[test]
    fn malformed_and_oversized_frames_are_rejected() {
        let bytes = encode(1, 2, &guidance());
        assert_eq!(
            decode::<Guidance>(&bytes[..10]),
            Err(FrameError::TooShort { len: 10 })
        );
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(matches!(
            decode::<Guidance>(&longer),
            Err(FrameError::Size { got, .. }) if got == size_of::<Guidance>() + 1
        ));
        assert!(matches!(
            decode::<Guidance>(&bytes[..bytes.len() - 8]),
            Err(FrameError::Size { .. })
        ));
        let mut magic = bytes.clone();
        magic[0] ^= 0xff;
        assert!(matches!(
            decode::<Guidance>(&magic),
            Err(FrameError::BadMagic(_))
        ));
        assert!(matches!(
            decode::<Path>(&bytes),
            Err(FrameError::WrongKind {
                expected: "path",
                got: "guidance"
            })
        ));
        // A finite header with a NaN force: the loop's own check, applied at the border.
        let mut nan = guidance();
        nan.attractive[2] = f64::NAN;
        assert!(matches!(
            decode::<Guidance>(&encode(1, 2, &nan)),
            Err(FrameError::Invalid {
                kind: "guidance",
                ..
            })
        ));
        let mut path = Path::default();
        path.header.sequence = 1;
        path.len = u64::MAX;
        assert!(matches!(
            decode::<Path>(&encode(1, 2, &path)),
            Err(FrameError::Invalid { kind: "path", .. })
        ));
        let mut state = HapticState::default();
        state.header.sequence = 5;
        state.user_pose.position_m[1] = f64::INFINITY;
        assert!(matches!(
            decode::<HapticState>(&encode(1, 2, &state)),
            Err(FrameError::Invalid { kind: "state", .. })
        ));
    }

    #[test]
    fn restamping_leaves_unset_stamps_unset() {
        let mut s = HapticState::default();
        s.header.timestamp_ns = 10;
        s.restamp(|t| t + 5);
        assert_eq!((s.header.timestamp_ns, s.published_ns), (15, 0));
    }
}
