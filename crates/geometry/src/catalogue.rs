//! The catalogue of metastable states: closed-form (d, γ, ψ) per state (Table 1, §3.2) with
//! the corrections derived in `docs/geometry.md`, checked by the 3D construction.

use core::f64::consts::PI;

use crate::construct::Module3d;
use crate::design::ModuleDesign;
use crate::pose::Pose;
use crate::state::{ShapeState, ShapeStates, SymmetricState};

/// Largest strain (relative crease-length error, see [`Module3d::max_strain`]) for which a
/// state counts as feasible: 1 %. Closed-form states that close exactly show ≲ 1e-12; the
/// pop-out residuals of n ≥ 4 modules grow continuously away from β_in/β_out, and 1 % is
/// about what a printed TPU hinge absorbs (documented in `docs/geometry.md`).
pub const STRAIN_TOLERANCE: f64 = 1e-2;

/// Tolerance used to call a closed form "exact" in tests and docs.
pub const EXACT_TOLERANCE: f64 = 1e-9;

/// A catalogue state with its pose and what the 3D construction says about it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct StateInfo {
    /// Which state.
    pub state: ShapeState,
    /// Closed-form pose (d in units of l).
    pub pose: Pose,
    /// The state exists for this β: its closed form is defined (e.g. β ≥ 90°/n for folded,
    /// w ≤ 2λ′ for pop-outs), d ≤ w, and `max_strain` ≤ [`STRAIN_TOLERANCE`].
    pub feasible: bool,
    /// Largest relative crease-length error of the 3D construction against the flat pattern.
    pub max_strain: f64,
    /// The common dihedral angle θ = θ_in = θ_out (radians) of a symmetric state; `None` for
    /// pop-outs (θ_in ≠ θ_out) and where the state does not exist.
    pub theta: Option<f64>,
}

/// Wraps an angle into [0, 2π).
pub(crate) fn wrap_2pi(a: f64) -> f64 {
    let t = 2.0 * PI;
    let r = a - t * libm::floor(a / t);
    if r >= t {
        0.0
    } else {
        r
    }
}

impl ModuleDesign {
    /// The 2(n+1) catalogue states, in order: deployed, folded, edge-0 … edge-(n−1),
    /// vertex-0 … vertex-(n−1).
    pub fn shape_states(&self) -> impl Iterator<Item = ShapeState> {
        ShapeStates::new(self.n())
    }

    /// Closed-form pose of a catalogue state (d in units of l):
    ///
    /// * deployed: d = w = tan β, γ = ψ = 0;
    /// * folded: d = √(w² − tan²(90°/n)) (eqs 10–11), γ = ψ = 0; d = 0 when β < 90°/n;
    /// * edge-i: γ = 2 asin(w / 2λ′) (eq 21), d = sin(γ/2) / tan(180°/n) (eq 23 corrected),
    ///   ψ = 360°·i/n + 180°/n + 90° (eq 24 corrected to eq 5's frame);
    /// * vertex-i: γ = 2 asin(w / 2λ) (eq 29), d = sin(γ/2) / sin(180°/n) (eq 31),
    ///   ψ = 360°·i/n + 90° (eq 32 corrected).
    ///
    /// Where w/2λ > 1 the pop-out does not exist; γ is clamped to 180° and the state is
    /// reported infeasible by [`ModuleDesign::state_info`].
    pub fn pose(&self, s: ShapeState) -> Pose {
        let n = self.n() as f64;
        let w = self.w();
        match s {
            ShapeState::Deployed => Pose::straight(w),
            ShapeState::Folded => Pose::straight(self.folded_d().unwrap_or(0.0)),
            ShapeState::Edge(i) => {
                let gamma = 2.0 * libm::asin((w / (2.0 * self.lambda_edge())).min(1.0));
                let d = 2.0 * self.apothem() * libm::sin(0.5 * gamma);
                let psi = wrap_2pi(2.0 * PI * i as f64 / n + PI / n + 0.5 * PI);
                Pose::new(d, gamma, psi)
            }
            ShapeState::Vertex(i) => {
                let gamma = 2.0 * libm::asin((w / (2.0 * self.lambda_vertex())).min(1.0));
                let d = 2.0 * self.r() * libm::sin(0.5 * gamma);
                let psi = wrap_2pi(2.0 * PI * i as f64 / n + 0.5 * PI);
                Pose::new(d, gamma, psi)
            }
        }
    }

    /// Whether the closed form of `s` is defined for this β (before any strain check).
    pub fn state_exists(&self, s: ShapeState) -> bool {
        match s {
            ShapeState::Deployed => true,
            ShapeState::Folded => self.folded_d().is_some(),
            ShapeState::Edge(i) => (i as u32) < self.n() && self.w() <= 2.0 * self.lambda_edge(),
            ShapeState::Vertex(i) => {
                (i as u32) < self.n() && self.w() <= 2.0 * self.lambda_vertex()
            }
        }
    }

