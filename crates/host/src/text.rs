//! Human text for the wire's enums: the one place where a fault, a refusal, a mode or a request
//! gets its words (the protocol crate carries no strings beyond each fault's short description).

use protocol::{
    Board, DeviceMessage, Event, FaultCode, Mode, ParamId, PlanPhase, Refusal, RefusedField,
    RejectReason, Request, RequestBody, ResponseBody, ResultCode, StateSet, Status, Step,
};
pub use transition_graph::{kind_name, manual_task_text as manual_task, PrimitiveText};

/// The fault's display code, `E-04`.
pub fn fault_code(fault: FaultCode) -> String {
    format!("E-{:02}", fault.code())
}

/// The fault's stable machine name, `transition-not-confirmed` (for JSON and tests).
pub const fn fault_name(fault: FaultCode) -> &'static str {
    match fault {
        FaultCode::OverPressure => "over-pressure",
        FaultCode::PressureSensor => "pressure-sensor",
        FaultCode::StepTimeout => "step-timeout",
        FaultCode::TransitionNotConfirmed => "transition-not-confirmed",
        FaultCode::LinkLoss => "link-loss",
        FaultCode::EStop => "e-stop",
        FaultCode::ServoLimit => "servo-limit",
        FaultCode::Leak => "leak",
        FaultCode::Watchdog => "watchdog",
        FaultCode::StateStorage => "state-storage",
        FaultCode::InletStuck => "inlet-stuck",
        FaultCode::NoPressureRise => "no-pressure-rise",
    }
}

/// `E-04 transition not confirmed by the sensors`.
pub fn fault(fault: FaultCode) -> String {
    format!("{} {}", fault_code(fault), fault.description())
}

/// The faults of a status bit set, `E-xx description, …` (`none` when empty).
pub fn fault_list(bits: u16) -> String {
    let names: Vec<String> = faults_in(bits).map(fault).collect();
    if names.is_empty() {
        "none".to_string()
    } else {
        names.join(", ")
    }
}

/// The faults of a status bit set.
pub fn faults_in(bits: u16) -> impl Iterator<Item = FaultCode> {
    FaultCode::ALL
        .into_iter()
        .filter(move |f| bits & f.bit() != 0)
}

/// A person's reading of a refusal.
pub const fn reject(reason: RejectReason) -> &'static str {
    match reason {
        RejectReason::VersionMismatch => "protocol version or schema id differ",
        RejectReason::NoHandshake => "no handshake yet on this link",
        RejectReason::EStopLatched => "the e-stop is latched (release it, then reset faults)",
        RejectReason::Faulted => "a fault is active (reset it first)",
        RejectReason::InvalidPlan => "the plan is empty, too long, or its steps do not chain",
        RejectReason::UnknownPlan => "no uploaded plan has this id",
        RejectReason::WrongState => "the step does not start from the device's current state",
        RejectReason::OutOfRange => "a value is out of range",
        RejectReason::NoManualPending => "no manual step is waiting for confirmation",
        RejectReason::NotAllowed => "not allowed now",
        RejectReason::NotSessionOwner => {
            "another host's session holds the crane (or it restarted): handshake again"
        }
        RejectReason::SessionBusy => {
            "another host is connected to the crane (it holds the session); take over explicitly \
             (host-tool: --take-over)"
        }
        RejectReason::Unconfirmed => {
            "the trunk state is unconfirmed: identify or declare it before running steps"
        }
        RejectReason::Unsigned => {
            "link signing is on and the request is not validly signed (no key given, or a \
             replayed counter): give the crane's key (host-tool: --link-key FILE or \
             $CRANE_LINK_KEY)"
        }
    }
}

/// A parameter's command-line name (kebab-case).
pub const fn param_name(id: ParamId) -> &'static str {
    match id {
        ParamId::PressureLimitKpa => "pressure-limit-kpa",
        ParamId::ServoMinDeg => "servo-min-deg",
        ParamId::ServoMaxDeg => "servo-max-deg",
        ParamId::ServoSlewDegPerS => "servo-slew-deg-per-s",
        ParamId::TelemetryHz => "telemetry-hz",
        ParamId::LinkTimeoutMs => "link-timeout-ms",
    }
}

