//! The solar station: which pop-out states of the top modules of a stack point its top face
//! at the sun, sample by sample through a day, and the best schedule with at most K refolds.
//!
//! A **configuration** is one catalogue state per adjustable module (the top `adjustable`
//! modules; the others keep fixed states). Its top-face normal comes from the geometry's
//! frames ([`geometry::orient`]) turned onto the compass by the base's [`Heading`]. A sample's
//! **score** is max(0, cos incidence) = max(0, n·s) while the sun is up, 0 while it is down.
//!
//! * [`Station::best_each`]: at every sample a configuration of highest score (ties keep the
//!   previous sample's configuration, then take the lowest index).
//! * [`Station::best_with_changes`]: the schedule of highest total score with at most K
//!   **refolds** (a refold is a sample whose configuration differs from the previous
//!   sample's, however many modules it changes; the first sample's configuration is free).
//!   Exact dynamic programming over time, O(T·(K+1)·C) time, proved in `docs/sun.md`.

use geometry::orient::{self, Heading};
use geometry::{ModuleDesign, ShapeState};
use nalgebra::Vector3;

/// What is wrong with a station.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StationError {
    /// No modules.
    #[error("the station needs at least one module")]
    NoModules,
    /// More adjustable modules than modules, or none.
    #[error("--adjustable {adjustable} must be in [1, {modules}] (the number of modules)")]
    Adjustable {
        /// Asked for.
        adjustable: usize,
        /// Modules in the stack.
        modules: usize,
    },
    /// The fixed states do not match the non-adjustable modules.
    #[error("--fixed has {given} states but {expected} modules are fixed (the bottom {expected})")]
    FixedCount {
        /// Given.
        given: usize,
        /// Needed.
        expected: usize,
    },
    /// A fixed state the geometry marks infeasible.
    #[error("fixed module {module} state {state} is infeasible for this design (crease strain {strain:.3})")]
    FixedInfeasible {
        /// 1-based module.
        module: usize,
        /// The state.
        state: ShapeState,
        /// Its strain.
        strain: f64,
    },
    /// Modules of different n cannot stack.
    #[error("every module must have the same n")]
    MixedN,
    /// Too many configurations to enumerate.
    #[error("{0} configurations (candidate states ^ adjustable modules) exceed the limit of 4096; adjust fewer modules")]
    TooMany(usize),
    /// The DP's back-pointer table would not fit.
    #[error("a schedule over {samples} samples with up to {changes} refolds and {configs} configurations needs too much memory; use a coarser --every or fewer --max-changes")]
    TooLarge {
        /// Samples.
        samples: usize,
        /// K.
        changes: usize,
        /// C.
        configs: usize,
    },
}

/// Most configurations enumerated.
pub const MAX_CONFIGURATIONS: usize = 4096;

/// One configuration of the adjustable modules and where it points the top face.
#[derive(Debug, Clone, PartialEq)]
pub struct Configuration {
    /// States of the adjustable modules, bottom first.
    pub states: Vec<ShapeState>,
    /// Top-face normal in the base frame.
    pub normal_base: Vector3<f64>,
    /// Top-face normal in east-north-up coordinates.
    pub normal_enu: Vector3<f64>,
}

/// The sun at one sample: its unit direction (east-north-up) and whether it is up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunDirection {
    /// Unit vector towards the sun, ENU.
    pub enu: Vector3<f64>,
    /// Above the horizon.
    pub up: bool,
}

impl SunDirection {
    /// From compass azimuth and elevation (degrees; refracted elevation: the direction light
    /// arrives from).
    pub fn from_compass(azimuth_deg: f64, elevation_deg: f64, up: bool) -> SunDirection {
        SunDirection {
            enu: orient::enu_from_azimuth_elevation(azimuth_deg, elevation_deg).into_inner(),
            up,
        }
    }
}

/// The beam score of a face with unit normal `normal` (ENU) under `sun`.
pub fn score(normal: &Vector3<f64>, sun: &SunDirection) -> f64 {
    if sun.up {
        normal.dot(&sun.enu).max(0.0)
    } else {
        0.0
    }
}

