//! The wire form written out by hand for the two directions the device speaks: it reads
//! [`Request`]s ([`Request::decode_into`]) and writes [`DeviceMessage`]s
//! ([`DeviceMessage::encode`]), byte for byte as postcard with the serde derives does (the
//! host keeps postcard and serde for everything).
//!
//! Why: on the board's Cortex-M4 the serde visitors and serialisers of the message types,
//! monomorphised for postcard, were ≈ 5 KB of the image (this codec is ≈ 3 KB: 1.6 KiB saved),
//! and at `opt-level = "z"` (the size the 40 KiB budget needs) deserialising the largest plan
//! through them made a 95 000-cycle loop pass, 41 000 here (BENCHMARKS.md, "firmware board").
//! A plan is read straight into its slots.
//!
//! The postcard wire form (postcard 1.x, its specification "wire format"): a struct or tuple is
//! its fields in order; `u8` one byte; `u16`/`u32`/`usize` an unsigned LEB128 varint (at most
//! 3/5/5 or 10 bytes, the last one's unused high bits zero; non-shortest forms are accepted);
//! `f32` four bytes little-endian; `bool` one byte 0 or 1; `Option` a byte 0 or 1 then the
//! value; an enum its variant index (0-based, in declaration order, not its discriminant) as a
//! varint `u32`, then the variant's fields; a `heapless::Vec` its length (`usize`) then its
//! elements, longer than its capacity being an error. `tests/wire/codec.rs` holds both
//! directions to postcard on every message the property strategies make and on mutated
//! bytes.

use geometry::{BottomState, TopState, TrunkState};
use heapless::Vec;

use crate::messages::*;

/// Bytes that are not a valid message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Invalid;

/// The result of reading one value.
pub type Read<T> = Result<T, Invalid>;

/// Reads postcard values from the front of a byte slice.
#[derive(Debug, Clone)]
pub struct Reader<'a> {
    rest: &'a [u8],
}

/// (most bytes, largest last byte) of a `usize` varint on this target, as postcard reads it.
const USIZE_VARINT: (u32, u8) = if usize::BITS == 64 { (10, 1) } else { (5, 15) };

