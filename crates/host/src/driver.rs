//! The one blocking loop around the engine, generic over where bytes and time come from: a
//! serial port on the wall clock (host-tool) or the simulator on its virtual clock (the
//! in-process `Pair`, the swarm tester).

use std::collections::VecDeque;

use geometry::TrunkState;
use protocol::{DeviceInfo, Event, RequestBody};
use transition_graph::Graph;

use crate::engine::{Host, HostEvent};
use crate::runner::{Outcome, RunEvent, RunOptions};
use crate::session::{Reply, SessionError, SessionEvent};

/// Where the engine's bytes go and come from, and what time it is.
pub trait Io {
    /// Now, in ms on this I/O's clock.
    fn now_ms(&mut self) -> u64;
    /// Writes one frame toward the device.
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()>;
    /// Waits until bytes arrive or the clock reaches `deadline_ms` (a wall-clock I/O may return
    /// earlier, so that its shell can look at its signals), and appends what came to `buf`.
    fn read(&mut self, deadline_ms: u64, buf: &mut Vec<u8>) -> std::io::Result<()>;
}

impl<T: Io + ?Sized> Io for &mut T {
    fn now_ms(&mut self) -> u64 {
        (**self).now_ms()
    }
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        (**self).write(bytes)
    }
    fn read(&mut self, deadline_ms: u64, buf: &mut Vec<u8>) -> std::io::Result<()> {
        (**self).read(deadline_ms, buf)
    }
}

/// What the shell does between turns of a plan run: shows progress and answers prompts.
/// It sees the I/O too (a simulated operator looks at the simulated trunk through it).
pub trait RunShell<I> {
    /// Something happened in the run.
    fn event(&mut self, event: &RunEvent, io: &mut I);
    /// Asked between turns: anything to tell the run?
    fn poll(&mut self, _io: &mut I) -> Option<ShellAction> {
        None
    }
    /// A device event arrived (telemetry and the like) during the run.
    fn device_event(&mut self, _event: &Event, _io: &mut I) {}
}

/// The shell's answers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ShellAction {
    /// Stop the run (Ctrl-C, a signal): abort on the device; the text says why.
    Cancel(String),
    /// The operator did the manual step.
    ConfirmManual,
    /// The operator says the trunk is in this state (`None`: cannot tell).
    Declare(Option<TrunkState>),
}

/// Longest wait in one turn when nothing is due (the engine always has a heartbeat due while
/// open, so this only bounds a closed session's wait).
const IDLE_WAIT_MS: u64 = 50;

/// The engine and its I/O, turned by one blocking loop. Dropping it ends the device's session
/// (a `Close`, not waited for), so the next host can shake hands at once.
#[derive(Debug)]
pub struct Driver<I: Io> {
    /// The engine.
    pub host: Host,
    /// The I/O.
    pub io: I,
    /// Device events seen by [`Driver::call`] and not yet taken.
    pub device_events: VecDeque<Event>,
    buf: Vec<u8>,
    vanished: bool,
}

impl<I: Io> Drop for Driver<I> {
    fn drop(&mut self) {
        if self.vanished {
            return;
        }
        self.host.close();
        while let Some(frame) = self.host.poll_transmit() {
            if self.io.write(&frame).is_err() {
                break;
            }
        }
    }
}

impl<I: Io> Driver<I> {
    /// A driver around `host` and `io`.
    pub fn new(host: Host, io: I) -> Self {
        Self {
            host,
            io,
            device_events: VecDeque::new(),
            buf: Vec::new(),
            vanished: false,
        }
    }

    /// Ends without a word, as a host that crashed or was killed does: no `Close`, so the
    /// device learns it only from the silence (its link watchdog).
    pub fn vanish(mut self) {
        self.vanished = true;
    }

    /// One turn: write what is due, wait for bytes or the next deadline, feed the engine.
    pub fn turn(&mut self) -> std::io::Result<()> {
        self.turn_until(None)
    }

