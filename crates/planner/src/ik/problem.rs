//! The problem every solver shares: per-module candidate transforms and the objective.

use std::sync::Arc;

use geometry::ModuleDesign;
use nalgebra::Point3;

use super::{Frame, IkError, Target};

/// One candidate state of one module: its name and its eq 5 transform (bottom → top frame).
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// The state's name (`deployed`, `folded`, `edge-3`, `vertex-0`, …).
    pub name: String,
    /// The module's transform in this state (eq 5), units of l.
    pub frame: Frame,
    /// Whether the geometry marks the state feasible (`StateInfo::feasible`: it exists for
    /// this β and its crease strain is within `geometry::STRAIN_TOLERANCE`).
    pub feasible: bool,
    /// The state's largest relative crease-length error (`StateInfo::max_strain`).
    pub strain: f64,
}

/// The candidate states of every module of a boom, bottom module first.
#[derive(Debug, Clone)]
pub struct Catalogue {
    modules: Vec<Arc<[Candidate]>>,
    uniform: bool,
}

impl Catalogue {
    /// A boom whose module `i` chooses among `modules[i]`.
    pub fn new(modules: Vec<Vec<Candidate>>) -> Result<Self, IkError> {
        if modules.is_empty() {
            return Err(IkError::NoModules);
        }
        if let Some(module) = modules.iter().position(Vec::is_empty) {
            return Err(IkError::NoCandidates {
                module,
                hint: String::new(),
            });
        }
        let uniform = modules.windows(2).all(|w| w[0] == w[1]);
        let mut shared: Vec<Arc<[Candidate]>> = Vec::with_capacity(modules.len());
        for m in modules {
            match shared.last() {
                Some(prev) if **prev == *m => shared.push(prev.clone()),
                _ => shared.push(m.into()),
            }
        }
        Ok(Catalogue {
            modules: shared,
            uniform,
        })
    }

    /// The boom of `designs` (bottom module first): each module's candidates are the 2(n+1)
    /// catalogue states of its design, in the catalogue's order (deployed, folded, edge-0…,
    /// vertex-0…), whether or not the geometry flags a residual — or, with `feasible_only`,
    /// only the states the geometry marks feasible. All designs must share n.
    pub fn from_designs(designs: &[ModuleDesign], feasible_only: bool) -> Result<Self, IkError> {
        let Some(first) = designs.first() else {
            return Err(IkError::NoModules);
        };
        if let Some(d) = designs.iter().find(|d| d.n() != first.n()) {
            return Err(IkError::Design(format!(
                "all modules must share n (their boundaries must be congruent); got n = {} and n = {}",
                first.n(),
                d.n()
            )));
        }
        let mut modules = Vec::with_capacity(designs.len());
        let mut cache: Option<(ModuleDesign, Vec<Candidate>)> = None;
        for (i, d) in designs.iter().enumerate() {
            if let Some((cd, cands)) = &cache {
                if cd == d {
                    modules.push(cands.clone());
                    continue;
                }
            }
            let cands: Vec<Candidate> = d
                .shape_states()
                .map(|s| d.state_info(s))
                .filter(|info| !feasible_only || info.feasible)
                .map(|info| Candidate {
                    name: info.state.to_string(),
                    frame: Frame::from_isometry(&info.pose.isometry()),
                    feasible: info.feasible,
                    strain: info.max_strain,
                })
                .collect();
            if cands.is_empty() {
                return Err(IkError::NoCandidates {
                    module: i,
                    hint: format!(
                        ": no state of n = {}, β = {}° is feasible; pass --all-states for the paper's full catalogue or choose another β",
                        d.n(),
                        d.beta_deg()
                    ),
                });
            }
            cache = Some((*d, cands.clone()));
            modules.push(cands);
        }
        Self::new(modules)
    }

    /// A boom of `m` identical modules choosing among `candidates`.
    pub fn uniform(candidates: Vec<Candidate>, m: usize) -> Result<Self, IkError> {
        Self::new(vec![candidates; m])
    }

