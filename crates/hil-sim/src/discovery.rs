//! Transition discovery: from each stable state, apply each kind of actuation and record where
//! the trunk settles.
//!
//! This runs the physics alone, with an ideal reference actuator (a valve regulator and
//! slew-limited winches that follow the firmware's valve policy: inlet closed and exhaust as a
//! relief valve while pulling, exhaust open while releasing). It answers "what can this trunk
//! do", independent of the controller; the controller is checked against the same physics by the
//! end-to-end tests.
//!
//! Two explorations per state:
//! - **pneumatic**: open the inlet and raise the pressure until the first snap-through (or the
//!   pressure cap), then vent;
//! - **tendon**: pull all three tendons together until the trunk has snapped into another named
//!   state (passing through the bottom's half-packed intermediate, which is not a state), or
//!   the winches reach their travel or stall, then release.
//!
//! Manual edges are the catalogue's (a person can fold anything); [`verify_catalogue`] checks,
//! through the real controller (the host engine sends each catalogue step, the firmware
//! executes it), that each edge's own primitives, with their parameters perturbed by a margin,
//! land where the catalogue says.

use geometry::TrunkState;
use protocol::messages::{ManualTask, Primitive, StepKind};
use protocol::transitions::{Transition, TRANSITIONS};

use crate::physics::trunk::{well_name, Module};
use crate::physics::{Actuation, Trunk, TrunkParams};

/// Physics step of the rig, s.
const DT_S: f64 = 1e-3;

/// The reference actuator's settings (from the firmware's default configuration where the
/// firmware has the same setting).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigConfig {
    /// Pressure cap: exploration stops inflating here.
    pub pressure_cap_kpa: f64,
    /// Regulator hysteresis.
    pub hysteresis_kpa: f64,
    /// Exhaust relief pressure while pulling.
    pub pull_relief_kpa: f64,
    /// Winch speed, mm/s.
    pub winch_mm_per_s: f64,
    /// Longest pull, mm.
    pub max_pull_mm: f64,
    /// Time to wait after a primitive for the trunk to settle, s.
    pub settle_s: f64,
}

impl RigConfig {
    /// The crane's own limits: its pressure cap (`CraneConfig::pressure_limit_kpa`) and the
    /// winches' travel, not the protocol's hard maximum.
    pub fn crane() -> Self {
        let fw = firmware::CraneConfig::default();
        Self {
            pressure_cap_kpa: fw.pressure_limit_kpa as f64,
            ..Self::default()
        }
    }
}

impl Default for RigConfig {
    fn default() -> Self {
        let fw = firmware::CraneConfig::default();
        Self {
            pressure_cap_kpa: protocol::HARD_MAX_PRESSURE_KPA as f64,
            hysteresis_kpa: fw.hysteresis_kpa as f64,
            pull_relief_kpa: fw.pull_relief_kpa as f64,
            winch_mm_per_s: (fw.servo.slew_deg_per_s * fw.geometry.winch.mm_per_deg()) as f64,
            max_pull_mm: fw.max_tendon_mm as f64,
            settle_s: 1.5,
        }
    }
}

/// One snap-through seen by the rig.
#[derive(Debug, Clone, PartialEq)]
pub struct SnapRecord {
    /// Time since the primitive sequence started, s.
    pub t_s: f64,
    /// Module.
    pub module: Module,
    /// Well names, e.g. `"F"` → `"D"`.
    pub from: &'static str,
    /// Well arrived in.
    pub to: &'static str,
    /// Gauge pressure at the snap's onset (when the module left its stable branch), kPa.
    pub pressure_kpa: f64,
    /// Tendon pay-in at the snap's onset, mm.
    pub pay_in_mm: f64,
}

/// The physics plus an ideal actuator.
#[derive(Debug, Clone)]
pub struct Rig {
    /// The trunk.
    pub trunk: Trunk,
    /// Actuator settings.
    pub cfg: RigConfig,
    act: Actuation,
    t_s: f64,
    /// Snaps so far.
    pub snaps: Vec<SnapRecord>,
    /// Highest gauge pressure seen, kPa.
    pub max_pressure_kpa: f64,
    /// Pressure and pay-in when each module last sat on a stable branch (the snap's onset).
    onset: [(f64, f64); 2],
}

