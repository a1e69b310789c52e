//! End-to-end tests: the real `host-tool` and `hil-sim` binaries, talking over pseudo-terminals.
//!
//! Build the binaries first when running this package alone:
//! `cargo build --workspace --bins --release && cargo test -p e2e --release`
//! (`cargo test --workspace --release` builds them itself).

mod cli;
mod deps;
mod elf;
mod faults;
mod graph_agreement;
mod plans;
mod pty;
mod serial_garbage;
mod signing;
mod swarm;
mod usage;