impl<'a> Reader<'a> {
    /// A reader over `bytes`.
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { rest: bytes }
    }

    /// The bytes not read yet.
    pub fn rest(&self) -> &'a [u8] {
        self.rest
    }

    /// `SetSigning`'s fields (out of line: rare, and the board pays for it in flash).
    #[inline(never)]
    fn set_signing_into(&mut self, body: &mut RequestBody) -> Read<()> {
        let (key, rest) = self.rest.split_first_chunk::<16>().ok_or(Invalid)?;
        self.rest = rest;
        let enabled = self.bool()?;
        *body = RequestBody::SetSigning { key: *key, enabled };
        Ok(())
    }

    /// `SetProbeProfile`'s fields (out of line, like `SetSigning`'s).
    #[inline(never)]
    fn set_probe_profile_into(&mut self, body: &mut RequestBody) -> Read<()> {
        let schema_id = self.u32()?;
        let profile = if self.bool()? {
            let (b, rest) = self.rest.split_first_chunk::<32>().ok_or(Invalid)?;
            self.rest = rest;
            let r =
                |i: usize| f32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]]);
            Some(ProbeProfile {
                states: [r(0), r(1), r(2), r(3), r(4), r(5)],
                between: [r(6), r(7)],
            })
        } else {
            None
        };
        *body = RequestBody::SetProbeProfile { schema_id, profile };
        Ok(())
    }

    /// One byte (a `u8`).
    #[inline(always)]
    pub fn byte(&mut self) -> Read<u8> {
        let (&b, rest) = self.rest.split_first().ok_or(Invalid)?;
        self.rest = rest;
        Ok(b)
    }

    /// A varint of at most `MAX` bytes whose last byte is at most `LAST`; a value that does
    /// not fit 32 bits (only a 64-bit `usize`'s) reads as `u32::MAX`. Most are one byte
    /// (indices, lengths, small values): that case is inlined.
    #[inline(always)]
    fn varint<const MAX: u32, const LAST: u8>(&mut self) -> Read<u32> {
        match self.rest.split_first() {
            Some((&b, rest)) if b < 0x80 => {
                self.rest = rest;
                Ok(u32::from(b))
            }
            _ => self.long_varint::<MAX, LAST>(),
        }
    }

    /// [`Reader::varint`] of more than one byte (or none left).
    #[inline(never)]
    fn long_varint<const MAX: u32, const LAST: u8>(&mut self) -> Read<u32> {
        let mut out = 0u32;
        // Bits at 2^32 and above (a 64-bit `usize` only).
        let mut wide = 0u32;
        for i in 0..MAX {
            let b = self.byte()?;
            let carry = u32::from(b & 0x7F);
            match i {
                0..=3 => out |= carry << (7 * i),
                4 => {
                    out |= carry << 28;
                    wide |= carry >> 4;
                }
                _ => wide |= carry,
            }
            if b < 0x80 {
                if i == MAX - 1 && b > LAST {
                    return Err(Invalid);
                }
                return Ok(if wide != 0 { u32::MAX } else { out });
            }
        }
        Err(Invalid)
    }

    /// A `u16`.
    #[inline(never)]
    pub fn u16(&mut self) -> Read<u16> {
        self.varint::<3, 3>().map(|v| v as u16)
    }

    /// A `u32`.
    #[inline(never)]
    pub fn u32(&mut self) -> Read<u32> {
        self.varint::<5, 15>()
    }

    /// A sequence length (`usize`), saturated to `u32::MAX`.
    #[inline(always)]
    pub fn seq_len(&mut self) -> Read<u32> {
        self.varint::<{ USIZE_VARINT.0 }, { USIZE_VARINT.1 }>()
    }

    /// A variant index below `variants`.
    #[inline(never)]
    pub fn variant(&mut self, variants: u32) -> Read<u32> {
        self.hot_variant(variants)
    }

    /// [`Reader::variant`] inlined, for the reads a plan repeats (per step and per primitive).
    #[inline(always)]
    fn hot_variant(&mut self, variants: u32) -> Read<u32> {
        match self.varint::<5, 15>()? {
            i if i < variants => Ok(i),
            _ => Err(Invalid),
        }
    }

    /// An `f32`.
    #[inline(always)]
    pub fn f32(&mut self) -> Read<f32> {
        let (b, rest) = self.rest.split_first_chunk::<4>().ok_or(Invalid)?;
        self.rest = rest;
        Ok(f32::from_le_bytes(*b))
    }

    /// A `bool`.
    pub fn bool(&mut self) -> Read<bool> {
        match self.byte()? {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(Invalid),
        }
    }

    /// A [`TrunkState`].
    pub fn trunk_state(&mut self) -> Read<TrunkState> {
        let top = match self.hot_variant(2)? {
            0 => TopState::Folded,
            _ => TopState::Deployed,
        };
        let bottom = match self.hot_variant(3)? {
            0 => BottomState::Packed,
            1 => BottomState::Folded,
            _ => BottomState::Deployed,
        };
        Ok(TrunkState::new(top, bottom))
    }

    fn manual_task(&mut self) -> Read<ManualTask> {
        Ok(match self.variant(3)? {
            0 => ManualTask::PackBottomModule,
            1 => ManualTask::FoldTopModule,
            _ => ManualTask::FoldBottomModule,
        })
    }

    fn param_id(&mut self) -> Read<ParamId> {
        ParamId::ALL
            .get(self.variant(ParamId::ALL.len() as u32)? as usize)
            .copied()
            .ok_or(Invalid)
    }

    fn primitive(&mut self) -> Read<Primitive> {
        Ok(match self.hot_variant(9)? {
            0 => Primitive::Inflate {
                pressure_kpa: self.f32()?,
                snaps: self.byte()?,
            },
            1 => Primitive::Vent {
                pressure_kpa: self.f32()?,
            },
            2 => Primitive::TendonPull {
                length_mm: self.f32()?,
                snaps: self.byte()?,
            },
            3 => Primitive::TendonRelease {
                length_mm: self.f32()?,
            },
            4 => Primitive::Hold {
                duration_ms: self.u32()?,
            },
            5 => Primitive::WaitSnap {
                timeout_ms: self.u32()?,
            },
            6 => Primitive::Manual(self.manual_task()?),
            7 => Primitive::Gripper {
                close: self.bool()?,
            },
            _ => Primitive::Bend {
                direction_deg: self.f32()?,
                angle_deg: self.f32()?,
            },
        })
    }

    /// A sequence length that fits `capacity`.
    fn len_within(&mut self, capacity: usize) -> Read<usize> {
        match self.seq_len()? as usize {
            n if n <= capacity => Ok(n),
            _ => Err(Invalid),
        }
    }

    /// A [`Step`], read into `step`.
    pub fn step_into(&mut self, step: &mut Step) -> Read<()> {
        step.kind = match self.hot_variant(3)? {
            0 => StepKind::Pneumatic,
            1 => StepKind::Tendon,
            _ => StepKind::Manual,
        };
        step.from = self.trunk_state()?;
        step.to = self.trunk_state()?;
        step.primitives.clear();
        for _ in 0..self.len_within(MAX_STEP_PRIMITIVES)? {
            let p = self.primitive()?;
            step.primitives.push(p).map_err(|_| Invalid)?;
        }
        step.timeout_ms = self.u32()?;
        Ok(())
    }

    /// A [`Plan`], read into `plan` (each step into its slot).
    pub fn plan_into(&mut self, plan: &mut Plan) -> Read<()> {
        plan.plan_id = self.u16()?;
        plan.steps.clear();
        for _ in 0..self.len_within(MAX_PLAN_STEPS)? {
            plan.steps.push(BLANK_STEP).map_err(|_| Invalid)?;
            let slot = plan.steps.last_mut().ok_or(Invalid)?;
            self.step_into(slot)?;
        }
        Ok(())
    }
}

