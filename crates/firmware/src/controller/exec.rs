//! Plan execution: steps, primitives, time limits, state confirmation.

use heapless::Vec;
use protocol::{
    Event, FaultCode, PlanPhase, PlanStatus, Primitive, StateSet, Step, StepKind,
    MAX_STEP_PRIMITIVES,
};

use super::belief::{self, Belief};
use super::identify::{ProbeLog, PROBE};
use super::snap::SnapSign;
use super::Controller;
use crate::store::StoredState;

/// Who started the running plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Origin {
    /// The host (watched for link loss).
    Host,
    /// A standalone button.
    Local,
    /// The identification probe (started by the host's `Identify`).
    Identify,
}

/// Where a confirming tendon pull (`TendonPull` with snaps) is. Under a pull the tendons pin
/// the trunk's height, so a buckling module may barely change the pressure; the volume tells
/// once the tendons are let out again with the valves closed (`docs/firmware.md`, "Tendon
/// steps").
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum PullPhase {
    /// Pulling toward the length until the expected spikes (or the length, then settling).
    Pulling,
    /// Letting the tendons out to where the pull started, both valves closed.
    Releasing,
    /// Sealed and still, the trunk settles before the pressure is compared.
    Settling,
    /// Checked: venting what the smaller volume added, back to the pressure before the pull
    /// (also when not confirmed: no air is left sealed in a trunk the step could not vouch
    /// for; letting it out changes no state).
    Venting,
}

/// The sealed-release check of a confirming tendon pull.
#[derive(Debug, Clone, Copy)]
struct PullCheck {
    phase: PullPhase,
    /// Filtered pressure when the pull started (valves closed).
    baseline_kpa: f32,
    /// Pressure lost through the relief valve during the pull (the drops while it was open),
    /// added back before the comparison: that gas left, the volume did not grow.
    relieved_kpa: f32,
    /// Pressure when the relief valve last opened (while it is open).
    relief_from_kpa: Option<f32>,
    /// Servo angles when the pull started: the sealed release returns there.
    start_deg: [f32; 3],
    /// When the current phase began to wait (at the length, or released).
    since_ms: Option<u64>,
    /// A snap came while the trunk was let out sealed: something else moved (a packed bottom
    /// unpacking under the pressure the pull left): the step is not confirmed.
    surprise: bool,
    /// The check did not confirm the fold: after the vent, the step fails unconfirmed.
    unconfirmed: bool,
}

/// What the sealed-release check asks for now.
enum CheckStep {
    Running,
    /// Stop pulling; release to the start angles.
    Release,
    /// Checked: vent back to the pressure before the pull, then end the step (confirmed or
    /// not, as [`PullCheck::unconfirmed`] says).
    Vent,
}

/// Advances the sealed-release check of a pull that expects `want` snaps (`seen` spikes so
/// far): pull until the spikes or the length (then let the trunk settle there), release to the
/// start sealed, settle, then compare the pressure with the one before the pull. The spikes
/// count, and the volume confirms that a module folded: a rise of at least `min_rise_kpa`
/// (docs/firmware.md, "Tendon steps"). A fold over a packed bottom (`packed`) is never
/// confirmed: its spike may have unpacked the bottom as well.
#[allow(clippy::too_many_arguments)]
fn pull_check(
    c: &mut PullCheck,
    seen: u8,
    want: u8,
    at_target: bool,
    now: u64,
    p: f32,
    cfg: crate::config::TendonCheckConfig,
    packed: bool,
) -> CheckStep {
    let settle = cfg.settle_ms as u64;
    match c.phase {
        PullPhase::Pulling => {
            let settled_at_length = at_target && {
                let t = *c.since_ms.get_or_insert(now);
                now.saturating_sub(t) >= settle
            };
            if seen >= want || settled_at_length {
                c.phase = PullPhase::Releasing;
                c.since_ms = None;
                return CheckStep::Release;
            }
            CheckStep::Running
        }
        PullPhase::Releasing => {
            if at_target {
                c.phase = PullPhase::Settling;
                c.since_ms = Some(now);
            }
            CheckStep::Running
        }
        PullPhase::Settling => {
            let t = *c.since_ms.get_or_insert(now);
            if now.saturating_sub(t) < settle {
                return CheckStep::Running;
            }
            // Confirmed by both: the spikes the step expects, counted under the pull (the pull
            // stops at them, so never more), and a sealed volume that shrank (a spike without
            // it was no fold). How much it shrank depends on the trunk: not compared.
            let folded = seen >= want && p - c.baseline_kpa + c.relieved_kpa >= cfg.min_rise_kpa;
            c.unconfirmed = c.surprise || packed || !folded;
            c.phase = PullPhase::Venting;
            CheckStep::Vent
        }
        PullPhase::Venting => CheckStep::Vent,
    }
}

/// The pressure of the hold after an inflation's snaps: one regulator band (`h`) under the
/// pressure the trunk snapped at (`snap_kpa`, its filtered peak, which overshoots the barrier
/// by the detection's lag), never above the cap: above a half-unpacked bottom's second barrier
/// (a cascade's is well under its first's), under the next module's barrier (well above the
/// first's: the order of every trunk the crane drives, `docs/firmware.md`).
fn repress_kpa(snap_kpa: f32, cap: f32, h: f32) -> f32 {
    (snap_kpa - h).min(cap - h).max(0.0)
}

