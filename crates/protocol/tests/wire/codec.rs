//! The hand-written codec (`protocol::codec`, the device's side of the wire) against postcard
//! with the serde derives (the host's): every request the strategies make reads back as
//! itself, mutated, truncated and extended bytes are accepted exactly when postcard accepts
//! them (and to the same value), varint edge forms included; every device message is written
//! byte for byte as postcard writes it; the frame-level paths agree with the serde ones.

use proptest::collection::vec;
use proptest::prelude::*;
use protocol::codec::{Reader, Writer};
use protocol::*;

use crate::props::{device_message, request};

/// postcard bytes of `v`.
fn to_vec<T: serde::Serialize>(v: &T) -> Vec<u8> {
    let mut buf = [0u8; 1024];
    postcard::to_slice(v, &mut buf).unwrap().to_vec()
}

/// postcard's reading of a whole frame payload (no bytes left over), as the serde frame path.
fn postcard_request(bytes: &[u8]) -> Option<Request> {
    let mut de = postcard::Deserializer::from_bytes(bytes);
    let req = <Request as serde::Deserialize>::deserialize(&mut de).ok()?;
    matches!(de.finalize(), Ok([])).then_some(req)
}

/// The codec's reading of the same, into `slot`.
fn codec_request(bytes: &[u8], slot: &mut Request) -> Option<Request> {
    let mut r = Reader::new(bytes);
    slot.decode_into(&mut r).ok()?;
    r.rest().is_empty().then(|| slot.clone())
}

/// Both readings agree: both refuse, or both give the same value (compared by its bytes, so
/// that a NaN read from mutated bytes compares bit for bit).
fn agree(bytes: &[u8], slot: &mut Request) -> Result<(), TestCaseError> {
    let theirs = postcard_request(bytes).map(|r| to_vec(&r));
    let ours = codec_request(bytes, slot).map(|r| to_vec(&r));
    prop_assert_eq!(ours, theirs, "bytes {:02x?}", bytes);
    Ok(())
}

fn big_request() -> Request {
    let plan = firmware_like_plan();
    Request {
        seq: 7,
        session: 9,
        body: RequestBody::UploadPlan(plan),
    }
}

