//! Framing edge cases: oversized, corrupt, empty and truncated frames, and resynchronisation.

use protocol::*;

use crate::samples::{get_status, largest_request, status_response};

fn frame_of<T: serde::Serialize>(msg: &T) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(msg, &mut buf).unwrap();
    buf[..n].to_vec()
}

/// Every non-`None` result of pushing `bytes`, in order.
fn push_all<T: serde::de::DeserializeOwned>(
    dec: &mut FrameDecoder,
    bytes: &[u8],
) -> Vec<Result<T, FrameError>> {
    bytes.iter().filter_map(|&b| dec.push::<T>(b)).collect()
}

#[test]
fn oversized_frame_is_dropped_counted_and_the_next_frame_decodes() {
    let mut dec = FrameDecoder::new();
    let mut stream = vec![0x55u8; 3 * MAX_FRAME_LEN];
    stream.push(0);
    stream.extend(frame_of(&get_status()));
    let got = push_all::<Request>(&mut dec, &stream);
    assert_eq!(got, vec![Err(FrameError::TooLong), Ok(get_status())]);
    assert_eq!(
        dec.stats(),
        DecoderStats {
            frames_ok: 1,
            frames_dropped: 1
        }
    );
}

#[test]
fn frame_length_limit_is_exactly_max_frame_len() {
    // MAX_FRAME_LEN - 1 stuffed bytes + delimiter: not refused as too long (it is garbage, so
    // it fails later, at COBS/CRC); one more byte and it is TooLong.
    let mut dec = FrameDecoder::new();
    let mut at_limit = vec![0x01u8; MAX_FRAME_LEN - 1];
    at_limit.push(0);
    let got = push_all::<Request>(&mut dec, &at_limit);
    assert_eq!(got.len(), 1);
    assert_ne!(got[0], Err(FrameError::TooLong));
    let mut over = vec![0x01u8; MAX_FRAME_LEN];
    over.push(0);
    assert_eq!(
        push_all::<Request>(&mut dec, &over),
        vec![Err(FrameError::TooLong)]
    );
    assert_eq!(dec.stats().frames_dropped, 2);
    // The one-shot decoder applies the same limit.
    assert_eq!(decode::<Request>(&mut over), Err(FrameError::TooLong));
}

#[test]
fn encode_refuses_a_too_small_buffer_without_panicking() {
    let frame_len = frame_of(&largest_request()).len();
    for len in 0..frame_len {
        let mut out = vec![0u8; len];
        assert_eq!(
            encode(&largest_request(), &mut out),
            Err(FrameError::TooLong),
            "buffer of {len} bytes"
        );
    }
    let mut out = vec![0u8; frame_len];
    assert_eq!(encode(&largest_request(), &mut out), Ok(frame_len));
}

#[test]
fn empty_frames_are_reported_but_not_counted() {
    let mut dec = FrameDecoder::new();
    let mut stream = vec![0, 0, 0];
    stream.extend(frame_of(&get_status()));
    let got = push_all::<Request>(&mut dec, &stream);
    assert_eq!(
        got,
        vec![
            Err(FrameError::Empty),
            Err(FrameError::Empty),
            Err(FrameError::Empty),
            Ok(get_status())
        ]
    );
    assert_eq!(dec.stats().frames_dropped, 0);
    // `feed` hides them.
    let got: Vec<_> = dec.feed::<Request>(&stream).collect();
    assert_eq!(got, vec![Ok(get_status())]);
}

#[test]
fn every_single_bit_flip_is_dropped_and_the_stream_recovers() {
    // CRC-16 catches every 1-bit error in the payload; a flip in a COBS code byte either breaks
    // the stuffing or shifts bytes, which the CRC then catches. A flip that makes a 0x00 splits
    // the frame: both parts are dropped. Exhaustive over three messages, so deterministic.
    for frame in [
        frame_of(&get_status()),
        frame_of(&status_response()),
        frame_of(&largest_request()),
    ] {
        for bit in 0..(frame.len() - 1) * 8 {
            let mut bad = frame.clone();
            bad[bit / 8] ^= 1 << (bit % 8);
            let mut dec = FrameDecoder::new();
            bad.extend(frame_of(&get_status()));
            let got = push_all::<Request>(&mut dec, &bad);
            let (last, before) = got.split_last().unwrap();
            assert_eq!(last, &Ok(get_status()), "bit {bit}");
            assert!(
                before.iter().all(|r| r.is_err()),
                "bit {bit} flipped and still decoded: {before:?}"
            );
        }
    }
}