/// Samples of the stalled-inflation watch's history: the window in `RISE_SLOTS - 1` intervals
/// (100 ms each for the default 3 s window).
const RISE_SLOTS: usize = 31;

/// The stalled-inflation watch (`docs/firmware.md`, "Safety"): the filtered pressure sampled
/// across the last window while the inflate regulator has the inlet open. Compared now against
/// a window ago (not against the start of the stall): the verdict comes a fixed time after the
/// rise stopped, whatever the noise did on the way.
#[derive(Debug, Clone, Copy)]
struct RiseWatch {
    /// A ring of samples; once full, the oldest (a window ago) is at `next`.
    kpa: [f32; RISE_SLOTS],
    next: usize,
    len: usize,
    /// When the next sample is due.
    due_ms: u64,
}

impl RiseWatch {
    const EMPTY: Self = Self {
        kpa: [0.0; RISE_SLOTS],
        next: 0,
        len: 0,
        due_ms: 0,
    };

    /// Forgets the history (the inlet closed: a new window starts when it opens again).
    fn reset(&mut self) {
        self.len = 0;
        self.next = 0;
    }

    /// One look at the pressure `p` with the inlet open since the last look; returns the
    /// diagnosis when the pressure gained less than the minimum across a whole window with the
    /// inlet open throughout: `Leak` when it stalled above the ambient band (gas comes in but
    /// goes out as fast), else `NoPressureRise` (it never left ambient: no supply, or an inlet
    /// stuck closed).
    fn feed(&mut self, now: u64, p: f32, cfg: crate::config::RiseWatchConfig) -> Option<FaultCode> {
        let slot_ms = (cfg.window_ms as u64 / (RISE_SLOTS as u64 - 1)).max(1);
        if self.len > 0 {
            if now < self.due_ms {
                return None;
            }
            if now >= self.due_ms + slot_ms {
                // The loop stalled for more than a slot: the samples would not be a window
                // apart. Start again (late rather than wrong).
                self.reset();
            }
        }
        self.due_ms = if self.len == 0 { now } else { self.due_ms } + slot_ms;
        self.kpa[self.next] = p;
        self.next = (self.next + 1) % RISE_SLOTS;
        self.len = (self.len + 1).min(RISE_SLOTS);
        if self.len < RISE_SLOTS || p - self.kpa[self.next] >= cfg.min_gain_kpa {
            return None;
        }
        Some(if p >= cfg.ambient_band_kpa {
            FaultCode::Leak
        } else {
            FaultCode::NoPressureRise
        })
    }
}

/// The running plan.
#[derive(Debug, Clone)]
pub(super) struct Exec {
    pub(super) plan: protocol::Plan,
    pub(super) origin: Origin,
    pub(super) step: u8,
    pub(super) step_start_ms: u64,
    pub(super) prim: u8,
    prim_start_ms: u64,
    prim_started: bool,
    /// Snaps of the expected sign seen during the current primitive.
    pub(super) snaps: u8,
    /// When the current primitive reached its pressure or length.
    reached_ms: Option<u64>,
    /// An inflation's snaps were all seen: when, and the pressure once the drop is over. The
    /// inlet stays shut while the drop is checked to be a step (a snap: the sealed trunk then
    /// holds its pressure) and not the start of a fall (a leak opening).
    snapped: Option<(u64, Option<f32>)>,
    /// Highest pressure of the current inflation before its snaps: what the trunk snapped at.
    snap_kpa: f32,
    /// The hold after an inflation's snaps (`docs/firmware.md`, "Pneumatic steps"): since when
    /// the pressure is back at the snap's and nothing snapped, and the snaps counted then.
    repress: Option<(Option<u64>, u8)>,
    /// A primitive of this step completed on sensor evidence (its snaps) or a person's word.
    evidence: bool,
    /// Pressure held by the inflate regulator for the rest of the step.
    hold_kpa: Option<f32>,
    /// Regulator state: inlet wanted open.
    filling: bool,
    /// Stalled-inflation watch over the regulator's open inlet.
    rise: RiseWatch,
    /// Relief state during a pull: exhaust wanted open.
    relieving: bool,
    /// The sealed-release check of the current `TendonPull` (with snaps).
    pull: Option<PullCheck>,
    /// A pneumatic step found the tendons out: it lets them out before its first primitive
    /// (a held tendon would fight the lengthening trunk).
    pre_release: bool,
    pub(super) waiting_manual: bool,
    pub(super) manual_confirmed: bool,
    /// A person worked on the trunk in this step (a `Manual` primitive began): only the
    /// check's probe, never the actuation's peaks, tells where it is.
    by_hand: bool,
    /// After a person's confirm: the check's [`PROBE`] primitive running, in place of the
    /// step's own (`docs/firmware.md`, "Manual steps: the check").
    check: Option<u8>,
    /// The step's journal record (`None`: a step within one state needs none) and whether it
    /// is persisted; nothing actuates before.
    journal: Option<u32>,
    journaled: bool,
    /// Highest filtered pressure and longest commanded pull since the step's first actuation,
    /// and whether the pressure readings were valid throughout (what `belief::untouched` needs).
    peak_kpa: f32,
    peak_pull_mm: f32,
    readings_valid: bool,
    /// Every state the current step may leave the trunk in: its reach, widened by what the air
    /// sealed in the trunk when it started may do (`transitions::reach_sealed`).
    pub(super) reach: StateSet,
}

