//! The streaming decoder unstuffs and checksums byte by byte; [`decode`] does the same work on
//! the whole frame at once through the `cobs` crate. On any stream, each delimiter must give
//! the same result from both (message, error kind) and the counters must add up.

use proptest::collection::vec;
use proptest::prelude::*;
use protocol::*;
use serde::ser::{Serialize, SerializeTuple, Serializer};

use super::props::{device_message, request};

/// Serialises as its bytes verbatim (postcard writes a tuple's `u8`s with no length prefix),
/// so [`encode`] frames an arbitrary payload with a correct CRC: it gets past the COBS and CRC
/// checks to the deserialiser.
struct Raw(Vec<u8>);

impl Serialize for Raw {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(self.0.len())?;
        for b in &self.0 {
            t.serialize_element(b)?;
        }
        t.end()
    }
}

fn frame_of<T: Serialize>(msg: &T) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(msg, &mut buf).expect("fits a frame");
    buf[..n].to_vec()
}

/// The bytes `msg` encodes to as a frame (for comparing messages holding NaN, which is not
/// `==` to itself).
fn canonical<T: Serialize>(r: &Result<T, FrameError>) -> Result<Vec<u8>, FrameError> {
    r.as_ref().map(frame_of).map_err(|e| *e)
}

/// Feeds `stream` byte by byte and checks every delimiter's result against [`decode`] of the
/// bytes since the previous delimiter. Returns the number of non-empty segments.
fn check_stream<T: Serialize + serde::de::DeserializeOwned>(
    dec: &mut FrameDecoder,
    stream: &[u8],
) -> Result<usize, TestCaseError> {
    let before = dec.stats();
    let mut segment = Vec::new();
    let (mut ok, mut dropped, mut nonempty) = (0u32, 0u32, 0usize);
    for &b in stream {
        let got = dec.push::<T>(b);
        if b != 0 {
            segment.push(b);
            prop_assert!(got.is_none());
            continue;
        }
        let got = got.expect("a delimiter always gives a result");
        segment.push(0);
        let want = decode::<T>(&mut segment);
        prop_assert_eq!(
            canonical(&got),
            canonical(&want),
            "segment of {} bytes",
            segment.len()
        );
        match got {
            Ok(_) => ok += 1,
            Err(FrameError::Empty) => {}
            Err(_) => dropped += 1,
        }
        if segment.len() > 1 {
            nonempty += 1;
        }
        segment.clear();
    }
    let after = dec.stats();
    prop_assert_eq!(after.frames_ok - before.frames_ok, ok);
    prop_assert_eq!(after.frames_dropped - before.frames_dropped, dropped);
    Ok(nonempty)
}

/// A corruption of a valid stream.
#[derive(Debug, Clone)]
enum Edit {
    Flip { at: usize, mask: u8 },
    Set { at: usize, byte: u8 },
    Delete { at: usize },
    Insert { at: usize, byte: u8 },
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), 1u8..).prop_map(|(at, mask)| Edit::Flip { at, mask }),
        (any::<usize>(), any::<u8>()).prop_map(|(at, byte)| Edit::Set { at, byte }),
        any::<usize>().prop_map(|at| Edit::Delete { at }),
        (any::<usize>(), any::<u8>()).prop_map(|(at, byte)| Edit::Insert { at, byte }),
    ]
}

fn apply(stream: &mut Vec<u8>, edits: &[Edit]) {
    for e in edits {
        let n = stream.len().max(1);
        match *e {
            Edit::Flip { at, mask } => {
                if let Some(b) = stream.get_mut(at % n) {
                    *b ^= mask;
                }
            }
            Edit::Set { at, byte } => {
                if let Some(b) = stream.get_mut(at % n) {
                    *b = byte;
                }
            }
            Edit::Delete { at } => {
                if !stream.is_empty() {
                    stream.remove(at % n);
                }
            }
            Edit::Insert { at, byte } => stream.insert(at % (stream.len() + 1), byte),
        }
    }
}

