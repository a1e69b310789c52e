//! The 3D construction of one module for any pose (eqs 3–9): bottom, mid-plane and top
//! vertices, crease lengths against the flat pattern, dihedral angles and strain.
//!
//! # The flat pattern of one module (units of l)
//!
//! Bottom vertices B_j and top vertices T_j (valley folds B_jB_{j+1}, T_jT_{j+1} of length 1),
//! one mid-plane point P_i per edge (mountain folds B_iP_i, B_{i+1}P_i, T_iP_i, T_{i+1}P_i of
//! length a = 1/(2 cos β)), and mid valley folds P_{j−1}P_j of length 1. Around each vertex j
//! the four mountain folds bound a rhombus B_j P_{j−1} T_j P_j whose diagonals are the mid
//! valley fold P_{j−1}P_j (flat length 1) and the *virtual crease* B_jT_j (flat length w).
//! A rigid rhombus folds along one diagonal only: either |P_{j−1}P_j| = 1 (the column is
//! folded, |B_jT_j| ≤ w) or |B_jT_j| = w (the column is stretched, |P_{j−1}P_j| ≤ 1).
//!
//! # Mid-plane points (eqs 6–9, with the γ = 0 fix)
//!
//! T is a rotation by γ about a hinge line in the bottom plane (or a translation when γ = 0),
//! so the *mid-plane* through that hinge at γ/2, with normal m = Rz(ψ)·Rx(γ/2)·ẑ, mirrors every
//! bottom vertex onto its top vertex. Every point equidistant from A, B, A′, B′ therefore lies
//! on the line where the mid-plane meets the bisector plane of AB; its direction is
//! u = (B − A) × m / |…| (the normal of the quadrilateral ABB′A′, eq 6's ê up to sign). That
//! replaces eq 6's cross product (B − A) × (B′ − A′), which vanishes when γ = 0 (parallel edges)
//! and when A = A′, B = B′ (a coinciding edge). O_c is the point of that line in the plane of
//! the quadrilateral (its circumcentre) and P = O_c + e·u, e = √(a² − |A − O_c|²) (eqs 8–9),
//! on the outer side (u points away from the module axis). When a² < |A − O_c|² no point
//! exists: P = O_c and the mountain folds are stretched by |A − O_c|/a − 1.

use nalgebra::{Point3, Vector3};

use crate::design::{ModuleDesign, MAX_N};
use crate::pose::Pose;

/// The self-packed state leaves eq 5's framework (its boundary is no longer the eq 3
/// polygon), so it has its own construction; re-exported here beside [`Module3d`].
pub use crate::hyperfold::SelfPacked3d;

const N: usize = MAX_N as usize;

/// Which diagonal of the rhombus around a vertex is folded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnFold {
    /// Folded along the mid valley fold P_{j−1}P_j (|B_jT_j| ≤ w).
    Folded,
    /// Folded along the virtual crease B_jT_j, stretched to w (|P_{j−1}P_j| ≤ 1).
    Stretched,
}

/// A module built in 3D for a pose. Fixed-size (no allocation): vertices for up to
/// [`MAX_N`] sides.
#[derive(Debug, Clone)]
pub struct Module3d {
    design: ModuleDesign,
    pose: Pose,
    bottom: [Point3<f64>; N],
    top: [Point3<f64>; N],
    mid: [Point3<f64>; N],
    /// Relative stretch of the mountain folds at P_i (0 when eq 8 has a real root).
    mountain_err: [f64; N],
}

impl Module3d {
    /// Builds the module of `design` in `pose`.
    pub fn build(design: &ModuleDesign, pose: &Pose) -> Self {
        let n = design.n() as usize;
        let iso = pose.isometry();
        let m = pose.mid_plane_normal();
        let a = design.a();
        let mut bottom = [Point3::origin(); N];
        let mut top = [Point3::origin(); N];
        for j in 0..n {
            bottom[j] = design.bottom_vertex(j as u32);
            top[j] = iso * bottom[j];
        }
        let mut mid = [Point3::origin(); N];
        let mut mountain_err = [0.0; N];
        for i in 0..n {
            let (pa, pb) = (bottom[i], bottom[(i + 1) % n]);
            let ta = top[i];
            let t = (pb - pa).normalize();
            let mut u = t.cross(&m);
            let un = u.norm();
            let mid_ab = Point3::from((pa.coords + pb.coords) * 0.5);
            // Mid-plane: m·x = c, through the midpoint of A and its mirror image A′.
            let c = m.dot(&((pa.coords + ta.coords) * 0.5));
            // Direction in the quadrilateral's plane, perpendicular to AB.
            let v = m - t * m.dot(&t);
            let vv = m.dot(&v);
            let oc = if vv > 1e-12 {
                mid_ab + v * ((c - m.dot(&mid_ab.coords)) / vv)
            } else {
                mid_ab
            };
            if un > 1e-12 {
                u /= un;
            } else {
                u = Vector3::zeros();
            }
            let rho2 = (pa - oc).norm_squared();
            let e2 = a * a - rho2;
            if e2 >= 0.0 {
                mid[i] = oc + u * libm::sqrt(e2);
            } else {
                mid[i] = oc;
                mountain_err[i] = libm::sqrt(rho2) / a - 1.0;
            }
        }
        Self {
            design: *design,
            pose: *pose,
            bottom,
            top,
            mid,
            mountain_err,
        }
    }

