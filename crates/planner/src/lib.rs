//! Planning for Yoshimura trunks and booms.
//!
//! - [`ik`]: shape inverse kinematics (paper §4.2): choose one metastable state per module so a
//!   stacked boom follows a target curve.
//! - [`graph`]: PDF trunk transition planning (paper §6.2): the six-state graph built from the
//!   protocol's transition catalogue, cheapest plans by Dijkstra, replanning — the
//!   `transition-graph` crate, re-exported (the host engine uses it alone, without the IK).
#![forbid(unsafe_code)]

pub use transition_graph as graph;
pub mod ik;
