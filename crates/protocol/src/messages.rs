//! Every message that crosses the serial link.
//!
//! The host sends [`Request`]s; the device answers each with exactly one
//! [`DeviceMessage::Response`] echoing the request's sequence number, and sends
//! [`DeviceMessage::Event`]s unprompted.
//!
//! The schema identity ([`crate::SCHEMA_ID`]) is a hash over these types' *structure* (their
//! `postcard_schema::Schema`: names, fields, variants and their types, in order), not over this
//! file's text: a comment edit keeps it, any change of a type's shape changes it, and a host and
//! device built from different definitions refuse each other at the handshake. Changes must be
//! deliberate: the golden byte tests pin the wire form.

use geometry::TrunkState;
use heapless::Vec;
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// Most steps one uploaded plan may hold (the six-state graph never needs more than five).
pub const MAX_PLAN_STEPS: usize = 8;
/// Most actuation primitives one plan step may hold.
pub const MAX_STEP_PRIMITIVES: usize = 4;

// ---------------------------------------------------------------------------------------------
// Host → device
// ---------------------------------------------------------------------------------------------

/// A request from the host. Every request gets exactly one response with the same `seq`.
///
/// A request repeated with the same `seq` (a retry after a lost response) is not executed twice:
/// the device answers it again with the response it gave the first time.
///
/// `session` binds the request to the handshake that opened it ([`DeviceInfo::session`]):
/// state-changing requests from any other session are refused with
/// [`RejectReason::NotSessionOwner`] (`docs/protocol.md`, "Sessions").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Schema)]
pub struct Request {
    /// Sequence number chosen by the host, echoed in the response.
    pub seq: u16,
    /// The session the device opened at this host's handshake (ignored in a `Hello`; 0 before
    /// one).
    pub session: u32,
    /// What the host asks for.
    pub body: RequestBody,
}

/// What a request asks for.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Schema)]
pub enum RequestBody {
    /// Handshake. The device answers with [`ResponseBody::Hello`] (its versions, board, trunk
    /// configuration and the new session's id); it rejects with
    /// [`RejectReason::VersionMismatch`] when either the protocol version or the schema identity
    /// differs, and with [`RejectReason::SessionBusy`] while another host's session is live and
    /// `takeover` is false, and still includes its own identity.
    Hello {
        /// The host's [`crate::PROTOCOL_VERSION`].
        protocol_version: u16,
        /// The host's [`crate::SCHEMA_ID`].
        schema_id: u32,
        /// Open a new session even while another host's is live (that host's next
        /// state-changing request is refused with [`RejectReason::NotSessionOwner`]).
        takeover: bool,
    },
    /// Ask for a [`Status`] snapshot.
    GetStatus,
    /// The host is alive. While a plan runs, a silent host (no request of any kind for
    /// [`ParamId::LinkTimeoutMs`]) makes the device abort to the safe state.
    Heartbeat,
    /// Upload a whole plan atomically (it replaces any idle plan; rejected while one runs).
    UploadPlan(Plan),
    /// Start the uploaded plan with this id.
    StartPlan {
        /// Must match the uploaded plan's id.
        plan_id: u16,
    },
    /// Run a single step now (as a one-step plan with id 0).
    RunStep(Step),
    /// Abort whatever runs and go to the safe state (not latched, unlike e-stop). Honoured from
    /// anyone, with or without a session.
    Abort,
    /// The operator has done the manual step the device asked for.
    ConfirmManual,
    /// Clear faults whose cause is gone (and the e-stop latch, once the button is released).
    ResetFaults,
    /// Tell the device the trunk's true state (after it was handled by hand, or at first use).
    /// Recorded as confirmed and persisted.
    DeclareState(TrunkState),
    /// Read a parameter.
    GetParam(ParamId),
    /// Write a parameter; rejected with [`RejectReason::OutOfRange`] outside [`ParamId::range`].
    SetParam {
        /// Which parameter.
        id: ParamId,
        /// New value, in the parameter's unit.
        value: f32,
    },
    /// End the caller's session: the crane is free for another host's handshake at once.
    Close,
    /// Identify an unconfirmed trunk state with the crane's own probes ([`ResultCode::InProgress`];
    /// the result shows in [`Status`]'s belief and a [`Event::StateReached`]). Where the sensing
    /// cannot decide, the device narrows the candidates and sends
    /// [`Event::IdentifyNeedsOperator`]: a [`RequestBody::DeclareState`] or the confirm button
    /// on the crane resolves it.
    Identify,
    /// Link signing ([`crate::sign`]): pairs the device with `key` and turns signing on
    /// (`enabled`), or turns it off and forgets the key (`enabled: false`, `key` ignored). The
    /// key is kept in the device's non-volatile store. While signing is off this is the pairing
    /// (over a link the operator trusts: the crane's own cable); while it is on, it must be
    /// signed with the key in force, like every session-bound request. Refused with
    /// [`RejectReason::NotAllowed`] by a build without link signing.
    SetSigning {
        /// The shared key (SipHash-2-4's 128-bit key).
        key: [u8; 16],
        /// Signing on (with `key`) or off.
        enabled: bool,
    },
    /// Stores the identification probe's calibration profile of this crane's trunk in the
    /// device's non-volatile store (`Some`), or erases it (`None`); either takes effect at once
    /// ([`RequestBody::Identify`] decides from a stored profile's signatures, asks the operator
    /// without one). Refused with [`RejectReason::VersionMismatch`] when `schema_id` is not the
    /// device's [`crate::SCHEMA_ID`] (a profile measured with another firmware), with
    /// [`RejectReason::OutOfRange`] and a [`RefusedField::ProbeRate`] refusal when a rate is
    /// outside [`PROBE_RATE_RANGE`] or not finite, [`ResultCode::Busy`] while a plan runs, and
    /// [`RejectReason::NotAllowed`] by a device whose store keeps no profile.
    SetProbeProfile {
        /// The firmware schema the profile was measured with ([`crate::SCHEMA_ID`]).
        schema_id: u32,
        /// The profile, or `None` to erase the stored one.
        profile: Option<ProbeProfile>,
    },
    /// The stored probe profile ([`ResponseBody::ProbeProfile`]; `None`: none stored).
    GetProbeProfile,
}