/// What a primitive's progress check decided.
enum Progress {
    Running,
    Done { evidence: bool },
    Fail(FaultCode),
}

impl Exec {
    fn current(&self) -> Option<(&Step, Option<Primitive>)> {
        let step = self.plan.steps.get(self.step as usize)?;
        let prim = match self.check {
            Some(i) => PROBE.get(i as usize),
            None => step.primitives.get(self.prim as usize),
        };
        Some((step, prim.copied()))
    }

    /// `prim` is an inflation whose expected snaps were all seen: its drop is being checked
    /// (the inlet shut) to be a snap and not a leak opening.
    fn snaps_all_seen(&self, prim: Primitive) -> bool {
        matches!(prim, Primitive::Inflate { snaps, .. } if snaps > 0 && self.snaps >= snaps)
    }

    /// The probe primitive running (its index in [`PROBE`]): the identification plan's, or a
    /// manual step's check.
    fn probe_index(&self) -> Option<u8> {
        match self.origin {
            Origin::Identify => Some(self.prim),
            _ => self.check,
        }
    }

    /// The task a manual step waits for (what the display and the status name).
    pub(super) fn waiting_task(&self) -> Option<protocol::ManualTask> {
        match self.current() {
            Some((_, Some(Primitive::Manual(t)))) if self.waiting_manual => Some(t),
            _ => None,
        }
    }

    /// Counts a snap if the current primitive waits for one of this sign; returns whether it did.
    pub(super) fn on_snap(&mut self, sign: SnapSign) -> bool {
        let wanted = match self.current() {
            Some((_, Some(Primitive::Inflate { snaps, .. }))) => {
                snaps > 0 && sign == SnapSign::Drop
            }
            Some((_, Some(Primitive::TendonPull { snaps, .. }))) => {
                snaps > 0
                    && sign == SnapSign::Rise
                    && self.pull.is_some_and(|c| c.phase == PullPhase::Pulling)
            }
            Some((_, Some(Primitive::WaitSnap { .. }))) => true,
            _ => false,
        };
        if let Some(c) = self.pull.as_mut() {
            // A drop under the pull (the trunk lengthened) or any snap while it is let out
            // sealed: not the fold the step makes.
            if matches!(c.phase, PullPhase::Releasing | PullPhase::Settling)
                || (c.phase == PullPhase::Pulling && sign == SnapSign::Drop)
            {
                c.surprise = true;
            }
        }
        if wanted && self.prim_started {
            self.snaps = self.snaps.saturating_add(1);
        }
        wanted && self.prim_started
    }
}

impl Controller {
    /// Starts `plan` now (checks were done by the caller).
    pub(super) fn start_exec(&mut self, plan: protocol::Plan, origin: Origin) {
        let now = self.now_ms;
        let steps = plan.steps.len() as u8;
        self.plan_status = Some(PlanStatus {
            plan_id: plan.plan_id,
            step: 0,
            steps,
            phase: PlanPhase::Running,
        });
        self.safe = false;
        self.enable_servos();
        self.joystick.armed = false;
        self.joystick.used_raw = None;
        let pre_release = self.pre_release_needed(plan.steps.first());
        let reach = self.step_reach(plan.steps.first());
        let journal = self.journal_step(plan.steps.first(), reach);
        self.exec = Some(Exec {
            plan,
            origin,
            step: 0,
            step_start_ms: now,
            prim: 0,
            prim_start_ms: now,
            prim_started: false,
            snaps: 0,
            reached_ms: None,
            snapped: None,
            snap_kpa: 0.0,
            repress: None,
            evidence: false,
            hold_kpa: None,
            filling: false,
            rise: RiseWatch::EMPTY,
            relieving: false,
            pull: None,
            pre_release,
            waiting_manual: false,
            manual_confirmed: false,
            by_hand: false,
            check: None,
            journal,
            journaled: journal.is_none(),
            peak_kpa: 0.0,
            peak_pull_mm: 0.0,
            readings_valid: true,
            reach,
        });
        self.advance_exec();
        self.update_outputs();
    }

    /// A standalone button's step: the nominal transition, as a one-step plan with id 0.
    pub(super) fn start_local_step(&mut self, t: &protocol::transitions::Transition) {
        let mut steps = Vec::new();
        let _ = steps.push(t.step());
        self.start_exec(protocol::Plan { plan_id: 0, steps }, Origin::Local);
    }

    /// Whether `step` must let the tendons out first: a pneumatic step while any tendon is
    /// shortened (the joystick or a `Bend` took up the slack; a held tendon would fight the
    /// lengthening trunk, and the snap would not come).
    fn pre_release_needed(&self, step: Option<&Step>) -> bool {
        step.is_some_and(|s| s.kind == StepKind::Pneumatic)
            && ((0..3).any(|i| {
                self.cfg
                    .geometry
                    .winch
                    .length_for_angle(i, self.servo_deg[i])
                    > 0.5
            }) || self.vent_first(step))
    }

    /// A pneumatic transition starts from the air: its snaps are counted on a ramp from
    /// ambient, never on a trunk left pressurised near a barrier (by a failed step or another
    /// host's plan), whose next snap could come before the detector has a history.
    fn vent_first(&self, step: Option<&Step>) -> bool {
        step.is_some_and(|s| s.kind == StepKind::Pneumatic && s.from != s.to)
            && self.pressure.filt_kpa > self.cfg.vent_tolerance_kpa
    }

