//! Planning for Yoshimura trunks and booms.
//!
//! - [`ik`]: shape inverse kinematics (paper §4.2): choose one metastable state per module so a
//!   stacked boom follows a target curve.
//! - [`graph`]: PDF trunk transition planning (paper §6.2): the six-state graph built from the
//!   protocol's transition catalogue, cheapest plans by Dijkstra, replanning.
//! - [`task`]: a goal for the tip (a point, a bend, a grip) as a plan of the device's
//!   primitives, or a refusal with the nearest feasible value.

pub mod graph;
pub mod ik;
pub mod task;
