//! Framing: `COBS(postcard(message) ‖ CRC-32/ISO-HDLC little-endian) ‖ 0x00`.
//!
//! [`encode`] writes one frame into a caller's buffer. [`FrameDecoder`] takes bytes one at a
//! time ([`FrameDecoder::push`]) or in chunks of any size ([`FrameDecoder::feed`]), and yields a
//! message at each delimiter that closes a valid frame; a corrupt, oversized or undecodable frame
//! is counted and dropped, and decoding resumes at the next delimiter.
//!
//! Why our own decoder loop rather than postcard's `CobsAccumulator`: on an oversized frame the
//! accumulator restarts in the middle of it, so the frame's tail is parsed as a new frame; ours
//! discards everything up to the next delimiter, and it keeps its CRC register as it goes.
//!
//! Why CRC-32 (protocol v2; v1 had CRC-16/IBM-SDLC): with COBS, a wire error of a few bits can
//! shift the unstuffed payload, which a 16-bit check passed about once in 10^7 mutated frames
//! (4 of 5·10^7 with 3–4 bit errors). CRC-32/ISO-HDLC has Hamming distance 4 or more up to
//! 91 607 bits, far beyond [`MAX_FRAME_LEN`]; the mutation campaign
//! (`cargo run --release -p protocol --example mutation`, BENCHMARKS.md) measures it. A frame
//! that fails the CRC-32 but carries a valid CRC-16 is reported as [`FrameError::Legacy`], so a
//! host can say that the peer runs protocol v1 instead of "no answer".
//!
//! Nothing here panics on any input or allocates: every index is bounds-checked by construction
//! (the fuzz target `fuzz/fuzz_targets/decoder.rs` and the property tests hold it to that).

use serde::{de::DeserializeOwned, Serialize};

use crate::codec::{Reader, Writer};
use crate::messages::{DeviceMessage, Request};

/// Largest encoded frame, delimiter included. The decoder drops anything longer.
pub const MAX_FRAME_LEN: usize = 512;
/// Largest payload (postcard bytes plus the 4-byte CRC) that fits in [`MAX_FRAME_LEN`]: COBS
/// adds at most one byte per 254 and the delimiter one more.
pub const MAX_RAW_LEN: usize = MAX_FRAME_LEN - 1 - (MAX_FRAME_LEN / 254 + 1);
/// Bytes of CRC after the postcard payload.
pub const CRC_LEN: usize = 4;

/// Largest frame without its delimiter.
const MAX_STUFFED_LEN: usize = MAX_FRAME_LEN - 1;

const CRC_ALGORITHM: &crc::Algorithm<u32> = &crc::CRC_32_ISO_HDLC;
const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(CRC_ALGORITHM);

// The streaming decoder keeps the CRC register itself (no indirection through a
// `crc::Digest`'s pointer to the algorithm), from the `crc` crate's own table. Its update step
// below is the one for reflected CRCs, as CRC-32/ISO-HDLC is. The one-shot path (`encode`,
// `decode`) runs the same step ([`crc32`]: the crate's `checksum` would link a second copy of
// the 1 KiB table into the board binary); a test compares it with the crate's `checksum`.
//
// On a bare-metal target (the board) the step is two look-ups in a 16-entry table (64 bytes
// of flash instead of 1 KiB, a few cycles more per byte: the bytes arrive ≈ 11 per loop pass);
// elsewhere one look-up in the 256-entry table. A test holds the two to each other.
const _: () = assert!(CRC_ALGORITHM.refin && CRC_ALGORITHM.refout && CRC_ALGORITHM.width == 32);
/// The reflected CRC's 256-entry table (1 KiB).
#[cfg_attr(target_os = "none", allow(dead_code))]
static CRC_TABLE: [u32; 256] = CRC.table()[0];
/// The reflected CRC's 16-entry table: four shifts of a nibble, which is the 256-entry
/// table's entry for that nibble in the high half of a byte (its low four shifts move zeros).
#[cfg_attr(not(target_os = "none"), allow(dead_code))]
static CRC_NIBBLES: [u32; 16] = {
    let t = CRC.table()[0];
    let mut out = [0u32; 16];
    let mut i = 0;
    while i < 16 {
        out[i] = t[i << 4];
        i += 1;
    }
    out
};
/// The register's initial value (reflected, as the input is).
const CRC_INIT: u32 = CRC_ALGORITHM.init.reverse_bits();

