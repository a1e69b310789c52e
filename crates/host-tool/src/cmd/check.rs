//! `host-tool check`: the pre-flight check of a connected crane (or the simulator), line by
//! line, with a person watching — the link, the pressure sensor's zero at rest, the inlet
//! valve (a small inflation and the pressure rise seen), the trunk holding that pressure sealed,
//! the exhaust valve (the fall seen), the three servos (a pull within the tendons' slack and
//! back), the gripper (closed and opened), the e-stop and the buttons. Everything is done with
//! the steps the protocol already has (one-step plans within the trunk's state), so the check
//! tests the firmware that will run the crane, not a special mode of it.
//!
//! Every line says what it measured; what the crane cannot measure is `not checked` with the
//! reason, never `pass`. A line that fails names its fault code; the crane is then made safe
//! (vented) and the lines after it are `not run`. Exit 0 only when every checked line passes.

use std::io::IsTerminal as _;

use hil_sim::sim::Buttons;
use protocol::{Primitive, Status};
use serde_json::{json, Value};

use crate::cmd::prim::{run_step, step_for, Link};
use crate::device::DeviceArgs;
use crate::failure::Failure;
use host::text;

/// Arguments of `host-tool check`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:
  host-tool check --sim
  host-tool check --sim --sim-fault leak        # the hold line fails with E-08
  host-tool check -p /dev/ttyACM0               # a person answers the prompts with Enter")]
pub struct Args {
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Print one JSON object: `ok` and the lines (`name`, `result`, `measured`, `limit`,
    /// `note`).
    #[arg(skip)]
    pub json: bool,
}

/// The inflation the inlet line makes, kPa: under every snap the trunk has (the lowest, the
/// bottom's unpacking, is 9.9 kPa even on a trunk 25 % softer than the simulator's), so the
/// state cannot change.
pub const CHECK_INFLATE_KPA: f32 = 3.0;
/// How long the hold line keeps the trunk sealed, ms.
const HOLD_MS: u32 = 3_000;
/// The most the pressure may fall while sealed for [`HOLD_MS`], kPa.
const HOLD_LOSS_KPA: f32 = 0.5;
/// The tendons' pull for the servo line, mm: inside the 2 mm take-up margin of slack.
const SERVO_PULL_MM: f32 = 1.0;

/// How a line ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Result_ {
    Pass,
    Fail,
    NotChecked,
    NotRun,
}

impl Result_ {
    fn word(self) -> &'static str {
        match self {
            Result_::Pass => "pass",
            Result_::Fail => "FAIL",
            Result_::NotChecked => "not checked",
            Result_::NotRun => "not run",
        }
    }

    fn json(self) -> &'static str {
        match self {
            Result_::Pass => "pass",
            Result_::Fail => "fail",
            Result_::NotChecked => "not-checked",
            Result_::NotRun => "not-run",
        }
    }
}

/// One line of the table.
struct Line {
    name: &'static str,
    result: Result_,
    measured: Option<String>,
    limit: Option<String>,
    note: String,
}

fn line(
    name: &'static str,
    result: Result_,
    measured: Option<String>,
    limit: Option<String>,
    note: impl Into<String>,
) -> Line {
    Line {
        name,
        result,
        measured,
        limit,
        note: note.into(),
    }
}

/// The kPa of `v`, one decimal.
fn kpa(v: f32) -> String {
    format!("{} kPa", crate::num::fixed(f64::from(v), 1))
}

/// The fault codes active in `st`, or what the step said.
fn why(st: &Status, error: Option<&str>) -> String {
    if st.faults != 0 {
        format!(
            "{}{}",
            text::fault_list(st.faults),
            error.map_or(String::new(), |e| format!(": {e}"))
        )
    } else {
        error.unwrap_or("the step did not complete").to_string()
    }
}

/// Asks the person at the crane to do `what` and waits for Enter; on the simulator its
/// simulated person does it with `press`.
fn person(link: &mut Link, what: &str, press: Buttons) -> Result<(), Failure> {
    if let Some(sim) = link.sim() {
        crate::say!("simulated person: {what}");
        sim.set_buttons(press);
        return Ok(());
    }
    crate::cmd::demo::ask_person(what)
}

/// Lets go of every button the simulated person holds.
fn release(link: &mut Link) {
    if let Some(sim) = link.sim() {
        sim.set_buttons(Buttons::default());
    }
}

