//! What a fit can and cannot say about a design: how much of the target it covers and the
//! warnings that keep a "proven optimal" fit from misleading (docs/ik.md, "Honest fits").
//!
//! The optimum over a catalogue that cannot bend is a straight column; the optimum over a
//! boom shorter than its target covers part of it. Both are correct answers to the question
//! asked and wrong answers to the question a designer means, so [`assess`] says so, with the
//! number that decided it.

use geometry::ModuleDesign;
use nalgebra::{Point3, Vector3};

use super::{bands, Algorithm, Catalogue, Control, Metric, Problem, Target};

/// A cosine below which a candidate counts as bending: its top frame's axis tilts by more than
/// about 1.4·10⁻⁴° from the bottom's.
const STRAIGHT_COS: f64 = 1.0 - 1e-12;

/// How much of the target a boom covers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coverage {
    /// The fraction of the target's arc length within `radius` of some tip, in [0, 1].
    pub fraction: f64,
    /// The distance that counts as covered: the longest step |T·0| of any state of the boom
    /// (units of l), so that tips one step apart along the curve cover all of it.
    pub radius: f64,
    /// The target's arc length L, units of l.
    pub length: f64,
}

impl Coverage {
    /// The covered fraction in [0, 1] (1 for a target of length 0 with a tip within reach).
    pub fn fraction(&self) -> f64 {
        self.fraction
    }
}

/// Stations along the target at which [`coverage`] tests the distance to the tips.
pub const COVERAGE_STATIONS: usize = 2000;

/// How much of `target` the `tips` cover: the fraction of [`COVERAGE_STATIONS`] stations at
/// equal arc-length steps (both ends included) that lie within `radius` of some tip. A boom
/// that bunches up near the base (eq 36 lets it), a straight column beside a helix or a boom
/// too short for its target covers a small fraction.
pub fn coverage(target: &Target, tips: &[Point3<f64>], radius: f64) -> Coverage {
    let length = target.length();
    let k = if length > 0.0 { COVERAGE_STATIONS } else { 1 };
    let r2 = radius * radius;
    let covered = (0..k)
        .filter(|&i| {
            let s = if k > 1 {
                length * i as f64 / (k - 1) as f64
            } else {
                0.0
            };
            let q = target.point_at_arc_length(s);
            tips.iter().any(|p| (p - q).norm_squared() <= r2)
        })
        .count();
    Coverage {
        fraction: covered as f64 / k as f64,
        radius,
        length,
    }
}

/// The longest step |T·0| of any candidate of the boom (units of l): [`coverage`]'s radius.
pub fn longest_step(catalogue: &Catalogue) -> f64 {
    (0..catalogue.len())
        .flat_map(|i| catalogue.candidates(i).iter())
        .map(|c| c.frame.translation.norm())
        .fold(0.0, f64::max)
}

/// The coverage of `tips` on the problem's target with the boom's [`longest_step`] radius.
pub fn problem_coverage(problem: &Problem, tips: &[Point3<f64>]) -> Coverage {
    coverage(
        problem.objective.target(),
        tips,
        longest_step(&problem.catalogue),
    )
}

/// The tightest bend any candidate of the boom makes.
#[derive(Debug, Clone, PartialEq)]
pub struct Bend {
    /// Its curvature κ = 2 sin(γ/2) / |step| (1/l): the curvature of the circular arc that
    /// turns by the state's tilt γ over its step (bottom to top centroid).
    pub curvature: f64,
    /// The state's tilt γ (degrees).
    pub tilt_deg: f64,
    /// The state's step |T·0| (units of l).
    pub step: f64,
    /// The state's name.
    pub state: String,
    /// The module (0 = bottom).
    pub module: usize,
}

/// The tilt γ (radians) of a frame: the angle between its z axis and the base's.
fn tilt(rotation: &nalgebra::Matrix3<f64>) -> f64 {
    rotation[(2, 2)].clamp(-1.0, 1.0).acos()
}

