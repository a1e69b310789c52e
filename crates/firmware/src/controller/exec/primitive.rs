//! The primitive under way: what each kind keeps while it runs, and one progress check per kind.
//!
//! A [`Run`] exists from the primitive's entry to its end; its [`RunKind`] carries only what
//! that kind of primitive needs (an inflation's snap and hold stages, a pull's relief and
//! sealed-release check, a manual step's confirm), so no other primitive can see or leave it
//! behind.

use protocol::{FaultCode, Primitive, Step};

use super::{Exec, Hold, Phase};
use crate::config::CraneConfig;
use crate::controller::snap::SnapSign;

/// The primitive under way (entered: its targets set, its watches reset).
#[derive(Debug, Clone, Copy)]
pub(super) struct Run {
    /// Snaps of the expected sign seen during it.
    pub(super) snaps: u8,
    pub(super) kind: RunKind,
}

/// What a primitive keeps while it runs, by kind.
// A one-byte tag: the checks of the kind stay single compares (a niche in a `u64` field
// would make each a 64-bit test).
#[derive(Debug, Clone, Copy)]
#[repr(u8)]
pub(super) enum RunKind {
    /// `Inflate`.
    Inflate(InflateRun),
    /// `TendonPull`.
    Pull(PullRun),
    /// `Manual`: waiting for the person's confirm (the display and the status name the task).
    Manual {
        /// The person confirmed: the primitive is done at the next look.
        confirmed: bool,
    },
    /// `Vent`, `TendonRelease`, `Hold`, `WaitSnap`, `Gripper`, `Bend`: nothing of their own.
    Plain,
}

impl RunKind {
    /// The state `prim` starts with (`start_kpa`, `start_deg`: the pressure and the servo
    /// angles when it is entered).
    pub(super) fn start(prim: Primitive, start_kpa: f32, start_deg: [f32; 3]) -> Self {
        match prim {
            Primitive::Inflate { .. } => Self::Inflate(InflateRun {
                snap_kpa: 0.0,
                stage: InflateStage::Filling { reached_ms: None },
            }),
            Primitive::TendonPull { snaps, .. } => Self::Pull(PullRun {
                relieving: false,
                check: (snaps > 0).then_some(PullCheck {
                    phase: PullPhase::Pulling,
                    baseline_kpa: start_kpa,
                    relieved_kpa: 0.0,
                    relief_from_kpa: None,
                    start_deg,
                    since_ms: None,
                    surprise: false,
                    unconfirmed: false,
                }),
            }),
            Primitive::Manual(_) => Self::Manual { confirmed: false },
            _ => Self::Plain,
        }
    }
}

/// An inflation under way.
#[derive(Debug, Clone, Copy)]
pub(super) struct InflateRun {
    /// Highest pressure before its snaps: what the trunk snapped at.
    snap_kpa: f32,
    stage: InflateStage,
}

/// Where an inflation is (`docs/firmware.md`, "Pneumatic steps").
#[derive(Debug, Clone, Copy)]
#[repr(u8)]
enum InflateStage {
    /// Filling until its snaps; when it reached its pressure (a snapless one is done there).
    Filling { reached_ms: Option<u64> },
    /// Its snaps were all seen: the inlet stays shut while the drop is checked to be a step (a
    /// snap: the sealed trunk then holds its pressure) and not the start of a fall (a leak
    /// opening). Since when, and the pressure once the drop is over.
    Dropping {
        since_ms: u64,
        after_kpa: Option<f32>,
    },
    /// The hold after the snaps: since when the pressure is back at the snap's and nothing
    /// snapped, and the snaps counted then.
    Holding {
        quiet_since_ms: Option<u64>,
        seen: u8,
    },
}

/// A tendon pull under way.
#[derive(Debug, Clone, Copy)]
pub(super) struct PullRun {
    /// Relief: the exhaust wanted open (the sealed trunk compressed above the relief pressure).
    relieving: bool,
    /// The sealed-release check of a pull that expects snaps (`None`: a positioning pull).
    pub(super) check: Option<PullCheck>,
}

/// What a primitive's progress check decided.
pub(super) enum Progress {
    Running,
    Done { evidence: bool },
    Fail(FaultCode),
}

/// What one look at the running primitive sees (read from the controller before it).
#[derive(Clone, Copy)]
pub(super) struct Look {
    pub(super) now: u64,
    /// The filtered pressure.
    pub(super) p: f32,
    /// The servos are at their targets.
    pub(super) at_target: bool,
    /// Since the primitive began.
    pub(super) elapsed: u64,
    /// An inflation whose snaps were all seen ([`Exec::snaps_all_seen`]).
    pub(super) snapped: bool,
}