/// A step slot's content before it is read.
const BLANK_STEP: Step = Step {
    kind: StepKind::Manual,
    from: TrunkState::new(TopState::Folded, BottomState::Packed),
    to: TrunkState::new(TopState::Folded, BottomState::Packed),
    primitives: Vec::new(),
    timeout_ms: 0,
};

impl Request {
    /// An empty request to read into ([`Request::decode_into`]). A function, not a `const`:
    /// a const of this ~540-byte type is stored whole in flash and copied at each use.
    pub fn blank() -> Request {
        Request {
            seq: 0,
            session: 0,
            body: RequestBody::GetStatus,
        }
    }

    /// Reads a request into `self` (a plan or a step into the slots already there when `self`
    /// holds one); on `Err` `self` is left partly written. Bytes after the request are left in
    /// `r` (a frame must have none: [`crate::FrameDecoder::push_into`] checks).
    pub fn decode_into(&mut self, r: &mut Reader<'_>) -> Read<()> {
        self.seq = r.u16()?;
        self.session = r.u32()?;
        let body = &mut self.body;
        match r.variant(17)? {
            0 => {
                *body = RequestBody::Hello {
                    protocol_version: r.u16()?,
                    schema_id: r.u32()?,
                    takeover: r.bool()?,
                }
            }
            1 => *body = RequestBody::GetStatus,
            2 => *body = RequestBody::Heartbeat,
            3 => {
                if !matches!(body, RequestBody::UploadPlan(_)) {
                    *body = RequestBody::UploadPlan(Plan {
                        plan_id: 0,
                        steps: Vec::new(),
                    });
                }
                if let RequestBody::UploadPlan(plan) = body {
                    r.plan_into(plan)?;
                }
            }
            4 => *body = RequestBody::StartPlan { plan_id: r.u16()? },
            5 => {
                if !matches!(body, RequestBody::RunStep(_)) {
                    *body = RequestBody::RunStep(BLANK_STEP);
                }
                if let RequestBody::RunStep(step) = body {
                    r.step_into(step)?;
                }
            }
            6 => *body = RequestBody::Abort,
            7 => *body = RequestBody::ConfirmManual,
            8 => *body = RequestBody::ResetFaults,
            9 => *body = RequestBody::DeclareState(r.trunk_state()?),
            10 => *body = RequestBody::GetParam(r.param_id()?),
            11 => {
                *body = RequestBody::SetParam {
                    id: r.param_id()?,
                    value: r.f32()?,
                }
            }
            12 => *body = RequestBody::Close,
            13 => *body = RequestBody::Identify,
            14 => r.set_signing_into(body)?,
            15 => r.set_probe_profile_into(body)?,
            _ => *body = RequestBody::GetProbeProfile,
        }
        Ok(())
    }
}

/// Writes postcard values into a byte buffer; a value that does not fit sets [`Writer::full`]
/// (and the rest is not written).
#[derive(Debug)]
pub struct Writer<'a> {
    buf: &'a mut [u8],
    len: usize,
    full: bool,
}

impl<'a> Writer<'a> {
    /// A writer filling `buf` from its start.
    pub fn new(buf: &'a mut [u8]) -> Self {
        Self {
            buf,
            len: 0,
            full: false,
        }
    }

    /// Bytes written, or `None` when something did not fit.
    pub fn written(&self) -> Option<usize> {
        (!self.full).then_some(self.len)
    }

    /// One byte (a `u8`).
    #[inline(never)]
    pub fn byte(&mut self, b: u8) {
        match self.buf.get_mut(self.len) {
            Some(slot) => {
                *slot = b;
                self.len += 1;
            }
            None => self.full = true,
        }
    }