/// A stack with its top modules adjustable.
#[derive(Debug, Clone)]
pub struct Station {
    designs: Vec<ModuleDesign>,
    fixed: Vec<ShapeState>,
    candidates: Vec<Vec<ShapeState>>,
    configurations: Vec<Configuration>,
    heading: Heading,
    pop_outs: bool,
}

/// A schedule: one configuration index per sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    /// Configuration per sample.
    pub choice: Vec<usize>,
    /// Σ score over the samples.
    pub total: f64,
    /// Samples whose configuration differs from the previous sample's.
    pub changes: usize,
}

impl Schedule {
    fn from_choice(choice: Vec<usize>, scores: &[Vec<f64>]) -> Schedule {
        let total = choice.iter().zip(scores).map(|(c, s)| s[*c]).sum();
        let changes = choice.windows(2).filter(|w| w[0] != w[1]).count();
        Schedule {
            choice,
            total,
            changes,
        }
    }
}

impl Station {
    /// A station of `designs` (bottom first, one n), the top `adjustable` of them adjustable
    /// among their feasible catalogue states (every catalogue state with `all_states`), the
    /// others in `fixed` (default: deployed), its base at `heading`.
    pub fn new(
        designs: Vec<ModuleDesign>,
        adjustable: usize,
        fixed: Option<Vec<ShapeState>>,
        heading: Heading,
        all_states: bool,
    ) -> Result<Station, StationError> {
        let m = designs.len();
        if m == 0 {
            return Err(StationError::NoModules);
        }
        if designs.iter().any(|d| d.n() != designs[0].n()) {
            return Err(StationError::MixedN);
        }
        if adjustable == 0 || adjustable > m {
            return Err(StationError::Adjustable {
                adjustable,
                modules: m,
            });
        }
        let n_fixed = m - adjustable;
        let fixed = fixed.unwrap_or_else(|| vec![ShapeState::Deployed; n_fixed]);
        if fixed.len() != n_fixed {
            return Err(StationError::FixedCount {
                given: fixed.len(),
                expected: n_fixed,
            });
        }
        for (k, (d, s)) in designs.iter().zip(&fixed).enumerate() {
            let info = d.state_info(*s);
            if !info.feasible && !all_states {
                return Err(StationError::FixedInfeasible {
                    module: k + 1,
                    state: *s,
                    strain: info.max_strain,
                });
            }
        }
        let candidates: Vec<Vec<ShapeState>> = designs[n_fixed..]
            .iter()
            .map(|d| {
                d.shape_states()
                    .filter(|s| all_states || d.state_info(*s).feasible)
                    .collect()
            })
            .collect();
        let count = candidates
            .iter()
            .try_fold(1usize, |acc, c| acc.checked_mul(c.len()))
            .unwrap_or(usize::MAX);
        if count > MAX_CONFIGURATIONS {
            return Err(StationError::TooMany(count));
        }
        let pop_outs = candidates.iter().any(|c| c.iter().any(|s| s.is_pop_out()));
        let mut station = Station {
            designs,
            fixed,
            candidates,
            configurations: Vec::with_capacity(count),
            heading,
            pop_outs,
        };
        for index in 0..count {
            let states = station.states_of(index);
            let normal_base = orient::top_normal(station.poses(&states)).into_inner();
            let normal_enu = station.heading.base_to_enu() * normal_base;
            station.configurations.push(Configuration {
                states,
                normal_base,
                normal_enu,
            });
        }
        Ok(station)
    }

    /// The adjustable states of configuration `index` (mixed radix, top module fastest).
    fn states_of(&self, mut index: usize) -> Vec<ShapeState> {
        let mut states = vec![ShapeState::Deployed; self.candidates.len()];
        for (slot, c) in states.iter_mut().zip(&self.candidates).rev() {
            *slot = c[index % c.len()];
            index /= c.len();
        }
        states
    }