/// What a look asks of the valves and the servos.
pub(super) struct Wants {
    pub(super) inlet: bool,
    pub(super) exhaust: bool,
    /// New servo targets (a confirming pull going back to where it started).
    pub(super) servo_deg: Option<[f32; 3]>,
}

/// Where a confirming tendon pull (`TendonPull` with snaps) is. Under a pull the tendons pin
/// the trunk's height, so a buckling module may barely change the pressure; the volume tells
/// once the tendons are let out again with the valves closed (`docs/firmware.md`, "Tendon
/// steps").
#[derive(Debug, Clone, Copy, PartialEq)]
enum PullPhase {
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
pub(super) struct PullCheck {
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

impl InflateRun {
    /// Before the snaps: done at the pressure when none are expected, else failed if they do
    /// not come within the settle time once it is reached.
    fn filling(&mut self, target: f32, snaps: u8, cfg: &CraneConfig, l: Look) -> Progress {
        let InflateStage::Filling { reached_ms } = &mut self.stage else {
            return Progress::Running;
        };
        if l.p >= target && reached_ms.is_none() {
            *reached_ms = Some(l.now);
        }
        match *reached_ms {
            Some(_) if snaps == 0 => Progress::Done { evidence: false },
            Some(t) if l.now.saturating_sub(t) >= cfg.snap.settle_ms as u64 => {
                Progress::Fail(FaultCode::TransitionNotConfirmed)
            }
            _ => Progress::Running,
        }
    }

    /// After the snaps (`seen` of them), the inlet shut: the drop must be a step.
    fn dropping(
        &mut self,
        seen: u8,
        hold: &mut Option<Hold>,
        cfg: &CraneConfig,
        l: Look,
        w: &mut Wants,
    ) -> Progress {
        let InflateStage::Dropping {
            since_ms,
            after_kpa,
        } = &mut self.stage
        else {
            return Progress::Running;
        };
        // A snap's drop is a step: once it is over, the sealed trunk holds its pressure. A leak
        // opening drops it as fast at first, then goes on falling: that drop is no evidence.
        w.inlet = false;
        if let Some(hold) = hold.as_mut() {
            hold.filling = false;
        }
        let snap_cfg = cfg.snap;
        let quiet = snap_cfg.refractory_ms as u64;
        let elapsed = l.now.saturating_sub(*since_ms);
        match *after_kpa {
            None if elapsed >= quiet => {
                *after_kpa = Some(l.p);
                Progress::Running
            }
            Some(p1) if l.p < p1 - snap_cfg.threshold_kpa => Progress::Fail(FaultCode::Leak),
            Some(_) if elapsed >= 2 * quiet => {
                // The drop was a snap: now the hold at the snap's pressure.
                self.stage = InflateStage::Holding {
                    quiet_since_ms: None,
                    seen,
                };
                *hold = Some(Hold {
                    kpa: repress_kpa(self.snap_kpa, cfg.pressure_limit_kpa, cfg.hysteresis_kpa),
                    filling: true,
                });
                Progress::Running
            }
            _ => Progress::Running,
        }
    }

    /// The hold after the snaps (`seen` of them now): back at the pressure the trunk snapped at
    /// (the regulator fills to it). A trunk in the step's target holds there (its next barrier
    /// is higher: the order every trunk the crane drives has); one left between wells goes on,
    /// and shows it by a snap.
    fn holding(&mut self, seen: u8, cfg: &CraneConfig, l: Look) -> Progress {
        let InflateStage::Holding {
            quiet_since_ms,
            seen: counted,
        } = &mut self.stage
        else {
            return Progress::Running;
        };
        let (cap, h) = (cfg.pressure_limit_kpa, cfg.hysteresis_kpa);
        let quiet = 2 * cfg.snap.refractory_ms as u64;
        if seen != *counted {
            *quiet_since_ms = None;
            *counted = seen;
            Progress::Running
        } else if let Some(t) = *quiet_since_ms {
            if l.now.saturating_sub(t) >= quiet {
                Progress::Done { evidence: true }
            } else {
                Progress::Running
            }
        } else {
            if l.p >= repress_kpa(self.snap_kpa, cap, h) - h {
                *quiet_since_ms = Some(l.now);
            }
            Progress::Running
        }
    }
}

/// `Done` (without evidence) once `cond` holds.
fn done_if(cond: bool) -> Progress {
    if cond {
        Progress::Done { evidence: false }
    } else {
        Progress::Running
    }
}

impl Exec {
    /// The primitive under way, if it has begun.
    pub(super) fn run(&self) -> Option<&Run> {
        match &self.phase {
            Phase::Primitive { run, .. } => run.as_ref(),
            _ => None,
        }
    }

