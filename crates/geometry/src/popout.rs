//! The limiting fold angles β_in (one pop-out, eqs 17–22) and β_out (two pop-out, eqs 25–30),
//! found numerically without `std`.
//!
//! In the paper's frames, eq 22 says the mid-plane point next to the coinciding edge is a unit
//! distance from the coinciding edge's own mid-plane point, and eq 30 says the flattened
//! triangle at the coinciding vertex has its mid valley fold of length 1 while the next
//! mountain fold keeps length a. In the 3D construction ([`crate::Module3d`]) both are the
//! closure of the rhombus next to the collapse: for `edge-0`, |P_0P_1| = 1 (vertex 1); for
//! `vertex-0`, |P_{n−1}P_0| = 1 (vertex 0). With γ from eqs 21/29 and the corrected d and ψ,
//! that residual is a function of β alone, solved here by a scan and bisection.

use crate::design::ModuleDesign;
use crate::state::ShapeState;

/// Signed closure residual |P_0P_1| − 1 of `edge-0` at fold angle `beta_deg`.
pub fn edge_residual(n: u32, beta_deg: f64) -> Option<f64> {
    let d = ModuleDesign::new(n, beta_deg).ok()?;
    let s = ShapeState::Edge(0);
    d.state_exists(s)
        .then(|| d.build(s).mid_fold_length(1) - 1.0)
}

/// Signed closure residual |P_{n−1}P_0| − 1 of `vertex-0` at fold angle `beta_deg`.
pub fn vertex_residual(n: u32, beta_deg: f64) -> Option<f64> {
    let d = ModuleDesign::new(n, beta_deg).ok()?;
    let s = ShapeState::Vertex(0);
    d.state_exists(s)
        .then(|| d.build(s).mid_fold_length(0) - 1.0)
}

/// Smallest root in (0°, 90°) of `f`, by a 0.05° scan then bisection to 1e-12°.
fn first_root(n: u32, f: fn(u32, f64) -> Option<f64>) -> Option<f64> {
    const STEP: f64 = 0.05;
    let mut lo = STEP;
    let mut flo = f(n, lo)?;
    let mut k = 2;
    loop {
        let hi = STEP * k as f64;
        if hi >= 90.0 {
            return None;
        }
        let fhi = f(n, hi)?;
        if flo == 0.0 {
            return Some(lo);
        }
        if (flo < 0.0) != (fhi < 0.0) {
            let (mut a, mut b, mut fa) = (lo, hi, flo);
            for _ in 0..60 {
                let m = 0.5 * (a + b);
                let fm = f(n, m)?;
                if (fm < 0.0) == (fa < 0.0) {
                    a = m;
                    fa = fm;
                } else {
                    b = m;
                }
                if b - a < 1e-12 {
                    break;
                }
            }
            return Some(0.5 * (a + b));
        }
        lo = hi;
        flo = fhi;
        k += 1;
    }
}

/// β_in in degrees: the fold angle at which the one-pop-out state closes at its coinciding
/// edge (eqs 21–22). `None` if no root exists for this n.
pub fn beta_in_deg(n: u32) -> Option<f64> {
    first_root(n, edge_residual)
}

/// β_out in degrees: the fold angle at which the two-pop-out state closes at its coinciding
/// vertex (eqs 29–30). `None` if no root exists for this n.
pub fn beta_out_deg(n: u32) -> Option<f64> {
    first_root(n, vertex_residual)
}
