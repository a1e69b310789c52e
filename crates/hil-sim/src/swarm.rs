//! The swarm tester: random scenarios of the whole system on one virtual clock, checked
//! against invariants at every step (FoundationDB's and TigerBeetle's deterministic simulation
//! testing, for a crane).
//!
//! A [`Scenario`] is drawn from a seed: an initial state, 1–5 targets, injected faults with
//! random onsets (several at once), line noise 0–2 %, power cuts, host crashes (a new host
//! engine takes over), and an operator mistake at a manual step. [`run`] plays it with the real
//! host engine, the real controller and the physics; [`Checker`] watches every millisecond.
//! Same seed, same run: [`run`] of a seed is reproducible exactly, and a failing scenario is
//! [`shrink`]ed to a smaller one that still fails.

use std::cell::RefCell;
use std::fmt::Write as _;
use std::rc::Rc;

use geometry::TrunkState;
use host::{Driver, Host, HostEvent, RunEvent, RunOptions, SessionEvent, Timing};
use protocol::messages::{ManualTask, Mode};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use transition_graph::Graph;

use crate::operator::Mistake;
use crate::pair::SimIo;
use crate::physics::{TrunkError, TrunkSpec};
use crate::{Fault, Sim, SimOptions};

/// True pressure allowed above the cap: the sensor's noise (3σ = 0.45 kPa), the filter's lag
/// and the exhaust's response while the firmware vents an over-pressure.
pub const PRESSURE_TOLERANCE_KPA: f32 = 3.0;
/// After a fault becomes active, the actuators must be safe within this long (the firmware
/// closes the inlet at once; limp servos and a vent to the cap take a moment).
pub const SAFE_WITHIN_MS: u64 = 2_000;
/// A confirmed state may disagree with the trunk this long while the trunk settles (a snap takes
/// a few hundred ms; the controller confirms at the end of a step).
pub const SETTLE_MS: u64 = 1_000;
/// A run's time bound: this much for connecting, identifying and replanning, plus each
/// planned step's own limit and the host's grace past it.
pub const RUN_BASE_BOUND_MS: u64 = 60_000;
/// The host's grace past a step's limit ([`host::RunOptions::step_grace_ms`]'s default).
const STEP_GRACE_MS: u64 = 5_000;
/// Host sessions per target (each crash or failure starts a new one).
const ATTEMPTS_PER_TARGET: usize = 3;
/// How far the tip may be from where the host's model puts it for the state the device
/// confirms, at rest on the calibrated trunk, mm: `host-tool reach`'s default tolerance.
pub const TIP_TOLERANCE_MM: f64 = 5.0;
/// The device's pressure reading below which the trunk holds no air, kPa (the controller's
/// vent tolerance 0.5 and twice the sensor's noise).
const AMBIENT_KPA: f32 = 0.8;
/// The tendon pull below which the tendons count as slack, N (≤ 0.48 N seen at rest after
/// every completed step).
const TENDON_SLACK_N: f64 = 1.0;
/// The name of a grasp task's object.
const TASK_OBJECT: &str = "task-object";
/// A grip session's time bound: connect, a status, the gripper's step.
const GRIP_BOUND_MS: u64 = 20_000;

/// The faults a scenario may inject (line noise is drawn as a rate of its own).
const INJECTABLE: [Fault; 7] = [
    Fault::ValveStuckClosed,
    Fault::ValveStuckOpen,
    Fault::Leak,
    Fault::ServoStall,
    Fault::TendonBreak,
    Fault::SensorDropout,
    Fault::LinkDrop,
];

/// One random scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Its seed (also the simulator's).
    pub seed: u64,
    /// The trunk's state at start.
    pub initial: TrunkState,
    /// States to reach, in order.
    pub targets: Vec<TrunkState>,
    /// Faults and their onsets (virtual ms).
    pub faults: Vec<(Fault, u64)>,
    /// Byte corruption probability on the link.
    pub line_noise: f64,
    /// Power cuts (virtual ms).
    pub power_cuts: Vec<u64>,
    /// Host crashes (virtual ms): the engine vanishes without a word; a new one takes over.
    pub host_crashes: Vec<u64>,
    /// The operator's mistake at the first manual step.
    pub mistake: Option<Mistake>,
    /// The operator stops the run under way (virtual ms; Ctrl-C): the next attempt resumes it.
    pub stops: Vec<u64>,
    /// A task: once the target of this index is reached, a person places an object of this
    /// mass (kg) at the tip and the host closes the gripper on it; the crane carries it through
    /// the targets after, and the gripper opens at the end.
    pub grasp: Option<(usize, f64)>,
    /// The trunk (the calibrated one, or one drawn around it: [`ScenarioOptions`]).
    pub trunk: TrunkSpec,
    /// The spread its trunk was drawn with (0: the base trunk itself).
    pub trunk_spread: f64,
    /// Draws refused (the physics could not represent them) before this trunk.
    pub trunk_redraws: u32,
    /// The scenario's trunk is calibrated first (`host::calibration`, as `host-tool calibrate
    /// --sim` does), on a twin of its crane with nothing injected; its plans then use the
    /// measured thresholds, or the catalogue's when the walk was refused.
    pub calibrate: bool,
}

/// How scenarios are drawn beyond their seed.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioOptions {
    /// The operator may make a mistake at a manual step.
    pub mistakes: bool,
    /// The trunk the scenarios' trunks are drawn around.
    pub trunk: TrunkSpec,
    /// Each scenario's trunk varies every parameter within ±this fraction
    /// ([`TrunkSpec::spread`]; 0: every scenario runs `trunk` itself).
    pub trunk_spread: f64,
    /// Each scenario begins with a calibration walk ([`Scenario::calibrate`]).
    pub calibrate: bool,
}

impl Default for ScenarioOptions {
    fn default() -> Self {
        Self {
            mistakes: true,
            trunk: TrunkSpec::pdf(),
            trunk_spread: 0.0,
            calibrate: false,
        }
    }
}

impl Scenario {
    /// The scenario of `seed` without the operator's mistake (`--no-operator-mistakes`).
    pub fn generate_without_mistakes(seed: u64) -> Self {
        Self {
            mistake: None,
            ..Self::generate(seed)
        }
    }

