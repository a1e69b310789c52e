//! Property tests: every message round-trips through a frame; any bytes leave the decoder
//! unharmed and in sync; chunking does not matter.

use geometry::TrunkState;
use proptest::collection::vec;
use proptest::prelude::*;
use protocol::*;

// ---- strategies -----------------------------------------------------------------------------

/// Finite floats only: NaN round-trips bit for bit but is not `==` to itself.
fn f() -> impl Strategy<Value = f32> {
    any::<f32>().prop_filter("finite", |x| x.is_finite())
}

fn trunk_state() -> impl Strategy<Value = TrunkState> {
    prop::sample::select(TrunkState::ALL.to_vec())
}

fn manual_task() -> impl Strategy<Value = ManualTask> {
    prop_oneof![
        Just(ManualTask::PackBottomModule),
        Just(ManualTask::FoldTopModule),
        Just(ManualTask::FoldBottomModule),
    ]
}

fn primitive() -> impl Strategy<Value = Primitive> {
    prop_oneof![
        (f(), any::<u8>()).prop_map(|(p, s)| Primitive::Inflate {
            pressure_kpa: p,
            snaps: s
        }),
        f().prop_map(|p| Primitive::Vent { pressure_kpa: p }),
        (f(), any::<u8>()).prop_map(|(l, s)| Primitive::TendonPull {
            length_mm: l,
            snaps: s
        }),
        f().prop_map(|l| Primitive::TendonRelease { length_mm: l }),
        any::<u32>().prop_map(|d| Primitive::Hold { duration_ms: d }),
        any::<u32>().prop_map(|t| Primitive::WaitSnap { timeout_ms: t }),
        manual_task().prop_map(Primitive::Manual),
        any::<bool>().prop_map(|c| Primitive::Gripper { close: c }),
        (f(), f()).prop_map(|(d, a)| Primitive::Bend {
            direction_deg: d,
            angle_deg: a
        }),
    ]
}

pub fn step() -> impl Strategy<Value = Step> {
    (
        prop_oneof![
            Just(StepKind::Pneumatic),
            Just(StepKind::Tendon),
            Just(StepKind::Manual)
        ],
        trunk_state(),
        trunk_state(),
        vec(primitive(), 0..=MAX_STEP_PRIMITIVES),
        any::<u32>(),
    )
        .prop_map(|(kind, from, to, prims, timeout_ms)| Step {
            kind,
            from,
            to,
            primitives: heapless::Vec::from_slice(&prims).unwrap(),
            timeout_ms,
        })
}

fn param_id() -> impl Strategy<Value = ParamId> {
    prop::sample::select(ParamId::ALL.to_vec())
}

fn request_body() -> impl Strategy<Value = RequestBody> {
    prop_oneof![
        (any::<u16>(), any::<u32>(), any::<bool>()).prop_map(|(p, s, t)| RequestBody::Hello {
            protocol_version: p,
            schema_id: s,
            takeover: t,
        }),
        Just(RequestBody::GetStatus),
        Just(RequestBody::Heartbeat),
        (any::<u16>(), vec(step(), 0..=MAX_PLAN_STEPS)).prop_map(|(plan_id, steps)| {
            RequestBody::UploadPlan(Plan {
                plan_id,
                steps: heapless::Vec::from_slice(&steps).unwrap(),
            })
        }),
        any::<u16>().prop_map(|plan_id| RequestBody::StartPlan { plan_id }),
        step().prop_map(RequestBody::RunStep),
        Just(RequestBody::Abort),
        Just(RequestBody::ConfirmManual),
        Just(RequestBody::ResetFaults),
        trunk_state().prop_map(RequestBody::DeclareState),
        param_id().prop_map(RequestBody::GetParam),
        (param_id(), f()).prop_map(|(id, value)| RequestBody::SetParam { id, value }),
        Just(RequestBody::Close),
        Just(RequestBody::Identify),
        (any::<[u8; 16]>(), any::<bool>())
            .prop_map(|(key, enabled)| RequestBody::SetSigning { key, enabled }),
    ]
}

