//! Yoshimura-origami geometry, `no_std` and allocation-free.
//!
//! This crate is the foundation of the workspace. It answers two questions exactly and
//! verifiably: *which metastable states does an (n, β) module have*, and *what shape does a
//! stack of modules take*. Everything else (inverse kinematics, planner, firmware, simulator)
//! builds on it.
//!
//! # Map
//!
//! * [`ModuleDesign`] — a module from (n, β), validated: w, a, r (eqs 1–3), optional mm scale.
//! * [`Pose`] — the eq 5 transform T(d, γ, ψ) = Rz(ψ)·Rx(γ/2)·Tz(d)·Rx(γ/2)·Rz(−ψ) from a
//!   module's bottom boundary (eq 3 polygon, circumradius r, unit edges) to its top.
//! * [`construct::Module3d`] — the 3D construction of a module in any pose (eqs 3–9): mid-plane
//!   points, crease lengths against the flat pattern, θ_in/θ_out, and the *strain* (largest
//!   relative crease-length error) by which every catalogue state is verified.
//! * [`ShapeState`] and the catalogue ([`ModuleDesign::shape_states`], [`ModuleDesign::pose`],
//!   [`ModuleDesign::state_info`]) — the 2(n+1) states deployed, folded, `edge-i`, `vertex-i`;
//!   [`SymmetricState`] adds flat-folded and self-packed (ζ, r_in); [`popout`] solves β_in and
//!   β_out.
//! * [`hyperfold::SelfPacked3d`] (also `construct::SelfPacked3d`) — the self-packed
//!   (hyperfolded) module built in 3D, d = 0 with the 2n virtual creases of §3.1.2: measures
//!   the hyperfold angle ζ (eq 13), the inner radius r_in (eq 14) and the strain.
//! * [`fk`] — forward kinematics of a stack (eqs 33–35), tips in units of l.
//! * [`orient`] — each module's top-face frame and outward normal ([`orient::top_faces`]), and
//!   the base frame on the compass ([`orient::Heading`]: azimuth of base x, default 90° = ENU).
//! * [`tendon`] — three-tendon constant-curvature bending and the joystick map.
//! * [`reach`] — the crane's tip pose for a trunk state and a bend (constant curvature over the
//!   state's flexible length) and the nearest point of a state's workspace to a goal.
//! * [`trunk`] — the crane trunk's six states `F&P` … `D&D`.
//!
//! Units: lengths in units of the valley fold length l = 1 unless a name says `_mm`; angles in
//! radians unless a name says `_deg`. Where the paper is wrong or ambiguous the choice made
//! here is derived and tested in `docs/geometry.md`.
//!
//! # What it must not do
//!
//! No I/O, no allocation, no panics on any input (constructors validate and return
//! `Result`), no `std`: it builds for `thumbv7em-none-eabihf` and runs on the crane's board.
//!
//! # Example
//!
//! ```
//! use geometry::{fk, ModuleDesign, ShapeState};
//!
//! let golden = ModuleDesign::new(3, 31.717_474_411_461_005).unwrap(); // tan β = 1/φ
//! assert_eq!(golden.shape_states().count(), 8);
//! for s in golden.shape_states() {
//!     let info = golden.state_info(s);
//!     assert!(info.feasible && info.max_strain < 1e-9, "{s}");
//! }
//! let stack = [(golden, ShapeState::Deployed), (golden, ShapeState::Edge(0))];
//! let tips: [_; 2] = {
//!     let mut out = [nalgebra::Point3::origin(); 2];
//!     fk::fill_tips_of_states(stack, &mut out).unwrap();
//!     out
//! };
//! assert!((tips[0].z - golden.w()).abs() < 1e-12);
//! ```
#![forbid(unsafe_code)]
#![no_std]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod catalogue;
pub mod construct;
pub mod design;
pub mod fk;
pub mod hyperfold;
pub mod orient;
pub mod popout;
pub mod pose;
pub mod reach;
pub mod state;
pub mod tendon;
pub mod trunk;

pub use catalogue::{StateInfo, STRAIN_TOLERANCE};
pub use construct::Module3d;
pub use design::{DesignError, ModuleDesign, MAX_N, MIN_N};
pub use hyperfold::{SelfPackError, SelfPacked3d};
pub use pose::Pose;
pub use state::{ParseShapeStateError, ParseShapeStateErrorKind, ShapeState, SymmetricState};
pub use trunk::{BottomState, ParseTrunkStateError, TopState, TrunkState};