/// The candidate with the largest curvature over every module, or `None` when no candidate
/// bends (every state straight: the boom is a column along +z).
pub fn tightest_bend(catalogue: &Catalogue) -> Option<Bend> {
    let mut best: Option<Bend> = None;
    for i in 0..catalogue.len() {
        if i > 0 && catalogue.is_uniform() {
            break;
        }
        for c in catalogue.candidates(i) {
            if c.frame.rotation[(2, 2)] >= STRAIGHT_COS {
                continue;
            }
            let g = tilt(&c.frame.rotation);
            let step = c.frame.translation.norm();
            let curvature = if step > 0.0 {
                2.0 * (0.5 * g).sin() / step
            } else {
                f64::INFINITY
            };
            if best.as_ref().is_none_or(|b| curvature > b.curvature) {
                best = Some(Bend {
                    curvature,
                    tilt_deg: g.to_degrees(),
                    step,
                    state: c.name.clone(),
                    module: i,
                });
            }
        }
    }
    best
}

/// The farthest the boom can reach along any path: Σ over modules of the longest step
/// |T·0| among its candidates (units of l). The tips' polyline is never longer.
pub fn reach(catalogue: &Catalogue) -> f64 {
    (0..catalogue.len())
        .map(|i| {
            catalogue
                .candidates(i)
                .iter()
                .map(|c| c.frame.translation.norm())
                .fold(0.0, f64::max)
        })
        .sum()
}

/// The unit tangent of the target at arc length `s` (the direction of the segment holding it;
/// zero-length segments are skipped forwards, then backwards). `None` for a curve of length 0.
fn tangent_at(points: &[Point3<f64>], arc: &[f64], s: f64) -> Option<Vector3<f64>> {
    let k = arc
        .partition_point(|&a| a <= s)
        .clamp(1, points.len().max(2) - 1);
    let dir = |j: usize| {
        let d = points[j] - points[j - 1];
        let l = d.norm();
        (l > 0.0).then(|| d / l)
    };
    (k..points.len())
        .find_map(dir)
        .or_else(|| (1..k).rev().find_map(dir))
}

/// The target's turning over windows of arc length `window`: for stations s_k every
/// `window / 4` (at most 200 000), the angle (radians) between the tangents at s_k and
/// s_k + window. Returns `(s_k, angle)` pairs; empty for a target shorter than `window`.
pub fn turning(target: &Target, window: f64) -> Vec<(f64, f64)> {
    let pts = target.points();
    let length = target.length();
    if window.is_nan() || window <= 0.0 || length < window || pts.len() < 2 {
        return Vec::new();
    }
    let mut arc = Vec::with_capacity(pts.len());
    let mut acc = 0.0;
    arc.push(0.0);
    for w in pts.windows(2) {
        acc += (w[1] - w[0]).norm();
        arc.push(acc);
    }
    let span = length - window;
    let count = ((4.0 * span / window).ceil() as usize).clamp(1, 200_000);
    (0..=count)
        .filter_map(|k| {
            let s = span * k as f64 / count as f64;
            let a = tangent_at(pts, &arc, s)?;
            let b = tangent_at(pts, &arc, s + window)?;
            Some((s, a.dot(&b).clamp(-1.0, 1.0).acos()))
        })
        .collect()
}

/// One thing a fit cannot be trusted to show, with the number that decided it.
#[derive(Debug, Clone, PartialEq)]
pub struct Warning {
    /// A stable name: `cannot-bend`, `curvature`, `too-long`, `doubles-back`, `coverage`.
    pub kind: &'static str,
    /// The sentence for a person.
    pub message: String,
    /// The deciding number (see [`Warning::kind`]'s documentation in docs/ik.md).
    pub value: f64,
    /// The limit it was compared with.
    pub limit: f64,
}

/// Below this covered fraction a fit gets a `coverage` warning.
pub const MIN_COVERAGE: f64 = 0.9;

/// A target turning faster than the tightest bend over more than this fraction of its length
/// gets a `curvature` warning.
pub const CURVATURE_FRACTION: f64 = 0.1;

