//! Golden bytes: the wire form of every message, variant by variant.
//!
//! A failure here means the format changed. If that is deliberate, bump
//! `protocol::PROTOCOL_VERSION` where the change is incompatible, update the expected hex from the
//! failure message (it prints every actual value), and say so in the commit message.
//!
//! Each enum's table must cover every variant: the `*_index` functions are exhaustive matches, so
//! adding a variant fails to compile here until it gets a golden case.

use core::fmt::Debug;

use protocol::*;
use serde::{de::DeserializeOwned, Serialize};

use crate::samples::{largest_request, st, status_response};

/// The current schema identity. It changes with any change of a message type's shape (a name,
/// field, variant or type; not a comment): update this one constant deliberately, together with
/// the golden bytes if the wire form changed (old builds will refuse the new ones at the
/// handshake).
const EXPECTED_SCHEMA_ID: u32 = 0x72d7_b597;

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex(s: &str) -> Vec<u8> {
    let s: String = s.chars().filter(|c| !c.is_whitespace()).collect();
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).expect("hex"))
        .collect()
}

/// Checks every case both ways (value → bytes, bytes → value) and reports all mismatches at
/// once with the actual hex, so a deliberate change is a copy-paste.
fn check<T: Serialize + DeserializeOwned + PartialEq + Debug>(what: &str, cases: &[(T, &str)]) {
    let mut bad = Vec::new();
    for (value, expected) in cases {
        let mut buf = [0u8; MAX_RAW_LEN];
        let bytes = postcard::to_slice(value, &mut buf).expect("serialises");
        let actual = hex(bytes);
        let expected_clean: String = expected.chars().filter(|c| !c.is_whitespace()).collect();
        if actual != expected_clean {
            bad.push(format!(
                "  {value:?}\n    expected {expected_clean}\n    actual   {actual}"
            ));
            continue;
        }
        let back: T = postcard::from_bytes(&unhex(expected)).expect("golden bytes deserialise");
        assert_eq!(
            &back, value,
            "{what}: golden bytes decode to a different value"
        );
    }
    assert!(
        bad.is_empty(),
        "{what}: wire form changed:\n{}",
        bad.join("\n")
    );
}

/// Asserts that `indices` (from an exhaustive match) cover 0..n.
fn covers(what: &str, indices: impl Iterator<Item = usize>, n: usize) {
    let mut seen = vec![false; n];
    for i in indices {
        seen[i] = true;
    }
    let missing: Vec<usize> = (0..n).filter(|&i| !seen[i]).collect();
    assert!(
        missing.is_empty(),
        "{what}: no golden case for variants {missing:?}"
    );
}

fn step_pneumatic() -> Step {
    Step {
        kind: StepKind::Pneumatic,
        from: st("F&P"),
        to: st("F&F"),
        primitives: heapless::Vec::from_slice(&[
            Primitive::Inflate {
                pressure_kpa: 25.5,
                snaps: 1,
            },
            Primitive::Vent { pressure_kpa: 0.0 },
        ])
        .unwrap(),
        timeout_ms: 20_000,
    }
}

fn step_tendon() -> Step {
    Step {
        kind: StepKind::Tendon,
        from: st("D&D"),
        to: st("F&D"),
        primitives: heapless::Vec::from_slice(&[
            Primitive::TendonPull {
                length_mm: 12.5,
                snaps: 2,
            },
            Primitive::TendonRelease { length_mm: 0.0 },
        ])
        .unwrap(),
        timeout_ms: 300,
    }
}

fn module(n: u8, beta_deg: f32) -> ModuleConfig {
    ModuleConfig {
        n,
        beta_deg,
        edge_mm: 25.0,
        layers: 3,
    }
}

fn device_info() -> DeviceInfo {
    DeviceInfo {
        protocol_version: 2,
        schema_id: 0xdead_beef,
        firmware_version: [0, 1, 2],
        board: Board::UnoR4Wifi,
        trunk: TrunkConfig {
            bottom: module(6, 35.0),
            top: module(6, 31.72),
            pressure_limit_kpa: 40.0,
        },
        session: 0x0102_0304,
        reset_cause: ResetCause::Watchdog,
        signing: true,
    }
}

#[test]
fn schema_id_is_the_pinned_value() {
    assert_eq!(
        SCHEMA_ID, EXPECTED_SCHEMA_ID,
        "a message type's shape changed: SCHEMA_ID is now {SCHEMA_ID:#010x}; update EXPECTED_SCHEMA_ID on \
         purpose (and the golden bytes if the wire form changed)"
    );
}

