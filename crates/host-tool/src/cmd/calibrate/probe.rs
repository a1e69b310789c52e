//! The identification probe's signatures, measured by `calibrate --manual` (docs/host.md,
//! "Calibration: the probe's signatures").
//!
//! The device runs the probe ([`protocol::probe`]) as three steps within the state the trunk is
//! in: vent and settle sealed; fill to [`PROBE_KPA`] and hold; vent. The device times the fill
//! itself (the middle step's `StepDone` duration less the hold's, on its own clock: the same
//! quantity its identification reads), the host takes the baseline from the settle's telemetry
//! and the leak from the hold's. A state is probed once when the walk reaches it; the two rests between
//! states (the bottom half-packed under the folded top and under the deployed top) are made by
//! the person, probed, undone, and the trunk probed again: the second reading must be the
//! state's first, or the trunk is not back where the device believes it is.

use geometry::TrunkState;
use host::calibration::WithinError;
use host::Driver;
use protocol::probe::{HOLD_MS, LEAK_DROP_KPA, PROBE, PROBE_KPA, RATE_TOLERANCE, SETTLE_MS};
use protocol::{RequestBody, Telemetry};

use crate::failure::Failure;
use crate::record::Recorder;
use crate::transport::AnyIo;

/// A second reading of a state after a rest between states was undone must be within this
/// fraction of the first: the device's own window. Two readings of one state differ by up to
/// 2.8 % (measured on the board ELF: the baseline is wherever the vent stopped under the
/// device's 0.5 kPa tolerance), so a tighter check refuses good trunks. It catches a trunk left
/// in another named state or half-packed under the deployed top (D&P½ reads 6 % off D&P on
/// the simulator's trunk); it cannot tell F&F from its half-packed rest (2 % apart), where the
/// person's word stands.
pub const REPEAT_TOLERANCE: f64 = RATE_TOLERANCE as f64;

/// The longest a probe step may take on the device's clock, ms (a fill at the device's lowest
/// accepted rate, 0.5 kPa/s, takes 8 s).
const STEP_TIMEOUT_MS: u64 = 20_000;

/// What one probe measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// The fill rate, kPa/s.
    pub rate: f64,
    /// The settle's baseline, kPa.
    pub p0_kpa: f64,
    /// The fill's duration on the device's clock, ms.
    pub fill_ms: u32,
    /// What the sealed hold lost from its first to its last 100 ms, kPa.
    pub drop_kpa: f64,
}

/// A rest between two named states that the person makes by hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Between {
    /// The bottom half-packed under the folded top (F&P½), made from F&F.
    FoldedTop,
    /// The bottom half-packed under the deployed top (D&P½), made from D&P.
    DeployedTop,
}

impl Between {
    /// The named state the rest is made from and returned to.
    pub fn home(self) -> TrunkState {
        match self {
            Between::FoldedTop => TrunkState::ALL[1],
            Between::DeployedTop => TrunkState::ALL[3],
        }
    }

    /// The rest's two named neighbours (its rate lies between theirs).
    pub fn neighbours(self) -> (TrunkState, TrunkState) {
        match self {
            Between::FoldedTop => (TrunkState::ALL[0], TrunkState::ALL[1]),
            Between::DeployedTop => (TrunkState::ALL[3], TrunkState::ALL[4]),
        }
    }

    /// Its index in a profile's `between`.
    pub fn index(self) -> usize {
        match self {
            Between::FoldedTop => 0,
            Between::DeployedTop => 1,
        }
    }

    /// Its name (`host::text::probe_rate_name`).
    pub fn name(self) -> String {
        host::text::probe_rate_name(6 + self.index() as u8)
    }

    /// What the person is asked to do to make the rest, and to undo it.
    fn tasks(self) -> (&'static str, &'static str) {
        match self {
            Between::FoldedTop => (
                "fold the bottom module's lowest unit into self-packing, only that one (the \
                 bottom half-packed under the folded top)",
                "unfold that unit again (the bottom module folded, as before)",
            ),
            Between::DeployedTop => (
                "unfold the bottom module's upper unit out of self-packing, only that one (the \
                 bottom half-packed under the deployed top)",
                "fold that unit back into self-packing (the bottom module packed, as before)",
            ),
        }
    }

    /// The well the simulated person moves the bottom module to: the rest, and home.
    fn wells(self) -> (usize, usize) {
        match self {
            Between::FoldedTop => (1, 2),
            Between::DeployedTop => (1, 0),
        }
    }
}

/// Why a probe could not be measured, or what it measured that the calibration refuses.
fn refuse(msg: String) -> Failure {
    super::refuse(msg)
}