/// The fill rates (kPa/s) the identification probe measures on one trunk, as a calibration
/// measured them (`docs/firmware.md`, "Identification").
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Schema)]
pub struct ProbeProfile {
    /// Fill rate of each state, by `TrunkState::index` (F&P, F&F, F&D, D&P, D&F, D&D).
    pub states: [f32; 6],
    /// Fill rate of a trunk resting half-packed under the folded top and under the deployed
    /// top.
    pub between: [f32; 2],
}

/// The fill rates a device accepts in a [`ProbeProfile`], kPa/s (inclusive): the probe fills
/// 4 kPa, so 0.5 kPa/s is an 8 s fill (its steps time out first) and 200 kPa/s a fill of 20 ms,
/// one control period's worth of samples.
pub const PROBE_RATE_RANGE: (f32, f32) = (0.5, 200.0);

impl ProbeProfile {
    /// Rate `i`: 0–5 the states', 6–7 the between signatures (NaN past 7).
    pub fn rate(&self, i: usize) -> f32 {
        match i {
            0..=5 => self.states[i],
            6 | 7 => self.between[i - 6],
            _ => f32::NAN,
        }
    }

    /// The first rate outside [`PROBE_RATE_RANGE`] or not finite, with its index
    /// ([`ProbeProfile::rate`]).
    pub fn out_of_range(&self) -> Option<(u8, f32)> {
        let (lo, hi) = PROBE_RATE_RANGE;
        (0..8u8)
            .map(|i| (i, self.rate(i as usize)))
            .find(|&(_, r)| !(r >= lo && r <= hi))
    }
}

/// A plan: steps executed in order, each a transition between trunk states.
///
/// `Deserialize` is written out ([`in_place`]), with the derive's wire form.
#[derive(Debug, Clone, PartialEq, Serialize, Schema)]
pub struct Plan {
    /// Identifier chosen by the host (non-zero; 0 is reserved for [`RequestBody::RunStep`]).
    pub plan_id: u16,
    /// The steps, in order.
    pub steps: Vec<Step, MAX_PLAN_STEPS>,
}

/// One step of a plan: a transition `from` → `to` made by a short sequence of primitives.
///
/// `Deserialize` is written out ([`in_place`]), with the derive's wire form.
#[derive(Debug, Clone, PartialEq, Serialize, Schema)]
pub struct Step {
    /// How the transition is actuated (for people and for reports).
    pub kind: StepKind,
    /// The state the trunk must be in when the step starts (checked by the device).
    pub from: TrunkState,
    /// The state the step should reach, confirmed by the device from its sensors.
    pub to: TrunkState,
    /// What to do, in order.
    pub primitives: Vec<Primitive, MAX_STEP_PRIMITIVES>,
    /// Time limit for the whole step; the device faults with [`FaultCode::StepTimeout`] after it.
    pub timeout_ms: u32,
}

