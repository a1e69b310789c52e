//! Yoshimura-origami geometry, `no_std` and allocation-free.
//!
//! This crate is the foundation of the workspace: the module design (n, β), the paper's eq 5
//! transform between a module's bottom and top boundaries, the 3D construction of a module, the
//! catalogue of metastable states, forward kinematics of a stack, and the names of the crane
//! trunk's states (`F&P` …).
//!
//! It never performs I/O and never allocates.
#![no_std]
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod trunk;

pub use trunk::{BottomState, ParseTrunkStateError, TopState, TrunkState};
