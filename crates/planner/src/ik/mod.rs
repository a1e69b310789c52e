//! Shape inverse kinematics (paper §4.2): choose one metastable state per module so that a
//! stacked Yoshimura boom follows a target curve.
//!
//! # The problem
//!
//! A boom of m modules grows from the origin along +z. Module i (bottom first) takes one of its
//! candidate states — the 2(n+1) shape states of the geometry catalogue (`deployed`, `folded`,
//! `edge-i`, `vertex-i`), or only the feasible ones — each with its eq 5 transform `T_i`. Tip i
//! is the centroid of module i's top boundary, `x_i = T1⋯Ti·0` (eq 35). A [`Metric`] scores the
//! tips against a [`Target`] polyline:
//!
//! - [`Metric::Eq36`] (default): `RMS = sqrt(1/m Σ_i dist(x_i, C)²)`, `dist` to the nearest
//!   point of the polyline C, segments included;
//! - [`Metric::Ordered`]: tip i is matched to the point at arc length `i·L/m` of C, so the boom
//!   covers the curve evenly and in order instead of bunching up on part of it.
//!
//! Both are sums of per-tip terms that depend only on the tip's position and index; every
//! solver uses that.
//!
//! # Solvers ([`Algorithm`]), one interface ([`solve`]) and one result ([`Solution`])
//!
//! | solver | what it does | guarantee |
//! |---|---|---|
//! | `exhaustive` | every sequence, depth first, parallel over prefixes; each prefix frame is composed once and shared by all its completions | optimal (`optimal: true` when it finishes) |
//! | `exact` | branch and bound seeded with a beam incumbent; admissible bound = exact prefix cost + per-tip reachable-set bound ([`reach`]); best-bound child order; parallel over top-level subtrees sharing an atomic incumbent | optimal, proven (`optimal: true` when it finishes) |
//! | `greedy` | each module in turn takes the state whose tip is closest to the target | none |
//! | `beam` | keeps the k best prefixes per layer, ranked by prefix cost + the same reachable-set bound over a short horizon | none (k → ∞ is exhaustive) |
//! | `window` | receding horizon: optimise modules j..j+w−1 exhaustively given the committed prefix, commit module j, slide; then sweep windows of w modules until none improves | no w consecutive modules can be changed to improve the fit (unless interrupted) |
//! | `dp` | dynamic programming over frames: two prefixes that reach the same frame have the same futures, so only the cheaper is kept; frames are merged when equal within a tolerance | optimal if the tolerance is 0 and the layer cap is not hit; otherwise approximate (see [`dp`]) |
//!
//! Every solver reports the RMS recomputed from its states' tips, so the reported RMS is always
//! the RMS of the reported boom. Solvers poll a stop flag in [`Control`] (Ctrl-C) and then
//! return the best complete boom found so far with `optimal: false`.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

pub mod bands;
pub mod beam;
pub mod chain;
pub mod diagnose;
pub mod dp;
mod error;
pub mod exact;
pub mod exhaustive;
mod frame;
mod problem;
pub mod reach;
pub mod symmetry;
pub mod target;
pub mod window;

pub use error::IkError;
pub use frame::Frame;
/// The point type of tips and targets (units of l).
pub use nalgebra::Point3;
pub use problem::{Candidate, Catalogue, Metric, Objective, Problem};
pub use target::Target;

/// Which solver to run, with its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Algorithm {
    /// Proven global optimum by branch and bound.
    Exact,
    /// Every sequence (the reference).
    Exhaustive,
    /// One module at a time, nearest tip.
    Greedy,
    /// Beam search keeping `width` prefixes per layer.
    Beam {
        /// Beam width k ≥ 1.
        width: usize,
    },
    /// Sliding windows of `width` modules (2–4).
    Window {
        /// Window width w.
        width: usize,
    },
    /// Dynamic programming over frames merged within tolerances.
    Dp(dp::DpParams),
}

impl Algorithm {
    /// The command-line names of the solvers.
    pub const NAMES: &'static [&'static str] =
        &["exact", "exhaustive", "greedy", "beam", "window", "dp"];

    /// The solver's name.
    pub fn name(&self) -> &'static str {
        match self {
            Algorithm::Exact => "exact",
            Algorithm::Exhaustive => "exhaustive",
            Algorithm::Greedy => "greedy",
            Algorithm::Beam { .. } => "beam",
            Algorithm::Window { .. } => "window",
            Algorithm::Dp(_) => "dp",
        }
    }
}

