//! The serial protocol of the Yoshimura crane: the one place where wire types live.
//!
//! - [`messages`]: every message host and device exchange ([`Request`], [`DeviceMessage`]).
//! - [`frame`]: framing — postcard payload, CRC-16, COBS with a `0x00` delimiter — and a
//!   streaming decoder that never panics and never allocates.
//! - Versioning: [`PROTOCOL_VERSION`] and [`SCHEMA_ID`] are exchanged in the handshake; a peer
//!   with different values is refused.
//!
//! This crate is `no_std`, performs no I/O and never allocates.
#![no_std]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod frame;
pub mod messages;
pub mod transitions;

pub use frame::{encode, DecoderStats, FrameDecoder, FrameError, MAX_FRAME_LEN};
pub use messages::*;

/// Protocol version: bumped on any incompatible change of framing or semantics.
pub const PROTOCOL_VERSION: u16 = 1;

/// Schema identity: FNV-1a (32 bit) over the source text of the message definitions, so a host
/// and a device built from different definitions refuse each other at the handshake.
pub const SCHEMA_ID: u32 = fnv1a32(include_str!("messages.rs").as_bytes());

/// The device sends [`Event::Heartbeat`] this often.
pub const HEARTBEAT_PERIOD_MS: u32 = 500;
/// The host should send a request (a [`RequestBody::Heartbeat`] if nothing else) this often.
pub const HOST_HEARTBEAT_PERIOD_MS: u32 = 250;
/// Default host silence after which a running plan is aborted (see [`ParamId::LinkTimeoutMs`]).
pub const DEFAULT_LINK_TIMEOUT_MS: u32 = 3_000;
/// The pressure cap can never be configured above this (the trunk's burst margin).
pub const HARD_MAX_PRESSURE_KPA: f32 = 60.0;

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