impl Rig {
    /// A rig with the calibrated trunk at rest in `state`.
    pub fn new(state: TrunkState, cfg: RigConfig) -> Self {
        let params = TrunkParams::pdf().unwrap_or_else(|e| unreachable!("pdf params: {e}"));
        Self::with_params(params, state, cfg)
    }

    /// A rig with the trunk of `params` at rest in `state`.
    pub fn with_params(params: TrunkParams, state: TrunkState, cfg: RigConfig) -> Self {
        Self {
            trunk: Trunk::new(params, state),
            cfg,
            act: Actuation::default(),
            t_s: 0.0,
            snaps: Vec::new(),
            max_pressure_kpa: 0.0,
            onset: [(0.0, 0.0); 2],
        }
    }

    fn tick(&mut self) -> usize {
        let wells = self.trunk.wells();
        let p_before = self.trunk.pressure_kpa();
        for (i, w) in wells.iter().enumerate() {
            if w.is_some() {
                self.onset[i] = (p_before, self.act.pay_in_mm[0]);
            }
        }
        let snaps = self.trunk.step(DT_S, &self.act);
        self.t_s += DT_S;
        let p = self.trunk.pressure_kpa();
        self.max_pressure_kpa = self.max_pressure_kpa.max(p);
        let mut n = 0;
        for s in snaps.iter() {
            n += 1;
            let (pressure_kpa, pay_in_mm) = self.onset[s.module as usize];
            self.snaps.push(SnapRecord {
                t_s: self.t_s,
                module: s.module,
                from: well_name(s.module, s.from_well),
                to: well_name(s.module, s.to_well),
                pressure_kpa,
                pay_in_mm,
            });
        }
        n
    }

    fn settle(&mut self) {
        self.act.inlet_open = false;
        let steps = (self.cfg.settle_s / DT_S) as usize;
        for _ in 0..steps {
            self.tick();
        }
    }

    /// Regulates toward `target_kpa` with the inlet until `snaps` snap-throughs (0: until the
    /// target is reached), or until it has held the target for the settle time.
    pub fn inflate(&mut self, target_kpa: f64, snaps: u8) -> usize {
        let mut seen = 0;
        let mut held_s = 0.0;
        let mut filling = true;
        self.act.exhaust_open = false;
        loop {
            let p = self.trunk.pressure_kpa();
            if p >= target_kpa {
                filling = false;
            } else if p < target_kpa - self.cfg.hysteresis_kpa {
                filling = true;
            }
            self.act.inlet_open = filling;
            seen += self.tick();
            if p >= target_kpa - self.cfg.hysteresis_kpa {
                held_s += DT_S;
            }
            if (snaps > 0 && seen >= snaps as usize)
                || (snaps == 0 && p >= target_kpa)
                || held_s > self.cfg.settle_s
                || self.t_s > 600.0
            {
                break;
            }
        }
        self.act.inlet_open = false;
        seen
    }

    /// Opens the exhaust until the pressure is at or below `target_kpa` (+0.5 kPa).
    pub fn vent(&mut self, target_kpa: f64) {
        self.act.inlet_open = false;
        self.act.exhaust_open = true;
        let start = self.t_s;
        while self.trunk.pressure_kpa() > target_kpa + 0.5 && self.t_s - start < 60.0 {
            self.tick();
        }
        self.act.exhaust_open = false;
    }

    /// Pulls all tendons toward `length_mm` at the winch speed until `snaps` snap-throughs
    /// (0: until the length), the exhaust relieving above the relief pressure; then waits up to
    /// the settle time for missing snaps.
    pub fn pull(&mut self, length_mm: f64, snaps: u8) -> usize {
        self.pull_until(length_mm, |_, seen| snaps > 0 && seen >= snaps as usize)
    }

