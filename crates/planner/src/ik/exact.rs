//! Exact solver: anytime branch and bound with a certified lower bound.
//!
//! - **Incumbent**: beam search (width [`SEED_BEAM_WIDTH`]) polished by sliding windows of 2
//!   modules gives an upper bound U on the optimal cost sum before the search starts; every
//!   better complete boom the search meets replaces it.
//! - **Bound** of a prefix of length j with top frame F: its exact cost `g` (tips 1..j) plus the
//!   reachable-set bound of [`super::reach`] for every remaining tip, where it may decide a
//!   prune strengthened for the next [`CHAIN_HORIZON`] tips by the chain covers of
//!   [`super::chain`], which couple those tips through the frame. All are lower bounds on the
//!   cost of any completion (the argument is in `docs/ik.md`), shaved by a relative 1e-12
//!   against floating-point rounding.
//! - **Tasks**: the prefixes of the first few modules (at least [`MIN_TASKS`]). Each task keeps
//!   a certified lower bound `lb` on every completion of its prefix; a task is *closed* once
//!   `lb ≥ U`. The certified lower bound on the optimum is `L = min(U, min over tasks of lb)`:
//!   every sequence extends exactly one task prefix.
//! - **Passes** (iterative deepening on the bound): pass p searches every open task whose `lb`
//!   is below a threshold `t_p ≤ U`, depth first, pruning every node whose bound reaches
//!   `min(t_p, U)`. When a task's pass completes, every completion of its prefix was either
//!   evaluated or lies below a pruned node, so the least pruned bound (or evaluated cost) is a
//!   new certified `lb` for the task. Thresholds grow from a histogram of the pruned bounds so
//!   each pass roughly doubles the work; the last pass has `t = U` and proves optimality.
//! - **Order, parallelism**: tasks of a pass run lowest `lb` first as rayon tasks sharing U
//!   through an atomic (non-negative `f64` bits order like the floats); within a task a node's
//!   children are visited in increasing bound.
//! - **Mirror symmetry** ([`symmetry`]): when a vertical plane through the axis maps the
//!   target and every candidate set onto themselves, only canonical sequences (of each mirror
//!   pair, the one whose first non-self-mirror state is the smaller index) are searched.
//! - **Stopping**: the caller's stop flag or deadline ([`Control`]) abandons the running tasks
//!   (their `lb` stays at its last certified value); a target gap stops the search as soon as
//!   `1 − sqrt(L/U) ≤ gap`. Either way the incumbent is returned with the certified `L`.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;

use super::chain::Chains;
use super::exhaustive::{prefixes, split_depth};
use super::reach::Reach;
use super::symmetry::{self, Mirror};
use super::{relative_gap, Control, Frame, Metric, Objective, Problem, Raw, Stop};

/// Beam width of the seeding incumbent.
pub const SEED_BEAM_WIDTH: usize = 64;

/// Levels of the chain covers: the coupled bound covers the next 4 tips (measured: the
/// coupling saturates by 4–6 levels, where the parent masks get dense).
pub const CHAIN_HORIZON: usize = 4;

/// The chain bound is computed for a node only when `tail + CHAIN_GATE·head` reaches the
/// budget (head, tail: the per-tip sums over the chain's tips and over the later ones): where
/// it can decide a prune.
pub const CHAIN_GATE: f64 = 2.0;

/// The chain bound is tried only for nodes with at least this many tips left (near the leaves
/// a prune saves little and the bound costs as much as a few children).
pub const CHAIN_MIN_REMAINING: usize = 8;

/// Fewest top-level tasks (the granularity of the certified bound and of the parallel split).
pub const MIN_TASKS: u128 = 512;

/// Bounds are multiplied by `1 − shave(m)`: a relative margin above the rounding error of a
/// sum of m non-negative terms (m·ε by the standard bound; 4m·ε, at least 1e-12).
fn shave(m: usize) -> f64 {
    1.0 - (4.0 * m as f64 * f64::EPSILON).max(1e-12)
}

