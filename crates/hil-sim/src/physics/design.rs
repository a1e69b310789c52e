//! A trunk's design — the pattern it is printed from (n, the edge length, β and layers per
//! module) — with the topology the crane's six states and transitions are built on, and the
//! heights and piston area that follow from it (`docs/simulator.md`, "Your own trunk").
//!
//! The crane's state set (`F&P` … `D&D`, `protocol::transitions`) is the paper's topology: two
//! modules of one n, a **self-packing bottom module** of two layers (P, P½ — one layer packed —,
//! F, D: it packs layer by layer in two snaps) under a **tendon-folded top module** (F, D) of
//! the smaller β (in compression the smaller β buckles first, §5.1). A design outside it is
//! refused with the reason; an infeasible one with the number that decided it.

use geometry::ModuleDesign;
use serde::{Deserialize, Serialize};

use super::params::{folded_d, layer_deployed_d, piston_area_mm2};

/// Largest edge length, mm (the fabrication crate's limit: a pattern's sheet stays bounded).
pub const MAX_EDGE_MM: f64 = 10_000.0;

/// Layers of the bottom module: exactly two (the crane's one half-packed state P½ is one layer
/// packed over one folded; the tendons pack it in two snaps).
pub const BOTTOM_LAYERS: u32 = 2;

/// Most layers of the top module: the physics has one barrier for the top (its layers snap
/// together, as the PDF trunk's two are calibrated to); a longer top could rest with some
/// layers popped and others folded, a state the crane's set does not have.
pub const MAX_TOP_LAYERS: u32 = 2;

/// How far a height or the piston area of a description may differ from what its design
/// gives, relative (0.1 %: a hand-written file's rounding, not another trunk).
pub const DESIGN_TOLERANCE: f64 = 1e-3;

/// One module's fold angle and layers.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModuleDesignSpec {
    /// Fold angle β, degrees.
    pub beta_deg: f64,
    /// Layers (rows of rhombi).
    pub layers: u32,
}

/// A trunk's design, as the `[design]` table of `trunks/*.toml`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrunkDesign {
    /// Polygon sides of both modules.
    pub n: u32,
    /// Valley-fold (polygon edge) length, mm.
    pub edge_mm: f64,
    /// The top module (tendon-folded: F, D).
    pub top: ModuleDesignSpec,
    /// The bottom module (self-packing: P, P½, F, D).
    pub bottom: ModuleDesignSpec,
}

/// The heights and area a design gives (mm, mm²): what [`super::TrunkParams::pdf`] derives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignHeights {
    /// Top module wells F, D.
    pub top: [f64; 2],
    /// Bottom module wells F, D (P and P½ depend on the printed panels' stack:
    /// P½ = P / 2 + F / 2, one layer packed over one folded).
    pub bottom_folded_mm: f64,
    /// Bottom module deployed.
    pub bottom_deployed_mm: f64,
    /// One folded bottom layer.
    pub bottom_layer_folded_mm: f64,
    /// Effective piston area (dV/dH of a deployed layer), mm².
    pub area_mm2: f64,
    /// Tendon slack length: the unloaded D&D height.
    pub tendon_slack_length_mm: f64,
}

/// Why a design was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DesignError {
    /// A number no module can have (the geometry crate's validation, or the edge length).
    #[error("the design is infeasible: {0}")]
    Infeasible(String),
    /// A feasible design the crane's state set and transitions do not hold for.
    #[error(
        "the design is not the crane's topology (a tendon-folded top module over a \
         self-packing bottom module; docs/simulator.md, \"Your own trunk\"): {0}"
    )]
    Topology(String),
}

impl TrunkDesign {
    /// The PDF trunk's design: n = 3, 75 mm edges, a 31.72° top over a 35° bottom, two layers
    /// each.
    pub const PDF: TrunkDesign = TrunkDesign {
        n: super::params::N_SIDES,
        edge_mm: super::params::EDGE_MM,
        top: ModuleDesignSpec {
            beta_deg: super::params::TOP_BETA_DEG,
            layers: super::params::TOP_LAYERS,
        },
        bottom: ModuleDesignSpec {
            beta_deg: super::params::BOTTOM_BETA_DEG,
            layers: super::params::BOTTOM_LAYERS,
        },
    };