    /// The scenario of `seed` drawn with `opts`: the same scenario as [`Scenario::generate`]
    /// (its own stream), with its trunk drawn from a stream of its own (so a spread changes
    /// the trunk and nothing else). Fails only for a base trunk the physics cannot represent
    /// or a spread outside [0, 1).
    pub fn generate_with(seed: u64, opts: &ScenarioOptions) -> Result<Self, TrunkError> {
        let mut s = if opts.mistakes {
            Self::generate(seed)
        } else {
            Self::generate_without_mistakes(seed)
        };
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7a0c_7a0c_7a0c_7a0c);
        let (trunk, redraws) = opts.trunk.spread(opts.trunk_spread, &mut rng)?;
        s.trunk = trunk;
        s.trunk_spread = opts.trunk_spread;
        s.trunk_redraws = redraws;
        s.calibrate = opts.calibrate;
        Ok(s)
    }

    /// The scenario of `seed`.
    pub fn generate(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_5eed_5eed_5eed);
        let state = |rng: &mut ChaCha8Rng| TrunkState::ALL[rng.gen_range(0..6)];
        let initial = state(&mut rng);
        let targets: Vec<TrunkState> = (0..rng.gen_range(1..=5)).map(|_| state(&mut rng)).collect();
        let horizon = 60_000;
        let mut faults = Vec::new();
        // Most runs are nominal or nearly: faults are rare events, and a run with every fault
        // tests little beyond the first.
        if rng.gen_bool(0.4) {
            for _ in 0..rng.gen_range(1..=3) {
                let f = INJECTABLE[rng.gen_range(0..INJECTABLE.len())];
                if !faults.iter().any(|(g, _)| *g == f) {
                    faults.push((f, rng.gen_range(0..horizon)));
                }
            }
        }
        let line_noise = if rng.gen_bool(0.3) {
            rng.gen_range(0.0..0.02)
        } else {
            0.0
        };
        let times = |rng: &mut ChaCha8Rng, p: f64| -> Vec<u64> {
            let mut v = Vec::new();
            for _ in 0..3 {
                if rng.gen_bool(p) {
                    v.push(rng.gen_range(0..horizon));
                }
            }
            v
        };
        let power_cuts = times(&mut rng, 0.15);
        let host_crashes = times(&mut rng, 0.15);
        let mistake = match rng.gen_range(0..10) {
            0 => Some(Mistake::Refuse),
            1 => Some(Mistake::WrongFold(
                [
                    ManualTask::PackBottomModule,
                    ManualTask::FoldTopModule,
                    ManualTask::FoldBottomModule,
                ][rng.gen_range(0..3)],
            )),
            _ => None,
        };
        // Drawn last: the draws above, and so every older scenario's other ingredients, are
        // unchanged.
        let stops = times(&mut rng, 0.1);
        let grasp = rng
            .gen_bool(0.3)
            .then(|| (rng.gen_range(0..targets.len()), rng.gen_range(0.02..1.0)));
        Self {
            seed,
            initial,
            targets,
            faults,
            line_noise,
            power_cuts,
            host_crashes,
            mistake,
            stops,
            grasp,
            trunk: TrunkSpec::pdf(),
            trunk_spread: 0.0,
            trunk_redraws: 0,
            calibrate: false,
        }
    }

    /// Smaller scenarios: each with one element fewer (a target, a fault, a cut, a crash, the
    /// noise, the mistake).
    pub fn smaller(&self) -> Vec<Scenario> {
        let mut out = Vec::new();
        for i in 0..self.targets.len() {
            if self.targets.len() > 1 {
                let mut s = self.clone();
                s.targets.remove(i);
                out.push(s);
            }
        }
        for i in 0..self.faults.len() {
            let mut s = self.clone();
            s.faults.remove(i);
            out.push(s);
        }
        for i in 0..self.power_cuts.len() {
            let mut s = self.clone();
            s.power_cuts.remove(i);
            out.push(s);
        }
        for i in 0..self.host_crashes.len() {
            let mut s = self.clone();
            s.host_crashes.remove(i);
            out.push(s);
        }
        for i in 0..self.stops.len() {
            let mut s = self.clone();
            s.stops.remove(i);
            out.push(s);
        }
        if self.line_noise > 0.0 {
            out.push(Scenario {
                line_noise: 0.0,
                ..self.clone()
            });
        }
        if self.mistake.is_some() {
            out.push(Scenario {
                mistake: None,
                ..self.clone()
            });
        }
        if self.grasp.is_some() {
            out.push(Scenario {
                grasp: None,
                ..self.clone()
            });
        }
        out
    }

    /// One line for people.
    pub fn describe(&self) -> String {
        let names = |v: &[TrunkState]| v.iter().map(|s| s.name()).collect::<Vec<_>>().join(" → ");
        let mut t = format!(
            "seed {}: {}{} → {}",
            self.seed,
            self.initial,
            if self.calibrate {
                ", calibrated first"
            } else {
                ""
            },
            names(&self.targets)
        );
        for (f, at) in &self.faults {
            let _ = write!(t, ", {f} at {at} ms");
        }
        if self.line_noise > 0.0 {
            let _ = write!(t, ", line noise {:.2} %", self.line_noise * 100.0);
        }
        for at in &self.power_cuts {
            let _ = write!(t, ", power cut at {at} ms");
        }
        for at in &self.host_crashes {
            let _ = write!(t, ", host crash at {at} ms");
        }
        if let Some(m) = self.mistake {
            let _ = write!(t, ", operator {m:?}");
        }
        for at in &self.stops {
            let _ = write!(t, ", operator stop at {at} ms");
        }
        if let Some((i, kg)) = self.grasp {
            let _ = write!(t, ", grasps a {kg:.2} kg object after target {}", i + 1);
        }
        if self.trunk_spread > 0.0 {
            let base = TrunkSpec::pdf();
            let _ = write!(
                t,
                ", trunk drawn ±{} ({} draw(s) refused first): {}",
                self.trunk_spread,
                self.trunk_redraws,
                self.trunk.describe_against(&base)
            );
        } else if self.trunk != TrunkSpec::pdf() {
            let _ = write!(t, ", trunk {}", self.trunk.name);
        }
        t
    }
}

/// An invariant that did not hold.
#[derive(Debug, Clone, PartialEq)]
pub struct Violation {
    /// The scenario's seed.
    pub seed: u64,
    /// Virtual time, ms.
    pub t_ms: u64,
    /// Which invariant, by a stable name.
    pub invariant: &'static str,
    /// What happened.
    pub detail: String,
}

