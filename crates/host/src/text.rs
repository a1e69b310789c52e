//! Human text for the wire's enums: the one place where a fault, a refusal, a mode or a request
//! gets its words (the protocol crate carries no strings beyond each fault's short description).

pub use planner::graph::{kind_name, manual_task_text as manual_task, PrimitiveText};
use protocol::{Board, FaultCode, Mode, PlanPhase, RejectReason, RequestBody};

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
            "another host is connected to the crane (it holds the session); take over explicitly"
        }
        RejectReason::Unconfirmed => {
            "the trunk state is unconfirmed: identify or declare it before running steps"
        }
    }
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
}