    fn pull_until(&mut self, length_mm: f64, mut done: impl FnMut(&Trunk, usize) -> bool) -> usize {
        let mut seen = 0;
        let mut relieving = false;
        let mut at_length_s = 0.0;
        self.act.inlet_open = false;
        loop {
            let p = self.trunk.pressure_kpa();
            if p > self.cfg.pull_relief_kpa {
                relieving = true;
            } else if p < self.cfg.pull_relief_kpa - self.cfg.hysteresis_kpa {
                relieving = false;
            }
            self.act.exhaust_open = relieving;
            let s = self.act.pay_in_mm[0];
            let next = (s + self.cfg.winch_mm_per_s * DT_S).min(length_mm);
            self.act.pay_in_mm = [next; 3];
            seen += self.tick();
            if done(&self.trunk, seen) {
                break;
            }
            if next >= length_mm {
                at_length_s += DT_S;
                if at_length_s > self.cfg.settle_s {
                    break;
                }
            }
        }
        self.act.exhaust_open = false;
        seen
    }

    /// Lets the tendons out to `length_mm` with the exhaust open.
    pub fn release(&mut self, length_mm: f64) {
        self.act.inlet_open = false;
        self.act.exhaust_open = true;
        while self.act.pay_in_mm[0] > length_mm {
            let next = (self.act.pay_in_mm[0] - self.cfg.winch_mm_per_s * DT_S).max(length_mm);
            self.act.pay_in_mm = [next; 3];
            self.tick();
        }
        self.settle();
        self.act.exhaust_open = false;
    }

    /// Lets the tendons out to `length_mm` with both valves closed, then waits the settle time:
    /// the trunk returns to its rest height at a constant gas amount, so the pressure tells its
    /// volume (docs/simulator.md, "Findings", 1).
    pub fn release_sealed(&mut self, length_mm: f64) {
        self.act.inlet_open = false;
        self.act.exhaust_open = false;
        while self.act.pay_in_mm[0] > length_mm {
            let next = (self.act.pay_in_mm[0] - self.cfg.winch_mm_per_s * DT_S).max(length_mm);
            self.act.pay_in_mm = [next; 3];
            self.tick();
        }
        self.settle();
    }

    /// Applies one catalogue primitive (manual tasks are done by hand at once).
    pub fn apply(&mut self, p: &Primitive) {
        match *p {
            Primitive::Inflate {
                pressure_kpa,
                snaps,
            } => {
                self.inflate(pressure_kpa as f64, snaps);
            }
            Primitive::Vent { pressure_kpa } => self.vent(pressure_kpa as f64),
            Primitive::TendonPull { length_mm, snaps } => {
                self.pull(length_mm as f64, snaps);
            }
            Primitive::TendonRelease { length_mm } => self.release(length_mm as f64),
            Primitive::Hold { duration_ms } => {
                for _ in 0..duration_ms {
                    self.tick();
                }
            }
            Primitive::WaitSnap { timeout_ms } => {
                for _ in 0..timeout_ms {
                    if self.tick() > 0 {
                        break;
                    }
                }
            }
            Primitive::Manual(task) => self.manual(task),
            Primitive::Gripper { .. } | Primitive::Bend { .. } => {}
        }
    }

    /// Does a manual task by hand.
    pub fn manual(&mut self, task: ManualTask) {
        match task {
            ManualTask::PackBottomModule => self.trunk.set_module_well(Module::Bottom, 0),
            ManualTask::FoldTopModule => self.trunk.set_module_well(Module::Top, 0),
            ManualTask::FoldBottomModule => self.trunk.set_module_well(Module::Bottom, 2),
        }
    }

    /// Where the trunk has settled (after the settle time).
    pub fn settled_state(&mut self) -> Option<TrunkState> {
        self.settle();
        self.trunk.state()
    }
}

/// What one exploration did.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Start state.
    pub from: TrunkState,
    /// Actuation kind.
    pub kind: StepKind,
    /// Where the trunk settled (`None`: between states).
    pub to: Option<TrunkState>,
    /// Snaps on the way.
    pub snaps: Vec<SnapRecord>,
    /// Highest gauge pressure, kPa.
    pub max_pressure_kpa: f64,
}

/// Inflates from `from` until the first snap (or the cap), then vents.
pub fn explore_pneumatic(from: TrunkState, cfg: RigConfig) -> Outcome {
    explore_pneumatic_of(Rig::new(from, cfg), from, cfg)
}

fn explore_pneumatic_of(mut rig: Rig, from: TrunkState, cfg: RigConfig) -> Outcome {
    rig.inflate(cfg.pressure_cap_kpa, 1);
    rig.vent(0.0);
    let to = rig.settled_state();
    Outcome {
        from,
        kind: StepKind::Pneumatic,
        to,
        snaps: rig.snaps,
        max_pressure_kpa: rig.max_pressure_kpa,
    }
}