/// The invariants, checked after every simulator step.
#[derive(Debug, Default)]
pub struct Checker {
    seed: u64,
    /// Every violation so far (at most one per invariant and scenario: the first).
    pub violations: Vec<Violation>,
    fault_since: Option<u64>,
    disagree_since: Option<u64>,
    boot_check_at: Option<u64>,
    trace: Option<String>,
    last_mode: Option<Mode>,
    /// The trunk's wells last noted in the trace (each module's, `None` on a snap branch).
    last_wells: Option<[Option<usize>; 2]>,
    /// The grasp task's object has been held (from then on the device's report of the
    /// gripper says whether it still is).
    captured: bool,
    /// The object's hold at the last check, and when it was last let go (until the device
    /// reports the gripper open).
    object_held: Option<bool>,
    released_at: Option<u64>,
    held_disagree_since: Option<u64>,
    /// The host's model of the straight trunk's height per state (the calibrated trunk only:
    /// on a trunk drawn around it the model is not that trunk's, by construction).
    model_heights: Option<geometry::reach::TrunkHeights>,
    tip_disagree_since: Option<u64>,
}

impl Checker {
    fn violate(&mut self, t_ms: u64, invariant: &'static str, detail: String) {
        if self.violations.iter().any(|v| v.invariant == invariant) {
            return;
        }
        if let Some(tr) = self.trace.as_mut() {
            let _ = writeln!(tr, "{t_ms:>9} VIOLATION {invariant}: {detail}");
        }
        self.violations.push(Violation {
            seed: self.seed,
            t_ms,
            invariant,
            detail,
        });
    }

    fn note(&mut self, t_ms: u64, what: &str) {
        if let Some(tr) = self.trace.as_mut() {
            let _ = writeln!(tr, "{t_ms:>9} {what}");
        }
    }

    /// The checks of one step.
    pub fn check(&mut self, sim: &Sim) {
        let t = sim.now_ms();
        let truth = sim.safety();
        let status = sim.controller().status();
        if self.trace.is_some() {
            // The trunk's own moves, for reading a replay: each module's well as it settles.
            let wells = sim.trunk().wells();
            if self.last_wells != Some(wells) && wells.iter().all(Option::is_some) {
                self.last_wells = Some(wells);
                let [top, bottom] = wells.map(|w| w.unwrap_or(0));
                self.note(
                    t,
                    &format!(
                        "trunk: top {} bottom {} at {:.1} kPa (the device reads {:.1})",
                        crate::physics::trunk::well_name(crate::physics::Module::Top, top),
                        crate::physics::trunk::well_name(crate::physics::Module::Bottom, bottom),
                        truth.pressure_kpa,
                        sim.controller().pressure_kpa()
                    ),
                );
            }
        }
        if self.last_mode != Some(status.mode) {
            self.note(
                t,
                &format!(
                    "device mode {:?}, belief {}{}, truth {}",
                    status.mode,
                    status.state,
                    if status.state_confirmed {
                        " (confirmed)"
                    } else {
                        " (unconfirmed)"
                    },
                    truth.true_state.map_or("between", |s| s.name())
                ),
            );
            self.last_mode = Some(status.mode);
        }
        // Pressure never above the cap (plus the sensor's tolerance).
        if truth.pressure_kpa > truth.pressure_limit_kpa + PRESSURE_TOLERANCE_KPA {
            self.violate(
                t,
                "pressure-cap",
                format!(
                    "true pressure {:.2} kPa above the cap {:.1} kPa + {PRESSURE_TOLERANCE_KPA}",
                    truth.pressure_kpa, truth.pressure_limit_kpa
                ),
            );
        }
        // After any fault the actuators are safe within the bound.
        if status.faults != 0 {
            let since = *self.fault_since.get_or_insert(t);
            // What the controller commands, and the pressure: a valve stuck open cannot be
            // closed by any firmware (the pressure then must stay under the cap all the same).
            let safe = !truth.inlet_commanded_open
                && truth.servos_still
                && truth.pressure_kpa <= truth.pressure_limit_kpa + PRESSURE_TOLERANCE_KPA;
            if !safe && t - since > SAFE_WITHIN_MS {
                self.violate(
                    t,
                    "safe-after-fault",
                    format!(
                        "faults {:#06x} active since {since} ms and the actuators are not safe \
                         (inlet commanded {}, servos still {}, pressure {:.1} kPa)",
                        status.faults,
                        if truth.inlet_commanded_open {
                            "open"
                        } else {
                            "closed"
                        },
                        truth.servos_still,
                        truth.pressure_kpa
                    ),
                );
            }
        } else {
            self.fault_since = None;
        }
        // Whenever the device says confirmed, it is the truth (outside a step, once settled).
        let idle = !matches!(status.mode, Mode::Running | Mode::WaitingManual);
        let wrong = status.state_confirmed && truth.true_state != Some(status.state);
        // While a step runs, no status claims a state the trunk is not in, at any instant: a
        // step that moves the trunk reports it moving (unconfirmed).
        if !idle && wrong {
            self.violate(
                t,
                "moving-confirmed",
                format!(
                    "while a step runs the device reports {} confirmed; the trunk is {}",
                    status.state,
                    truth.true_state.map_or("between states", |s| s.name())
                ),
            );
        }
        if idle && wrong {
            let since = *self.disagree_since.get_or_insert(t);
            if t - since > SETTLE_MS {
                self.violate(
                    t,
                    "device-confirmed-truth",
                    format!(
                        "the device reports {} confirmed; the trunk is {}",
                        status.state,
                        truth.true_state.map_or("between states", |s| s.name())
                    ),
                );
            }
        } else {
            self.disagree_since = None;
        }
        self.check_task(sim, t, idle, &status);
        // After a power cut the state is true or unconfirmed (checked once the board is up).
        if self.boot_check_at.is_some_and(|at| t >= at) {
            self.boot_check_at = None;
            if wrong {
                self.violate(
                    t,
                    "power-cut-truth",
                    format!(
                        "after a power cut the device boots with {} confirmed; the trunk is {}",
                        status.state,
                        truth.true_state.map_or("between states", |s| s.name())
                    ),
                );
            }
        }
    }
}

impl Checker {
    /// A checker for `seed` that also holds the tip to the host's model
    /// ([`TIP_TOLERANCE_MM`]; what [`run`] does on the calibrated trunk).
    pub fn watching_the_tip(seed: u64) -> Self {
        Self {
            seed,
            model_heights: model_heights(),
            ..Self::default()
        }
    }

