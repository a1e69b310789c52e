//! Protocol requests: one response each, echoing `seq`.

use geometry::TrunkState;
use heapless::Vec;
use protocol::{
    DeviceInfo, DeviceMessage, ParamId, Plan, PlanPhase, PlanStatus, Primitive, Refusal,
    RefusedField, RejectReason, Request, RequestBody, ResponseBody, ResultCode, Step,
    MAX_FRAME_LEN, PROTOCOL_VERSION, SCHEMA_ID,
};

use super::link::Fingerprint;

use super::exec::Origin;
use super::link;
use super::{max_bend_deg, stiff_bend_limit_rad, Controller};

/// Longest step time limit accepted (one hour).
pub const MAX_STEP_TIMEOUT_MS: u32 = 3_600_000;

type Answer = (ResultCode, ResponseBody);

fn ok() -> Answer {
    (ResultCode::Ok, ResponseBody::None)
}

fn reject(r: RejectReason) -> Answer {
    (ResultCode::Rejected(r), ResponseBody::None)
}

/// A refusal, naming its field when it is about one.
type Refused = (RejectReason, Option<Refusal>);

/// The answer to a refused request.
fn refused((r, detail): Refused) -> Answer {
    (
        ResultCode::Rejected(r),
        detail.map_or(ResponseBody::None, ResponseBody::Refused),
    )
}

/// A refusal naming its field: `value` asked for, `limit` passed.
fn refuse(
    r: RejectReason,
    step: Option<u8>,
    field: RefusedField,
    value: f32,
    limit: f32,
) -> Refused {
    (
        r,
        Some(Refusal {
            step,
            field,
            value,
            limit,
        }),
    )
}

/// A field's value and the limit it passes.
type Passed = (RefusedField, f32, f32);

impl Controller {
    /// A decoded request (`req` is the decoder's slot: an uploaded plan is moved out of it, not
    /// copied).
    pub(super) fn on_request(&mut self, req: &mut Request, fingerprint: u32) {
        // Only the session owner's requests keep the link alive (a stranger's status polls
        // must not hide the owner's silence from the link watch).
        if self.link.session != 0 && req.session == self.link.session {
            self.link.last_rx_ms = self.now_ms;
        }
        self.link.entropy = Fingerprint(self.link.entropy ^ fingerprint)
            .with(self.now_ms as u8)
            .0;
        if let Some(frame) = self.cache.lookup(req.seq, fingerprint) {
            // A retry of the request just answered: the same answer, not a second execution.
            let mut copy = [0u8; link::CACHE_LEN];
            let n = frame.len();
            copy[..n].copy_from_slice(frame);
            self.tx.push_frame(&copy[..n], 0);
            return;
        }
        self.defer_events = true;
        let (result, body) = self.dispatch(req);
        self.defer_events = false;
        let msg = DeviceMessage::Response {
            seq: req.seq,
            result,
            body,
        };
        // Responses fit the cache-sized scratch (a status is under 100 bytes); the full-size
        // buffer is only a fallback, so no request can go unanswered.
        let mut scratch = [0u8; link::CACHE_LEN];
        if let Ok(n) = protocol::encode_device_message(&msg, &mut scratch) {
            self.answer(req.seq, fingerprint, &scratch[..n]);
        } else {
            let mut big = [0u8; MAX_FRAME_LEN];
            let n = link::encode(&msg, &mut big);
            self.answer(req.seq, fingerprint, &big[..n]);
        }
        // Events caused by the request follow its response.
        let deferred = core::mem::take(&mut self.deferred);
        for ev in deferred {
            self.emit(ev);
        }
        self.update_outputs();
    }

    /// Sends the response `frame` to the request `(seq, fingerprint)`, and keeps it for a retry.
    #[inline(never)]
    fn answer(&mut self, seq: u16, fingerprint: u32, frame: &[u8]) {
        self.cache.store(seq, fingerprint, frame);
        self.tx.push_frame(frame, 0);
    }