/// A parameter's unit, for people.
pub const fn param_unit(id: ParamId) -> &'static str {
    match id {
        ParamId::PressureLimitKpa => "kPa",
        ParamId::ServoMinDeg | ParamId::ServoMaxDeg => "deg",
        ParamId::ServoSlewDegPerS => "deg/s",
        ParamId::TelemetryHz => "Hz",
        ParamId::LinkTimeoutMs => "ms",
    }
}

/// What a probe profile's rate `i` ([`protocol::ProbeProfile::rate`]) is the signature of:
/// a state's name, or `F&P½`/`D&P½` (half-packed under the folded or the deployed top).
pub fn probe_rate_name(i: u8) -> String {
    match i {
        0..=5 => geometry::TrunkState::ALL[i as usize].to_string(),
        6 => "F&P½".into(),
        7 => "D&P½".into(),
        _ => format!("#{i}"),
    }
}

/// The stable machine name of a refused field (for JSON).
pub const fn refused_field_name(field: RefusedField) -> &'static str {
    match field {
        RefusedField::Pressure => "pressure",
        RefusedField::TendonLength => "tendon-length",
        RefusedField::BendAngle => "bend-angle",
        RefusedField::Duration => "duration",
        RefusedField::Param(id) => param_name(id),
        RefusedField::Steps => "steps",
        RefusedField::ProbeRate(_) => "probe-rate",
    }
}

/// A refusal in words: the reason, and when the device named it, the field, what the request
/// needs, the limit and how to change it — "it needs 16 kPa, above the pressure limit of
/// 10 kPa; raise the limit with `host-tool param set pressure-limit-kpa 16`" (the step is named
/// by whoever knows the plan: [`crate::runner`]).
pub fn refusal(reason: RejectReason, detail: Option<&Refusal>) -> String {
    let Some(r) = detail else {
        return reject(reason).to_string();
    };
    let (v, lim) = (r.value, r.limit);
    let what = match r.field {
        RefusedField::Pressure => format!(
            "it needs {v} kPa, above the pressure limit of {lim} kPa; raise the limit with \
             `host-tool param set pressure-limit-kpa {v}` (at most {}) if the trunk is rated \
             for it",
            protocol::HARD_MAX_PRESSURE_KPA
        ),
        RefusedField::TendonLength => format!(
            "it needs a tendon length of {v} mm, beyond the tendons' reach of {lim} mm (their \
             travel within servo-min-deg and servo-max-deg: `host-tool param get` shows them)"
        ),
        RefusedField::BendAngle => format!(
            "it bends {v}°, more than the {lim}° that fit from its state (the tendons' travel \
             and the stiffness of the state); bend less or from a more deployed state"
        ),
        RefusedField::Duration => {
            format!("its time of {v} ms is outside 1 to {lim} ms; the planner's cost model sets it")
        }
        RefusedField::ProbeRate(i) => {
            let (lo, hi) = protocol::PROBE_RATE_RANGE;
            format!(
                "its {} fill rate of {v} kPa/s is outside {lo} to {hi} kPa/s (limit {lim})",
                probe_rate_name(i)
            )
        }
        RefusedField::Param(id) => {
            let (lo, hi) = id.range();
            let unit = param_unit(id);
            let name = param_name(id);
            match id {
                ParamId::ServoMinDeg if (lo..=hi).contains(&v) => format!(
                    "{name} {v} {unit} would pass servo-max-deg = {lim} {unit}; raise \
                     servo-max-deg first"
                ),
                ParamId::ServoMaxDeg if (lo..=hi).contains(&v) => format!(
                    "{name} {v} {unit} would pass servo-min-deg = {lim} {unit}; lower \
                     servo-min-deg first"
                ),
                _ => format!(
                    "{name} {v} {unit} is outside its range {lo} to {hi} {unit}{}",
                    if id.is_integer() {
                        " (whole numbers)"
                    } else {
                        ""
                    }
                ),
            }
        }
        RefusedField::Steps => format!(
            "the plan is empty, does not chain on here, or has more than {lim} steps ({v} given)"
        ),
    };
    format!("{}: {what}", reject(reason))
}

