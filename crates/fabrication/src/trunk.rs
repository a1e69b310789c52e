//! The trunk description shared by every output: modules, layers, edge length.

use std::fmt;

use geometry::ModuleDesign;

/// Most layers a trunk may have in total (a pattern of 1000 layers is already a 50 m sheet at
/// the crane's 75 mm edge; the limit keeps every output bounded).
pub const MAX_LAYERS: usize = 1000;

/// Why a fabrication request was refused. The text says what is valid.
#[derive(Debug, Clone, PartialEq)]
pub struct FabError(pub String);

impl fmt::Display for FabError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for FabError {}

impl FabError {
    pub(crate) fn new(msg: impl Into<String>) -> Self {
        FabError(msg.into())
    }
}

/// The defaults, from the paper's crane trunk (§5.4, §6) and Table 2.
#[derive(Debug, Clone, Copy)]
pub struct Defaults;

impl Defaults {
    /// n = 3 (the crane trunk).
    pub const N: u32 = 3;
    /// β per module, bottom first: 35° (self-packing module) under 31.72° (golden ratio).
    pub const BETA: &'static str = "35,31.72";
    /// Layers per module: 2 (the bottom packs "layer by layer" in two snaps, §5.4).
    pub const LAYERS: &'static str = "2";
    /// Edge (valley fold) length: 75 mm, the trunk's base length L3 (§5.4, Table 2).
    pub const EDGE_MM: f64 = 75.0;
    /// Gap between neighbouring facets with the default β list: d4 = 2·d1 = 3.0 mm for the
    /// 35° bottom module, d1 = 1.5 mm for the golden top module (§5.4, Table 2).
    pub const GAP_MM_TRUNK: &'static str = "3,1.5";
    /// Gap for any other module list: d1 = 1.5 mm (Table 2).
    pub const GAP_MM: f64 = 1.5;
    /// Nylon facet thickness: t1 = 0.6 mm (Table 2).
    pub const FACET_MM: f64 = 0.6;
    /// TPU 95A base sheet thickness: t2 = 0.2 mm (Table 2).
    pub const BASE_MM: f64 = 0.2;
    /// Seam allowance (glue tab) to close the cylinder: 5 mm.
    pub const SEAM_MM: f64 = 5.0;
}

/// One module of the trunk: an (n, β) design repeated over `layers` layers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Module {
    /// The design (n, β).
    pub design: ModuleDesign,
    /// Number of layers (rows of rhombi), ≥ 1.
    pub layers: usize,
}

/// A stack of modules (bottom first) at a physical edge length.
#[derive(Debug, Clone, PartialEq)]
pub struct Trunk {
    modules: Vec<Module>,
    edge_mm: f64,
}

impl Trunk {
    /// Validates: at least one module, every module ≥ 1 layer, all modules share n, at most
    /// [`MAX_LAYERS`] layers in total, edge length finite and in (0, 10 000] mm.
    pub fn new(modules: Vec<Module>, edge_mm: f64) -> Result<Self, FabError> {
        let Some(first) = modules.first() else {
            return Err(FabError::new("a trunk needs at least one module"));
        };
        let n = first.design.n();
        if let Some(m) = modules.iter().find(|m| m.design.n() != n) {
            return Err(FabError::new(format!(
                "every module must have the same n (their boundaries join); got n = {n} and n = {}",
                m.design.n()
            )));
        }
        if modules.iter().any(|m| m.layers == 0) {
            return Err(FabError::new("every module needs at least 1 layer"));
        }
        let total: usize = modules.iter().map(|m| m.layers).sum();
        if total > MAX_LAYERS {
            return Err(FabError::new(format!(
                "{total} layers in total; at most {MAX_LAYERS} are supported"
            )));
        }
        if !(edge_mm.is_finite() && edge_mm > 0.0 && edge_mm <= 10_000.0) {
            return Err(FabError::new(format!(
                "the edge length must be in (0, 10000] mm, got {edge_mm}"
            )));
        }
        Ok(Self { modules, edge_mm })
    }

    /// The modules, bottom first.
    pub fn modules(&self) -> &[Module] {
        &self.modules
    }

    /// Number of polygon sides n.
    pub fn n(&self) -> u32 {
        self.modules[0].design.n()
    }

    /// Edge (valley fold) length l in mm.
    pub fn edge_mm(&self) -> f64 {
        self.edge_mm
    }

    /// Total number of layers.
    pub fn layer_count(&self) -> usize {
        self.modules.iter().map(|m| m.layers).sum()
    }

    /// For each layer, bottom first: (module index, design).
    pub fn layers(&self) -> Vec<(usize, ModuleDesign)> {
        self.modules
            .iter()
            .enumerate()
            .flat_map(|(k, m)| std::iter::repeat_n((k, m.design), m.layers))
            .collect()
    }

    /// Flat height of the pattern, Σ layers·w, in units of l.
    pub fn flat_height(&self) -> f64 {
        self.modules
            .iter()
            .map(|m| m.layers as f64 * m.design.w())
            .sum()
    }

    /// A one-line description, e.g. `n = 3, β = 35°×2 + 31.72°×2 layers, l = 75 mm`.
    pub fn describe(&self) -> String {
        let parts: Vec<String> = self
            .modules
            .iter()
            .map(|m| format!("{}°×{}", m.design.beta_deg(), m.layers))
            .collect();
        format!(
            "n = {}, β = {} layers (bottom first), l = {} mm",
            self.n(),
            parts.join(" + "),
            self.edge_mm
        )
    }
}