    /// Number of modules m.
    pub fn len(&self) -> usize {
        self.modules.len()
    }

    /// Always false: a catalogue has at least one module.
    pub fn is_empty(&self) -> bool {
        self.modules.is_empty()
    }

    /// Whether every module has the same candidates (in the same order).
    pub fn is_uniform(&self) -> bool {
        self.uniform
    }

    /// The candidates of module `i` (0 = bottom).
    #[inline]
    pub fn candidates(&self, i: usize) -> &[Candidate] {
        &self.modules[i]
    }

    /// Number of complete sequences, ∏ K_i (saturating).
    pub fn sequences(&self) -> u128 {
        self.modules
            .iter()
            .fold(1u128, |acc, m| acc.saturating_mul(m.len() as u128))
    }

    /// The tips x_1..x_m of the boom in `states` (candidate indices, bottom first), eq 35.
    pub fn tips(&self, states: &[usize]) -> Vec<Point3<f64>> {
        self.frames(states).iter().map(Frame::origin).collect()
    }

    /// The cumulative frames T1⋯Ti of the boom in `states`.
    pub fn frames(&self, states: &[usize]) -> Vec<Frame> {
        let mut f = Frame::identity();
        states
            .iter()
            .enumerate()
            .map(|(i, &s)| {
                f = f.compose(&self.modules[i][s].frame);
                f
            })
            .collect()
    }

    /// The modules of `states` whose state the geometry marks infeasible:
    /// `(module index, candidate)`, bottom first.
    pub fn infeasible<'a>(
        &'a self,
        states: &'a [usize],
    ) -> impl Iterator<Item = (usize, &'a Candidate)> + 'a {
        states
            .iter()
            .enumerate()
            .map(|(i, &s)| (i, &self.modules[i][s]))
            .filter(|(_, c)| !c.feasible)
    }

    /// The names of `states`.
    pub fn names(&self, states: &[usize]) -> Vec<String> {
        states
            .iter()
            .enumerate()
            .map(|(i, &s)| self.modules[i][s].name.clone())
            .collect()
    }
}

/// How a boom's tips are scored against the target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Metric {
    /// Eq 36: RMS over tips of the distance from each tip to its nearest point on the target
    /// polyline (anywhere on it, segments included).
    #[default]
    Eq36,
    /// Ordered: tip i (1-based) is matched to the point at arc length `i·L/m` along the target
    /// (L its length), so the tips cover the whole curve, in order, evenly.
    Ordered,
}

impl Metric {
    /// The metric's command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Metric::Eq36 => "eq36",
            Metric::Ordered => "ordered",
        }
    }
}

/// The objective: the sum over tips of a per-tip squared distance; RMS = sqrt(sum / m).
///
/// Both metrics are *separable*: tip i's cost depends only on its position and on i. The branch
/// and bound relies on this.
#[derive(Debug, Clone)]
pub struct Objective {
    target: Target,
    metric: Metric,
    stations: Vec<Point3<f64>>,
}

impl Objective {
    /// The objective of fitting `m` tips to `target` under `metric`.
    pub fn new(target: Target, metric: Metric, m: usize) -> Self {
        let stations = match metric {
            Metric::Eq36 => Vec::new(),
            Metric::Ordered => (1..=m)
                .map(|i| target.point_at_arc_length(target.length() * i as f64 / m as f64))
                .collect(),
        };
        Objective {
            target,
            metric,
            stations,
        }
    }

    /// The target curve.
    pub fn target(&self) -> &Target {
        &self.target
    }

    /// The ordered metric's stations (tip i matched to `stations()[i]`); empty for eq 36.
    pub fn stations(&self) -> &[Point3<f64>] {
        &self.stations
    }

    /// The metric.
    pub fn metric(&self) -> Metric {
        self.metric
    }