/// `Deserialize` for [`Plan`] and [`Step`] that builds the steps where they will lie.
///
/// Why not the derive: its visitors return every `Step` (~64 bytes) and the steps' `Vec`
/// (~520 bytes) by value through several `Result`/`Option` layers, which the compiler lays out
/// at odd offsets; on the board's Cortex-M4 those unaligned moves were a third of the ≈ 90 000
/// cycles of the loop pass that receives the largest plan (the emulator's pass profile,
/// BENCHMARKS.md). Here each step is deserialised into its slot of the plan's `Vec`, and its
/// primitives (12 bytes each) into its own.
///
/// The wire form is the derive's (a struct is its fields in declaration order, a `heapless::Vec`
/// its length then its elements; a sequence longer than the capacity is an error, as
/// heapless's own `Deserialize` makes it): `tests/wire/in_place.rs` holds it to a derived twin
/// of both types byte for byte, on valid, truncated and mutated input. Only the sequence form
/// is read (postcard's; a self-describing format's map form is refused), which is the only
/// form the protocol uses.
pub mod in_place {
    use super::{Plan, Primitive, Step, StepKind, MAX_PLAN_STEPS, MAX_STEP_PRIMITIVES};
    use core::fmt;
    use geometry::{BottomState, TopState, TrunkState};
    use heapless::Vec;
    use serde::de::{self, DeserializeSeed, Deserializer, SeqAccess, Visitor};
    use serde::Deserialize;

    const PLAN_FIELDS: &[&str] = &["plan_id", "steps"];
    const STEP_FIELDS: &[&str] = &["kind", "from", "to", "primitives", "timeout_ms"];

    /// A slot's content before its step is read in.
    const BLANK: Step = Step {
        kind: StepKind::Manual,
        from: TrunkState::new(TopState::Folded, BottomState::Packed),
        to: TrunkState::new(TopState::Folded, BottomState::Packed),
        primitives: Vec::new(),
        timeout_ms: 0,
    };

    /// The next field of a struct read as a sequence, or the derive's error for a short one.
    fn field<'de, A: SeqAccess<'de>, T: Deserialize<'de>>(
        seq: &mut A,
        index: usize,
        what: &'static str,
    ) -> Result<T, A::Error> {
        seq.next_element()?
            .ok_or_else(|| de::Error::invalid_length(index, &what))
    }

    impl<'de> Deserialize<'de> for Plan {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            let mut plan = Plan {
                plan_id: 0,
                steps: Vec::new(),
            };
            d.deserialize_struct("Plan", PLAN_FIELDS, PlanVisitor(&mut plan))?;
            Ok(plan)
        }
    }

    struct PlanVisitor<'a>(&'a mut Plan);

    impl<'de> Visitor<'de> for PlanVisitor<'_> {
        type Value = ();
        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("struct Plan")
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
            const WHAT: &str = "struct Plan with 2 elements";
            self.0.plan_id = field(&mut seq, 0, WHAT)?;
            seq.next_element_seed(StepsSeed(&mut self.0.steps))?
                .ok_or_else(|| de::Error::invalid_length(1, &WHAT))
        }
    }

    /// The plan's steps, each read into its slot.
    struct StepsSeed<'a>(&'a mut Vec<Step, MAX_PLAN_STEPS>);

    impl<'de> DeserializeSeed<'de> for StepsSeed<'_> {
        type Value = ();
        fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
            d.deserialize_seq(self)
        }
    }

    impl<'de> Visitor<'de> for StepsSeed<'_> {
        type Value = ();
        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("a sequence")
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
            let steps = self.0;
            steps.clear();
            loop {
                if steps.is_full() {
                    // One more is an error, once it has been read (as heapless's visitor).
                    return match seq.next_element::<Step>()? {
                        None => Ok(()),
                        Some(_) => Err(de::Error::invalid_length(
                            MAX_PLAN_STEPS + 1,
                            &"fewer elements in sequence",
                        )),
                    };
                }
                // Cannot fail: not full.
                let _ = steps.push(BLANK);
                let read = match steps.last_mut() {
                    Some(slot) => seq.next_element_seed(StepSeed(slot))?,
                    None => None,
                };
                if read.is_none() {
                    steps.pop();
                    return Ok(());
                }
            }
        }
    }

    impl<'de> Deserialize<'de> for Step {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            let mut step = BLANK;
            StepSeed(&mut step).deserialize(d)?;
            Ok(step)
        }
    }

    /// One step, read into `self.0`.
    struct StepSeed<'a>(&'a mut Step);

    impl<'de> DeserializeSeed<'de> for StepSeed<'_> {
        type Value = ();
        fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
            d.deserialize_struct("Step", STEP_FIELDS, self)
        }
    }

    impl<'de> Visitor<'de> for StepSeed<'_> {
        type Value = ();
        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("struct Step")
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
            const WHAT: &str = "struct Step with 5 elements";
            let step = self.0;
            step.kind = field(&mut seq, 0, WHAT)?;
            step.from = field(&mut seq, 1, WHAT)?;
            step.to = field(&mut seq, 2, WHAT)?;
            seq.next_element_seed(PrimitivesSeed(&mut step.primitives))?
                .ok_or_else(|| de::Error::invalid_length(3, &WHAT))?;
            step.timeout_ms = field(&mut seq, 4, WHAT)?;
            Ok(())
        }
    }

    /// A step's primitives (small and `Copy`: pushed by value).
    struct PrimitivesSeed<'a>(&'a mut Vec<Primitive, MAX_STEP_PRIMITIVES>);

    impl<'de> DeserializeSeed<'de> for PrimitivesSeed<'_> {
        type Value = ();
        fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
            d.deserialize_seq(self)
        }
    }

    impl<'de> Visitor<'de> for PrimitivesSeed<'_> {
        type Value = ();
        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("a sequence")
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
            let prims = self.0;
            prims.clear();
            while let Some(p) = seq.next_element::<Primitive>()? {
                if prims.push(p).is_err() {
                    return Err(de::Error::invalid_length(
                        MAX_STEP_PRIMITIVES + 1,
                        &"fewer elements in sequence",
                    ));
                }
            }
            Ok(())
        }
    }
}

