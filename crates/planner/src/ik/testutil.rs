//! Synthetic module catalogues for unit tests (eq 5 written out independently).

use nalgebra::{Isometry3, Vector3};

use super::{Candidate, Frame};

/// Eq 5 as the literal product Rz(ψ)·Rx(γ/2)·Tz(d)·Rx(γ/2)·Rz(−ψ).
pub fn eq5(d: f64, gamma: f64, psi: f64) -> Frame {
    let rz = |a: f64| Isometry3::rotation(Vector3::z() * a);
    let rx = |a: f64| Isometry3::rotation(Vector3::x() * a);
    let tz = Isometry3::translation(0.0, 0.0, d);
    Frame::from_isometry(&(rz(psi) * rx(0.5 * gamma) * tz * rx(0.5 * gamma) * rz(-psi)))
}

/// A 2(n+1)-state catalogue shaped like a Yoshimura module's (deployed, folded, n edge and n
/// vertex pop-outs), with made-up parameters.
pub fn synthetic(n: usize) -> Vec<Candidate> {
    let tau = std::f64::consts::TAU;
    let mut v = vec![
        Candidate {
            name: "deployed".into(),
            frame: eq5(1.3, 0.0, 0.0),
            feasible: true,
            strain: 0.0,
        },
        Candidate {
            name: "folded".into(),
            frame: eq5(0.35, 0.0, 0.0),
            feasible: true,
            strain: 0.0,
        },
    ];
    for i in 0..n {
        let psi = tau * i as f64 / n as f64 + tau / (2.0 * n as f64);
        v.push(Candidate {
            name: format!("edge-{i}"),
            frame: eq5(0.8, 0.55, psi),
            feasible: true,
            strain: 0.0,
        });
    }
    for i in 0..n {
        let psi = tau * i as f64 / n as f64;
        v.push(Candidate {
            name: format!("vertex-{i}"),
            frame: eq5(0.85, 0.45, psi),
            feasible: true,
            strain: 0.0,
        });
    }
    v
}