    /// The poses of the whole stack with the adjustable modules in `states`.
    pub fn poses<'a>(
        &'a self,
        states: &'a [ShapeState],
    ) -> impl Iterator<Item = geometry::Pose> + 'a {
        self.designs
            .iter()
            .zip(self.fixed.iter().chain(states))
            .map(|(d, s)| d.pose(*s))
    }

    /// Module designs, bottom first.
    pub fn designs(&self) -> &[ModuleDesign] {
        &self.designs
    }

    /// States of the fixed (bottom) modules.
    pub fn fixed(&self) -> &[ShapeState] {
        &self.fixed
    }

    /// Candidate states of each adjustable module.
    pub fn candidates(&self) -> &[Vec<ShapeState>] {
        &self.candidates
    }

    /// Every configuration; index 0 has every adjustable module in its first candidate
    /// (deployed).
    pub fn configurations(&self) -> &[Configuration] {
        &self.configurations
    }

    /// The base's compass heading.
    pub fn heading(&self) -> Heading {
        self.heading
    }

    /// Whether any adjustable module has a pop-out candidate (without one the top face never
    /// tilts: only deployed and folded remain).
    pub fn has_pop_outs(&self) -> bool {
        self.pop_outs
    }

    /// The score of every configuration at every sample: `scores[t][c]`.
    pub fn scores(&self, suns: &[SunDirection]) -> Vec<Vec<f64>> {
        suns.iter()
            .map(|s| {
                self.configurations
                    .iter()
                    .map(|c| score(&c.normal_enu, s))
                    .collect()
            })
            .collect()
    }

    /// At every sample a configuration of highest score; ties keep the previous sample's
    /// configuration, then take the lowest index.
    pub fn best_each(&self, scores: &[Vec<f64>]) -> Schedule {
        let mut choice = Vec::with_capacity(scores.len());
        let mut prev: Option<usize> = None;
        for s in scores {
            let best = argmax(s);
            let c = match prev {
                Some(p) if s[p] >= s[best] => p,
                _ => best,
            };
            choice.push(c);
            prev = Some(c);
        }
        Schedule::from_choice(choice, scores)
    }

    /// The schedule of highest total score with at most `k` refolds, exactly; among equal
    /// totals the fewest refolds. See the module docs and `docs/sun.md` for the proof.
    pub fn best_with_changes(
        &self,
        scores: &[Vec<f64>],
        k: usize,
    ) -> Result<Schedule, StationError> {
        let free = self.best_each(scores);
        if free.changes <= k {
            // The per-sample optimum bounds every schedule, and this one is within budget.
            return Ok(free);
        }
        let t_len = scores.len();
        let c_len = self.configurations.len();
        let layers = k + 1;
        let words = c_len.div_ceil(64);
        let cells = t_len
            .checked_mul(layers)
            .and_then(|x| x.checked_mul(words))
            .filter(|x| *x <= 1 << 27)
            .ok_or(StationError::TooLarge {
                samples: t_len,
                changes: k,
                configs: c_len,
            })?;
        // switched[(t·layers + j)·words + c/64] bit c%64: V_t[j][c] came from a refold.
        let mut switched = vec![0u64; cells];
        // from[t·layers + j]: the configuration a refold into sample t at budget j leaves.
        let mut from = vec![0usize; t_len * layers];
        let mut v = vec![vec![0.0f64; c_len]; layers];
        for row in v.iter_mut() {
            row.copy_from_slice(&scores[0]);
        }
        let mut next = v.clone();
        for t in 1..t_len {
            for j in 0..layers {
                let best_prev = if j > 0 { Some(argmax(&v[j - 1])) } else { None };
                if let Some(b) = best_prev {
                    from[t * layers + j] = b;
                }
                for c in 0..c_len {
                    let stay = v[j][c];
                    let (val, sw) = match best_prev {
                        Some(b) if v[j - 1][b] > stay => (v[j - 1][b], true),
                        _ => (stay, false),
                    };
                    next[j][c] = val + scores[t][c];
                    if sw {
                        switched[(t * layers + j) * words + c / 64] |= 1 << (c % 64);
                    }
                }
            }
            std::mem::swap(&mut v, &mut next);
        }
        // The smallest budget that reaches the best total (V is non-decreasing in j).
        // Paths of equal value may round differently in the last bits: equal within 1e-12.
        let top = v[k][argmax(&v[k])];
        let tol = 1e-12 * top.abs().max(1.0);
        let j_best = (0..layers)
            .find(|&j| v[j][argmax(&v[j])] >= top - tol)
            .unwrap_or(k);
        let mut c = argmax(&v[j_best]);
        let mut j = j_best;
        let mut choice = vec![0usize; t_len];
        for t in (0..t_len).rev() {
            choice[t] = c;
            if t == 0 {
                break;
            }
            if switched[(t * layers + j) * words + c / 64] & (1 << (c % 64)) != 0 {
                c = from[t * layers + j];
                j -= 1;
            }
        }
        Ok(Schedule::from_choice(choice, scores))
    }
}