    /// Starts the identification probe.
    pub(super) fn start_identify(&mut self) {
        self.ident.probe = Some(super::identify::ProbeLog::default());
        let plan = super::identify::probe_plan(self.state());
        self.start_exec(plan, Origin::Identify);
    }

    /// The probe ended: narrow the belief by its verdict; ask the operator where it cannot
    /// decide (not after an abort or a fault: the host or the person decides what next).
    fn finish_identify(&mut self, completed: bool) {
        let Some(log) = self.ident.probe.take() else {
            return;
        };
        self.ident.last = Some(log);
        if !completed {
            return;
        }
        let mut b = self.belief;
        if let Some(profile) = self.cfg.probe_profile {
            b.narrow(log.verdict(b.candidates(), &profile));
        }
        self.set_belief(b);
        if !b.is_confirmed() {
            self.ask_operator();
        }
    }

    /// The states `step` may leave the trunk in, starting now (empty for none).
    fn step_reach(&self, step: Option<&Step>) -> StateSet {
        step.map_or(StateSet::EMPTY, |s| {
            protocol::transitions::reach_sealed(s, self.pressure.filt_kpa)
        })
    }

    /// Journals `step` (pending `from → to` with `reach`, the states it may end in) ahead of its
    /// first actuation; returns the record's number, or `None` for a step within one state.
    fn journal_step(&mut self, step: Option<&Step>, reach: StateSet) -> Option<u32> {
        let step = step.filter(|s| s.from != s.to)?;
        Some(self.store(StoredState {
            state: step.from,
            confirmed: false,
            candidates: reach,
            pending: Some(protocol::Transition {
                from: step.from,
                to: step.to,
            }),
        }))
    }

    /// What is known after `e`'s current step stopped short of its end.
    fn interrupted_belief(&self, e: &Exec) -> Option<Belief> {
        let step = e.plan.steps.get(e.step as usize)?;
        if step.from == step.to {
            return None;
        }
        let pending = Some(protocol::Transition {
            from: step.from,
            to: step.to,
        });
        if e.by_hand {
            // A person's hands leave no trace in the actuation: what the check's probe
            // measured (if it ran) narrows the step's reach, nothing else.
            let mut b = Belief::unconfirmed(step.from, e.reach, pending);
            if let (Some(log), Some(profile)) = (self.ident.probe, self.cfg.probe_profile) {
                b.narrow(log.verdict(b.candidates(), &profile));
            }
            return Some(b);
        }
        // Unpacking passes the half-packed well (one layer of two): its drop may have been the
        // first layer's, the second's still to come when the step stopped.
        let half_way = step.from.bottom == geometry::BottomState::Packed
            && step.to.bottom != geometry::BottomState::Packed;
        if e.evidence && !half_way {
            // Already confirmed (its snaps or the sealed release) before a later primitive of
            // it failed: the trunk is there.
            return Some(Belief::confirmed(step.to));
        }
        if !e.journaled
            || (e.readings_valid && belief::untouched(step.from, e.peak_kpa, e.peak_pull_mm))
        {
            // Nothing moved, or nothing came near a snap: still where it started.
            return Some(Belief::confirmed(step.from));
        }
        // An inflation whose snaps all came, stopped while the check that its drop was a snap
        // ran: most likely there, not certain.
        let snapped = step
            .primitives
            .get(e.prim as usize)
            .is_some_and(|p| e.snaps_all_seen(*p));
        let guess = if snapped { step.to } else { step.from };
        Some(Belief::unconfirmed(guess, e.reach, pending))
    }

    /// Ends the running plan (if any) with `phase`, reporting the step and the plan.
    pub(super) fn end_plan(&mut self, phase: PlanPhase) {
        let Some(e) = self.exec.take() else {
            return;
        };
        let now = self.now_ms;
        self.want_inlet = false;
        self.want_exhaust = false;
        let ok = phase == PlanPhase::Done;
        if e.origin == Origin::Identify {
            self.finish_identify(ok);
        }
        if !ok {
            if let Some(b) = self.interrupted_belief(&e) {
                if b == self.belief && e.journal.is_some() {
                    // Unchanged (confirmed `from`), but the record says "pending": rewrite it.
                    self.store(StoredState::confirmed(b.state()));
                }
                if !b.is_confirmed() {
                    self.leak_quiet_until_ms = now + super::LEAK_SETTLE_MS;
                }
                self.set_belief(b);
            }
        }
        // A manual step's check ends with its plan.
        self.ident.last = self.ident.probe.take().or(self.ident.last);
        if !ok {
            self.emit(Event::StepDone {
                plan_id: e.plan.plan_id,
                step: e.step,
                ok: false,
                state: self.state(),
                duration_ms: now.saturating_sub(e.step_start_ms) as u32,
            });
        }
        self.emit(Event::PlanDone {
            plan_id: e.plan.plan_id,
            ok,
            state: self.state(),
        });
        self.plan_status = Some(PlanStatus {
            plan_id: e.plan.plan_id,
            step: e.step,
            steps: e.plan.steps.len() as u8,
            phase,
        });
    }

    /// Runs the plan as far as it can go now.
    pub(super) fn advance_exec(&mut self) {
        // Each pass finishes at most one primitive or one step: bounded by the plan's size.
        for _ in 0..(protocol::MAX_PLAN_STEPS * (MAX_STEP_PRIMITIVES + 2)) {
            if !self.advance_once() {
                break;
            }
        }
        self.update_outputs();
    }

