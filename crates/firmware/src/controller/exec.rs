//! Plan execution: steps, primitives, time limits, state confirmation.

use heapless::Vec;
use protocol::{
    Event, FaultCode, PlanPhase, PlanStatus, Primitive, Step, StepKind, MAX_STEP_PRIMITIVES,
};

use super::snap::SnapSign;
use super::Controller;

/// Who started the running plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Origin {
    /// The host (watched for link loss).
    Host,
    /// A standalone button.
    Local,
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
    /// A primitive of this step completed on sensor evidence (its snaps) or a person's word.
    evidence: bool,
    /// Pressure held by the inflate regulator for the rest of the step.
    hold_kpa: Option<f32>,
    /// Regulator state: inlet wanted open.
    filling: bool,
    /// Relief state during a pull: exhaust wanted open.
    relieving: bool,
    pub(super) waiting_manual: bool,
    pub(super) manual_confirmed: bool,
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
        Some((step, step.primitives.get(self.prim as usize).copied()))
    }

    /// Counts a snap if the current primitive waits for one of this sign; returns whether it did.
    pub(super) fn on_snap(&mut self, sign: SnapSign) -> bool {
        let wanted = match self.current() {
            Some((_, Some(Primitive::Inflate { snaps, .. }))) => {
                snaps > 0 && sign == SnapSign::Drop
            }
            Some((_, Some(Primitive::TendonPull { snaps, .. }))) => {
                snaps > 0 && sign == SnapSign::Rise
            }
            Some((_, Some(Primitive::WaitSnap { .. }))) => true,
            _ => false,
        };
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
        self.joystick_armed = false;
        self.joystick_used_raw = None;
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
            evidence: false,
            hold_kpa: None,
            filling: false,
            relieving: false,
            waiting_manual: false,
            manual_confirmed: false,
        });
        self.advance_exec();
        self.update_outputs();
    }

    /// A standalone button's step: the nominal transition, as a one-step plan with id 0. A
    /// pneumatic step first lets the tendons out (a bent trunk must not fight the pressure).
    pub(super) fn start_local_step(&mut self, t: &protocol::transitions::Transition) {
        let mut step = t.step();
        let bent = (0..3).any(|i| self.cfg.servo.length_for_angle(i, self.servo_deg[i]) > 0.5);
        if t.kind == StepKind::Pneumatic && bent && step.primitives.len() < MAX_STEP_PRIMITIVES {
            let mut prims: Vec<Primitive, MAX_STEP_PRIMITIVES> = Vec::new();
            let _ = prims.push(Primitive::TendonRelease { length_mm: 0.0 });
            for p in &step.primitives {
                let _ = prims.push(*p);
            }
            step.primitives = prims;
        }
        let mut steps = Vec::new();
        let _ = steps.push(step);
        self.start_exec(protocol::Plan { plan_id: 0, steps }, Origin::Local);
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
        if !ok {
            self.emit(Event::StepDone {
                plan_id: e.plan.plan_id,
                step: e.step,
                ok: false,
                state: self.state,
                duration_ms: now.saturating_sub(e.step_start_ms) as u32,
            });
        }
        self.emit(Event::PlanDone {
            plan_id: e.plan.plan_id,
            ok,
            state: self.state,
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
                if let Some(e) = self.exec.as_mut() {
                    e.evidence |= evidence;
                    e.prim = e.prim.saturating_add(1);
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

    fn enter_primitive(&mut self, prim: Primitive) -> Result<(), FaultCode> {
        let now = self.now_ms;
        let cap = self.cfg.pressure_limit_kpa;
        let h = self.cfg.hysteresis_kpa;
        let p = self.pressure.filt_kpa;
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
                let l = self.bend_lengths(
                    (direction_deg as f64).to_radians(),
                    (angle_deg as f64).to_radians(),
                );
                targets = Some(self.angles_for(l).ok_or(FaultCode::ServoLimit)?);
            }
            Primitive::Gripper { close } => self.gripper_closed = close,
            Primitive::Manual(task) => manual = Some(task),
            _ => {}
        }
        if let Some(t) = targets {
            self.servo_target_deg = t;
        }
        let Some(e) = self.exec.as_mut() else {
            return Ok(());
        };
        e.prim_started = true;
        e.prim_start_ms = now;
        e.snaps = 0;
        e.reached_ms = None;
        match prim {
            Primitive::Inflate { pressure_kpa, .. } => {
                // Never regulate above the cap (which may have been lowered since the upload).
                let target = pressure_kpa.min(cap - h).max(0.0);
                e.hold_kpa = Some(target);
                e.filling = p < target;
            }
            Primitive::Vent { .. }
            | Primitive::TendonPull { .. }
            | Primitive::TendonRelease { .. } => e.hold_kpa = None,
            _ => {}
        }
        if let Some(task) = manual {
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
        let at_target = self.servos_at_target();
        let relief = self.cfg.pull_relief_kpa;
        let vent_tol = self.cfg.vent_tolerance_kpa;
        let gripper_ms = self.cfg.gripper_settle_ms as u64;
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
                if snaps > 0 && e.snaps >= snaps {
                    Progress::Done { evidence: true }
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
                // The sealed trunk is compressed: the exhaust relieves above the relief pressure.
                if p > relief {
                    e.relieving = true;
                } else if p < relief - h {
                    e.relieving = false;
                }
                exhaust = e.relieving;
                if snaps > 0 && e.snaps >= snaps {
                    // Stop pulling at the snap: the servos stay where they are.
                    self.servo_target_deg = self.servo_deg;
                    Progress::Done { evidence: true }
                } else if let Some(t) = reached(e, at_target) {
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
                if e.manual_confirmed {
                    Progress::Done { evidence: true }
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
        if let Some(ps) = self.plan_status.as_mut() {
            if matches!(prim, Primitive::Manual(_)) && matches!(result, Progress::Running) {
                ps.phase = PlanPhase::WaitingManual;
            } else {
                ps.phase = PlanPhase::Running;
            }
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
        let (plan_id, idx, evidence) = (e.plan.plan_id, e.step, e.evidence);
        let duration_ms = now.saturating_sub(e.step_start_ms) as u32;
        let n_steps = e.plan.steps.len();
        if from != to {
            // Confirmed when a primitive completed on its snaps or a person's confirmation;
            // a step with neither is assumed, not confirmed.
            self.set_state(to, evidence);
        }
        self.emit(Event::StepDone {
            plan_id,
            step: idx,
            ok: true,
            state: self.state,
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
        if next_from != Some(self.state) || !self.confirmed {
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
            e.relieving = false;
        }
        if let Some(ps) = self.plan_status.as_mut() {
            ps.step = next as u8;
        }
    }
}
