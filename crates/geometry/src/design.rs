//! Module design: the fold pattern of one Yoshimura module, from (n, β) (paper §2, eqs 1–3).

use core::f64::consts::PI;
use core::fmt;

/// Smallest number of polygon sides: a module needs at least a triangle.
pub const MIN_N: u32 = 3;
/// Largest number of polygon sides accepted. The paper studies n = 3…6; 64 keeps every
/// per-module buffer (the 3D construction) small and fixed-size, and `Edge(u8)`/`Vertex(u8)`
/// indices in range.
pub const MAX_N: u32 = 64;

/// Why a module design was rejected. The `Display` text says what is valid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DesignError {
    /// n below [`MIN_N`].
    TooFewSides(u32),
    /// n above [`MAX_N`].
    TooManySides(u32),
    /// β (in degrees) is NaN or infinite.
    BetaNotFinite,
    /// β (in degrees) is not strictly between 0° and 90°.
    BetaOutOfRange(f64),
    /// The physical edge length (mm) is not a finite positive number.
    EdgeNotPositive,
}

impl fmt::Display for DesignError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DesignError::TooFewSides(n) => {
                write!(
                    f,
                    "n = {n} is too small; n must be an integer in [{MIN_N}, {MAX_N}]"
                )
            }
            DesignError::TooManySides(n) => {
                write!(
                    f,
                    "n = {n} is too large; n must be an integer in [{MIN_N}, {MAX_N}]"
                )
            }
            DesignError::BetaNotFinite => {
                write!(
                    f,
                    "beta must be a finite angle in degrees strictly between 0 and 90"
                )
            }
            DesignError::BetaOutOfRange(b) => write!(
                f,
                "beta = {b} deg is out of range; beta must be strictly between 0 and 90 degrees"
            ),
            DesignError::EdgeNotPositive => {
                write!(
                    f,
                    "the edge length must be a finite positive number of millimetres"
                )
            }
        }
    }
}

impl core::error::Error for DesignError {}

/// One Yoshimura module: n-gon boundaries with unit edges (the valley fold length l = 1) and
/// fold angle β between mountain and valley folds.
///
/// All lengths are in units of l unless a name says `_mm`; angles are radians unless a name
/// says `_deg`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ModuleDesign {
    n: u32,
    beta_deg: f64,
    edge_mm: Option<f64>,
}

impl ModuleDesign {
    /// A module with `n` sides (n ∈ [[`MIN_N`], [`MAX_N`]]) and fold angle `beta_deg`
    /// (finite, strictly between 0° and 90°).
    pub fn new(n: u32, beta_deg: f64) -> Result<Self, DesignError> {
        if n < MIN_N {
            return Err(DesignError::TooFewSides(n));
        }
        if n > MAX_N {
            return Err(DesignError::TooManySides(n));
        }
        if !beta_deg.is_finite() {
            return Err(DesignError::BetaNotFinite);
        }
        if !(beta_deg > 0.0 && beta_deg < 90.0) {
            return Err(DesignError::BetaOutOfRange(beta_deg));
        }
        Ok(Self {
            n,
            beta_deg,
            edge_mm: None,
        })
    }

    /// The same design with a physical scale: the valley fold (polygon edge) is `edge_mm`
    /// millimetres long. Geometry stays in units of l; multiply by [`Self::mm_per_l`].
    pub fn with_edge_mm(self, edge_mm: f64) -> Result<Self, DesignError> {
        if !(edge_mm.is_finite() && edge_mm > 0.0) {
            return Err(DesignError::EdgeNotPositive);
        }
        Ok(Self {
            edge_mm: Some(edge_mm),
            ..self
        })
    }

    /// Number of polygon sides n.
    pub fn n(&self) -> u32 {
        self.n
    }

    /// Fold angle β in degrees.
    pub fn beta_deg(&self) -> f64 {
        self.beta_deg
    }

    /// Fold angle β in radians.
    pub fn beta(&self) -> f64 {
        self.beta_deg.to_radians()
    }

    /// The physical edge length in mm, if one was given.
    pub fn edge_mm(&self) -> Option<f64> {
        self.edge_mm
    }

    /// Millimetres per unit of l (the edge length), if a physical scale was given.
    pub fn mm_per_l(&self) -> Option<f64> {
        self.edge_mm
    }

    /// w = tan β (eq 1): the unfolded module height, and the deployed slant height.
    pub fn w(&self) -> f64 {
        libm::tan(self.beta())
    }

    /// a = 1 / (2 cos β) (eq 2): the mountain fold length.
    pub fn a(&self) -> f64 {
        0.5 / libm::cos(self.beta())
    }

    /// r = 1 / (2 sin(180°/n)): circumradius of the boundary polygon (unit edges).
    pub fn r(&self) -> f64 {
        0.5 / libm::sin(PI / self.n as f64)
    }

    /// Apothem of the boundary polygon, 1 / (2 tan(180°/n)): centre to edge midpoint.
    pub fn apothem(&self) -> f64 {
        0.5 / libm::tan(PI / self.n as f64)
    }

    /// The flat-foldable fold angle 90°/n (eq 12), in degrees.
    pub fn flat_foldable_beta_deg(&self) -> f64 {
        90.0 / self.n as f64
    }

    /// Bottom boundary vertex `i` (eq 3): angle 360°·i/n, circumradius r, in the xy-plane.
    pub fn bottom_vertex(&self, i: u32) -> nalgebra::Point3<f64> {
        let t = 2.0 * PI * (i % self.n) as f64 / self.n as f64;
        let r = self.r();
        nalgebra::Point3::new(r * libm::cos(t), r * libm::sin(t), 0.0)
    }

    /// λ′ (eq 16): distance from an edge's line to the farthest boundary vertex.
    pub fn lambda_edge(&self) -> f64 {
        let t = PI / self.n as f64;
        if self.n.is_multiple_of(2) {
            libm::cos(t) / libm::sin(t)
        } else {
            (1.0 + libm::cos(t)) / (2.0 * libm::sin(t))
        }
    }

    /// λ (eq 28): distance from the tangent at a vertex to the farthest boundary vertex.
    pub fn lambda_vertex(&self) -> f64 {
        let t = PI / self.n as f64;
        if self.n.is_multiple_of(2) {
            1.0 / libm::sin(t)
        } else {
            (1.0 + libm::cos(t)) / (2.0 * libm::sin(t))
        }
    }
}