pub fn request() -> impl Strategy<Value = Request> {
    (any::<u16>(), any::<u32>(), request_body()).prop_map(|(seq, session, body)| Request {
        seq,
        session,
        body,
    })
}

fn fault() -> impl Strategy<Value = FaultCode> {
    prop::sample::select(FaultCode::ALL.to_vec())
}

fn mode() -> impl Strategy<Value = Mode> {
    prop_oneof![
        Just(Mode::Standalone),
        Just(Mode::Running),
        Just(Mode::WaitingManual),
        Just(Mode::Safe),
        Just(Mode::EStop),
    ]
}

fn reject_reason() -> impl Strategy<Value = RejectReason> {
    prop::sample::select(vec![
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
    ])
}

fn result_code() -> impl Strategy<Value = ResultCode> {
    prop_oneof![
        Just(ResultCode::Ok),
        reject_reason().prop_map(ResultCode::Rejected),
        Just(ResultCode::Busy),
        Just(ResultCode::InProgress),
    ]
}

fn module() -> impl Strategy<Value = ModuleConfig> {
    (any::<u8>(), f(), f(), any::<u8>()).prop_map(|(n, beta_deg, edge_mm, layers)| ModuleConfig {
        n,
        beta_deg,
        edge_mm,
        layers,
    })
}

fn device_info() -> impl Strategy<Value = DeviceInfo> {
    (
        any::<u16>(),
        any::<u32>(),
        any::<[u8; 3]>(),
        prop_oneof![
            Just(Board::UnoR4Wifi),
            Just(Board::UnoR4Minima),
            Just(Board::Simulator)
        ],
        (module(), module(), f()),
        (any::<u32>(), reset_cause(), any::<bool>()),
    )
        .prop_map(
            |(
                protocol_version,
                schema_id,
                firmware_version,
                board,
                (bottom, top, p),
                (session, reset_cause, signing),
            )| DeviceInfo {
                protocol_version,
                schema_id,
                firmware_version,
                board,
                trunk: TrunkConfig {
                    bottom,
                    top,
                    pressure_limit_kpa: p,
                },
                session,
                reset_cause,
                signing,
            },
        )
}

fn reset_cause() -> impl Strategy<Value = ResetCause> {
    prop_oneof![
        Just(ResetCause::PowerOn),
        Just(ResetCause::Watchdog),
        Just(ResetCause::BrownOut),
        Just(ResetCause::Software),
        Just(ResetCause::Unknown),
    ]
}

fn transition() -> impl Strategy<Value = Transition> {
    (trunk_state(), trunk_state()).prop_map(|(from, to)| Transition { from, to })
}

fn plan_phase() -> impl Strategy<Value = PlanPhase> {
    prop_oneof![
        Just(PlanPhase::Ready),
        Just(PlanPhase::Running),
        Just(PlanPhase::WaitingManual),
        Just(PlanPhase::Done),
        fault().prop_map(PlanPhase::Failed),
        Just(PlanPhase::Aborted),
    ]
}

fn status() -> impl Strategy<Value = Status> {
    (
        (trunk_state(), any::<bool>(), mode(), f(), [f(), f(), f()]),
        any::<[bool; 4]>(),
        proptest::option::of(
            (any::<u16>(), any::<u8>(), any::<u8>(), plan_phase()).prop_map(
                |(plan_id, step, steps, phase)| PlanStatus {
                    plan_id,
                    step,
                    steps,
                    phase,
                },
            ),
        ),
        (any::<u16>(), any::<u32>(), any::<u32>(), any::<u32>()),
        (
            any::<u8>(),
            proptest::option::of(transition()),
            proptest::option::of(manual_task()),
        ),
    )
        .prop_map(
            |(
                (state, state_confirmed, mode, pressure_kpa, servo_deg),
                [inlet_open, exhaust_open, gripper_closed, estop],
                plan,
                (faults, frames_rx, frames_dropped, uptime_ms),
                (candidates, interrupted, manual_task),
            )| Status {
                state,
                state_confirmed,
                candidates: StateSet(candidates),
                interrupted,
                mode,
                pressure_kpa,
                servo_deg,
                inlet_open,
                exhaust_open,
                gripper_closed,
                estop,
                plan,
                manual_task,
                faults,
                frames_rx,
                frames_dropped,
                uptime_ms,
            },
        )
}

