//! The host side of the protocol: handshake, sequence numbers, timeouts and retries.
//!
//! Every request gets a fresh sequence number and waits for the response echoing it. When none
//! comes in time the *same* request with the *same* sequence number is sent again: the device
//! executes a request once and answers a repeat from its cache, so a retry after a lost
//! response never runs an action twice. Responses to other sequence numbers (late answers to
//! an earlier attempt) are ignored; events are queued for the caller, who treats them as hints
//! (a frame may be lost) and the status as the truth.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::time::{Duration, Instant};

use protocol::{
    DeviceInfo, DeviceMessage, Event, RejectReason, Request, RequestBody, ResponseBody, ResultCode,
    Status, PROTOCOL_VERSION, SCHEMA_ID,
};

use crate::link::{Link, LinkStats};

/// How long to wait and how often to try.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// Wait for a response this long before sending the request again.
    pub request_timeout: Duration,
    /// Attempts per request (the first send included) before the link counts as lost.
    pub attempts: u32,
    /// While a plan runs, poll the status (which also keeps the device's link watchdog fed)
    /// this often.
    pub poll_period: Duration,
}

impl Timing {
    /// Timing for real hardware over USB serial: the device's loop answers within a few ms;
    /// polling at 100 ms keeps well inside its 250 ms heartbeat expectation.
    pub fn hardware() -> Self {
        Self {
            request_timeout: Duration::from_millis(250),
            attempts: 8,
            poll_period: Duration::from_millis(100),
        }
    }

    /// Timing for the simulator running `speed` times faster than wall time: the device's
    /// heartbeat expectation ([`protocol::HOST_HEARTBEAT_PERIOD_MS`] of device time) shrinks by
    /// `speed`, and so must the poll period (at most 50 ms: the simulator's link watchdog).
    pub fn simulator(speed: f64) -> Self {
        let speed = if speed.is_finite() && speed > 0.0 {
            speed
        } else {
            1.0
        };
        let heartbeat_ms = f64::from(protocol::HOST_HEARTBEAT_PERIOD_MS) / speed;
        let poll_ms = heartbeat_ms.clamp(5.0, 50.0);
        Self {
            request_timeout: Duration::from_millis(30),
            // 2 s of wall time before giving up: many device seconds at speed > 1, and a
            // corrupted frame under line noise costs one timeout.
            attempts: 65,
            poll_period: Duration::from_secs_f64(poll_ms / 1000.0),
        }
    }
}

/// Why a request did not get a usable answer.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// No response after every attempt: the link is down or the device is not answering.
    #[error(
        "no response to {request} after {attempts} attempts ({timeout_ms} ms each): \
         the device does not answer (link lost?)"
    )]
    Timeout {
        /// Which request.
        request: &'static str,
        /// How many times it was sent.
        attempts: u32,
        /// How long each attempt waited.
        timeout_ms: u64,
    },
    /// The transport failed.
    #[error("serial I/O failed: {0}")]
    Io(#[from] std::io::Error),
    /// Host and device speak different protocols.
    #[error(
        "protocol mismatch: this host-tool speaks protocol version {host_version} \
         (schema id {host_schema:#010x}), the device speaks protocol version {device_version} \
         (schema id {device_schema:#010x}); update the firmware or the host-tool so they match"
    )]
    VersionMismatch {
        /// [`PROTOCOL_VERSION`].
        host_version: u16,
        /// [`SCHEMA_ID`].
        host_schema: u32,
        /// The device's protocol version.
        device_version: u16,
        /// The device's schema id.
        device_schema: u32,
    },
    /// The device refused the request.
    #[error("the device refused {request}: {}", reject_text(*.reason))]
    Rejected {
        /// Which request.
        request: &'static str,
        /// Why.
        reason: RejectReason,
    },
    /// The device is busy (e.g. a plan runs).
    #[error("the device is busy and refused {request} (a plan is running?)")]
    Busy {
        /// Which request.
        request: &'static str,
    },
    /// The device answered with something that does not fit the request.
    #[error("unexpected answer to {request}: {got}")]
    Unexpected {
        /// Which request.
        request: &'static str,
        /// What came.
        got: String,
    },
}

/// A person's reading of a reject reason.
pub fn reject_text(reason: RejectReason) -> &'static str {
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

/// The device's answer to one request.
#[derive(Debug, Clone, PartialEq)]
pub struct Reply {
    /// Outcome.
    pub result: ResultCode,
    /// Data.
    pub body: ResponseBody,
}

/// Counters of the session (for reports and benchmarks).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SessionStats {
    /// Requests made (retries not counted).
    pub requests: u64,
    /// Requests sent again after a timeout.
    pub retries: u64,
    /// Responses ignored because they answered another sequence number.
    pub stale_responses: u64,
}