/// Shared controls between a running solver and its caller: a stop flag the solver polls
/// (Ctrl-C), an optional deadline and target gap, and counters the caller may read for
/// progress.
#[derive(Debug, Clone)]
pub struct Control {
    /// Set to ask the solver to stop and return the best boom found so far.
    pub stop: Arc<AtomicBool>,
    /// Stop (as if `stop` were set) once this instant has passed.
    pub deadline: Option<Instant>,
    /// `exact` stops as soon as its certified relative gap ([`Solution::gap`]) is at most
    /// this (0: run until the optimum is proven).
    pub target_gap: f64,
    /// Sequences or search nodes evaluated so far (updated in batches).
    pub evaluated: Arc<AtomicU64>,
    /// Best sum of squared tip costs found so far, as `f64` bits (`u64::MAX` before any).
    pub best_sum_bits: Arc<AtomicU64>,
    /// Best proven lower bound on the optimal sum of squared tip costs, as `f64` bits
    /// (0 before any; only `exact` and a finished `exhaustive` raise it).
    pub lower_bound_bits: Arc<AtomicU64>,
}

impl Default for Control {
    fn default() -> Self {
        Self::new()
    }
}

impl Control {
    /// A fresh control: not stopped, no deadline, gap 0, nothing evaluated.
    pub fn new() -> Self {
        Control {
            stop: Arc::new(AtomicBool::new(false)),
            deadline: None,
            target_gap: 0.0,
            evaluated: Arc::new(AtomicU64::new(0)),
            best_sum_bits: Arc::new(AtomicU64::new(u64::MAX)),
            lower_bound_bits: Arc::new(AtomicU64::new(0)),
        }
    }

    /// Whether the caller asked to stop or the deadline has passed.
    #[inline]
    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed) || self.deadline.is_some_and(|d| Instant::now() >= d)
    }

    /// Why the solver should stop now, if it should.
    pub(crate) fn stop_reason(&self) -> Option<Stop> {
        if self.stop.load(Ordering::Relaxed) {
            Some(Stop::Interrupted)
        } else if self.deadline.is_some_and(|d| Instant::now() >= d) {
            Some(Stop::TimeLimit)
        } else {
            None
        }
    }

    pub(crate) fn offer_lower_bound(&self, sum: f64) {
        self.lower_bound_bits
            .fetch_max(sum.max(0.0).to_bits(), Ordering::Relaxed);
    }

    /// Best proven lower bound on the RMS of any boom of `m` modules.
    pub fn lower_bound_rms(&self, m: usize) -> f64 {
        (f64::from_bits(self.lower_bound_bits.load(Ordering::Relaxed)) / m as f64).sqrt()
    }

    pub(crate) fn add_evaluated(&self, n: u64) {
        self.evaluated.fetch_add(n, Ordering::Relaxed);
    }

    pub(crate) fn offer_best(&self, sum: f64) {
        // Non-negative f64 order like their bit patterns.
        self.best_sum_bits
            .fetch_min(sum.max(0.0).to_bits(), Ordering::Relaxed);
    }

    /// Best RMS found so far for a boom of `m` modules, if any.
    pub fn best_rms(&self, m: usize) -> Option<f64> {
        let bits = self.best_sum_bits.load(Ordering::Relaxed);
        (bits != u64::MAX).then(|| (f64::from_bits(bits) / m as f64).sqrt())
    }
}

/// The result of a solver.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// Candidate index of each module, bottom first.
    pub states: Vec<usize>,
    /// Name of each module's state, bottom first.
    pub names: Vec<String>,
    /// RMS of the boom's tips under the problem's metric, recomputed from `states`.
    pub rms: f64,
    /// Whether `states` is proven to be a global optimum.
    pub optimal: bool,
    /// Complete sequences (exhaustive) or search nodes / partial sequences (the others)
    /// evaluated.
    pub evaluated: u64,
    /// Wall-clock time of the solve.
    pub elapsed: Duration,
    /// The tips x_1..x_m of the boom (units of l).
    pub tips: Vec<Point3<f64>>,
    /// Whether the solver stopped early because [`Control::stop`] was set or the deadline
    /// passed.
    pub interrupted: bool,
    /// Why the solver returned.
    pub stop: Stop,
    /// A proven lower bound on the RMS of every boom (`exact`, and `exhaustive` when it
    /// finishes); `None` for solvers that prove nothing.
    pub lower_bound_rms: Option<f64>,
    /// The certified relative gap `(rms − lower_bound_rms) / rms` (0 when `rms` is 0): the
    /// optimum's RMS is at least `rms·(1 − gap)`. `None` without a lower bound.
    pub gap: Option<f64>,
}

