//! `host-tool identify`: have the device identify an unconfirmed trunk state — its own probes
//! first, then the operator among the candidates the probes leave — and report the state it
//! then confirms. A confirmed state is reported at once.

use host::RunOptions;
use planner::graph::Graph;
use serde_json::json;

use crate::cmd::plan::{interrupt_flag, CliShell};
use crate::device::{Connection, DeviceArgs};
use crate::failure::Failure;

/// Arguments of `host-tool identify`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Print one JSON object on stdout.
    #[arg(short = 'j', long)]
    pub json: bool,
}

/// Has the device on `conn` identify its state (its probes, then the operator; Ctrl-C
/// aborts): the outcome's `final_state` is the state it then confirms.
pub fn identify(conn: &mut Connection) -> host::Outcome {
    let mut shell = CliShell::new(interrupt_flag());
    let options = RunOptions {
        identify_only: true,
        ..RunOptions::default()
    };
    // The target is replaced by whatever the device confirms.
    conn.session.run_plan(
        Graph::nominal(),
        geometry::TrunkState::AS_MANUFACTURED,
        options,
        &mut shell,
    )
}

/// Runs `host-tool identify`.
pub fn run(args: Args) -> Result<(), Failure> {
    let device = args.device.validate(None)?;
    let mut conn = device.connect()?;
    let out = identify(&mut conn);
    let truth = conn.close();
    let candidates: Vec<&str> = out
        .last_status
        .as_ref()
        .map(|s| s.candidates.iter().map(|c| c.name()).collect())
        .unwrap_or_default();
    if args.json {
        crate::cli::print_json(json!({
            "ok": out.ok(),
            "state": out.final_state.map(|s| s.name()),
            "state_confirmed": out.state_confirmed,
            "identified": out.identified,
            "candidates": candidates,
            "error": out.error(),
            "sim": truth.as_ref().map(crate::sim::SimTruth::to_json),
        }));
    } else if out.ok() {
        crate::out!(
            "the trunk is {} (confirmed{})",
            out.final_state.map_or("?", |s| s.name()),
            if out.identified {
                ", just identified"
            } else {
                " already"
            }
        );
    }
    if out.ok() {
        Ok(())
    } else {
        Err(Failure::Runtime(anyhow::anyhow!(
            "{}",
            out.error()
                .unwrap_or("the device's state is still unconfirmed")
        )))
    }
}