    /// A protocol-v1 frame: a v1 host's Hello gets v1's refusal with this device's versions
    /// (`protocol::legacy`), so the old host says which versions differ instead of "no
    /// answer"; anything else of v1 is dropped.
    pub(super) fn on_v1_frame(&mut self) {
        let info = self.device_info(0);
        let mut out = [0u8; link::CACHE_LEN];
        if let Some(n) =
            protocol::legacy::refuse_v1_hello(self.decoder.last_frame(), &info, &mut out)
        {
            self.tx.push_frame(&out[..n], 0);
        }
    }

    /// The device's identity; `session` is the one just opened (0 on a refused handshake:
    /// the session in force is never told to a stranger).
    fn device_info(&self, session: u32) -> DeviceInfo {
        DeviceInfo {
            protocol_version: PROTOCOL_VERSION,
            schema_id: SCHEMA_ID,
            firmware_version: self.cfg.firmware_version,
            board: self.cfg.board,
            trunk: self.cfg.geometry.trunk(self.cfg.pressure_limit_kpa),
            session,
            reset_cause: self.link.reset_cause,
            signing: self.signing(),
        }
    }

    /// While signing is on, a session-bound request must carry a valid signature whose counter
    /// rises above the last accepted (a replayed frame does not).
    #[cfg(feature = "link-signing")]
    fn signature_ok(&mut self) -> bool {
        if self.signing.key.is_none() {
            return true;
        }
        match self.decoder.signed_counter() {
            Some(c) if c > self.signing.last_counter => {
                self.signing.last_counter = c;
                true
            }
            _ => false,
        }
    }

    #[cfg(not(feature = "link-signing"))]
    #[inline(always)]
    fn signature_ok(&mut self) -> bool {
        true
    }

    /// Pairs (a key, signing on) or unpairs (signing off, the key forgotten).
    #[cfg(feature = "link-signing")]
    fn set_signing(&mut self, key: &protocol::sign::LinkKey, enabled: bool) -> Answer {
        if !self.signing.store_keeps_key {
            return reject(RejectReason::NotAllowed);
        }
        if enabled && key.iter().all(|&b| b == 0) {
            return reject(RejectReason::OutOfRange);
        }
        let key = enabled.then_some(*key);
        self.signing.key = key;
        self.signing.to_store = Some(key);
        self.decoder.set_key(key.as_ref());
        ok()
    }

    #[cfg(not(feature = "link-signing"))]
    fn set_signing(&mut self, _key: &[u8; 16], _enabled: bool) -> Answer {
        reject(RejectReason::NotAllowed)
    }

    /// Stores (or erases) the probe profile: in force at once, persisted by the shell.
    #[inline(never)]
    fn set_probe_profile_request(
        &mut self,
        schema_id: u32,
        profile: &Option<protocol::ProbeProfile>,
    ) -> Answer {
        if self.exec.is_some() {
            return (ResultCode::Busy, ResponseBody::None);
        }
        if !self.ident.store_keeps_profile {
            return reject(RejectReason::NotAllowed);
        }
        if schema_id != protocol::SCHEMA_ID {
            return reject(RejectReason::VersionMismatch);
        }
        if let Some((i, rate)) = profile.as_ref().and_then(|p| p.out_of_range()) {
            let (lo, hi) = protocol::PROBE_RATE_RANGE;
            let limit = if rate < lo { lo } else { hi };
            return refused(refuse(
                RejectReason::OutOfRange,
                None,
                RefusedField::ProbeRate(i),
                rate,
                limit,
            ));
        }
        self.cfg.probe_profile = *profile;
        self.ident.profile_to_store = Some(*profile);
        ok()
    }

    /// Whether the session's owner was heard within the link timeout.
    fn owner_live(&self) -> bool {
        self.link.session != 0
            && self.now_ms.saturating_sub(self.link.last_rx_ms) < self.cfg.link_timeout_ms as u64
    }

