//! Trunk physics: the multistable modules, the gas, the tendons (no devices, no firmware).

pub mod calibration;
pub mod design;
pub mod gas;
pub mod multistable;
pub mod params;
pub mod spec;
pub mod trunk;

pub use design::{DesignError, TrunkDesign};
pub use params::TrunkParams;
pub use spec::{TrunkError, TrunkSpec};
pub use trunk::{Actuation, Module, Snap, Trunk};