#[test]
fn truncated_frames_are_dropped() {
    let frame = frame_of(&status_response());
    for cut in 1..frame.len() - 1 {
        let mut dec = FrameDecoder::new();
        let mut stream = frame[..cut].to_vec();
        stream.push(0);
        let got = push_all::<DeviceMessage>(&mut dec, &stream);
        assert_eq!(got.len(), 1, "cut {cut}");
        assert!(got[0].is_err(), "cut {cut}");
        assert_eq!(dec.stats().frames_dropped, 1);
    }
}

#[test]
fn a_frame_of_the_other_direction_is_a_payload_error() {
    // The device decoding its own message type: CRC fine, payload not a Request.
    let mut frame = frame_of(&status_response());
    assert_eq!(decode::<Request>(&mut frame), Err(FrameError::Payload));
}

#[test]
fn trailing_bytes_after_a_message_are_refused() {
    // A valid CRC over "GetStatus request + one extra byte": refused, not silently truncated.
    let payload = [0x01u8, 0x01, 0x01, 0x00];
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&payload);
    let mut stuffed = stuff(&payload, &crc.to_le_bytes());
    assert_eq!(decode::<Request>(&mut stuffed), Err(FrameError::Payload));
}

/// `payload ‖ check`, COBS-stuffed, with its delimiter.
fn stuff(payload: &[u8], check: &[u8]) -> Vec<u8> {
    let mut raw = payload.to_vec();
    raw.extend(check);
    let mut stuffed = vec![0u8; raw.len() + 2];
    let n = cobs::try_encode(&raw, &mut stuffed).unwrap();
    stuffed.truncate(n);
    stuffed.push(0);
    stuffed
}

#[test]
fn a_protocol_v1_frame_is_told_apart_and_dropped() {
    // A v1 GetStatus (seq 1, no session) with v1's CRC-16/IBM-SDLC: not accepted, but named.
    let payload = [0x01u8, 0x01];
    let crc16 = crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC).checksum(&payload);
    let mut frame = stuff(&payload, &crc16.to_le_bytes());
    assert_eq!(hex(&frame), "050101160700");
    assert_eq!(
        decode::<Request>(&mut frame.clone()),
        Err(FrameError::Legacy)
    );
    let mut dec = FrameDecoder::new();
    assert_eq!(
        push_all::<Request>(&mut dec, &frame),
        vec![Err(FrameError::Legacy)]
    );
    assert_eq!(dec.stats().frames_dropped, 1);
    // With one bit flipped in its CRC it is neither: too short for a v2 frame.
    frame[3] ^= 0x10;
    assert_eq!(decode::<Request>(&mut frame), Err(FrameError::Payload));
    // A longer v1 frame (a v1 Hello: seq 1, variant 0, version 1, schema 0x221ee9a8).
    let payload = [0x01u8, 0x00, 0x01, 0xa8, 0xd3, 0xfb, 0x90, 0x02];
    let crc16 = crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC).checksum(&payload);
    let mut frame = stuff(&payload, &crc16.to_le_bytes());
    assert_eq!(
        decode::<Request>(&mut frame.clone()),
        Err(FrameError::Legacy)
    );
    frame[4] ^= 0x01;
    assert_eq!(decode::<Request>(&mut frame), Err(FrameError::Crc));
    // Longer than LEGACY_CHECK_MAX: not checked (a plain CRC error), so a corrupted long
    // frame never costs a bitwise CRC-16 over all of it.
    let payload = [0x01u8; LEGACY_CHECK_MAX];
    let crc16 = crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC).checksum(&payload);
    let mut frame = stuff(&payload, &crc16.to_le_bytes());
    assert_eq!(decode::<Request>(&mut frame), Err(FrameError::Crc));
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

#[test]
fn one_shot_decode_matches_the_stream_decoder() {
    let mut frame = frame_of(&largest_request());
    assert_eq!(decode::<Request>(&mut frame.clone()), Ok(largest_request()));
    // Without the delimiter too.
    frame.pop();
    assert_eq!(decode::<Request>(&mut frame), Ok(largest_request()));
    assert_eq!(decode::<Request>(&mut []), Err(FrameError::Empty));
    assert_eq!(decode::<Request>(&mut [0]), Err(FrameError::Empty));
    assert_eq!(decode::<Request>(&mut [3, 0, 1, 0]), Err(FrameError::Cobs));
}

#[test]
fn reset_discards_a_partial_frame_and_keeps_the_counters() {
    let mut dec = FrameDecoder::new();
    let frame = frame_of(&get_status());
    push_all::<Request>(&mut dec, &frame);
    push_all::<Request>(&mut dec, &frame[..3]);
    dec.reset();
    assert_eq!(
        push_all::<Request>(&mut dec, &frame),
        vec![Ok(get_status())]
    );
    assert_eq!(dec.stats().frames_ok, 2);
    assert_eq!(dec.stats().frames_dropped, 0);
}