    /// A new session id: never 0, never the one it replaces; unpredictable to another host
    /// (mixed from the sensor noise and the arrival times of every frame since boot, and
    /// whatever the shell added with [`Controller::add_entropy`]).
    fn next_session_id(&mut self) -> u32 {
        self.link.opened = self.link.opened.wrapping_add(1);
        let mut h = Fingerprint(self.link.entropy);
        for b in (self.now_ms as u32)
            .to_le_bytes()
            .into_iter()
            .chain(self.link.opened.to_le_bytes())
        {
            h = h.with(b);
        }
        // A final avalanche (lowbias32), so ids of consecutive handshakes share no bits.
        let mut x = h.0;
        x ^= x >> 16;
        x = x.wrapping_mul(0x7feb_352d);
        x ^= x >> 15;
        x = x.wrapping_mul(0x846c_a68b);
        x ^= x >> 16;
        if x == 0 || x == self.link.session {
            x = x.wrapping_add(0x9e37_79b9) | 1;
        }
        x
    }

    fn hello(&mut self, protocol_version: u16, schema_id: u32, takeover: bool) -> Answer {
        // The one rule both sides apply (the host engine on the answer's `DeviceInfo`).
        if protocol::check_hello(protocol_version, schema_id).is_err() {
            let info = ResponseBody::Hello(self.device_info(0));
            return (ResultCode::Rejected(RejectReason::VersionMismatch), info);
        }
        if self.owner_live() && !takeover {
            let info = ResponseBody::Hello(self.device_info(0));
            return (ResultCode::Rejected(RejectReason::SessionBusy), info);
        }
        let first = !self.link.handshake;
        self.link.handshake = true;
        self.link.session = self.next_session_id();
        self.link.last_rx_ms = self.now_ms;
        if first {
            self.periodic.next_heartbeat_ms = self.now_ms;
            self.periodic.next_telemetry_ms = self.now_ms;
        }
        (
            ResultCode::Ok,
            ResponseBody::Hello(self.device_info(self.link.session)),
        )
    }

    // Requests are borrowed, not moved: a plan is ~600 bytes and every move is a memcpy on the M4.
    fn dispatch(&mut self, req: &mut Request) -> Answer {
        let session = req.session;
        let body = &mut req.body;
        if let RequestBody::Hello {
            protocol_version,
            schema_id,
            takeover,
        } = *body
        {
            return self.hello(protocol_version, schema_id, takeover);
        }
        if let RequestBody::Abort = body {
            // From anyone, with or without a session: stopping is always allowed.
            self.enter_safe(PlanPhase::Aborted);
            return ok();
        }
        if !self.link.handshake {
            return reject(RejectReason::NoHandshake);
        }
        if body.needs_session() && (self.link.session == 0 || session != self.link.session) {
            return reject(RejectReason::NotSessionOwner);
        }
        // `Close` stays unsigned: it only ends the session, as an unsigned `Hello` with
        // `takeover` does, and a host without the key must still be able to let go.
        if body.needs_session() && !matches!(body, RequestBody::Close) && !self.signature_ok() {
            return reject(RejectReason::Unsigned);
        }
        match *body {
            RequestBody::Hello { .. } | RequestBody::Abort => ok(), // handled above
            RequestBody::Close => {
                self.link.session = 0;
                ok()
            }
            RequestBody::Identify => self.identify(),
            RequestBody::SetSigning { ref key, enabled } => self.set_signing(key, enabled),
            RequestBody::SetProbeProfile {
                schema_id,
                ref profile,
            } => self.set_probe_profile_request(schema_id, profile),
            RequestBody::GetProbeProfile => (
                ResultCode::Ok,
                ResponseBody::ProbeProfile(self.cfg.probe_profile),
            ),
            RequestBody::GetStatus => (ResultCode::Ok, ResponseBody::Status(self.status())),
            RequestBody::Heartbeat => ok(),
            RequestBody::UploadPlan(ref mut plan) => self.upload(plan),
            RequestBody::StartPlan { plan_id } => self.start_uploaded(plan_id),
            RequestBody::RunStep(ref step) => self.run_step(step),
            RequestBody::ConfirmManual => {
                if self
                    .exec
                    .as_mut()
                    .is_some_and(super::exec::Exec::confirm_manual)
                {
                    self.advance_exec();
                    ok()
                } else {
                    reject(RejectReason::NoManualPending)
                }
            }
            RequestBody::ResetFaults => {
                if self.panel.buttons.estop {
                    return reject(RejectReason::NotAllowed);
                }
                if self.reset_faults() {
                    ok()
                } else {
                    reject(RejectReason::NotAllowed)
                }
            }
            RequestBody::DeclareState(state) => {
                if self.exec.is_some() {
                    return (ResultCode::Busy, ResponseBody::None);
                }
                self.declare(state);
                ok()
            }
            RequestBody::GetParam(id) => (
                ResultCode::Ok,
                ResponseBody::Param {
                    id,
                    value: self.param(id),
                },
            ),
            RequestBody::SetParam { id, value } => self.set_param(id, value),
        }
    }