#[test]
fn protocol_version_is_the_pinned_value() {
    assert_eq!(PROTOCOL_VERSION, 2);
}

#[test]
fn trunk_states() {
    let names = ["F&P", "F&F", "F&D", "D&P", "D&F", "D&D"];
    let hexes = ["0000", "0001", "0002", "0100", "0101", "0102"];
    let cases: Vec<_> = names.iter().map(|n| st(n)).zip(hexes).collect();
    check("TrunkState", &cases);
}

fn request_index(b: &RequestBody) -> usize {
    match b {
        RequestBody::Hello { .. } => 0,
        RequestBody::GetStatus => 1,
        RequestBody::Heartbeat => 2,
        RequestBody::UploadPlan(_) => 3,
        RequestBody::StartPlan { .. } => 4,
        RequestBody::RunStep(_) => 5,
        RequestBody::Abort => 6,
        RequestBody::ConfirmManual => 7,
        RequestBody::ResetFaults => 8,
        RequestBody::DeclareState(_) => 9,
        RequestBody::GetParam(_) => 10,
        RequestBody::SetParam { .. } => 11,
        RequestBody::Close => 12,
        RequestBody::Identify => 13,
        RequestBody::SetSigning { .. } => 14,
        RequestBody::SetProbeProfile { .. } => 15,
        RequestBody::GetProbeProfile => 16,
    }
}

#[test]
fn requests() {
    // seq 258 pins the varint form of `seq` (0x82 0x02); session 1 is one byte.
    let req = |body| Request {
        seq: 258,
        session: 1,
        body,
    };
    let cases = [
        (
            req(RequestBody::Hello {
                protocol_version: 1,
                schema_id: 0xdead_beef,
                takeover: true,
            }),
            "8202010001effdb6f50d01",
        ),
        (req(RequestBody::GetStatus), "82020101"),
        (req(RequestBody::Heartbeat), "82020102"),
        (
            req(RequestBody::UploadPlan(Plan {
                plan_id: 3,
                steps: heapless::Vec::from_slice(&[step_pneumatic(), step_tendon()]).unwrap(),
            })),
            "820201030302000000000102000000cc41010100000000a09c010101020002020200004841020300000000ac02",
        ),
        (req(RequestBody::StartPlan { plan_id: 3 }), "8202010403"),
        (req(RequestBody::RunStep(step_pneumatic())), "82020105000000000102000000cc41010100000000a09c01"),
        (req(RequestBody::Abort), "82020106"),
        (req(RequestBody::ConfirmManual), "82020107"),
        (req(RequestBody::ResetFaults), "82020108"),
        (req(RequestBody::DeclareState(st("D&F"))), "820201090101"),
        (req(RequestBody::GetParam(ParamId::PressureLimitKpa)), "8202010a00"),
        (
            req(RequestBody::SetParam {
                id: ParamId::TelemetryHz,
                value: 10.0,
            }),
            "8202010b0400002041",
        ),
        (req(RequestBody::Close), "8202010c"),
        (req(RequestBody::Identify), "8202010d"),
        (
            req(RequestBody::SetSigning {
                key: *b"0123456789abcdef",
                enabled: true,
            }),
            "8202010e3031323334353637383961626364656601",
        ),
        (
            req(RequestBody::SetProbeProfile {
                schema_id: 0xdead_beef,
                profile: Some(probe_profile()),
            }),
            "8202010feffdb6f50d010000c03f00000040000020400000404000006040000080400000e03f00005040",
        ),
        (
            req(RequestBody::SetProbeProfile {
                schema_id: 0xdead_beef,
                profile: None,
            }),
            "8202010feffdb6f50d00",
        ),
        (req(RequestBody::GetProbeProfile), "82020110"),
    ];
    check("Request", &cases);
    covers(
        "RequestBody",
        cases.iter().map(|c| request_index(&c.0.body)),
        17,
    );
    // The first byte after the seq and session varints is the variant index.
    for (r, _) in &cases {
        let mut buf = [0u8; MAX_RAW_LEN];
        let bytes = postcard::to_slice(r, &mut buf).unwrap();
        assert_eq!(bytes[3] as usize, request_index(&r.body));
    }
}