/// Pulls from `from` until the trunk sits in another named state after a snap (or the winch
/// travel ends), then releases.
pub fn explore_tendon(from: TrunkState, cfg: RigConfig) -> Outcome {
    explore_tendon_of(Rig::new(from, cfg), from, cfg)
}

fn explore_tendon_of(mut rig: Rig, from: TrunkState, cfg: RigConfig) -> Outcome {
    let max = cfg.max_pull_mm;
    rig.pull_until(max, |t, seen| {
        seen > 0 && t.state().is_some_and(|s| s != from)
    });
    rig.release(0.0);
    let to = rig.settled_state();
    Outcome {
        from,
        kind: StepKind::Tendon,
        to,
        snaps: rig.snaps,
        max_pressure_kpa: rig.max_pressure_kpa,
    }
}

/// One edge of the discovered graph.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct Edge {
    /// Start state.
    pub from: TrunkState,
    /// End state.
    pub to: TrunkState,
    /// How it is actuated.
    pub kind: EdgeKind,
}

/// [`StepKind`] with an order (for sorting and comparing graphs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum EdgeKind {
    /// Pressure.
    Pneumatic,
    /// Tendons.
    Tendon,
    /// By hand.
    Manual,
}

impl From<StepKind> for EdgeKind {
    fn from(k: StepKind) -> Self {
        match k {
            StepKind::Pneumatic => EdgeKind::Pneumatic,
            StepKind::Tendon => EdgeKind::Tendon,
            StepKind::Manual => EdgeKind::Manual,
        }
    }
}

impl EdgeKind {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            EdgeKind::Pneumatic => "pneumatic",
            EdgeKind::Tendon => "tendon",
            EdgeKind::Manual => "manual",
        }
    }
}

/// The discovered graph: every exploration and the edges they found.
#[derive(Debug, Clone, PartialEq)]
pub struct Graph {
    /// Every exploration (two per state).
    pub outcomes: Vec<Outcome>,
    /// Edges: explorations that ended in another named state, plus the catalogue's manual
    /// edges; sorted.
    pub edges: Vec<Edge>,
}

/// Runs every exploration (12 runs of the physics).
pub fn discover(cfg: RigConfig) -> Graph {
    let params = TrunkParams::pdf().unwrap_or_else(|e| unreachable!("pdf params: {e}"));
    discover_trunk(&params, cfg)
}

/// [`discover`] on the trunk of `params`.
pub fn discover_trunk(params: &TrunkParams, cfg: RigConfig) -> Graph {
    let mut outcomes = Vec::new();
    for from in TrunkState::ALL {
        let rig = || Rig::with_params(params.clone(), from, cfg);
        outcomes.push(explore_pneumatic_of(rig(), from, cfg));
        outcomes.push(explore_tendon_of(rig(), from, cfg));
    }
    let mut edges: Vec<Edge> = outcomes
        .iter()
        .filter_map(|o| match o.to {
            Some(to) if to != o.from => Some(Edge {
                from: o.from,
                to,
                kind: o.kind.into(),
            }),
            _ => None,
        })
        .collect();
    edges.extend(
        TRANSITIONS
            .iter()
            .filter(|t| t.kind == StepKind::Manual)
            .map(|t| Edge {
                from: t.from,
                to: t.to,
                kind: EdgeKind::Manual,
            }),
    );
    edges.sort();
    edges.dedup();
    Graph { outcomes, edges }
}

/// The catalogue's edges in the same form.
pub fn catalogue_edges() -> Vec<Edge> {
    let mut e: Vec<Edge> = TRANSITIONS
        .iter()
        .map(|t| Edge {
            from: t.from,
            to: t.to,
            kind: t.kind.into(),
        })
        .collect();
    e.sort();
    e
}

