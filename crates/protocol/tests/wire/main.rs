//! The protocol crate's integration tests (one binary): golden bytes, property tests, framing
//! edge cases, handshake.

mod edges;
mod golden;
mod handshake;
mod props;
mod samples;
mod smoke;
