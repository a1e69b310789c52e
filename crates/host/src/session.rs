//! The session: handshake, sequence numbers, retries and the heartbeat, without I/O.
//!
//! Requests are sent one at a time (stop and wait). Each gets a fresh sequence number; when no
//! response comes within [`Timing::request_timeout_ms`] the *same* request with the *same*
//! sequence number is sent again: the device executes a request once and answers a repeat from
//! its cache, so a retry never runs an action twice. Responses to other sequence numbers (late
//! answers to an earlier attempt) are ignored. Events are handed on as they come; they are hints
//! (any frame can be lost), the status is the truth.
//!
//! The link is lost when the device has been silent (no valid frame at all, its own heartbeat
//! events included) for [`Timing::silence_ms`] while a request waits, or when one request has
//! been sent [`Timing::max_attempts`] times. While the session is open and nothing else is
//! being sent, a [`RequestBody::Heartbeat`] goes out every [`Timing::heartbeat_ms`].
//!
//! Time is whatever the shell says it is: `now_ms` from a wall clock over a serial port, or the
//! simulator's virtual clock in-process. The session never reads a clock.

use std::collections::VecDeque;

use protocol::sign::LinkKey;
use protocol::{
    DeviceInfo, DeviceMessage, Event, FrameDecoder, RejectReason, Request, RequestBody,
    ResponseBody, ResultCode, Status, MAX_FRAME_LEN,
};

use crate::text;

/// How long to wait and how often to try (milliseconds on the shell's clock).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// Wait this long for a response before sending the request again.
    pub request_timeout_ms: u64,
    /// Sends of one request (the first included) before the link counts as lost.
    pub max_attempts: u32,
    /// Device silence (no valid frame) while a request waits that counts as a lost link.
    pub silence_ms: u64,
    /// Send a heartbeat when nothing was sent for this long.
    pub heartbeat_ms: u64,
}

impl Timing {
    /// The one timing, from the protocol's constants: a retry every
    /// [`protocol::RESPONSE_TIMEOUT_MS`], a heartbeat every [`protocol::HOST_HEARTBEAT_PERIOD_MS`],
    /// and the link lost after [`protocol::DEFAULT_LINK_TIMEOUT_MS`] of device silence (the
    /// device heartbeats every [`protocol::HEARTBEAT_PERIOD_MS`], so silence that long is not
    /// noise) or 4 × [`protocol::MAX_RETRIES`] resends of one request.
    pub const fn standard() -> Self {
        Self {
            request_timeout_ms: protocol::RESPONSE_TIMEOUT_MS as u64,
            max_attempts: 1 + 4 * protocol::MAX_RETRIES as u32,
            silence_ms: protocol::DEFAULT_LINK_TIMEOUT_MS as u64,
            heartbeat_ms: protocol::HOST_HEARTBEAT_PERIOD_MS as u64,
        }
    }
}

impl Default for Timing {
    fn default() -> Self {
        Self::standard()
    }
}

/// Identifies one request made through [`Session::request`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RequestId(pub u64);

/// The device's answer to one request.
#[derive(Debug, Clone, PartialEq)]
pub struct Reply {
    /// Outcome.
    pub result: ResultCode,
    /// Data.
    pub body: ResponseBody,
}

impl Reply {
    /// `Ok(body)` for `Ok`/`InProgress`, the refusal as an error otherwise.
    pub fn accepted(self, request: &'static str) -> Result<ResponseBody, SessionError> {
        match self.result {
            ResultCode::Ok | ResultCode::InProgress => Ok(self.body),
            ResultCode::Rejected(reason) => Err(SessionError::Rejected {
                request,
                reason,
                refusal: match self.body {
                    ResponseBody::Refused(r) => Some(r),
                    _ => None,
                },
            }),
            ResultCode::Busy => Err(SessionError::Busy { request }),
        }
    }

    /// The status this reply carries.
    pub fn status(self) -> Result<Status, SessionError> {
        match self.accepted("GetStatus")? {
            ResponseBody::Status(s) => Ok(s),
            other => Err(SessionError::Unexpected {
                request: "GetStatus",
                got: format!("{other:?}"),
            }),
        }
    }
}

