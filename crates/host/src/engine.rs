//! [`Host`]: the session and the job it runs (a plan, or single requests), behind the five calls
//! of a sans-IO engine.

use std::collections::VecDeque;

use geometry::TrunkState;
use protocol::RequestBody;
use transition_graph::Graph;

use crate::runner::{PlanRunner, RunEvent, RunOptions};
use crate::session::{RequestId, Session, SessionEvent, Timing};

/// What the engine tells its shell.
#[derive(Debug, Clone, PartialEq)]
pub enum HostEvent {
    /// From the session: handshake, replies to the shell's own requests, device events, link
    /// loss. Replies to the plan runner's requests are not repeated here.
    Session(SessionEvent),
    /// From the plan runner.
    Run(RunEvent),
}

/// The host side of the link: one session and, optionally, a plan run over it.
///
/// Inputs are [`Host::handle_bytes`] and [`Host::handle_timeout`] (each with `now_ms` on the
/// shell's clock), plus the shell's own requests and the operator's answers; outputs are
/// [`Host::poll_transmit`], [`Host::poll_timeout`] and [`Host::poll_event`].
#[derive(Debug)]
pub struct Host {
    session: Session,
    runner: Option<PlanRunner>,
    events: VecDeque<HostEvent>,
}

impl Host {
    /// A host that has sent nothing; `first_seq` should differ between host processes.
    pub fn new(timing: Timing, first_seq: u16) -> Self {
        Self {
            session: Session::new(timing, first_seq),
            runner: None,
            events: VecDeque::new(),
        }
    }

    /// Starts the handshake.
    pub fn connect(&mut self, now_ms: u64) {
        self.session.connect(now_ms);
        self.route(now_ms);
    }

    /// Starts a handshake that takes the crane over from the host that holds it.
    pub fn connect_takeover(&mut self, now_ms: u64) {
        self.session.connect_takeover(now_ms);
        self.route(now_ms);
    }

    /// Ends the device's session (see [`Session::close`]); flush [`Host::poll_transmit`].
    pub fn close(&mut self) {
        self.session.close();
    }

    /// Ends the device's session and waits for its answer, resending a lost one (see
    /// [`Session::close_confirmed`]); the outcome is the returned id's event.
    pub fn close_confirmed(&mut self, attempts: u32, now_ms: u64) -> Option<RequestId> {
        let id = self.session.close_confirmed(attempts, now_ms);
        self.route(now_ms);
        id
    }

    /// Link signing's key and first counter (see [`Session::set_signing`]).
    pub fn set_signing(&mut self, key: Option<protocol::sign::LinkKey>, first_counter: u64) {
        self.session.set_signing(key, first_counter);
    }

    /// The session.
    pub fn session(&self) -> &Session {
        &self.session
    }

    /// The plan run, if one was started.
    pub fn runner(&self) -> Option<&PlanRunner> {
        self.runner.as_ref()
    }

    /// A request of the shell's own; its answer comes as a [`SessionEvent::Reply`].
    pub fn request(&mut self, body: RequestBody, now_ms: u64) -> RequestId {
        let id = self.session.request(body, now_ms);
        self.route(now_ms);
        id
    }

    /// A request ahead of every queued one (an abort).
    pub fn request_first(&mut self, body: RequestBody, now_ms: u64) -> RequestId {
        let id = self.session.request_first(body, now_ms);
        self.route(now_ms);
        id
    }

    /// Starts a plan run toward `target` (the handshake must be done).
    pub fn run_plan(&mut self, graph: Graph, target: TrunkState, options: RunOptions, now_ms: u64) {
        let mut runner = PlanRunner::new(graph, target, options);
        runner.start(&mut self.session, now_ms);
        self.runner = Some(runner);
        self.route(now_ms);
    }

    /// Cancels the plan run (aborts on the device) — `why` says what stopped it.
    pub fn cancel(&mut self, why: &str, now_ms: u64) {
        if let Some(r) = self.runner.as_mut() {
            r.cancel(&mut self.session, now_ms, why);
        }
        self.route(now_ms);
    }

    /// The operator confirms the manual step the device waits for.
    pub fn confirm_manual(&mut self, now_ms: u64) {
        if let Some(r) = self.runner.as_mut() {
            r.confirm_manual(&mut self.session, now_ms);
        }
        self.route(now_ms);
    }

    /// The operator's answer to an identify prompt.
    pub fn declare(&mut self, state: Option<TrunkState>, now_ms: u64) {
        if let Some(r) = self.runner.as_mut() {
            r.declare(&mut self.session, state, now_ms);
        }
        self.route(now_ms);
    }

    /// Bytes from the device.
    pub fn handle_bytes(&mut self, bytes: &[u8], now_ms: u64) {
        self.session.handle_bytes(bytes, now_ms);
        self.route(now_ms);
    }

    /// Time has passed.
    pub fn handle_timeout(&mut self, now_ms: u64) {
        self.session.handle_timeout(now_ms);
        if let Some(r) = self.runner.as_mut() {
            r.handle_timeout(&mut self.session, now_ms);
        }
        self.route(now_ms);
    }

    /// The next frame to write.
    pub fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.session.poll_transmit()
    }

    /// When [`Host::handle_timeout`] is due next.
    pub fn poll_timeout(&self) -> Option<u64> {
        let r = self.runner.as_ref().and_then(PlanRunner::poll_timeout);
        match (self.session.poll_timeout(), r) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// The next event for the shell.
    pub fn poll_event(&mut self) -> Option<HostEvent> {
        self.events.pop_front()
    }

    /// Hands the session's events to the runner and to the shell.
    fn route(&mut self, now_ms: u64) {
        loop {
            let mut progressed = false;
            while let Some(ev) = self.session.poll_event() {
                progressed = true;
                let mut claimed = false;
                if let Some(r) = self.runner.as_mut() {
                    claimed = matches!(
                        ev,
                        SessionEvent::Reply { id, .. } | SessionEvent::Failed { id, .. }
                            if Some(id) == r.waiting_on()
                    );
                    r.handle_session_event(&ev, &mut self.session, now_ms);
                }
                if !claimed {
                    self.events.push_back(HostEvent::Session(ev));
                }
            }
            if let Some(r) = self.runner.as_mut() {
                while let Some(ev) = r.poll_event() {
                    progressed = true;
                    self.events.push_back(HostEvent::Run(ev));
                }
            }
            if !progressed {
                break;
            }
        }
    }
}
