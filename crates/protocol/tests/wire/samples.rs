//! Sample messages shared by the tests and the bench (`benches/frame.rs` includes this file).
#![allow(dead_code)] // each includer uses a different subset

use protocol::*;

/// A trunk state from its name.
pub fn st(name: &str) -> geometry::TrunkState {
    name.parse().expect("valid state name")
}

/// The largest request on the wire: a full plan (MAX_PLAN_STEPS × MAX_STEP_PRIMITIVES) of the
/// widest primitive (`Bend`: two f32), with every varint at its longest, and no zero byte in
/// the payload (states `D&F` = `01 01`, floats without a zero byte) so COBS needs its
/// worst-case overhead: this is the longest frame any message can make.
pub fn largest_request() -> Request {
    let prim = Primitive::Bend {
        direction_deg: 359.7, // 9a d9 b3 43
        angle_deg: 89.7,      // 66 66 b3 42
    };
    let step = Step {
        kind: StepKind::Tendon,
        from: st("D&F"),
        to: st("D&F"),
        primitives: heapless::Vec::from_slice(&[prim; MAX_STEP_PRIMITIVES]).expect("fits"),
        timeout_ms: u32::MAX,
    };
    let steps: heapless::Vec<Step, MAX_PLAN_STEPS> =
        core::iter::repeat_n(step, MAX_PLAN_STEPS).collect();
    Request {
        seq: u16::MAX,
        session: u32::MAX,
        body: RequestBody::UploadPlan(Plan {
            plan_id: u16::MAX,
            steps,
        }),
    }
}

/// A status response with every varint at its longest and a plan present.
pub fn status_response() -> DeviceMessage {
    DeviceMessage::Response {
        seq: u16::MAX,
        result: ResultCode::Ok,
        body: ResponseBody::Status(Status {
            state: st("D&F"),
            state_confirmed: false,
            candidates: StateSet::ALL,
            interrupted: Some(Transition {
                from: st("D&D"),
                to: st("D&F"),
            }),
            mode: Mode::Running,
            pressure_kpa: 23.75,
            servo_deg: [90.0, 91.5, 88.25],
            inlet_open: true,
            exhaust_open: false,
            gripper_closed: true,
            estop: false,
            plan: Some(PlanStatus {
                plan_id: u16::MAX,
                step: 7,
                steps: 8,
                phase: PlanPhase::Failed(FaultCode::StateStorage),
            }),
            manual_task: Some(ManualTask::FoldBottomModule),
            faults: u16::MAX,
            frames_rx: u32::MAX,
            frames_dropped: u32::MAX,
            uptime_ms: u32::MAX,
        }),
    }
}

/// The smallest request.
pub fn get_status() -> Request {
    Request {
        seq: 1,
        session: 1,
        body: RequestBody::GetStatus,
    }
}