    /// One decision; returns whether to look again at once.
    fn advance_once(&mut self) -> bool {
        let now = self.now_ms;
        let Some(e) = self.exec.as_ref() else {
            return false;
        };
        let Some((step, prim)) = e.current() else {
            // Defensive: an index past the plan ends it.
            self.end_plan(PlanPhase::Done);
            return false;
        };
        if now.saturating_sub(e.step_start_ms) >= step.timeout_ms as u64 {
            self.raise(FaultCode::StepTimeout);
            return false;
        }
        if !e.journaled {
            // Write-ahead: the step's record must be persisted before anything moves.
            let persisted = e.journal.is_some_and(|n| self.journal_persisted(n));
            if persisted {
                if let Some(e) = self.exec.as_mut() {
                    e.journaled = true;
                }
                return true;
            }
            if now.saturating_sub(e.step_start_ms) >= super::JOURNAL_TIMEOUT_MS {
                self.raise(FaultCode::StateStorage);
            }
            return false;
        }
        let (p, valid) = (self.pressure.filt_kpa, self.pressure_valid());
        let pull_mm = (0..3).fold(0.0f32, |m, i| {
            m.max(
                self.cfg
                    .geometry
                    .winch
                    .length_for_angle(i, self.servo_deg[i]),
            )
        });
        if let Some(e) = self.exec.as_mut() {
            e.peak_kpa = e.peak_kpa.max(p);
            e.peak_pull_mm = e.peak_pull_mm.max(pull_mm);
            e.readings_valid &= valid;
        }
        let Some(e) = self.exec.as_ref() else {
            return false;
        };
        if let (Some(log), Some(i), false) =
            (self.ident.probe.as_mut(), e.probe_index(), e.pre_release)
        {
            log.sample(i, e.prim_start_ms, now, p);
        }
        if e.pre_release {
            return self.pre_release();
        }
        let Some(prim) = prim else {
            self.finish_step();
            return self.exec.is_some();
        };
        if !e.prim_started {
            if let Err(code) = self.enter_primitive(prim) {
                self.raise(code);
                return false;
            }
        }
        match self.progress(prim) {
            Progress::Running => false,
            Progress::Fail(code) => {
                self.raise(code);
                false
            }
            Progress::Done { evidence } => {
                let p = self.pressure.filt_kpa;
                let profiled = self.cfg.probe_profile.is_some();
                let at = self.exec.as_ref().and_then(Exec::probe_index);
                if let (Some(log), Some(i)) = (self.ident.probe.as_mut(), at) {
                    log.primitive_done(i, now, p);
                }
                if let Some(e) = self.exec.as_mut() {
                    e.evidence |= evidence;
                    // A person's confirm is checked by the probe before the step goes on (with a
                    // profile of this trunk: without one the probe is no evidence).
                    e.check = match (prim, e.check) {
                        (Primitive::Manual(_), None) if profiled => Some(0),
                        (_, Some(i)) if (i as usize) + 1 < PROBE.len() => Some(i + 1),
                        _ => None,
                    };
                    if e.check == Some(0) {
                        self.ident.probe = Some(ProbeLog::default());
                    } else if e.check.is_none() {
                        e.prim = e.prim.saturating_add(1);
                    }
                    e.prim_started = false;
                    e.snaps = 0;
                    e.reached_ms = None;
                    e.waiting_manual = false;
                    e.manual_confirmed = false;
                    e.relieving = false;
                    e.prim_start_ms = now;
                }
                self.want_inlet = false;
                self.want_exhaust = false;
                true
            }
        }
    }

    /// Lets every tendon out (exhaust open: no vacuum) and vents a pressurised trunk before a
    /// pneumatic step; returns whether to look again at once (done).
    fn pre_release(&mut self) -> bool {
        let slack = self.angles_for([0.0; 3]);
        let Some(slack) = slack else {
            self.raise(FaultCode::ServoLimit);
            return false;
        };
        self.servo_target_deg = slack;
        self.want_inlet = false;
        let step = self
            .exec
            .as_ref()
            .and_then(|e| e.plan.steps.get(e.step as usize));
        if self.servos_at_target() && !self.vent_first(step) {
            self.want_exhaust = false;
            if let Some(e) = self.exec.as_mut() {
                e.pre_release = false;
                e.prim_start_ms = self.now_ms;
            }
            return true;
        }
        self.want_exhaust = true;
        false
    }

