//! The host engine against the real firmware controller, in-process, on one clock (no physics: the
//! trunk stays put, which is enough for the protocol's half of the contract).

use firmware::{BootRecord, Controller, CraneConfig, Inputs};
use host::{Driver, Host, Io, SessionError, SessionEvent, Timing};
use protocol::{Mode, PlanPhase, RequestBody, ResultCode};

/// The controller as the engine's I/O, with a switch to lose frames.
struct Board {
    ctl: Controller,
    rest: Inputs,
    now_ms: u64,
    /// Drop the next response frames the controller sends.
    drop_next: u32,
    /// Drop everything from now on (a cut cable).
    cut: bool,
    pending: Vec<u8>,
}

impl Board {
    fn new() -> Self {
        let cfg = CraneConfig::default();
        Self {
            ctl: Controller::new(cfg, BootRecord::Empty, 0),
            rest: Inputs::at_rest(&cfg),
            now_ms: 0,
            drop_next: 0,
            cut: false,
            pending: Vec::new(),
        }
    }

    fn tick(&mut self) {
        self.now_ms += 1;
        self.ctl.handle_inputs(&self.rest, self.now_ms);
        self.ctl.handle_time(self.now_ms);
        let mut tmp = [0u8; 512];
        loop {
            let n = self.ctl.poll_tx(&mut tmp);
            if n == 0 {
                break;
            }
            self.pending.extend_from_slice(&tmp[..n]);
        }
        while self.drop_next > 0 || self.cut {
            let Some(end) = self.pending.iter().position(|&b| b == 0) else {
                break;
            };
            self.pending.drain(..=end);
            self.drop_next = self.drop_next.saturating_sub(1);
        }
    }
}

impl Io for Board {
    fn now_ms(&mut self) -> u64 {
        self.now_ms
    }
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        if !self.cut {
            self.ctl.handle_rx(bytes, self.now_ms);
        }
        Ok(())
    }
    fn read(&mut self, deadline_ms: u64, buf: &mut Vec<u8>) -> std::io::Result<()> {
        while self.pending.is_empty() && self.now_ms < deadline_ms {
            self.tick();
        }
        buf.append(&mut self.pending);
        Ok(())
    }
}

fn driver() -> Driver<Board> {
    Driver::new(Host::new(Timing::standard(), 1), Board::new())
}

#[test]
fn handshake_status_and_a_plan_start_against_the_real_controller() {
    let mut d = driver();
    let info = d.connect().unwrap();
    assert_eq!(
        (info.protocol_version, info.schema_id),
        (protocol::PROTOCOL_VERSION, protocol::SCHEMA_ID)
    );
    let status = d.status().unwrap();
    assert_eq!(status.state, geometry::TrunkState::AS_MANUFACTURED);
    assert_eq!(status.mode, Mode::Standalone);
    let plan = transition_graph::Graph::nominal()
        .plan(status.state, "F&F".parse().unwrap())
        .unwrap()
        .to_protocol(3)
        .unwrap();
    d.command(RequestBody::UploadPlan(plan)).unwrap();
    d.command(RequestBody::StartPlan { plan_id: 3 }).unwrap();
    let ps = d.status().unwrap().plan.unwrap();
    assert_eq!((ps.plan_id, ps.steps, ps.phase), (3, 1, PlanPhase::Running));
    d.command(RequestBody::Abort).unwrap();
    let status = d.status().unwrap();
    assert!(!status.inlet_open, "{status:?}");
    assert_eq!(status.plan.unwrap().phase, PlanPhase::Aborted);
}

#[test]
fn a_lost_response_is_retried_with_the_same_seq_and_executed_once() {
    let mut d = driver();
    d.connect().unwrap();
    let plan = transition_graph::Graph::nominal()
        .plan("F&P".parse().unwrap(), "F&F".parse().unwrap())
        .unwrap()
        .to_protocol(9)
        .unwrap();
    d.command(RequestBody::UploadPlan(plan)).unwrap();
    // The StartPlan response is lost: the retry (same seq) gets the cached answer, not a
    // second execution (which the controller would refuse as Busy: the plan runs).
    d.io.drop_next = 1;
    let t0 = d.io.now_ms;
    let reply = d.call(RequestBody::StartPlan { plan_id: 9 }).unwrap();
    assert!(
        matches!(reply.result, ResultCode::Ok | ResultCode::InProgress),
        "{reply:?}"
    );
    assert_eq!(d.host.session().stats().retries, 1);
    // One response timeout of the one timing, within a few ms of loop passes.
    let waited = d.io.now_ms - t0;
    let timeout = u64::from(protocol::RESPONSE_TIMEOUT_MS);
    assert!((timeout..timeout + 10).contains(&waited), "{waited} ms");
    d.command(RequestBody::Abort).unwrap();
}

#[test]
fn a_silent_device_is_a_lost_link_after_the_silence_limit() {
    let mut d = driver();
    d.connect().unwrap();
    d.io.cut = true;
    let t0 = d.io.now_ms;
    let err = d.status().unwrap_err();
    let SessionError::Timeout {
        request,
        attempts,
        waited_ms,
    } = err
    else {
        panic!("{err}")
    };
    assert_eq!(request, "GetStatus");
    // The device's heartbeats stopped too: silence, not attempts, ends it.
    let silence = u64::from(protocol::DEFAULT_LINK_TIMEOUT_MS);
    assert!(
        waited_ms >= silence - u64::from(protocol::RESPONSE_TIMEOUT_MS),
        "{waited_ms}"
    );
    assert!(d.io.now_ms - t0 <= silence + u64::from(protocol::RESPONSE_TIMEOUT_MS));
    assert!(attempts >= 2, "{attempts}");
    assert!(d.host.session().is_closed());
    // Every later request fails at once, without traffic.
    assert_eq!(d.status().unwrap_err(), SessionError::Closed);
}

#[test]
fn the_engine_keeps_the_link_alive_while_idle() {
    let mut d = driver();
    d.connect().unwrap();
    let plan = transition_graph::Graph::nominal()
        .plan("F&P".parse().unwrap(), "F&F".parse().unwrap())
        .unwrap()
        .to_protocol(4)
        .unwrap();
    d.command(RequestBody::UploadPlan(plan)).unwrap();
    d.command(RequestBody::StartPlan { plan_id: 4 }).unwrap();
    // 10 s with no request of the shell's own: the heartbeats keep the device's link watchdog
    // (3 s) from aborting the plan.
    d.idle(10_000).unwrap();
    let ps = d.status().unwrap().plan.unwrap();
    assert_ne!(ps.phase, PlanPhase::Aborted, "{ps:?}");
    assert!(d.io.ctl.status().faults & protocol::FaultCode::LinkLoss.bit() == 0);
}

#[test]
fn an_abort_goes_ahead_of_queued_requests() {
    let mut d = driver();
    d.connect().unwrap();
    let now = d.io.now_ms;
    let a = d.host.request(RequestBody::GetStatus, now);
    let b = d.host.request(RequestBody::GetStatus, now);
    let abort = d.host.request_first(RequestBody::Abort, now);
    let mut order = Vec::new();
    while order.len() < 3 {
        while let Some(ev) = d.host.poll_event() {
            match ev {
                host::HostEvent::Session(SessionEvent::Reply { id, .. }) => order.push(id),
                host::HostEvent::Session(SessionEvent::Failed { id, .. }) => order.push(id),
                _ => {}
            }
        }
        d.turn().unwrap();
    }
    // The first status was already on the wire and is abandoned; the abort comes next.
    assert_eq!(order, vec![a, abort, b]);
}