/// One byte into a reflected CRC-32 register, a byte at a time.
#[cfg_attr(target_os = "none", allow(dead_code))]
#[inline(always)]
fn crc_step_bytewise(register: u32, byte: u8) -> u32 {
    CRC_TABLE[usize::from(register as u8 ^ byte)] ^ (register >> 8)
}

/// One byte into a reflected CRC-32 register, a nibble at a time.
#[cfg_attr(not(target_os = "none"), allow(dead_code))]
#[inline(always)]
fn crc_step_nibblewise(register: u32, byte: u8) -> u32 {
    let r = register ^ u32::from(byte);
    let r = CRC_NIBBLES[(r & 0xF) as usize] ^ (r >> 4);
    CRC_NIBBLES[(r & 0xF) as usize] ^ (r >> 4)
}

/// One byte into a reflected CRC-32 register.
#[inline(always)]
fn crc_step(register: u32, byte: u8) -> u32 {
    if cfg!(target_os = "none") {
        crc_step_nibblewise(register, byte)
    } else {
        crc_step_bytewise(register, byte)
    }
}

/// Protocol v1's check, CRC-16/IBM-SDLC (poly 0x1021 reflected, init 0xFFFF, final xor
/// 0xFFFF), only to recognise an old peer's frames and to answer its `Hello`
/// ([`crate::legacy`]): bit by bit (bad frames only), by hand rather than the `crc` crate's
/// `NoTable` (3× the size on the board); a test holds it to the crate's.
pub(crate) fn legacy_crc16(bytes: &[u8]) -> u16 {
    let mut r = 0xFFFFu16;
    for &b in bytes {
        r ^= u16::from(b);
        for _ in 0..8 {
            r = if r & 1 != 0 {
                (r >> 1) ^ 0x8408
            } else {
                r >> 1
            };
        }
    }
    !r
}

/// CRC-32/ISO-HDLC of `bytes` (as `crc::Crc::<u32>::checksum`).
fn crc32(bytes: &[u8]) -> u32 {
    bytes.iter().fold(CRC_INIT, |r, &b| crc_step(r, b)) ^ CRC_ALGORITHM.xorout
}

/// [`crc32`] for the signing tests, which build frames by hand.
#[cfg(all(test, feature = "signing"))]
pub(crate) fn crc32_for_tests(bytes: &[u8]) -> u32 {
    crc32(bytes)
}

/// Why a frame could not be encoded or decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// The message does not fit in [`MAX_FRAME_LEN`] or the output buffer.
    TooLong,
    /// COBS structure invalid.
    Cobs,
    /// CRC mismatch.
    Crc,
    /// CRC-32 mismatch, but the frame checks out under protocol v1's CRC-16: the peer runs an
    /// older build (dropped like any bad frame).
    Legacy,
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
    stuff(&mut raw, used, out)
}

/// [`encode`] for a signed request ([`crate::sign`]): `postcard(msg) ‖ counter ‖ tag` as the
/// payload, `tag` the MAC under `key` of the bytes before it.
#[cfg(feature = "signing")]
pub fn encode_signed<T: Serialize>(
    msg: &T,
    key: &crate::sign::LinkKey,
    counter: u64,
    out: &mut [u8],
) -> Result<usize, FrameError> {
    use crate::sign::{COUNTER_LEN, TAG_LEN, TRAILER_LEN};
    let mut raw = [0u8; MAX_RAW_LEN];
    let used = postcard::to_slice(msg, &mut raw[..MAX_RAW_LEN - CRC_LEN - TRAILER_LEN])
        .map_err(|_| FrameError::TooLong)?
        .len();
    raw[used..used + COUNTER_LEN].copy_from_slice(&counter.to_le_bytes());
    let tag = crate::sign::tag(key, &raw[..used + COUNTER_LEN]);
    raw[used + COUNTER_LEN..used + TRAILER_LEN].copy_from_slice(&tag);
    debug_assert_eq!(tag.len(), TAG_LEN);
    stuff(&mut raw, used + TRAILER_LEN, out)
}