    /// The two modules' designs (top, bottom) with the edge length, or why the design is
    /// infeasible or outside the crane's topology.
    pub fn check(&self) -> Result<(ModuleDesign, ModuleDesign), DesignError> {
        let infeasible =
            |what: &str, e: geometry::DesignError| DesignError::Infeasible(format!("{what}: {e}"));
        let top = ModuleDesign::new(self.n, self.top.beta_deg)
            .map_err(|e| infeasible("design.n / design.top.beta_deg", e))?;
        let bottom = ModuleDesign::new(self.n, self.bottom.beta_deg)
            .map_err(|e| infeasible("design.n / design.bottom.beta_deg", e))?;
        if !(self.edge_mm.is_finite() && self.edge_mm > 0.0 && self.edge_mm <= MAX_EDGE_MM) {
            return Err(DesignError::Infeasible(format!(
                "design.edge_mm = {} is not a length in (0, {MAX_EDGE_MM}] mm",
                self.edge_mm
            )));
        }
        let (top, bottom) = (
            top.with_edge_mm(self.edge_mm)
                .map_err(|e| infeasible("design.edge_mm", e))?,
            bottom
                .with_edge_mm(self.edge_mm)
                .map_err(|e| infeasible("design.edge_mm", e))?,
        );
        let ff = 90.0 / self.n as f64;
        if self.bottom.layers != BOTTOM_LAYERS {
            return Err(DesignError::Topology(format!(
                "design.bottom.layers = {} but the bottom module has exactly {BOTTOM_LAYERS} \
                 layers: it packs layer by layer in two snaps, and its one half-packed state \
                 P½ is one layer packed over one folded",
                self.bottom.layers
            )));
        }
        if !(1..=MAX_TOP_LAYERS).contains(&self.top.layers) {
            return Err(DesignError::Topology(format!(
                "design.top.layers = {} but the top module has 1 to {MAX_TOP_LAYERS} layers: \
                 its layers snap as one (F or D); a longer top could rest part-deployed, a \
                 state the crane's set does not have",
                self.top.layers
            )));
        }
        if !bottom.can_self_pack() {
            return Err(DesignError::Topology(format!(
                "the bottom module cannot self-pack at design.bottom.beta_deg = {}° (n = {}): \
                 self-packing needs β in ({ff:.4}°, 45°] (above the flat-foldable 90°/n, at \
                 most 45°; Table 1)",
                self.bottom.beta_deg, self.n
            )));
        }
        if !(self.top.beta_deg > ff && top.folded_d().is_some_and(|d| d > 0.0)) {
            return Err(DesignError::Topology(format!(
                "the top module cannot be tendon-folded at design.top.beta_deg = {}° (n = {}): \
                 its folded state needs β above the flat-foldable 90°/n = {ff:.4}° (at or \
                 below it the module folds flat or not at all, eqs 10–12)",
                self.top.beta_deg, self.n
            )));
        }
        if self.top.beta_deg >= self.bottom.beta_deg {
            return Err(DesignError::Topology(format!(
                "design.top.beta_deg = {}° is not below design.bottom.beta_deg = {}°: the top \
                 must have the smaller β (in compression the smaller β buckles first, §5.1, so \
                 the tendons fold the top before they fold and pack the bottom)",
                self.top.beta_deg, self.bottom.beta_deg
            )));
        }
        Ok((top, bottom))
    }

