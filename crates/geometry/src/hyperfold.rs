//! The self-packed (hyperfolded) module built in 3D (paper §3.1.2, Table 1, eqs 13–15).
//!
//! # The configuration (derived in `docs/geometry.md`, "Self-packed")
//!
//! Fully compacted: d = 0 and θ_in = θ_out = 0, so every top vertex lies on its bottom vertex
//! (T_j = B_j) and every top facet on its bottom facet. What is left is one closed strip of 2n
//! triangles per layer: the inner triangles B_jB_{j+1}P_j and the outer triangles
//! B_jP_{j−1}P_j, each flat-folded onto its neighbours across the mountain folds. Laid flat,
//! that strip wraps around a centre C with an angle of 4β per module edge, i.e. 4nβ in all,
//! which is 360° only at the flat-foldable β = 90°/n. For β > 90°/n the surplus angle is
//! taken up by a saddle: the strip is cut along the symmetry axis of *every* triangle into 2n
//! facets of apex angle 2β at C, and consecutive facets turn against each other by the
//! hyperfold angle ζ about those axes — the **virtual creases**:
//!
//! * through each inner triangle, from P_j to the midpoint E_j of the boundary edge
//!   B_jB_{j+1} (flat length w/2), so the boundary valley fold is bent at E_j;
//! * through each outer triangle, from B_j to the midpoint K_j of the mid valley fold
//!   P_{j−1}P_j (flat length w/2), so the mid valley fold is bent at K_j.
//!
//! With C at the origin the 2n facet edges (rays) alternate up and down: the rays through the
//! boundary nodes B_j rise at ε, the rays through the mid-plane nodes P_j (and E_j) fall at
//! −ε, cos ε = cos β / cos(90°/n), azimuths 360°·j/n and 360°·j/n + 180°/n. On those rays
//! |CB_j| = |CP_j| = ρ = 1/(2 sin 2β) and |CE_j| = |CK_j| = r_in = 1/(2 tan 2β) (eq 14).
//! Then every crease keeps its flat length exactly and the dihedral between consecutive
//! facets is ζ with cos ζ = (2 sin²(90°/n) − sin²β)/sin²β (eq 13). Both are *measured* here
//! ([`SelfPacked3d::hyperfold_angle`], [`SelfPacked3d::inner_radius`]) and tested.
//!
//! The construction exists for β ∈ [90°/n, 45°]: below 90°/n cos ε > 1; above 45° r_in < 0
//! and the edge midpoints pass through the centre where all facets meet (eq 15). At 90°/n it
//! is the flat-folded state (ε = ζ = 0, B_j on eq 3's polygon); at 45° the edge midpoints all
//! touch at the centre.

use core::f64::consts::PI;
use core::fmt;

use nalgebra::{Point3, Vector3};

use crate::design::{ModuleDesign, MAX_N};

const N: usize = MAX_N as usize;

/// Why a module has no self-packed (hyperfolded) configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SelfPackError {
    /// β < 90°/n: the strip's angle 4nβ is short of 360°; such a module folds (eqs 10–12)
    /// but never closes to d = 0.
    BelowFlatFoldable,
    /// β > 45°: r_in = 1/(2 tan 2β) < 0, the layer passes through its own centre (eq 15).
    Above45,
}

impl fmt::Display for SelfPackError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SelfPackError::BelowFlatFoldable => {
                f.write_str("no self-packed state: beta is below the flat-foldable 90/n degrees")
            }
            SelfPackError::Above45 => {
                f.write_str("no self-packed state: beta above 45 degrees self-intersects")
            }
        }
    }
}

impl core::error::Error for SelfPackError {}

/// Which crease a segment of the self-packed module belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CreaseKind {
    /// Half of a boundary valley fold B_jB_{j+1} (flat length 1/2; bent at E_j).
    BoundaryValley,
    /// A mountain fold B_jP_j or B_{j+1}P_j (flat length a).
    Mountain,
    /// Half of a mid valley fold P_{j−1}P_j (flat length 1/2; bent at K_j).
    MidValley,
    /// Virtual crease across inner triangle j, P_j → E_j (flat length w/2).
    VirtualInner,
    /// Virtual crease across the outer triangle at vertex j, B_j → K_j (flat length w/2).
    VirtualOuter,
}

