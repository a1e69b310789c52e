//! Framing: `COBS(postcard(message) ‖ CRC-16/IBM-SDLC little-endian) ‖ 0x00`.
//!
//! [`encode`] writes one frame into a caller's buffer. [`FrameDecoder`] takes bytes one at a
//! time ([`FrameDecoder::push`]) or in chunks of any size ([`FrameDecoder::feed`]), and yields a
//! message at each delimiter that closes a valid frame; a corrupt, oversized or undecodable frame
//! is counted and dropped, and decoding resumes at the next delimiter.
//!
//! Why our own decoder loop rather than postcard's `CobsAccumulator`: on an oversized frame the
//! accumulator restarts in the middle of it, so the frame's tail is parsed as a new frame; ours
//! discards everything up to the next delimiter. postcard's CRC helpers are also 32-bit only,
//! and CRC-16 is plenty for frames of at most [`MAX_FRAME_LEN`] bytes.
//!
//! Nothing here panics on any input or allocates: every index is bounds-checked by construction
//! (the fuzz target `fuzz/fuzz_targets/decoder.rs` and the property tests hold it to that).

use serde::{de::DeserializeOwned, Serialize};

/// Largest encoded frame, delimiter included. The decoder drops anything longer.
pub const MAX_FRAME_LEN: usize = 512;
/// Largest payload (postcard bytes plus the 2-byte CRC) that fits in [`MAX_FRAME_LEN`]: COBS
/// adds at most one byte per 254 and the delimiter one more.
pub const MAX_RAW_LEN: usize = MAX_FRAME_LEN - 1 - (MAX_FRAME_LEN / 254 + 1);
/// Bytes of CRC after the postcard payload.
pub const CRC_LEN: usize = 2;

/// Largest frame without its delimiter.
const MAX_STUFFED_LEN: usize = MAX_FRAME_LEN - 1;

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
    /// The payload is not a valid message (or has bytes left over after one).
    Payload,
    /// A delimiter with nothing before it (ignored, not counted as a drop). Senders may send a
    /// lone `0x00` first to flush a receiver's partial frame.
    Empty,
}

/// Encodes `msg` as one complete frame (delimiter included) into `out`; returns its length.
///
/// `out` of [`MAX_FRAME_LEN`] bytes always suffices for a message that fits at all. Uses
/// [`MAX_RAW_LEN`] bytes of stack for the unstuffed payload.
pub fn encode<T: Serialize>(msg: &T, out: &mut [u8]) -> Result<usize, FrameError> {
    let mut raw = [0u8; MAX_RAW_LEN];
    let used = postcard::to_slice(msg, &mut raw[..MAX_RAW_LEN - CRC_LEN])
        .map_err(|_| FrameError::TooLong)?
        .len();
    let crc = CRC.checksum(&raw[..used]).to_le_bytes();
    raw[used..used + CRC_LEN].copy_from_slice(&crc);
    let raw_len = used + CRC_LEN;
    // `try_encode` bounds-checks every write (`cobs::encode` would panic on a short buffer);
    // no worst-case pre-check, so a buffer exactly the frame's length is enough. cobs 0.3
    // reports a short buffer either as an error or as a length past the end: both refused.
    let n = cobs::try_encode(&raw[..raw_len], out).map_err(|_| FrameError::TooLong)?;
    if n >= out.len() {
        return Err(FrameError::TooLong);
    }
    out[n] = 0;
    Ok(n + 1)
}

/// Decodes one complete frame held in `frame` (with or without its trailing delimiter; the
/// buffer is decoded in place and clobbered). Does not touch any [`FrameDecoder`] counters.
pub fn decode<T: DeserializeOwned>(frame: &mut [u8]) -> Result<T, FrameError> {
    let frame = match frame.split_last_mut() {
        None => return Err(FrameError::Empty),
        Some((0, rest)) => rest,
        Some(_) => frame,
    };
    if frame.is_empty() {
        return Err(FrameError::Empty);
    }
    if frame.len() > MAX_STUFFED_LEN {
        // The streaming decoder would drop it too.
        return Err(FrameError::TooLong);
    }
    if frame.contains(&0) {
        // A zero inside would be a delimiter: this is not one frame.
        return Err(FrameError::Cobs);
    }
    decode_stuffed(frame)
}