    /// Why a plan cannot start now, if it cannot.
    fn start_blocker(&self) -> Option<Answer> {
        if self.exec.is_some() {
            return Some((ResultCode::Busy, ResponseBody::None));
        }
        if self.safety.estop_latched {
            return Some(reject(RejectReason::EStopLatched));
        }
        if self.safety.faults != 0 {
            return Some(reject(RejectReason::Faulted));
        }
        None
    }

    /// Checks a plan's shape and values; `Err` is the rejection (naming the step and the
    /// field where a value is refused).
    fn validate(&self, steps: &[Step]) -> Result<(), Refused> {
        let shape = |i: usize| {
            refuse(
                RejectReason::InvalidPlan,
                Some(i as u8),
                RefusedField::Steps,
                steps.len() as f32,
                protocol::MAX_PLAN_STEPS as f32,
            )
        };
        if steps.is_empty() {
            return Err(shape(0));
        }
        for (i, w) in steps.windows(2).enumerate() {
            if w[0].to != w[1].from {
                return Err(shape(i + 1));
            }
        }
        for (i, s) in steps.iter().enumerate() {
            if s.primitives.is_empty() {
                return Err(shape(i));
            }
            let passed = if s.timeout_ms == 0 || s.timeout_ms > MAX_STEP_TIMEOUT_MS {
                Err((
                    RefusedField::Duration,
                    s.timeout_ms as f32,
                    MAX_STEP_TIMEOUT_MS as f32,
                ))
            } else {
                s.primitives
                    .iter()
                    .try_for_each(|p| self.primitive_in_range(p, s.from))
            };
            if let Err((field, value, limit)) = passed {
                return Err(refuse(
                    RejectReason::OutOfRange,
                    Some(i as u8),
                    field,
                    value,
                    limit,
                ));
            }
        }
        // Letting the air out changes no state, nor does the probe's fill (under a third of the
        // lowest snap: `protocol::probe`): a single step within the state of vents, holds and
        // fills to at most the probe's pressure without snaps is allowed when the state is not
        // confirmed too (the host lets out air left sealed in the trunk before it identifies
        // it; a calibration probes a trunk the person holds between states).
        let harmless = steps.len() == 1
            && steps[0].from == steps[0].to
            && steps[0].primitives.iter().all(|p| match *p {
                Primitive::Vent { .. } | Primitive::Hold { .. } => true,
                Primitive::Inflate {
                    pressure_kpa,
                    snaps,
                } => snaps == 0 && pressure_kpa <= protocol::probe::PROBE_KPA,
                _ => false,
            });
        if !self.confirmed() && !harmless {
            return Err((RejectReason::Unconfirmed, None));
        }
        if steps[0].from != self.state() {
            return Err((RejectReason::WrongState, None));
        }
        Ok(())
    }

    /// A tendon length (the same on all three) against the travel and the servo limits.
    fn tendon_in_range(&self, length_mm: f32) -> Result<(), Passed> {
        // The fast check first (two comparisons: the upload of a whole plan fits one loop
        // pass); the field is worked out only for a refusal.
        if self.equal_pull_allowed(length_mm) {
            return Ok(());
        }
        // The reach: the travel within the servo limits.
        let (lo, hi) = self.pull_range_mm;
        let limit = if length_mm < lo { lo } else { hi };
        Err((RefusedField::TendonLength, length_mm, limit))
    }