    /// The heights and the piston area this design gives (unchecked: call [`Self::check`]
    /// first; an infeasible design gives zeros).
    pub fn heights(&self) -> DesignHeights {
        let l = self.edge_mm;
        let top_f = self.top.layers as f64 * folded_d(self.top.beta_deg, self.n) * l;
        let top_d = self.top.layers as f64 * layer_deployed_d(self.top.beta_deg, self.n) * l;
        let bot_layer_f = folded_d(self.bottom.beta_deg, self.n) * l;
        let bot_f = self.bottom.layers as f64 * bot_layer_f;
        let bot_d = self.bottom.layers as f64 * layer_deployed_d(self.bottom.beta_deg, self.n) * l;
        DesignHeights {
            top: [top_f, top_d],
            bottom_folded_mm: bot_f,
            bottom_deployed_mm: bot_d,
            bottom_layer_folded_mm: bot_layer_f,
            area_mm2: piston_area_mm2(self.n, self.edge_mm),
            tendon_slack_length_mm: top_d + bot_d,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(f: impl FnOnce(&mut TrunkDesign)) -> Result<(), DesignError> {
        let mut d = TrunkDesign::PDF;
        f(&mut d);
        d.check().map(|_| ())
    }

    #[test]
    fn the_pdf_design_holds_and_each_refusal_names_its_number() {
        TrunkDesign::PDF.check().unwrap();
        let topo = |r: Result<(), DesignError>, word: &str| match r {
            Err(DesignError::Topology(t)) => assert!(t.contains(word), "{t}"),
            other => panic!("{other:?}"),
        };
        let infeasible = |r: Result<(), DesignError>, word: &str| match r {
            Err(e @ DesignError::Infeasible(_)) => assert!(e.to_string().contains(word), "{e}"),
            other => panic!("{other:?}"),
        };
        infeasible(with(|d| d.n = 2), "n = 2");
        infeasible(with(|d| d.n = 65), "n = 65");
        infeasible(with(|d| d.top.beta_deg = 90.0), "beta = 90");
        infeasible(with(|d| d.bottom.beta_deg = f64::NAN), "finite");
        infeasible(with(|d| d.edge_mm = 0.0), "edge_mm = 0");
        infeasible(with(|d| d.edge_mm = 10_000.5), "edge_mm");
        with(|d| d.edge_mm = MAX_EDGE_MM).unwrap();
        topo(with(|d| d.bottom.layers = 3), "bottom.layers = 3");
        topo(with(|d| d.bottom.layers = 1), "bottom.layers = 1");
        topo(with(|d| d.top.layers = 3), "top.layers = 3");
        topo(with(|d| d.top.layers = 0), "top.layers = 0");
        with(|d| d.top.layers = 1).unwrap();
        // The bottom self-packs in (90°/n, 45°]: 45° is in, above is out, 30° (n = 3) is out.
        topo(with(|d| d.bottom.beta_deg = 45.01), "cannot self-pack");
        with(|d| d.bottom.beta_deg = 45.0).unwrap();
        topo(
            with(|d| {
                d.bottom.beta_deg = 30.0;
                d.top.beta_deg = 29.0;
            }),
            "cannot self-pack",
        );
        // The top folds above 90°/n and has the smaller β.
        topo(with(|d| d.top.beta_deg = 30.0), "cannot be tendon-folded");
        with(|d| d.top.beta_deg = 30.01).unwrap();
        topo(with(|d| d.top.beta_deg = 35.0), "smaller β");
        // n = 4: the flat-foldable angle is 22.5°.
        with(|d| {
            d.n = 4;
            d.top.beta_deg = 22.6;
        })
        .unwrap();
        topo(
            with(|d| {
                d.n = 4;
                d.top.beta_deg = 22.5;
            }),
            "22.5000",
        );
    }

    #[test]
    fn the_pdf_design_gives_the_calibrated_heights() {
        let h = TrunkDesign::PDF.heights();
        assert!((h.top[0] - 33.10482703659852).abs() < 1e-9);
        assert!((h.top[1] - 92.71423608660702).abs() < 1e-9);
        assert!((h.bottom_folded_mm - 59.426748377547106).abs() < 1e-9);
        assert!((h.bottom_deployed_mm - 105.03113073145646).abs() < 1e-9);
        assert!((h.area_mm2 - 3247.595264191646).abs() < 1e-6);
        assert!((h.tendon_slack_length_mm - 197.74536681806347).abs() < 1e-9);
    }
}