/// Turning by more than this within one module length (degrees) is doubling back.
pub const DOUBLE_BACK_DEG: f64 = 90.0;

/// The warnings of a fit with `tips` of `problem` (whose modules are `designs`; `all_states`
/// as asked). `cannot-bend` runs a beam search (k = 64) over the full catalogue to say what
/// `--all-states` would give; `control` bounds it (its stop flag and deadline).
pub fn assess(
    problem: &Problem,
    designs: &[ModuleDesign],
    all_states: bool,
    tips: &[Point3<f64>],
    rms: f64,
    control: &Control,
) -> Vec<Warning> {
    let mut out = Vec::new();
    let catalogue = &problem.catalogue;
    let target = problem.objective.target();
    let length = target.length();
    let m = catalogue.len();
    let bend = tightest_bend(catalogue);
    let window = bend
        .as_ref()
        .map(|b| b.step)
        .unwrap_or_else(|| problem.shortest_module().max(1e-9));
    let turns = turning(target, window);
    let n = designs.first().map_or(0, ModuleDesign::n);
    let curved = turns.iter().any(|&(_, a)| a > 1e-6);
    match &bend {
        None if curved => {
            let mut betas: Vec<f64> = designs.iter().map(ModuleDesign::beta_deg).collect();
            betas.dedup();
            let beta_text = betas
                .iter()
                .map(|b| format!("{b}°"))
                .collect::<Vec<_>>()
                .join(", ");
            let names: Vec<&str> = catalogue
                .candidates(0)
                .iter()
                .map(|c| c.name.as_str())
                .collect();
            let bending = bands::bending_bands(n);
            let band_text = if bending.is_empty() {
                format!(
                    "no pop-out of n = {n} is feasible at any β (strain ≤ {} %); see host-tool design --n 3..8 for the n that bend",
                    geometry::STRAIN_TOLERANCE * 100.0
                )
            } else {
                format!(
                    "pop-outs are feasible for n = {n} at β {} (host-tool design --n {n})",
                    bands::describe(&bending)
                )
            };
            let alt = if all_states {
                String::new()
            } else {
                all_states_rms(problem, designs, control).map_or(String::new(), |r| {
                    format!(
                        "; with --all-states (the paper's pop-outs, infeasible here) a beam search finds RMS {r:.4} l against {rms:.4} l"
                    )
                })
            };
            out.push(Warning {
                kind: "cannot-bend",
                message: format!(
                    "no feasible state of n = {n}, β = {beta_text} bends (only {}): the fit is a straight column whatever the target; {band_text}{alt}",
                    names.join(", ")
                ),
                value: 0.0,
                limit: 0.0,
            });
        }
        Some(b) if !turns.is_empty() => {
            let limit = b.curvature * b.step;
            let over = turns.iter().filter(|&&(_, a)| a > limit * 1.05).count();
            let fraction = over as f64 / turns.len() as f64;
            if fraction > CURVATURE_FRACTION {
                let peak = turns.iter().map(|&(_, a)| a).fold(0.0, f64::max) / window;
                out.push(Warning {
                    kind: "curvature",
                    message: format!(
                        "the target turns faster than any feasible state can bend over {:.0} % of its length: it needs up to {peak:.3} /l, the tightest bend is {:.3} /l ({} of module {}: tilt {:.2}° over a step of {:.4} l)",
                        100.0 * fraction,
                        b.curvature,
                        b.state,
                        b.module + 1,
                        b.tilt_deg,
                        b.step
                    ),
                    value: fraction,
                    limit: CURVATURE_FRACTION,
                });
            }
        }
        _ => {}
    }
    if let Some(&(s, a)) = turns.iter().max_by(|x, y| x.1.total_cmp(&y.1)) {
        if a.to_degrees() > DOUBLE_BACK_DEG {
            let p = target.point_at_arc_length(s + 0.5 * window);
            out.push(Warning {
                kind: "doubles-back",
                message: format!(
                    "the target doubles back: its direction turns by {:.1}° within one module length ({window:.4} l) near ({:.3}, {:.3}, {:.3}) (arc length {:.3} of {length:.3} l); a boom cannot retrace a curve, expect a poor fit there",
                    a.to_degrees(),
                    p.x,
                    p.y,
                    p.z,
                    s + 0.5 * window
                ),
                value: a.to_degrees(),
                limit: DOUBLE_BACK_DEG,
            });
        }
    }
    let r = reach(catalogue);
    if length > r * (1.0 + 1e-9) {
        out.push(Warning {
            kind: "too-long",
            message: format!(
                "the target is {length:.4} l long but {m} modules reach at most {r:.4} l (the longest state of every module, end to end): no fit covers more than {:.0} % of it; add modules or shorten the target",
                100.0 * r / length
            ),
            value: length,
            limit: r,
        });
    }
    let shortest: f64 = (0..m)
        .map(|i| {
            catalogue
                .candidates(i)
                .iter()
                .map(|c| c.frame.translation.norm())
                .fold(f64::INFINITY, f64::min)
        })
        .sum();
    let straight_span = (target.points()[target.points().len() - 1] - target.points()[0]).norm();
    if shortest > length.max(straight_span) * 1.5 + window {
        out.push(Warning {
            kind: "boom-too-long",
            message: format!(
                "the boom is at least {shortest:.4} l long ({m} modules in their shortest states) but the target is {length:.4} l: the tips beyond its end cannot fit; use fewer modules"
            ),
            value: shortest,
            limit: length,
        });
    }
    let cov = problem_coverage(problem, tips);
    if cov.fraction() < MIN_COVERAGE {
        let hint = if problem.objective.metric() == Metric::Eq36 {
            "; eq 36 lets every tip sit near any part of the curve, --metric ordered matches tip i to arc length i·L/m and makes the boom cover it"
        } else {
            ""
        };
        out.push(Warning {
            kind: "coverage",
            message: format!(
                "the fit covers {:.0} % of the target: only that much of its {length:.4} l lies within one module step ({:.4} l) of a tip{hint}",
                100.0 * cov.fraction(),
                cov.radius
            ),
            value: cov.fraction(),
            limit: MIN_COVERAGE,
        });
    }
    out
}