/// How a step is actuated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum StepKind {
    /// Pressurised air lengthens the trunk.
    Pneumatic,
    /// Tendons shorten the trunk.
    Tendon,
    /// A person folds panels by hand.
    Manual,
}

/// An actuation primitive the device executes with its own interlocks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Schema)]
pub enum Primitive {
    /// Raise the pressure toward `pressure_kpa` (closed loop, inlet valve), hold it there with
    /// hysteresis, and finish after `snaps` snap-throughs have been detected (0: finish when the
    /// pressure is reached). Never exceeds the pressure limit.
    Inflate {
        /// Target gauge pressure.
        pressure_kpa: f32,
        /// Snap-throughs to wait for.
        snaps: u8,
    },
    /// Open the exhaust until the pressure is at or below `pressure_kpa`.
    Vent {
        /// Target gauge pressure.
        pressure_kpa: f32,
    },
    /// Pull all three tendons in by up to `length_mm` (slew-limited), finishing after `snaps`
    /// snap-throughs (0: finish at the length).
    TendonPull {
        /// Tendon shortening from slack.
        length_mm: f32,
        /// Snap-throughs to wait for.
        snaps: u8,
    },
    /// Let the tendons out to `length_mm` of shortening (0: fully slack).
    TendonRelease {
        /// Remaining tendon shortening.
        length_mm: f32,
    },
    /// Keep everything as it is for a while.
    Hold {
        /// How long.
        duration_ms: u32,
    },
    /// Wait for one snap-through, with its own time limit.
    WaitSnap {
        /// How long to wait.
        timeout_ms: u32,
    },
    /// Ask a person to do something by hand, and wait for the confirm button or the host.
    Manual(ManualTask),
    /// Open or close the gripper.
    Gripper {
        /// `true` to close.
        close: bool,
    },
    /// Bend a flexible trunk by differential tendon pull (constant-curvature kinematics).
    Bend {
        /// Direction of the bend in the base frame (0° = toward tendon 0).
        direction_deg: f32,
        /// Bend angle of the trunk's tip axis.
        angle_deg: f32,
    },
}

/// What a manual step asks a person to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum ManualTask {
    /// Fold the panels of the bottom module's two lowest units back into self-packing.
    PackBottomModule,
    /// Fold the top module's panels (pop it back from deployed to folded) by hand.
    FoldTopModule,
    /// Fold the bottom module from deployed to folded by hand.
    FoldBottomModule,
}

/// A tunable parameter with a unit and a valid range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum ParamId {
    /// Pressure cap in kPa (configurable up to the hard maximum).
    PressureLimitKpa,
    /// Lowest servo angle, degrees.
    ServoMinDeg,
    /// Highest servo angle, degrees.
    ServoMaxDeg,
    /// Servo slew-rate limit, degrees per second.
    ServoSlewDegPerS,
    /// Telemetry rate in Hz (0: off).
    TelemetryHz,
    /// Host silence that counts as link loss while a plan runs, ms.
    LinkTimeoutMs,
}

impl ParamId {
    /// All parameters.
    pub const ALL: [ParamId; 6] = [
        ParamId::PressureLimitKpa,
        ParamId::ServoMinDeg,
        ParamId::ServoMaxDeg,
        ParamId::ServoSlewDegPerS,
        ParamId::TelemetryHz,
        ParamId::LinkTimeoutMs,
    ];

