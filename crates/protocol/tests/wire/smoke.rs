//! Smoke test of the framing round trip (the protocol issue extends this into golden tests).
use protocol::*;

#[test]
fn a_plan_upload_round_trips_through_a_frame() {
    let mut steps = heapless::Vec::new();
    let mut prims = heapless::Vec::new();
    prims
        .push(Primitive::Inflate {
            pressure_kpa: 25.0,
            snaps: 1,
        })
        .unwrap();
    prims.push(Primitive::Vent { pressure_kpa: 0.0 }).unwrap();
    steps
        .push(Step {
            kind: StepKind::Pneumatic,
            from: "F&P".parse().unwrap(),
            to: "F&F".parse().unwrap(),
            primitives: prims,
            timeout_ms: 20_000,
        })
        .unwrap();
    let req = Request {
        seq: 7,
        session: 0x5eed,
        body: RequestBody::UploadPlan(Plan { plan_id: 3, steps }),
    };
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(&req, &mut buf).unwrap();
    assert_eq!(buf[n - 1], 0);
    assert!(buf[..n - 1].iter().all(|&b| b != 0));
    let mut dec = FrameDecoder::new();
    let mut out = None;
    for &b in &buf[..n] {
        if let Some(r) = dec.push::<Request>(b) {
            out = Some(r);
        }
    }
    assert_eq!(out, Some(Ok(req)));
    assert_eq!(dec.stats().frames_ok, 1);
}
