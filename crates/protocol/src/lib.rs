//! The serial protocol of the Yoshimura crane: the one place where wire types live.
//!
//! Host tool, firmware and simulator all import these types; nothing else defines a message.
//! The full description (message table, timing, retry policy, measured sizes) is
//! `docs/protocol.md`.
//!
//! # Map
//!
//! - [`messages`]: every message host and device exchange. The host sends a [`Request`]
//!   (`seq` + [`RequestBody`]); the device answers each with exactly one
//!   [`DeviceMessage::Response`] echoing `seq`, and sends [`DeviceMessage::Event`]s unprompted.
//!   Every request carries the `session` its handshake opened; state-changing requests from
//!   another session are refused ([`RejectReason::NotSessionOwner`]).
//! - [`frame`]: framing — `COBS(postcard ‖ CRC-32) ‖ 0x00` — with [`encode`], a one-shot
//!   [`decode`] and the streaming [`FrameDecoder`] (byte by byte or chunk by chunk), which
//!   counts and drops bad frames and resynchronises at the next delimiter.
//! - Versioning: [`PROTOCOL_VERSION`] and [`SCHEMA_ID`] are exchanged in the handshake
//!   ([`RequestBody::Hello`] / [`DeviceInfo`]); [`check_hello`] is the one comparison both
//!   sides use, and a peer with different values is refused. [`SCHEMA_ID`] is derived from the
//!   message types' structure ([`schema_hash`] over their `postcard_schema::Schema`), so a
//!   comment edit keeps it and a change of any field, variant or type changes it.
//! - Timing: [`HEARTBEAT_PERIOD_MS`], [`HOST_HEARTBEAT_PERIOD_MS`],
//!   [`DEFAULT_LINK_TIMEOUT_MS`], [`RESPONSE_TIMEOUT_MS`], [`MAX_RETRIES`].
//! - [`transitions`]: the nominal trunk transition catalogue (owned by the simulator's
//!   calibration; shared so planner, firmware and simulator agree).
//! - [`crane`]: the crane's shape as host and controller both model it ([`CraneGeometry`]:
//!   modules, tendons, winches, bend limits per state); plain data, not on the wire.
//!
//! # What this crate must not do
//!
//! - No I/O, no clock, no allocation, no `std`: it builds for `thumbv7em-none-eabihf`.
//! - No panic on any input: every byte sequence fed to the decoder yields a message, a counted
//!   drop or nothing (property tests and the `fuzz/` target hold it to that).
//! - No strings in errors: [`FrameError`] and [`VersionMismatch`] are small `Copy` values;
//!   turning them into sentences is the host tool's job.
//! - No silent format change: golden byte tests in `tests/wire/golden.rs` pin every message.
//!
//! # Example
//!
//! ```
//! use protocol::{encode, FrameDecoder, Request, RequestBody, MAX_FRAME_LEN};
//!
//! let req = Request { seq: 1, session: 0, body: RequestBody::GetStatus };
//! let mut frame = [0u8; MAX_FRAME_LEN];
//! let n = encode(&req, &mut frame).unwrap();
//! assert_eq!(frame[n - 1], 0x00); // the delimiter
//!
//! // The receiver sees the bytes in whatever chunks the serial port delivers.
//! let mut dec = FrameDecoder::new();
//! let (a, b) = frame[..n].split_at(2);
//! assert_eq!(dec.feed::<Request>(a).count(), 0);
//! let got: Vec<_> = dec.feed::<Request>(b).collect();
//! assert_eq!(got, vec![Ok(req)]);
//! assert_eq!(dec.stats().frames_ok, 1);
//! ```
#![forbid(unsafe_code)]
#![no_std]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]
// Wire types are plain values: no `Box` in no_std, and a large request (`UploadPlan`) is built
// once per send, so the size difference between variants costs nothing that matters.
#![allow(clippy::large_enum_variant)]
// `transitions.rs` (owned by the simulator engineer) checks its constant ordering with plain
// `assert!` in its tests; remove this once those become `const { assert!(..) }`.
#![cfg_attr(test, allow(clippy::assertions_on_constants))]

pub mod codec;
pub mod crane;
pub mod frame;
pub mod legacy;
pub mod messages;
pub mod probe;
pub mod sign;
pub mod transitions;

pub use crane::{CraneGeometry, WinchConfig, DEFAULT_VENT_TOLERANCE_KPA};
pub use frame::{
    decode, encode, encode_device_message, DecoderStats, Feed, FrameDecoder, FrameError,
    LEGACY_CHECK_MAX, MAX_FRAME_LEN, MAX_RAW_LEN,
};
pub use messages::*;