    /// The design.
    pub fn design(&self) -> &ModuleDesign {
        &self.design
    }

    /// The pose it was built for.
    pub fn pose(&self) -> &Pose {
        &self.pose
    }

    /// Bottom boundary vertices B_0 … B_{n−1} (eq 3).
    pub fn bottom(&self) -> &[Point3<f64>] {
        &self.bottom[..self.design.n() as usize]
    }

    /// Top boundary vertices T_j = T·B_j (eq 4).
    pub fn top(&self) -> &[Point3<f64>] {
        &self.top[..self.design.n() as usize]
    }

    /// Mid-plane points P_0 … P_{n−1}, P_i over edge (i, i+1) (eqs 6–9).
    pub fn mid(&self) -> &[Point3<f64>] {
        &self.mid[..self.design.n() as usize]
    }

    fn n(&self) -> usize {
        self.design.n() as usize
    }

    /// Relative stretch of the four mountain folds at P_i (0 when they have length a).
    pub fn mountain_strain(&self, i: usize) -> f64 {
        self.mountain_err[i % self.n()]
    }

    /// Largest relative error of the mountain folds at P_i measured directly:
    /// max over B_i, B_{i+1}, T_i, T_{i+1} of ||X − P_i| − a| / a.
    pub fn mountain_length_error(&self, i: usize) -> f64 {
        let n = self.n();
        let i = i % n;
        let a = self.design.a();
        let p = self.mid[i];
        [
            self.bottom[i],
            self.bottom[(i + 1) % n],
            self.top[i],
            self.top[(i + 1) % n],
        ]
        .iter()
        .map(|x| libm::fabs((x - p).norm() - a) / a)
        .fold(0.0, f64::max)
    }

    /// |P_{j−1}P_j|: the mid valley fold at vertex j (flat length 1).
    pub fn mid_fold_length(&self, j: usize) -> f64 {
        let n = self.n();
        let j = j % n;
        (self.mid[j] - self.mid[(j + n - 1) % n]).norm()
    }

    /// |B_jT_j|: the virtual crease at vertex j (flat length w).
    pub fn column_length(&self, j: usize) -> f64 {
        let j = j % self.n();
        (self.top[j] - self.bottom[j]).norm()
    }

    /// Residual of the rhombus at vertex j and the diagonal it folds along: the smaller of
    /// the relative errors ||P_{j−1}P_j| − 1| and ||B_jT_j| − w| / w.
    pub fn column(&self, j: usize) -> (f64, ColumnFold) {
        let w = self.design.w();
        let eh = libm::fabs(self.mid_fold_length(j) - 1.0);
        let ev = libm::fabs(self.column_length(j) - w) / w;
        if eh <= ev {
            (eh, ColumnFold::Folded)
        } else {
            (ev, ColumnFold::Stretched)
        }
    }

    /// Largest relative crease-length error against the flat pattern ("strain"): over all
    /// boundary edges, mountain folds and rhombi (each rhombus by its better diagonal).
    pub fn max_strain(&self) -> f64 {
        let n = self.n();
        let mut s: f64 = 0.0;
        for j in 0..n {
            let k = (j + 1) % n;
            s = s.max(libm::fabs((self.bottom[k] - self.bottom[j]).norm() - 1.0));
            s = s.max(libm::fabs((self.top[k] - self.top[j]).norm() - 1.0));
            s = s.max(self.mountain_length_error(j));
            s = s.max(self.column(j).0);
        }
        s
    }

    /// θ_in at edge i: the angle at P_i between the inner facets B_iB_{i+1}P_i and
    /// T_iT_{i+1}P_i, from the chord between the edge midpoints: |M_iM′_i| = w sin(θ_in/2).
    /// 180° when deployed, 0 on a coinciding edge.
    pub fn theta_in(&self, i: usize) -> f64 {
        let n = self.n();
        let i = i % n;
        let mb = (self.bottom[i].coords + self.bottom[(i + 1) % n].coords) * 0.5;
        let mt = (self.top[i].coords + self.top[(i + 1) % n].coords) * 0.5;
        chord_angle((mt - mb).norm(), self.design.w())
    }

    /// θ_out at vertex j: the fold angle of the rhombus around vertex j, from the chord
    /// |B_jT_j| = w sin(θ_out/2). 180° when stretched, 0 at a coinciding vertex.
    pub fn theta_out(&self, j: usize) -> f64 {
        chord_angle(self.column_length(j), self.design.w())
    }
}

fn chord_angle(chord: f64, w: f64) -> f64 {
    2.0 * libm::asin((chord / w).clamp(0.0, 1.0))
}