fn response_body() -> impl Strategy<Value = ResponseBody> {
    prop_oneof![
        Just(ResponseBody::None),
        device_info().prop_map(ResponseBody::Hello),
        status().prop_map(ResponseBody::Status),
        (param_id(), f()).prop_map(|(id, value)| ResponseBody::Param { id, value }),
        (proptest::option::of(any::<u8>()), param_id(), f(), f()).prop_map(
            |(step, id, value, limit)| ResponseBody::Refused(Refusal {
                step,
                field: RefusedField::Param(id),
                value,
                limit,
            })
        ),
    ]
}

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        (any::<u32>(), mode()).prop_map(|(uptime_ms, mode)| Event::Heartbeat { uptime_ms, mode }),
        (
            any::<u32>(),
            f(),
            [f(), f(), f()],
            any::<[bool; 3]>(),
            trunk_state()
        )
            .prop_map(|(uptime_ms, pressure_kpa, servo_deg, [i, e, c], state)| {
                Event::Telemetry(Telemetry {
                    uptime_ms,
                    pressure_kpa,
                    servo_deg,
                    inlet_open: i,
                    exhaust_open: e,
                    state,
                    state_confirmed: c,
                })
            }),
        (any::<u16>(), any::<u8>(), any::<u8>(), any::<u32>()).prop_map(
            |(plan_id, step, primitive, elapsed_ms)| Event::StepProgress {
                plan_id,
                step,
                primitive,
                elapsed_ms
            }
        ),
        (
            any::<u16>(),
            any::<u8>(),
            any::<bool>(),
            trunk_state(),
            any::<u32>()
        )
            .prop_map(|(plan_id, step, ok, state, duration_ms)| Event::StepDone {
                plan_id,
                step,
                ok,
                state,
                duration_ms
            }),
        (any::<u16>(), any::<bool>(), trunk_state())
            .prop_map(|(plan_id, ok, state)| Event::PlanDone { plan_id, ok, state }),
        (trunk_state(), any::<bool>())
            .prop_map(|(state, confirmed)| Event::StateReached { state, confirmed }),
        (any::<u16>(), any::<u8>(), manual_task()).prop_map(|(plan_id, step, task)| {
            Event::ManualRequired {
                plan_id,
                step,
                task,
            }
        }),
        fault().prop_map(Event::FaultRaised),
        fault().prop_map(Event::FaultCleared),
        any::<u8>().prop_map(|c| Event::IdentifyNeedsOperator {
            candidates: StateSet(c)
        }),
    ]
}

pub fn device_message() -> impl Strategy<Value = DeviceMessage> {
    prop_oneof![
        (any::<u16>(), result_code(), response_body())
            .prop_map(|(seq, result, body)| DeviceMessage::Response { seq, result, body }),
        event().prop_map(DeviceMessage::Event),
    ]
}

// ---- helpers --------------------------------------------------------------------------------

fn frame_of<T: serde::Serialize>(msg: &T) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(msg, &mut buf).expect("every message fits a frame");
    buf[..n].to_vec()
}

/// Splits `bytes` at the given cut points (taken modulo the length) and feeds the chunks.
fn feed_chunked<T: serde::de::DeserializeOwned>(
    dec: &mut FrameDecoder,
    bytes: &[u8],
    cuts: &[usize],
) -> Vec<Result<T, FrameError>> {
    let mut cuts: Vec<usize> = cuts.iter().map(|c| c % (bytes.len() + 1)).collect();
    cuts.push(0);
    cuts.push(bytes.len());
    cuts.sort_unstable();
    cuts.windows(2)
        .flat_map(|w| dec.feed::<T>(&bytes[w[0]..w[1]]).collect::<Vec<_>>())
        .collect()
}