/// A conversation with one device. Dropping it ends the device's session (a `Close` sent
/// without waiting), so the next host can shake hands at once.
pub struct Session<T: Read + Write> {
    link: Link<T>,
    timing: Timing,
    next_seq: u16,
    /// The session the handshake opened (0 before it), sent in every request.
    session: u32,
    events: VecDeque<Event>,
    stats: SessionStats,
}

/// The name of a request for messages.
pub fn request_name(body: &RequestBody) -> &'static str {
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

impl<T: Read + Write> Drop for Session<T> {
    fn drop(&mut self) {
        if self.session == 0 {
            return;
        }
        let close = Request {
            seq: self.next_seq,
            session: self.session,
            body: RequestBody::Close,
        };
        // Best effort: if it is lost, the device frees the session after its link timeout.
        let _ = self.link.send(&close);
    }
}

impl<T: Read + Write> Session<T> {
    /// A session over `io` (no handshake yet: call [`Session::handshake`]).
    pub fn new(io: T, timing: Timing) -> Self {
        Self {
            link: Link::new(io),
            timing,
            // Start away from 0 so a device that rebooted (its cache empty) and a fresh host
            // do not agree on a stale sequence number by accident.
            next_seq: 1,
            session: 0,
            events: VecDeque::new(),
            stats: SessionStats::default(),
        }
    }

    /// The timing in use.
    pub fn timing(&self) -> Timing {
        self.timing
    }

    /// Counters of the session.
    pub fn stats(&self) -> SessionStats {
        self.stats
    }

    /// Counters of the framing layer.
    pub fn link_stats(&self) -> LinkStats {
        self.link.stats()
    }

    /// The transport (e.g. for a test to inject bytes).
    #[cfg(test)]
    pub fn transport_mut(&mut self) -> &mut T {
        self.link.transport_mut()
    }

    /// Events received so far and not yet taken, oldest first.
    pub fn take_events(&mut self) -> Vec<Event> {
        self.events.drain(..).collect()
    }

    /// Sends `body` and waits for its response, retrying with the same sequence number.
    pub fn request(&mut self, body: RequestBody) -> Result<Reply, SessionError> {
        let seq = self.next_seq;
        self.next_seq = self.next_seq.wrapping_add(1).max(1);
        self.stats.requests += 1;
        let name = request_name(&body);
        let request = Request {
            seq,
            session: self.session,
            body,
        };
        for attempt in 0..self.timing.attempts {
            if attempt > 0 {
                self.stats.retries += 1;
            }
            self.link.send(&request)?;
            let deadline = Instant::now() + self.timing.request_timeout;
            while let Some(msg) = self.link.recv(deadline)? {
                match msg {
                    DeviceMessage::Response {
                        seq: got,
                        result,
                        body,
                    } if got == seq => return Ok(Reply { result, body }),
                    DeviceMessage::Response { .. } => self.stats.stale_responses += 1,
                    DeviceMessage::Event(ev) => self.events.push_back(ev),
                }
            }
        }
        Err(SessionError::Timeout {
            request: name,
            attempts: self.timing.attempts,
            timeout_ms: self.timing.request_timeout.as_millis() as u64,
        })
    }

    /// Sends `body` and requires `Ok` (or `InProgress`) as the result.
    pub fn command(&mut self, body: RequestBody) -> Result<ResponseBody, SessionError> {
        let name = request_name(&body);
        let reply = self.request(body)?;
        match reply.result {
            ResultCode::Ok | ResultCode::InProgress => Ok(reply.body),
            ResultCode::Rejected(reason) => Err(SessionError::Rejected {
                request: name,
                reason,
            }),
            ResultCode::Busy => Err(SessionError::Busy { request: name }),
        }
    }

    /// The handshake: exchanges protocol version and schema identity, refuses a mismatch.
    pub fn handshake(&mut self) -> Result<DeviceInfo, SessionError> {
        let reply = self.request(RequestBody::hello())?;
        let info = match reply.body {
            ResponseBody::Hello(info) => info,
            other => {
                return Err(SessionError::Unexpected {
                    request: "Hello",
                    got: format!("{:?} {other:?}", reply.result),
                })
            }
        };
        // Check the identity ourselves too: a device that says Ok but differs is still refused.
        if reply.result == ResultCode::Rejected(RejectReason::VersionMismatch)
            || info.protocol_version != PROTOCOL_VERSION
            || info.schema_id != SCHEMA_ID
        {
            return Err(SessionError::VersionMismatch {
                host_version: PROTOCOL_VERSION,
                host_schema: SCHEMA_ID,
                device_version: info.protocol_version,
                device_schema: info.schema_id,
            });
        }
        if let ResultCode::Rejected(reason) = reply.result {
            return Err(SessionError::Rejected {
                request: "Hello",
                reason,
            });
        }
        self.session = info.session;
        Ok(info)
    }