/// Runs `t` as one step through the real controller on the simulated crane (the host engine
/// sends it, the controller executes its primitives with its own regulator, relief and sealed
/// release, the simulated operator does a manual step), with every inflation pressure scaled by
/// `pressure_scale` and every pull length offset by `length_offset_mm`; returns where the trunk
/// really settled (the simulator's truth, not what the controller concluded), or why the step
/// could not be sent.
pub fn run_transition(
    t: &Transition,
    pressure_scale: f32,
    length_offset_mm: f32,
) -> Result<Option<TrunkState>, crate::host::HostError> {
    let mut sim = crate::Sim::new(crate::SimOptions {
        initial: t.from,
        seed: 0,
        ..crate::SimOptions::default()
    });
    let mut host = crate::host::SimHost::new();
    host.hello(&mut sim)?;
    let mut step = t.step();
    // A pull longer than the winches' travel is refused by the controller (its interlock): the
    // margin is tested within what it accepts.
    let max_pull_mm = sim.crane_config().max_tendon_mm;
    for p in step.primitives.iter_mut() {
        match p {
            Primitive::Inflate { pressure_kpa, .. } => *pressure_kpa *= pressure_scale,
            Primitive::TendonPull { length_mm, .. } => {
                *length_mm = (*length_mm + length_offset_mm).clamp(0.0, max_pull_mm)
            }
            _ => {}
        }
    }
    // The step's own time limit, and the operator's delay for a manual one, bound the run.
    let limit_ms = u64::from(step.timeout_ms) + 10_000;
    host.run_plan(&mut sim, 1, &[step], limit_ms)?;
    // The trunk settles (the engine heartbeats meanwhile).
    for _ in 0..1_500 {
        host.poll(&mut sim);
    }
    Ok(sim.safety().true_state)
}

/// A catalogue edge that did not land where it says.
#[derive(Debug, Clone, PartialEq)]
pub struct Mismatch {
    /// The edge.
    pub from: TrunkState,
    /// Where it should land.
    pub expected: TrunkState,
    /// Where it landed.
    pub got: Option<TrunkState>,
    /// The perturbation: pressure scale and length offset.
    pub perturbation: (f32, f32),
}

/// Runs every catalogue edge through the real controller ([`run_transition`]) nominally and
/// perturbed (pressures ×(1 ± `pressure_margin`), lengths ± `length_margin_mm`); returns the
/// edges that missed.
pub fn verify_catalogue(pressure_margin: f32, length_margin_mm: f32) -> Vec<Mismatch> {
    let mut bad = Vec::new();
    for t in &TRANSITIONS {
        for (ps, lo) in [
            (1.0, 0.0),
            (1.0 - pressure_margin, -length_margin_mm),
            (1.0 + pressure_margin, length_margin_mm),
        ] {
            let got = run_transition(t, ps, lo).ok().flatten();
            if got != Some(t.to) {
                bad.push(Mismatch {
                    from: t.from,
                    expected: t.to,
                    got,
                    perturbation: (ps, lo),
                });
            }
        }
    }
    bad
}

fn opt_state(s: Option<TrunkState>) -> String {
    s.map_or_else(|| "between".to_string(), |s| s.name().to_string())
}