/// [`encode`] for a [`DeviceMessage`] through the hand-written codec ([`crate::codec`]): the
/// same bytes, without serde (the device's path).
pub fn encode_device_message(msg: &DeviceMessage, out: &mut [u8]) -> Result<usize, FrameError> {
    let mut raw = [0u8; MAX_RAW_LEN];
    let mut w = Writer::new(&mut raw[..MAX_RAW_LEN - CRC_LEN]);
    msg.encode(&mut w);
    let used = w.written().ok_or(FrameError::TooLong)?;
    stuff(&mut raw, used, out)
}

/// `raw[..used]`: a payload; appends its CRC and writes the frame into `out`.
fn stuff(raw: &mut [u8; MAX_RAW_LEN], used: usize, out: &mut [u8]) -> Result<usize, FrameError> {
    let payload = raw.get(..used).ok_or(FrameError::TooLong)?;
    let crc = crc32(payload).to_le_bytes();
    raw.get_mut(used..used + CRC_LEN)
        .ok_or(FrameError::TooLong)?
        .copy_from_slice(&crc);
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
    let crc = match raw.split_last_chunk::<CRC_LEN>() {
        Some((payload, _)) => crc32(payload),
        None => 0,
    };
    check_and_deserialize(raw, crc, 0)
}

/// `raw`: one unstuffed frame, more than [`CRC_LEN`] bytes long; `crc`: the CRC of all but its
/// last [`CRC_LEN`] bytes, which must equal them (little-endian).
fn check_and_deserialize<T: DeserializeOwned>(
    raw: &[u8],
    crc: u32,
    trailer: usize,
) -> Result<T, FrameError> {
    let payload = checked_payload(raw, crc, trailer)?;
    // An empty remainder is required: a frame carries exactly one message, so trailing bytes
    // mean a sender bug and are refused rather than silently ignored. (The deserialiser by
    // hand rather than `take_from_bytes`: the message is not moved through a tuple, one
    // ~500-byte memcpy less on the M4 for a plan.)
    let mut de = postcard::Deserializer::from_bytes(payload);
    let msg = T::deserialize(&mut de).map_err(|_| FrameError::Payload)?;
    match de.finalize() {
        Ok([]) => Ok(msg),
        _ => Err(FrameError::Payload),
    }
}

/// [`check_and_deserialize`] for a [`Request`] read into `out` by the hand-written codec.
fn check_and_read_request(
    raw: &[u8],
    crc: u32,
    trailer: usize,
    out: &mut Request,
) -> Result<(), FrameError> {
    let mut r = Reader::new(checked_payload(raw, crc, trailer)?);
    out.decode_into(&mut r).map_err(|_| FrameError::Payload)?;
    match r.rest() {
        [] => Ok(()),
        _ => Err(FrameError::Payload),
    }
}

/// The payload of `raw` (see [`check_and_deserialize`]) when its CRC checks out, without its
/// last `trailer` bytes (a verified signature's, [`crate::sign`]).
fn checked_payload(raw: &[u8], crc: u32, trailer: usize) -> Result<&[u8], FrameError> {
    let Some((payload, check)) = raw
        .split_last_chunk::<CRC_LEN>()
        .filter(|(p, _)| !p.is_empty())
    else {
        // Too short for a v2 frame: a short v1 one (2-byte CRC), or garbage.
        return Err(match legacy_or_crc(raw) {
            FrameError::Legacy => FrameError::Legacy,
            _ => FrameError::Payload,
        });
    };
    if crc.to_le_bytes() != *check {
        return Err(legacy_or_crc(raw));
    }
    #[cfg(feature = "signing")]
    let payload = payload
        .get(..payload.len().saturating_sub(trailer))
        .filter(|p| !p.is_empty())
        .ok_or(FrameError::Payload)?;
    #[cfg(not(feature = "signing"))]
    let _ = trailer;
    Ok(payload)
}