    /// Whether `p`'s values fit, for a step that starts in `from`; `Err` names the field.
    fn primitive_in_range(&self, p: &Primitive, from: TrunkState) -> Result<(), Passed> {
        let limit = self.cfg.pressure_limit_kpa;
        let pressure = |kpa: f32| {
            if kpa.is_finite() && kpa >= 0.0 && kpa <= limit {
                Ok(())
            } else {
                Err((RefusedField::Pressure, kpa, limit))
            }
        };
        let duration = |ms: u32, zero_ok: bool| {
            if (zero_ok || ms > 0) && ms <= MAX_STEP_TIMEOUT_MS {
                Ok(())
            } else {
                Err((
                    RefusedField::Duration,
                    ms as f32,
                    MAX_STEP_TIMEOUT_MS as f32,
                ))
            }
        };
        match *p {
            Primitive::Inflate { pressure_kpa, .. } => pressure(pressure_kpa),
            Primitive::Vent { pressure_kpa } => pressure(pressure_kpa),
            Primitive::TendonPull { length_mm, .. } | Primitive::TendonRelease { length_mm } => {
                self.tendon_in_range(length_mm)
            }
            Primitive::Hold { duration_ms } => duration(duration_ms, true),
            Primitive::WaitSnap { timeout_ms } => duration(timeout_ms, false),
            Primitive::Manual(_) | Primitive::Gripper { .. } => Ok(()),
            Primitive::Bend {
                direction_deg,
                angle_deg,
            } => {
                // The bend runs around `from`'s taken-up slack (`bend_lengths`), so a bend that
                // cannot fit there is refused now, not as a `ServoLimit` mid-plan. Conservative
                // and cheap (no trigonometry: the upload of a full plan of bends must fit in
                // one loop pass): the most any tendon is pulled by a bend of θ is take-up +
                // r_t·θ, whatever the direction.
                let take_up_mm = self.take_up_for(from);
                let worst_mm =
                    take_up_mm + self.cfg.geometry.tendon_radius_mm * angle_deg.to_radians();
                let stiff_rad =
                    stiff_bend_limit_rad(&self.cfg, take_up_mm, max_bend_deg(&self.cfg, from));
                if !(direction_deg.is_finite()
                    && angle_deg.is_finite()
                    && (0.0..=180.0).contains(&angle_deg)
                    && !stiff_rad.is_some_and(|limit_rad| angle_deg.to_radians() > limit_rad))
                {
                    let stiff = stiff_rad.map_or(180.0, f32::to_degrees).min(180.0);
                    return Err((RefusedField::BendAngle, angle_deg, stiff));
                }
                self.tendon_in_range(worst_mm)
            }
        }
    }

    fn upload(&mut self, plan: &mut Plan) -> Answer {
        if self.exec.is_some() {
            return (ResultCode::Busy, ResponseBody::None);
        }
        if plan.plan_id == 0 || plan.plan_id == super::identify::IDENTIFY_PLAN_ID {
            return reject(RejectReason::InvalidPlan);
        }
        if let Err(r) = self.validate(&plan.steps) {
            return refused(r);
        }
        self.plan_status = Some(PlanStatus {
            plan_id: plan.plan_id,
            step: 0,
            steps: plan.steps.len() as u8,
            phase: PlanPhase::Ready,
        });
        // Moved out of the request's slot (its steps are the next frame's to overwrite): a
        // clone cost ≈ 2 000 cycles of the upload's pass (`Step::clone`).
        let empty = Plan {
            plan_id: 0,
            steps: Vec::new(),
        };
        self.uploaded = Some(core::mem::replace(plan, empty));
        ok()
    }