/// The graph as JSON: `{"states": [...], "edges": [{"from","to","kind"}], "explorations": [...]}`.
pub fn to_json(g: &Graph) -> serde_json::Value {
    use serde_json::json;
    json!({
        "states": TrunkState::ALL.iter().map(|s| s.name()).collect::<Vec<_>>(),
        "edges": g.edges.iter().map(|e| json!({
            "from": e.from.name(), "to": e.to.name(), "kind": e.kind.name(),
        })).collect::<Vec<_>>(),
        "explorations": g.outcomes.iter().map(|o| json!({
            "from": o.from.name(),
            "kind": EdgeKind::from(o.kind).name(),
            "to": opt_state(o.to),
            "max_pressure_kpa": (o.max_pressure_kpa * 100.0).round() / 100.0,
            "snaps": o.snaps.iter().map(|s| json!({
                "t_s": (s.t_s * 1000.0).round() / 1000.0,
                "module": match s.module { Module::Top => "top", Module::Bottom => "bottom" },
                "from": s.from, "to": s.to,
                "pressure_kpa": (s.pressure_kpa * 100.0).round() / 100.0,
                "pay_in_mm": (s.pay_in_mm * 10.0).round() / 10.0,
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    })
}

/// The graph in Graphviz DOT (red: pressure, orange: tendons, dashed black: by hand, as in the
/// paper's Fig. 5c).
pub fn to_dot(g: &Graph) -> String {
    let mut s = String::from("digraph pdf_trunk {\n  rankdir=LR;\n  node [shape=box];\n");
    for st in TrunkState::ALL {
        s.push_str(&format!("  \"{}\";\n", st.name()));
    }
    for e in &g.edges {
        let style = match e.kind {
            EdgeKind::Pneumatic => "color=red",
            EdgeKind::Tendon => "color=orange",
            EdgeKind::Manual => "color=black, style=dashed",
        };
        s.push_str(&format!(
            "  \"{}\" -> \"{}\" [label=\"{}\", {style}];\n",
            e.from.name(),
            e.to.name(),
            e.kind.name()
        ));
    }
    s.push_str("}\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pull from `from` to `length_mm` (relief as the firmware does), release sealed; returns
    /// (snaps, pressure change from before the pull to after the sealed release, final state).
    fn pull_and_release_sealed(from: &str, length_mm: f64) -> (usize, f64, Option<TrunkState>) {
        let mut rig = Rig::new(from.parse().unwrap(), RigConfig::default());
        let p0 = rig.trunk.pressure_kpa();
        let snaps = rig.pull(length_mm, 0);
        rig.release_sealed(0.0);
        (snaps, rig.trunk.pressure_kpa() - p0, rig.trunk.state())
    }

    #[test]
    fn a_sealed_release_reveals_the_snaps_the_pressure_step_misses() {
        // F&D → F&F: a pull short of the buckling (80 mm) and one past it (120 mm).
        let (n_short, dp_short, s_short) = pull_and_release_sealed("F&D", 80.0);
        let (n_long, dp_long, s_long) = pull_and_release_sealed("F&D", 120.0);
        assert_eq!((n_short, s_short), (0, Some("F&D".parse().unwrap())));
        assert_eq!((n_long, s_long), (1, Some("F&F".parse().unwrap())));
        assert!(dp_long - dp_short > 4.0, "{dp_short} vs {dp_long} kPa");
        // F&F → F&P (two snaps): the packed trunk ends ≈ 49 mm shorter.
        let (n, dp, s) = pull_and_release_sealed("F&F", 182.0);
        assert_eq!((n, s), (2, Some("F&P".parse().unwrap())));
        let (_, dp0, _) = pull_and_release_sealed("F&F", 120.0);
        assert!(dp - dp0 > 4.0, "{dp0} vs {dp} kPa");
        // Every residual stays below the lowest snap threshold (unpacking at 13 kPa).
        assert!(dp_long < 12.0 && dp < 12.0, "{dp_long} {dp}");
    }

    /// The firmware confirms a tendon step by its n spikes and a sealed rise of at least
    /// `tendon_check.min_rise_kpa`: every catalogue edge clears the rise with margin, whether
    /// the pull stops at the snaps or goes to its full length; a pull short of the snap does
    /// not, and packing one bottom layer of two shows one spike of the two the step expects.
    #[test]
    fn every_tendon_edge_clears_the_firmwares_sealed_rise_threshold() {
        let per_snap = firmware::CraneConfig::default().tendon_check.min_rise_kpa as f64;
        for t in TRANSITIONS.iter().filter(|t| t.kind == StepKind::Tendon) {
            let Some(Primitive::TendonPull { length_mm, snaps }) = t.primitives.first() else {
                panic!("{t:?}");
            };
            let need = per_snap;
            for stop_at_snaps in [*snaps, 0] {
                let mut rig = Rig::new(t.from, RigConfig::default());
                let p0 = rig.trunk.pressure_kpa();
                rig.pull(*length_mm as f64, stop_at_snaps);
                rig.release_sealed(0.0);
                let rise = rig.trunk.pressure_kpa() - p0;
                assert!(rise > need + 1.0, "{} -> {}: {rise:.2} kPa", t.from, t.to);
            }
        }
        let (_, no_snap, _) = pull_and_release_sealed("F&D", 80.0);
        assert!(no_snap < per_snap - 1.0, "{no_snap}");
        let (n, one_layer, s) = pull_and_release_sealed("F&F", 150.0);
        assert_eq!((n, s), (1, None));
        assert!(one_layer > per_snap, "{one_layer}");
    }
}