    fn enter_primitive(&mut self, prim: Primitive) -> Result<(), FaultCode> {
        let now = self.now_ms;
        let cap = self.cfg.pressure_limit_kpa;
        let h = self.cfg.hysteresis_kpa;
        let p = self.pressure.filt_kpa;
        let start_deg = self.servo_deg;
        let mut targets = None;
        let mut manual = None;
        match prim {
            Primitive::TendonPull { length_mm, .. } | Primitive::TendonRelease { length_mm } => {
                targets = Some(
                    self.angles_for([length_mm; 3])
                        .ok_or(FaultCode::ServoLimit)?,
                );
            }
            Primitive::Bend {
                direction_deg,
                angle_deg,
            } => {
                let l = self
                    .bend_lengths(direction_deg, angle_deg.to_radians())
                    .ok_or(FaultCode::ServoLimit)?;
                targets = Some(self.angles_for(l).ok_or(FaultCode::ServoLimit)?);
            }
            Primitive::Gripper { close } => self.gripper_closed = close,
            Primitive::Manual(task) => manual = Some(task),
            _ => {}
        }
        if let Some(t) = targets {
            self.servo_target_deg = t;
        }
        if matches!(
            prim,
            Primitive::Inflate { snaps: 1.., .. } | Primitive::TendonPull { snaps: 1.., .. }
        ) {
            // Only what this primitive makes counts: a step the detector's history still holds
            // (a snap just before, under another plan or none) is not this one's snap.
            self.snap.reset();
        }
        let Some(e) = self.exec.as_mut() else {
            return Ok(());
        };
        e.prim_started = true;
        e.prim_start_ms = now;
        e.snaps = 0;
        e.reached_ms = None;
        e.snapped = None;
        e.snap_kpa = 0.0;
        e.repress = None;
        e.pull = match prim {
            Primitive::TendonPull { snaps, .. } if snaps > 0 => Some(PullCheck {
                phase: PullPhase::Pulling,
                baseline_kpa: p,
                relieved_kpa: 0.0,
                relief_from_kpa: None,
                start_deg,
                since_ms: None,
                surprise: false,
                unconfirmed: false,
            }),
            _ => None,
        };
        match prim {
            Primitive::Inflate {
                pressure_kpa,
                snaps,
            } => {
                // An inflation that waits for snaps fills until it sees them, up to the cap: where
                // a trunk snaps is its own (a stiffer one snaps above the plan's nominal
                // pressure), and the inlet closes at the snap. Never above the cap (which may
                // have been lowered since the upload).
                let target = if snaps > 0 { cap } else { pressure_kpa };
                let target = target.min(cap - h).max(0.0);
                e.hold_kpa = Some(target);
                e.filling = p < target;
            }
            Primitive::Vent { .. }
            | Primitive::TendonPull { .. }
            | Primitive::TendonRelease { .. } => e.hold_kpa = None,
            _ => {}
        }
        if let Some(task) = manual {
            e.by_hand = true;
            e.waiting_manual = true;
            e.manual_confirmed = false;
            let (plan_id, step) = (e.plan.plan_id, e.step);
            if let Some(ps) = self.plan_status.as_mut() {
                ps.phase = PlanPhase::WaitingManual;
            }
            self.emit(Event::ManualRequired {
                plan_id,
                step,
                task,
            });
        }
        Ok(())
    }