/// The RMS a beam search (k = 64) finds with the full catalogue of `designs`, or `None` when
/// it cannot be built or was stopped.
fn all_states_rms(problem: &Problem, designs: &[ModuleDesign], control: &Control) -> Option<f64> {
    let catalogue = Catalogue::from_designs(designs, false).ok()?;
    let p = Problem::new(
        catalogue,
        problem.objective.target().clone(),
        problem.objective.metric(),
    );
    let c = Control {
        stop: control.stop.clone(),
        deadline: control.deadline,
        ..Control::new()
    };
    let s = super::solve(&p, Algorithm::Beam { width: 64 }, &c).ok()?;
    (!s.interrupted && s.rms.is_finite()).then_some(s.rms)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problem(
        n: u32,
        beta: f64,
        m: usize,
        spec: &str,
        metric: Metric,
    ) -> (Problem, Vec<ModuleDesign>) {
        let designs = vec![ModuleDesign::new(n, beta).unwrap(); m];
        let cat = Catalogue::from_designs(&designs, true).unwrap();
        let target = super::super::target::generate(spec).unwrap();
        (Problem::new(cat, target, metric), designs)
    }

    #[test]
    fn a_design_without_feasible_popouts_cannot_bend_and_says_where_it_could() {
        let (p, d) = problem(6, 35.0, 8, "helix:radius=1,pitch=4", Metric::Eq36);
        assert!(tightest_bend(&p.catalogue).is_none());
        let s = super::super::solve(&p, Algorithm::Greedy, &Control::new()).unwrap();
        let w = assess(&p, &d, false, &s.tips, s.rms, &Control::new());
        let cb = w
            .iter()
            .find(|w| w.kind == "cannot-bend")
            .expect("cannot-bend");
        assert!(cb.message.contains("--all-states"), "{}", cb.message);
        assert!(
            cb.message.contains("host-tool design --n 3..8"),
            "{}",
            cb.message
        );
        assert!(
            cb.message.contains("no pop-out of n = 6 is feasible"),
            "{}",
            cb.message
        );
    }

    #[test]
    fn a_bending_design_has_its_tightest_bend_and_no_cannot_bend_warning() {
        let (p, d) = problem(
            3,
            31.72,
            10,
            "helix:radius=1,pitch=2,turns=1",
            Metric::Ordered,
        );
        let b = tightest_bend(&p.catalogue).expect("n = 3, β = 31.72° bends");
        // κ = 2 sin(γ/2)/step, recomputed from the geometry's pose of the named state.
        let design = d[0];
        let st = geometry::ShapeState::parse(&b.state, 3).unwrap();
        let pose = design.pose(st);
        let iso = pose.isometry();
        let step = iso.translation.vector.norm();
        let g = pose.gamma;
        approx::assert_relative_eq!(
            b.curvature,
            2.0 * (0.5 * g).sin() / step,
            max_relative = 1e-9
        );
        let s = super::super::solve(&p, Algorithm::Exact, &Control::new()).unwrap();
        let w = assess(&p, &d, false, &s.tips, s.rms, &Control::new());
        assert!(w.iter().all(|w| w.kind != "cannot-bend"), "{w:?}");
    }

    #[test]
    fn coverage_measures_how_far_along_the_curve_the_tips_get() {
        let t = Target::new(vec![Point3::origin(), Point3::new(0.0, 0.0, 10.0)]).unwrap();
        // Tips on the axis at z = 1, 3: within 1 of z ∈ [0, 4] — 40 % of the line (to the
        // station spacing 10/1999).
        let c = coverage(
            &t,
            &[Point3::new(0.0, 0.0, 1.0), Point3::new(0.0, 0.0, 3.0)],
            1.0,
        );
        approx::assert_relative_eq!(c.fraction(), 0.4, epsilon = 2e-3);
        // Off the line by 0.6 with radius 1: covers ±0.8 around z = 5.
        let c = coverage(&t, &[Point3::new(0.6, 0.0, 5.0)], 1.0);
        approx::assert_relative_eq!(c.fraction(), 0.16, epsilon = 2e-3);
        assert_eq!(
            coverage(&t, &[Point3::new(0.0, 0.0, 20.0)], 1.0).fraction(),
            0.0
        );
    }

    #[test]
    fn a_hairpin_doubles_back_and_a_long_target_is_too_long() {
        let (p0, d) = problem(3, 31.72, 4, "helix", Metric::Eq36);
        let hairpin = Target::new(vec![
            Point3::origin(),
            Point3::new(0.0, 0.0, 3.0),
            Point3::new(0.1, 0.0, 0.0),
        ])
        .unwrap();
        let p = Problem::new(p0.catalogue.clone(), hairpin, Metric::Eq36);
        let tips = p.catalogue.tips(&[0, 0, 0, 0]);
        let w = assess(&p, &d, false, &tips, 1.0, &Control::new());
        let db = w.iter().find(|w| w.kind == "doubles-back").expect("{w:?}");
        assert!(db.value > 170.0, "{db:?}");
        let long = Target::new(vec![Point3::origin(), Point3::new(0.0, 0.0, 100.0)]).unwrap();
        let p = Problem::new(p0.catalogue.clone(), long, Metric::Ordered);
        let w = assess(&p, &d, false, &tips, 1.0, &Control::new());
        let tl = w.iter().find(|w| w.kind == "too-long").expect("{w:?}");
        approx::assert_relative_eq!(tl.limit, reach(&p.catalogue), max_relative = 1e-12);
        assert!(tl.limit < 100.0 && tl.value == 100.0);
        assert!(w.iter().any(|w| w.kind == "coverage"));
    }
}