/// Why a request did not get a usable answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SessionError {
    /// No response: the link is down or the device does not answer.
    #[error(
        "no response to {request} after {attempts} attempts over {waited_ms} ms: \
         the device does not answer (link lost?)"
    )]
    Timeout {
        /// Which request.
        request: &'static str,
        /// How many times it was sent.
        attempts: u32,
        /// How long it waited in all.
        waited_ms: u64,
    },
    /// Host and device speak different protocols.
    #[error("{}", text::version_mismatch(.0))]
    VersionMismatch(protocol::VersionMismatch),
    /// The device refused the request.
    #[error("the device refused {request}: {}", text::refusal(*.reason, .refusal.as_ref()))]
    Rejected {
        /// Which request.
        request: &'static str,
        /// Why.
        reason: RejectReason,
        /// The field, the value asked for and the limit, when the device names them.
        refusal: Option<protocol::Refusal>,
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
    /// An urgent request (an abort) went out instead; the device may or may not have executed
    /// this one.
    #[error("{request} was superseded by an urgent request")]
    Preempted {
        /// Which request.
        request: &'static str,
    },
    /// The session is closed (the link was lost before, or it was never opened).
    #[error("the session is closed")]
    Closed,
}

/// What the session tells its owner.
#[derive(Debug, Clone, PartialEq)]
pub enum SessionEvent {
    /// The handshake succeeded.
    Opened(DeviceInfo),
    /// The handshake failed; the session is closed.
    HandshakeFailed(SessionError),
    /// The answer to a request.
    Reply {
        /// Which request.
        id: RequestId,
        /// The answer.
        reply: Reply,
    },
    /// A request got no usable answer (lost link, closed session, preempted).
    Failed {
        /// Which request.
        id: RequestId,
        /// Why.
        error: SessionError,
    },
    /// An event the device sent.
    Device(Event),
    /// The link is lost (sent once, after the `Failed` of every waiting request); the
    /// session is closed. The device's link watchdog makes the crane safe by itself.
    LinkLost(SessionError),
}

/// Counters of the session (for reports and benchmarks).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SessionStats {
    /// Requests made (retries and automatic heartbeats not counted).
    pub requests: u64,
    /// Requests sent again after a timeout.
    pub retries: u64,
    /// Responses ignored because they answered another sequence number.
    pub stale_responses: u64,
    /// Frames sent.
    pub frames_tx: u64,
    /// Frames received and decoded.
    pub frames_rx: u64,
    /// Frames received but dropped (corrupt, oversized, undecodable).
    pub frames_dropped: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Not connected yet.
    New,
    /// Hello sent.
    Handshaking,
    /// Handshake done.
    Open,
    /// `Close` sent as a request ([`Session::close_confirmed`]), its answer awaited.
    Closing,
    /// Lost or failed.
    Closed,
}

#[derive(Debug)]
struct Pending {
    id: RequestId,
    seq: u16,
    name: &'static str,
    frame: Vec<u8>,
    attempts: u32,
    /// Sends of it (the first included) before it is given up.
    max_attempts: u32,
    first_sent_ms: u64,
    retry_at_ms: u64,
    /// An automatic heartbeat: its answer is not reported.
    internal: bool,
    /// A `SetSigning`: the device's signing once it says Ok (`Some(key)`: on with it).
    signing_change: Option<Option<LinkKey>>,
}

/// A conversation with one device, as a state machine.
#[derive(Debug)]
pub struct Session {
    timing: Timing,
    phase: Phase,
    next_seq: u16,
    next_id: u64,
    decoder: FrameDecoder,
    queue: VecDeque<(RequestId, RequestBody, bool)>,
    pending: Option<Pending>,
    transmit: VecDeque<Vec<u8>>,
    events: VecDeque<SessionEvent>,
    last_tx_ms: u64,
    last_rx_ms: u64,
    info: Option<DeviceInfo>,
    /// The device's session id from the handshake (0 before it), sent in every request.
    session_id: u32,
    stats: SessionStats,
    keepalive: bool,
    /// The link key and the next signed frame's counter ([`Session::set_signing`]).
    signing: Option<(LinkKey, u64)>,
}