    fn run_mut(&mut self) -> Option<&mut Run> {
        match &mut self.phase {
            Phase::Primitive { run, .. } => run.as_mut(),
            _ => None,
        }
    }

    /// Snaps of the expected sign seen during the current primitive (0 before it begins).
    pub(super) fn snaps(&self) -> u8 {
        self.run().map_or(0, |r| r.snaps)
    }

    /// One look at `prim`, the primitive under way: its progress check, by kind.
    pub(super) fn look(
        &mut self,
        prim: Primitive,
        cfg: &CraneConfig,
        l: Look,
        w: &mut Wants,
    ) -> Progress {
        match prim {
            Primitive::Inflate {
                pressure_kpa,
                snaps,
            } => self.inflate(pressure_kpa, snaps, cfg, l, w),
            Primitive::Vent { pressure_kpa } => {
                w.inlet = false;
                if l.p <= pressure_kpa + cfg.vent_tolerance_kpa {
                    Progress::Done { evidence: false }
                } else {
                    w.exhaust = true;
                    Progress::Running
                }
            }
            Primitive::TendonPull { snaps, .. } => self.pull(snaps, cfg, l, w),
            Primitive::TendonRelease { .. } => {
                // Let air in as the trunk lengthens (no vacuum pulling it back).
                w.inlet = false;
                w.exhaust = true;
                done_if(l.at_target)
            }
            Primitive::Hold { duration_ms } => done_if(l.elapsed >= duration_ms as u64),
            Primitive::WaitSnap { timeout_ms } => {
                if self.snaps() >= 1 {
                    Progress::Done { evidence: true }
                } else if l.elapsed >= timeout_ms as u64 {
                    Progress::Fail(FaultCode::TransitionNotConfirmed)
                } else {
                    Progress::Running
                }
            }
            Primitive::Manual(_) => self.manual(w),
            Primitive::Gripper { .. } => done_if(l.elapsed >= cfg.gripper_settle_ms as u64),
            Primitive::Bend { .. } => done_if(l.at_target),
        }
    }

    /// An inflation: fill to its pressure (or, waiting for snaps, up to the cap); after the
    /// snaps, check the drop was one, then hold at the snap's pressure until quiet.
    fn inflate(
        &mut self,
        pressure_kpa: f32,
        snaps: u8,
        cfg: &CraneConfig,
        l: Look,
        w: &mut Wants,
    ) -> Progress {
        let (h, cap) = (cfg.hysteresis_kpa, cfg.pressure_limit_kpa);
        let target = self.hold.map_or(pressure_kpa, |hold| hold.kpa).min(cap - h);
        // Unpacking may stop with one layer of two unpacked (the first layer's drop took
        // the pressure under the second's barrier): the hold at the snap's pressure then
        // unpacks the second, one snap more, and only there.
        let unpacking = self.step().is_some_and(|st| {
            st.from.bottom == geometry::BottomState::Packed
                && st.to.bottom != geometry::BottomState::Packed
        });
        let allowed = snaps.saturating_add(unpacking as u8);
        let Phase::Primitive {
            run:
                Some(Run {
                    snaps: seen,
                    kind: RunKind::Inflate(r),
                }),
            ..
        } = &mut self.phase
        else {
            return Progress::Running;
        };
        let seen = *seen;
        if !l.snapped {
            r.snap_kpa = r.snap_kpa.max(l.p);
            return r.filling(target, snaps, cfg, l);
        }
        if seen > allowed {
            // A snap more than the step can make: the trunk went on past its target.
            return Progress::Fail(FaultCode::TransitionNotConfirmed);
        }
        if let InflateStage::Filling { .. } = r.stage {
            r.stage = InflateStage::Dropping {
                since_ms: l.now,
                after_kpa: None,
            };
        }
        match r.stage {
            InflateStage::Dropping { .. } => r.dropping(seen, &mut self.hold, cfg, l, w),
            InflateStage::Holding { .. } => r.holding(seen, cfg, l),
            InflateStage::Filling { .. } => Progress::Running,
        }
    }