    /// A varint (`u16`, `u32`, `usize` and variant indices: the shortest form).
    #[inline(never)]
    pub fn varint(&mut self, mut v: u32) {
        while v >= 0x80 {
            self.byte(v as u8 | 0x80);
            v >>= 7;
        }
        self.byte(v as u8);
    }

    /// Bytes as they are.
    #[inline(never)]
    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.byte(b);
        }
    }

    /// An `f32`.
    pub fn f32(&mut self, v: f32) {
        self.bytes(&v.to_le_bytes());
    }

    /// A `bool`.
    pub fn bool(&mut self, v: bool) {
        self.byte(u8::from(v));
    }

    /// An `Option`'s tag: whether a value follows.
    fn some(&mut self, present: bool) {
        self.bool(present);
    }

    /// A [`TrunkState`].
    pub fn trunk_state(&mut self, s: TrunkState) {
        self.varint(s.top as u32);
        self.varint(s.bottom as u32);
    }

    fn fault(&mut self, f: FaultCode) {
        // The variant index, not the display code (which starts at 1).
        self.varint(u32::from(f.code()) - 1);
    }

    fn servo_deg(&mut self, deg: &[f32; 3]) {
        for &d in deg {
            self.f32(d);
        }
    }

    fn module(&mut self, m: &ModuleConfig) {
        self.byte(m.n);
        self.f32(m.beta_deg);
        self.f32(m.edge_mm);
        self.byte(m.layers);
    }

    fn device_info(&mut self, d: &DeviceInfo) {
        self.varint(u32::from(d.protocol_version));
        self.varint(d.schema_id);
        self.bytes(&d.firmware_version);
        self.varint(d.board as u32);
        self.module(&d.trunk.bottom);
        self.module(&d.trunk.top);
        self.f32(d.trunk.pressure_limit_kpa);
        self.varint(d.session);
        self.varint(d.reset_cause as u32);
        self.bool(d.signing);
    }

    fn status(&mut self, s: &Status) {
        self.trunk_state(s.state);
        self.bool(s.state_confirmed);
        self.byte(s.candidates.0);
        self.some(s.interrupted.is_some());
        if let Some(t) = s.interrupted {
            self.trunk_state(t.from);
            self.trunk_state(t.to);
        }
        self.varint(s.mode as u32);
        self.f32(s.pressure_kpa);
        self.servo_deg(&s.servo_deg);
        self.bool(s.inlet_open);
        self.bool(s.exhaust_open);
        self.bool(s.gripper_closed);
        self.bool(s.estop);
        self.some(s.plan.is_some());
        if let Some(p) = s.plan {
            self.varint(u32::from(p.plan_id));
            self.byte(p.step);
            self.byte(p.steps);
            match p.phase {
                PlanPhase::Ready => self.varint(0),
                PlanPhase::Running => self.varint(1),
                PlanPhase::WaitingManual => self.varint(2),
                PlanPhase::Done => self.varint(3),
                PlanPhase::Failed(f) => {
                    self.varint(4);
                    self.fault(f);
                }
                PlanPhase::Aborted => self.varint(5),
            }
        }
        self.some(s.manual_task.is_some());
        if let Some(t) = s.manual_task {
            self.varint(t as u32);
        }
        self.varint(u32::from(s.faults));
        self.varint(s.frames_rx);
        self.varint(s.frames_dropped);
        self.varint(s.uptime_ms);
    }

    fn result(&mut self, r: ResultCode) {
        match r {
            ResultCode::Ok => self.varint(0),
            ResultCode::Rejected(why) => {
                self.varint(1);
                self.varint(why as u32);
            }
            ResultCode::Busy => self.varint(2),
            ResultCode::InProgress => self.varint(3),
        }
    }

    fn response_body(&mut self, b: &ResponseBody) {
        match b {
            ResponseBody::None => self.varint(0),
            ResponseBody::Hello(info) => {
                self.varint(1);
                self.device_info(info);
            }
            ResponseBody::Status(s) => {
                self.varint(2);
                self.status(s);
            }
            ResponseBody::Param { id, value } => {
                self.varint(3);
                self.varint(*id as u32);
                self.f32(*value);
            }
            ResponseBody::Refused(r) => {
                self.varint(4);
                self.some(r.step.is_some());
                if let Some(step) = r.step {
                    self.byte(step);
                }
                match r.field {
                    RefusedField::Pressure => self.varint(0),
                    RefusedField::TendonLength => self.varint(1),
                    RefusedField::BendAngle => self.varint(2),
                    RefusedField::Duration => self.varint(3),
                    RefusedField::Param(id) => {
                        self.varint(4);
                        self.varint(id as u32);
                    }
                    RefusedField::Steps => self.varint(5),
                    RefusedField::ProbeRate(i) => {
                        self.varint(6);
                        self.byte(i);
                    }
                }
                self.f32(r.value);
                self.f32(r.limit);
            }
            ResponseBody::ProbeProfile(p) => {
                self.varint(5);
                self.some(p.is_some());
                if let Some(p) = p {
                    for i in 0..8 {
                        self.f32(p.rate(i));
                    }
                }
            }
        }
    }

    fn event(&mut self, e: &Event) {
        match e {
            Event::Heartbeat { uptime_ms, mode } => {
                self.varint(0);
                self.varint(*uptime_ms);
                self.varint(*mode as u32);
            }
            Event::Telemetry(t) => {
                self.varint(1);
                self.varint(t.uptime_ms);
                self.f32(t.pressure_kpa);
                self.servo_deg(&t.servo_deg);
                self.bool(t.inlet_open);
                self.bool(t.exhaust_open);
                self.trunk_state(t.state);
                self.bool(t.state_confirmed);
            }
            Event::StepProgress {
                plan_id,
                step,
                primitive,
                elapsed_ms,
            } => {
                self.varint(2);
                self.varint(u32::from(*plan_id));
                self.byte(*step);
                self.byte(*primitive);
                self.varint(*elapsed_ms);
            }
            Event::StepDone {
                plan_id,
                step,
                ok,
                state,
                duration_ms,
            } => {
                self.varint(3);
                self.varint(u32::from(*plan_id));
                self.byte(*step);
                self.bool(*ok);
                self.trunk_state(*state);
                self.varint(*duration_ms);
            }
            Event::PlanDone { plan_id, ok, state } => {
                self.varint(4);
                self.varint(u32::from(*plan_id));
                self.bool(*ok);
                self.trunk_state(*state);
            }
            Event::StateReached { state, confirmed } => {
                self.varint(5);
                self.trunk_state(*state);
                self.bool(*confirmed);
            }
            Event::ManualRequired {
                plan_id,
                step,
                task,
            } => {
                self.varint(6);
                self.varint(u32::from(*plan_id));
                self.byte(*step);
                self.varint(*task as u32);
            }
            Event::FaultRaised(f) => {
                self.varint(7);
                self.fault(*f);
            }
            Event::FaultCleared(f) => {
                self.varint(8);
                self.fault(*f);
            }
            Event::IdentifyNeedsOperator { candidates } => {
                self.varint(9);
                self.byte(candidates.0);
            }
        }
    }
}