#[test]
fn param_ids() {
    let cases: Vec<_> = ParamId::ALL
        .iter()
        .copied()
        .zip(["00", "01", "02", "03", "04", "05"])
        .collect();
    check("ParamId", &cases);
    // ALL lists every variant: an exhaustive match numbers them.
    let index = |p: ParamId| match p {
        ParamId::PressureLimitKpa => 0,
        ParamId::ServoMinDeg => 1,
        ParamId::ServoMaxDeg => 2,
        ParamId::ServoSlewDegPerS => 3,
        ParamId::TelemetryHz => 4,
        ParamId::LinkTimeoutMs => 5,
    };
    covers("ParamId", ParamId::ALL.iter().map(|&p| index(p)), 6);
}

fn primitive_index(p: &Primitive) -> usize {
    match p {
        Primitive::Inflate { .. } => 0,
        Primitive::Vent { .. } => 1,
        Primitive::TendonPull { .. } => 2,
        Primitive::TendonRelease { .. } => 3,
        Primitive::Hold { .. } => 4,
        Primitive::WaitSnap { .. } => 5,
        Primitive::Manual(_) => 6,
        Primitive::Gripper { .. } => 7,
        Primitive::Bend { .. } => 8,
    }
}

#[test]
fn primitives() {
    let cases = [
        (
            Primitive::Inflate {
                pressure_kpa: 25.5,
                snaps: 1,
            },
            "000000cc4101",
        ),
        (Primitive::Vent { pressure_kpa: 2.0 }, "0100000040"),
        (
            Primitive::TendonPull {
                length_mm: 12.5,
                snaps: 2,
            },
            "020000484102",
        ),
        (Primitive::TendonRelease { length_mm: 0.5 }, "030000003f"),
        (Primitive::Hold { duration_ms: 1_000 }, "04e807"),
        (Primitive::WaitSnap { timeout_ms: 5_000 }, "058827"),
        (Primitive::Manual(ManualTask::PackBottomModule), "0600"),
        (Primitive::Gripper { close: true }, "0701"),
        (
            Primitive::Bend {
                direction_deg: 120.0,
                angle_deg: -30.0,
            },
            "080000f0420000f0c1",
        ),
    ];
    check("Primitive", &cases);
    covers("Primitive", cases.iter().map(|c| primitive_index(&c.0)), 9);
}

#[test]
fn small_enums() {
    let kind = |k: StepKind| match k {
        StepKind::Pneumatic => 0,
        StepKind::Tendon => 1,
        StepKind::Manual => 2,
    };
    let kinds = [
        (StepKind::Pneumatic, "00"),
        (StepKind::Tendon, "01"),
        (StepKind::Manual, "02"),
    ];
    check("StepKind", &kinds);
    covers("StepKind", kinds.iter().map(|c| kind(c.0)), 3);

    let task = |t: ManualTask| match t {
        ManualTask::PackBottomModule => 0,
        ManualTask::FoldTopModule => 1,
        ManualTask::FoldBottomModule => 2,
    };
    let tasks = [
        (ManualTask::PackBottomModule, "00"),
        (ManualTask::FoldTopModule, "01"),
        (ManualTask::FoldBottomModule, "02"),
    ];
    check("ManualTask", &tasks);
    covers("ManualTask", tasks.iter().map(|c| task(c.0)), 3);

    let board = |b: Board| match b {
        Board::UnoR4Wifi => 0,
        Board::UnoR4Minima => 1,
        Board::Simulator => 2,
    };
    let boards = [
        (Board::UnoR4Wifi, "00"),
        (Board::UnoR4Minima, "01"),
        (Board::Simulator, "02"),
    ];
    check("Board", &boards);
    covers("Board", boards.iter().map(|c| board(c.0)), 3);

    let mode = |m: Mode| match m {
        Mode::Standalone => 0,
        Mode::Running => 1,
        Mode::WaitingManual => 2,
        Mode::Safe => 3,
        Mode::EStop => 4,
    };
    let modes = [
        (Mode::Standalone, "00"),
        (Mode::Running, "01"),
        (Mode::WaitingManual, "02"),
        (Mode::Safe, "03"),
        (Mode::EStop, "04"),
    ];
    check("Mode", &modes);
    covers("Mode", modes.iter().map(|c| mode(c.0)), 5);

    let phase = |p: PlanPhase| match p {
        PlanPhase::Ready => 0,
        PlanPhase::Running => 1,
        PlanPhase::WaitingManual => 2,
        PlanPhase::Done => 3,
        PlanPhase::Failed(_) => 4,
        PlanPhase::Aborted => 5,
    };
    let phases = [
        (PlanPhase::Ready, "00"),
        (PlanPhase::Running, "01"),
        (PlanPhase::WaitingManual, "02"),
        (PlanPhase::Done, "03"),
        (PlanPhase::Failed(FaultCode::LinkLoss), "0404"),
        (PlanPhase::Aborted, "05"),
    ];
    check("PlanPhase", &phases);
    covers("PlanPhase", phases.iter().map(|c| phase(c.0)), 6);
}