    /// The inclusive valid range of the parameter's value.
    pub const fn range(self) -> (f32, f32) {
        match self {
            ParamId::PressureLimitKpa => (0.0, crate::HARD_MAX_PRESSURE_KPA),
            ParamId::ServoMinDeg => (0.0, 180.0),
            ParamId::ServoMaxDeg => (0.0, 180.0),
            ParamId::ServoSlewDegPerS => (1.0, 600.0),
            ParamId::TelemetryHz => (0.0, 50.0),
            ParamId::LinkTimeoutMs => (200.0, 60_000.0),
        }
    }

    /// Whether the parameter takes whole numbers only (`link-timeout-ms`: a fraction would be
    /// truncated by the device, so it is refused).
    pub const fn is_integer(self) -> bool {
        matches!(self, ParamId::LinkTimeoutMs)
    }

    /// Whether `value` is finite, within [`ParamId::range`] and, for an integer parameter,
    /// whole.
    pub fn accepts(self, value: f32) -> bool {
        let (lo, hi) = self.range();
        value.is_finite()
            && value >= lo
            && value <= hi
            && (!self.is_integer() || value as u32 as f32 == value)
    }
}

// ---------------------------------------------------------------------------------------------
// Device → host
// ---------------------------------------------------------------------------------------------

/// A message from the device.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Schema)]
pub enum DeviceMessage {
    /// The one answer to the request with sequence number `seq`.
    Response {
        /// The request's sequence number.
        seq: u16,
        /// Outcome.
        result: ResultCode,
        /// Data, when the request asks for some.
        body: ResponseBody,
    },
    /// Sent unprompted.
    Event(Event),
}

/// Outcome of a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum ResultCode {
    /// Done.
    Ok,
    /// Refused; nothing changed.
    Rejected(RejectReason),
    /// The device is busy with something that must finish first (e.g. a running plan).
    Busy,
    /// Accepted and started; completion is reported by events and status.
    InProgress,
}

/// Why a request was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum RejectReason {
    /// Protocol version or schema identity differ (the response carries the device's).
    VersionMismatch,
    /// No successful handshake yet on this link.
    NoHandshake,
    /// The e-stop is latched.
    EStopLatched,
    /// A fault is active; reset it first.
    Faulted,
    /// The plan is empty, too long, or its steps do not chain (`to` of one ≠ `from` of next).
    InvalidPlan,
    /// No uploaded plan has this id.
    UnknownPlan,
    /// The step's `from` is not the device's current (confirmed) state.
    WrongState,
    /// A value is out of range or not finite.
    OutOfRange,
    /// There is no manual step waiting for confirmation.
    NoManualPending,
    /// The request is not allowed now (e.g. `ResetFaults` with the e-stop still pressed).
    NotAllowed,
    /// The request's `session` is not the device's current one (another host took over, or the
    /// device restarted): handshake again.
    NotSessionOwner,
    /// Another host's session is live; a `Hello` with `takeover: true` takes the crane over.
    SessionBusy,
    /// The trunk state is unconfirmed, so a step's `from` cannot be vouched for: identify first.
    Unconfirmed,
    /// Link signing is on ([`DeviceInfo::signing`]) and this session-bound request (`Close`
    /// excepted) carries no valid signature: none, or a counter not above the last one accepted (a replay).
    /// A frame signed with another key does not decode at all (dropped).
    Unsigned,
}

/// Data carried by a response.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Schema)]
pub enum ResponseBody {
    /// No data.
    None,
    /// The device's identity, answering [`RequestBody::Hello`] (also on a version mismatch).
    Hello(DeviceInfo),
    /// A status snapshot.
    Status(Status),
    /// A parameter's current value.
    Param {
        /// Which parameter.
        id: ParamId,
        /// Its value.
        value: f32,
    },
    /// With a `Rejected` result: the field the refusal is about, what the request asks for and
    /// the limit it passes.
    Refused(Refusal),
    /// The stored probe profile, answering [`RequestBody::GetProbeProfile`] (`None`: none).
    ProbeProfile(Option<ProbeProfile>),
}

/// What a refusal is about: the field, the value asked for and the limit it passes, both in
/// the field's unit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Schema)]
pub struct Refusal {
    /// The plan step (0-based) the refused value belongs to; `None` outside a plan.
    pub step: Option<u8>,
    /// The field.
    pub field: RefusedField,
    /// The value the request asks for.
    pub value: f32,
    /// The limit it passes (a maximum, or for [`RefusedField::Param`] below its range the
    /// minimum).
    pub limit: f32,
}

