//! The wire-error campaign shared by the bench binary (`benches/mutation.rs`, ≥ 10^8 frames)
//! and a 10^6-frame test (`tests/wire/mutation.rs`): real frames of every kind, each hit by
//! 1–4 random bit flips or by a burst error (2–32 bits, first and last flipped, the rest
//! random), fed to a receiver; every message a receiver accepts from a mutated frame is an
//! undetected error. The same mutations are applied to protocol v1's framing (CRC-16/IBM-SDLC)
//! for comparison.
#![allow(dead_code)] // each includer uses a different part

use protocol::*;
use serde::Serialize;

/// Frames and what they decode as.
pub struct Sample {
    /// The v2 frame (COBS, CRC-32), delimiter excluded.
    pub v2: Vec<u8>,
    /// The same payload framed as v1 (COBS, CRC-16), delimiter excluded.
    pub v1: Vec<u8>,
    /// A request (else a device message).
    pub request: bool,
}

fn frames<T: Serialize>(msg: &T, request: bool) -> Sample {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(msg, &mut buf).expect("fits");
    let v2 = buf[..n - 1].to_vec();
    let mut raw = [0u8; MAX_RAW_LEN];
    let payload = postcard::to_slice(msg, &mut raw).expect("fits").to_vec();
    let mut with_crc = payload.clone();
    with_crc.extend(crc16().checksum(&payload).to_le_bytes());
    let mut v1 = vec![0u8; with_crc.len() + with_crc.len() / 254 + 2];
    let m = cobs::try_encode(&with_crc, &mut v1).expect("fits");
    v1.truncate(m);
    Sample { v2, v1, request }
}

fn crc16() -> crc::Crc<u16> {
    crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC)
}

fn st(name: &str) -> geometry::TrunkState {
    name.parse().expect("state")
}

/// Every kind of frame the link carries, short and long.
pub fn samples() -> Vec<Sample> {
    let req = |seq, body| Request {
        seq,
        session: 0x5eed_1234,
        body,
    };
    let step = protocol::transitions::transition(st("D&D"), st("F&D"))
        .expect("edge")
        .step();
    let plan = Plan {
        plan_id: 7,
        steps: heapless::Vec::from_slice(&[
            protocol::transitions::transition(st("F&P"), st("F&F"))
                .expect("edge")
                .step(),
            protocol::transitions::transition(st("F&F"), st("D&F"))
                .expect("edge")
                .step(),
        ])
        .expect("fits"),
    };
    let status = Status {
        state: st("D&F"),
        state_confirmed: false,
        candidates: StateSet::single(st("D&F")).with(st("D&D")),
        interrupted: Some(Transition {
            from: st("D&F"),
            to: st("D&D"),
        }),
        mode: Mode::Safe,
        pressure_kpa: 23.75,
        servo_deg: [90.0, 91.5, 88.25],
        inlet_open: false,
        exhaust_open: false,
        gripper_closed: true,
        estop: false,
        plan: Some(PlanStatus {
            plan_id: 7,
            step: 1,
            steps: 2,
            phase: PlanPhase::Aborted,
        }),
        manual_task: None,
        faults: FaultCode::Leak.bit(),
        frames_rx: 12_345,
        frames_dropped: 3,
        uptime_ms: 987_654,
    };
    vec![
        frames(&req(1, RequestBody::GetStatus), true),
        frames(&req(2, RequestBody::Heartbeat), true),
        frames(&req(3, RequestBody::Abort), true),
        frames(&req(300, RequestBody::DeclareState(st("F&D"))), true),
        frames(&req(301, RequestBody::RunStep(step)), true),
        frames(&req(302, RequestBody::UploadPlan(plan)), true),
        frames(
            &req(
                303,
                RequestBody::SetParam {
                    id: ParamId::PressureLimitKpa,
                    value: 35.0,
                },
            ),
            true,
        ),
        frames(
            &DeviceMessage::Event(Event::Heartbeat {
                uptime_ms: 500,
                mode: Mode::Running,
            }),
            false,
        ),
        frames(
            &DeviceMessage::Event(Event::Telemetry(Telemetry {
                uptime_ms: 61_000,
                pressure_kpa: 12.5,
                servo_deg: [10.0, 12.0, 8.0],
                inlet_open: true,
                exhaust_open: false,
                state: st("F&F"),
                state_confirmed: true,
            })),
            false,
        ),
        frames(
            &DeviceMessage::Response {
                seq: 301,
                result: ResultCode::Ok,
                body: ResponseBody::Status(status),
            },
            false,
        ),
    ]
}

/// xorshift64*: fast, seeded, good enough to place bit errors.
pub struct Rng(u64);