    /// Pose, feasibility, strain and θ of a catalogue state, from its 3D construction.
    pub fn state_info(&self, s: ShapeState) -> StateInfo {
        let pose = self.pose(s);
        let max_strain = Module3d::build(self, &pose).max_strain();
        let exists = self.state_exists(s);
        let feasible = exists
            && pose.d <= self.w() * (1.0 + EXACT_TOLERANCE)
            && max_strain <= STRAIN_TOLERANCE;
        let theta = match s {
            ShapeState::Deployed => Some(PI),
            ShapeState::Folded => self.folded_theta(),
            _ => None,
        };
        StateInfo {
            state: s,
            pose,
            feasible,
            max_strain,
            theta,
        }
    }

    /// Builds the module in state `s` in 3D.
    pub fn build(&self, s: ShapeState) -> Module3d {
        Module3d::build(self, &self.pose(s))
    }

    /// θ of the folded state: cos(θ/2) = tan(90°/n) / tan β (eq 11; Table 1's entry has
    /// tan(θ/2) in place of tan β, a typo). `None` when β < 90°/n.
    pub fn folded_theta(&self) -> Option<f64> {
        let c = libm::tan(PI / (2.0 * self.n() as f64)) / self.w();
        if c > 1.0 {
            None
        } else {
            Some(2.0 * libm::acos(c))
        }
    }

    /// d of the folded state, w sin(θ/2) = √(w² − tan²(90°/n)) (eq 10). `None` when β < 90°/n.
    pub fn folded_d(&self) -> Option<f64> {
        let t = libm::tan(PI / (2.0 * self.n() as f64));
        let w = self.w();
        if w < t {
            None
        } else {
            Some(libm::sqrt((w - t) * (w + t)))
        }
    }

    /// Whether β is (within 1e-9°) the flat-foldable angle 90°/n.
    pub fn is_flat_foldable(&self) -> bool {
        libm::fabs(self.beta_deg() - self.flat_foldable_beta_deg()) <= 1e-9
    }

    /// Whether β ∈ (90°/n, 45°], the self-packed range of Table 1.
    pub fn can_self_pack(&self) -> bool {
        let b = self.beta_deg();
        b > self.flat_foldable_beta_deg() && b <= 45.0 && !self.is_flat_foldable()
    }

    /// Hyperfold angle ζ (eq 13), radians:
    /// cos ζ = (2 sin²(90°/n) − sin²β) / sin²β, for β ∈ (90°/n, 45°]; `None` outside.
    /// Verified as the measured turn between consecutive facets of the 3D construction
    /// ([`crate::SelfPacked3d::hyperfold_angle`]).
    ///
    /// Evaluated in the equivalent half-angle form sin(ζ/2) = √(sin(β − x) sin(β + x)) / sin β,
    /// x = 90°/n, because acos of eq 13's right-hand side loses half the digits near the
    /// flat-foldable limit where it approaches 1.
    pub fn zeta(&self) -> Option<f64> {
        if !self.can_self_pack() {
            return None;
        }
        let x = PI / (2.0 * self.n() as f64);
        let b = self.beta();
        let s2 = (libm::sin(b - x) * libm::sin(b + x)).max(0.0);
        Some(2.0 * libm::asin((libm::sqrt(s2) / libm::sin(b)).min(1.0)))
    }

    /// Inner radius of the self-packed layer, r_in = 1 / (2 tan 2β) (eq 14), units of l, for
    /// β ∈ (90°/n, 45°]; `None` outside. Verified as the measured distance from the hyperfold's
    /// centre to its nearest panel ([`crate::SelfPacked3d::inner_radius`]).
    pub fn r_in(&self) -> Option<f64> {
        if !self.can_self_pack() {
            return None;
        }
        if libm::fabs(self.beta_deg() - 45.0) <= 1e-12 {
            return Some(0.0);
        }
        Some(0.5 / libm::tan(2.0 * self.beta()))
    }

    /// Pose of a symmetric state (Table 1), `None` where the state does not exist for this β:
    /// deployed d = w; folded d = w sin(θ/2) (β ≥ 90°/n); flat-folded d = 0 (β = 90°/n only);
    /// self-packed d = 0 (β ∈ (90°/n, 45°]). This is the axial height a simulator needs.
    pub fn symmetric_pose(&self, s: SymmetricState) -> Option<Pose> {
        match s {
            SymmetricState::Deployed => Some(Pose::straight(self.w())),
            SymmetricState::Folded => self.folded_d().map(Pose::straight),
            SymmetricState::FlatFolded => self.is_flat_foldable().then_some(Pose::straight(0.0)),
            SymmetricState::SelfPacked => self.can_self_pack().then_some(Pose::straight(0.0)),
        }
    }

    /// The self-packed state's pose (d = 0), `None` outside β ∈ (90°/n, 45°].
    pub fn self_packed(&self) -> Option<Pose> {
        self.symmetric_pose(SymmetricState::SelfPacked)
    }

    /// Axial height d (units of l) of a symmetric state, `None` where it does not exist.
    pub fn symmetric_height(&self, s: SymmetricState) -> Option<f64> {
        self.symmetric_pose(s).map(|p| p.d)
    }
}
