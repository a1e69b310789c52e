//! Mirror symmetry: a vertical plane through the boom's axis that maps the target onto itself
//! and every module's candidate set onto itself.
//!
//! If M (the reflection in the plane) fixes every target point, and for every module and
//! candidate a the conjugate `M·T_a·M` is again a candidate σ(a) of that module, then the boom
//! σ(s) (every state mirrored) has tips `M·x_i(s)` — the base frame is fixed by M — and hence
//! the same cost as s under both metrics (M is an isometry fixing the polyline and the ordered
//! stations). So the search may keep only one of s and σ(s): the *canonical* one, in which the
//! first module whose state is not its own mirror has `a < σ(a)`. Both conditions are checked
//! numerically, never assumed. The planar generators (`sine`, `arc`, in the x–z plane) have
//! this symmetry with the geometry's catalogues (their pop-out phases ψ come in pairs ψ, π − ψ,
//! e.g. n = 3: 30°/150°, 270°; n = 4: 45°/135°, 0°/180°); the helix does not.

use nalgebra::{Matrix3, Vector3};

use super::{Frame, Problem};

/// Relative tolerance of the symmetry checks (the mirrored data must match to rounding).
const TOL: f64 = 1e-12;

/// The candidate permutation of a mirror symmetry: `sigma[i][a]` is the mirror image of
/// candidate a of module i.
#[derive(Debug, Clone, PartialEq)]
pub struct Mirror {
    /// Per module, the mirror image of each candidate.
    pub sigma: Vec<Vec<usize>>,
    /// Unit normal of the mirror plane (horizontal).
    pub normal: Vector3<f64>,
}

impl Mirror {
    /// Whether the prefix `states` (module 0 first) is canonical: its first state that is not
    /// its own mirror is the smaller of the pair.
    pub fn canonical(&self, states: &[usize]) -> bool {
        for (i, &a) in states.iter().enumerate() {
            let b = self.sigma[i][a];
            if a != b {
                return a < b;
            }
        }
        true
    }

    /// Whether every state of `states` is its own mirror.
    pub fn fixed(&self, states: &[usize]) -> bool {
        states
            .iter()
            .enumerate()
            .all(|(i, &a)| self.sigma[i][a] == a)
    }
}

fn close(a: &Frame, b: &Frame) -> bool {
    let scale = 1.0 + a.translation.norm();
    (a.rotation - b.rotation).abs().max() <= TOL
        && (a.translation - b.translation).abs().max() <= TOL * scale
}

/// The mirror symmetry of `problem`, if it has one.
pub fn find(problem: &Problem) -> Option<Mirror> {
    let target = problem.objective.target();
    let pts = target.points();
    let scale = pts.iter().map(|p| p.coords.amax()).fold(1.0, f64::max);
    // The plane contains the z axis and the point farthest from it.
    let far = pts
        .iter()
        .max_by(|a, b| (a.x * a.x + a.y * a.y).total_cmp(&(b.x * b.x + b.y * b.y)))?;
    let r = (far.x * far.x + far.y * far.y).sqrt();
    let normal = if r <= TOL * scale {
        Vector3::y()
    } else {
        Vector3::new(-far.y / r, far.x / r, 0.0)
    };
    let on_plane = |v: &Vector3<f64>| v.dot(&normal).abs() <= TOL * scale;
    if !pts.iter().all(|p| on_plane(&p.coords)) {
        return None;
    }
    if !problem
        .objective
        .stations()
        .iter()
        .all(|p| on_plane(&p.coords))
    {
        return None;
    }
    let m: Matrix3<f64> = Matrix3::identity() - 2.0 * normal * normal.transpose();
    let mut sigma = Vec::with_capacity(problem.m());
    for i in 0..problem.m() {
        let cands = problem.catalogue.candidates(i);
        let mut perm = Vec::with_capacity(cands.len());
        for c in cands {
            let mirrored = Frame {
                rotation: m * c.frame.rotation * m,
                translation: m * c.frame.translation,
            };
            let b = cands.iter().position(|d| close(&d.frame, &mirrored))?;
            perm.push(b);
        }
        sigma.push(perm);
    }
    Some(Mirror { sigma, normal })
}
