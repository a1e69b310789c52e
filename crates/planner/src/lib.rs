//! Planning for Yoshimura trunks and booms.
//!
//! - [`ik`]: shape inverse kinematics (paper §4.2): choose one metastable state per module so a
//!   stacked boom follows a target curve.
//! - [`graph`]: PDF trunk transition planning (paper §6.2): the six-state graph built from the
//!   protocol's transition catalogue, cheapest plans by Dijkstra, replanning — the
//!   `transition-graph` crate, re-exported (the host engine uses it alone, without the IK).
//! - [`sun`]: where the sun is (NREL SPA through `solar-positioning`; site, ΔT and air
//!   explicit), sunrise/sunset, polar day and night, and the time parsers the commands share.
//! - [`station`]: the solar station (paper §7.2): which catalogue states of the top modules
//!   point the top face at the sun, sample by sample, and the exact best schedule with at
//!   most K refolds (dynamic programming over time, `docs/sun.md`).
//! - [`task`]: a goal for the tip (a point, a bend, a grip) as a plan of the device's
//!   primitives, or a refusal with the nearest feasible value.
#![forbid(unsafe_code)]

pub use transition_graph as graph;
pub mod ik;
pub mod station;
pub mod sun;
pub mod task;