#[test]
fn fault_codes_go_by_variant_index_not_display_code() {
    // serde numbers variants 0.., so E-01 (OverPressure) is 0x00 on the wire.
    let cases: Vec<_> = FaultCode::ALL
        .iter()
        .map(|&f| (f, format!("{:02x}", f.code() - 1)))
        .collect();
    let cases: Vec<(FaultCode, &str)> = cases.iter().map(|(f, h)| (*f, h.as_str())).collect();
    check("FaultCode", &cases);
    let index = |f: FaultCode| match f {
        FaultCode::OverPressure => 0,
        FaultCode::PressureSensor => 1,
        FaultCode::StepTimeout => 2,
        FaultCode::TransitionNotConfirmed => 3,
        FaultCode::LinkLoss => 4,
        FaultCode::EStop => 5,
        FaultCode::ServoLimit => 6,
        FaultCode::Leak => 7,
        FaultCode::Watchdog => 8,
        FaultCode::StateStorage => 9,
        FaultCode::InletStuck => 10,
        FaultCode::NoPressureRise => 11,
    };
    covers("FaultCode", FaultCode::ALL.iter().map(|&f| index(f)), 12);
}

#[test]
fn reject_reasons_and_result_codes() {
    let reason = |r: RejectReason| match r {
        RejectReason::VersionMismatch => 0,
        RejectReason::NoHandshake => 1,
        RejectReason::EStopLatched => 2,
        RejectReason::Faulted => 3,
        RejectReason::InvalidPlan => 4,
        RejectReason::UnknownPlan => 5,
        RejectReason::WrongState => 6,
        RejectReason::OutOfRange => 7,
        RejectReason::NoManualPending => 8,
        RejectReason::NotAllowed => 9,
        RejectReason::NotSessionOwner => 10,
        RejectReason::SessionBusy => 11,
        RejectReason::Unconfirmed => 12,
        RejectReason::Unsigned => 13,
    };
    let reasons = [
        RejectReason::VersionMismatch,
        RejectReason::NoHandshake,
        RejectReason::EStopLatched,
        RejectReason::Faulted,
        RejectReason::InvalidPlan,
        RejectReason::UnknownPlan,
        RejectReason::WrongState,
        RejectReason::OutOfRange,
        RejectReason::NoManualPending,
        RejectReason::NotAllowed,
        RejectReason::NotSessionOwner,
        RejectReason::SessionBusy,
        RejectReason::Unconfirmed,
        RejectReason::Unsigned,
    ];
    let hexes: Vec<String> = (0..14).map(|i| format!("01{i:02x}")).collect();
    let cases: Vec<(ResultCode, &str)> = reasons
        .iter()
        .zip(&hexes)
        .map(|(&r, h)| (ResultCode::Rejected(r), h.as_str()))
        .collect();
    check("ResultCode::Rejected", &cases);
    covers("RejectReason", reasons.iter().map(|&r| reason(r)), 14);

    let cause = |c: ResetCause| match c {
        ResetCause::PowerOn => 0,
        ResetCause::Watchdog => 1,
        ResetCause::BrownOut => 2,
        ResetCause::Software => 3,
        ResetCause::Unknown => 4,
    };
    let causes = [
        (ResetCause::PowerOn, "00"),
        (ResetCause::Watchdog, "01"),
        (ResetCause::BrownOut, "02"),
        (ResetCause::Software, "03"),
        (ResetCause::Unknown, "04"),
    ];
    check("ResetCause", &causes);
    covers("ResetCause", causes.iter().map(|c| cause(c.0)), 5);

    // A state set is its bitmask byte; a transition its two states.
    check(
        "StateSet",
        &[
            (StateSet::EMPTY, "00"),
            (StateSet::single(st("D&D")), "20"),
            (StateSet::ALL, "3f"),
        ],
    );
    check(
        "Transition",
        &[(
            Transition {
                from: st("D&D"),
                to: st("F&D"),
            },
            "01020002",
        )],
    );

    let result = |r: ResultCode| match r {
        ResultCode::Ok => 0,
        ResultCode::Rejected(_) => 1,
        ResultCode::Busy => 2,
        ResultCode::InProgress => 3,
    };
    let results = [
        (ResultCode::Ok, "00"),
        (ResultCode::Rejected(RejectReason::WrongState), "0106"),
        (ResultCode::Busy, "02"),
        (ResultCode::InProgress, "03"),
    ];
    check("ResultCode", &results);
    covers("ResultCode", results.iter().map(|c| result(c.0)), 4);
}