    fn progress(&mut self, prim: Primitive) -> Progress {
        let now = self.now_ms;
        let p = self.pressure.filt_kpa;
        let h = self.cfg.hysteresis_kpa;
        let cap = self.cfg.pressure_limit_kpa;
        let settle = self.cfg.snap.settle_ms as u64;
        let snap_cfg = self.cfg.snap;
        let at_target = self.servos_at_target();
        let relief = self.cfg.pull_relief_kpa;
        let vent_tol = self.cfg.vent_tolerance_kpa;
        let gripper_ms = self.cfg.gripper_settle_ms as u64;
        let check = self.cfg.tendon_check;
        let rise_cfg = self.cfg.rise_watch;
        // The inlet command in force since the last look (after the safety overlay: the cap,
        // an invalid reading or a safety vent keep it shut whatever the regulator wants).
        let inlet_was_open = self.outputs.inlet_open;
        let Some(e) = self.exec.as_mut() else {
            return Progress::Running;
        };
        // The inflate regulator keeps holding its pressure through later primitives of the
        // step (Hold, WaitSnap, Manual, Gripper, Bend), until a vent or a tendon move.
        let mut inlet = false;
        let mut exhaust = false;
        if let Some(target) = e.hold_kpa {
            // The cap may be lowered while the step runs.
            let target = target.min(cap - h);
            if p >= target {
                e.filling = false;
            } else if p < target - h {
                e.filling = true;
            }
            inlet = e.filling;
        }
        // Stalled inflation: the regulator had the inlet open, yet the pressure does not rise.
        // Not while a person works on the trunk (their hands move it).
        // Nor once an inflation's snaps came (the check after them closes the inlet).
        let snapped = e.snaps_all_seen(prim);
        let mut stall = None;
        if e.hold_kpa.is_some()
            && inlet_was_open
            && !snapped
            && !matches!(prim, Primitive::Manual(_))
        {
            stall = e.rise.feed(now, p, rise_cfg);
        } else {
            e.rise.reset();
        }
        let elapsed = now.saturating_sub(e.prim_start_ms);
        let reached = |e: &mut Exec, cond: bool| {
            if cond && e.reached_ms.is_none() {
                e.reached_ms = Some(now);
            }
            e.reached_ms
        };
        let result = match prim {
            Primitive::Inflate {
                pressure_kpa,
                snaps,
            } => {
                let target = e.hold_kpa.unwrap_or(pressure_kpa).min(cap - h);
                let r = reached(e, p >= target);
                if !snapped {
                    e.snap_kpa = e.snap_kpa.max(p);
                }
                // Unpacking may stop with one layer of two unpacked (the first layer's drop took
                // the pressure under the second's barrier): the hold at the snap's pressure then
                // unpacks the second, one snap more, and only there.
                let unpacking = e.plan.steps.get(e.step as usize).is_some_and(|st| {
                    st.from.bottom == geometry::BottomState::Packed
                        && st.to.bottom != geometry::BottomState::Packed
                });
                let allowed = snaps.saturating_add(unpacking as u8);
                if snapped && e.snaps > allowed {
                    // A snap more than the step can make: the trunk went on past its target.
                    Progress::Fail(FaultCode::TransitionNotConfirmed)
                } else if let (true, Some((since, seen))) = (snapped, e.repress) {
                    // The hold: back at the pressure the trunk snapped at (the regulator above
                    // fills to it). A trunk in the step's target holds there (its next barrier
                    // is higher: the order every trunk the crane drives has); one left between
                    // wells goes on, and shows it by a snap.
                    let quiet = 2 * snap_cfg.refractory_ms as u64;
                    if e.snaps != seen {
                        e.repress = Some((None, e.snaps));
                        Progress::Running
                    } else if let Some(t) = since {
                        if now.saturating_sub(t) >= quiet {
                            Progress::Done { evidence: true }
                        } else {
                            Progress::Running
                        }
                    } else {
                        if p >= repress_kpa(e.snap_kpa, cap, h) - h {
                            e.repress = Some((Some(now), seen));
                        }
                        Progress::Running
                    }
                } else if snapped {
                    // A snap's drop is a step: once it is over, the sealed trunk holds its
                    // pressure. A leak opening drops it as fast at first, then goes on
                    // falling: that drop is no evidence.
                    inlet = false;
                    e.filling = false;
                    let quiet = snap_cfg.refractory_ms as u64;
                    let (t, after) = e.snapped.get_or_insert((now, None));
                    let elapsed = now.saturating_sub(*t);
                    match *after {
                        None if elapsed >= quiet => {
                            *after = Some(p);
                            Progress::Running
                        }
                        Some(p1) if p < p1 - snap_cfg.threshold_kpa => {
                            Progress::Fail(FaultCode::Leak)
                        }
                        Some(_) if elapsed >= 2 * quiet => {
                            // The drop was a snap: now the hold at the snap's pressure.
                            e.repress = Some((None, e.snaps));
                            e.hold_kpa = Some(repress_kpa(e.snap_kpa, cap, h));
                            e.filling = true;
                            Progress::Running
                        }
                        _ => Progress::Running,
                    }
                } else if let Some(t) = r {
                    if snaps == 0 {
                        Progress::Done { evidence: false }
                    } else if now.saturating_sub(t) >= settle {
                        Progress::Fail(FaultCode::TransitionNotConfirmed)
                    } else {
                        Progress::Running
                    }
                } else {
                    Progress::Running
                }
            }
            Primitive::Vent { pressure_kpa } => {
                inlet = false;
                if p <= pressure_kpa + vent_tol {
                    Progress::Done { evidence: false }
                } else {
                    exhaust = true;
                    Progress::Running
                }
            }
            Primitive::TendonPull { snaps, .. } => {
                inlet = false;
                match e.pull {
                    None
                    | Some(PullCheck {
                        phase: PullPhase::Pulling,
                        ..
                    }) => {
                        // The sealed trunk is compressed: the exhaust relieves above the
                        // relief pressure (the check below allows for the gas it lets out).
                        if p > relief {
                            e.relieving = true;
                        } else if p < relief - h {
                            e.relieving = false;
                        }
                        exhaust = e.relieving;
                    }
                    Some(_) => e.relieving = false,
                }
                if let Some(c) = e.pull.as_mut() {
                    // Account for the gas the relief lets out (measured as the drop while open;
                    // the pull's own compression meanwhile makes it an underestimate, which errs
                    // toward not confirming).
                    match (e.relieving, c.relief_from_kpa) {
                        (true, None) => c.relief_from_kpa = Some(p),
                        (false, Some(from)) => {
                            c.relieved_kpa += (from - p).max(0.0);
                            c.relief_from_kpa = None;
                        }
                        _ => {}
                    }
                }
                match e.pull.as_mut() {
                    // A positioning pull: done at the length.
                    None => {
                        if at_target {
                            Progress::Done { evidence: false }
                        } else {
                            Progress::Running
                        }
                    }
                    Some(c) => match pull_check(c, e.snaps, snaps, at_target, now, p, check, {
                        // A fold over a packed bottom: its sealed spike may unpack the bottom
                        // (F&F), which the pressure does not tell from the fold alone (F&P).
                        e.plan
                            .steps
                            .get(e.step as usize)
                            .is_some_and(|st| st.from.bottom == geometry::BottomState::Packed)
                    }) {
                        CheckStep::Running => Progress::Running,
                        CheckStep::Release => {
                            // Stop pulling (at the spikes or the length) and go back to where
                            // the pull started, sealed.
                            self.servo_target_deg = c.start_deg;
                            Progress::Running
                        }
                        CheckStep::Vent => {
                            // Back to the pressure before the pull; a baseline within the
                            // vent tolerance of ambient counts as ambient (no creep from step
                            // to step).
                            let to = if c.baseline_kpa < vent_tol {
                                0.0
                            } else {
                                c.baseline_kpa
                            };
                            if p > to + vent_tol {
                                exhaust = true;
                                Progress::Running
                            } else if c.unconfirmed {
                                Progress::Fail(FaultCode::TransitionNotConfirmed)
                            } else {
                                Progress::Done { evidence: true }
                            }
                        }
                    },
                }
            }
            Primitive::TendonRelease { .. } => {
                // Let air in as the trunk lengthens (no vacuum pulling it back).
                inlet = false;
                exhaust = true;
                if at_target {
                    Progress::Done { evidence: false }
                } else {
                    Progress::Running
                }
            }
            Primitive::Hold { duration_ms } => {
                if elapsed >= duration_ms as u64 {
                    Progress::Done { evidence: false }
                } else {
                    Progress::Running
                }
            }
            Primitive::WaitSnap { timeout_ms } => {
                if e.snaps >= 1 {
                    Progress::Done { evidence: true }
                } else if elapsed >= timeout_ms as u64 {
                    Progress::Fail(FaultCode::TransitionNotConfirmed)
                } else {
                    Progress::Running
                }
            }
            Primitive::Manual(_) => {
                // A person folds a trunk open to the air (unless the step holds a pressure on
                // purpose): a sealed one, left pressurised by a failed step, would be squeezed
                // over the cap by their hands.
                exhaust = e.hold_kpa.is_none();
                if e.manual_confirmed {
                    // The person's word alone is no evidence: the check follows.
                    Progress::Done { evidence: false }
                } else {
                    Progress::Running
                }
            }
            Primitive::Gripper { .. } => {
                if elapsed >= gripper_ms {
                    Progress::Done { evidence: false }
                } else {
                    Progress::Running
                }
            }
            Primitive::Bend { .. } => {
                if at_target {
                    Progress::Done { evidence: false }
                } else {
                    Progress::Running
                }
            }
        };
        // A primitive that completed (or failed by itself) in this pass keeps its verdict.
        let result = match (result, stall) {
            (Progress::Running, Some(code)) => Progress::Fail(code),
            (r, _) => r,
        };
        if let Some(ps) = self.plan_status.as_mut() {
            if matches!(prim, Primitive::Manual(_)) && matches!(result, Progress::Running) {
                ps.phase = PlanPhase::WaitingManual;
            } else {
                ps.phase = PlanPhase::Running;
            }
        }
        if snapped {
            // The check after the snaps watches the sealed fall itself (the drop's tail is no
            // leak).
            self.leak_quiet_until_ms = self.leak_quiet_until_ms.max(now + super::snap::SLOT_MS);
        }
        self.want_inlet = inlet;
        self.want_exhaust = exhaust;
        result
    }