    /// The task's invariants: nothing reported held that was dropped (or dropped that is
    /// held), and no tip further from where the host's model puts it than
    /// [`TIP_TOLERANCE_MM`] for a state the device confirms at rest (vented, unloaded).
    fn check_task(&mut self, sim: &Sim, t: u64, idle: bool, status: &protocol::messages::Status) {
        if let Some(o) = sim.world().objects().iter().find(|o| o.name == TASK_OBJECT) {
            if o.held && !self.captured {
                self.captured = true;
                self.note(
                    t,
                    &format!("the gripper holds the object ({:.2} kg)", o.mass_kg),
                );
            }
            if self.object_held == Some(true) && !o.held {
                self.released_at = Some(t);
            }
            if o.held {
                self.released_at = None;
            }
            self.object_held = Some(o.held);
            // Held, the device says the gripper is closed (open, it would claim the object let
            // go).
            if o.held && !status.gripper_closed {
                let since = *self.held_disagree_since.get_or_insert(t);
                if t - since > SETTLE_MS {
                    self.violate(
                        t,
                        "held-reported",
                        "the device reports the gripper open; it holds the object".into(),
                    );
                }
            } else {
                self.held_disagree_since = None;
            }
            // Let go, the device says the gripper opened (closed all along, it would claim
            // the object still held).
            if let Some(at) = self.released_at {
                if !status.gripper_closed {
                    self.released_at = None;
                } else if t - at > SETTLE_MS {
                    self.violate(
                        t,
                        "held-reported",
                        format!(
                            "the object was let go at {at} ms; the device still reports the \
                             gripper closed (the object held)"
                        ),
                    );
                }
            }
        }
        let Some(heights) = self.model_heights else {
            return;
        };
        let truth = sim.true_tip();
        let model = heights.height_mm(status.state);
        let off = ((truth.position_mm[0]).powi(2)
            + (truth.position_mm[1]).powi(2)
            + (truth.position_mm[2] - model).powi(2))
        .sqrt();
        // The model is the trunk without air: the claim is checked where the device reads no
        // air in it (sealed air lengthens a module within its well).
        let vented = status.pressure_kpa <= AMBIENT_KPA;
        // ... and without a load: a held object compresses the trunk (0.8 kg lowers the F&F
        // tip by 6.4 mm), which the model does not know.
        let unloaded = sim.world().load_n() == 0.0;
        // ... and with slack tendons: a pull aborted under way can leave them taut (5.2 N held
        // F&P's tip 12.4 mm below the model: seed 8975), which the model does not know either.
        let slack = sim.trunk().tensions_n().iter().all(|&n| n < TENDON_SLACK_N);
        if idle
            && vented
            && unloaded
            && slack
            && status.state_confirmed
            && sim.safety().true_state == Some(status.state)
        {
            if off > TIP_TOLERANCE_MM {
                let since = *self.tip_disagree_since.get_or_insert(t);
                if t - since > SETTLE_MS {
                    self.violate(
                        t,
                        "tip-reported",
                        format!(
                            "{} confirmed: the model's tip is {model:.1} mm up the axis, the true \
                             tip ({:.1}, {:.1}, {:.1}) mm is {off:.1} mm from it",
                            status.state,
                            truth.position_mm[0],
                            truth.position_mm[1],
                            truth.position_mm[2]
                        ),
                    );
                }
            } else {
                self.tip_disagree_since = None;
            }
        } else {
            self.tip_disagree_since = None;
        }
    }
}

/// The host's model of the straight trunk's heights, for the simulator's own configuration.
pub fn model_heights() -> Option<geometry::reach::TrunkHeights> {
    let cfg = crate::sim::sim_crane_geometry();
    let m = |c: &protocol::ModuleConfig| geometry::reach::BuiltModule {
        n: u32::from(c.n),
        beta_deg: f64::from(c.beta_deg),
        edge_mm: f64::from(c.edge_mm),
        layers: u32::from(c.layers),
    };
    geometry::reach::TrunkHeights::of_modules(
        m(&cfg.top),
        m(&cfg.bottom),
        f64::from(cfg.packed_layer_mm),
    )
    .ok()
}

/// What one scenario did.
#[derive(Debug, Clone, PartialEq)]
pub struct RunReport {
    /// The scenario.
    pub scenario: Scenario,
    /// Virtual time it took, ms.
    pub virtual_ms: u64,
    /// Targets reached (confirmed and true).
    pub reached: usize,
    /// Invariants that did not hold.
    pub violations: Vec<Violation>,
    /// The trace, when asked for.
    pub trace: String,
    /// The calibration walk's outcome, when the scenario asked for one: its duration (virtual
    /// ms), or why it was refused.
    pub calibration: Option<Result<u64, String>>,
    /// Virtual time of the calibration walk's twin, ms (not in `virtual_ms`).
    pub calibration_ms: u64,
}