/// The stable machine name of a refusal (for JSON).
pub const fn reject_name(reason: RejectReason) -> &'static str {
    match reason {
        RejectReason::VersionMismatch => "version-mismatch",
        RejectReason::NoHandshake => "no-handshake",
        RejectReason::EStopLatched => "e-stop-latched",
        RejectReason::Faulted => "faulted",
        RejectReason::InvalidPlan => "invalid-plan",
        RejectReason::UnknownPlan => "unknown-plan",
        RejectReason::WrongState => "wrong-state",
        RejectReason::OutOfRange => "out-of-range",
        RejectReason::NoManualPending => "no-manual-pending",
        RejectReason::NotAllowed => "not-allowed",
        RejectReason::NotSessionOwner => "not-session-owner",
        RejectReason::SessionBusy => "session-busy",
        RejectReason::Unconfirmed => "unconfirmed",
        RejectReason::Unsigned => "unsigned",
    }
}

/// A request's name for messages.
pub const fn request_name(body: &RequestBody) -> &'static str {
    match body {
        RequestBody::Hello { .. } => "Hello",
        RequestBody::GetStatus => "GetStatus",
        RequestBody::Heartbeat => "Heartbeat",
        RequestBody::UploadPlan(_) => "UploadPlan",
        RequestBody::StartPlan { .. } => "StartPlan",
        RequestBody::RunStep(_) => "RunStep",
        RequestBody::Abort => "Abort",
        RequestBody::ConfirmManual => "ConfirmManual",
        RequestBody::ResetFaults => "ResetFaults",
        RequestBody::DeclareState(_) => "DeclareState",
        RequestBody::GetParam(_) => "GetParam",
        RequestBody::SetParam { .. } => "SetParam",
        RequestBody::Close => "Close",
        RequestBody::Identify => "Identify",
        RequestBody::SetSigning { .. } => "SetSigning",
        RequestBody::SetProbeProfile { .. } => "SetProbeProfile",
        RequestBody::GetProbeProfile => "GetProbeProfile",
    }
}

/// An event's name for messages.
pub const fn event_name(event: &Event) -> &'static str {
    match event {
        Event::Heartbeat { .. } => "Heartbeat",
        Event::Telemetry(_) => "Telemetry",
        Event::StepProgress { .. } => "StepProgress",
        Event::StepDone { .. } => "StepDone",
        Event::PlanDone { .. } => "PlanDone",
        Event::StateReached { .. } => "StateReached",
        Event::ManualRequired { .. } => "ManualRequired",
        Event::FaultRaised(_) => "FaultRaised",
        Event::FaultCleared(_) => "FaultCleared",
        Event::IdentifyNeedsOperator { .. } => "IdentifyNeedsOperator",
    }
}

/// A result code's name: `ok`, `in-progress`, `busy`, `rejected: out-of-range`.
pub fn result(result: ResultCode) -> String {
    match result {
        ResultCode::Ok => "ok".into(),
        ResultCode::InProgress => "in-progress".into(),
        ResultCode::Busy => "busy".into(),
        ResultCode::Rejected(r) => format!("rejected: {}", reject_name(r)),
    }
}

fn seconds(ms: u32) -> String {
    format!("{:.3} s", f64::from(ms) / 1000.0)
}

fn confirmed(state: geometry::TrunkState, confirmed: bool) -> String {
    if confirmed {
        format!("{state} confirmed")
    } else {
        format!("{state} unconfirmed")
    }
}

fn states(set: StateSet) -> String {
    let names: Vec<&str> = set.iter().map(|s| s.name()).collect();
    names.join(" ")
}

/// What an unconfirmed report says of the trunk: `the trunk may be F&P, F&F or D&F`, or (all six
/// states) `the trunk's state is unknown`.
pub fn may_be(set: StateSet) -> String {
    let names: Vec<&str> = set.iter().map(|s| s.name()).collect();
    match names.split_last() {
        Some((last, init)) if set != StateSet::ALL => match init {
            [] => format!("the trunk may be {last}"),
            _ => format!("the trunk may be {} or {last}", init.join(", ")),
        },
        _ => "the trunk's state is unknown".to_string(),
    }
}

fn step_text(s: &Step) -> String {
    format!("{} → {} {}", s.from, s.to, kind_name(s.kind))
}

