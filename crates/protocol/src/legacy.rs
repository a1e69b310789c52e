//! Protocol v1's handshake refusal, so that a v2 device refuses a v1 host in words the v1 host
//! understands (v1 cannot read CRC-32 frames at all).
//!
//! A v1 frame is `COBS(postcard ‖ CRC-16/IBM-SDLC) ‖ 0x00`, and a v1 `Hello` is
//! `Request { seq, Hello { protocol_version, schema_id } }` without a session. The v2
//! [`FrameDecoder`](crate::FrameDecoder) names such a frame
//! [`FrameError::Legacy`](crate::FrameError::Legacy); [`refuse_v1_hello`] turns it into the v1
//! answer
//! `Response { seq, Rejected(VersionMismatch), Hello(DeviceInfo) }` with this device's
//! protocol version and schema identity, which a v1 host reports naming both versions.
//! Nothing else of v1 is spoken.
//!
//! The v1 messages are written and read by the hand-written codec ([`crate::codec`]), in
//! postcard's wire form of v1's types (`tests/wire/legacy.rs` holds them to serde twins).

use crate::codec::{v1_hello_seq, v1_refusal, Writer};
use crate::frame::legacy_crc16;
use crate::messages::DeviceInfo;

/// When `raw` (an unstuffed frame with its CRC-16, as [`crate::FrameDecoder::last_frame`]
/// gives it after a [`crate::FrameError::Legacy`]) is a v1 `Hello`, writes the v1 refusal
/// carrying `info`'s versions into `out` as one v1 frame (delimiter included) and returns its
/// length; `None` for anything else.
pub fn refuse_v1_hello(raw: &[u8], info: &DeviceInfo, out: &mut [u8]) -> Option<usize> {
    let (payload, check) = raw.split_last_chunk::<2>()?;
    if legacy_crc16(payload).to_le_bytes() != *check {
        return None;
    }
    let seq = v1_hello_seq(payload)?;
    let mut raw_out = [0u8; 96];
    let mut w = Writer::new(&mut raw_out[..94]);
    v1_refusal(&mut w, seq, info);
    let used = w.written()?;
    let crc = legacy_crc16(&raw_out[..used]).to_le_bytes();
    raw_out[used..used + 2].copy_from_slice(&crc);
    let n = cobs::try_encode(&raw_out[..used + 2], out).ok()?;
    if n >= out.len() {
        return None;
    }
    out[n] = 0;
    Some(n + 1)
}