/// Waits (up to `ms` on the link's clock) for a status that `done` accepts; the last status.
fn await_status(
    link: &mut Link,
    ms: u64,
    done: impl Fn(&Status) -> bool,
) -> Result<Status, Failure> {
    let until = link.now_ms() + ms;
    loop {
        let st = link.status()?;
        if done(&st) || link.now_ms() >= until {
            return Ok(st);
        }
        link.wait(50)?;
    }
}

/// Runs the lines in order into `out`; the first failure stops the ones after it.
fn run_lines(link: &mut Link, out: &mut Vec<Line>) -> Result<(), Failure> {
    let st = link.status()?;
    out.push(line(
        "link",
        Result_::Pass,
        Some(format!(
            "{} frames received, {} dropped",
            st.frames_rx, st.frames_dropped
        )),
        None,
        "handshake done, the protocol and schema are the host's",
    ));
    if let Some(why) = crate::cmd::prim::blocked(&st) {
        out.push(line("ready", Result_::Fail, None, None, why));
        return Ok(());
    }
    let state = st.state;
    let tol = protocol::DEFAULT_VENT_TOLERANCE_KPA;

    // The sensor's zero: at rest with the exhaust open the trunk is at ambient.
    let end = run_step(link, step_for(state, Primitive::Vent { pressure_kpa: 0.0 }))?;
    if !end.ok {
        out.push(line(
            "sensor zero",
            Result_::Fail,
            Some(kpa(end.status.pressure_kpa)),
            Some(format!("±{tol} kPa")),
            why(&end.status, end.error.as_deref()),
        ));
        return Ok(());
    }
    let st = await_status(link, 1_000, |_| false)?;
    let zero = st.pressure_kpa;
    let ok = zero.abs() <= tol && st.faults == 0;
    out.push(line(
        "sensor zero",
        if ok { Result_::Pass } else { Result_::Fail },
        Some(kpa(zero)),
        Some(format!("±{tol} kPa at rest")),
        if ok {
            "the sensor reads ambient with the trunk vented".to_string()
        } else {
            why(&st, Some("the sensor does not read ambient at rest"))
        },
    ));
    if !ok {
        return Ok(());
    }

    // The inlet: a small inflation, under every snap.
    let end = run_step(
        link,
        step_for(
            state,
            Primitive::Inflate {
                pressure_kpa: CHECK_INFLATE_KPA,
                snaps: 0,
            },
        ),
    )?;
    let rise = end.status.pressure_kpa - zero;
    let ok = end.ok && rise >= CHECK_INFLATE_KPA - tol;
    out.push(line(
        "inlet valve",
        if ok { Result_::Pass } else { Result_::Fail },
        Some(format!("+{}", kpa(rise))),
        Some(format!("≥ {} kPa", CHECK_INFLATE_KPA - tol)),
        if ok {
            "it opened and the pressure rose".to_string()
        } else {
            why(&end.status, end.error.as_deref())
        },
    ));
    if !ok {
        return Ok(());
    }

    // Sealed: the trunk holds the pressure.
    let before = end.status.pressure_kpa;
    let end = run_step(
        link,
        step_for(
            state,
            Primitive::Hold {
                duration_ms: HOLD_MS,
            },
        ),
    )?;
    let loss = before - end.status.pressure_kpa;
    let ok = end.ok && loss <= HOLD_LOSS_KPA && end.status.faults == 0;
    out.push(line(
        "hold (valves closed)",
        if ok { Result_::Pass } else { Result_::Fail },
        Some(format!("−{} in {} s", kpa(loss.max(0.0)), HOLD_MS / 1000)),
        Some(format!("≤ {HOLD_LOSS_KPA} kPa")),
        if ok {
            "no leak".to_string()
        } else {
            why(
                &end.status,
                end.error
                    .as_deref()
                    .or(Some("the pressure falls while sealed: a leak")),
            )
        },
    ));
    if !ok {
        return Ok(());
    }

    // The exhaust: back to ambient.
    let end = run_step(link, step_for(state, Primitive::Vent { pressure_kpa: 0.0 }))?;
    // The vent ends within its tolerance of ambient; the sensor's noise adds as much again.
    let ok = end.ok && end.status.pressure_kpa <= 2.0 * tol && end.status.faults == 0;
    out.push(line(
        "exhaust valve",
        if ok { Result_::Pass } else { Result_::Fail },
        Some(kpa(end.status.pressure_kpa)),
        Some(format!("≤ {} kPa", 2.0 * tol)),
        if ok {
            "it opened and the pressure fell to ambient".to_string()
        } else {
            why(&end.status, end.error.as_deref())
        },
    ));
    if !ok {
        return Ok(());
    }

    // The servos: a pull inside the tendons' slack, and back.
    let end = run_step(
        link,
        step_for(
            state,
            Primitive::TendonPull {
                length_mm: SERVO_PULL_MM,
                snaps: 0,
            },
        ),
    )?;
    let pulled = end.status.servo_deg;
    let back = if end.ok {
        Some(run_step(
            link,
            step_for(state, Primitive::TendonRelease { length_mm: 0.0 }),
        )?)
    } else {
        None
    };
    let ok = end.ok
        && pulled.iter().all(|d| *d > 0.0)
        && back
            .as_ref()
            .is_some_and(|b| b.ok && b.status.servo_deg.iter().all(|d| d.abs() < 0.5));
    let failed = back.as_ref().filter(|b| !b.ok).unwrap_or(&end);
    out.push(line("servos", if ok { Result_::Pass } else { Result_::Fail }, Some(format!("{}° {}° {}° and back", crate::num::fixed(f64::from(pulled[0]), 1), crate::num::fixed(f64::from(pulled[1]), 1), crate::num::fixed(f64::from(pulled[2]), 1))), Some(format!("{SERVO_PULL_MM} mm of pull, in the slack")), if ok { "commanded and acknowledged; the servos report no position: watch all three move (a stalled or unpowered servo shows only under load, in a plan)".to_string() } else { why(&failed.status, failed.error.as_deref()) }));
    if !ok {
        return Ok(());
    }

    // The gripper: closed and opened, back as it was.
    let was = end.status.gripper_closed;
    let mut seen = Vec::new();
    let mut gripper_ok = true;
    for close in [!was, was] {
        let e = run_step(link, step_for(state, Primitive::Gripper { close }))?;
        gripper_ok &= e.ok && e.status.gripper_closed == close;
        seen.push(if e.status.gripper_closed {
            "closed"
        } else {
            "open"
        });
        if !gripper_ok {
            out.push(line(
                "gripper",
                Result_::Fail,
                Some(seen.join(", ")),
                None,
                why(&e.status, e.error.as_deref()),
            ));
            return Ok(());
        }
    }
    out.push(line(
        "gripper",
        Result_::Pass,
        Some(seen.join(", then ")),
        None,
        "the device drove it both ways (no sensor sees the jaw: watch it)",
    ));

    // The e-stop: pressed, latched; released and reset with the confirm button.
    person(
        link,
        "press the e-stop, then press Enter",
        Buttons {
            estop: true,
            ..Buttons::default()
        },
    )?;
    let st = await_status(link, 2_000, |s| s.estop)?;
    release(link);
    let latched = st.estop;
    let mut note = if latched {
        "latched".to_string()
    } else {
        "the device never reported it pressed".to_string()
    };
    let mut reset = false;
    if latched {
        person(
            link,
            "release the e-stop and press the confirm button, then press Enter",
            Buttons {
                confirm: true,
                ..Buttons::default()
            },
        )?;
        let st = await_status(link, 2_000, |s| !s.estop && s.faults == 0)?;
        release(link);
        reset = !st.estop && st.faults == 0;
        note = if reset {
            "latched, then reset by the confirm button".into()
        } else {
            format!(
                "latched, but not reset by the confirm button ({})",
                why(&st, None)
            )
        };
    }
    out.push(line(
        "e-stop and confirm",
        if latched && reset {
            Result_::Pass
        } else {
            Result_::Fail
        },
        Some(if latched {
            "pressed: latched".into()
        } else {
            "not seen".into()
        }),
        None,
        note,
    ));
    if !(latched && reset) {
        return Ok(());
    }

    // The gripper button: toggles the gripper, and again back.
    let before = link.status()?.gripper_closed;
    let mut toggled = 0;
    for _ in 0..2 {
        let expect = if toggled % 2 == 0 { !before } else { before };
        person(
            link,
            "press the gripper button once, then press Enter",
            Buttons {
                gripper: true,
                ..Buttons::default()
            },
        )?;
        let st = await_status(link, 2_000, |s| s.gripper_closed == expect)?;
        release(link);
        link.wait(200)?;
        if st.gripper_closed == expect {
            toggled += 1;
        }
    }
    out.push(line(
        "gripper button",
        if toggled == 2 {
            Result_::Pass
        } else {
            Result_::Fail
        },
        Some(format!("{toggled} of 2 presses toggled it")),
        None,
        "each press toggles the gripper",
    ));
    if toggled != 2 {
        return Ok(());
    }
    out.push(line("step up/down buttons", Result_::NotChecked, None, None, "each starts a transition (the trunk would move): check them in a plan, with air and tendons ready"));
    out.push(line("show-pressure button", Result_::NotChecked, None, None, "it changes only the display, which the protocol does not report: press it and read the display"));
    Ok(())
}