    /// A status snapshot.
    pub fn status(&mut self) -> Result<Status, SessionError> {
        match self.command(RequestBody::GetStatus)? {
            ResponseBody::Status(status) => Ok(status),
            other => Err(SessionError::Unexpected {
                request: "GetStatus",
                got: format!("{other:?}"),
            }),
        }
    }

    /// Collects events for `duration` without sending anything.
    pub fn listen(&mut self, duration: Duration) -> Result<(), SessionError> {
        let deadline = Instant::now() + duration;
        while let Some(msg) = self.link.recv(deadline)? {
            match msg {
                DeviceMessage::Event(ev) => self.events.push_back(ev),
                DeviceMessage::Response { .. } => self.stats.stale_responses += 1,
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session_fake::FakeDevice;

    fn timing() -> Timing {
        Timing {
            request_timeout: Duration::from_millis(5),
            attempts: 4,
            poll_period: Duration::from_millis(1),
        }
    }

    fn s(name: &str) -> geometry::TrunkState {
        name.parse().unwrap()
    }

    #[test]
    fn handshake_then_status_reports_the_devices_state() {
        let mut session = Session::new(FakeDevice::new(s("D&F")), timing());
        let info = session.handshake().unwrap();
        assert_eq!(
            (info.protocol_version, info.schema_id),
            (PROTOCOL_VERSION, SCHEMA_ID)
        );
        assert_eq!(session.status().unwrap().state, s("D&F"));
        assert_eq!(session.stats().retries, 0);
    }

    #[test]
    fn a_version_mismatch_names_both_versions_and_schema_ids() {
        let mut dev = FakeDevice::new(s("F&P"));
        dev.version = (PROTOCOL_VERSION + 1, 0xdead_beef);
        let mut session = Session::new(dev, timing());
        let err = session.handshake().unwrap_err();
        let msg = err.to_string();
        assert!(matches!(err, SessionError::VersionMismatch { .. }));
        assert!(
            msg.contains(&format!("protocol version {PROTOCOL_VERSION}")),
            "{msg}"
        );
        assert!(
            msg.contains(&format!("protocol version {}", PROTOCOL_VERSION + 1)),
            "{msg}"
        );
        assert!(msg.contains(&format!("{SCHEMA_ID:#010x}")), "{msg}");
        assert!(msg.contains("0xdeadbeef"), "{msg}");
    }

    #[test]
    fn lost_responses_are_retried_with_the_same_seq_and_executed_once() {
        let mut dev = FakeDevice::new(s("F&P"));
        dev.drop_every = Some(2); // every second response is lost
        let mut session = Session::new(dev, timing());
        session.handshake().unwrap();
        for _ in 0..10 {
            assert_eq!(session.status().unwrap().state, s("F&P"));
        }
        assert!(session.stats().retries >= 5, "{:?}", session.stats());
        let dev = session.transport_mut();
        assert!(dev.executed.values().all(|&n| n == 1), "{:?}", dev.executed);
        assert_eq!(dev.executed.len(), 11);
    }

    #[test]
    fn a_silent_device_times_out_after_every_attempt() {
        let mut dev = FakeDevice::new(s("F&P"));
        dev.silent_after = Some(1);
        let mut session = Session::new(dev, timing());
        session.handshake().unwrap();
        let err = session.status().unwrap_err();
        assert!(
            matches!(
                err,
                SessionError::Timeout {
                    request: "GetStatus",
                    attempts: 4,
                    ..
                }
            ),
            "{err}"
        );
        assert_eq!(session.transport_mut().requests_seen, 5);
    }

    #[test]
    fn garbage_before_a_frame_does_not_hide_the_response() {
        let mut dev = FakeDevice::new(s("F&F"));
        // Noise already waiting in the host's receive buffer, without a delimiter: it spoils
        // the first response, which is then retried.
        dev.inject_to_host(&[0x13, 0x37, 0x42]);
        let mut session = Session::new(dev, timing());
        session.handshake().unwrap();
        assert_eq!(session.stats().retries, 1);
        assert_eq!(session.link_stats().frames_dropped, 1);
        // Noise on the host → device direction: the leading delimiter of the next frame closes it.
        session
            .transport_mut()
            .write_all(&[0x55, 0x13, 0xff, 0x02])
            .unwrap();
        assert_eq!(session.status().unwrap().state, s("F&F"));
        assert_eq!(session.stats().retries, 1);
    }

    #[test]
    fn requests_before_the_handshake_are_refused() {
        let mut session = Session::new(FakeDevice::new(s("F&P")), timing());
        let err = session.status().unwrap_err();
        assert!(
            matches!(
                err,
                SessionError::Rejected {
                    reason: RejectReason::NoHandshake,
                    ..
                }
            ),
            "{err}"
        );
    }
}

/// The session against the real firmware controller, in-process (no physics: the trunk stays
/// put, which is enough for the protocol's half of the contract).
#[cfg(test)]
mod with_firmware {
    use std::io::{self, Read, Write};

    use firmware::{BootRecord, Controller, CraneConfig, Inputs};
    use protocol::{Mode, PlanPhase};

    use super::*;

    struct Board {
        ctl: Controller,
        rest: Inputs,
        now_ms: u64,
        /// Drop the next response frame(s) the controller sends.
        drop_next: u32,
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
                pending: Vec::new(),
            }
        }

        fn tick(&mut self, ms: u64) {
            for _ in 0..ms {
                self.now_ms += 1;
                self.ctl.handle_inputs(&self.rest, self.now_ms);
                self.ctl.handle_time(self.now_ms);
            }
        }
    }

    impl Write for Board {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            self.ctl.handle_rx(buf, self.now_ms);
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    impl Read for Board {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            self.tick(1);
            let mut tmp = [0u8; 512];
            loop {
                let n = self.ctl.poll_tx(&mut tmp);
                if n == 0 {
                    break;
                }
                self.pending.extend_from_slice(&tmp[..n]);
            }
            // Drop whole frames on request (everything up to and including a delimiter).
            while self.drop_next > 0 {
                let Some(end) = self.pending.iter().position(|&b| b == 0) else {
                    break;
                };
                self.pending.drain(..=end);
                self.drop_next -= 1;
            }
            if self.pending.is_empty() {
                return Err(io::ErrorKind::WouldBlock.into());
            }
            let n = buf.len().min(self.pending.len());
            buf[..n].copy_from_slice(&self.pending[..n]);
            self.pending.drain(..n);
            Ok(n)
        }
    }

    fn timing() -> Timing {
        Timing {
            request_timeout: Duration::from_millis(20),
            attempts: 5,
            poll_period: Duration::from_millis(1),
        }
    }

    #[test]
    fn handshake_status_and_a_plan_start_against_the_real_controller() {
        let mut session = Session::new(Board::new(), timing());
        let info = session.handshake().unwrap();
        assert_eq!(
            (info.protocol_version, info.schema_id),
            (PROTOCOL_VERSION, SCHEMA_ID)
        );
        let status = session.status().unwrap();
        assert_eq!(status.state, geometry::TrunkState::AS_MANUFACTURED);
        assert_eq!(status.mode, Mode::Standalone);
        let plan = planner::graph::Graph::nominal()
            .plan(status.state, "F&F".parse().unwrap())
            .unwrap()
            .to_protocol(3)
            .unwrap();
        session.command(RequestBody::UploadPlan(plan)).unwrap();
        session
            .command(RequestBody::StartPlan { plan_id: 3 })
            .unwrap();
        let status = session.status().unwrap();
        let ps = status.plan.unwrap();
        assert_eq!((ps.plan_id, ps.steps), (3, 1));
        assert_eq!(ps.phase, PlanPhase::Running);
        // Abort leaves the actuators safe.
        session.command(RequestBody::Abort).unwrap();
        let status = session.status().unwrap();
        assert!(!status.inlet_open, "{status:?}");
        assert_eq!(status.plan.unwrap().phase, PlanPhase::Aborted);
    }

    #[test]
    fn a_lost_response_is_answered_from_the_controllers_cache() {
        let mut session = Session::new(Board::new(), timing());
        session.handshake().unwrap();
        let plan = planner::graph::Graph::nominal()
            .plan("F&P".parse().unwrap(), "F&F".parse().unwrap())
            .unwrap()
            .to_protocol(9)
            .unwrap();
        session.command(RequestBody::UploadPlan(plan)).unwrap();
        // The StartPlan response is lost: the retry (same seq) must get the cached answer, not
        // a second execution (which the controller would refuse as Busy: the plan runs).
        session.transport_mut().drop_next = 1;
        let reply = session
            .request(RequestBody::StartPlan { plan_id: 9 })
            .unwrap();
        assert!(
            matches!(reply.result, ResultCode::Ok | ResultCode::InProgress),
            "{reply:?}"
        );
        assert_eq!(session.stats().retries, 1);
        session.command(RequestBody::Abort).unwrap();
    }
}
