//! Plan execution: steps, primitives, time limits, state confirmation.

use heapless::Vec;
use protocol::{
    Event, FaultCode, PlanPhase, PlanStatus, Primitive, StateSet, Step, StepKind,
    MAX_STEP_PRIMITIVES,
};

use super::belief::{self, Belief};
use super::identify::{ProbeLog, PROBE};
use super::Controller;
use crate::store::StoredState;
use primitive::{Look, Progress, Run, RunKind, Wants};

mod primitive;

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

/// The inflate regulator's hold: the pressure kept for the rest of the step (through later
/// `Hold`, `WaitSnap`, `Manual`, `Gripper`, `Bend`), until a vent or a tendon move.
#[derive(Debug, Clone, Copy)]
struct Hold {
    kpa: f32,
    /// Inlet wanted open (the regulator's hysteresis).
    filling: bool,
}

/// Highest filtered pressure and longest commanded pull since the step's first actuation, and
/// whether the pressure readings were valid throughout (what `belief::untouched` needs).
#[derive(Debug, Clone, Copy)]
struct Peaks {
    kpa: f32,
    pull_mm: f32,
    readings_valid: bool,
}

impl Peaks {
    const START: Self = Self {
        kpa: 0.0,
        pull_mm: 0.0,
        readings_valid: true,
    };
}

/// Where the current step is.
#[derive(Debug, Clone, Copy)]
#[repr(u8)]
enum Phase {
    /// Write-ahead: the step's journal record (number `record`) is being persisted; nothing
    /// actuates before. Then the pre-release, if `pre_release`.
    Journaling { record: u32, pre_release: bool },
    /// A pneumatic step found the tendons out (or air sealed in the trunk): it lets them out
    /// (and vents) before its first primitive (a held tendon would fight the lengthening
    /// trunk).
    PreRelease,
    /// The primitives: the step's own ([`Exec::prim`]) or, after a person's confirm, the
    /// check's [`PROBE`] primitive `check` in its place (`docs/firmware.md`, "Manual steps:
    /// the check"); `run` once that primitive has begun.
    Primitive { check: Option<u8>, run: Option<Run> },
}

impl Phase {
    /// The phase a step starts in: its journal record (`None`: a step within one state needs
    /// none), then the pre-release if needed, then its first primitive.
    fn first(journal: Option<u32>, pre_release: bool) -> Self {
        match journal {
            Some(record) => Self::Journaling {
                record,
                pre_release,
            },
            None => Self::after_journal(pre_release),
        }
    }

    fn after_journal(pre_release: bool) -> Self {
        if pre_release {
            Self::PreRelease
        } else {
            Self::PRIMITIVES
        }
    }

    /// The step's primitives, the current one not begun.
    const PRIMITIVES: Self = Self::Primitive {
        check: None,
        run: None,
    };
}

/// The running plan.
#[derive(Debug, Clone)]
pub(super) struct Exec {
    pub(super) plan: protocol::Plan,
    pub(super) origin: Origin,
    pub(super) step: u8,
    pub(super) step_start_ms: u64,
    /// The step's current primitive (also while the check's probe runs in its place).
    pub(super) prim: u8,
    prim_start_ms: u64,
    phase: Phase,
    /// A primitive of this step completed on sensor evidence (its snaps) or a person's word.
    evidence: bool,
    /// A person worked on the trunk in this step (a `Manual` primitive began): only the
    /// check's probe, never the actuation's peaks, tells where it is.
    by_hand: bool,
    /// The step has a journal record (a step within one state has none).
    recorded: bool,
    peaks: Peaks,
    /// The inflate regulator's hold (`None`: the inlet stays shut).
    hold: Option<Hold>,
    /// Stalled-inflation watch over the regulator's open inlet.
    rise: RiseWatch,
    /// Every state the current step may leave the trunk in: its reach, widened by what the air
    /// sealed in the trunk when it started may do (`transitions::reach_sealed`).
    pub(super) reach: StateSet,
}