    /// All primitives of the current step are done: update the state, report, go on.
    fn finish_step(&mut self) {
        let now = self.now_ms;
        let Some(e) = self.exec.as_ref() else {
            return;
        };
        let Some(step) = e.plan.steps.get(e.step as usize) else {
            return;
        };
        let (from, to) = (step.from, step.to);
        let reach = e.reach;
        let (plan_id, idx, evidence) = (e.plan.plan_id, e.step, e.evidence);
        let duration_ms = now.saturating_sub(e.step_start_ms) as u32;
        let n_steps = e.plan.steps.len();
        if from != to && e.by_hand {
            if self.interrupted_belief(e) != Some(Belief::confirmed(to)) {
                // The check did not find the trunk where the person said: what it found (or
                // the candidates) stands, and the plan stops here.
                self.raise(FaultCode::TransitionNotConfirmed);
                return;
            }
            self.ident.last = self.ident.probe.take();
            self.confirm_state(to);
        } else if from != to {
            // Confirmed when a primitive completed on its snaps or a person's confirmation;
            // a step with neither is assumed, not confirmed: its target is the guess.
            if evidence {
                self.confirm_state(to);
            } else {
                self.set_belief(Belief::unconfirmed(
                    to,
                    reach,
                    Some(protocol::Transition { from, to }),
                ));
            }
        }
        self.emit(Event::StepDone {
            plan_id,
            step: idx,
            ok: true,
            state: self.state(),
            duration_ms,
        });
        let next = idx as usize + 1;
        if next >= n_steps {
            self.end_plan(PlanPhase::Done);
            return;
        }
        let next_from = self
            .exec
            .as_ref()
            .and_then(|e| e.plan.steps.get(next))
            .map(|s| s.from);
        let probing = self
            .exec
            .as_ref()
            .is_some_and(|e| e.origin == Origin::Identify);
        if !probing && (next_from != Some(self.state()) || !self.confirmed()) {
            // The failure report names the step that cannot start.
            if let Some(e) = self.exec.as_mut() {
                e.step = next as u8;
                e.step_start_ms = now;
            }
            self.raise(FaultCode::TransitionNotConfirmed);
            return;
        }
        if let Some(e) = self.exec.as_mut() {
            e.step = next as u8;
            e.step_start_ms = now;
            e.prim = 0;
            e.prim_start_ms = now;
            e.prim_started = false;
            e.snaps = 0;
            e.reached_ms = None;
            e.evidence = false;
            e.hold_kpa = None;
            e.filling = false;
            e.rise.reset();
            e.relieving = false;
            e.pull = None;
            e.by_hand = false;
        }
        let pre_release =
            self.pre_release_needed(self.exec.as_ref().and_then(|e| e.plan.steps.get(next)));
        let next_step = self
            .exec
            .as_ref()
            .and_then(|e| e.plan.steps.get(next))
            .cloned();
        let reach = self.step_reach(next_step.as_ref());
        let journal = self.journal_step(next_step.as_ref(), reach);
        if let Some(e) = self.exec.as_mut() {
            e.reach = reach;
            e.pre_release = pre_release;
            e.journal = journal;
            e.journaled = journal.is_none();
            e.peak_kpa = 0.0;
            e.peak_pull_mm = 0.0;
            e.readings_valid = true;
        }
        if let Some(ps) = self.plan_status.as_mut() {
            ps.step = next as u8;
        }
    }
}