    /// A turn that never waits past `cap` (the clock's ms): the one pump around the engine,
    /// also for a shell that must look up between slices (host-tool's `serve`).
    pub fn turn_until(&mut self, cap: Option<u64>) -> std::io::Result<()> {
        while let Some(frame) = self.host.poll_transmit() {
            self.io.write(&frame)?;
        }
        let now = self.io.now_ms();
        let mut deadline = self.host.poll_timeout().unwrap_or(now + IDLE_WAIT_MS);
        if let Some(cap) = cap {
            deadline = deadline.min(cap);
        }
        self.buf.clear();
        if deadline > now {
            self.io.read(deadline, &mut self.buf)?;
        }
        let now = self.io.now_ms();
        if !self.buf.is_empty() {
            let bytes = std::mem::take(&mut self.buf);
            self.host.handle_bytes(&bytes, now);
            self.buf = bytes;
        }
        if self.host.poll_timeout().is_some_and(|t| t <= now) {
            self.host.handle_timeout(now);
        }
        while let Some(frame) = self.host.poll_transmit() {
            self.io.write(&frame)?;
        }
        Ok(())
    }

    /// Connects: the handshake, to its end.
    pub fn connect(&mut self) -> Result<DeviceInfo, SessionError> {
        self.connect_with(false)
    }

    /// Connects, taking the crane over from the host that holds it when `takeover`.
    pub fn connect_with(&mut self, takeover: bool) -> Result<DeviceInfo, SessionError> {
        let now = self.io.now_ms();
        if takeover {
            self.host.connect_takeover(now);
        } else {
            self.host.connect(now);
        }
        loop {
            while let Some(ev) = self.host.poll_event() {
                match ev {
                    HostEvent::Session(SessionEvent::Opened(info)) => return Ok(info),
                    HostEvent::Session(SessionEvent::HandshakeFailed(e)) => return Err(e),
                    HostEvent::Session(SessionEvent::Device(e)) => self.device_events.push_back(e),
                    _ => {}
                }
            }
            self.turn().map_err(|e| io_error("Hello", &e))?;
        }
    }

    /// Sends `body` and waits for its answer.
    pub fn call(&mut self, body: RequestBody) -> Result<Reply, SessionError> {
        let name = crate::text::request_name(&body);
        let now = self.io.now_ms();
        let urgent = matches!(body, RequestBody::Abort);
        let id = if urgent {
            self.host.request_first(body, now)
        } else {
            self.host.request(body, now)
        };
        loop {
            while let Some(ev) = self.host.poll_event() {
                match ev {
                    HostEvent::Session(SessionEvent::Reply { id: got, reply }) if got == id => {
                        return Ok(reply)
                    }
                    HostEvent::Session(SessionEvent::Failed { id: got, error }) if got == id => {
                        return Err(error)
                    }
                    HostEvent::Session(SessionEvent::Device(e)) => self.device_events.push_back(e),
                    _ => {}
                }
            }
            self.turn().map_err(|e| io_error(name, &e))?;
        }
    }

    /// Ends the device's session and waits for the device to say so: `Close` is resent while
    /// its answer is lost, `attempts` sends at most (one [`crate::Timing::request_timeout_ms`]
    /// apart), so the next host can shake hands at once even on a noisy line. `Ok` when the
    /// device answered (or nothing was open); the last attempt's timeout otherwise (the device
    /// then frees the session after its link timeout). Closed on this side either way.
    pub fn close_confirmed(&mut self, attempts: u32) -> Result<(), SessionError> {
        let now = self.io.now_ms();
        let Some(id) = self.host.close_confirmed(attempts, now) else {
            return Ok(());
        };
        loop {
            while let Some(ev) = self.host.poll_event() {
                match ev {
                    HostEvent::Session(SessionEvent::Reply { id: got, .. }) if got == id => {
                        return Ok(())
                    }
                    HostEvent::Session(SessionEvent::Failed { id: got, error }) if got == id => {
                        return Err(error)
                    }
                    HostEvent::Session(SessionEvent::Device(e)) => self.device_events.push_back(e),
                    _ => {}
                }
            }
            if let Err(e) = self.turn() {
                self.host.close();
                return Err(io_error("Close", &e));
            }
        }
    }

