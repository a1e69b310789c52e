//! The protocol crate's integration tests (one binary): golden bytes, property tests, framing
//! edge cases, handshake, the streaming decoder against the one-shot one, the in-place plan
//! deserialiser against the derive.

mod codec;
mod edges;
mod golden;
mod handshake;
mod in_place;
mod incremental;
mod legacy;
mod mutation;
mod props;
mod samples;
mod smoke;
