//! CDR as ROS 2 puts it on the wire (OMG XCDR version 1, "plain CDR", little-endian), the
//! payload of every rmw_zenoh sample.
//!
//! A payload is a 4-byte encapsulation header, `00 01 00 00` (representation CDR_LE, options
//! 0), then the fields in declaration order: a primitive of n bytes (1, 2, 4 or 8) starts at a
//! multiple of n counted from the first byte *after* the header; a string is a `u32` length
//! that counts its terminating NUL, the UTF-8 bytes and the NUL; a sequence is a `u32` count
//! and its elements; a fixed array is its elements; a nested message is its fields (no
//! alignment of its own). `bool` is one byte, 0 or 1.
//!
//! The reader is strict and never panics: every read is bounds-checked and names the field it
//! was reading, a sequence count cannot claim more elements than bytes remain, strings must be
//! NUL-terminated UTF-8, and more than 3 bytes left after the message (the padding some
//! writers add to a multiple of 4) is an error.

/// The encapsulation header of little-endian plain CDR (CDR_LE).
pub const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Why a payload could not be read. Each names the field being read (`what`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CdrError {
    /// Shorter than the 4-byte encapsulation header.
    #[error("{len}-byte payload: shorter than the 4-byte CDR encapsulation header")]
    NoHeader {
        /// Bytes received.
        len: usize,
    },
    /// Big-endian CDR (`00 00`): rmw_zenoh writes little-endian only, and so do we.
    #[error("big-endian CDR (encapsulation 00 00): only little-endian CDR (00 01) is read")]
    BigEndian,
    /// Another representation (XCDR2, parameter lists, ...).
    #[error("encapsulation {0:02x} {1:02x}: not plain little-endian CDR (00 01)")]
    Encapsulation(u8, u8),
    /// The payload ends inside a field.
    #[error("{what}: payload ends at byte {at} of the message, {needed} more needed")]
    Short {
        /// The field.
        what: &'static str,
        /// Offset after the header where the read started.
        at: usize,
        /// Bytes missing.
        needed: usize,
    },
    /// A string without its terminating NUL, or of length 0.
    #[error("{what}: string of length {len} is not NUL-terminated")]
    Unterminated {
        /// The field.
        what: &'static str,
        /// Its length field.
        len: u32,
    },
    /// A string that is not UTF-8.
    #[error("{what}: string is not UTF-8")]
    NotUtf8 {
        /// The field.
        what: &'static str,
    },
    /// A sequence longer than its reader accepts, or than the bytes that remain.
    #[error("{what}: sequence of {count} elements, at most {max} fit")]
    SequenceTooLong {
        /// The field.
        what: &'static str,
        /// Its count field.
        count: u32,
        /// The most it could hold.
        max: usize,
    },
    /// A `bool` that is neither 0 nor 1.
    #[error("{what}: bool byte {value}, expected 0 or 1")]
    Bool {
        /// The field.
        what: &'static str,
        /// The byte.
        value: u8,
    },
    /// Bytes left after the message.
    #[error("{extra} bytes after the end of the message (at most 3 bytes of padding allowed)")]
    Trailing {
        /// How many.
        extra: usize,
    },
}

/// Writes one message: the header first, then fields in order.
#[derive(Debug, Default)]
pub struct CdrWriter {
    buf: Vec<u8>,
}

impl CdrWriter {
    /// A writer with the encapsulation header written.
    pub fn new() -> Self {
        Self::with_buffer(Vec::new())
    }

    /// A writer reusing `buf`'s allocation (cleared), header written.
    pub fn with_buffer(mut buf: Vec<u8>) -> Self {
        buf.clear();
        buf.extend_from_slice(&CDR_LE);
        CdrWriter { buf }
    }

    fn align(&mut self, n: usize) {
        let offset = self.buf.len() - CDR_LE.len();
        let pad = (n - offset % n) % n;
        self.buf.extend(std::iter::repeat_n(0u8, pad));
    }

    /// A `uint8` (or `byte`, `char`).
    pub fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }

    /// A `bool`: one byte, 0 or 1.
    pub fn bool(&mut self, v: bool) {
        self.buf.push(u8::from(v));
    }

    /// An `int32`.
    pub fn i32(&mut self, v: i32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `uint32`.
    pub fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `float32`.
    pub fn f32(&mut self, v: f32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `float64`.
    pub fn f64(&mut self, v: f64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `string` (its length counts the NUL written after it).
    pub fn string(&mut self, s: &str) {
        self.u32(seq_count(s.len() + 1));
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    /// The count of a sequence of `n` elements (the elements follow).
    pub fn sequence(&mut self, n: usize) {
        self.u32(seq_count(n));
    }

    /// The bytes of a `uint8[]` sequence (count included).
    pub fn bytes(&mut self, b: &[u8]) {
        self.sequence(b.len());
        self.buf.extend_from_slice(b);
    }

    /// The payload, header included.
    pub fn finish(self) -> Vec<u8> {
        self.buf
    }
}

/// A sequence or string length as CDR's `u32`. Our own messages are far below 4 GiB; a longer
/// one saturates, which no reader accepts, rather than wrapping into a wrong message.
fn seq_count(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// Reads one message from a payload (header checked in [`CdrReader::new`]).
#[derive(Debug)]
pub struct CdrReader<'a> {
    body: &'a [u8],
    pos: usize,
}

impl<'a> CdrReader<'a> {
    /// A reader of `payload`, whose encapsulation header must be CDR_LE.
    pub fn new(payload: &'a [u8]) -> Result<Self, CdrError> {
        if payload.len() < CDR_LE.len() {
            return Err(CdrError::NoHeader { len: payload.len() });
        }
        match (payload[0], payload[1]) {
            (0x00, 0x01) => {}
            (0x00, 0x00) => return Err(CdrError::BigEndian),
            (a, b) => return Err(CdrError::Encapsulation(a, b)),
        }
        Ok(CdrReader {
            body: &payload[CDR_LE.len()..],
            pos: 0,
        })
    }

    fn take(&mut self, what: &'static str, n: usize, align: usize) -> Result<&'a [u8], CdrError> {
        let start = self.pos + (align - self.pos % align) % align;
        let end = start.saturating_add(n);
        if end > self.body.len() {
            return Err(CdrError::Short {
                what,
                at: self.pos,
                needed: end - self.body.len(),
            });
        }
        self.pos = end;
        Ok(&self.body[start..end])
    }

    fn array<const N: usize>(&mut self, what: &'static str) -> Result<[u8; N], CdrError> {
        let s = self.take(what, N, N)?;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }

    /// A `uint8`.
    pub fn u8(&mut self, what: &'static str) -> Result<u8, CdrError> {
        Ok(self.take(what, 1, 1)?[0])
    }

    /// A `bool` (0 or 1).
    pub fn bool(&mut self, what: &'static str) -> Result<bool, CdrError> {
        match self.u8(what)? {
            0 => Ok(false),
            1 => Ok(true),
            value => Err(CdrError::Bool { what, value }),
        }
    }

    /// An `int32`.
    pub fn i32(&mut self, what: &'static str) -> Result<i32, CdrError> {
        self.array::<4>(what).map(i32::from_le_bytes)
    }

    /// A `uint32`.
    pub fn u32(&mut self, what: &'static str) -> Result<u32, CdrError> {
        self.array::<4>(what).map(u32::from_le_bytes)
    }

    /// A `float32`.
    pub fn f32(&mut self, what: &'static str) -> Result<f32, CdrError> {
        self.array::<4>(what).map(f32::from_le_bytes)
    }

    /// A `float64`.
    pub fn f64(&mut self, what: &'static str) -> Result<f64, CdrError> {
        self.array::<8>(what).map(f64::from_le_bytes)
    }

    /// A `string`.
    pub fn string(&mut self, what: &'static str) -> Result<&'a str, CdrError> {
        let len = self.u32(what)?;
        let bytes = self.take(what, len as usize, 1)?;
        match bytes.split_last() {
            Some((0, text)) => std::str::from_utf8(text).map_err(|_| CdrError::NotUtf8 { what }),
            _ => Err(CdrError::Unterminated { what, len }),
        }
    }

    /// The count of a sequence whose elements take at least `min_element_bytes` each, at
    /// most `max` of them.
    pub fn sequence(
        &mut self,
        what: &'static str,
        min_element_bytes: usize,
        max: usize,
    ) -> Result<usize, CdrError> {
        let count = self.u32(what)?;
        let remaining = self.body.len() - self.pos;
        let fit = max.min(remaining / min_element_bytes.max(1));
        if count as usize > fit {
            return Err(CdrError::SequenceTooLong {
                what,
                count,
                max: fit,
            });
        }
        Ok(count as usize)
    }

    /// Checks that nothing but padding (at most 3 bytes) follows the message.
    pub fn finish(self) -> Result<(), CdrError> {
        let extra = self.body.len() - self.pos;
        if extra > 3 {
            return Err(CdrError::Trailing { extra });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitives_are_aligned_from_the_end_of_the_header() {
        let mut w = CdrWriter::new();
        w.u8(7);
        w.f64(1.5);
        w.string("ab");
        w.i32(-2);
        let b = w.finish();
        // header | 07 | 7 pad | f64 | len 3 | 'a' 'b' 0 | 1 pad | i32
        assert_eq!(b.len(), 4 + 1 + 7 + 8 + 4 + 3 + 1 + 4);
        assert_eq!(&b[..5], &[0, 1, 0, 0, 7]);
        assert_eq!(&b[12..20], &1.5f64.to_le_bytes());
        let mut r = CdrReader::new(&b).unwrap();
        assert_eq!(r.u8("a").unwrap(), 7);
        assert_eq!(r.f64("b").unwrap(), 1.5);
        assert_eq!(r.string("c").unwrap(), "ab");
        assert_eq!(r.i32("d").unwrap(), -2);
        r.finish().unwrap();
    }

    #[test]
    fn malformed_payloads_are_errors_naming_the_field() {
        assert_eq!(
            CdrReader::new(&[0, 1]).unwrap_err(),
            CdrError::NoHeader { len: 2 }
        );
        assert_eq!(
            CdrReader::new(&[0, 0, 0, 0]).unwrap_err(),
            CdrError::BigEndian
        );
        assert_eq!(
            CdrReader::new(&[0, 7, 0, 0]).unwrap_err(),
            CdrError::Encapsulation(0, 7)
        );
        let mut r = CdrReader::new(&[0, 1, 0, 0, 1, 2, 3]).unwrap();
        let e = r.f64("wrench.force.x").unwrap_err();
        assert_eq!(
            e,
            CdrError::Short {
                what: "wrench.force.x",
                at: 0,
                needed: 5
            }
        );
        assert!(e.to_string().contains("wrench.force.x"));
        // A string length beyond the payload, and one without its NUL.
        let mut r = CdrReader::new(&[0, 1, 0, 0, 0xff, 0xff, 0xff, 0x7f, b'a']).unwrap();
        assert!(matches!(r.string("frame_id"), Err(CdrError::Short { .. })));
        let mut r = CdrReader::new(&[0, 1, 0, 0, 2, 0, 0, 0, b'a', b'b']).unwrap();
        assert!(matches!(
            r.string("frame_id"),
            Err(CdrError::Unterminated { len: 2, .. })
        ));
        let mut r = CdrReader::new(&[0, 1, 0, 0, 0, 0, 0, 0]).unwrap();
        assert!(matches!(
            r.string("frame_id"),
            Err(CdrError::Unterminated { len: 0, .. })
        ));
        let mut r = CdrReader::new(&[0, 1, 0, 0, 2, 0, 0, 0, 0xff, 0]).unwrap();
        assert!(matches!(r.string("s"), Err(CdrError::NotUtf8 { .. })));
        // A count that claims more elements than the bytes could hold.
        let mut r = CdrReader::new(&[0, 1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0]).unwrap();
        assert!(matches!(
            r.sequence("poses", 8, 1000),
            Err(CdrError::SequenceTooLong {
                count: 16_777_216,
                ..
            })
        ));
        let mut r = CdrReader::new(&[0, 1, 0, 0, 2]).unwrap();
        assert!(matches!(r.bool("b"), Err(CdrError::Bool { value: 2, .. })));
        let r = CdrReader::new(&[0, 1, 0, 0, 1, 2, 3, 4]).unwrap();
        assert_eq!(r.finish(), Err(CdrError::Trailing { extra: 4 }));
        let r = CdrReader::new(&[0, 1, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(r.finish(), Ok(()));
    }

    /// Any bytes give a value or an error, never a panic.
    #[test]
    fn arbitrary_bytes_never_panic() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for len in 0..200usize {
            for _ in 0..50 {
                let bytes: Vec<u8> = (0..len)
                    .map(|i| {
                        x ^= x << 13;
                        x ^= x >> 7;
                        x ^= x << 17;
                        if i < 2 { [0u8, 1][i] } else { x as u8 }
                    })
                    .collect();
                if let Ok(mut r) = CdrReader::new(&bytes) {
                    let _ = r.string("s");
                    let _ = r.sequence("q", 4, 100);
                    let _ = r.f64("f");
                    let _ = r.bool("b");
                    let _ = r.finish();
                }
            }
        }
    }
}