    /// Squared distance of tip `i` (0-based) at `p`.
    #[inline]
    pub fn cost(&self, i: usize, p: &Point3<f64>) -> f64 {
        match self.metric {
            Metric::Eq36 => self.target.dist2(p),
            Metric::Ordered => (p - self.stations[i]).norm_squared(),
        }
    }

    /// A lower bound on [`cost`](Self::cost) of tip `i` anywhere within `radius` of `center`.
    #[inline(always)]
    pub fn ball_lower_bound(&self, i: usize, center: &Point3<f64>, radius: f64) -> f64 {
        let d = match self.metric {
            Metric::Eq36 => self.target.dist_lower_bound(center, radius),
            Metric::Ordered => ((center - self.stations[i]).norm() - radius).max(0.0),
        };
        d * d
    }

    /// Like [`ball_lower_bound`](Self::ball_lower_bound), with the target's fine grid for eq 36
    /// once it is built ([`Target::prepare_fine_bounds`]).
    #[inline(always)]
    pub fn ball_lower_bound_fine(&self, i: usize, center: &Point3<f64>, radius: f64) -> f64 {
        let d = match self.metric {
            Metric::Eq36 => self.target.dist_lower_bound_fine(center, radius),
            Metric::Ordered => ((center - self.stations[i]).norm() - radius).max(0.0),
        };
        d * d
    }

    /// The point tip `i` is matched to (the nearest point of the target for eq 36).
    pub fn matched_point(&self, i: usize, p: &Point3<f64>) -> Point3<f64> {
        match self.metric {
            Metric::Eq36 => self.target.nearest_point(p),
            Metric::Ordered => self.stations[i],
        }
    }

    /// RMS of the given tips: `sqrt(Σ cost / m)`.
    pub fn rms(&self, tips: &[Point3<f64>]) -> f64 {
        if tips.is_empty() {
            return 0.0;
        }
        let sum: f64 = tips.iter().enumerate().map(|(i, p)| self.cost(i, p)).sum();
        (sum / tips.len() as f64).sqrt()
    }
}

/// A complete inverse-kinematics problem: what each module can do and what to fit.
#[derive(Debug, Clone)]
pub struct Problem {
    /// The candidate states of each module.
    pub catalogue: Catalogue,
    /// The objective.
    pub objective: Objective,
}

impl Problem {
    /// A problem fitting the boom of `catalogue` to `target` under `metric`.
    pub fn new(catalogue: Catalogue, target: Target, metric: Metric) -> Self {
        let m = catalogue.len();
        Problem {
            objective: Objective::new(target, metric, m),
            catalogue,
        }
    }

    /// Number of modules m.
    pub fn m(&self) -> usize {
        self.catalogue.len()
    }

    /// The length of one module for [`check_fittable`](Self::check_fittable): the shortest
    /// step `|T·0|` (bottom to top centroid) among the bottom module's candidates.
    pub fn shortest_module(&self) -> f64 {
        self.catalogue
            .candidates(0)
            .iter()
            .map(|c| c.frame.translation.norm())
            .fold(f64::INFINITY, f64::min)
    }

    /// Refuses a target the boom cannot follow: one shorter (in arc length) than the
    /// [`shortest_module`](Self::shortest_module), less a relative 1e-9 for rounding. (A single
    /// point has length 0.)
    pub fn check_fittable(&self) -> Result<(), IkError> {
        let length = self.objective.target().length();
        let module = self.shortest_module();
        if length < module * (1.0 - 1e-9) {
            return Err(IkError::TooShort { length, module });
        }
        Ok(())
    }

    /// Sum of squared per-tip costs of `states`.
    pub fn cost_sum(&self, states: &[usize]) -> f64 {
        self.catalogue
            .tips(states)
            .iter()
            .enumerate()
            .map(|(i, p)| self.objective.cost(i, p))
            .sum()
    }

    /// RMS of `states` (eq 36 or ordered).
    pub fn rms(&self, states: &[usize]) -> f64 {
        self.objective.rms(&self.catalogue.tips(states))
    }
}