/// Plays `scenario`; with `trace`, records what happened.
pub fn run(scenario: &Scenario, trace: bool) -> RunReport {
    let seed = scenario.seed;
    let sim = Sim::new(SimOptions {
        initial: scenario.initial,
        seed,
        faults: Vec::new(),
        speed: f64::INFINITY,
        operator: true,
        firmware_elf: None,
        trunk: scenario.trunk.clone(),
    });
    let checker = Rc::new(RefCell::new(Checker {
        seed,
        trace: trace.then(String::new),
        model_heights: (scenario.trunk == TrunkSpec::pdf())
            .then(model_heights)
            .flatten(),
        ..Checker::default()
    }));
    let crash = Rc::new(RefCell::new(false));
    let stop = Rc::new(RefCell::new(false));
    // Power cuts, host crashes and stops so far: an attempt they did not touch is judged for
    // liveness.
    let upsets = Rc::new(RefCell::new(0_u32));
    let mut io = SimIo::new(sim);
    let (graph, calibration, calibration_ms) = if scenario.calibrate {
        let (graph, outcome, ms) = calibrate_twin(scenario, &checker);
        (graph, Some(outcome), ms)
    } else {
        (Graph::nominal(), None, 0)
    };
    io.sim.set_line_noise_rate(scenario.line_noise);
    io.sim.operator_mut().mistake = scenario.mistake;
    {
        let checker = Rc::clone(&checker);
        let crash = Rc::clone(&crash);
        let stop = Rc::clone(&stop);
        let upsets = Rc::clone(&upsets);
        let mut faults = scenario.faults.clone();
        let mut cuts = scenario.power_cuts.clone();
        let mut crashes = scenario.host_crashes.clone();
        let mut stops = scenario.stops.clone();
        io.monitor = Some(Box::new(move |sim: &mut Sim| {
            let t = sim.now_ms();
            faults.retain(|(f, at)| {
                if t >= *at {
                    sim.inject_fault(*f);
                    checker.borrow_mut().note(t, &format!("inject {f}"));
                    false
                } else {
                    true
                }
            });
            let before = cuts.len();
            cuts.retain(|at| t < *at);
            if cuts.len() < before {
                *upsets.borrow_mut() += 1;
                sim.power_cycle();
                let mut c = checker.borrow_mut();
                c.note(t, "power cut");
                c.boot_check_at = Some(t + 50);
            }
            let before = crashes.len();
            crashes.retain(|at| t < *at);
            if crashes.len() < before {
                *upsets.borrow_mut() += 1;
                *crash.borrow_mut() = true;
            }
            let before = stops.len();
            stops.retain(|at| t < *at);
            if stops.len() < before {
                *upsets.borrow_mut() += 1;
                *stop.borrow_mut() = true;
            }
            checker.borrow_mut().check(sim);
        }));
    }
    let mut reached = 0;
    let mut first_seq: u16 = 1;
    // A host restarted after a crash takes the crane over from its dead predecessor.
    let mut takeover = false;
    let mut gripping = false;
    for (index, &target) in scenario.targets.iter().enumerate() {
        let mut reached_this = false;
        for _attempt in 0..ATTEMPTS_PER_TARGET {
            first_seq = first_seq.wrapping_add(0x1111).max(1);
            let upsets_before = *upsets.borrow();
            let start_truth = io.sim.ground_truth().true_state;
            let start_ms = io.sim.now_ms();
            let mut driver = Driver::new(Host::new(Timing::standard(), first_seq), &mut io);
            let result = play_target(
                &mut driver,
                (&graph, target),
                &crash,
                &stop,
                &checker,
                takeover,
            );
            takeover = matches!(result, Played::Crashed);
            if takeover {
                driver.vanish();
            } else {
                drop(driver);
            }
            // Liveness: on the calibrated trunk, with no fault, noise or operator mistake in
            // the scenario, an attempt that starts at a named state and that no power cut,
            // host crash or stop touches reaches its target (a resumed plan after a stop
            // among them: the state it starts from is identified first).
            let clean = scenario.faults.is_empty()
                && scenario.line_noise == 0.0
                && scenario.mistake.is_none()
                && scenario.trunk == TrunkSpec::pdf()
                && start_truth.is_some()
                && *upsets.borrow() == upsets_before;
            if clean && matches!(result, Played::Failed) {
                checker.borrow_mut().violate(
                    io.sim.now_ms(),
                    "liveness",
                    format!(
                        "the run toward {target} that started at {start_ms} ms from {} with \
                         nothing upsetting it did not reach its target",
                        start_truth.map_or("between states", |s| s.name())
                    ),
                );
            }
            match result {
                Played::Reached => {
                    reached += 1;
                    reached_this = true;
                    break;
                }
                Played::Crashed | Played::Failed => {}
            }
        }
        // The task: a person places the object at the tip, the host closes the gripper on it.
        if let Some((_, kg)) = scenario.grasp.filter(|(i, _)| *i == index && reached_this) {
            let object = crate::world::Object {
                name: TASK_OBJECT.into(),
                position_mm: io.sim.true_tip().position_mm,
                mass_kg: kg,
                held: false,
            };
            if io.sim.place_object(object).is_ok() {
                checker.borrow_mut().note(
                    io.sim.now_ms(),
                    &format!("a person places a {kg:.2} kg object at the tip"),
                );
                gripping = true;
                // As `host-tool pick` does: open, then close on the object.
                for close in [false, true] {
                    takeover = grip(
                        &mut io,
                        close,
                        (&crash, &stop, &checker),
                        &mut first_seq,
                        takeover,
                    );
                }
            }
        }
        // A pause at the target, as a person would take before the next request.
        let pause = 500 + (seed.wrapping_mul(2_654_435_761) >> 7) % 8_000;
        let end = io.sim.now_ms() + pause;
        while io.sim.now_ms() < end {
            io.step();
        }
    }
    if gripping {
        // The end of the task: the gripper opens (the object falls below the tip).
        grip(
            &mut io,
            false,
            (&crash, &stop, &checker),
            &mut first_seq,
            takeover,
        );
        let end = io.sim.now_ms() + 2 * SETTLE_MS;
        while io.sim.now_ms() < end {
            io.step();
        }
    }
    io.monitor = None;
    let c = checker.borrow();
    RunReport {
        scenario: scenario.clone(),
        virtual_ms: io.sim.now_ms(),
        reached,
        violations: c.violations.clone(),
        trace: c.trace.clone().unwrap_or_default(),
        calibration,
        calibration_ms,
    }
}

/// The calibration walk of a scenario's trunk ([`Scenario::calibrate`]), on a twin of its
/// crane (the same trunk, seed and initial state, nothing injected) watched by a judge of its
/// own, whose violations are the scenario's: the scenario itself then runs exactly as drawn
/// (a refused walk changes nothing), its plans on the measured graph. A walk on the crane
/// itself would leave the trunk wherever a refused walk stopped, and the scenario's
/// comparison with its uncalibrated run would measure that, not the thresholds.
fn calibrate_twin(
    scenario: &Scenario,
    checker: &RefCell<Checker>,
) -> (Graph, Result<u64, String>, u64) {
    let twin = Sim::new(SimOptions {
        initial: scenario.initial,
        seed: scenario.seed,
        faults: Vec::new(),
        speed: f64::INFINITY,
        operator: true,
        firmware_elf: None,
        trunk: scenario.trunk.clone(),
    });
    let judge = Rc::new(RefCell::new(Checker {
        seed: scenario.seed,
        trace: checker.borrow().trace.as_ref().map(|_| String::new()),
        ..Checker::default()
    }));
    let mut io = SimIo::new(twin);
    let j = Rc::clone(&judge);
    io.monitor = Some(Box::new(move |sim: &mut Sim| j.borrow_mut().check(sim)));
    let (graph, outcome) = calibrate_first(&mut io, &judge);
    io.monitor = None;
    let judge = judge.borrow();
    let mut c = checker.borrow_mut();
    if let (Some(t), Some(twin)) = (c.trace.as_mut(), judge.trace.as_ref()) {
        for line in twin.lines() {
            let _ = writeln!(t, "  calibration {line}");
        }
    }
    for v in &judge.violations {
        c.violate(
            v.t_ms,
            v.invariant,
            format!("in the calibration walk: {}", v.detail),
        );
    }
    (graph, outcome, io.sim.now_ms())
}

