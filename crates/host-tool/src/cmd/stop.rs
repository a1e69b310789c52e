//! `host-tool stop`: abort whatever runs; report the safe state the device went to.

use serde_json::json;

use crate::cmd::status::{snapshot, status_json, Snapshot};
use crate::failure::Failure;
use host::text;
use protocol::{Mode, RequestBody};

/// Arguments of `host-tool stop`: the same as `status`'s (the device, `--json`).
pub use crate::cmd::status::Args;

/// Runs `host-tool stop`.
pub fn run(args: Args) -> Result<(), Failure> {
    let Snapshot {
        status,
        info,
        truth,
        abort_latency_ms,
        ..
    } = snapshot(&args.device, Some(RequestBody::Abort))?;
    let safe = !status.inlet_open;
    const STILL_OPEN: &str = "the device still reports its inlet valve open after the abort";
    if args.json {
        let mut v = status_json(&status, &info, truth.as_ref());
        v["aborted"] = json!(true);
        v["safe"] = json!(safe);
        v["ok"] = json!(safe);
        v["error"] = json!((!safe).then_some(STILL_OPEN));
        if let Some(ms) = abort_latency_ms {
            v["abort_latency_ms"] = json!(ms);
        }
        crate::cli::print_json(v);
    } else {
        crate::out!(
            "aborted: the device is in mode {} at {}; inlet {}, exhaust {}, pressure {} kPa, \
             servos {} {}° {}° {}°",
            text::mode(status.mode),
            status.state,
            if status.inlet_open { "OPEN" } else { "closed" },
            if status.exhaust_open {
                "open (venting)"
            } else {
                "closed"
            },
            crate::num::fixed(f64::from(status.pressure_kpa), 1),
            // The safe state stops the servo pulses; the status then reports the last command.
            if matches!(status.mode, Mode::Safe | Mode::EStop) {
                "off (limp), last commanded"
            } else {
                "at"
            },
            crate::num::fixed(f64::from(status.servo_deg[0]), 1),
            crate::num::fixed(f64::from(status.servo_deg[1]), 1),
            crate::num::fixed(f64::from(status.servo_deg[2]), 1)
        );
    }
    if safe {
        Ok(())
    } else {
        Err(Failure::Runtime(anyhow::anyhow!("{STILL_OPEN}")))
    }
}