/// Histogram bins of pruned bounds between the pass threshold and U.
const BINS: usize = 64;

/// A lower bound on the cost of the tips after `j` modules with top frame `frame`, or some
/// value above `budget` once it is clear the bound exceeds it (still a lower bound). The next
/// h tips (h = the chain covers' levels) are bounded by the larger of the reach covers' per-tip
/// sum and the chain covers' cheapest path (the coupled bound); every later tip by its per-tip
/// bound. The two parts bound disjoint sets of tips, so their sum is a lower bound. The chain
/// bound is computed only when the per-tip sum is within budget and `tail + gate·head` reaches
/// the budget (where it may decide a prune), or without chain covers not at all.
pub(crate) fn remaining_bound(
    obj: &Objective,
    reach: &Reach,
    chains: Option<&Chains>,
    gate: f64,
    frame: &Frame,
    j: usize,
    budget: f64,
) -> f64 {
    let Some(chains) = chains else {
        return reach.suffix_lower_bound_grouped(obj, frame, j, budget);
    };
    let h = chains.levels_after(j);
    let head = reach.suffix_range(obj, frame, j, 1, h, budget);
    if head > budget {
        return head;
    }
    let tail = reach.suffix_from(obj, frame, j, h + 1, budget - head);
    if head + tail > budget || h < 2 || tail + gate * head < budget {
        return head + tail;
    }
    let chain = chains.lower_bound(obj, frame, j, h, budget - tail);
    tail + head.max(chain)
}

struct Shared<'a> {
    problem: &'a Problem,
    /// A mirror symmetry of the problem: only canonical sequences are searched.
    mirror: Option<Mirror>,
    /// `shave(m)`.
    shave: f64,
    reach: &'a Reach,
    /// Chain covers of the next tips (the coupled bound), when built.
    chains: Option<&'a Chains>,
    /// Nodes with fewer tips left do not try the chain bound ([`CHAIN_MIN_REMAINING`]).
    chain_min_remaining: usize,
    control: &'a Control,
    ub_bits: AtomicU64,
    best: Mutex<(f64, Vec<usize>)>,
    /// Set when the caller's stop flag or deadline fired, or the target gap was reached.
    abort: AtomicBool,
}

impl Shared<'_> {
    /// [`remaining_bound`] with this search's covers after `j` modules whose prefix costs `g`:
    /// the chain bound is tried (with [`CHAIN_GATE`], the budget being the incumbent less `g`)
    /// only while at least [`CHAIN_MIN_REMAINING`] tips are left, where a prune saves a large
    /// subtree.
    #[inline]
    fn remaining_bound(&self, frame: &Frame, j: usize, g: f64) -> f64 {
        let gate = if self.chain_min_remaining == 0 {
            f64::INFINITY
        } else if self.problem.m() - j >= self.chain_min_remaining {
            CHAIN_GATE
        } else {
            0.0
        };
        remaining_bound(
            &self.problem.objective,
            self.reach,
            self.chains,
            gate,
            frame,
            j,
            self.ub() - g,
        )
    }

    /// The bound of a task's prefix: the per-tip bound of every remaining tip, in full (no
    /// budget; the chain bound is for the search's nodes).
    fn task_bound(&self, frame: &Frame, j: usize) -> f64 {
        self.reach
            .suffix_lower_bound_grouped(&self.problem.objective, frame, j, f64::INFINITY)
    }

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

/// One top-level subtree.
struct Task {
    prefix: Vec<usize>,
    frame: Frame,
    g: f64,
    /// Whether every state of `prefix` is its own mirror (always false without a mirror).
    fixed: bool,
    /// Certified lower bound on the cost of every completion of `prefix`, as `f64` bits.
    lb: AtomicU64,
}

impl Task {
    #[inline]
    fn lb(&self) -> f64 {
        f64::from_bits(self.lb.load(Ordering::Relaxed))
    }
}