impl Session {
    /// A session that has sent nothing. `first_seq` should differ between sessions (a device
    /// caches its last answers by sequence number); [`Session::connect`] starts the handshake.
    pub fn new(timing: Timing, first_seq: u16) -> Self {
        Self {
            timing,
            phase: Phase::New,
            next_seq: first_seq.max(1),
            next_id: 0,
            decoder: FrameDecoder::new(),
            queue: VecDeque::new(),
            pending: None,
            transmit: VecDeque::new(),
            events: VecDeque::new(),
            last_tx_ms: 0,
            last_rx_ms: 0,
            info: None,
            session_id: 0,
            stats: SessionStats::default(),
            keepalive: true,
            signing: None,
        }
    }

    /// Ends the session on the device at once (a `Close` is queued for
    /// [`Session::poll_transmit`], not waited for: if it is lost, the device frees the session
    /// after its link timeout) and closes this side. Nothing happens unless it is open.
    pub fn close(&mut self) {
        if self.phase == Phase::Closing {
            // Its `Close` is already on the wire: stop waiting for the answer.
            self.pending = None;
            self.phase = Phase::Closed;
            return;
        }
        if self.phase != Phase::Open {
            return;
        }
        let request = Request {
            seq: self.next_seq,
            session: self.session_id,
            body: RequestBody::Close,
        };
        self.next_seq = self.next_seq.wrapping_add(1).max(1);
        if let Ok(frame) = self.frame(&request) {
            self.transmit.push_back(frame);
            self.stats.frames_tx += 1;
        }
        self.pending = None;
        self.queue.clear();
        self.phase = Phase::Closed;
    }

    /// Ends the session on the device and waits for the answer: `Close` goes out as a request,
    /// sent `attempts` times at most (the first included, every
    /// [`Timing::request_timeout_ms`]) while its answer is lost. A resend carries the same
    /// `seq`, so the device answers it from its cache and closes nothing twice. Whatever waited
    /// or was queued fails ([`SessionError::Preempted`], [`SessionError::Closed`]). The outcome
    /// is an event for the returned id: [`SessionEvent::Reply`] (the device answered), or
    /// [`SessionEvent::Failed`] with [`SessionError::Timeout`] after the last attempt (the
    /// device then frees the session after its link timeout); the session is closed either
    /// way. `None` (nothing sent) unless the session is open.
    pub fn close_confirmed(&mut self, attempts: u32, now_ms: u64) -> Option<RequestId> {
        if self.phase != Phase::Open {
            return None;
        }
        if let Some(p) = self.pending.take() {
            if !p.internal {
                self.events.push_back(SessionEvent::Failed {
                    id: p.id,
                    error: SessionError::Preempted { request: p.name },
                });
            }
        }
        for (id, _, internal) in self.queue.drain(..) {
            if !internal {
                self.events.push_back(SessionEvent::Failed {
                    id,
                    error: SessionError::Closed,
                });
            }
        }
        let id = self.alloc_id();
        self.stats.requests += 1;
        self.phase = Phase::Closing;
        self.send_new(id, RequestBody::Close, false, attempts.max(1), now_ms);
        Some(id)
    }

    /// Link signing ([`protocol::sign`]): signs every request after the handshake with `key`
    /// when the device says signing is on ([`DeviceInfo::signing`]), counters from
    /// `first_counter` up (it must rise above every counter the device accepted since it
    /// booted: host-tool gives the wall clock's µs). `None`: never signs. A `SetSigning` the
    /// device accepts turns signing on with its key (or off) from the next request.
    pub fn set_signing(&mut self, key: Option<LinkKey>, first_counter: u64) {
        self.signing = key.map(|k| (k, first_counter.max(1)));
    }

    /// Whether requests go out signed now.
    pub fn signs(&self) -> bool {
        self.signing.is_some() && self.info.as_ref().is_some_and(|i| i.signing)
    }