/// One host session running `host::calibration::run` on `io`, the simulated person answering
/// its prompts. The graph plans then use: the measured one, or the catalogue's when the walk
/// was refused (what a person does with a trunk that will not calibrate: run it on the
/// catalogue's thresholds, which fail honestly where they do not fit).
fn calibrate_first(io: &mut SimIo, checker: &RefCell<Checker>) -> (Graph, Result<u64, String>) {
    let start = io.sim.now_ms();
    checker.borrow_mut().note(start, "calibration walk begins");
    let mut d = Driver::new(Host::new(Timing::standard(), 1), &mut *io);
    let walked = match d.connect() {
        Ok(_) => host::calibration::run(
            &mut d,
            &mut crate::pair::SimShell::default(),
            false,
            &mut host::calibration::Quiet,
        )
        .map_err(|e| e.to_string()),
        Err(e) => Err(format!("the calibration's handshake failed: {e}")),
    };
    drop(d);
    let outcome = walked.and_then(|w| {
        let c = &w.calibration;
        c.graph(c.pressure_limit_kpa)
            .map(|g| (g, w.duration_ms))
            .map_err(|e| format!("calibration refused: {e}"))
    });
    let t = io.sim.now_ms();
    match outcome {
        Ok((graph, ms)) => {
            checker
                .borrow_mut()
                .note(t, &format!("calibration walk done in {ms} ms"));
            (graph, Ok(ms))
        }
        Err(e) => {
            checker
                .borrow_mut()
                .note(t, &format!("{e}; the catalogue's thresholds"));
            (Graph::nominal(), Err(e))
        }
    }
}

enum Played {
    Reached,
    Crashed,
    Failed,
}

/// One host session toward `target`: connect, run the plan, judge the host's final claim.
fn play_target(
    d: &mut Driver<&mut SimIo>,
    (graph, target): (&Graph, TrunkState),
    crash: &RefCell<bool>,
    stop: &RefCell<bool>,
    checker: &RefCell<Checker>,
    takeover: bool,
) -> Played {
    let start = d.io.sim.now_ms();
    let mut bound_ms = RUN_BASE_BOUND_MS;
    checker.borrow_mut().note(
        start,
        &format!(
            "host connects{}, target {target}",
            if takeover { " (taking over)" } else { "" }
        ),
    );
    if takeover {
        d.host.connect_takeover(start);
    } else {
        d.host.connect(start);
    }
    let mut opened = false;
    // The person was asked the trunk's state and has not answered yet (their hands are on it).
    let mut asked = false;
    loop {
        if *crash.borrow() {
            *crash.borrow_mut() = false;
            checker.borrow_mut().note(d.io.sim.now_ms(), "host crash");
            return Played::Crashed;
        }
        if std::mem::take(&mut *stop.borrow_mut()) {
            let now = d.io.sim.now_ms();
            checker.borrow_mut().note(now, "operator stop");
            d.host.cancel("the operator stopped it", now);
        }
        if d.io.sim.now_ms() - start > bound_ms {
            checker.borrow_mut().violate(
                d.io.sim.now_ms(),
                "run-time-bound",
                format!("the run toward {target} did not end within its bound of {bound_ms} ms"),
            );
            return Played::Failed;
        }
        if let Some(truth) = d.io.sim.person_names().filter(|_| asked) {
            // The person at the crane looks at the trunk.
            asked = false;
            let now = d.io.sim.now_ms();
            checker.borrow_mut().note(
                now,
                &format!(
                    "operator identifies {}",
                    truth.map_or("nothing (between states)", |s| s.name())
                ),
            );
            d.host.declare(truth, now);
        }
        while let Some(ev) = d.host.poll_event() {
            let now = d.io.sim.now_ms();
            match ev {
                HostEvent::Session(SessionEvent::Opened(_)) if !opened => {
                    opened = true;
                    let options = RunOptions {
                        take_over_running: true,
                        ..RunOptions::default()
                    };
                    d.host.run_plan(graph.clone(), target, options, now);
                }
                HostEvent::Session(SessionEvent::HandshakeFailed(e)) => {
                    checker
                        .borrow_mut()
                        .note(now, &format!("handshake failed: {e}"));
                    return Played::Failed;
                }
                HostEvent::Run(RunEvent::IdentifyPrompt { .. }) => asked = true,
                HostEvent::Run(RunEvent::Plan { plan, .. }) => {
                    bound_ms += plan
                        .steps()
                        .iter()
                        .map(|st| u64::from(st.edge.transition.timeout_ms) + STEP_GRACE_MS)
                        .sum::<u64>();
                    // No step actuates from a false belief: the plan starts where the trunk is.
                    let truth = d.io.sim.ground_truth().true_state;
                    if truth != Some(plan.from()) {
                        checker.borrow_mut().violate(
                            now,
                            "plan-from-truth",
                            format!(
                                "a plan from {} was started; the trunk is {}",
                                plan.from(),
                                truth.map_or("between states", |s| s.name())
                            ),
                        );
                    }
                    checker
                        .borrow_mut()
                        .note(now, &format!("plan {} → {}", plan.from(), plan.target()));
                }
                HostEvent::Run(RunEvent::Finished) => {
                    let out = d
                        .host
                        .runner()
                        .map(|r| r.outcome().clone())
                        .unwrap_or_default();
                    // Let the trunk settle, then judge the host's claim.
                    let end = now + 500;
                    while d.io.sim.now_ms() < end {
                        d.io.step();
                    }
                    let truth = d.io.sim.ground_truth().true_state;
                    let t = d.io.sim.now_ms();
                    checker.borrow_mut().note(
                        t,
                        &format!(
                            "run ends: ok {}, host says {} (confirmed {}), truth {}; {}",
                            out.ok(),
                            out.final_state.map_or("nothing", |s| s.name()),
                            out.state_confirmed,
                            truth.map_or("between states", |s| s.name()),
                            out.error().unwrap_or("")
                        ),
                    );
                    // Unconfirmed, the host's candidates hold the truth (after a lost link too:
                    // a script may declare the only one).
                    if let Some(t) =
                        truth.filter(|t| !out.state_confirmed && !out.candidates.contains(*t))
                    {
                        checker.borrow_mut().violate(
                            d.io.sim.now_ms(),
                            "host-candidates-truth",
                            format!(
                                "the host reports {} unconfirmed, may be {}; the trunk is {t}",
                                out.final_state.map_or("nothing", |s| s.name()),
                                out.candidates
                                    .iter()
                                    .map(|s| s.name())
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            ),
                        );
                    }
                    if out.state_confirmed && out.final_state.is_some() && out.final_state != truth
                    {
                        checker.borrow_mut().violate(
                            t,
                            "host-confirmed-truth",
                            format!(
                                "the host reports {} confirmed at the end; the trunk is {}",
                                out.final_state.map_or("nothing", |s| s.name()),
                                truth.map_or("between states", |s| s.name())
                            ),
                        );
                    }
                    return if out.ok() {
                        Played::Reached
                    } else {
                        Played::Failed
                    };
                }
                _ => {}
            }
        }
        if d.host.session().is_closed() && !opened {
            return Played::Failed;
        }
        if d.turn().is_err() {
            return Played::Failed;
        }
    }
}