/// One straight crease segment of the self-packed module and its flat-pattern length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crease {
    /// Which crease.
    pub kind: CreaseKind,
    /// The vertex index j it belongs to (see [`CreaseKind`]).
    pub index: usize,
    /// One end.
    pub from: Point3<f64>,
    /// The other end.
    pub to: Point3<f64>,
    /// Its length in the flat pattern (units of l).
    pub flat_length: f64,
}

impl Crease {
    /// Length in 3D (units of l).
    pub fn length(&self) -> f64 {
        (self.to - self.from).norm()
    }

    /// Relative length error against the flat pattern.
    pub fn strain(&self) -> f64 {
        libm::fabs(self.length() - self.flat_length) / self.flat_length
    }
}

/// The self-packed (hyperfolded) module built in 3D, centre of the hyperfold at the origin,
/// z the module axis. Fixed-size (no allocation): up to [`MAX_N`] sides.
///
/// Top vertices coincide with bottom vertices (d = 0, θ_in = θ_out = 0), so one layer
/// describes the module: [`Self::top`] returns the same points as [`Self::bottom`].
#[derive(Debug, Clone)]
pub struct SelfPacked3d {
    design: ModuleDesign,
    epsilon: f64,
    rho: f64,
    r_in: f64,
    bottom: [Point3<f64>; N],
    mid: [Point3<f64>; N],
    edge_bend: [Point3<f64>; N],
    mid_bend: [Point3<f64>; N],
}

impl SelfPacked3d {
    /// Builds the self-packed module of `design`, β ∈ [90°/n, 45°] (at 90°/n, within the
    /// 1e-9° of [`ModuleDesign::is_flat_foldable`], it is the flat-folded state).
    pub fn build(design: &ModuleDesign) -> Result<Self, SelfPackError> {
        let n = design.n() as usize;
        let beta = design.beta();
        let half = PI / (2.0 * n as f64);
        let flat = design.is_flat_foldable();
        if !flat && design.beta_deg() < design.flat_foldable_beta_deg() {
            return Err(SelfPackError::BelowFlatFoldable);
        }
        if design.beta_deg() > 45.0 {
            return Err(SelfPackError::Above45);
        }
        // cos ε = cos β / cos(90°/n): consecutive rays (azimuth step 180°/n, elevations ±ε)
        // must be 2β apart, cos 2β = cos²ε cos(180°/n) − sin²ε.
        let epsilon = if flat {
            0.0
        } else {
            libm::acos((libm::cos(beta) / libm::cos(half)).min(1.0))
        };
        let rho = 0.5 / libm::sin(2.0 * beta);
        // r_in = ρ cos 2β = 1/(2 tan 2β), written so that it is exactly 0 at 45°.
        let r_in = if libm::fabs(design.beta_deg() - 45.0) <= 1e-12 {
            0.0
        } else {
            rho * libm::cos(2.0 * beta)
        };
        let (ce, se) = (libm::cos(epsilon), libm::sin(epsilon));
        let ray = |azimuth: f64, up: bool| {
            let z = if up { se } else { -se };
            Vector3::new(ce * libm::cos(azimuth), ce * libm::sin(azimuth), z)
        };
        let mut bottom = [Point3::origin(); N];
        let mut mid = [Point3::origin(); N];
        let mut edge_bend = [Point3::origin(); N];
        let mut mid_bend = [Point3::origin(); N];
        for j in 0..n {
            let phi = 2.0 * PI * j as f64 / n as f64;
            let ub = ray(phi, true);
            let up = ray(phi + 2.0 * half, false);
            bottom[j] = Point3::from(ub * rho);
            mid_bend[j] = Point3::from(ub * r_in);
            mid[j] = Point3::from(up * rho);
            edge_bend[j] = Point3::from(up * r_in);
        }
        Ok(Self {
            design: *design,
            epsilon,
            rho,
            r_in,
            bottom,
            mid,
            edge_bend,
            mid_bend,
        })
    }

    fn n(&self) -> usize {
        self.design.n() as usize
    }

    /// The design.
    pub fn design(&self) -> &ModuleDesign {
        &self.design
    }

    /// Boundary vertices B_0 … B_{n−1}: a planar regular n-gon at height ρ sin ε, circumradius
    /// ρ cos ε = 1/(4 sin β cos(90°/n)) (r at the flat-foldable β, smaller above it).
    pub fn bottom(&self) -> &[Point3<f64>] {
        &self.bottom[..self.n()]
    }