impl Exec {
    /// `plan` from its first step, now (its `reach`, `journal` record and pre-release).
    fn new(
        plan: protocol::Plan,
        origin: Origin,
        now: u64,
        reach: StateSet,
        journal: Option<u32>,
        pre_release: bool,
    ) -> Self {
        Self {
            plan,
            origin,
            step: 0,
            step_start_ms: now,
            prim: 0,
            prim_start_ms: now,
            phase: Phase::first(journal, pre_release),
            evidence: false,
            by_hand: false,
            recorded: journal.is_some(),
            peaks: Peaks::START,
            hold: None,
            rise: RiseWatch::EMPTY,
            reach,
        }
    }

    /// Goes on to step `index`, now.
    fn begin_step(
        &mut self,
        index: u8,
        now: u64,
        reach: StateSet,
        journal: Option<u32>,
        pre_release: bool,
    ) {
        self.step = index;
        self.step_start_ms = now;
        self.prim = 0;
        self.prim_start_ms = now;
        self.phase = Phase::first(journal, pre_release);
        self.evidence = false;
        self.by_hand = false;
        self.recorded = journal.is_some();
        self.peaks = Peaks::START;
        self.hold = None;
        self.rise.reset();
        self.reach = reach;
    }

    fn current(&self) -> Option<(&Step, Option<Primitive>)> {
        let step = self.plan.steps.get(self.step as usize)?;
        let prim = match self.check() {
            Some(i) => PROBE.get(i as usize),
            None => step.primitives.get(self.prim as usize),
        };
        Some((step, prim.copied()))
    }

    /// The check's probe primitive running in place of the step's own (its index in [`PROBE`]).
    fn check(&self) -> Option<u8> {
        match self.phase {
            Phase::Primitive { check, .. } => check,
            _ => None,
        }
    }

    /// `prim` is an inflation whose expected snaps were all seen: its drop is being checked
    /// (the inlet shut) to be a snap and not a leak opening.
    fn snaps_all_seen(&self, prim: Primitive) -> bool {
        matches!(prim, Primitive::Inflate { snaps, .. } if snaps > 0 && self.snaps() >= snaps)
    }

    /// The probe primitive running (its index in [`PROBE`]): the identification plan's, or a
    /// manual step's check.
    fn probe_index(&self) -> Option<u8> {
        match self.origin {
            Origin::Identify => Some(self.prim),
            _ => self.check(),
        }
    }

    /// A manual primitive waits for the person's confirm.
    pub(super) fn waiting_manual(&self) -> bool {
        matches!(
            self.run(),
            Some(Run {
                kind: RunKind::Manual { .. },
                ..
            })
        )
    }

    /// The person confirmed the manual primitive; returns whether one was waiting.
    pub(super) fn confirm_manual(&mut self) -> bool {
        match &mut self.phase {
            Phase::Primitive {
                run:
                    Some(Run {
                        kind: RunKind::Manual { confirmed },
                        ..
                    }),
                ..
            } => {
                *confirmed = true;
                true
            }
            _ => false,
        }
    }