struct Worker<'a, 'b> {
    shared: &'b Shared<'a>,
    /// The pass threshold t: nodes whose bound reaches `min(t, U)` are pruned.
    threshold: f64,
    /// Histogram of pruned bounds in `[hist_lo, hist_hi)`.
    hist: [u64; BINS],
    hist_lo: f64,
    hist_scale: f64,
    path: Vec<usize>,
    /// Per-depth child buffers: (bound, g, candidate, frame).
    bufs: Vec<Vec<(f64, f64, usize, Frame)>>,
    nodes: u64,
    unflushed: u64,
    aborted: bool,
}

impl Worker<'_, '_> {
    #[inline]
    fn prune_level(&self) -> f64 {
        self.threshold.min(self.shared.ub())
    }

    #[inline]
    fn pruned(&mut self, bound: f64) {
        let x = (bound - self.hist_lo) * self.hist_scale;
        if (0.0..BINS as f64).contains(&x) {
            self.hist[x as usize] += 1;
        }
    }

    /// Searches below the prefix `path[..j]` (frame `frame`, cost `g`); returns a lower bound on
    /// the cost of every completion of it (the least pruned bound or evaluated leaf cost), valid
    /// only if `self.aborted` is still false.
    fn dfs(&mut self, j: usize, frame: &Frame, g: f64, fixed: bool) -> f64 {
        let sh = self.shared;
        let problem = sh.problem;
        let m = problem.m();
        let obj = &problem.objective;
        let shave = sh.shave;
        let mut least = f64::INFINITY;
        let mut kids = std::mem::take(&mut self.bufs[j]);
        kids.clear();
        let mut level = self.prune_level();
        let sigma = sh.mirror.as_ref().map(|mi| &mi.sigma[j]);
        for (a, c) in problem.catalogue.candidates(j).iter().enumerate() {
            if fixed && sigma.is_some_and(|s| s[a] < a) {
                // Its mirror image, with the same completions' costs, is searched instead.
                continue;
            }
            let f = frame.compose(&c.frame);
            let gc = g + obj.cost(j, &f.origin());
            self.nodes += 1;
            if j + 1 == m {
                self.path[j] = a;
                sh.offer(gc, &self.path);
                least = least.min(gc);
                level = self.prune_level();
                continue;
            }
            if gc * shave >= level {
                least = least.min(gc * shave);
                self.pruned(gc * shave);
                continue;
            }
            let lb = sh.remaining_bound(&f, j + 1, gc);
            let bound = (gc + lb) * shave;
            if bound < level {
                kids.push((bound, gc, a, f));
            } else {
                least = least.min(bound);
                self.pruned(bound);
            }
        }
        self.unflushed += problem.catalogue.candidates(j).len() as u64;
        if self.unflushed >= 1 << 12 {
            sh.control.add_evaluated(self.unflushed);
            self.unflushed = 0;
            if sh.control.stopped() {
                sh.abort.store(true, Ordering::Relaxed);
            }
        }
        kids.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.2.cmp(&y.2)));
        for (i, &(bound, gc, a, f)) in kids.iter().enumerate() {
            if sh.abort.load(Ordering::Relaxed) {
                self.aborted = true;
                break;
            }
            if bound >= self.prune_level() {
                // Sorted: every remaining child is pruned too.
                least = least.min(bound);
                for k in &kids[i..] {
                    self.pruned(k.0);
                }
                break;
            }
            self.path[j] = a;
            let child_fixed = fixed && sigma.is_some_and(|s| s[a] == a);
            let sub = self.dfs(j + 1, &f, gc, child_fixed);
            least = least.min(sub);
            if self.aborted {
                break;
            }
        }
        self.bufs[j] = kids;
        least
    }
}

/// Searches still running after this long switch to the target's fine lower-bound grid.
const FINE_GRID_AFTER: std::time::Duration = std::time::Duration::from_millis(100);

