//! Greedy and beam search.
//!
//! - Greedy: module by module, bottom first, take the state whose tip has the lowest cost.
//! - Beam (width k): keep the k best prefixes of each length, ranked by their exact cost so far
//!   plus the reachable-set lower bound ([`super::reach`]) for the next [`BEAM_HORIZON`] tips.
//!   Prefixes that reach the same frame (within 1e-9 l and 1e-9 rad) have identical futures, so
//!   only the cheapest of them is kept (it dominates the others). Ties in rank break by lower
//!   prefix cost, then by candidate order, so the result is deterministic.

use std::collections::HashSet;

use rayon::prelude::*;

use super::reach::Reach;
use super::{Control, Frame, Problem, Raw};

/// How many tips ahead the beam's ranking bound looks.
pub const BEAM_HORIZON: usize = 4;

/// Greedy: each module in turn takes the state whose tip is nearest the target.
pub(crate) fn greedy(problem: &Problem, control: &Control) -> Raw {
    let (states, evaluated) = complete_greedily(problem, Frame::identity(), Vec::new());
    control.add_evaluated(evaluated);
    Raw {
        states,
        optimal: problem.m() == 0,
        evaluated,
        interrupted: false,
        lower_bound: None,
        stop: None,
    }
}

/// Extends `prefix` (whose top frame is `frame`) to a full boom greedily. Returns the states
/// and the number of tips evaluated.
pub(crate) fn complete_greedily(
    problem: &Problem,
    mut frame: Frame,
    mut prefix: Vec<usize>,
) -> (Vec<usize>, u64) {
    let mut evaluated = 0;
    for j in prefix.len()..problem.m() {
        let mut best = (f64::INFINITY, 0usize, frame);
        for (a, c) in problem.catalogue.candidates(j).iter().enumerate() {
            let f = frame.compose(&c.frame);
            let cost = problem.objective.cost(j, &f.origin());
            evaluated += 1;
            if cost < best.0 {
                best = (cost, a, f);
            }
        }
        prefix.push(best.1);
        frame = best.2;
    }
    (prefix, evaluated)
}

/// The best (lowest `g`, the first of equals) of the deepest layer reached, traced back
/// through every layer's `(parent, candidate)` links and, when the search stopped below the
/// top module, completed greedily. `last`: the deepest layer's `(g, frame)`s. Returns the
/// states and the tips the completion evaluated. Shared by the beam and the DP.
pub(crate) fn trace_back_best(
    problem: &Problem,
    layers: &[Vec<(u32, u16)>],
    last: impl IntoIterator<Item = (f64, Frame)>,
) -> (Vec<usize>, u64) {
    let mut best: Option<(usize, f64, Frame)> = None;
    for (i, (g, frame)) in last.into_iter().enumerate() {
        if best.is_none_or(|(_, best_g, _)| g.total_cmp(&best_g).is_lt()) {
            best = Some((i, g, frame));
        }
    }
    let (best, frame) = best.map_or((0, Frame::identity()), |(i, _, f)| (i, f));
    let depth = layers.len();
    let mut states = vec![0usize; depth];
    let mut idx = best as u32;
    for d in (0..depth).rev() {
        let (p, c) = layers[d][idx as usize];
        states[d] = c as usize;
        idx = p;
    }
    if depth < problem.m() {
        complete_greedily(problem, frame, states)
    } else {
        (states, 0)
    }
}

#[derive(Clone, Copy)]
struct Entry {
    score: f64,
    g: f64,
    frame: Frame,
    parent: u32,
    cand: u16,
}

/// Quantises a frame for duplicate detection.
pub(crate) fn frame_key(f: &Frame, step: f64) -> [i64; 12] {
    let mut k = [0i64; 12];
    for (i, v) in f.translation.iter().chain(f.rotation.iter()).enumerate() {
        k[i] = (v / step).round() as i64;
    }
    k
}

/// Beam search of width `width`; returns the best complete boom and the number of prefixes
/// evaluated.
pub(crate) fn beam(problem: &Problem, width: usize, control: &Control) -> Raw {
    let reach = Reach::new(&problem.catalogue, BEAM_HORIZON);
    let (states, _g, evaluated, interrupted) = beam_with(problem, &reach, width, control);
    Raw {
        states,
        optimal: false,
        evaluated,
        interrupted,
        lower_bound: None,
        stop: None,
    }
}

/// Beam search with a precomputed reach; returns (states, cost sum, evaluated, interrupted).
pub fn beam_with(
    problem: &Problem,
    reach: &Reach,
    width: usize,
    control: &Control,
) -> (Vec<usize>, f64, u64, bool) {
    let m = problem.m();
    let obj = &problem.objective;
    let mut layers: Vec<Vec<(u32, u16)>> = Vec::with_capacity(m);
    let mut cur = vec![Entry {
        score: 0.0,
        g: 0.0,
        frame: Frame::identity(),
        parent: 0,
        cand: 0,
    }];
    let mut evaluated = 0u64;
    let mut interrupted = false;
    let mut children: Vec<Entry>;
    let mut seen: HashSet<[i64; 12]> = HashSet::new();
    for j in 0..m {
        if control.stopped() {
            interrupted = true;
            break;
        }
        let cands = problem.catalogue.candidates(j);
        let expand = |(pi, e): (usize, &Entry)| -> Vec<Entry> {
            cands
                .iter()
                .enumerate()
                .map(|(a, c)| {
                    let f = e.frame.compose(&c.frame);
                    let g = e.g + obj.cost(j, &f.origin());
                    let h = if j + 1 < m {
                        reach.suffix_lower_bound(obj, &f, j + 1, f64::INFINITY)
                    } else {
                        0.0
                    };
                    Entry {
                        score: g + h,
                        g,
                        frame: f,
                        parent: pi as u32,
                        cand: a as u16,
                    }
                })
                .collect()
        };
        // Parallel when the layer is big enough to pay for it; the order is kept either way.
        children = if cur.len() * cands.len() >= 256 {
            cur.par_iter().enumerate().flat_map_iter(expand).collect()
        } else {
            cur.iter().enumerate().flat_map(expand).collect()
        };
        evaluated += children.len() as u64;
        children.sort_by(|x, y| {
            x.score
                .total_cmp(&y.score)
                .then(x.g.total_cmp(&y.g))
                .then(x.parent.cmp(&y.parent))
                .then(x.cand.cmp(&y.cand))
        });
        seen.clear();
        let mut next = Vec::with_capacity(width);
        for ch in &children {
            if next.len() == width {
                break;
            }
            if seen.insert(frame_key(&ch.frame, 1e-9)) {
                next.push(*ch);
            }
        }
        layers.push(next.iter().map(|e| (e.parent, e.cand)).collect());
        cur = next;
    }
    control.add_evaluated(evaluated);
    let (states, n) = trace_back_best(problem, &layers, cur.iter().map(|e| (e.g, e.frame)));
    evaluated += n;
    let g = problem.cost_sum(&states);
    control.offer_best(g);
    (states, g, evaluated, interrupted)
}