/// Opens or closes the gripper in up to [`ATTEMPTS_PER_TARGET`] host sessions (after a failed
/// one, the device's link watch is let lapse first: a session whose `Close` was lost on a
/// noisy line holds the device until then). Returns whether the last host crashed (the next
/// one takes over).
fn grip(
    io: &mut SimIo,
    close: bool,
    (crash, stop, checker): (&RefCell<bool>, &RefCell<bool>, &RefCell<Checker>),
    first_seq: &mut u16,
    mut takeover: bool,
) -> bool {
    for attempt in 0..ATTEMPTS_PER_TARGET {
        if attempt > 0 && !takeover {
            let end = io.sim.now_ms() + u64::from(protocol::DEFAULT_LINK_TIMEOUT_MS) + 500;
            while io.sim.now_ms() < end {
                io.step();
            }
        }
        *first_seq = first_seq.wrapping_add(0x1111).max(1);
        let mut driver = Driver::new(Host::new(Timing::standard(), *first_seq), &mut *io);
        let played = play_grip(&mut driver, close, crash, stop, checker, takeover);
        takeover = matches!(played, Played::Crashed);
        if takeover {
            driver.vanish();
        } else {
            drop(driver);
        }
        if matches!(played, Played::Reached) {
            break;
        }
    }
    takeover
}

/// One host session that opens (`close = false`) or closes the gripper as `host-tool grip`
/// does: a status first, and the gripper's step only when the device is idle, fault-free and
/// its state confirmed (refused otherwise, as the CLI refuses it).
fn play_grip(
    d: &mut Driver<&mut SimIo>,
    close: bool,
    crash: &RefCell<bool>,
    stop: &RefCell<bool>,
    checker: &RefCell<Checker>,
    takeover: bool,
) -> Played {
    use protocol::messages::{Primitive, RequestBody, ResponseBody, StepKind};
    /// While the step runs, a status this often (an event lost on a noisy line is not sent
    /// again; the status says when the step has ended).
    const POLL_MS: u64 = 250;
    let start = d.io.sim.now_ms();
    let (verb, done) = if close {
        ("close", "closed")
    } else {
        ("open", "open")
    };
    checker
        .borrow_mut()
        .note(start, &format!("host connects to {verb} the gripper"));
    if takeover {
        d.host.connect_takeover(start);
    } else {
        d.host.connect(start);
    }
    let mut status_id = None;
    let mut stepping = false;
    let mut next_poll = u64::MAX;
    loop {
        if *crash.borrow() {
            *crash.borrow_mut() = false;
            checker.borrow_mut().note(d.io.sim.now_ms(), "host crash");
            return Played::Crashed;
        }
        // A stop while the gripper moves ends nothing the device would not end itself: the
        // step is one primitive; the stop is noted and the step left to finish.
        if std::mem::take(&mut *stop.borrow_mut()) {
            checker
                .borrow_mut()
                .note(d.io.sim.now_ms(), "operator stop (the gripper's step)");
        }
        let now = d.io.sim.now_ms();
        if now - start > GRIP_BOUND_MS {
            checker.borrow_mut().note(
                now,
                &format!("the gripper's session ended at its bound of {GRIP_BOUND_MS} ms"),
            );
            return Played::Failed;
        }
        if stepping && status_id.is_none() && now >= next_poll {
            status_id = Some(d.host.request(RequestBody::GetStatus, now));
        }
        while let Some(ev) = d.host.poll_event() {
            let now = d.io.sim.now_ms();
            match ev {
                HostEvent::Session(SessionEvent::Opened(_)) => {
                    status_id = Some(d.host.request(RequestBody::GetStatus, now));
                }
                HostEvent::Session(SessionEvent::Reply { id, reply }) if Some(id) == status_id => {
                    status_id = None;
                    let ResponseBody::Status(st) = reply.body else {
                        checker
                            .borrow_mut()
                            .note(now, &format!("no status: {:?}", reply.body));
                        return Played::Failed;
                    };
                    let idle = !matches!(st.mode, Mode::Running | Mode::WaitingManual);
                    if stepping {
                        if !idle {
                            next_poll = now + POLL_MS;
                            continue;
                        }
                        let ok = st.gripper_closed == close;
                        checker.borrow_mut().note(
                            now,
                            &format!(
                                "the gripper's step has ended: the gripper is {}",
                                if st.gripper_closed { "closed" } else { "open" }
                            ),
                        );
                        return if ok { Played::Reached } else { Played::Failed };
                    }
                    if !(idle && st.faults == 0 && st.state_confirmed && !st.estop) {
                        checker.borrow_mut().note(
                            now,
                            &format!(
                                "the gripper's step refused: mode {:?}, faults {:#06x}, state {} \
                                 (confirmed {})",
                                st.mode, st.faults, st.state, st.state_confirmed
                            ),
                        );
                        return Played::Failed;
                    }
                    if st.gripper_closed == close {
                        checker
                            .borrow_mut()
                            .note(now, &format!("the gripper is already {done}"));
                        return Played::Reached;
                    }
                    let step = planner::task::step_within(
                        st.state,
                        StepKind::Tendon,
                        &[Primitive::Gripper { close }],
                    );
                    d.host.request(RequestBody::RunStep(step), now);
                    stepping = true;
                    next_poll = now + POLL_MS;
                }
                HostEvent::Session(SessionEvent::Device(protocol::messages::Event::StepDone {
                    ok,
                    ..
                })) if stepping => {
                    checker
                        .borrow_mut()
                        .note(now, &format!("the gripper's step ends: ok {ok}"));
                    return if ok { Played::Reached } else { Played::Failed };
                }
                HostEvent::Session(
                    SessionEvent::HandshakeFailed(_)
                    | SessionEvent::LinkLost(_)
                    | SessionEvent::Failed { .. },
                ) => {
                    checker
                        .borrow_mut()
                        .note(now, &format!("the gripper's session failed: {ev:?}"));
                    return Played::Failed;
                }
                _ => {}
            }
        }
        if d.turn().is_err() {
            checker
                .borrow_mut()
                .note(d.io.sim.now_ms(), "the gripper's session: the link failed");
            return Played::Failed;
        }
    }
}