/// A request as one line for the debug trace (`-v`): `#12 GetStatus`,
/// `#5 UploadPlan{plan 1: F&P → F&F pneumatic, F&F → D&F pneumatic}`,
/// `#7 SetParam{telemetry-hz = 50 Hz}`.
pub fn request_line(req: &Request) -> String {
    let name = request_name(&req.body);
    let detail = match &req.body {
        RequestBody::Hello {
            protocol_version,
            schema_id,
            takeover,
        } => format!(
            "protocol {protocol_version}, schema {schema_id:#010x}{}",
            if *takeover { ", takeover" } else { "" }
        ),
        RequestBody::UploadPlan(plan) => {
            let steps: Vec<String> = plan.steps.iter().map(step_text).collect();
            format!("plan {}: {}", plan.plan_id, steps.join(", "))
        }
        RequestBody::StartPlan { plan_id } => format!("plan {plan_id}"),
        RequestBody::RunStep(step) => step_text(step),
        RequestBody::DeclareState(state) => state.to_string(),
        RequestBody::GetParam(id) => param_name(*id).to_string(),
        RequestBody::SetParam { id, value } => {
            format!("{} = {value} {}", param_name(*id), param_unit(*id))
        }
        // Never the key.
        RequestBody::SetSigning { enabled, .. } => if *enabled { "on" } else { "off" }.to_string(),
        RequestBody::SetProbeProfile { profile, .. } => match profile {
            Some(p) => probe_profile_text(p),
            None => "erase".to_string(),
        },
        RequestBody::GetStatus
        | RequestBody::Heartbeat
        | RequestBody::Abort
        | RequestBody::ConfirmManual
        | RequestBody::ResetFaults
        | RequestBody::Close
        | RequestBody::GetProbeProfile
        | RequestBody::Identify => String::new(),
    };
    if detail.is_empty() {
        format!("#{} {name}", req.seq)
    } else {
        format!("#{} {name}{{{detail}}}", req.seq)
    }
}

fn status_text(s: &Status) -> String {
    let mut t = format!(
        "{}, {}, {:.1} kPa, servos {:.0}/{:.0}/{:.0}°",
        confirmed(s.state, s.state_confirmed),
        mode(s.mode),
        s.pressure_kpa,
        s.servo_deg[0],
        s.servo_deg[1],
        s.servo_deg[2]
    );
    if !s.state_confirmed {
        if let (Mode::Running | Mode::WaitingManual, Some(step)) = (s.mode, s.interrupted) {
            t += &format!(", moving {} → {}", step.from, step.to);
        }
        t += &format!(", may be {}", states(s.candidates));
    }
    if let Some(p) = &s.plan {
        t += &format!(
            ", plan {} step {}/{} {}",
            p.plan_id,
            u16::from(p.step) + 1,
            p.steps,
            phase(p.phase)
        );
    }
    if s.faults != 0 {
        let codes: Vec<String> = faults_in(s.faults).map(fault_code).collect();
        t += &format!(", faults {}", codes.join(" "));
    }
    t + &format!(", uptime {}", seconds(s.uptime_ms))
}

