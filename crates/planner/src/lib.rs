//! Planning for Yoshimura trunks and booms.
//!
//! - [`ik`]: shape inverse kinematics (paper §4.2): choose one metastable state per module so a
//!   stacked boom follows a target curve.
//! - `graph` (PDF trunk transition planning) lands with its issue.

pub mod ik;