    /// `request` as one frame with a leading delimiter; signed when [`Session::signs`].
    fn frame(&mut self, request: &Request) -> Result<Vec<u8>, protocol::FrameError> {
        let mut frame = vec![0u8; MAX_FRAME_LEN + 1];
        let signs = self.signs() && !matches!(request.body, RequestBody::Hello { .. });
        let n = match self.signing.as_mut() {
            Some((key, counter)) if signs => {
                let c = *counter;
                *counter = counter.saturating_add(1);
                protocol::frame::encode_signed(request, key, c, &mut frame[1..])?
            }
            _ => protocol::encode(request, &mut frame[1..])?,
        };
        frame.truncate(n + 1);
        Ok(frame)
    }

    /// Starts the handshake.
    pub fn connect(&mut self, now_ms: u64) {
        self.start_handshake(RequestBody::hello(), now_ms);
    }

    /// Starts a handshake that takes the crane over from a host that holds it (that host's
    /// next state-changing request is refused: it is told).
    pub fn connect_takeover(&mut self, now_ms: u64) {
        self.start_handshake(RequestBody::hello_takeover(), now_ms);
    }

    fn start_handshake(&mut self, hello: RequestBody, now_ms: u64) {
        if self.phase != Phase::New {
            return;
        }
        self.phase = Phase::Handshaking;
        self.last_rx_ms = now_ms;
        let id = self.alloc_id();
        self.queue.push_back((id, hello, false));
        self.pump(now_ms);
    }

    /// Whether automatic heartbeats are sent while idle (on by default).
    pub fn set_keepalive(&mut self, on: bool) {
        self.keepalive = on;
    }

    /// The timing in use.
    pub fn timing(&self) -> Timing {
        self.timing
    }

    /// Who the device is, once it answered the handshake: the session it opened, or (after a
    /// refusal) its versions and trunk with session 0 — the session in force is never told.
    pub fn device(&self) -> Option<&DeviceInfo> {
        self.info.as_ref()
    }

    /// Whether the handshake is done and the link not lost.
    pub fn is_open(&self) -> bool {
        self.phase == Phase::Open
    }

    /// Whether the session has ended (link lost or handshake failed).
    pub fn is_closed(&self) -> bool {
        self.phase == Phase::Closed
    }

    /// Whether a request waits for its answer or is queued.
    pub fn is_busy(&self) -> bool {
        self.pending.as_ref().is_some_and(|p| !p.internal) || !self.queue.is_empty()
    }

    /// Counters.
    pub fn stats(&self) -> SessionStats {
        let d = self.decoder.stats();
        SessionStats {
            frames_rx: u64::from(d.frames_ok),
            frames_dropped: u64::from(d.frames_dropped),
            ..self.stats
        }
    }

    /// Queues a request; its answer comes as [`SessionEvent::Reply`] (or `Failed`).
    pub fn request(&mut self, body: RequestBody, now_ms: u64) -> RequestId {
        let Ok(id) = self.admit() else {
            return self.next_id();
        };
        self.queue.push_back((id, body, false));
        self.pump(now_ms);
        id
    }

    /// Queues a request ahead of every other queued one (an abort is never queued behind work).
    /// A request already on the wire is abandoned ([`SessionError::Preempted`]): its answer,
    /// if it comes, is ignored.
    pub fn request_first(&mut self, body: RequestBody, now_ms: u64) -> RequestId {
        let Ok(id) = self.admit() else {
            return self.next_id();
        };
        if self.phase == Phase::Open {
            if let Some(p) = self.pending.take() {
                if !p.internal {
                    self.events.push_back(SessionEvent::Failed {
                        id: p.id,
                        error: SessionError::Preempted { request: p.name },
                    });
                }
            }
        }
        self.queue.push_front((id, body, false));
        self.pump(now_ms);
        id
    }

    /// Bytes received from the device, in any chunking.
    pub fn handle_bytes(&mut self, bytes: &[u8], now_ms: u64) {
        for &b in bytes {
            // A bad frame is counted by the decoder; decoding resumes at the next delimiter.
            if let Some(Ok(msg)) = self.decoder.push::<DeviceMessage>(b) {
                self.last_rx_ms = now_ms;
                self.on_message(msg);
            }
        }
        self.pump(now_ms);
    }