/// The field a [`Refusal`] names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum RefusedField {
    /// A step's pressure (kPa) against the pressure limit ([`ParamId::PressureLimitKpa`]).
    Pressure,
    /// A tendon length (mm) against the tendons' reach: their travel within the servo limits
    /// ([`ParamId::ServoMinDeg`], [`ParamId::ServoMaxDeg`]).
    TendonLength,
    /// A bend angle (deg) against the largest bend that fits from the step's state.
    BendAngle,
    /// A step's time limit or a hold (ms) against the longest accepted.
    Duration,
    /// A parameter's value against its range or the parameter it must not pass.
    Param(ParamId),
    /// The plan's number of steps against the most a plan holds (`value` 0: empty or not
    /// chained).
    Steps,
    /// A probe profile's rate (kPa/s; the index, 0–5 a state's and 6–7 a between signature's)
    /// against [`PROBE_RATE_RANGE`] (`limit` the bound it passes; NaN passes the maximum).
    ProbeRate(u8),
}

/// Who the device is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Schema)]
pub struct DeviceInfo {
    /// The device's [`crate::PROTOCOL_VERSION`].
    pub protocol_version: u16,
    /// The device's [`crate::SCHEMA_ID`].
    pub schema_id: u32,
    /// Firmware version, `[major, minor, patch]`.
    pub firmware_version: [u8; 3],
    /// The board it runs on.
    pub board: Board,
    /// The trunk it drives.
    pub trunk: TrunkConfig,
    /// The session this handshake opened (new per boot and per handshake; put it in every
    /// later [`Request::session`]). On a refused handshake, the session in force (0: none).
    pub session: u32,
    /// Why the device last started.
    pub reset_cause: ResetCause,
    /// Link signing is on: every session-bound request but `Close` must be signed
    /// ([`crate::sign`]).
    pub signing: bool,
}

/// Why the device last started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum ResetCause {
    /// Power was applied (or the simulator's power was cycled).
    PowerOn,
    /// The watchdog restarted it (the Watchdog fault is raised too).
    Watchdog,
    /// The supply dipped below the brown-out threshold.
    BrownOut,
    /// A software reset.
    Software,
    /// The board could not tell.
    Unknown,
}

/// A set of trunk states, one bit per [`TrunkState::index`] (bit 0 = `F&P` … bit 5 = `D&D`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, Schema)]
pub struct StateSet(pub u8);

impl StateSet {
    /// No state.
    pub const EMPTY: StateSet = StateSet(0);
    /// All six states.
    pub const ALL: StateSet = StateSet(0b11_1111);

    /// The set holding only `s`.
    pub const fn single(s: TrunkState) -> StateSet {
        StateSet(1 << s.index())
    }

    /// This set with `s` added.
    pub const fn with(self, s: TrunkState) -> StateSet {
        StateSet(self.0 | (1 << s.index()))
    }

    /// Whether `s` is in the set.
    pub const fn contains(self, s: TrunkState) -> bool {
        self.0 & (1 << s.index()) != 0
    }

    /// The states in both sets.
    pub const fn intersect(self, other: StateSet) -> StateSet {
        StateSet(self.0 & other.0 & Self::ALL.0)
    }

    /// The states in either set.
    pub const fn union(self, other: StateSet) -> StateSet {
        StateSet((self.0 | other.0) & Self::ALL.0)
    }

    /// How many states (bits above bit 5 do not count).
    pub const fn len(self) -> u32 {
        (self.0 & Self::ALL.0).count_ones()
    }

    /// No state.
    pub const fn is_empty(self) -> bool {
        self.len() == 0
    }

    /// The one state, when the set holds exactly one.
    pub fn only(self) -> Option<TrunkState> {
        if self.len() == 1 {
            TrunkState::from_index((self.0 & Self::ALL.0).trailing_zeros() as usize)
        } else {
            None
        }
    }

    /// The states, in [`TrunkState::ALL`] order.
    pub fn iter(self) -> impl Iterator<Item = TrunkState> {
        TrunkState::ALL
            .into_iter()
            .filter(move |s| self.contains(*s))
    }
}

/// A transition between two trunk states (`from` → `to`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub struct Transition {
    /// Where it started.
    pub from: TrunkState,
    /// Where it was going.
    pub to: TrunkState,
}

/// Hardware the firmware runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum Board {
    /// Arduino UNO R4 WiFi (host link through the ESP32-S3 USB bridge).
    UnoR4Wifi,
    /// Arduino UNO R4 Minima.
    UnoR4Minima,
    /// The hil-sim simulator.
    Simulator,
}