/// The names of every line, in order (for the `not run` rows).
const NAMES: [&str; 11] = [
    "link",
    "sensor zero",
    "inlet valve",
    "hold (valves closed)",
    "exhaust valve",
    "servos",
    "gripper",
    "e-stop and confirm",
    "gripper button",
    "step up/down buttons",
    "show-pressure button",
];

/// Runs `host-tool check`.
pub fn run(args: Args) -> Result<(), Failure> {
    if !args.device.sim && !std::io::stdin().is_terminal() {
        return Err(Failure::usage(
            "check needs a person at the crane to press the e-stop and the buttons and to answer with Enter: run it on a terminal (or with --sim)",
        ));
    }
    let mut link = Link::open_recorded(
        &args.device,
        &crate::cmd::task::WorldArgs::default().parse()?,
        None,
        "check",
    )?;
    let mut lines = Vec::new();
    let result = run_lines(&mut link, &mut lines);
    // Whatever happened, the crane ends vented and released.
    release(&mut link);
    let safe = match link.status() {
        Ok(st)
            if st.pressure_kpa > protocol::DEFAULT_VENT_TOLERANCE_KPA
                && crate::cmd::prim::blocked(&st).is_none() =>
        {
            run_step(
                &mut link,
                step_for(st.state, Primitive::Vent { pressure_kpa: 0.0 }),
            )
            .map(|e| e.ok)
            .unwrap_or(false)
        }
        Ok(_) => true,
        Err(_) => false,
    };
    let truth = link
        .sim()
        .map(|s| crate::sim::SimTruth::from(s.ground_truth()));
    link.close();
    match result {
        Ok(()) => {}
        Err(Failure::Interrupted(m)) => return Err(Failure::Interrupted(m)),
        Err(e) => {
            // A link lost mid-check: the line it was on failed, with the reason.
            let name = NAMES
                .into_iter()
                .find(|n| !lines.iter().any(|l| l.name == *n))
                .unwrap_or("link");
            lines.push(line(
                name,
                Result_::Fail,
                None,
                None,
                crate::cmd::reach::failure_text(&e),
            ));
        }
    }
    let failed_at = lines.iter().position(|l| l.result == Result_::Fail);
    for name in NAMES {
        if !lines.iter().any(|l| l.name == name) && failed_at.is_some() {
            lines.push(line(
                name,
                Result_::NotRun,
                None,
                None,
                "after a failed line",
            ));
        }
    }
    let ok = failed_at.is_none();
    if args.json {
        crate::cli::print_json(json!({
            "ok": ok,
            "lines": lines.iter().map(|l| json!({
                "name": l.name,
                "result": l.result.json(),
                "measured": l.measured,
                "limit": l.limit,
                "note": l.note,
            })).collect::<Vec<Value>>(),
            "ended_safe": safe,
            "sim": truth.as_ref().map(crate::sim::SimTruth::to_json),
        }));
    } else {
        crate::out!(
            "{:<22} {:<12} {:<26} {:<26} note",
            "check",
            "result",
            "measured",
            "limit"
        );
        for l in &lines {
            crate::out!(
                "{:<22} {:<12} {:<26} {:<26} {}",
                l.name,
                l.result.word(),
                l.measured.as_deref().unwrap_or("-"),
                l.limit.as_deref().unwrap_or("-"),
                l.note
            );
        }
    }
    if ok {
        Ok(())
    } else {
        let l = &lines[failed_at.unwrap_or(0)];
        Err(Failure::Runtime(anyhow::anyhow!(
            "check failed at '{}': {}",
            l.name,
            l.note
        )))
    }
}