/// Index of the largest value (the first of equals).
fn argmax(s: &[f64]) -> usize {
    let mut best = 0;
    for (i, v) in s.iter().enumerate() {
        if *v > s[best] {
            best = i;
        }
    }
    best
}

/// What a person does to take one module from `from` to `to`, in the crease pattern's terms
/// (`host-tool pattern`'s facet numbers within the module's layer: inner bottom i = i, inner
/// top i = n + i, rhombus lower j = 2n + j, rhombus upper j = 3n + j).
pub fn folding_instruction(n: u32, from: ShapeState, to: ShapeState) -> String {
    let n = n as usize;
    let undo = match from {
        ShapeState::Deployed => None,
        ShapeState::Folded => {
            Some("pull the module out to its deployed height (every column stretched)".to_string())
        }
        ShapeState::Edge(i) => {
            let i = i as usize;
            Some(format!(
                "open edge {i} (inner facets {i} and {}) until the module stands straight",
                n + i
            ))
        }
        ShapeState::Vertex(i) => {
            let i = i as usize;
            Some(format!(
                "open column {i} (rhombus facets {} and {}) until the module stands straight",
                2 * n + i,
                3 * n + i
            ))
        }
    };
    let todo = match to {
        ShapeState::Deployed => None,
        ShapeState::Folded => Some(
            "fold every column in along its mid valley fold (all rhombi) to the folded height"
                .to_string(),
        ),
        ShapeState::Edge(i) => {
            let i = i as usize;
            Some(format!(
                "fold edge {i} in: inner facets {i} and {} fold flat onto each other until top edge {i} rests on bottom edge {i}",
                n + i
            ))
        }
        ShapeState::Vertex(i) => {
            let i = i as usize;
            Some(format!(
                "push vertex {i} in: rhombus facets {} and {} fold flat along the mid valley fold until top vertex {i} rests on bottom vertex {i}",
                2 * n + i,
                3 * n + i
            ))
        }
    };
    match (undo, todo) {
        (None, None) => "no change".to_string(),
        (Some(u), None) => u,
        (None, Some(t)) => t,
        (Some(u), Some(t)) => format!("{u}, then {t}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instructions_name_the_facets_of_both_states() {
        let s = folding_instruction(3, ShapeState::Edge(0), ShapeState::Vertex(2));
        assert!(s.contains("open edge 0 (inner facets 0 and 3)"), "{s}");
        assert!(s.contains("rhombus facets 8 and 11"), "{s}");
        assert!(s.contains("top vertex 2 rests on bottom vertex 2"), "{s}");
        assert_eq!(
            folding_instruction(3, ShapeState::Deployed, ShapeState::Deployed),
            "no change"
        );
    }

    #[test]
    fn argmax_takes_the_first_of_equals() {
        assert_eq!(argmax(&[0.1, 0.5, 0.5, 0.2]), 1);
    }
}
