//! Exact solver: branch and bound with a proof of optimality.
//!
//! - **Incumbent**: beam search (width [`SEED_BEAM_WIDTH`]) polished by sliding windows of 2
//!   modules gives an upper bound U on the optimal cost sum before the search starts.
//! - **Bound** of a prefix of length j with top frame F: its exact cost `g` (tips 1..j) plus the
//!   reachable-set bound of [`super::reach`] for every remaining tip. Both are lower bounds on
//!   the cost of any completion, so pruning when `g + lb ≥ U` never discards a strictly better
//!   boom (the bound is shaved by a relative 1e-12 against rounding).
//! - **Order**: depth first; a node's children are visited in increasing bound, and the loop
//!   stops at the first child whose bound reaches the (possibly improved) incumbent.
//! - **Parallelism**: the prefixes of the first few modules are sorted by bound and searched as
//!   rayon tasks sharing the incumbent through an atomic (non-negative `f64` bits order like the
//!   floats); the best sequence itself is kept under a mutex, touched only on improvement.
//!
//! When the search finishes, every sequence was either evaluated or proven no better than the
//! incumbent, so the result is a global optimum (`optimal: true`); if it is stopped (Ctrl-C), the
//! incumbent is returned with `optimal: false`.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;

use rayon::prelude::*;

use super::exhaustive::{prefixes, split_depth};
use super::reach::Reach;
use super::{Control, Frame, Problem, Raw};

/// Beam width of the seeding incumbent.
pub const SEED_BEAM_WIDTH: usize = 64;

const SHAVE: f64 = 1.0 - 1e-12;

struct Shared<'a> {
    problem: &'a Problem,
    reach: &'a Reach,
    control: &'a Control,
    ub_bits: AtomicU64,
    best: Mutex<(f64, Vec<usize>)>,
    stopped: AtomicBool,
}

impl Shared<'_> {
    #[inline]
    fn ub(&self) -> f64 {
        f64::from_bits(self.ub_bits.load(Ordering::Relaxed))
    }

    fn offer(&self, g: f64, path: &[usize]) {
        if g >= self.ub() {
            return;
        }
        let mut best = self.best.lock().unwrap_or_else(|e| e.into_inner());
        if g < best.0 {
            best.0 = g;
            best.1.clear();
            best.1.extend_from_slice(path);
            self.ub_bits.fetch_min(g.to_bits(), Ordering::Relaxed);
            self.control.offer_best(g);
        }
    }
}

struct Worker<'a, 'b> {
    shared: &'b Shared<'a>,
    path: Vec<usize>,
    /// Per-depth child buffers: (bound, g, candidate, frame).
    bufs: Vec<Vec<(f64, f64, usize, Frame)>>,
    nodes: u64,
    unflushed: u64,
}

impl Worker<'_, '_> {
    fn dfs(&mut self, j: usize, frame: &Frame, g: f64) {
        let sh = self.shared;
        let problem = sh.problem;
        let m = problem.m();
        let obj = &problem.objective;
        let mut kids = std::mem::take(&mut self.bufs[j]);
        kids.clear();
        let mut ub = sh.ub();
        for (a, c) in problem.catalogue.candidates(j).iter().enumerate() {
            let f = frame.compose(&c.frame);
            let gc = g + obj.cost(j, &f.origin());
            self.nodes += 1;
            if gc * SHAVE >= ub {
                continue;
            }
            if j + 1 == m {
                self.path[j] = a;
                sh.offer(gc, &self.path);
                ub = sh.ub();
                continue;
            }
            let lb = sh.reach.suffix_lower_bound(obj, &f, j + 1, ub - gc);
            let bound = (gc + lb) * SHAVE;
            if bound < ub {
                kids.push((bound, gc, a, f));
            }
        }
        self.unflushed += problem.catalogue.candidates(j).len() as u64;
        if self.unflushed >= 1 << 16 {
            sh.control.add_evaluated(self.unflushed);
            self.unflushed = 0;
            if sh.control.stopped() {
                sh.stopped.store(true, Ordering::Relaxed);
            }
        }
        kids.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.2.cmp(&y.2)));
        for &(bound, gc, a, f) in &kids {
            if bound >= sh.ub() || sh.stopped.load(Ordering::Relaxed) {
                break;
            }
            self.path[j] = a;
            self.dfs(j + 1, &f, gc);
        }
        self.bufs[j] = kids;
    }
}

pub(crate) fn solve(problem: &Problem, control: &Control) -> Raw {
    let m = problem.m();
    let reach = Reach::new(&problem.catalogue, m);
    // Incumbent: beam, then window polish.
    let seed_reach = Reach::new(&problem.catalogue, super::beam::BEAM_HORIZON);
    let (seed, _, seed_evals, _) =
        super::beam::beam_with(problem, &seed_reach, SEED_BEAM_WIDTH, control);
    let (seed, polish_evals) = super::window::polish(problem, seed, 2, control);
    let seed_cost = problem.cost_sum(&seed);
    control.offer_best(seed_cost);
    let shared = Shared {
        problem,
        reach: &reach,
        control,
        ub_bits: AtomicU64::new(seed_cost.to_bits()),
        best: Mutex::new((seed_cost, seed)),
        stopped: AtomicBool::new(control.stopped()),
    };
    // Top-level subtrees: prefixes with their bounds, most promising first.
    let depth = split_depth(problem, 512).min(m.saturating_sub(1));
    let mut tasks: Vec<(f64, Vec<usize>, Frame, f64)> = prefixes(problem, depth)
        .into_iter()
        .map(|(p, f, g)| {
            let lb = reach.suffix_lower_bound(&problem.objective, &f, depth, f64::INFINITY);
            ((g + lb) * SHAVE, p, f, g)
        })
        .collect();
    let top_nodes = tasks.len() as u64;
    tasks.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
    let nodes: u64 = tasks
        .par_iter()
        .map(|(bound, prefix, frame, g)| {
            if *bound >= shared.ub() || shared.stopped.load(Ordering::Relaxed) {
                return 0;
            }
            let mut w = Worker {
                shared: &shared,
                path: vec![0; m],
                bufs: vec![Vec::new(); m],
                nodes: 0,
                unflushed: 0,
            };
            w.path[..depth].copy_from_slice(prefix);
            if depth == m {
                shared.offer(*g, prefix);
                return 1;
            }
            w.dfs(depth, frame, *g);
            control.add_evaluated(w.unflushed);
            w.nodes
        })
        .sum();
    let interrupted = shared.stopped.load(Ordering::Relaxed);
    let (_, states) = shared.best.into_inner().unwrap_or_else(|e| e.into_inner());
    Raw {
        states,
        optimal: !interrupted,
        evaluated: nodes + top_nodes + seed_evals + polish_evals,
        interrupted,
    }
}
