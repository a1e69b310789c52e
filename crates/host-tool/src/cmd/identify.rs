//! `host-tool identify`: have the device identify an unconfirmed trunk state — its own probes
//! first, then the operator among the candidates the probes leave — and report the state it
//! then confirms. A confirmed state is reported at once.

use host::RunOptions;
use planner::graph::Graph;
use serde_json::json;

use crate::device::{Connection, DeviceArgs};
use crate::failure::Failure;
use crate::shell::{interrupt_flag, CliShell};

/// Arguments of `host-tool identify`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Print one JSON object on stdout.
    #[arg(skip)]
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

/// What `identify` prints for the state the device reports after identifying: JSON, or the
/// line that says it is confirmed; an unconfirmed end is the error.
fn report(
    json: bool,
    ok: bool,
    state: Option<&str>,
    identified: bool,
    v: serde_json::Value,
    error: Option<&str>,
) -> Result<(), Failure> {
    if json {
        crate::cli::print_json(v);
    } else if ok {
        crate::out!(
            "the trunk is {} (confirmed{})",
            state.unwrap_or("?"),
            if identified {
                ", just identified"
            } else {
                " already"
            }
        );
    }
    if ok {
        Ok(())
    } else {
        Err(Failure::Runtime(anyhow::anyhow!(
            "{}",
            error.unwrap_or("the device's state is still unconfirmed")
        )))
    }
}

/// `identify` through a `serve` server: it runs the identification (its simulated operator
/// answers on `--sim`; on a crane, the crane's confirm button or `host-tool declare` from
/// another terminal), this client prints its notes and the outcome.
fn through_server(server: &std::path::Path, args: &Args) -> Result<(), Failure> {
    let (o, ok) = crate::client::run(server, &crate::serve_protocol::Request::Identify)?;
    // A confirmed state's candidates are that state, as the device reports them.
    let candidates = match (&o.candidates, o.state_confirmed, &o.final_state) {
        (None, true, Some(s)) => Some(vec![s.clone()]),
        (c, ..) => c.clone(),
    };
    let out = json!({
        "ok": ok,
        "state": o.final_state,
        "state_confirmed": o.state_confirmed,
        "identified": o.identified,
        "candidates": candidates,
        "error": o.error,
        "sim": o.sim.as_ref().map(crate::sim::SimTruth::to_json),
    });
    report(
        args.json,
        ok,
        o.final_state.as_deref(),
        o.identified,
        out,
        o.error.as_deref(),
    )
}

/// Runs `host-tool identify`.
pub fn run(args: Args) -> Result<(), Failure> {
    if let Some(server) = crate::client::server_for(&args.device)? {
        return through_server(&server, &args);
    }
    let device = args.device.validate(None)?;
    let mut conn = device.connect()?;
    let out = identify(&mut conn);
    let truth = conn.close();
    let candidates: Vec<&str> = out.candidates.iter().map(|c| c.name()).collect();
    let v = json!({
        "ok": out.ok(),
        "state": out.final_state.map(|s| s.name()),
        "state_confirmed": out.state_confirmed,
        "identified": out.identified,
        "candidates": candidates,
        "error": out.error(),
        "sim": truth.as_ref().map(crate::sim::SimTruth::to_json),
    });
    report(
        args.json,
        out.ok(),
        out.final_state.map(|s| s.name()),
        out.identified,
        v,
        out.error(),
    )
}