/// Eq 36 problems with at least this many sequences build the fine grid before the seed.
const FINE_GRID_SEQUENCES: u128 = 10_000_000_000_000;

/// Fewer open tasks than this are split into their children before a pass.
const MIN_OPEN_TASKS: usize = 512;

/// Replaces every open task (lb < `ub`) whose children are not leaves by its children (closed
/// tasks are dropped: their lb ≥ U cannot lower the global bound). A child's completions are
/// among its parent's, so it inherits the parent's certified bound (or its own, if larger).
fn split(shared: &Shared<'_>, tasks: Vec<Task>, ub: f64) -> Vec<Task> {
    let problem = shared.problem;
    let m = problem.m();
    let obj = &problem.objective;
    let mut out = Vec::with_capacity(tasks.len() * 4);
    for task in tasks {
        let lb = task.lb();
        if lb >= ub {
            continue;
        }
        let j = task.prefix.len();
        if j + 1 >= m {
            out.push(task);
            continue;
        }
        let sigma = shared.mirror.as_ref().map(|mi| &mi.sigma[j]);
        for (a, c) in problem.catalogue.candidates(j).iter().enumerate() {
            if task.fixed && sigma.is_some_and(|s| s[a] < a) {
                continue;
            }
            let frame = task.frame.compose(&c.frame);
            let g = task.g + obj.cost(j, &frame.origin());
            let own = (g + shared.task_bound(&frame, j + 1)) * shared.shave;
            let mut prefix = task.prefix.clone();
            prefix.push(a);
            out.push(Task {
                fixed: task.fixed && sigma.is_some_and(|s| s[a] == a),
                prefix,
                frame,
                g,
                lb: AtomicU64::new(own.max(lb).to_bits()),
            });
        }
    }
    out.sort_by(|a, b| {
        a.lb()
            .total_cmp(&b.lb())
            .then_with(|| a.prefix.cmp(&b.prefix))
    });
    out
}

/// The certified lower bound `min(U, min over tasks of lb)`.
fn global_lower_bound(tasks: &[Task], ub: f64) -> f64 {
    tasks.iter().map(Task::lb).fold(ub, f64::min)
}

pub(crate) fn solve(problem: &Problem, control: &Control) -> Raw {
    solve_with(problem, control, MIN_TASKS, None, CHAIN_MIN_REMAINING)
}