/// The trunk configuration the device is built for.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Schema)]
pub struct TrunkConfig {
    /// The bottom module.
    pub bottom: ModuleConfig,
    /// The top module.
    pub top: ModuleConfig,
    /// Current pressure cap.
    pub pressure_limit_kpa: f32,
}

/// One module of the trunk.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Schema)]
pub struct ModuleConfig {
    /// Polygon sides.
    pub n: u8,
    /// Fold angle β.
    pub beta_deg: f32,
    /// Valley-fold (polygon edge) length.
    pub edge_mm: f32,
    /// Number of unit layers stacked in the module.
    pub layers: u8,
}

/// What the device is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum Mode {
    /// Standalone: joystick and buttons drive the crane; no plan.
    Standalone,
    /// A plan (or single step) is running.
    Running,
    /// A plan waits for a person to do a manual step.
    WaitingManual,
    /// Safe state after a fault or abort; actuators frozen/closed.
    Safe,
    /// E-stop latched.
    EStop,
}

/// Snapshot of the device.
///
/// The belief: `state_confirmed` says whether `state` is known (sensors, a confirmed step, the
/// operator or the host said so). When it is not, `state` is only the last confirmed state,
/// `candidates` the states the trunk may be in, and `interrupted` the step that was under way
/// when confidence was lost; plan steps are refused ([`RejectReason::Unconfirmed`]) until the
/// state is identified or declared (`docs/firmware.md`, "What a state report means").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Schema)]
pub struct Status {
    /// The confirmed state, or (unconfirmed) the last confirmed one.
    pub state: TrunkState,
    /// Whether `state` is confirmed (sensors, a confirmed step, the operator or the host).
    pub state_confirmed: bool,
    /// The states the trunk may be in: exactly `{state}` when confirmed.
    pub candidates: StateSet,
    /// The step that was under way when confidence was lost (`None` when confirmed, or when
    /// nothing was moving).
    pub interrupted: Option<Transition>,
    /// What the device is doing.
    pub mode: Mode,
    /// Measured gauge pressure.
    pub pressure_kpa: f32,
    /// Commanded servo angles of the three tendon servos.
    pub servo_deg: [f32; 3],
    /// Inlet valve open.
    pub inlet_open: bool,
    /// Exhaust valve open.
    pub exhaust_open: bool,
    /// Gripper closed.
    pub gripper_closed: bool,
    /// E-stop latched.
    pub estop: bool,
    /// The active (or last) plan.
    pub plan: Option<PlanStatus>,
    /// The task a manual step waits for a person to do (`None` when none waits).
    pub manual_task: Option<ManualTask>,
    /// Active faults, one bit per [`FaultCode`] (`1 << code as u16`).
    pub faults: u16,
    /// Frames received and decoded.
    pub frames_rx: u32,
    /// Frames dropped (corrupt, oversized, undecodable).
    pub frames_dropped: u32,
    /// Device uptime.
    pub uptime_ms: u32,
}

/// Progress of the active or last plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub struct PlanStatus {
    /// Its id.
    pub plan_id: u16,
    /// Index of the step running now (or the last one run).
    pub step: u8,
    /// Steps in the plan.
    pub steps: u8,
    /// Where it is.
    pub phase: PlanPhase,
}

/// Phase of a plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum PlanPhase {
    /// Uploaded, not started.
    Ready,
    /// Executing `step`.
    Running,
    /// Waiting for a manual step's confirmation.
    WaitingManual,
    /// All steps done; the target state is confirmed.
    Done,
    /// Stopped by a fault at `step`.
    Failed(FaultCode),
    /// Aborted by the host or a button.
    Aborted,
}

/// Every fault the device can raise. Each has a code (its discriminant), an event and a
/// display message (`E-xx`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[repr(u8)]
pub enum FaultCode {
    /// Pressure above the cap: vented immediately.
    OverPressure = 1,
    /// The pressure sensor reads out of range or stopped changing when it must.
    PressureSensor = 2,
    /// A step exceeded its time limit.
    StepTimeout = 3,
    /// A step ended but its transition was not confirmed by the sensors.
    TransitionNotConfirmed = 4,
    /// No host heartbeat while a plan ran.
    LinkLoss = 5,
    /// The e-stop button was pressed.
    EStop = 6,
    /// A servo command was outside the configured limits (clamped; step aborted).
    ServoLimit = 7,
    /// Pressure decays faster than the trunk's leak allowance with valves closed, or it stalls
    /// well above ambient while inflating with the inlet open (the supply cannot beat the leak).
    Leak = 8,
    /// The board restarted through its watchdog.
    Watchdog = 9,
    /// The persisted state could not be read; the state is unconfirmed.
    StateStorage = 10,
    /// The pressure rises (or will not vent) with the inlet commanded closed: the inlet valve
    /// is stuck open. The exhaust stays open.
    InletStuck = 11,
    /// The pressure stays at ambient while inflating with the inlet open: the supply is off or
    /// the inlet valve is stuck closed.
    NoPressureRise = 12,
}