/// A full plan (8 steps × 4 bends), as the largest upload.
fn firmware_like_plan() -> Plan {
    let step = Step {
        kind: StepKind::Tendon,
        from: "F&F".parse().unwrap(),
        to: "F&F".parse().unwrap(),
        primitives: heapless::Vec::from_slice(
            &[Primitive::Bend {
                direction_deg: 12.5,
                angle_deg: 30.0,
            }; MAX_STEP_PRIMITIVES],
        )
        .unwrap(),
        timeout_ms: 60_000,
    };
    Plan {
        plan_id: 3,
        steps: core::iter::repeat_n(step, MAX_PLAN_STEPS).collect(),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn every_request_reads_back_as_itself(req in request(), reuse in any::<bool>()) {
        let bytes = to_vec(&req);
        // Into a blank slot, or into one that holds a full plan (read in place over it).
        let mut slot = if reuse { big_request() } else { Request::blank() };
        prop_assert_eq!(codec_request(&bytes, &mut slot), Some(req));
    }

    #[test]
    fn mutated_requests_are_read_as_postcard_reads_them(
        req in request(),
        edits in vec((any::<usize>(), any::<u8>()), 1..4),
        cut in proptest::option::of(any::<usize>()),
        tail in vec(any::<u8>(), 0..3),
    ) {
        let mut bytes = to_vec(&req);
        for &(at, b) in &edits {
            let n = bytes.len();
            bytes[at % n] = b;
        }
        if let Some(c) = cut {
            bytes.truncate(c % (bytes.len() + 1));
        }
        bytes.extend_from_slice(&tail);
        let mut blank = Request::blank();
        agree(&bytes, &mut blank)?;
        agree(&bytes, &mut big_request())?;
    }

    #[test]
    fn short_garbage_is_read_as_postcard_reads_it(bytes in vec(any::<u8>(), 0..40)) {
        let mut blank = Request::blank();
        agree(&bytes, &mut blank)?;
    }

    #[test]
    fn every_device_message_is_written_as_postcard_writes_it(msg in device_message()) {
        let theirs = to_vec(&msg);
        let mut buf = [0u8; 1024];
        let mut w = Writer::new(&mut buf);
        msg.encode(&mut w);
        let n = w.written().expect("fits");
        prop_assert_eq!(&buf[..n], &theirs[..]);
        // Too small a buffer: refused, whatever is short.
        for short in [0, n / 2, n.saturating_sub(1)] {
            if short < n {
                let mut small = vec![0u8; short];
                let mut w = Writer::new(&mut small);
                msg.encode(&mut w);
                prop_assert_eq!(w.written(), None);
            }
        }
        // The frame is the serde path's frame.
        let mut a = [0u8; MAX_FRAME_LEN];
        let mut b = [0u8; MAX_FRAME_LEN];
        let na = encode(&msg, &mut a).unwrap();
        let nb = encode_device_message(&msg, &mut b).unwrap();
        prop_assert_eq!(&a[..na], &b[..nb]);
    }

    /// The device's frame path (`push_request`) against the serde one (`push::<Request>`) on
    /// garbage and frames mixed: the same results, the same counters.
    #[test]
    fn push_request_is_push(
        reqs in vec(request(), 1..4),
        garbage in vec(prop_oneof![Just(0u8), any::<u8>()], 0..300),
        split in any::<usize>(),
    ) {
        let mut line = Vec::new();
        let at = split % (garbage.len() + 1);
        line.extend_from_slice(&garbage[..at]);
        line.push(0);
        for req in &reqs {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let n = encode(req, &mut buf).unwrap();
            line.extend_from_slice(&buf[..n]);
        }
        line.extend_from_slice(&garbage[at..]);
        let (mut serde_dec, mut codec_dec) = (FrameDecoder::new(), FrameDecoder::new());
        let mut slot = Request::blank();
        for &b in &line {
            let theirs = serde_dec.push::<Request>(b).map(|r| r.map(|q| to_vec(&q)));
            let ours = codec_dec
                .push_request(b, &mut slot)
                .map(|r| r.map(|()| to_vec(&slot)));
            prop_assert_eq!(ours, theirs);
            prop_assert_eq!(codec_dec.stats(), serde_dec.stats());
            prop_assert_eq!(codec_dec.last_frame(), serde_dec.last_frame());
        }
    }
}

/// Every last byte after a run of continuation bytes, for each varint of a request (the `u16`
/// `seq`, the `u32` `session`, the `usize` length of a plan's steps and a variant index), and
/// runs longer than any varint: accepted or refused as postcard does.
#[test]
fn varint_edge_forms_are_read_as_postcard_reads_them() {
    let mut slot = Request::blank();
    for run in 0..12 {
        for last in 0..=255u8 {
            let varint: Vec<u8> = std::iter::repeat_n(0x80u8, run).chain([last]).collect();
            let ones: Vec<u8> = std::iter::repeat_n(0xFFu8, run).chain([last]).collect();
            for v in [&varint, &ones] {
                // seq
                let mut b = v.clone();
                b.extend_from_slice(&[0, 1]);
                assert!(agree(&b, &mut slot).is_ok(), "seq {b:02x?}");
                // session
                let mut b = vec![5];
                b.extend_from_slice(v);
                b.push(1);
                assert!(agree(&b, &mut slot).is_ok(), "session {b:02x?}");
                // the body's variant index
                let mut b = vec![5, 0];
                b.extend_from_slice(v);
                assert!(agree(&b, &mut slot).is_ok(), "variant {b:02x?}");
                // a plan's step count (an empty plan after it when the count reads as 0)
                let mut b = vec![5, 0, 3, 1];
                b.extend_from_slice(v);
                assert!(agree(&b, &mut slot).is_ok(), "steps {b:02x?}");
            }
        }
    }
}

/// A full plan read into a slot that held another full plan: every field is the new one's.
#[test]
fn a_plan_read_over_another_is_the_new_plan() {
    let mut slot = big_request();
    let mut other = firmware_like_plan();
    other.plan_id = 11;
    other.steps.truncate(3);
    other.steps[1].primitives.truncate(1);
    other.steps[2].primitives[0] = Primitive::Hold { duration_ms: 300 };
    let req = Request {
        seq: 1,
        session: 2,
        body: RequestBody::UploadPlan(other),
    };
    assert_eq!(codec_request(&to_vec(&req), &mut slot), Some(req));
}