/// A message from the device as one line for the debug trace (`-v`):
/// `#12 ok Status{F&P confirmed, standalone, 0.0 kPa, …}`,
/// `#5 rejected: out-of-range Refused{step 1, pressure 16 (limit 10)}`,
/// `event StepDone{plan 1 step 1, ok, F&F, 5.200 s}`.
pub fn message_line(msg: &DeviceMessage) -> String {
    match msg {
        DeviceMessage::Response {
            seq,
            result: r,
            body,
        } => {
            let body = match body {
                ResponseBody::None => String::new(),
                ResponseBody::Hello(i) => format!(
                    " Hello{{protocol {}, schema {:#010x}, firmware {}.{}.{}, {}, session {}}}",
                    i.protocol_version,
                    i.schema_id,
                    i.firmware_version[0],
                    i.firmware_version[1],
                    i.firmware_version[2],
                    board(i.board),
                    i.session
                ),
                ResponseBody::Status(s) => format!(" Status{{{}}}", status_text(s)),
                ResponseBody::Param { id, value } => format!(
                    " Param{{{} = {value} {}}}",
                    param_name(*id),
                    param_unit(*id)
                ),
                ResponseBody::Refused(f) => format!(
                    " Refused{{{}{} {} (limit {})}}",
                    f.step
                        .map_or(String::new(), |s| format!("step {}, ", u16::from(s) + 1)),
                    refused_field_name(f.field),
                    f.value,
                    f.limit
                ),
                ResponseBody::ProbeProfile(p) => format!(
                    " ProbeProfile{{{}}}",
                    p.as_ref().map_or("none".to_string(), probe_profile_text)
                ),
            };
            format!("#{seq} {}{body}", result(*r))
        }
        DeviceMessage::Event(e) => {
            let detail = match e {
                Event::Heartbeat { uptime_ms, mode: m } => {
                    format!("{}, {}", seconds(*uptime_ms), mode(*m))
                }
                Event::Telemetry(t) => format!(
                    "{}, {:.1} kPa, servos {:.0}/{:.0}/{:.0}°, inlet {}, exhaust {}, {}",
                    seconds(t.uptime_ms),
                    t.pressure_kpa,
                    t.servo_deg[0],
                    t.servo_deg[1],
                    t.servo_deg[2],
                    if t.inlet_open { "open" } else { "closed" },
                    if t.exhaust_open { "open" } else { "closed" },
                    confirmed(t.state, t.state_confirmed)
                ),
                Event::StepProgress {
                    plan_id,
                    step,
                    primitive,
                    elapsed_ms,
                } => format!(
                    "plan {plan_id} step {} primitive {}, {}",
                    u16::from(*step) + 1,
                    u16::from(*primitive) + 1,
                    seconds(*elapsed_ms)
                ),
                Event::StepDone {
                    plan_id,
                    step,
                    ok,
                    state,
                    duration_ms,
                } => format!(
                    "plan {plan_id} step {}, {}, {state}, {}",
                    u16::from(*step) + 1,
                    if *ok { "ok" } else { "not confirmed" },
                    seconds(*duration_ms)
                ),
                Event::PlanDone { plan_id, ok, state } => format!(
                    "plan {plan_id}, {}, {state}",
                    if *ok { "ok" } else { "not ok" }
                ),
                Event::StateReached {
                    state,
                    confirmed: c,
                } => confirmed(*state, *c),
                Event::ManualRequired {
                    plan_id,
                    step,
                    task,
                } => format!(
                    "plan {plan_id} step {}: {}",
                    u16::from(*step) + 1,
                    manual_task(*task)
                ),
                Event::FaultRaised(f) | Event::FaultCleared(f) => fault(*f),
                Event::IdentifyNeedsOperator { candidates } => states(*candidates),
            };
            format!("event {}{{{detail}}}", event_name(e))
        }
    }
}

/// A mode's name.
pub const fn mode(mode: Mode) -> &'static str {
    match mode {
        Mode::Standalone => "standalone",
        Mode::Running => "running",
        Mode::WaitingManual => "waiting-manual",
        Mode::Safe => "safe",
        Mode::EStop => "e-stop",
    }
}

/// A plan phase's name.
pub fn phase(phase: PlanPhase) -> String {
    match phase {
        PlanPhase::Ready => "ready".into(),
        PlanPhase::Running => "running".into(),
        PlanPhase::WaitingManual => "waiting-manual".into(),
        PlanPhase::Done => "done".into(),
        PlanPhase::Failed(f) => format!("failed: {}", fault(f)),
        PlanPhase::Aborted => "aborted".into(),
    }
}

/// A board's name for people.
pub const fn board(board: Board) -> &'static str {
    match board {
        Board::UnoR4Wifi => "Arduino UNO R4 WiFi",
        Board::UnoR4Minima => "Arduino UNO R4 Minima",
        Board::Simulator => "hil-sim simulator",
    }
}

/// A failed handshake, naming both sides' versions and what to do.
pub fn version_mismatch(m: &protocol::VersionMismatch) -> String {
    format!(
        "protocol mismatch: this host speaks protocol version {} (schema id {:#010x}), the \
         device speaks protocol version {} (schema id {:#010x}); update the firmware or the \
         host-tool so they match",
        m.local_protocol_version, m.local_schema_id, m.peer_protocol_version, m.peer_schema_id
    )
}