fn response_index(b: &ResponseBody) -> usize {
    match b {
        ResponseBody::None => 0,
        ResponseBody::Hello(_) => 1,
        ResponseBody::Status(_) => 2,
        ResponseBody::Param { .. } => 3,
        ResponseBody::Refused(_) => 4,
        ResponseBody::ProbeProfile(_) => 5,
    }
}

/// A probe profile whose rates are exact in `f32` (1.5 = 0x3fc00000 and so on).
fn probe_profile() -> ProbeProfile {
    ProbeProfile {
        states: [1.5, 2.0, 2.5, 3.0, 3.5, 4.0],
        between: [1.75, 3.25],
    }
}

#[test]
fn responses() {
    let resp = |result, body| DeviceMessage::Response {
        seq: 258,
        result,
        body,
    };
    let mut idle = match status_response() {
        DeviceMessage::Response {
            body: ResponseBody::Status(s),
            ..
        } => s,
        _ => unreachable!(),
    };
    idle.plan = None;
    idle.manual_task = None;
    idle.mode = Mode::Standalone;
    idle.faults = FaultCode::Leak.bit() | FaultCode::EStop.bit();
    idle.frames_rx = 1_000;
    idle.frames_dropped = 2;
    idle.uptime_ms = 65_536;
    let cases = [
        (resp(ResultCode::Ok, ResponseBody::None), "0082020000"),
        (resp(ResultCode::InProgress, ResponseBody::None), "0082020300"),
        (resp(ResultCode::Ok, ResponseBody::Hello(device_info())), "008202000102effdb6f50d000102000600000c420000c84103068fc2fd410000c84103000020428486880801\
             01"),
        (
            resp(
                ResultCode::Rejected(RejectReason::VersionMismatch),
                ResponseBody::Hello(DeviceInfo {
                    board: Board::Simulator,
                    ..device_info()
                }),
            ),
            "00820201000102effdb6f50d000102020600000c420000c84103068fc2fd410000c84103000020428486880801\
             01",
        ),
        (resp(ResultCode::Ok, ResponseBody::Status(idle)), "00820200020101003f0101020101000000be410000b4420000b7420080b042010001000000c002e80702808004"),
        (status_response(), "00ffff0300020101003f0101020101010000be410000b4420000b7420080b0420100010001ffff03070804090102ffff03ffffffff0fffffffff0fffffffff0f"),
        (
            resp(
                ResultCode::Ok,
                ResponseBody::Param {
                    id: ParamId::LinkTimeoutMs,
                    value: 3_000.0,
                },
            ),
            "00820200030500803b45",
        ),
        (
            resp(
                ResultCode::Rejected(RejectReason::OutOfRange),
                ResponseBody::Refused(Refusal {
                    step: Some(1),
                    field: RefusedField::Param(ParamId::TelemetryHz),
                    value: 16.0,
                    limit: 10.0,
                }),
            ),
            "008202010704010104040000804100002041",
        ),
        (
            resp(
                ResultCode::Rejected(RejectReason::OutOfRange),
                ResponseBody::Refused(Refusal {
                    step: None,
                    field: RefusedField::ProbeRate(6),
                    value: -1.0,
                    limit: 0.5,
                }),
            ),
            "008202010704000606000080bf0000003f",
        ),
        (
            resp(ResultCode::Ok, ResponseBody::ProbeProfile(Some(probe_profile()))),
            "0082020005010000c03f00000040000020400000404000006040000080400000e03f00005040",
        ),
        (resp(ResultCode::Ok, ResponseBody::ProbeProfile(None)), "008202000500"),
    ];
    check("DeviceMessage::Response", &cases);
    covers(
        "ResponseBody",
        cases.iter().map(|c| match &c.0 {
            DeviceMessage::Response { body, .. } => response_index(body),
            DeviceMessage::Event(_) => unreachable!(),
        }),
        6,
    );
}