/// Runs one step within `state` ([`host::calibration::run_within`]); a failure names the
/// probe.
fn run_within(
    s: &mut Driver<Recorder<AnyIo>>,
    state: TrunkState,
    prims: &[protocol::Primitive],
    interrupted: &std::sync::atomic::AtomicBool,
) -> Result<(Vec<Telemetry>, u32), Failure> {
    let stop = || interrupted.load(std::sync::atomic::Ordering::SeqCst);
    host::calibration::run_within(s, state, prims, STEP_TIMEOUT_MS as u32, &stop).map_err(|e| {
        match e {
            WithinError::Interrupted => Failure::Interrupted(
                "calibration interrupted: the probe was aborted, the device is in its safe state"
                    .into(),
            ),
            WithinError::Link(e) => anyhow::anyhow!("the probe at {state}: {e}").into(),
            WithinError::Failed { why, .. } => refuse(format!("the probe at {state}: {why}")),
        }
    })
}

fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Runs the probe within `state` (the device's belief; the trunk may rest between states while
/// the person holds it so) and reads it.
pub fn measure(
    s: &mut Driver<Recorder<AnyIo>>,
    state: TrunkState,
    interrupted: &std::sync::atomic::AtomicBool,
) -> Result<Reading, Failure> {
    // Vent, settle sealed: the baseline is the settle's second half.
    let (settle, _) = run_within(s, state, &PROBE[..2], interrupted)?;
    let last_ms = settle.last().map_or(0, |t| t.uptime_ms);
    let base: Vec<f64> = settle
        .iter()
        .filter(|t| {
            !t.inlet_open && !t.exhaust_open && last_ms.saturating_sub(t.uptime_ms) < SETTLE_MS / 2
        })
        .map(|t| f64::from(t.pressure_kpa))
        .collect();
    let p0 = mean(&base).ok_or_else(|| {
        refuse(format!(
            "the probe at {state}: no telemetry while the trunk settled sealed"
        ))
    })?;
    // The fill and the sealed hold (one step, as the device's own probe runs them: the inlet
    // regulates the target through the hold, so only a leak lowers it), timed by the device:
    // the step's duration less the hold's.
    let (hold, fill_and_hold_ms) = run_within(s, state, &PROBE[2..4], interrupted)?;
    let fill_ms = fill_and_hold_ms.saturating_sub(HOLD_MS);
    run_within(s, state, &PROBE[4..], interrupted)?;
    let end_ms = hold.last().map_or(0, |t| t.uptime_ms);
    // A sample's time into the hold, ms (`None` during the fill).
    let into_hold = |t: &Telemetry| {
        let before_end = end_ms.saturating_sub(t.uptime_ms);
        (before_end <= HOLD_MS).then(|| HOLD_MS - before_end)
    };
    let window = |from: u32, to: u32| -> Vec<f64> {
        hold.iter()
            .filter(|t| into_hold(t).is_some_and(|ms| (from..to).contains(&ms)))
            .map(|t| f64::from(t.pressure_kpa))
            .collect()
    };
    let (first, last) = (window(0, 100), window(HOLD_MS - 100, HOLD_MS + 1));
    let (Some(first), Some(last)) = (mean(&first), mean(&last)) else {
        return Err(refuse(format!(
            "the probe at {state}: no telemetry during the sealed hold"
        )));
    };
    let drop_kpa = (first - last).max(f64::from(PROBE_KPA) - last);
    if protocol::probe::leaking(PROBE_KPA, first as f32, last as f32) {
        return Err(refuse(format!(
            "the probe at {state}: the sealed trunk lost {drop_kpa:.2} kPa in {} s ({first:.2} \
             → {last:.2} kPa; over {LEAK_DROP_KPA} kPa: a leak); a leaking trunk fills slower \
             than its volume says, so its signatures would be the leak's: find the leak and \
             calibrate again",
            f64::from(HOLD_MS) / 1000.0
        )));
    }
    let rate = protocol::probe::fill_rate(p0 as f32, PROBE_KPA, u64::from(fill_ms))
        .map(f64::from)
        .ok_or_else(|| refuse(format!("the probe at {state}: a fill of no duration")))?;
    Ok(Reading {
        rate,
        p0_kpa: p0,
        fill_ms,
        drop_kpa,
    })
}

/// Asks the person to do `what` by hand and waits for the Enter (the simulated person does it
/// at once, moving the bottom module to `sim_well`); the link is kept alive meanwhile. A fold
/// moves the air sealed in the trunk, which the device may take for a leak: such a fault is
/// said and reset (the probe's own hold then tells a real leak).
fn by_hand(
    s: &mut Driver<Recorder<AnyIo>>,
    what: &str,
    sim_well: usize,
    interrupted: &std::sync::atomic::AtomicBool,
) -> Result<(), Failure> {
    person(s, what, sim_well, interrupted)?;
    let st = s
        .status()
        .map_err(|e| anyhow::anyhow!("after the fold by hand: {e}"))?;
    if st.faults != 0 {
        crate::say!(
            "calibrate: the device raised {} as the person folded the sealed trunk: reset",
            host::text::fault_list(st.faults)
        );
        s.command(RequestBody::ResetFaults)
            .map_err(|e| anyhow::anyhow!("resetting the faults after the fold by hand: {e}"))?;
    }
    Ok(())
}

fn person(
    s: &mut Driver<Recorder<AnyIo>>,
    what: &str,
    sim_well: usize,
    interrupted: &std::sync::atomic::AtomicBool,
) -> Result<(), Failure> {
    if let AnyIo::Sim(io) = &mut s.io.inner {
        crate::say!("calibrate: the simulated person is asked to {what}");
        io.sim
            .move_module_by_hand(hil_sim::physics::trunk::Module::Bottom, sim_well);
        return s
            .idle(500)
            .map_err(|e| anyhow::anyhow!("after the fold by hand: {e}").into());
    }
    if !crate::keyboard::available() {
        return Err(refuse(format!(
            "a person must {what}, and confirm with Enter: run this on a terminal"
        )));
    }
    crate::keyboard::discard_typed();
    crate::say!("please {what}, then press Enter");
    loop {
        if interrupted.load(std::sync::atomic::Ordering::SeqCst) {
            return Err(Failure::Interrupted("calibration interrupted".into()));
        }
        if crate::keyboard::try_line().is_some() {
            return s
                .idle(500)
                .map_err(|e| anyhow::anyhow!("after the fold by hand: {e}").into());
        }
        s.idle(100)
            .map_err(|e| anyhow::anyhow!("waiting for the person: {e}"))?;
    }
}

/// The rest `b`: made by the person from its home state (where the device believes the trunk
/// is, and where `home` was read), probed, undone, and the home state probed again.
pub fn measure_between(
    s: &mut Driver<Recorder<AnyIo>>,
    b: Between,
    home: Reading,
    interrupted: &std::sync::atomic::AtomicBool,
) -> Result<Reading, Failure> {
    let (make, undo) = b.tasks();
    let (rest_well, home_well) = b.wells();
    by_hand(s, make, rest_well, interrupted)?;
    let r = measure(s, b.home(), interrupted);
    // Undone whatever the probe found: the device believes the home state.
    by_hand(s, undo, home_well, interrupted)?;
    let r = r?;
    let again = measure(s, b.home(), interrupted)?;
    let off = (again.rate - home.rate).abs() > REPEAT_TOLERANCE * home.rate;
    if !off {
        // The device may have seen the folds by hand (the sealed trunk's pressure moved) and
        // no longer vouches for its state: the person's word and the probe's second reading
        // (the state's own) say the trunk is home.
        let st = s
            .status()
            .map_err(|e| anyhow::anyhow!("after the rest {}: {e}", b.name()))?;
        if !st.state_confirmed {
            s.command(RequestBody::DeclareState(b.home()))
                .map_err(|e| {
                    refuse(format!(
                    "after the rest {}, declaring {} (the person's word, the probe's reading): \
                     {e}",
                    b.name(),
                    b.home()
                ))
                })?;
            crate::say!(
                "calibrate: the device saw the folds by hand; {} declared (the probe reads it \
                 again: {:.2} kPa/s)",
                b.home(),
                again.rate
            );
        }
    }
    if off {
        return Err(refuse(format!(
            "after the rest {} was undone, the trunk fills at {:.2} kPa/s, not at {}'s {:.2} \
             kPa/s (more than {:.1} % off): it is not back at {}; put it back by hand and \
             calibrate again",
            b.name(),
            again.rate,
            b.home(),
            home.rate,
            REPEAT_TOLERANCE * 100.0,
            b.home()
        )));
    }
    Ok(r)
}

/// Refuses a set of signatures a trunk cannot have, naming what was seen: a rest between two
/// states must fill between their rates (its volume is between theirs). Returns what the
/// signatures cannot tell apart: two states each inside the other's window (said, not refused:
/// the device then asks the person between them).
pub fn check(states: &[f64; 6], between: &[f64; 2]) -> Result<Vec<String>, String> {
    for b in [Between::FoldedTop, Between::DeployedTop] {
        let (a, c) = b.neighbours();
        let (lo, hi) = {
            let (x, y) = (states[a.index()], states[c.index()]);
            (x.min(y), x.max(y))
        };
        let r = between[b.index()];
        if !(lo..=hi).contains(&r) {
            return Err(format!(
                "the rest {} fills at {r:.2} kPa/s, outside its neighbours' {a} {:.2} and {c} \
                 {:.2} kPa/s: a half-packed bottom holds a volume between theirs, so the \
                 readings are not of this trunk at rest",
                b.name(),
                states[a.index()],
                states[c.index()]
            ));
        }
    }
    let tol = f64::from(RATE_TOLERANCE);
    let mut notes = Vec::new();
    for (i, a) in TrunkState::ALL.iter().enumerate() {
        for b in &TrunkState::ALL[i + 1..] {
            let (x, y) = (states[a.index()], states[b.index()]);
            // One state's signature inside the other's window: the probe cannot tell them
            // apart at their signatures.
            if (x - y).abs() <= tol * x.max(y) {
                notes.push(format!(
                    "{a} and {b} fill at {x:.2} and {y:.2} kPa/s: within the probe's windows \
                     (±{:.0} %), so identification asks the person between them",
                    tol * 100.0
                ));
            }
        }
    }
    Ok(notes)
}