/// Longest frame checked for being protocol v1's: a v1 `Hello`, heartbeat or status answer is
/// shorter, and the bitwise CRC-16 over it stays a few thousand cycles on the M4 (a corrupted
/// 500-byte frame must not cost the control loop a bitwise pass over all of it).
pub const LEGACY_CHECK_MAX: usize = 64;

/// A frame whose CRC-32 failed: [`FrameError::Legacy`] when it is a valid protocol-v1 frame
/// (payload ‖ CRC-16/IBM-SDLC) of at most [`LEGACY_CHECK_MAX`] bytes, else [`FrameError::Crc`].
fn legacy_or_crc(raw: &[u8]) -> FrameError {
    if raw.len() > LEGACY_CHECK_MAX {
        return FrameError::Crc;
    }
    match raw.split_last_chunk::<2>() {
        Some((payload, check))
            if !payload.is_empty() && legacy_crc16(payload).to_le_bytes() == *check =>
        {
            FrameError::Legacy
        }
        _ => FrameError::Crc,
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
/// State is only the frame since the last delimiter, so after any garbage the decoder is in
/// sync again as soon as it has seen one `0x00`.
///
/// Incremental: each byte is COBS-decoded as it arrives and the CRC advances with it, so the
/// delimiter's [`FrameDecoder::push`] does only the CRC comparison and the deserialisation.
/// On the device a large frame arrives over tens of ms (≈ 34 ms for the largest at 115 200 Bd)
/// while its loop runs at 1 kHz: this spreads the unstuffing and the CRC over the byte
/// arrivals instead of doing them all in the pass that sees the delimiter. Results, errors and
/// counters are those of [`decode`] on the same bytes (the property tests hold it to that).
#[derive(Debug, Clone)]
pub struct FrameDecoder {
    /// The frame decoded so far (COBS removed, CRC still at the end).
    buf: [u8; MAX_FRAME_LEN],
    /// Decoded bytes in `buf`.
    len: usize,
    /// Encoded (stuffed) bytes received since the delimiter: the size limit is on these, as
    /// in [`decode`].
    stuffed: usize,
    /// Data bytes still due in the current COBS block; 0: the next byte is a code byte.
    run: u8,
    /// The current block's code byte (0 before the first): a block of code < 0xFF is followed
    /// by a zero, written when the next block starts (no zero after the last block).
    code: u8,
    overflow: bool,
    /// CRC register over `buf[..len - CRC_LEN]`: a decoded byte enters it only once four more
    /// have arrived, because the last four bytes are the CRC itself and where the frame ends is
    /// known only at the delimiter.
    crc: u32,
    /// Length of the frame the last delimiter closed (its bytes stay in `buf`).
    last_len: usize,
    stats: DecoderStats,
    /// Link signing's MAC ([`FrameDecoder::set_key`]) over `buf[..len - CRC_LEN - TAG_LEN]`,
    /// advanced as the bytes arrive, like the CRC (the tag and the CRC are the frame's last
    /// bytes).
    #[cfg(feature = "signing")]
    mac: Option<crate::sign::Mac>,
    /// The counter of the frame the last delimiter closed, when its signature checked out.
    #[cfg(feature = "signing")]
    signed: Option<u64>,
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
            stuffed: 0,
            run: 0,
            code: 0,
            overflow: false,
            crc: CRC_INIT,
            last_len: 0,
            stats: DecoderStats {
                frames_ok: 0,
                frames_dropped: 0,
            },
            #[cfg(feature = "signing")]
            mac: None,
            #[cfg(feature = "signing")]
            signed: None,
        }
    }

    /// Verifies link signatures under `key` from the next frame on (`None`: none, every frame
    /// is read as unsigned). A frame whose last [`crate::sign::TRAILER_LEN`] bytes before the
    /// CRC are a valid counter and tag is read without them and its counter reported by
    /// [`FrameDecoder::signed_counter`]; any other frame is read as an unsigned one (so one
    /// signed with another key does not decode: its trailer is left over).
    #[cfg(feature = "signing")]
    pub fn set_key(&mut self, key: Option<&crate::sign::LinkKey>) {
        self.mac = key.map(crate::sign::Mac::new);
        self.reset();
    }

    /// The counter of the frame the last delimiter closed, if it carried a valid signature.
    pub fn signed_counter(&self) -> Option<u64> {
        #[cfg(feature = "signing")]
        return self.signed;
        #[cfg(not(feature = "signing"))]
        None
    }

    /// The counters.
    pub fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// The unstuffed bytes (CRC included) of the frame the last delimiter closed, until the
    /// next byte is pushed: how a device reads a [`FrameError::Legacy`] frame
    /// ([`crate::legacy`]). Empty after an oversized frame.
    pub fn last_frame(&self) -> &[u8] {
        self.buf.get(..self.last_len).unwrap_or(&[])
    }

    /// Forgets a partial frame (e.g. after the port was reopened); keeps the counters.
    pub fn reset(&mut self) {
        self.len = 0;
        self.stuffed = 0;
        self.run = 0;
        self.code = 0;
        self.overflow = false;
        self.crc = CRC_INIT;
        #[cfg(feature = "signing")]
        if let Some(m) = self.mac.as_mut() {
            m.reset();
        }
    }

    /// Appends one decoded byte; the byte [`CRC_LEN`] places before it joins the CRC.
    #[inline(always)]
    fn emit(&mut self, byte: u8) {
        // `len - 4` wraps for the first four bytes: `get` finds nothing, nothing to add yet.
        if let Some(&old) = self.buf.get(self.len.wrapping_sub(CRC_LEN)) {
            self.crc = crc_step(self.crc, old);
        }
        #[cfg(feature = "signing")]
        if let Some(m) = self.mac.as_mut() {
            if let Some(&old) = self
                .buf
                .get(self.len.wrapping_sub(CRC_LEN + crate::sign::TAG_LEN))
            {
                m.update(old);
            }
        }
        // Never full: a frame decodes to at most as many bytes as it has encoded, and those
        // are capped at `MAX_STUFFED_LEN`.
        if let Some(slot) = self.buf.get_mut(self.len) {
            *slot = byte;
            self.len += 1;
        }
    }

    /// One encoded (non-zero) byte of the frame being received.
    #[inline(always)]
    fn unstuff(&mut self, byte: u8) {
        if self.run == 0 {
            // A code byte. The previous block, unless it was a full 254-byte run, stood for
            // data followed by a zero, and a block follows it: that zero is data too.
            if self.code != 0 && self.code != 0xFF {
                self.emit(0);
            }
            self.code = byte;
            self.run = byte - 1; // byte != 0
        } else {
            self.emit(byte);
            self.run -= 1;
        }
    }

    /// Feeds one byte. At a delimiter returns `Some(Ok(msg))` for a valid frame or
    /// `Some(Err(e))` for a dropped one (already counted; [`FrameError::Empty`] is not a drop);
    /// otherwise `None`.
    #[inline]
    pub fn push<T: DeserializeOwned>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte != 0 {
            self.accept(byte);
            return None;
        }
        self.finish(check_and_deserialize)
    }

    /// [`FrameDecoder::push`] for a [`Request`], read by the hand-written codec
    /// ([`Request::decode_into`]) into `out`, where it lies (the device's path): the same
    /// results and counters, `Some(Ok(()))` when `out` holds a new request.
    #[inline]
    pub fn push_request(&mut self, byte: u8, out: &mut Request) -> Option<Result<(), FrameError>> {
        if byte != 0 {
            self.accept(byte);
            return None;
        }
        self.finish(|raw, crc, trailer| check_and_read_request(raw, crc, trailer, out))
    }

    /// A non-zero byte: the per-byte work, kept small (it runs for every byte received).
    #[inline]
    fn accept(&mut self, byte: u8) {
        if self.overflow {
            // Keep discarding until the delimiter: the tail of an oversized frame must not be
            // taken for the start of a new one.
        } else if self.stuffed < MAX_STUFFED_LEN {
            self.stuffed += 1;
            self.unstuff(byte);
        } else {
            self.overflow = true;
        }
    }

    /// The delimiter: checks and deserialises the frame, counts the result, starts afresh.
    /// Out of line so that the per-byte path stays lean where `push` is inlined.
    #[inline(never)]
    fn finish<T>(
        &mut self,
        read: impl FnOnce(&[u8], u32, usize) -> Result<T, FrameError>,
    ) -> Option<Result<T, FrameError>> {
        let stuffed = core::mem::replace(&mut self.stuffed, 0);
        let len = core::mem::replace(&mut self.len, 0);
        let run = core::mem::replace(&mut self.run, 0);
        self.code = 0;
        let overflow = core::mem::replace(&mut self.overflow, false);
        self.last_len = if overflow { 0 } else { len };
        let crc = core::mem::replace(&mut self.crc, CRC_INIT) ^ CRC_ALGORITHM.xorout;
        let trailer = self.signature(len);
        let result = if overflow {
            Err(FrameError::TooLong)
        } else if stuffed == 0 {
            return Some(Err(FrameError::Empty));
        } else if run != 0 {
            // The last block announced more bytes than came before the delimiter.
            Err(FrameError::Cobs)
        } else {
            match self.buf.get(..len) {
                Some(raw) => read(raw, crc, trailer),
                None => Err(FrameError::TooLong),
            }
        };
        match &result {
            Ok(_) => self.stats.frames_ok = self.stats.frames_ok.wrapping_add(1),
            Err(_) => self.stats.frames_dropped = self.stats.frames_dropped.wrapping_add(1),
        }
        Some(result)
    }

    /// At the delimiter of a frame of `len` decoded bytes: the trailer to strip when the frame
    /// carries a valid signature (its counter then in `signed`), else 0; the MAC starts over.
    #[cfg(feature = "signing")]
    fn signature(&mut self, len: usize) -> usize {
        use crate::sign::{COUNTER_LEN, TAG_LEN, TRAILER_LEN};
        self.signed = None;
        let Some(m) = self.mac.as_mut() else {
            return 0;
        };
        let tag = m.tag();
        m.reset();
        if len < TRAILER_LEN + CRC_LEN + 1 {
            return 0;
        }
        let at = len - CRC_LEN - TAG_LEN;
        let (Some(got), Some(counter)) = (
            self.buf.get(at..at + TAG_LEN),
            self.buf
                .get(at - COUNTER_LEN..at)
                .and_then(|c| <[u8; COUNTER_LEN]>::try_from(c).ok()),
        ) else {
            return 0;
        };
        if got != tag {
            return 0;
        }
        self.signed = Some(u64::from_le_bytes(counter));
        TRAILER_LEN
    }

    /// Without the feature `signing` no frame is signed.
    #[cfg(not(feature = "signing"))]
    #[inline(always)]
    fn signature(&mut self, _len: usize) -> usize {
        0
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_shot_crc_is_the_crates_checksum() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926); // the catalogue's check value
        let mut bytes = [0u8; 600];
        let mut x = 0x1234_5678u32;
        for b in bytes.iter_mut() {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            *b = x as u8;
        }
        for n in [0, 1, 2, 3, 4, 63, 64, 255, 511, 600] {
            assert_eq!(crc32(&bytes[..n]), CRC.checksum(&bytes[..n]), "{n} bytes");
        }
    }

    #[test]
    fn the_legacy_crc_is_the_crates_ibm_sdlc() {
        let crate_crc = crc::Crc::<u16, crc::NoTable>::new(&crc::CRC_16_IBM_SDLC);
        let mut x = 0x9E37_79B9u32;
        let bytes: [u8; 70] = core::array::from_fn(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as u8
        });
        for n in 0..=bytes.len() {
            assert_eq!(
                legacy_crc16(&bytes[..n]),
                crate_crc.checksum(&bytes[..n]),
                "{n} bytes"
            );
        }
        assert_eq!(legacy_crc16(b"123456789"), 0x906E); // the catalogue's check value
    }

    #[test]
    fn the_nibble_step_is_the_byte_step() {
        let mut r = CRC_INIT;
        for i in 0..100_000u32 {
            let b = (i.wrapping_mul(2_654_435_761) >> 13) as u8;
            assert_eq!(
                crc_step_nibblewise(r, b),
                crc_step_bytewise(r, b),
                "{r:#x} {b}"
            );
            r = crc_step_bytewise(r, b) ^ i;
        }
    }
}