/// An event in words, for people (monitor's lines, the recording's `/events`): its kind
/// (`step-done`, `fault-raised`, …) and a line (`plan 1 step 2 done in 5200 ms, now F&F`;
/// `None` for heartbeats, telemetry and step progress, which say nothing a person reads).
pub fn event(ev: &Event) -> (&'static str, Option<String>) {
    match ev {
        Event::Heartbeat { .. } => ("heartbeat", None),
        Event::Telemetry(_) => ("telemetry", None),
        Event::StepProgress { .. } => ("step-progress", None),
        Event::StepDone {
            plan_id,
            step,
            ok,
            state,
            duration_ms,
        } => (
            "step-done",
            Some(format!(
                "plan {plan_id} step {} {} in {duration_ms} ms, now {state}",
                step + 1,
                if *ok { "done" } else { "FAILED" }
            )),
        ),
        Event::PlanDone { plan_id, ok, state } => (
            "plan-done",
            Some(format!(
                "plan {plan_id} {} at {state}",
                if *ok { "done" } else { "FAILED" }
            )),
        ),
        Event::StateReached { state, confirmed } => (
            "state-reached",
            Some(format!(
                "state {state}{}",
                if *confirmed { "" } else { " (unconfirmed)" }
            )),
        ),
        Event::ManualRequired { step, task, .. } => (
            "manual-required",
            Some(format!(
                "manual step {} required: {}",
                step + 1,
                manual_task(*task)
            )),
        ),
        Event::FaultRaised(f) => ("fault-raised", Some(format!("FAULT {}", fault(*f)))),
        Event::FaultCleared(f) => (
            "fault-cleared",
            Some(format!("fault cleared: {}", fault(*f))),
        ),
        Event::IdentifyNeedsOperator { candidates } => (
            "identify-needs-operator",
            Some(format!(
                "identification needs the operator: one of {}",
                candidates
                    .iter()
                    .map(|s| s.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        ),
    }
}

/// A probe profile's rates in words: `F&P 11.71, …, D&P½ 13.20 kPa/s`.
pub fn probe_profile_text(p: &protocol::ProbeProfile) -> String {
    let rates: Vec<String> = (0..8u8)
        .map(|i| format!("{} {:.2}", probe_rate_name(i), p.rate(usize::from(i))))
        .collect();
    format!("{} kPa/s", rates.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_fault_has_a_distinct_name_and_its_display_code() {
        let names: std::collections::BTreeSet<_> =
            FaultCode::ALL.iter().map(|f| fault_name(*f)).collect();
        assert_eq!(names.len(), FaultCode::ALL.len());
        assert_eq!(fault_code(FaultCode::TransitionNotConfirmed), "E-04");
        assert_eq!(fault_code(FaultCode::NoPressureRise), "E-12");
        assert_eq!(
            fault_list(FaultCode::Leak.bit() | FaultCode::EStop.bit()),
            format!(
                "E-06 {}, E-08 {}",
                FaultCode::EStop.description(),
                FaultCode::Leak.description()
            )
        );
        assert_eq!(fault_list(0), "none");
    }

    #[test]
    fn frames_read_as_one_line_each_with_their_names_and_key_fields() {
        use geometry::TrunkState;
        let st = |s: &str| s.parse::<TrunkState>().unwrap();
        let req = |seq, body| {
            request_line(&Request {
                seq,
                session: 7,
                body,
            })
        };
        assert_eq!(req(12, RequestBody::GetStatus), "#12 GetStatus");
        assert_eq!(
            req(
                3,
                RequestBody::SetParam {
                    id: ParamId::TelemetryHz,
                    value: 50.0
                }
            ),
            "#3 SetParam{telemetry-hz = 50 Hz}"
        );
        let edge = protocol::transitions::transition(st("F&P"), st("F&F"))
            .unwrap()
            .step();
        let mut plan = protocol::Plan {
            plan_id: 1,
            steps: heapless::Vec::new(),
        };
        plan.steps.push(edge).unwrap();
        assert_eq!(
            req(4, RequestBody::UploadPlan(plan)),
            "#4 UploadPlan{plan 1: F&P → F&F pneumatic}"
        );
        assert_eq!(
            message_line(&DeviceMessage::Response {
                seq: 5,
                result: ResultCode::Rejected(RejectReason::OutOfRange),
                body: ResponseBody::Refused(Refusal {
                    step: Some(0),
                    field: RefusedField::Pressure,
                    value: 16.0,
                    limit: 10.0,
                }),
            }),
            "#5 rejected: out-of-range Refused{step 1, pressure 16 (limit 10)}"
        );
        assert_eq!(
            message_line(&DeviceMessage::Event(Event::StepDone {
                plan_id: 1,
                step: 0,
                ok: true,
                state: st("F&F"),
                duration_ms: 5_200,
            })),
            "event StepDone{plan 1 step 1, ok, F&F, 5.200 s}"
        );
        assert_eq!(
            message_line(&DeviceMessage::Event(Event::FaultRaised(FaultCode::Leak))),
            format!("event FaultRaised{{{}}}", fault(FaultCode::Leak))
        );
    }
}
