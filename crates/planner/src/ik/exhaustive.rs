//! Exhaustive search: the reference.
//!
//! Depth-first over all ∏K_i sequences. The frame of every prefix is composed exactly once, from
//! its parent's frame, and shared by all its completions; the last module only needs its tip
//! (`F·t_a`), not a full frame. The prefixes of the first few modules are split across threads
//! (rayon); the best sequence is the lowest cost sum, ties broken by the lexicographically
//! smallest state indices so the answer is deterministic.

use rayon::prelude::*;

use super::{Control, Frame, Problem, Raw};

/// Prefix length at which the search splits into parallel tasks: enough tasks to balance
/// two-to-many threads, at most m − 1 levels.
pub(crate) fn split_depth(problem: &Problem, min_tasks: u128) -> usize {
    let m = problem.m();
    let mut count = 1u128;
    let mut d = 0;
    while d + 1 < m && count < min_tasks {
        count = count.saturating_mul(problem.catalogue.candidates(d).len() as u128);
        d += 1;
    }
    d
}

/// All prefixes of length `depth` with their frames and cost sums, in lexicographic order.
pub(crate) fn prefixes(problem: &Problem, depth: usize) -> Vec<(Vec<usize>, Frame, f64)> {
    let mut layer = vec![(Vec::new(), Frame::identity(), 0.0)];
    for j in 0..depth {
        let cands = problem.catalogue.candidates(j);
        let mut next = Vec::with_capacity(layer.len() * cands.len());
        for (states, frame, g) in &layer {
            for (a, c) in cands.iter().enumerate() {
                let f = frame.compose(&c.frame);
                let mut s: Vec<usize> = states.clone();
                s.push(a);
                next.push((s, f, g + problem.objective.cost(j, &f.origin())));
            }
        }
        layer = next;
    }
    layer
}

struct Task<'a> {
    problem: &'a Problem,
    control: &'a Control,
    path: Vec<usize>,
    best: f64,
    best_path: Vec<usize>,
    count: u64,
    unflushed: u64,
    stopped: bool,
}

impl Task<'_> {
    fn rec(&mut self, j: usize, frame: &Frame, g: f64) {
        let m = self.problem.m();
        let obj = &self.problem.objective;
        let cands = self.problem.catalogue.candidates(j);
        if j + 1 == m {
            for (a, c) in cands.iter().enumerate() {
                let tip = frame.apply_vec(&c.frame.translation);
                let total = g + obj.cost(j, &tip);
                if total < self.best {
                    self.best = total;
                    self.path[j] = a;
                    self.best_path.copy_from_slice(&self.path);
                }
            }
            self.count += cands.len() as u64;
            self.unflushed += cands.len() as u64;
            if self.unflushed >= 1 << 20 {
                self.control.add_evaluated(self.unflushed);
                self.unflushed = 0;
                if self.control.stopped() {
                    self.stopped = true;
                }
            }
            return;
        }
        for (a, c) in cands.iter().enumerate() {
            if self.stopped {
                return;
            }
            let f = frame.compose(&c.frame);
            self.path[j] = a;
            self.rec(j + 1, &f, g + obj.cost(j, &f.origin()));
        }
    }
}

pub(crate) fn solve(problem: &Problem, control: &Control) -> Raw {
    let m = problem.m();
    if problem.catalogue.sequences() >= 1_000_000 {
        problem.objective.target().prepare_fast_queries();
    }
    let depth = split_depth(problem, 256);
    let tasks = prefixes(problem, depth);
    let results: Vec<(f64, Vec<usize>, u64, bool)> = tasks
        .into_par_iter()
        .map(|(prefix, frame, g)| {
            let mut path = vec![0usize; m];
            path[..depth].copy_from_slice(&prefix);
            let mut t = Task {
                problem,
                control,
                best_path: path.clone(),
                path,
                best: f64::INFINITY,
                count: 0,
                unflushed: 0,
                stopped: control.stopped(),
            };
            if !t.stopped {
                t.rec(depth, &frame, g);
            }
            control.add_evaluated(t.unflushed);
            if t.best.is_finite() {
                control.offer_best(t.best);
            }
            (t.best, t.best_path, t.count, t.stopped)
        })
        .collect();
    let evaluated = results.iter().map(|r| r.2).sum();
    let interrupted = results.iter().any(|r| r.3);
    let best = results
        .into_iter()
        .filter(|r| r.0.is_finite())
        .min_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
    let states = match best {
        Some((_, s, _, _)) => s,
        // Interrupted before any leaf: fall back to greedy so a complete boom is returned.
        None => super::beam::complete_greedily(problem, Frame::identity(), Vec::new()).0,
    };
    Raw {
        states,
        optimal: !interrupted,
        evaluated,
        interrupted,
        lower_bound: None,
        stop: None,
    }
}