    fn start_uploaded(&mut self, plan_id: u16) -> Answer {
        if let Some(b) = self.start_blocker() {
            return b;
        }
        let Some(plan) = self.uploaded.as_ref().filter(|p| p.plan_id == plan_id) else {
            return reject(RejectReason::UnknownPlan);
        };
        // The state may have changed since the upload (a button step, a declared state).
        if let Err(r) = self.validate(&plan.steps) {
            return refused(r);
        }
        let plan = plan.clone();
        self.start_exec(plan, Origin::Host);
        (ResultCode::InProgress, ResponseBody::None)
    }

    /// Identification of an unconfirmed state: `Ok` when there is nothing to identify; else
    /// the device asks the operator ([`protocol::Event::IdentifyNeedsOperator`]).
    fn identify(&mut self) -> Answer {
        if self.exec.is_some() {
            return (ResultCode::Busy, ResponseBody::None);
        }
        if self.confirmed() {
            return ok();
        }
        if self.safety.estop_latched {
            return reject(RejectReason::EStopLatched);
        }
        if self.safety.faults != 0 || !self.pressure_valid() || self.cfg.probe_profile.is_none() {
            // No probing with a fault active (reset it first, or a person tells), nor without a
            // profile of this trunk (the probe's readings then say nothing about it).
            self.ask_operator();
        } else {
            self.start_identify();
        }
        (ResultCode::InProgress, ResponseBody::None)
    }

    fn run_step(&mut self, step: &Step) -> Answer {
        if let Some(b) = self.start_blocker() {
            return b;
        }
        if let Err(r) = self.validate(core::slice::from_ref(step)) {
            return refused(r);
        }
        let mut steps = Vec::new();
        let _ = steps.push(step.clone());
        self.start_exec(Plan { plan_id: 0, steps }, Origin::Host);
        (ResultCode::InProgress, ResponseBody::None)
    }

    fn param(&self, id: ParamId) -> f32 {
        match id {
            ParamId::PressureLimitKpa => self.cfg.pressure_limit_kpa,
            ParamId::ServoMinDeg => self.cfg.servo.min_deg,
            ParamId::ServoMaxDeg => self.cfg.servo.max_deg,
            ParamId::ServoSlewDegPerS => self.cfg.servo.slew_deg_per_s,
            ParamId::TelemetryHz => self.cfg.telemetry_hz,
            ParamId::LinkTimeoutMs => self.cfg.link_timeout_ms as f32,
        }
    }

    fn set_param(&mut self, id: ParamId, value: f32) -> Answer {
        let passes = |limit: f32| {
            refused(refuse(
                RejectReason::OutOfRange,
                None,
                RefusedField::Param(id),
                value,
                limit,
            ))
        };
        if !id.accepts(value) {
            let (lo, hi) = id.range();
            return passes(if value < lo {
                lo
            } else if value > hi || !value.is_finite() {
                hi
            } else {
                value as u32 as f32
            });
        }
        match id {
            ParamId::PressureLimitKpa => {
                self.cfg.pressure_limit_kpa = value;
            }
            ParamId::ServoMinDeg => {
                if value > self.cfg.servo.max_deg {
                    return passes(self.cfg.servo.max_deg);
                }
                self.cfg.servo.min_deg = value;
                self.pull_range_mm = super::equal_pull_range(&self.cfg);
            }
            ParamId::ServoMaxDeg => {
                if value < self.cfg.servo.min_deg {
                    return passes(self.cfg.servo.min_deg);
                }
                self.cfg.servo.max_deg = value;
                self.pull_range_mm = super::equal_pull_range(&self.cfg);
            }
            ParamId::ServoSlewDegPerS => self.cfg.servo.slew_deg_per_s = value,
            ParamId::TelemetryHz => {
                self.cfg.telemetry_hz = value;
                self.periodic.next_telemetry_ms = self.now_ms;
            }
            ParamId::LinkTimeoutMs => self.cfg.link_timeout_ms = value as u32,
        }
        (
            ResultCode::Ok,
            ResponseBody::Param {
                id,
                value: self.param(id),
            },
        )
    }
}
