//! Link signing, optional and off by default (as MAVLink 2's message signing): a 128-bit key
//! shared at pairing ([`crate::RequestBody::SetSigning`]) and kept in the device's
//! non-volatile store; while it is on ([`crate::DeviceInfo::signing`]) every session-bound
//! request but `Close` must carry a valid signature, so a frame forged with a session id read off the line
//! is refused, and a recorded one replayed is too.
//!
//! A signed request frame is `COBS(postcard(request) ‖ counter ‖ tag ‖ CRC-32) ‖ 0x00`:
//! `counter` a u64 little-endian that the host raises with every signed frame (host-tool: the
//! wall clock's µs since 1970, so it rises across host processes too), and `tag` the
//! 64-bit SipHash-2-4 of `postcard(request) ‖ counter` under the key, little-endian. The
//! device accepts a signed request only when its tag checks out and its counter is above the
//! last one it accepted; the session id inside the signed bytes binds it to the session, so a
//! frame recorded in an earlier session is refused by the session rule. An unsigned frame is
//! the plain frame ([`crate::frame`]): the signature is a trailer, and requests anyone may
//! send (`Hello`, `GetStatus`, `GetParam`, `Abort`) stay unsigned.
//!
//! Why SipHash-2-4 (the `siphasher` crate, no_std): it is a keyed PRF designed as a MAC for
//! short messages, a few hundred bytes of code and ≈ 10 cycles per byte on a Cortex-M4, fed one
//! byte at a time as the frame arrives ([`crate::FrameDecoder`]), so verifying the largest plan
//! costs its receiving passes a few cycles per byte and its last pass only the finalisation.
//! HMAC-SHA-256 would cost ≈ 20 k cycles per plan frame and ≈ 3 KiB of flash. A 64-bit tag
//! makes a blind forgery succeed once in 2^64 tries; each try costs a frame on a 115 200 Bd
//! line.
//!
//! Computing tags needs the feature `signing`; the message types are the same either way.

/// Bytes of a link key.
pub const KEY_LEN: usize = 16;
/// Bytes of the counter in a signed frame.
pub const COUNTER_LEN: usize = 8;
/// Bytes of the tag in a signed frame.
pub const TAG_LEN: usize = 8;
/// Bytes a signature adds to a frame's payload: counter and tag.
pub const TRAILER_LEN: usize = COUNTER_LEN + TAG_LEN;

/// A link key.
pub type LinkKey = [u8; KEY_LEN];

/// The incremental MAC: bytes in one at a time, the tag of what went in.
#[cfg(feature = "signing")]
#[derive(Debug, Clone)]
pub struct Mac {
    fresh: siphasher::sip::SipHasher24,
    state: siphasher::sip::SipHasher24,
}

#[cfg(feature = "signing")]
impl Mac {
    /// A MAC under `key`, over nothing yet.
    pub fn new(key: &LinkKey) -> Self {
        let fresh = siphasher::sip::SipHasher24::new_with_key(key);
        Self {
            state: fresh,
            fresh,
        }
    }

    /// One more byte.
    #[inline(always)]
    pub fn update(&mut self, byte: u8) {
        use core::hash::Hasher;
        self.state.write_u8(byte);
    }

    /// The tag of the bytes so far (the state is kept).
    pub fn tag(&self) -> [u8; TAG_LEN] {
        use core::hash::Hasher;
        self.state.finish().to_le_bytes()
    }

    /// Starts over, under the same key.
    pub fn reset(&mut self) {
        self.state = self.fresh;
    }
}

/// The tag of `bytes` under `key`.
#[cfg(feature = "signing")]
pub fn tag(key: &LinkKey, bytes: &[u8]) -> [u8; TAG_LEN] {
    let mut m = Mac::new(key);
    for &b in bytes {
        m.update(b);
    }
    m.tag()
}

#[cfg(all(test, feature = "signing"))]
mod tests {
    use super::*;
    use crate::{FrameDecoder, FrameError, Request, RequestBody};

    const KEY: LinkKey = *b"0123456789abcdef";

    fn request() -> Request {
        Request {
            seq: 7,
            session: 0x1234_5678,
            body: RequestBody::SetParam {
                id: crate::ParamId::PressureLimitKpa,
                value: 30.0,
            },
        }
    }