/// [`solve`] with at least `min_tasks` top-level tasks, trying the chain bound at nodes with at
/// least `chain_min_remaining` tips left (see [`CHAIN_MIN_REMAINING`]; 0: at every node,
/// without the [`CHAIN_GATE`] test); every certified lower bound it computes is also pushed to
/// `trace` (for tests).
pub(crate) fn solve_with(
    problem: &Problem,
    control: &Control,
    min_tasks: u128,
    trace: Option<&Mutex<Vec<f64>>>,
    chain_min_remaining: usize,
) -> Raw {
    let record = |lb: f64| {
        if let Some(t) = trace {
            t.lock().unwrap_or_else(|e| e.into_inner()).push(lb);
        }
    };
    let m = problem.m();
    let start = Instant::now();
    let reach = Reach::new(&problem.catalogue, m);
    // Incumbent: beam, then window polish.
    // Large eq 36 problems use the fine grid from the start (seed included).
    let fine_now = problem.objective.metric() == Metric::Eq36
        && problem.catalogue.sequences() >= FINE_GRID_SEQUENCES;
    let mut seed_reach = Reach::new(&problem.catalogue, super::beam::BEAM_HORIZON);
    if fine_now {
        problem.objective.target().prepare_fine_bounds();
        seed_reach = seed_reach.with_fine_bounds();
    }
    let (seed, _, seed_evals, _) =
        super::beam::beam_with(problem, &seed_reach, SEED_BEAM_WIDTH, control);
    let (seed, polish_evals) = super::window::polish(problem, seed, 2, control);
    let seed_cost = problem.cost_sum(&seed);
    control.offer_best(seed_cost);
    let mirror = symmetry::find(problem);
    let chains = (m >= 3).then(|| Chains::new(&problem.catalogue, CHAIN_HORIZON));
    let shared = Shared {
        problem,
        mirror: mirror.clone(),
        shave: shave(m),
        reach: &reach,
        chains: chains.as_ref(),
        chain_min_remaining,
        control,
        ub_bits: AtomicU64::new(seed_cost.to_bits()),
        best: Mutex::new((seed_cost, seed)),
        abort: AtomicBool::new(false),
    };
    // Top-level tasks with their initial bounds.
    let depth = split_depth(problem, min_tasks).min(m.saturating_sub(1));
    let mut tasks: Vec<Task> = prefixes(problem, depth)
        .into_iter()
        .filter(|(prefix, _, _)| mirror.as_ref().is_none_or(|mi| mi.canonical(prefix)))
        .map(|(prefix, frame, g)| {
            let lb = shared.task_bound(&frame, depth);
            Task {
                fixed: mirror.as_ref().is_some_and(|mi| mi.fixed(&prefix)),
                prefix,
                frame,
                g,
                lb: AtomicU64::new(((g + lb) * shave(m)).to_bits()),
            }
        })
        .collect();
    let mut evaluated = tasks.len() as u64 + seed_evals + polish_evals;
    tasks.sort_by(|a, b| {
        a.lb()
            .total_cmp(&b.lb())
            .then_with(|| a.prefix.cmp(&b.prefix))
    });
    let gap_target = control.target_gap.max(0.0);
    let gap_reached = |lb: f64, ub: f64| {
        gap_target > 0.0
            && relative_gap((ub / m as f64).sqrt(), (lb / m as f64).sqrt()) <= gap_target
    };
    let last_check = Mutex::new(Instant::now());
    let mut stop = None;
    let mut optimal = false;
    // The first threshold: the bound below which about an eighth of the open tasks lie.
    // (and at most 1/32 of the initial gap above the bound).
    let mut threshold = {
        let ub = shared.ub();
        let open: Vec<f64> = tasks.iter().map(Task::lb).filter(|&b| b < ub).collect();
        let lb = global_lower_bound(&tasks, ub);
        open.get(open.len() / 8)
            .copied()
            .unwrap_or(ub)
            .min(lb + (ub - lb) / 32.0)
    };
    // Largest threshold step (bound units), adapted to how fast the passes grow.
    let mut step = f64::INFINITY;
    let mut last_nodes = 0u64;
    let mut fine = fine_now;
    loop {
        let ub = shared.ub();
        let lb = global_lower_bound(&tasks, ub);
        if !step.is_finite() {
            step = (ub - lb) / 32.0;
        }
        control.offer_lower_bound(lb);
        record(lb);
        if lb >= ub {
            optimal = true;
            break;
        }
        if gap_reached(lb, ub) {
            stop = Some(Stop::Gap);
            break;
        }
        if control.stopped() || shared.abort.load(Ordering::Relaxed) {
            break;
        }
        // Few open tasks: split each into its children, for a finer bound and balanced cores.
        let open = tasks.iter().filter(|x| x.lb() < ub).count();
        if open < MIN_OPEN_TASKS && tasks.len() < 1 << 20 {
            let before = tasks.len();
            tasks = split(&shared, tasks, ub);
            evaluated += tasks.len().saturating_sub(before) as u64;
        }
        // Not proven quickly: the fine distance grid pays for its build (≈ 0.1 s).
        if !fine && problem.objective.metric() == Metric::Eq36 && start.elapsed() >= FINE_GRID_AFTER
        {
            fine = true;
            problem.objective.target().prepare_fine_bounds();
            // A second seed: the beam ranks prefixes better on the fine grid.
            let reach =
                Reach::new(&problem.catalogue, super::beam::BEAM_HORIZON).with_fine_bounds();
            let (seed, _, e1, _) =
                super::beam::beam_with(problem, &reach, SEED_BEAM_WIDTH, control);
            let (seed, e2) = super::window::polish(problem, seed, 2, control);
            evaluated += e1 + e2;
            shared.offer(problem.cost_sum(&seed), &seed);
        }
        let t = threshold.min(ub).max(lb);
        let hist_lo = t;
        let hist_scale = if ub > t { BINS as f64 / (ub - t) } else { 0.0 };
        let results: Vec<(u64, [u64; BINS])> = tasks
            .par_iter()
            .filter(|task| task.lb() < t)
            .map(|task| {
                if shared.abort.load(Ordering::Relaxed) {
                    return (0, [0; BINS]);
                }
                let mut w = Worker {
                    shared: &shared,
                    threshold: t,
                    hist: [0; BINS],
                    hist_lo,
                    hist_scale,
                    path: vec![0; m],
                    bufs: vec![Vec::new(); m],
                    nodes: 0,
                    unflushed: 0,
                    aborted: false,
                };
                let depth = task.prefix.len();
                w.path[..depth].copy_from_slice(&task.prefix);
                let least = if depth == m {
                    shared.offer(task.g, &task.prefix);
                    task.g
                } else {
                    w.dfs(depth, &task.frame, task.g, task.fixed)
                };
                control.add_evaluated(w.unflushed);
                if !w.aborted {
                    // Both the old and the new bound are certified; keep the larger.
                    task.lb.fetch_max(least.to_bits(), Ordering::Relaxed);
                    // Now and then, publish the certified bound and check the target gap.
                    let mut last = last_check.lock().unwrap_or_else(|e| e.into_inner());
                    if last.elapsed().as_millis() >= 20 {
                        *last = Instant::now();
                        let ub = shared.ub();
                        let lb = global_lower_bound(&tasks, ub);
                        control.offer_lower_bound(lb);
                        record(lb);
                        if gap_reached(lb, ub) {
                            shared.abort.store(true, Ordering::Relaxed);
                        }
                    }
                }
                (w.nodes, w.hist)
            })
            .collect();
        // The frontier: pruned nodes, and the open tasks this pass did not search.
        let mut hist = [0u64; BINS];
        for task in &tasks {
            let x = (task.lb() - hist_lo) * hist_scale;
            if (0.0..BINS as f64).contains(&x) {
                hist[x as usize] += 1;
            }
        }
        let mut nodes = 0;
        for (n, h) in &results {
            nodes += n;
            for (a, b) in hist.iter_mut().zip(h) {
                *a += b;
            }
        }
        evaluated += nodes;
        if t >= ub {
            // A complete pass at t = U closes every task; the loop head confirms it.
            continue;
        }
        // Next threshold: enough frontier nodes below it to roughly double the work, but a
        // step no larger than `step`, which doubles while passes grow slowly and halves when
        // they explode (frontier counts cannot see how large the subtrees below them are).
        let want = (nodes / 2).max(64);
        let mut cum = 0;
        let mut next = ub;
        for (i, c) in hist.iter().enumerate() {
            cum += c;
            if cum >= want {
                next = hist_lo + (i + 1) as f64 / hist_scale;
                break;
            }
        }
        if last_nodes > 0 {
            if nodes < 3 * last_nodes {
                step *= 2.0;
            } else if nodes > 12 * last_nodes {
                step *= 0.5;
            }
        }
        last_nodes = nodes.max(1);
        threshold = next.min(t + step);
    }
    let interrupted = !optimal && stop.is_none();
    let ub = shared.ub();
    let lb = global_lower_bound(&tasks, ub);
    control.offer_lower_bound(lb);
    record(lb);
    let (_, states) = shared.best.into_inner().unwrap_or_else(|e| e.into_inner());
    Raw {
        states,
        optimal,
        evaluated,
        interrupted,
        lower_bound: Some(lb),
        stop,
    }
}