fn event_index(e: &Event) -> usize {
    match e {
        Event::Heartbeat { .. } => 0,
        Event::Telemetry(_) => 1,
        Event::StepProgress { .. } => 2,
        Event::StepDone { .. } => 3,
        Event::PlanDone { .. } => 4,
        Event::StateReached { .. } => 5,
        Event::ManualRequired { .. } => 6,
        Event::FaultRaised(_) => 7,
        Event::FaultCleared(_) => 8,
        Event::IdentifyNeedsOperator { .. } => 9,
    }
}

#[test]
fn events() {
    let ev = DeviceMessage::Event;
    let cases = [
        (
            ev(Event::Heartbeat {
                uptime_ms: 500,
                mode: Mode::Safe,
            }),
            "0100f40303",
        ),
        (
            ev(Event::Telemetry(Telemetry {
                uptime_ms: 1_234,
                pressure_kpa: 12.25,
                servo_deg: [0.0, 90.0, 180.0],
                inlet_open: true,
                exhaust_open: false,
                state: st("F&F"),
                state_confirmed: false,
            })),
            "0101d20900004441000000000000b442000034430100000100",
        ),
        (
            ev(Event::StepProgress {
                plan_id: 3,
                step: 1,
                primitive: 2,
                elapsed_ms: 150,
            }),
            "01020301029601",
        ),
        (
            ev(Event::StepDone {
                plan_id: 3,
                step: 1,
                ok: true,
                state: st("D&F"),
                duration_ms: 4_321,
            }),
            "01030301010101e121",
        ),
        (
            ev(Event::PlanDone {
                plan_id: 3,
                ok: false,
                state: st("F&D"),
            }),
            "010403000002",
        ),
        (
            ev(Event::StateReached {
                state: st("D&D"),
                confirmed: true,
            }),
            "0105010201",
        ),
        (
            ev(Event::ManualRequired {
                plan_id: 4,
                step: 2,
                task: ManualTask::FoldTopModule,
            }),
            "0106040201",
        ),
        (ev(Event::FaultRaised(FaultCode::OverPressure)), "010700"),
        (ev(Event::FaultCleared(FaultCode::StateStorage)), "010809"),
        (
            ev(Event::IdentifyNeedsOperator {
                candidates: StateSet::single(st("F&D")).with(st("F&F")),
            }),
            "010906",
        ),
    ];
    check("DeviceMessage::Event", &cases);
    covers(
        "Event",
        cases.iter().map(|c| match &c.0 {
            DeviceMessage::Event(e) => event_index(e),
            DeviceMessage::Response { .. } => unreachable!(),
        }),
        10,
    );
}

/// Whole frames: pins the CRC (CRC-32/ISO-HDLC, little-endian) and the COBS stuffing. The CRCs
/// here were cross-checked with Python's `zlib.crc32` (the same CRC-32).
#[test]
fn whole_frames() {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let get_status = Request {
        seq: 1,
        session: 1,
        body: RequestBody::GetStatus,
    };
    let n = encode(&get_status, &mut buf).unwrap();
    assert_eq!(hex(&buf[..n]), "08010101f2b29f9000");

    // A payload with zeros in it exercises the stuffing.
    let heartbeat = DeviceMessage::Event(Event::Heartbeat {
        uptime_ms: 0,
        mode: Mode::Standalone,
    });
    let n = encode(&heartbeat, &mut buf).unwrap();
    assert_eq!(hex(&buf[..n]), "020101010579b8f89900");
}

/// The largest message must fit a frame; its size is pinned so growth is noticed (and
/// `docs/protocol.md` / BENCHMARKS.md updated).
#[test]
fn largest_message_fits_max_frame_len() {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(&largest_request(), &mut buf).unwrap();
    assert!(n <= MAX_FRAME_LEN);
    // By construction: seq 3 + session 5 + tag 1 + plan_id 3 + len 1 + 8 × (kind 1 + states 4
    // + len 1 + 4 × Bend 9 + timeout 5) = 389 postcard bytes, + CRC 4 = 393, + COBS 2 (no zero
    // in a 393-byte run: one code byte per 254) + delimiter 1 = 396.
    assert_eq!(n, 396, "largest frame size changed");
    // The sample really is zero-free, so no message can make a longer frame.
    let mut raw = [0u8; MAX_RAW_LEN];
    let payload = postcard::to_slice(&largest_request(), &mut raw).unwrap();
    assert_eq!(payload.len(), 389);
    assert!(payload.iter().all(|&b| b != 0));
    let n = encode(&status_response(), &mut buf).unwrap();
    assert_eq!(n, 70, "largest status frame size changed");
}
