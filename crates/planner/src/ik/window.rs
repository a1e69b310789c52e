//! Sliding windows of w modules (paper §4.2: "optimizing over sliding windows of 2–4 layers").
//!
//! 1. **Receding horizon.** For j = 1..m: given the committed modules 1..j−1, try every
//!    assignment of modules j..j+w−1 (fewer at the top) and score it by the cost of those w
//!    tips; commit module j's state from the best assignment and slide by one.
//! 2. **Window sweeps.** For each window of w consecutive modules, bottom to top, try every
//!    assignment of the window with all other modules fixed, scoring the *whole* boom (modules
//!    above the window move rigidly with it); keep a strict improvement. Repeat until a full
//!    sweep improves nothing (at most [`MAX_SWEEPS`] sweeps).
//!
//! Guarantee: unless stopped or the sweep cap is hit, no change of any w consecutive modules
//! lowers the RMS (a local optimum in the w-window neighbourhood). Cost per sweep:
//! O(m · K^w · m) tip evaluations.

use super::{Control, Frame, Problem, Raw};

/// Maximum number of improvement sweeps.
pub const MAX_SWEEPS: usize = 100;

pub(crate) fn solve(problem: &Problem, w: usize, control: &Control) -> Raw {
    let m = problem.m();
    let mut states = Vec::with_capacity(m);
    let mut frame = Frame::identity();
    let mut evaluated = 0u64;
    for j in 0..m {
        if control.stopped() {
            let (s, n) = super::beam::complete_greedily(problem, frame, states);
            control.add_evaluated(evaluated + n);
            return Raw {
                states: s,
                optimal: false,
                evaluated: evaluated + n,
                interrupted: true,
                lower_bound: None,
                stop: None,
            };
        }
        let hi = (j + w).min(m);
        let mut best = (f64::INFINITY, 0usize);
        enumerate(problem, j, hi, &frame, 0.0, &mut |cost, a0| {
            evaluated += 1;
            if cost < best.0 {
                best = (cost, a0);
            }
        });
        let c = &problem.catalogue.candidates(j)[best.1];
        frame = frame.compose(&c.frame);
        states.push(best.1);
    }
    control.add_evaluated(evaluated);
    let (states, n) = polish(problem, states, w, control);
    Raw {
        states,
        optimal: false,
        evaluated: evaluated + n,
        interrupted: control.stopped(),
        lower_bound: None,
        stop: None,
    }
}

/// Calls `visit(cost, first_state)` for every assignment of modules `lo..hi` stacked on
/// `frame`, with `cost` the sum of their tip costs plus `g`.
fn enumerate(
    problem: &Problem,
    lo: usize,
    hi: usize,
    frame: &Frame,
    g: f64,
    visit: &mut dyn FnMut(f64, usize),
) {
    fn rec(
        problem: &Problem,
        (j, hi): (usize, usize),
        frame: &Frame,
        g: f64,
        first: Option<usize>,
        visit: &mut dyn FnMut(f64, usize),
    ) {
        for (a, c) in problem.catalogue.candidates(j).iter().enumerate() {
            let f = frame.compose(&c.frame);
            let gc = g + problem.objective.cost(j, &f.origin());
            let first = first.unwrap_or(a);
            if j + 1 == hi {
                visit(gc, first);
            } else {
                rec(problem, (j + 1, hi), &f, gc, Some(first), visit);
            }
        }
    }
    if lo < hi {
        rec(problem, (lo, hi), frame, g, None, visit);
    }
}

/// Window sweeps (step 2) from `states`; returns the improved states and the number of window
/// assignments evaluated.
pub fn polish(
    problem: &Problem,
    mut states: Vec<usize>,
    w: usize,
    control: &Control,
) -> (Vec<usize>, u64) {
    let m = problem.m();
    let w = w.min(m);
    let obj = &problem.objective;
    let cat = &problem.catalogue;
    let mut evaluated = 0u64;
    let mut current = problem.cost_sum(&states);
    for _ in 0..MAX_SWEEPS {
        let mut improved = false;
        for j in 0..=(m - w) {
            if control.stopped() {
                control.add_evaluated(evaluated);
                return (states, evaluated);
            }
            let frames = cat.frames(&states);
            let base = if j == 0 {
                Frame::identity()
            } else {
                frames[j - 1]
            };
            let prefix_cost: f64 = (0..j).map(|i| obj.cost(i, &frames[i].origin())).sum();
            // Tips above the window, in the frame of the window's top.
            let mut rel = Frame::identity();
            let suffix: Vec<(usize, nalgebra::Vector3<f64>)> = (j + w..m)
                .map(|i| {
                    rel = rel.compose(&cat.candidates(i)[states[i]].frame);
                    (i, rel.translation)
                })
                .collect();
            let mut best = (current, None::<Vec<usize>>);
            let mut window = vec![0usize; w];
            let mut stack = vec![(base, prefix_cost); w + 1];
            // Odometer over the window's assignments, composing each prefix once.
            let mut depth = 0usize;
            let mut idx = vec![0usize; w];
            loop {
                if depth == w {
                    let (top, g) = stack[w];
                    let mut total = g;
                    for (i, q) in &suffix {
                        total += obj.cost(*i, &top.apply_vec(q));
                        if total >= best.0 {
                            break;
                        }
                    }
                    evaluated += 1;
                    if total < best.0 * (1.0 - 1e-12) - 1e-300 {
                        best = (total, Some(window.clone()));
                    }
                    depth -= 1;
                    idx[depth] += 1;
                    continue;
                }
                let cands = cat.candidates(j + depth);
                if idx[depth] == cands.len() {
                    if depth == 0 {
                        break;
                    }
                    idx[depth] = 0;
                    depth -= 1;
                    idx[depth] += 1;
                    continue;
                }
                let (f0, g0) = stack[depth];
                let f = f0.compose(&cands[idx[depth]].frame);
                window[depth] = idx[depth];
                stack[depth + 1] = (f, g0 + obj.cost(j + depth, &f.origin()));
                depth += 1;
            }
            if let (total, Some(win)) = best {
                states[j..j + w].copy_from_slice(&win);
                current = total;
                improved = true;
            }
        }
        if !improved {
            break;
        }
    }
    control.add_evaluated(evaluated);
    (states, evaluated)
}