/// The smallest scenario derived from `failing` that still violates an invariant (greedy:
/// drop one element at a time while it still fails).
pub fn shrink(failing: &Scenario) -> Scenario {
    let mut best = failing.clone();
    loop {
        let next = best
            .smaller()
            .into_iter()
            .find(|s| !run(s, false).violations.is_empty());
        match next {
            Some(s) => best = s,
            None => return best,
        }
    }
}

/// The swarm's totals.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SwarmReport {
    /// Scenarios run.
    pub runs: u64,
    /// Virtual time of all runs, ms.
    pub virtual_ms: u64,
    /// Targets asked for and reached.
    pub targets: u64,
    /// Targets reached.
    pub reached: u64,
    /// Every violation, with its seed.
    pub violations: Vec<Violation>,
    /// Calibration walks done (scenarios that asked for one).
    pub calibrations: u64,
    /// Of them, refused (their scenarios ran on the catalogue's thresholds).
    pub calibrations_refused: u64,
    /// Virtual time of the calibration walks, ms (not in `virtual_ms`).
    pub calibration_ms: u64,
    /// With [`swarm_split`]: the scenarios whose trunk's physics makes every actuated
    /// transition of the catalogue within the crane's limits ([`feasible`]), their targets and
    /// the targets they reached.
    pub feasible: Option<(u64, u64, u64)>,
}

/// Whether the physics of `trunk` makes every actuated transition of the catalogue, to the
/// catalogue's end state, within the crane's own limits (its 40 kPa pressure cap, the winches'
/// 185 mm): `discovery::discover_trunk` with `RigConfig::crane()`. A trunk that is not is one no
/// threshold can take through every state: its bottom deploys over the cap, or a fold or the
/// pack needs more tendon than the winches have, or a snap lands elsewhere.
pub fn feasible(trunk: &TrunkSpec) -> bool {
    use crate::discovery::{discover_trunk, EdgeKind, RigConfig};
    let Ok(params) = trunk.params() else {
        return false;
    };
    let g = discover_trunk(&params, RigConfig::crane());
    protocol::transitions::TRANSITIONS
        .iter()
        .filter(|t| t.kind != protocol::StepKind::Manual)
        .all(|t| {
            g.edges
                .iter()
                .any(|e| e.from == t.from && e.to == t.to && e.kind == EdgeKind::from(t.kind))
        })
}

/// Runs `runs` scenarios with seeds `seed..seed + runs` on `threads` threads.
pub fn swarm(seed: u64, runs: u64, threads: usize) -> SwarmReport {
    swarm_of(seed, runs, threads, &Scenario::generate)
}

/// [`swarm`] with scenarios made by `make` from their seeds.
pub fn swarm_of(
    seed: u64,
    runs: u64,
    threads: usize,
    make: &(dyn Fn(u64) -> Scenario + Sync),
) -> SwarmReport {
    swarm_split(seed, runs, threads, make, false)
}

/// [`swarm_of`]; with `split`, also the totals of the scenarios on [`feasible`] trunks.
pub fn swarm_split(
    seed: u64,
    runs: u64,
    threads: usize,
    make: &(dyn Fn(u64) -> Scenario + Sync),
    split: bool,
) -> SwarmReport {
    let threads = threads.max(1) as u64;
    let parts: Vec<SwarmReport> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|k| {
                scope.spawn(move || {
                    let mut r = SwarmReport {
                        feasible: split.then_some((0, 0, 0)),
                        ..SwarmReport::default()
                    };
                    let mut i = k;
                    while i < runs {
                        let s = make(seed.wrapping_add(i));
                        let rep = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                            run(&s, false)
                        }))
                        .unwrap_or_else(|_| RunReport {
                            scenario: s.clone(),
                            virtual_ms: 0,
                            reached: 0,
                            violations: vec![Violation {
                                seed: s.seed,
                                t_ms: 0,
                                invariant: "no-panic",
                                detail: "the run panicked".into(),
                            }],
                            trace: String::new(),
                            calibration: None,
                            calibration_ms: 0,
                        });
                        r.runs += 1;
                        r.virtual_ms += rep.virtual_ms;
                        r.targets += s.targets.len() as u64;
                        r.reached += rep.reached as u64;
                        r.violations.extend(rep.violations);
                        if let Some(c) = &rep.calibration {
                            r.calibrations += 1;
                            r.calibrations_refused += u64::from(c.is_err());
                        }
                        r.calibration_ms += rep.calibration_ms;
                        if let Some(f) = r.feasible.as_mut().filter(|_| feasible(&s.trunk)) {
                            f.0 += 1;
                            f.1 += s.targets.len() as u64;
                            f.2 += rep.reached as u64;
                        }
                        i += threads;
                    }
                    r
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_default())
            .collect()
    });
    let mut total = SwarmReport {
        feasible: split.then_some((0, 0, 0)),
        ..SwarmReport::default()
    };
    for p in parts {
        total.runs += p.runs;
        total.virtual_ms += p.virtual_ms;
        total.targets += p.targets;
        total.reached += p.reached;
        total.violations.extend(p.violations);
        total.calibrations += p.calibrations;
        total.calibrations_refused += p.calibrations_refused;
        total.calibration_ms += p.calibration_ms;
        if let (Some(t), Some(f)) = (total.feasible.as_mut(), p.feasible) {
            t.0 += f.0;
            t.1 += f.1;
            t.2 += f.2;
        }
    }
    total.violations.sort_by_key(|v| (v.seed, v.t_ms));
    total
}
