//! `host-tool declare STATE`: tell the device the trunk's true state (after it was folded by
//! hand outside a plan), then report the state the device holds.

use protocol::RequestBody;
use serde_json::json;

use crate::cmd::status::{snapshot, status_json, Snapshot};
use crate::device::DeviceArgs;
use crate::failure::Failure;
use host::text;

/// Arguments of `host-tool declare`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The trunk's true state: F&P, F&F, F&D, D&P, D&F or D&D.
    #[arg(value_name = "STATE", value_parser = crate::arg::trunk_state)]
    pub state: geometry::TrunkState,
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Print one JSON object on stdout.
    #[arg(skip)]
    pub json: bool,
}

/// Runs `host-tool declare`.
pub fn run(args: Args) -> Result<(), Failure> {
    // Parsed by clap, before any connection: a typo never reaches the device.
    let declared = args.state;
    let Snapshot {
        status,
        info,
        truth,
        ..
    } = snapshot(&args.device, Some(RequestBody::DeclareState(declared)))?;
    let kept = (status.state != declared).then(|| {
        format!(
            "the device accepted the declaration of {declared} but reports {}",
            status.state
        )
    });
    if args.json {
        let mut v = status_json(&status, &info, truth.as_ref());
        v["declared"] = json!(declared.name());
        v["ok"] = json!(kept.is_none());
        v["error"] = json!(kept);
        crate::cli::print_json(v);
    } else {
        crate::out!(
            "declared {declared}: the device now reports {}{} (mode {})",
            status.state,
            if status.state_confirmed {
                ", confirmed"
            } else {
                ", not confirmed"
            },
            text::mode(status.mode)
        );
    }
    // The status read after the request is the truth; a device that kept another state did
    // not do what was asked.
    match kept {
        None => Ok(()),
        Some(e) => Err(Failure::Runtime(anyhow::anyhow!("{e}"))),
    }
}
