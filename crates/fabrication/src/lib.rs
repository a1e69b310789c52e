//! Fabrication files for Yoshimura trunks, built from the `geometry` crate.
//!
//! A [`Trunk`] is a stack of modules (one (n, β) design each, several layers per module) at a
//! physical edge length. From it this crate makes:
//!
//! * [`pattern::Pattern`] — the whole trunk's flat crease pattern (every facet triangle split
//!   along its symmetry axis, the virtual crease of paper §3.1.2), with the seam allowance;
//!   written as SVG ([`svg`]), DXF ([`dxf_out`]) and FOLD v1.2 ([`fold`]) with one frame per
//!   state from [`folded`] (3D coordinates and fold angles from `geometry::Module3d` /
//!   `geometry::SelfPacked3d`);
//! * [`tiles`] — the 1:1 pattern tiled over A4 or Letter pages with registration marks and a
//!   scale bar;
//! * [`panel`] — the dual-material printable panel of §5.3 (TPU base sheet, nylon facets with
//!   a gap between neighbours) as 3MF with two objects and materials, or one STL per material;
//! * [`kit`] — the meter-scale kit of §7: facet cut list, hinge positions, hinge/screw counts;
//! * [`nest`] — cut sheets of the kit's facets on real sheet sizes, with insert holes and
//!   labels, written per sheet as DXF and SVG by [`nest_out`];
//! * [`parts`] — printable parts as closed solids (binary STL, and a slicer-ready 3MF each with
//!   its material, quantity and dimensions): the kit's hinge leaf, the crane's upper and lower
//!   caps, tendon locator and gripper mount;
//! * [`threemf`] — the 3MF package writer the panel and the parts share;
//! * [`bom`] — bills of materials (the crane: printed panel, printed parts, magnets and
//!   electronics; the kit: sheets, facets, printed hinge leaves, pins, screws, inserts) as CSV;
//! * [`model`] — a 3D model of a stack in given states (binary glTF 2.0, OBJ, STL), coloured by
//!   module, with the strain of non-isometric states shown.
//!
//! Lengths inside are in units of l (the valley fold length) unless a name says `_mm`; files
//! are written in millimetres (glTF in metres, as its specification requires).
//!
//! Every function that takes user input validates it and returns an `Err` with a message that
//! says what is valid; nothing panics on any input.
#![forbid(unsafe_code)]

pub mod bom;
pub mod dxf_out;
pub mod fold;
pub mod folded;
pub mod kit;
pub mod mesh;
pub mod model;
pub mod nest;
pub mod nest_out;
pub mod panel;
pub mod parts;
pub mod pattern;
pub mod svg;
pub mod threemf;
pub mod tiles;
mod trunk;

pub use trunk::{Defaults, FabError, Module, Trunk, MAX_LAYERS};