impl DeviceMessage {
    /// Writes the message's postcard bytes.
    pub fn encode(&self, w: &mut Writer<'_>) {
        match self {
            DeviceMessage::Response { seq, result, body } => {
                w.varint(0);
                w.varint(u32::from(*seq));
                w.result(*result);
                w.response_body(body);
            }
            DeviceMessage::Event(e) => {
                w.varint(1);
                w.event(e);
            }
        }
    }
}

/// Protocol v1's `Hello` (`Request { seq, Hello { protocol_version, schema_id } }`, no
/// session) read from the front of `payload`, as postcard's `from_bytes` reads it (bytes after
/// it are ignored): its `seq`.
pub(crate) fn v1_hello_seq(payload: &[u8]) -> Option<u16> {
    let mut r = Reader::new(payload);
    let seq = r.u16().ok()?;
    // `Hello` is v1's `RequestBody`'s only variant the device knows.
    r.variant(1).ok()?;
    r.u16().ok()?;
    r.u32().ok()?;
    Some(seq)
}

/// Protocol v1's refusal of a `Hello`: `Response { seq, Rejected(VersionMismatch),
/// Hello(v1 DeviceInfo) }`, v1's `DeviceInfo` being v2's without `session` and `reset_cause`.
pub(crate) fn v1_refusal(w: &mut Writer<'_>, seq: u16, info: &DeviceInfo) {
    w.varint(0); // Response
    w.varint(u32::from(seq));
    w.varint(1); // Rejected
    w.varint(0); // VersionMismatch
    w.varint(1); // Hello
    w.varint(u32::from(info.protocol_version));
    w.varint(info.schema_id);
    w.bytes(&info.firmware_version);
    w.varint(info.board as u32);
    w.module(&info.trunk.bottom);
    w.module(&info.trunk.top);
    w.f32(info.trunk.pressure_limit_kpa);
}