/// Why a solver returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// It ran to completion (for `exact`/`exhaustive`: the optimum is proven).
    Finished,
    /// `exact` reached the requested gap ([`Control::target_gap`]).
    Gap,
    /// The deadline ([`Control::deadline`]) passed.
    TimeLimit,
    /// [`Control::stop`] was set (Ctrl-C).
    Interrupted,
}

impl Stop {
    /// The name used in reports (`finished`, `gap`, `time-limit`, `interrupted`).
    pub fn name(self) -> &'static str {
        match self {
            Stop::Finished => "finished",
            Stop::Gap => "gap",
            Stop::TimeLimit => "time-limit",
            Stop::Interrupted => "interrupted",
        }
    }
}

/// The relative gap between an incumbent RMS and a lower bound on it.
pub fn relative_gap(rms: f64, lower_bound_rms: f64) -> f64 {
    if rms <= 0.0 {
        0.0
    } else {
        ((rms - lower_bound_rms) / rms).clamp(0.0, 1.0)
    }
}

/// What a solver returns before the common bookkeeping.
pub(crate) struct Raw {
    pub states: Vec<usize>,
    pub optimal: bool,
    pub evaluated: u64,
    pub interrupted: bool,
    /// Proven lower bound on the optimal cost sum, if the solver proves one.
    pub lower_bound: Option<f64>,
    /// `Some(Stop::Gap)` when the solver stopped at the target gap.
    pub stop: Option<Stop>,
}

/// Runs `algorithm` on `problem`.
pub fn solve(
    problem: &Problem,
    algorithm: Algorithm,
    control: &Control,
) -> Result<Solution, IkError> {
    let start = Instant::now();
    let raw = match algorithm {
        Algorithm::Exact => exact::solve(problem, control),
        Algorithm::Exhaustive => exhaustive::solve(problem, control),
        Algorithm::Greedy => beam::greedy(problem, control),
        Algorithm::Beam { width } => {
            if width == 0 {
                return Err(IkError::Parameter("beam width must be at least 1".into()));
            }
            beam::beam(problem, width, control)
        }
        Algorithm::Window { width } => {
            if !(1..=6).contains(&width) {
                return Err(IkError::Parameter(format!(
                    "window width must be between 1 and 6 (the paper uses 2–4); got {width}"
                )));
            }
            window::solve(problem, width, control)
        }
        Algorithm::Dp(params) => dp::solve(problem, params, control)?,
    };
    Ok(finish(problem, raw, start.elapsed(), control))
}

fn finish(problem: &Problem, raw: Raw, elapsed: Duration, control: &Control) -> Solution {
    let tips = problem.catalogue.tips(&raw.states);
    let rms = problem.objective.rms(&tips);
    let m = problem.m();
    let optimal = raw.optimal && !raw.interrupted;
    let lower_bound_rms = if optimal {
        Some(rms)
    } else {
        raw.lower_bound
            .map(|lb| (lb.max(0.0) / m as f64).sqrt().min(rms))
    };
    let stop = if raw.interrupted {
        control.stop_reason().unwrap_or(Stop::Interrupted)
    } else {
        raw.stop.unwrap_or(Stop::Finished)
    };
    Solution {
        names: problem.catalogue.names(&raw.states),
        rms,
        optimal,
        evaluated: raw.evaluated,
        elapsed,
        tips,
        interrupted: raw.interrupted,
        stop,
        lower_bound_rms,
        gap: lower_bound_rms.map(|lb| if optimal { 0.0 } else { relative_gap(rms, lb) }),
        states: raw.states,
    }
}

#[cfg(test)]
mod tests;
#[cfg(test)]
pub(crate) mod testutil;