    /// The task a manual step waits for (what the display and the status name).
    pub(super) fn waiting_task(&self) -> Option<protocol::ManualTask> {
        match self.current() {
            Some((_, Some(Primitive::Manual(t)))) if self.waiting_manual() => Some(t),
            _ => None,
        }
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
        self.safety.safe = false;
        self.enable_servos();
        self.panel.joystick.armed = false;
        self.panel.joystick.used_raw = None;
        let pre_release = self.pre_release_needed(plan.steps.first());
        let reach = self.step_reach(plan.steps.first());
        let journal = self.journal_step(plan.steps.first(), reach);
        self.exec = Some(Exec::new(plan, origin, now, reach, journal, pre_release));
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
                    .length_for_angle(i, self.act.servo_deg[i])
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
        let mut b = self.trunk.belief;
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
        let journaling = matches!(e.phase, Phase::Journaling { .. });
        if journaling
            || (e.peaks.readings_valid
                && belief::untouched(step.from, e.peaks.kpa, e.peaks.pull_mm))
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
        self.act.want_inlet = false;
        self.act.want_exhaust = false;
        let ok = phase == PlanPhase::Done;
        if e.origin == Origin::Identify {
            self.finish_identify(ok);
        }
        if !ok {
            if let Some(b) = self.interrupted_belief(&e) {
                if b == self.trunk.belief && e.recorded {
                    // Unchanged (confirmed `from`), but the record says "pending": rewrite it.
                    self.store(StoredState::confirmed(b.state()));
                }
                if !b.is_confirmed() {
                    self.watch.leak_quiet_until_ms = now + super::LEAK_SETTLE_MS;
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
        let Some((step, _)) = e.current() else {
            // Defensive: an index past the plan ends it.
            self.end_plan(PlanPhase::Done);
            return false;
        };
        if now.saturating_sub(e.step_start_ms) >= step.timeout_ms as u64 {
            self.raise(FaultCode::StepTimeout);
            return false;
        }
        if let Phase::Journaling {
            record,
            pre_release,
        } = e.phase
        {
            return self.await_journal(record, pre_release);
        }
        self.track_peaks();
        if self
            .exec
            .as_ref()
            .is_some_and(|e| matches!(e.phase, Phase::PreRelease))
        {
            return self.pre_release();
        }
        self.advance_primitive()
    }

    /// Write-ahead: the step's record must be persisted before anything moves.
    fn await_journal(&mut self, record: u32, pre_release: bool) -> bool {
        if self.journal_persisted(record) {
            if let Some(e) = self.exec.as_mut() {
                e.phase = Phase::after_journal(pre_release);
            }
            return true;
        }
        let started = self.exec.as_ref().map_or(0, |e| e.step_start_ms);
        if self.now_ms.saturating_sub(started) >= super::JOURNAL_TIMEOUT_MS {
            self.raise(FaultCode::StateStorage);
        }
        false
    }

    /// The peaks of the step's actuation so far.
    fn track_peaks(&mut self) {
        let (p, valid) = (self.pressure.filt_kpa, self.pressure_valid());
        let pull_mm = (0..3).fold(0.0f32, |m, i| {
            m.max(
                self.cfg
                    .geometry
                    .winch
                    .length_for_angle(i, self.act.servo_deg[i]),
            )
        });
        if let Some(e) = self.exec.as_mut() {
            e.peaks.kpa = e.peaks.kpa.max(p);
            e.peaks.pull_mm = e.peaks.pull_mm.max(pull_mm);
            e.peaks.readings_valid &= valid;
        }
    }

    /// The step's primitives: begins the current one, looks at it, goes on when it is done.
    fn advance_primitive(&mut self) -> bool {
        let now = self.now_ms;
        let p = self.pressure.filt_kpa;
        let Some(e) = self.exec.as_ref() else {
            return false;
        };
        let Some((_, prim)) = e.current() else {
            return false;
        };
        if let (Some(log), Some(i)) = (self.ident.probe.as_mut(), e.probe_index()) {
            log.sample(i, e.prim_start_ms, now, p);
        }
        let Some(prim) = prim else {
            self.finish_step();
            return self.exec.is_some();
        };
        if e.run().is_none() {
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
                self.primitive_done(prim, evidence);
                true
            }
        }
    }

    /// `prim` completed (on its snaps or a person's word: `evidence`): the next primitive, or
    /// after a person's confirm the check's probe.
    fn primitive_done(&mut self, prim: Primitive, evidence: bool) {
        let now = self.now_ms;
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
            let check = match (prim, e.check()) {
                (Primitive::Manual(_), None) if profiled => Some(0),
                (_, Some(i)) if (i as usize) + 1 < PROBE.len() => Some(i + 1),
                _ => None,
            };
            if check == Some(0) {
                self.ident.probe = Some(ProbeLog::default());
            } else if check.is_none() {
                e.prim = e.prim.saturating_add(1);
            }
            e.phase = Phase::Primitive { check, run: None };
            e.prim_start_ms = now;
        }
        self.act.want_inlet = false;
        self.act.want_exhaust = false;
    }

    /// Lets every tendon out (exhaust open: no vacuum) and vents a pressurised trunk before a
    /// pneumatic step; returns whether to look again at once (done).
    fn pre_release(&mut self) -> bool {
        let slack = self.angles_for([0.0; 3]);
        let Some(slack) = slack else {
            self.raise(FaultCode::ServoLimit);
            return false;
        };
        self.act.servo_target_deg = slack;
        self.act.want_inlet = false;
        let step = self
            .exec
            .as_ref()
            .and_then(|e| e.plan.steps.get(e.step as usize));
        if self.servos_at_target() && !self.vent_first(step) {
            self.act.want_exhaust = false;
            if let Some(e) = self.exec.as_mut() {
                e.phase = Phase::PRIMITIVES;
                e.prim_start_ms = self.now_ms;
            }
            return true;
        }
        self.act.want_exhaust = true;
        false
    }

    fn enter_primitive(&mut self, prim: Primitive) -> Result<(), FaultCode> {
        let now = self.now_ms;
        let cap = self.cfg.pressure_limit_kpa;
        let h = self.cfg.hysteresis_kpa;
        let p = self.pressure.filt_kpa;
        let start_deg = self.act.servo_deg;
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
            Primitive::Gripper { close } => self.act.gripper_closed = close,
            Primitive::Manual(task) => manual = Some(task),
            _ => {}
        }
        if let Some(t) = targets {
            self.act.servo_target_deg = t;
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
        e.prim_start_ms = now;
        if let Phase::Primitive { run, .. } = &mut e.phase {
            *run = Some(Run {
                snaps: 0,
                kind: RunKind::start(prim, p, start_deg),
            });
        }
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
                e.hold = Some(Hold {
                    kpa: target,
                    filling: p < target,
                });
            }
            Primitive::Vent { .. }
            | Primitive::TendonPull { .. }
            | Primitive::TendonRelease { .. } => e.hold = None,
            _ => {}
        }
        if let Some(task) = manual {
            e.by_hand = true;
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

    /// One look at the primitive under way: the inflate regulator's hold and the stalled-
    /// inflation watch, then the primitive's own check ([`Exec::look`]), then the valves.
    fn progress(&mut self, prim: Primitive) -> Progress {
        let now = self.now_ms;
        let p = self.pressure.filt_kpa;
        let h = self.cfg.hysteresis_kpa;
        let cap = self.cfg.pressure_limit_kpa;
        let at_target = self.servos_at_target();
        // The inlet command in force since the last look (after the safety overlay: the cap,
        // an invalid reading or a safety vent keep it shut whatever the regulator wants).
        let inlet_was_open = self.act.outputs.inlet_open;
        let cfg = &self.cfg;
        let Some(e) = self.exec.as_mut() else {
            return Progress::Running;
        };
        // The inflate regulator keeps holding its pressure through later primitives of the
        // step (Hold, WaitSnap, Manual, Gripper, Bend), until a vent or a tendon move.
        let mut w = Wants {
            inlet: false,
            exhaust: false,
            servo_deg: None,
        };
        if let Some(hold) = e.hold.as_mut() {
            // The cap may be lowered while the step runs.
            let target = hold.kpa.min(cap - h);
            if p >= target {
                hold.filling = false;
            } else if p < target - h {
                hold.filling = true;
            }
            w.inlet = hold.filling;
        }
        // Stalled inflation: the regulator had the inlet open, yet the pressure does not rise.
        // Not while a person works on the trunk (their hands move it).
        // Nor once an inflation's snaps came (the check after them closes the inlet).
        let snapped = e.snaps_all_seen(prim);
        let mut stall = None;
        if e.hold.is_some() && inlet_was_open && !snapped && !matches!(prim, Primitive::Manual(_)) {
            stall = e.rise.feed(now, p, cfg.rise_watch);
        } else {
            e.rise.reset();
        }
        let look = Look {
            now,
            p,
            at_target,
            elapsed: now.saturating_sub(e.prim_start_ms),
            snapped,
        };
        let result = e.look(prim, cfg, look, &mut w);
        if let Some(t) = w.servo_deg {
            self.act.servo_target_deg = t;
        }
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
            self.watch.leak_quiet_until_ms = self
                .watch
                .leak_quiet_until_ms
                .max(now + super::snap::SLOT_MS);
        }
        self.act.want_inlet = w.inlet;
        self.act.want_exhaust = w.exhaust;
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
        let next_step = self
            .exec
            .as_ref()
            .and_then(|e| e.plan.steps.get(next))
            .cloned();
        let pre_release = self.pre_release_needed(next_step.as_ref());
        let reach = self.step_reach(next_step.as_ref());
        let journal = self.journal_step(next_step.as_ref(), reach);
        if let Some(e) = self.exec.as_mut() {
            e.begin_step(next as u8, now, reach, journal, pre_release);
        }
        if let Some(ps) = self.plan_status.as_mut() {
            ps.step = next as u8;
        }
    }
}