    fn signed(key: &LinkKey, counter: u64) -> ([u8; crate::MAX_FRAME_LEN], usize) {
        let mut buf = [0u8; crate::MAX_FRAME_LEN];
        let n = crate::frame::encode_signed(&request(), key, counter, &mut buf).unwrap();
        (buf, n)
    }

    fn push_all(d: &mut FrameDecoder, bytes: &[u8]) -> Option<Result<Request, FrameError>> {
        let mut out = Request::blank();
        let mut last = None;
        for &b in bytes {
            if let Some(r) = d.push_request(b, &mut out) {
                last = Some(r.map(|()| out.clone()));
            }
        }
        last
    }

    #[test]
    fn sip_hash_2_4_is_the_reference_vector() {
        // The SipHash paper's test vector (appendix A): key 00..0f, message 00..0e.
        let key: LinkKey = core::array::from_fn(|i| i as u8);
        let msg: [u8; 15] = core::array::from_fn(|i| i as u8);
        assert_eq!(u64::from_le_bytes(tag(&key, &msg)), 0xa129_ca61_49be_45e5);
    }

    #[test]
    fn a_signed_frame_decodes_with_its_counter_under_the_key_only() {
        let (buf, n) = signed(&KEY, 99);
        // Its payload is the plain frame's plus 16 bytes.
        let mut plain = [0u8; crate::MAX_FRAME_LEN];
        let p = crate::encode(&request(), &mut plain).unwrap();
        assert_eq!(n, p + TRAILER_LEN);
        let mut keyed = FrameDecoder::new();
        keyed.set_key(Some(&KEY));
        assert_eq!(push_all(&mut keyed, &buf[..n]), Some(Ok(request())));
        assert_eq!(keyed.signed_counter(), Some(99));
        // The plain frame decodes too, as unsigned.
        assert_eq!(push_all(&mut keyed, &plain[..p]), Some(Ok(request())));
        assert_eq!(keyed.signed_counter(), None);
        // Another key, or no key: the trailer is left over, the frame is dropped.
        let mut other = FrameDecoder::new();
        other.set_key(Some(b"fedcba9876543210"));
        assert_eq!(
            push_all(&mut other, &buf[..n]),
            Some(Err(FrameError::Payload))
        );
        assert_eq!(other.signed_counter(), None);
        let mut none = FrameDecoder::new();
        assert_eq!(
            push_all(&mut none, &buf[..n]),
            Some(Err(FrameError::Payload))
        );
        // After a dropped frame the next one verifies again (the MAC starts over).
        assert_eq!(
            push_all(&mut keyed, &[1, 2, 3, 0]).map(|r| r.is_err()),
            Some(true)
        );
        let (buf2, n2) = signed(&KEY, 100);
        assert_eq!(push_all(&mut keyed, &buf2[..n2]), Some(Ok(request())));
        assert_eq!(keyed.signed_counter(), Some(100));
    }

    #[test]
    fn a_changed_counter_or_payload_byte_breaks_the_signature() {
        // Re-sign with the CRC fixed up but one signed byte changed: the tag no longer
        // matches, and the frame is dropped rather than taken as unsigned.
        let mut raw = [0u8; 64];
        let used = postcard::to_slice(&request(), &mut raw).unwrap().len();
        raw[used..used + COUNTER_LEN].copy_from_slice(&5u64.to_le_bytes());
        let t = tag(&KEY, &raw[..used + COUNTER_LEN]);
        raw[used + COUNTER_LEN..used + TRAILER_LEN].copy_from_slice(&t);
        for at in [
            0,
            used - 1,
            used,
            used + COUNTER_LEN - 1,
            used + COUNTER_LEN,
        ] {
            let mut bad = raw;
            bad[at] ^= 0x01;
            let len = used + TRAILER_LEN;
            let crc = crate::frame::crc32_for_tests(&bad[..len]);
            bad[len..len + 4].copy_from_slice(&crc.to_le_bytes());
            let mut out = [0u8; 128];
            let n = cobs::encode(&bad[..len + 4], &mut out);
            out[n] = 0;
            let mut d = FrameDecoder::new();
            d.set_key(Some(&KEY));
            let got = push_all(&mut d, &out[..n + 1]);
            assert!(
                d.signed_counter().is_none(),
                "byte {at} flipped: still signed ({got:?})"
            );
        }
    }
}