impl FaultCode {
    /// All faults.
    pub const ALL: [FaultCode; 12] = [
        FaultCode::OverPressure,
        FaultCode::PressureSensor,
        FaultCode::StepTimeout,
        FaultCode::TransitionNotConfirmed,
        FaultCode::LinkLoss,
        FaultCode::EStop,
        FaultCode::ServoLimit,
        FaultCode::Leak,
        FaultCode::Watchdog,
        FaultCode::StateStorage,
        FaultCode::InletStuck,
        FaultCode::NoPressureRise,
    ];

    /// The numeric code shown on the display as `E-xx`.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The bit of this fault in [`Status::faults`].
    pub const fn bit(self) -> u16 {
        1 << (self as u16)
    }

    /// A short human description.
    pub const fn description(self) -> &'static str {
        match self {
            FaultCode::OverPressure => "pressure above the limit; vented",
            FaultCode::PressureSensor => "pressure sensor out of range or not responding",
            FaultCode::StepTimeout => "step exceeded its time limit",
            FaultCode::TransitionNotConfirmed => "transition not confirmed by the sensors",
            FaultCode::LinkLoss => "host link lost during a plan",
            FaultCode::EStop => "emergency stop pressed",
            FaultCode::ServoLimit => "servo command outside its limits",
            FaultCode::Leak => "pressure leak: it stalls while inflating or falls while sealed",
            FaultCode::Watchdog => "restarted by the watchdog",
            FaultCode::StateStorage => "stored trunk state unreadable",
            FaultCode::InletStuck => "inlet stuck open: pressure rises with it closed",
            FaultCode::NoPressureRise => {
                "no pressure rise with the inlet open: supply off or inlet stuck closed"
            }
        }
    }
}

/// A message the device sends unprompted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Schema)]
pub enum Event {
    /// Sent every [`crate::HEARTBEAT_PERIOD_MS`].
    Heartbeat {
        /// Device uptime.
        uptime_ms: u32,
        /// Current mode.
        mode: Mode,
    },
    /// Sent at the requested telemetry rate.
    Telemetry(Telemetry),
    /// A step is running (sent with telemetry, at most every 100 ms).
    StepProgress {
        /// Plan id.
        plan_id: u16,
        /// Step index.
        step: u8,
        /// Index of the primitive running within the step.
        primitive: u8,
        /// Time since the step started.
        elapsed_ms: u32,
    },
    /// A step finished.
    StepDone {
        /// Plan id.
        plan_id: u16,
        /// Step index.
        step: u8,
        /// `true` when its target state was confirmed.
        ok: bool,
        /// The state the device now believes.
        state: TrunkState,
        /// How long the step took.
        duration_ms: u32,
    },
    /// The whole plan finished.
    PlanDone {
        /// Plan id.
        plan_id: u16,
        /// `true` when every step succeeded.
        ok: bool,
        /// Final state.
        state: TrunkState,
    },
    /// The trunk's state changed (confirmed from sensors or declared).
    StateReached {
        /// The new state.
        state: TrunkState,
        /// Whether it was confirmed.
        confirmed: bool,
    },
    /// A manual step needs a person; confirm with the button or [`RequestBody::ConfirmManual`].
    ManualRequired {
        /// Plan id.
        plan_id: u16,
        /// Step index.
        step: u8,
        /// What to do.
        task: ManualTask,
    },
    /// A fault became active.
    FaultRaised(FaultCode),
    /// A fault was cleared.
    FaultCleared(FaultCode),
    /// Identification could not tell these states apart with the crane's sensors: a person
    /// must say which it is (the confirm button on the crane accepts the one shown, or the
    /// host sends [`RequestBody::DeclareState`]).
    IdentifyNeedsOperator {
        /// The states still possible.
        candidates: StateSet,
    },
}

/// Periodic measurements.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Schema)]
pub struct Telemetry {
    /// Device uptime.
    pub uptime_ms: u32,
    /// Measured gauge pressure.
    pub pressure_kpa: f32,
    /// Commanded servo angles.
    pub servo_deg: [f32; 3],
    /// Inlet valve open.
    pub inlet_open: bool,
    /// Exhaust valve open.
    pub exhaust_open: bool,
    /// Current state (the confirmed one, or the last confirmed one).
    pub state: TrunkState,
    /// Whether `state` is confirmed.
    pub state_confirmed: bool,
}