/// Payload bytes: arbitrary, or mostly non-zero so that runs of 254 (COBS code 0xFF) occur.
fn payload() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        vec(any::<u8>(), 0..520),
        vec(prop_oneof![20 => 1u8.., 1 => Just(0u8)], 200..520),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Valid request frames, then the same frames corrupted: same result as `decode` at every
    /// delimiter.
    #[test]
    fn agrees_with_decode_on_requests(
        reqs in vec(request(), 1..5),
        edits in vec(edit(), 0..6),
    ) {
        let stream: Vec<u8> = reqs.iter().flat_map(frame_of).collect();
        let mut dec = FrameDecoder::new();
        let frames = check_stream::<Request>(&mut dec, &stream)?;
        prop_assert_eq!(dec.stats().frames_ok as usize, frames);
        prop_assert_eq!(dec.stats().frames_dropped, 0);

        let mut corrupted = stream;
        apply(&mut corrupted, &edits);
        corrupted.push(0);
        check_stream::<Request>(&mut dec, &corrupted)?;
    }

    /// Device messages (the other payload type), corrupted.
    #[test]
    fn agrees_with_decode_on_device_messages(
        msgs in vec(device_message(), 1..4),
        edits in vec(edit(), 0..4),
    ) {
        let mut stream: Vec<u8> = msgs.iter().flat_map(frame_of).collect();
        apply(&mut stream, &edits);
        stream.push(0);
        check_stream::<DeviceMessage>(&mut FrameDecoder::new(), &stream)?;
    }

    /// Arbitrary payloads with a correct CRC (they reach the deserialiser: mostly `Payload`
    /// errors, long zero-free runs, frames near and over the size limit), some corrupted.
    #[test]
    fn agrees_with_decode_on_raw_payloads(
        payloads in vec(payload(), 1..4),
        edits in vec(edit(), 0..3),
    ) {
        let mut stream = Vec::new();
        for p in &payloads {
            let mut buf = vec![0u8; 2 * MAX_FRAME_LEN];
            match encode(&Raw(p.clone()), &mut buf) {
                Ok(n) => stream.extend_from_slice(&buf[..n]),
                // Too long for a frame: its bytes, made non-zero, go out as one oversized
                // segment.
                Err(_) => {
                    stream.extend(p.iter().map(|&b| b | 1));
                    stream.push(0);
                }
            }
        }
        let mut dec = FrameDecoder::new();
        check_stream::<Request>(&mut dec, &stream)?;
        apply(&mut stream, &edits);
        stream.push(0);
        check_stream::<Request>(&mut dec, &stream)?;
    }

    /// Plain garbage, zero-heavy or not.
    #[test]
    fn agrees_with_decode_on_garbage(
        garbage in prop_oneof![
            vec(any::<u8>(), 0..1_500),
            vec(prop_oneof![Just(0u8), any::<u8>()], 0..300),
            vec(1u8.., 400..700),
        ],
    ) {
        let mut stream = garbage;
        stream.push(0);
        check_stream::<Request>(&mut FrameDecoder::new(), &stream)?;
    }

    /// `reset` mid-frame forgets the partial frame's decoding state, COBS and CRC included.
    #[test]
    fn reset_mid_frame_leaves_no_trace(
        first in request(),
        second in request(),
        cut in any::<usize>(),
    ) {
        let a = frame_of(&first);
        let b = frame_of(&second);
        let mut dec = FrameDecoder::new();
        for &byte in &a[..cut % a.len()] {
            prop_assert!(dec.push::<Request>(byte).is_none());
        }
        dec.reset();
        let got: Vec<_> = dec.feed::<Request>(&b).collect();
        prop_assert_eq!(canonical(&got[0]), Ok(b.clone()));
        prop_assert_eq!(dec.stats(), DecoderStats { frames_ok: 1, frames_dropped: 0 });
    }
}

/// Payloads around the COBS block boundaries (a 254-byte zero-free run is a code-0xFF block,
/// after which no zero is implied) and around the size limit.
#[test]
fn block_boundaries_decode_like_decode() {
    let mut dec = FrameDecoder::new();
    for len in [0usize, 1, 2, 3, 251, 252, 253, 254, 255, 256, 507, 508, 509] {
        for fill in [0x01u8, 0xFF] {
            let mut buf = vec![0u8; 2 * MAX_FRAME_LEN];
            let Ok(n) = encode(&Raw(vec![fill; len]), &mut buf) else {
                assert!(len > 500, "only over-long payloads fail to encode ({len})");
                continue;
            };
            let frame = &buf[..n];
            let got: Vec<_> = frame
                .iter()
                .filter_map(|&b| dec.push::<Request>(b))
                .collect();
            let want = decode::<Request>(&mut frame.to_vec());
            assert_eq!(got, vec![want], "payload {len} × {fill:#04x}");
            // All got past COBS and CRC (a few are even requests: `01 01` is `GetStatus`).
            assert!(
                !matches!(
                    got[0],
                    Err(FrameError::Cobs | FrameError::Crc | FrameError::TooLong)
                ),
                "payload {len} × {fill:#04x}: {:?}",
                got[0]
            );
        }
    }
}