    /// Sends `body` and requires `Ok`/`InProgress`.
    pub fn command(&mut self, body: RequestBody) -> Result<protocol::ResponseBody, SessionError> {
        let name = crate::text::request_name(&body);
        self.call(body)?.accepted(name)
    }

    /// A status snapshot.
    pub fn status(&mut self) -> Result<protocol::Status, SessionError> {
        self.call(RequestBody::GetStatus)?.status()
    }

    /// Lets the engine run (heartbeats, events) until the clock has advanced by `ms`.
    pub fn idle(&mut self, ms: u64) -> Result<(), SessionError> {
        let end = self.io.now_ms() + ms;
        while self.io.now_ms() < end {
            while let Some(ev) = self.host.poll_event() {
                match ev {
                    HostEvent::Session(SessionEvent::Device(e)) => self.device_events.push_back(e),
                    HostEvent::Session(SessionEvent::LinkLost(e)) => return Err(e),
                    _ => {}
                }
            }
            if self.host.session().is_closed() {
                return Err(SessionError::Closed);
            }
            // Never wait past `end`.
            self.turn_until(Some(end))
                .map_err(|e| io_error("Heartbeat", &e))?;
        }
        Ok(())
    }

    /// Runs a plan toward `target` to its end, telling `shell` what happens.
    pub fn run_plan(
        &mut self,
        graph: Graph,
        target: TrunkState,
        options: RunOptions,
        shell: &mut dyn RunShell<I>,
    ) -> Outcome {
        let now = self.io.now_ms();
        self.host.run_plan(graph, target, options, now);
        loop {
            while let Some(ev) = self.host.poll_event() {
                match ev {
                    HostEvent::Run(RunEvent::Finished) => {
                        shell.event(&RunEvent::Finished, &mut self.io);
                        return self.outcome();
                    }
                    HostEvent::Run(ev) => shell.event(&ev, &mut self.io),
                    HostEvent::Session(SessionEvent::Device(e)) => {
                        shell.device_event(&e, &mut self.io)
                    }
                    HostEvent::Session(_) => {}
                }
            }
            if let Some(action) = shell.poll(&mut self.io) {
                let now = self.io.now_ms();
                match action {
                    ShellAction::Cancel(why) => self.host.cancel(&why, now),
                    ShellAction::ConfirmManual => self.host.confirm_manual(now),
                    ShellAction::Declare(state) => self.host.declare(state, now),
                }
                continue;
            }
            if self.host.runner().is_some_and(|r| r.is_finished()) {
                return self.outcome();
            }
            if let Err(e) = self.turn() {
                // The transport is gone: nothing more can be learnt from the device.
                let now = self.io.now_ms();
                self.host.cancel(&format!("serial I/O failed: {e}"), now);
                let mut out = self.outcome();
                out.state_confirmed = false;
                if out.failure.is_none() {
                    out.failure = Some(crate::runner::RunFailure {
                        kind: crate::runner::FailureKind::LinkLost,
                        step: None,
                        fault: None,
                        reject: None,
                        refusal: None,
                        message: format!("serial I/O failed: {e}"),
                    });
                }
                return out;
            }
        }
    }

    fn outcome(&self) -> Outcome {
        self.host
            .runner()
            .map(|r| r.outcome().clone())
            .unwrap_or_default()
    }
}

fn io_error(request: &'static str, e: &std::io::Error) -> SessionError {
    SessionError::Unexpected {
        request,
        got: format!("serial I/O failed: {e}"),
    }
}