/// Protocol version: bumped on any incompatible change of framing or semantics.
///
/// - 1: CRC-16 framing, no sessions.
/// - 2: CRC-32 framing, session-bound requests, the belief (candidates, interrupted step) in
///   [`Status`], [`RequestBody::Identify`] and [`RequestBody::Close`].
pub const PROTOCOL_VERSION: u16 = 2;

/// Schema identity: [`schema_hash`] of the two message roots, [`Request`] (host → device) and
/// [`DeviceMessage`] (device → host), so a host and a device built from differently shaped
/// definitions refuse each other at the handshake. Computed at compile time; costs no flash.
pub const SCHEMA_ID: u32 = {
    let req = schema_hash::<Request>().to_le_bytes();
    let dev = schema_hash::<DeviceMessage>().to_le_bytes();
    fnv1a32(&[
        req[0], req[1], req[2], req[3], dev[0], dev[1], dev[2], dev[3],
    ])
};

/// A 32-bit identity of `T`'s wire shape: postcard-schema's 64-bit FNV-1a key of its
/// [`postcard_schema::Schema`] (every type, field and variant name and every field's type,
/// recursively, in declaration order; doc comments and attributes other than serde's play no
/// part), folded to 32 bits.
pub const fn schema_hash<T: postcard_schema::Schema + ?Sized>() -> u32 {
    let key = postcard_schema::key::Key::for_path::<T>("yoshimura-crane").to_bytes();
    let k = u64::from_le_bytes(key);
    (k as u32) ^ ((k >> 32) as u32)
}

/// The device sends [`Event::Heartbeat`] this often.
pub const HEARTBEAT_PERIOD_MS: u32 = 500;
/// The host should send a request (a [`RequestBody::Heartbeat`] if nothing else) this often.
pub const HOST_HEARTBEAT_PERIOD_MS: u32 = 250;
/// Default host silence after which a running plan is aborted (see [`ParamId::LinkTimeoutMs`]).
pub const DEFAULT_LINK_TIMEOUT_MS: u32 = 3_000;
/// The pressure cap can never be configured above this (the trunk's burst margin).
pub const HARD_MAX_PRESSURE_KPA: f32 = 60.0;

/// How long the host waits for the response to a request before sending it again with the same
/// `seq`. The largest frame takes ≈ 34 ms at 115 200 Bd and the device answers within one
/// control-loop pass, so this leaves a wide margin while still detecting loss quickly.
pub const RESPONSE_TIMEOUT_MS: u32 = 250;
/// Resends of one request (same `seq`) before the host declares the link lost. With
/// [`RESPONSE_TIMEOUT_MS`] this gives up after 1 s, well inside [`DEFAULT_LINK_TIMEOUT_MS`].
pub const MAX_RETRIES: u8 = 3;

/// The two sides' versions when a handshake fails. No `Display` here (no_std, no strings): the
/// host tool formats it, naming both versions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VersionMismatch {
    /// This build's [`PROTOCOL_VERSION`].
    pub local_protocol_version: u16,
    /// This build's [`SCHEMA_ID`].
    pub local_schema_id: u32,
    /// The peer's protocol version.
    pub peer_protocol_version: u16,
    /// The peer's schema identity.
    pub peer_schema_id: u32,
}

impl VersionMismatch {
    /// Whether the protocol versions differ (otherwise only the message definitions do).
    pub const fn protocol_differs(&self) -> bool {
        self.local_protocol_version != self.peer_protocol_version
    }

    /// Whether the schema identities differ.
    pub const fn schema_differs(&self) -> bool {
        self.local_schema_id != self.peer_schema_id
    }
}

/// The handshake check both sides make: the device on [`RequestBody::Hello`] (answering
/// [`RejectReason::VersionMismatch`] on `Err`), the host on the [`DeviceInfo`] it gets back.
/// Both the protocol version and the schema identity must be equal to this build's.
pub const fn check_hello(
    peer_protocol_version: u16,
    peer_schema_id: u32,
) -> Result<(), VersionMismatch> {
    if peer_protocol_version == PROTOCOL_VERSION && peer_schema_id == SCHEMA_ID {
        Ok(())
    } else {
        Err(VersionMismatch {
            local_protocol_version: PROTOCOL_VERSION,
            local_schema_id: SCHEMA_ID,
            peer_protocol_version,
            peer_schema_id,
        })
    }
}