impl Rng {
    /// Seeded (0 is replaced).
    pub fn new(seed: u64) -> Self {
        Self(seed.max(1).wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// Uniform in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        (((self.next_u64() >> 32) * n as u64) >> 32) as usize
    }
}

/// Flips 1–4 distinct random bits of `frame` (returns `true`), or (one time in two) applies a
/// burst of 2–32 bits (returns `false`).
pub fn mutate(frame: &mut [u8], rng: &mut Rng) -> bool {
    let bits = frame.len() * 8;
    if rng.next_u64() & 1 == 0 {
        let k = 1 + rng.below(4);
        let mut chosen = [usize::MAX; 4];
        let mut n = 0;
        while n < k {
            let b = rng.below(bits);
            if !chosen[..n].contains(&b) {
                chosen[n] = b;
                frame[b / 8] ^= 1 << (b % 8);
                n += 1;
            }
        }
        true
    } else {
        let len = (2 + rng.below(31)).min(bits);
        let start = rng.below(bits - len + 1);
        for i in 0..len {
            if i == 0 || i == len - 1 || rng.next_u64() & 1 == 1 {
                let b = start + i;
                frame[b / 8] ^= 1 << (b % 8);
            }
        }
        false
    }
}

/// Whether a receiver accepts any message from the mutated bytes (each zero-delimited segment
/// is one frame, as the streaming decoder sees them; the tests hold it equal to `decode`).
fn accepts_v2(bytes: &[u8], request: bool, scratch: &mut Vec<u8>) -> bool {
    bytes.split(|&b| b == 0).any(|seg| {
        if seg.is_empty() {
            return false;
        }
        scratch.clear();
        scratch.extend_from_slice(seg);
        if request {
            decode::<Request>(scratch).is_ok()
        } else {
            decode::<DeviceMessage>(scratch).is_ok()
        }
    })
}

/// The same for protocol v1's framing (CRC-16/IBM-SDLC, then the v2 message types: the
/// question is only how often the check passes a corrupted payload that still parses).
fn accepts_v1(bytes: &[u8], request: bool, crc: &crc::Crc<u16>, scratch: &mut Vec<u8>) -> bool {
    bytes.split(|&b| b == 0).any(|seg| {
        if seg.is_empty() {
            return false;
        }
        scratch.clear();
        scratch.extend_from_slice(seg);
        let Ok(n) = cobs::decode_in_place(scratch) else {
            return false;
        };
        let Some((payload, check)) = scratch[..n].split_last_chunk::<2>() else {
            return false;
        };
        if payload.is_empty() || crc.checksum(payload).to_le_bytes() != *check {
            return false;
        }
        if request {
            postcard::from_bytes::<Request>(payload).is_ok()
        } else {
            postcard::from_bytes::<DeviceMessage>(payload).is_ok()
        }
    })
}

/// What a campaign found.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Report {
    /// Mutated frames fed.
    pub frames: u64,
    /// Of which by random 1–4-bit errors (the rest by bursts).
    pub bit_error_frames: u64,
    /// Mutated frames from which a v2 receiver accepted a message.
    pub accepted_v2: u64,
    /// The same mutations on v1 frames: accepted by a CRC-16 receiver.
    pub accepted_v1: u64,
}

impl Report {
    /// The sum of two reports.
    pub fn plus(self, o: Report) -> Report {
        Report {
            frames: self.frames + o.frames,
            bit_error_frames: self.bit_error_frames + o.bit_error_frames,
            accepted_v2: self.accepted_v2 + o.accepted_v2,
            accepted_v1: self.accepted_v1 + o.accepted_v1,
        }
    }
}

/// Mutates `frames` frames (cycling through [`samples`]) with `seed`; `v1` also runs the v1
/// comparison.
pub fn campaign(frames: u64, seed: u64, v1: bool) -> Report {
    let samples = samples();
    let crc = crc16();
    let mut rng = Rng::new(seed);
    let mut report = Report::default();
    let mut buf = Vec::with_capacity(MAX_FRAME_LEN);
    let mut scratch = Vec::with_capacity(MAX_FRAME_LEN);
    for i in 0..frames {
        let s = &samples[(i % samples.len() as u64) as usize];
        // The same mutation (same random stream) for both framings.
        let state = Rng(rng.next_u64() | 1);
        buf.clear();
        buf.extend_from_slice(&s.v2);
        let bit_errors = mutate(&mut buf, &mut Rng(state.0));
        report.frames += 1;
        report.bit_error_frames += bit_errors as u64;
        if accepts_v2(&buf, s.request, &mut scratch) {
            report.accepted_v2 += 1;
        }
        if v1 {
            buf.clear();
            buf.extend_from_slice(&s.v1);
            mutate(&mut buf, &mut Rng(state.0));
            if accepts_v1(&buf, s.request, &crc, &mut scratch) {
                report.accepted_v1 += 1;
            }
        }
    }
    report
}