    /// Time has passed: resend, give up or send a heartbeat as due.
    pub fn handle_timeout(&mut self, now_ms: u64) {
        if let Some(p) = &self.pending {
            if now_ms >= p.retry_at_ms {
                let silent = now_ms.saturating_sub(self.last_rx_ms) >= self.timing.silence_ms;
                if p.attempts >= p.max_attempts || silent {
                    let p = self.pending.take().expect("checked above");
                    let error = SessionError::Timeout {
                        request: p.name,
                        attempts: p.attempts,
                        waited_ms: now_ms.saturating_sub(p.first_sent_ms),
                    };
                    if self.phase == Phase::Closing {
                        // An unanswered Close: closed on this side; the link is not "lost",
                        // it was being ended.
                        self.phase = Phase::Closed;
                        self.events
                            .push_back(SessionEvent::Failed { id: p.id, error });
                        return;
                    }
                    self.lose(p, error);
                    return;
                }
                self.resend(now_ms);
            }
        }
        self.pump(now_ms);
    }

    /// The next frame to write to the device.
    pub fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.transmit.pop_front()
    }

    /// When [`Session::handle_timeout`] should be called next.
    pub fn poll_timeout(&self) -> Option<u64> {
        match (&self.pending, self.phase) {
            (Some(p), _) => Some(p.retry_at_ms),
            (None, Phase::Open) if self.keepalive => {
                Some(self.last_tx_ms.saturating_add(self.timing.heartbeat_ms))
            }
            _ => None,
        }
    }

    /// The next thing the owner should know.
    pub fn poll_event(&mut self) -> Option<SessionEvent> {
        self.events.pop_front()
    }

    /// A new request's id; on a closed session the request fails at once (`Err`).
    fn admit(&mut self) -> Result<RequestId, ()> {
        let id = self.alloc_id();
        self.stats.requests += 1;
        if matches!(self.phase, Phase::Closed | Phase::Closing) {
            self.events.push_back(SessionEvent::Failed {
                id,
                error: SessionError::Closed,
            });
            return Err(());
        }
        Ok(id)
    }

    /// The id [`Session::admit`] gave last.
    fn next_id(&self) -> RequestId {
        RequestId(self.next_id)
    }

    fn alloc_id(&mut self) -> RequestId {
        self.next_id += 1;
        RequestId(self.next_id)
    }

    fn lose(&mut self, p: Pending, error: SessionError) {
        let handshake = self.phase == Phase::Handshaking;
        self.phase = Phase::Closed;
        if handshake {
            self.events.push_back(SessionEvent::HandshakeFailed(error));
            return;
        }
        if !p.internal {
            self.events.push_back(SessionEvent::Failed {
                id: p.id,
                error: error.clone(),
            });
        }
        for (id, _, internal) in self.queue.drain(..) {
            if !internal {
                self.events.push_back(SessionEvent::Failed {
                    id,
                    error: SessionError::Closed,
                });
            }
        }
        self.events.push_back(SessionEvent::LinkLost(error));
    }

    fn on_message(&mut self, msg: DeviceMessage) {
        match msg {
            DeviceMessage::Event(ev) => self.events.push_back(SessionEvent::Device(ev)),
            DeviceMessage::Response { seq, result, body } => {
                let Some(p) = self.pending.as_ref().filter(|p| p.seq == seq) else {
                    self.stats.stale_responses += 1;
                    return;
                };
                let p_id = p.id;
                let internal = p.internal;
                let signing_change = p.signing_change;
                self.pending = None;
                if let (Some(change), ResultCode::Ok) = (signing_change, result) {
                    if let Some(key) = change {
                        let counter = self.signing.map_or(1, |(_, c)| c);
                        self.signing = Some((key, counter));
                    }
                    if let Some(info) = self.info.as_mut() {
                        info.signing = change.is_some();
                    }
                }
                let reply = Reply { result, body };
                if self.phase == Phase::Handshaking {
                    self.finish_handshake(reply);
                } else if self.phase == Phase::Closing {
                    // Any answer ends it: Ok, or a refusal that says the session is no longer
                    // ours to close.
                    self.phase = Phase::Closed;
                    self.events
                        .push_back(SessionEvent::Reply { id: p_id, reply });
                } else if !internal {
                    self.events
                        .push_back(SessionEvent::Reply { id: p_id, reply });
                }
            }
        }
    }

    fn finish_handshake(&mut self, reply: Reply) {
        let info = match reply.body {
            ResponseBody::Hello(info) => info,
            other => {
                self.phase = Phase::Closed;
                self.events
                    .push_back(SessionEvent::HandshakeFailed(SessionError::Unexpected {
                        request: "Hello",
                        got: format!("{:?} {other:?}", reply.result),
                    }));
                return;
            }
        };
        // Kept on a refusal too: who refused, with which versions.
        self.info = Some(info.clone());
        // The one rule both sides apply (`protocol::check_hello`); a device that says Ok but
        // differs is still refused.
        if let Err(mismatch) = info.check() {
            self.phase = Phase::Closed;
            self.events.push_back(SessionEvent::HandshakeFailed(
                SessionError::VersionMismatch(mismatch),
            ));
            return;
        }
        if let ResultCode::Rejected(reason) = reply.result {
            self.phase = Phase::Closed;
            self.events
                .push_back(SessionEvent::HandshakeFailed(SessionError::Rejected {
                    request: "Hello",
                    reason,
                    refusal: None,
                }));
            return;
        }
        self.phase = Phase::Open;
        self.session_id = info.session;
        self.events.push_back(SessionEvent::Opened(info));
    }

    /// Sends the next queued request if none waits; a heartbeat when idle for too long.
    fn pump(&mut self, now_ms: u64) {
        if self.pending.is_some()
            || matches!(self.phase, Phase::New | Phase::Closed | Phase::Closing)
        {
            return;
        }
        let next = match self.queue.pop_front() {
            Some(n) => Some(n),
            None if self.keepalive
                && self.phase == Phase::Open
                && now_ms >= self.last_tx_ms.saturating_add(self.timing.heartbeat_ms) =>
            {
                let id = self.alloc_id();
                Some((id, RequestBody::Heartbeat, true))
            }
            None => None,
        };
        let Some((id, body, internal)) = next else {
            return;
        };
        let max_attempts = self.timing.max_attempts;
        self.send_new(id, body, internal, max_attempts, now_ms);
    }

    /// Puts a new request on the wire as the one pending, with the next `seq`.
    fn send_new(
        &mut self,
        id: RequestId,
        body: RequestBody,
        internal: bool,
        max_attempts: u32,
        now_ms: u64,
    ) {
        let seq = self.next_seq;
        self.next_seq = self.next_seq.wrapping_add(1).max(1);
        let name = text::request_name(&body);
        let signing_change = match body {
            RequestBody::SetSigning { key, enabled } => Some(enabled.then_some(key)),
            _ => None,
        };
        let request = Request {
            seq,
            session: self.session_id,
            body,
        };
        // A lone delimiter first closes whatever half frame or noise the device's decoder
        // holds, so a request is never glued to garbage.
        let frame = match self.frame(&request) {
            Ok(frame) => frame,
            Err(_) => {
                self.events.push_back(SessionEvent::Failed {
                    id,
                    error: SessionError::Unexpected {
                        request: name,
                        got: "the request does not fit in one frame".into(),
                    },
                });
                if self.phase == Phase::Closing {
                    self.phase = Phase::Closed;
                }
                return self.pump(now_ms);
            }
        };
        self.pending = Some(Pending {
            id,
            seq,
            name,
            frame,
            attempts: 0,
            max_attempts,
            first_sent_ms: now_ms,
            retry_at_ms: now_ms,
            internal,
            signing_change,
        });
        self.resend(now_ms);
    }

    fn resend(&mut self, now_ms: u64) {
        let Some(p) = self.pending.as_mut() else {
            return;
        };
        if p.attempts > 0 {
            self.stats.retries += 1;
        }
        p.attempts += 1;
        p.retry_at_ms = now_ms + self.timing.request_timeout_ms;
        self.transmit.push_back(p.frame.clone());
        self.stats.frames_tx += 1;
        self.last_tx_ms = now_ms;
    }
}