impl RequestBody {
    /// The handshake request carrying this build's versions.
    pub const fn hello() -> Self {
        RequestBody::Hello {
            protocol_version: PROTOCOL_VERSION,
            schema_id: SCHEMA_ID,
            takeover: false,
        }
    }

    /// The handshake request that takes the crane over from a live session.
    pub const fn hello_takeover() -> Self {
        RequestBody::Hello {
            protocol_version: PROTOCOL_VERSION,
            schema_id: SCHEMA_ID,
            takeover: true,
        }
    }

    /// Whether the request changes the device's state (and so is refused from anyone but the
    /// session's owner): everything except `Hello`, `GetStatus`, `GetParam`,
    /// `GetProbeProfile` and `Abort`
    /// (`Heartbeat` is the owner's too: it keeps the session alive).
    pub const fn needs_session(&self) -> bool {
        !matches!(
            self,
            RequestBody::Hello { .. }
                | RequestBody::GetStatus
                | RequestBody::GetParam(_)
                | RequestBody::GetProbeProfile
                | RequestBody::Abort
        )
    }
}

impl DeviceInfo {
    /// Host side of the handshake: [`check_hello`] on the device's versions.
    pub const fn check(&self) -> Result<(), VersionMismatch> {
        check_hello(self.protocol_version, self.schema_id)
    }
}

const fn fnv1a32(bytes: &[u8]) -> u32 {
    let mut hash: u32 = 0x811c_9dc5;
    let mut i = 0;
    while i < bytes.len() {
        hash ^= bytes[i] as u32;
        hash = hash.wrapping_mul(0x0100_0193);
        i += 1;
    }
    hash
}

#[cfg(test)]
mod tests {
    use super::*;

    // Three versions of one small message, as `messages.rs` might be edited: `documented`
    // differs from `original` only in its comments, `reshaped` in one field's type, `renamed`
    // in one variant's name.
    #[allow(dead_code)] // only their shapes matter
    mod original {
        #[derive(postcard_schema::Schema)]
        pub struct Probe {
            pub seq: u16,
            pub body: Body,
        }
        #[derive(postcard_schema::Schema)]
        pub enum Body {
            Ping,
            Set { value: f32 },
        }
    }
    #[allow(dead_code)] // only their shapes matter
    mod documented {
        /// A probe, now documented.
        #[derive(postcard_schema::Schema)]
        pub struct Probe {
            /// The sequence number (a comment edit).
            pub seq: u16,
            // A plain comment too.
            pub body: Body,
        }
        /// What it asks.
        #[derive(postcard_schema::Schema)]
        pub enum Body {
            /// Nothing.
            Ping,
            /// A value.
            Set {
                /// In kPa.
                value: f32,
            },
        }
    }
    #[allow(dead_code)] // only their shapes matter
    mod reshaped {
        #[derive(postcard_schema::Schema)]
        pub struct Probe {
            pub seq: u32,
            pub body: Body,
        }
        #[derive(postcard_schema::Schema)]
        pub enum Body {
            Ping,
            Set { value: f32 },
        }
    }
    #[allow(dead_code)] // only their shapes matter
    mod renamed {
        #[derive(postcard_schema::Schema)]
        pub struct Probe {
            pub seq: u16,
            pub body: Body,
        }
        #[derive(postcard_schema::Schema)]
        pub enum Body {
            Ping,
            Put { value: f32 },
        }
    }

    #[test]
    fn schema_identity_follows_the_shape_not_the_comments() {
        let id = schema_hash::<original::Probe>();
        assert_eq!(
            schema_hash::<documented::Probe>(),
            id,
            "a comment changed the id"
        );
        assert_ne!(
            schema_hash::<reshaped::Probe>(),
            id,
            "a field type change kept the id"
        );
        assert_ne!(
            schema_hash::<renamed::Probe>(),
            id,
            "a variant rename kept the id"
        );
        // And the real roots: the two directions differ, and SCHEMA_ID depends on both.
        assert_ne!(schema_hash::<Request>(), schema_hash::<DeviceMessage>());
        assert_ne!(SCHEMA_ID, schema_hash::<Request>());
    }

    #[test]
    fn fnv1a32_matches_the_reference_vectors() {
        // Published FNV-1a 32-bit test vectors.
        assert_eq!(fnv1a32(b""), 0x811c_9dc5);
        assert_eq!(fnv1a32(b"a"), 0xe40c_292c);
        assert_eq!(fnv1a32(b"foobar"), 0xbf9c_f968);
    }
}