    /// Top boundary vertices: the same points as [`Self::bottom`] (d = 0).
    pub fn top(&self) -> &[Point3<f64>] {
        self.bottom()
    }

    /// Mid-plane vertices P_0 … P_{n−1}, P_i over edge (i, i+1): a regular n-gon at height
    /// −ρ sin ε, rotated by 180°/n.
    pub fn mid(&self) -> &[Point3<f64>] {
        &self.mid[..self.n()]
    }

    /// E_j: where the virtual crease of inner triangle j bends the boundary edge B_jB_{j+1}
    /// (its midpoint; distance r_in from the centre).
    pub fn edge_bend(&self, j: usize) -> Point3<f64> {
        self.edge_bend[j % self.n()]
    }

    /// K_j: where the virtual crease of the outer triangle at vertex j bends the mid valley
    /// fold P_{j−1}P_j (its midpoint; distance r_in from the centre).
    pub fn mid_fold_bend(&self, j: usize) -> Point3<f64> {
        self.mid_bend[j % self.n()]
    }

    /// Elevation ε of the rays through B_j above the plane through the centre (radians);
    /// the rays through P_j fall by the same angle.
    pub fn twist_elevation(&self) -> f64 {
        self.epsilon
    }

    /// |CB_j| = |CP_j| = 1/(2 sin 2β).
    pub fn node_radius(&self) -> f64 {
        self.rho
    }

    /// Axial thickness of the packed layer, 2ρ sin ε (0 when flat-folded): the B nodes at
    /// +ρ sin ε, the P nodes at −ρ sin ε.
    pub fn thickness(&self) -> f64 {
        2.0 * self.rho * libm::sin(self.epsilon)
    }

    /// Slant height d: distance between the centroids of the top and bottom boundary (0).
    pub fn height(&self) -> f64 {
        (centroid(self.top()) - centroid(self.bottom())).norm()
    }

