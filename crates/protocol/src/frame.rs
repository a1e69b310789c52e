//! Framing: `COBS(postcard(message) ‖ CRC-16/IBM-SDLC little-endian) ‖ 0x00`.
//!
//! [`encode`] writes one frame into a caller's buffer. [`FrameDecoder`] takes bytes one at a
//! time in any chunking, and yields a message at each delimiter that closes a valid frame; a
//! corrupt, oversized or undecodable frame is counted and dropped, and decoding resumes at the
//! next delimiter.

use serde::{de::DeserializeOwned, Serialize};

/// Largest encoded frame, delimiter included.
pub const MAX_FRAME_LEN: usize = 512;
/// Largest payload (postcard bytes plus the 2-byte CRC) that fits in [`MAX_FRAME_LEN`].
const MAX_RAW_LEN: usize = MAX_FRAME_LEN - 1 - (MAX_FRAME_LEN / 254 + 1);

const CRC: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC);

/// Why a frame could not be encoded or decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// The message does not fit in [`MAX_FRAME_LEN`] or the output buffer.
    TooLong,
    /// COBS structure invalid.
    Cobs,
    /// CRC mismatch.
    Crc,
    /// The payload is not a valid message.
    Payload,
    /// A delimiter with nothing before it (ignored, not counted as a drop).
    Empty,
}

/// Encodes `msg` as one complete frame (delimiter included) into `out`; returns its length.
pub fn encode<T: Serialize>(msg: &T, out: &mut [u8]) -> Result<usize, FrameError> {
    let mut raw = [0u8; MAX_RAW_LEN];
    let used = postcard::to_slice(msg, &mut raw[..MAX_RAW_LEN - 2])
        .map_err(|_| FrameError::TooLong)?
        .len();
    let crc = CRC.checksum(&raw[..used]).to_le_bytes();
    raw[used..used + 2].copy_from_slice(&crc);
    let raw_len = used + 2;
    if out.len() < cobs::max_encoding_length(raw_len) + 1 {
        return Err(FrameError::TooLong);
    }
    let n = cobs::encode(&raw[..raw_len], out);
    out[n] = 0;
    Ok(n + 1)
}

/// Counters kept by a [`FrameDecoder`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DecoderStats {
    /// Frames decoded successfully.
    pub frames_ok: u32,
    /// Frames dropped (corrupt, oversized, undecodable).
    pub frames_dropped: u32,
}

/// Streaming frame decoder with a fixed buffer.
#[derive(Debug)]
pub struct FrameDecoder {
    buf: [u8; MAX_FRAME_LEN],
    len: usize,
    overflow: bool,
    stats: DecoderStats,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    /// An empty decoder.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME_LEN],
            len: 0,
            overflow: false,
            stats: DecoderStats {
                frames_ok: 0,
                frames_dropped: 0,
            },
        }
    }

    /// The counters.
    pub fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// Feeds one byte. At a delimiter returns `Some(Ok(msg))` for a valid frame or
    /// `Some(Err(e))` for a dropped one (already counted); otherwise `None`.
    pub fn push<T: DeserializeOwned>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte != 0 {
            if self.len < self.buf.len() {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflow = true;
            }
            return None;
        }
        let len = core::mem::replace(&mut self.len, 0);
        let overflow = core::mem::replace(&mut self.overflow, false);
        let result = if overflow {
            Err(FrameError::TooLong)
        } else if len == 0 {
            return Some(Err(FrameError::Empty));
        } else {
            Self::decode_frame(&mut self.buf[..len])
        };
        match &result {
            Ok(_) => self.stats.frames_ok = self.stats.frames_ok.wrapping_add(1),
            Err(_) => self.stats.frames_dropped = self.stats.frames_dropped.wrapping_add(1),
        }
        Some(result)
    }

    fn decode_frame<T: DeserializeOwned>(frame: &mut [u8]) -> Result<T, FrameError> {
        let n = cobs::decode_in_place(frame).map_err(|_| FrameError::Cobs)?;
        if n < 3 {
            return Err(FrameError::Payload);
        }
        let (payload, crc) = frame[..n].split_at(n - 2);
        if CRC.checksum(payload).to_le_bytes() != [crc[0], crc[1]] {
            return Err(FrameError::Crc);
        }
        postcard::from_bytes(payload).map_err(|_| FrameError::Payload)
    }
}