fn check_frame_shape(frame: &[u8]) -> Result<(), TestCaseError> {
    prop_assert!(frame.len() <= MAX_FRAME_LEN);
    prop_assert_eq!(frame.last(), Some(&0));
    prop_assert!(frame[..frame.len() - 1].iter().all(|&b| b != 0));
    Ok(())
}

// ---- properties -----------------------------------------------------------------------------

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn any_request_round_trips(req in request()) {
        let mut frame = frame_of(&req);
        check_frame_shape(&frame)?;
        let mut dec = FrameDecoder::new();
        let got: Vec<_> = dec.feed::<Request>(&frame).collect();
        prop_assert_eq!(got, vec![Ok(req.clone())]);
        prop_assert_eq!(decode::<Request>(&mut frame), Ok(req));
    }

    #[test]
    fn any_device_message_round_trips(msg in device_message()) {
        let frame = frame_of(&msg);
        check_frame_shape(&frame)?;
        let mut dec = FrameDecoder::new();
        let got: Vec<_> = dec.feed::<DeviceMessage>(&frame).collect();
        prop_assert_eq!(got, vec![Ok(msg)]);
    }

    /// Any garbage, then one delimiter, then a valid frame: no panic, the frame decodes, and
    /// every delimiter-terminated non-empty segment is counted exactly once (ok or dropped).
    #[test]
    fn garbage_never_panics_and_the_next_frame_decodes(
        garbage in vec(any::<u8>(), 0..2_000),
        zero_heavy in vec(prop_oneof![Just(0u8), any::<u8>()], 0..200),
        req in request(),
    ) {
        let mut dec = FrameDecoder::new();
        let mut stream = garbage;
        stream.extend(zero_heavy);
        let segments = stream.split(|&b| b == 0).count() - 1; // terminated by a zero
        let nonempty_segments = stream
            .split(|&b| b == 0)
            .take(segments)
            .filter(|s| !s.is_empty())
            .count();
        let mut results = 0;
        for &b in &stream {
            if let Some(r) = dec.push::<Request>(b) {
                if r != Err(FrameError::Empty) {
                    results += 1;
                }
            }
        }
        prop_assert_eq!(results, nonempty_segments);
        let s = dec.stats();
        prop_assert_eq!((s.frames_ok + s.frames_dropped) as usize, nonempty_segments);

        // The sender's customary leading delimiter flushes any partial frame.
        let mut tail = vec![0u8];
        tail.extend(frame_of(&req));
        let got: Vec<_> = dec.feed::<Request>(&tail).collect();
        prop_assert_eq!(got.last(), Some(&Ok(req)));
    }

    /// The same garbage, as a device message decoder (the other payload type).
    #[test]
    fn garbage_never_panics_the_device_message_decoder(garbage in vec(any::<u8>(), 0..1_500)) {
        let mut dec = FrameDecoder::new();
        for &b in &garbage {
            let _ = dec.push::<DeviceMessage>(b);
        }
        let mut copy = garbage.clone();
        let _ = decode::<DeviceMessage>(&mut copy);
        let msg = DeviceMessage::Event(Event::FaultRaised(FaultCode::Leak));
        let mut tail = vec![0u8];
        tail.extend(frame_of(&msg));
        let got: Vec<_> = dec.feed::<DeviceMessage>(&tail).collect();
        prop_assert_eq!(got.last(), Some(&Ok(msg)));
    }

    /// Several frames back to back, cut into arbitrary chunks, come out whole and in order.
    #[test]
    fn chunking_does_not_matter(
        msgs in vec(device_message(), 1..6),
        cuts in vec(any::<usize>(), 0..40),
    ) {
        let stream: Vec<u8> = msgs.iter().flat_map(frame_of).collect();
        let mut dec = FrameDecoder::new();
        let got = feed_chunked::<DeviceMessage>(&mut dec, &stream, &cuts);
        let want: Vec<_> = msgs.into_iter().map(Ok).collect();
        prop_assert_eq!(got, want);
        prop_assert_eq!(dec.stats().frames_dropped, 0);
    }
}
