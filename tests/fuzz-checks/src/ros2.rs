//! What every ROS 2 sample goes through: its attachment and its CDR payload, as
//! `hrrtc_ros2::rmw::Attachment::decode` and `msgs::Message::decode` read them, and the
//! fuzz inputs' layout of samples.

use hrrtc_ros2::msgs::Message;
use hrrtc_ros2::rmw::{ATTACHMENT_LEN, Attachment, AttachmentError};

/// The attachment length byte that stands for "no attachment".
pub const NO_ATTACHMENT: u8 = 255;

/// A sample as a subscriber's callback gets it.
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    /// Its attachment, if it has one.
    pub attachment: Option<&'a [u8]>,
    /// Its payload.
    pub payload: &'a [u8],
}

/// Splits an attachment off `data`: one byte of length ([`NO_ATTACHMENT`]: none), then that
/// many bytes (fewer if `data` ends). `None` when `data` is empty.
pub fn take_attachment(data: &[u8]) -> Option<(Option<&[u8]>, &[u8])> {
    let (&len, rest) = data.split_first()?;
    if len == NO_ATTACHMENT {
        return Some((None, rest));
    }
    let (attachment, rest) = rest.split_at(usize::from(len).min(rest.len()));
    Some((Some(attachment), rest))
}

/// The attachment length byte and bytes of `attachment` in a fuzz input.
pub fn put_attachment(out: &mut Vec<u8>, attachment: Option<&[u8]>) {
    match attachment {
        Some(a) => {
            let len = u8::try_from(a.len()).expect("an attachment of fewer than 255 bytes");
            assert_ne!(len, NO_ATTACHMENT);
            out.push(len);
            out.extend_from_slice(a);
        }
        None => out.push(NO_ATTACHMENT),
    }
}

/// Decodes an attachment: rmw_zenoh's 33 bytes and nothing else, and a decoded one encodes
/// to the same bytes. Whether it decoded.
pub fn attachment(bytes: Option<&[u8]>) -> bool {
    match Attachment::decode(bytes) {
        Ok(a) => {
            assert_eq!(Some(&a.encode()[..]), bytes, "an attachment re-encoded");
            true
        }
        Err(e) => {
            assert!(!e.to_string().is_empty());
            match (e, bytes) {
                (AttachmentError::Missing, None) => {}
                (AttachmentError::Malformed { len, gid_len }, Some(b)) => {
                    assert_eq!((len, gid_len), (b.len(), b.get(16).copied()));
                    assert!(len != ATTACHMENT_LEN || gid_len != Some(16));
                }
                (e, b) => panic!("{e:?} for attachment {b:?}"),
            }
            false
        }
    }
}

/// Decodes a payload as an `M`: a message or an error, never a panic; a message that
/// decodes was read to within the 3 bytes of padding allowed after it, and encodes to bytes
/// that decode to the same message (compared by its encoding and its `Debug` text, which
/// tell NaNs and signed zeros apart where `==` cannot).
pub fn message<M: Message + std::fmt::Debug>(payload: &[u8]) -> Option<M> {
    let m = match M::decode(payload) {
        Ok(m) => m,
        Err(e) => {
            assert!(!e.to_string().is_empty());
            return None;
        }
    };
    let name = M::TYPE.name;
    let bytes = m.encode();
    assert!(
        payload.len() >= bytes.len() && payload.len() - bytes.len() <= 3,
        "{name}: {} bytes decoded, {} re-encoded",
        payload.len(),
        bytes.len()
    );
    let again = M::decode(&bytes).unwrap_or_else(|e| panic!("{name} re-encoded: {e}"));
    assert_eq!(again.encode(), bytes, "{name} re-encoded twice");
    assert_eq!(format!("{again:?}"), format!("{m:?}"), "{name} re-decoded");
    Some(m)
}