/// `frame`: the COBS bytes of one frame, no zero among them.
fn decode_stuffed<T: DeserializeOwned>(frame: &mut [u8]) -> Result<T, FrameError> {
    // cobs 0.3 `decode_in_place` reads only below the first zero (there is none) and checks
    // every run length against the end before copying, so malformed input is an error, not a
    // panic; the decoded length never exceeds the input length.
    let n = cobs::decode_in_place(frame).map_err(|_| FrameError::Cobs)?;
    let raw = frame.get(..n).ok_or(FrameError::Cobs)?;
    if raw.len() <= CRC_LEN {
        return Err(FrameError::Payload);
    }
    let (payload, crc) = raw.split_at(raw.len() - CRC_LEN);
    if CRC.checksum(payload).to_le_bytes() != [crc[0], crc[1]] {
        return Err(FrameError::Crc);
    }
    // `take_from_bytes` + empty remainder: a frame carries exactly one message, so trailing
    // bytes mean a sender bug and are refused rather than silently ignored.
    match postcard::take_from_bytes(payload) {
        Ok((msg, [])) => Ok(msg),
        _ => Err(FrameError::Payload),
    }
}

/// Counters kept by a [`FrameDecoder`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DecoderStats {
    /// Frames decoded successfully.
    pub frames_ok: u32,
    /// Frames dropped (corrupt, oversized, undecodable). Wraps on overflow.
    pub frames_dropped: u32,
}

/// Streaming frame decoder with a fixed buffer of [`MAX_FRAME_LEN`] bytes; a frame longer
/// than [`MAX_FRAME_LEN`] (delimiter included) is dropped as [`FrameError::TooLong`].
///
/// State is only the bytes since the last delimiter, so after any garbage the decoder is in
/// sync again as soon as it has seen one `0x00`.
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

    /// Forgets a partial frame (e.g. after the port was reopened); keeps the counters.
    pub fn reset(&mut self) {
        self.len = 0;
        self.overflow = false;
    }

    /// Feeds one byte. At a delimiter returns `Some(Ok(msg))` for a valid frame or
    /// `Some(Err(e))` for a dropped one (already counted; [`FrameError::Empty`] is not a drop);
    /// otherwise `None`.
    pub fn push<T: DeserializeOwned>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte != 0 {
            match self.buf[..MAX_STUFFED_LEN].get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                }
                // Keep discarding until the delimiter: the tail of an oversized frame must not
                // be taken for the start of a new one.
                None => self.overflow = true,
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
            match self.buf[..MAX_STUFFED_LEN].get_mut(..len) {
                Some(frame) => decode_stuffed(frame),
                None => Err(FrameError::TooLong),
            }
        };
        match &result {
            Ok(_) => self.stats.frames_ok = self.stats.frames_ok.wrapping_add(1),
            Err(_) => self.stats.frames_dropped = self.stats.frames_dropped.wrapping_add(1),
        }
        Some(result)
    }

    /// Feeds a chunk of bytes; the returned iterator yields each frame result the chunk
    /// completes (skipping [`FrameError::Empty`]). Bytes the iterator is not driven over are
    /// not fed, so drive it to the end:
    ///
    /// ```
    /// # use protocol::*;
    /// # let mut dec = FrameDecoder::new();
    /// # let chunk = [0u8; 4];
    /// for msg in dec.feed::<DeviceMessage>(&chunk) {
    ///     match msg {
    ///         Ok(_msg) => { /* handle */ }
    ///         Err(_dropped) => { /* already counted in stats() */ }
    ///     }
    /// }
    /// ```
    pub fn feed<'d, 'b, T: DeserializeOwned>(&'d mut self, bytes: &'b [u8]) -> Feed<'d, 'b, T> {
        Feed {
            decoder: self,
            bytes: bytes.iter(),
            _msg: core::marker::PhantomData,
        }
    }
}

/// Iterator returned by [`FrameDecoder::feed`].
#[derive(Debug)]
pub struct Feed<'d, 'b, T> {
    decoder: &'d mut FrameDecoder,
    bytes: core::slice::Iter<'b, u8>,
    _msg: core::marker::PhantomData<fn() -> T>,
}

impl<T: DeserializeOwned> Iterator for Feed<'_, '_, T> {
    type Item = Result<T, FrameError>;

    fn next(&mut self) -> Option<Self::Item> {
        for &b in self.bytes.by_ref() {
            match self.decoder.push::<T>(b) {
                None | Some(Err(FrameError::Empty)) => {}
                Some(r) => return Some(r),
            }
        }
        None
    }
}