    /// A tendon pull: to its length, relieving the compressed sealed trunk above the relief
    /// pressure; one that expects snaps is confirmed by its sealed-release check.
    fn pull(&mut self, snaps: u8, cfg: &CraneConfig, l: Look, w: &mut Wants) -> Progress {
        let (h, relief, vent_tol) = (
            cfg.hysteresis_kpa,
            cfg.pull_relief_kpa,
            cfg.vent_tolerance_kpa,
        );
        // A fold over a packed bottom: its sealed spike may unpack the bottom (F&F), which
        // the pressure does not tell from the fold alone (F&P).
        let packed = self
            .step()
            .is_some_and(|st| st.from.bottom == geometry::BottomState::Packed);
        let Some(Run {
            snaps: seen,
            kind: RunKind::Pull(r),
        }) = self.run_mut()
        else {
            return Progress::Running;
        };
        let seen = *seen;
        w.inlet = false;
        match r.check {
            None
            | Some(PullCheck {
                phase: PullPhase::Pulling,
                ..
            }) => {
                // The sealed trunk is compressed: the exhaust relieves above the
                // relief pressure (the check below allows for the gas it lets out).
                if l.p > relief {
                    r.relieving = true;
                } else if l.p < relief - h {
                    r.relieving = false;
                }
                w.exhaust = r.relieving;
            }
            Some(_) => r.relieving = false,
        }
        let Some(c) = r.check.as_mut() else {
            // A positioning pull: done at the length.
            return done_if(l.at_target);
        };
        // Account for the gas the relief lets out (measured as the drop while open; the
        // pull's own compression meanwhile makes it an underestimate, which errs toward not
        // confirming).
        match (r.relieving, c.relief_from_kpa) {
            (true, None) => c.relief_from_kpa = Some(l.p),
            (false, Some(from)) => {
                c.relieved_kpa += (from - l.p).max(0.0);
                c.relief_from_kpa = None;
            }
            _ => {}
        }
        match pull_check(
            c,
            seen,
            snaps,
            l.at_target,
            l.now,
            l.p,
            cfg.tendon_check,
            packed,
        ) {
            CheckStep::Running => Progress::Running,
            CheckStep::Release => {
                // Stop pulling (at the spikes or the length) and go back to where the pull
                // started, sealed.
                w.servo_deg = Some(c.start_deg);
                Progress::Running
            }
            CheckStep::Vent => {
                // Back to the pressure before the pull; a baseline within the vent tolerance
                // of ambient counts as ambient (no creep from step to step).
                let to = if c.baseline_kpa < vent_tol {
                    0.0
                } else {
                    c.baseline_kpa
                };
                if l.p > to + vent_tol {
                    w.exhaust = true;
                    Progress::Running
                } else if c.unconfirmed {
                    Progress::Fail(FaultCode::TransitionNotConfirmed)
                } else {
                    Progress::Done { evidence: true }
                }
            }
        }
    }

    /// A manual primitive: waits for the person's confirm.
    fn manual(&mut self, w: &mut Wants) -> Progress {
        // A person folds a trunk open to the air (unless the step holds a pressure on
        // purpose): a sealed one, left pressurised by a failed step, would be squeezed
        // over the cap by their hands.
        w.exhaust = self.hold.is_none();
        match self.run() {
            // The person's word alone is no evidence: the check follows.
            Some(Run {
                kind: RunKind::Manual { confirmed: true },
                ..
            }) => Progress::Done { evidence: false },
            _ => Progress::Running,
        }
    }

    /// Counts a snap if the current primitive waits for one of this sign; returns whether it did.
    pub(in crate::controller) fn on_snap(&mut self, sign: SnapSign) -> bool {
        let prim = self.current().and_then(|(_, p)| p);
        let Some(run) = self.run_mut() else {
            return false;
        };
        let pulling = matches!(
            run.kind,
            RunKind::Pull(PullRun {
                check: Some(PullCheck {
                    phase: PullPhase::Pulling,
                    ..
                }),
                ..
            })
        );
        let wanted = match prim {
            Some(Primitive::Inflate { snaps, .. }) => snaps > 0 && sign == SnapSign::Drop,
            Some(Primitive::TendonPull { snaps, .. }) => {
                snaps > 0 && sign == SnapSign::Rise && pulling
            }
            Some(Primitive::WaitSnap { .. }) => true,
            _ => false,
        };
        if let RunKind::Pull(PullRun { check: Some(c), .. }) = &mut run.kind {
            // A drop under the pull (the trunk lengthened) or any snap while it is let out
            // sealed: not the fold the step makes.
            if matches!(c.phase, PullPhase::Releasing | PullPhase::Settling)
                || (c.phase == PullPhase::Pulling && sign == SnapSign::Drop)
            {
                c.surprise = true;
            }
        }
        if wanted {
            run.snaps = run.snaps.saturating_add(1);
        }
        wanted
    }

    /// The step under way.
    fn step(&self) -> Option<&Step> {
        self.plan.steps.get(self.step as usize)
    }
}