    /// All 8n straight crease segments of one layer (the top layer coincides), each with
    /// its flat-pattern length: per vertex j the two halves of the boundary edge j, the two
    /// mountain folds at P_j, the two halves of the mid valley fold at vertex j, and the
    /// virtual creases P_jE_j and B_jK_j.
    pub fn creases(&self) -> impl Iterator<Item = Crease> + '_ {
        let n = self.n();
        (0..8 * n).map(move |k| self.crease(k / 8, k % 8))
    }

    fn crease(&self, j: usize, which: usize) -> Crease {
        let n = self.n();
        let d = &self.design;
        let (b0, b1) = (self.bottom[j], self.bottom[(j + 1) % n]);
        let (p_prev, p) = (self.mid[(j + n - 1) % n], self.mid[j]);
        let (e, k) = (self.edge_bend[j], self.mid_bend[j]);
        let half_w = 0.5 * d.w();
        let (kind, from, to, flat_length) = match which {
            0 => (CreaseKind::BoundaryValley, b0, e, 0.5),
            1 => (CreaseKind::BoundaryValley, e, b1, 0.5),
            2 => (CreaseKind::Mountain, b0, p, d.a()),
            3 => (CreaseKind::Mountain, b1, p, d.a()),
            4 => (CreaseKind::MidValley, p_prev, k, 0.5),
            5 => (CreaseKind::MidValley, k, p, 0.5),
            6 => (CreaseKind::VirtualInner, p, e, half_w),
            _ => (CreaseKind::VirtualOuter, b0, k, half_w),
        };
        Crease {
            kind,
            index: j,
            from,
            to,
            flat_length,
        }
    }

    /// The 2n virtual creases of one layer: P_jE_j (inner triangles) then B_jK_j (outer).
    pub fn virtual_creases(&self) -> impl Iterator<Item = Crease> + '_ {
        self.creases()
            .filter(|c| matches!(c.kind, CreaseKind::VirtualInner | CreaseKind::VirtualOuter))
    }

    /// The 4n half-triangle panels of one layer (each real triangle split by its virtual
    /// crease), in facet order: facet 2j (between the rays through B_j and P_j) holds
    /// (B_j, E_j, P_j) and (B_j, P_j, K_j); facet 2j+1 (between P_j and B_{j+1}) holds
    /// (E_j, B_{j+1}, P_j) and (B_{j+1}, K_{j+1}, P_j).
    pub fn panels(&self) -> impl Iterator<Item = (usize, [Point3<f64>; 3])> + '_ {
        let n = self.n();
        (0..4 * n).map(move |k| {
            let j = k / 4;
            let j1 = (j + 1) % n;
            let (b0, b1, p) = (self.bottom[j], self.bottom[j1], self.mid[j]);
            let (e, k0, k1) = (self.edge_bend[j], self.mid_bend[j], self.mid_bend[j1]);
            match k % 4 {
                0 => (2 * j, [b0, e, p]),
                1 => (2 * j, [b0, p, k0]),
                2 => (2 * j + 1, [e, b1, p]),
                _ => (2 * j + 1, [b1, k1, p]),
            }
        })
    }

    /// Largest relative crease-length error against the flat pattern ("strain", as
    /// [`crate::Module3d::max_strain`]), over every segment of [`Self::creases`].
    pub fn max_strain(&self) -> f64 {
        self.creases().map(|c| c.strain()).fold(0.0, f64::max)
    }

    /// Measured hyperfold angle at virtual crease `k` (radians): the turn between the two
    /// halves of the triangle it splits, 0 when they are coplanar (flat-folded). Even
    /// k = 2j: the outer triangle at vertex j (axis B_jK_j, halves towards P_{j−1} and P_j);
    /// odd k = 2j+1: inner triangle j (axis P_jE_j, halves towards B_j and B_{j+1}).
    pub fn hyperfold_angle(&self, k: usize) -> f64 {
        let n = self.n();
        let k = k % (2 * n);
        let j = k / 2;
        let (o, axis_end, x, y) = if k.is_multiple_of(2) {
            (
                self.mid_bend[j],
                self.bottom[j],
                self.mid[(j + n - 1) % n],
                self.mid[j],
            )
        } else {
            (
                self.edge_bend[j],
                self.mid[j],
                self.bottom[j],
                self.bottom[(j + 1) % n],
            )
        };
        let axis = (axis_end - o).normalize();
        let perp = |p: Point3<f64>| {
            let v = p - o;
            v - axis * axis.dot(&v)
        };
        let (u, v) = (perp(x), perp(y));
        // The dihedral between the halves is the angle between u and v; the turn is its
        // supplement. atan2 keeps it accurate near 0 where acos is not.
        PI - libm::atan2(u.cross(&v).norm(), u.dot(&v))
    }

    /// Measured inner radius: the smallest distance from the centre of the hyperfold (the
    /// origin) to any panel of the layer (eq 14's "minimum radial distance from the origin").
    pub fn inner_radius(&self) -> f64 {
        self.panels()
            .map(|(_, t)| closest_on_triangle(Point3::origin(), t).coords.norm())
            .fold(f64::INFINITY, f64::min)
    }

    /// r_in from the construction, 1/(2 tan 2β) (0 at 45°).
    pub fn r_in(&self) -> f64 {
        self.r_in
    }
}

fn centroid(ps: &[Point3<f64>]) -> Point3<f64> {
    let mut s = Vector3::zeros();
    for p in ps {
        s += p.coords;
    }
    Point3::from(s / ps.len().max(1) as f64)
}

/// Closest point to `p` on triangle `t` (Ericson, *Real-Time Collision Detection*, 5.1.5).
pub(crate) fn closest_on_triangle(p: Point3<f64>, t: [Point3<f64>; 3]) -> Point3<f64> {
    let [a, b, c] = t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom.abs() < f64::MIN_POSITIVE {
        // Degenerate (zero-area) triangle: fall back to the nearest vertex.
        let da = (p - a).norm_squared();
        let db = (p - b).norm_squared();
        let dc = (p - c).norm_squared();
        return if da <= db && da <= dc {
            a
        } else if db <= dc {
            b
        } else {
            c
        };
    }
    a + ab * (vb / denom) + ac * (vc / denom)
}

impl ModuleDesign {
    /// The self-packed module built in 3D ([`SelfPacked3d`]); β ∈ [90°/n, 45°].
    pub fn build_self_packed(&self) -> Result<SelfPacked3d, SelfPackError> {
        SelfPacked3d::build(self)
    }
}
