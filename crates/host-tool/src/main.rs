//! `host-tool`: the command line of the Yoshimura crane.
//!
//! Arguments are parsed by clap, validated into a config once, then the command runs.
//! Exit codes: 0 success, 1 runtime failure (device, link, plan), 2 usage error.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// A line on stderr. A closed stderr (the terminal went away) is no reason to die mid-plan:
/// the run goes on to its safe end.
#[macro_export]
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

/// Text on stderr without a newline (as [`say!`]).
#[macro_export]
macro_rules! say_raw {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stderr(), $($t)*);
    }};
}

/// A line on stdout; a closed stdout (`| head`) ends nothing abruptly.
#[macro_export]
macro_rules! out {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

/// Text on stdout without a newline (as [`out!`]).
#[macro_export]
macro_rules! out_raw {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($t)*);
    }};
}

mod client;
mod cmd;
mod device;
mod failure;
mod figure;
mod live;
mod progress;
mod record;
mod scene;
mod sim;
mod transport;

/// Design, plan and command Yoshimura-origami cranes (or their simulator).
#[derive(Debug, Parser)]
#[command(name = "host-tool", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// The metastable states of one Yoshimura module (n, β).
    States(cmd::states::Args),
    /// Forward kinematics of a stack of modules: the tip of each module.
    Fk(cmd::fk::Args),
    /// Inverse kinematics: fit a stacked boom to a target curve.
    Ik(cmd::ik::Args),
    /// Files to make a trunk: crease pattern (SVG, DXF, FOLD), printable panel (3MF, STL), kit.
    Pattern(cmd::pattern::Args),
    /// A 3D model of a stack in given states: glTF, OBJ, STL (strain of infeasible states in red).
    Model(cmd::model::Args),
    /// Take the crane (--port) or the simulator (--sim) to a trunk state, e.g. --target 'D&F'.
    Plan(cmd::plan::Args),
    /// One status snapshot of the crane (or the simulator).
    Status(cmd::status::Args),
    /// Live telemetry until Ctrl-C or --duration.
    Monitor(cmd::monitor::Args),
    /// Tell the device the trunk's true state (after folding it by hand), e.g. declare 'D&D'.
    Declare(cmd::declare::Args),
    /// Read (`param get [NAME]`) or change (`param set NAME VALUE`) a device parameter.
    Param(cmd::param::Args),
    /// Abort whatever runs; report the safe state.
    Stop(cmd::stop::Args),
    /// Identify an unconfirmed trunk state: the crane's probes, then the operator.
    Identify(cmd::identify::Args),
    /// List serial ports; recognise Arduino UNO R4 boards.
    Ports(cmd::ports::Args),
    /// Read a recording (MCAP): summary, CSV export, pressure/servo plot, recovery.
    Log(cmd::log::Args),
    /// Own the link to a crane (or the simulator), record it, and serve other terminals'
    /// status/stop/declare/monitor/plan over a local socket.
    Serve(cmd::serve::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::States(args) => cmd::states::run(args),
        Command::Fk(args) => cmd::fk::run(args),
        Command::Ik(args) => cmd::ik::run(args),
        Command::Pattern(args) => cmd::pattern::run(args),
        Command::Model(args) => cmd::model::run(args),
        Command::Plan(args) => cmd::plan::run(args),
        Command::Status(args) => cmd::status::run(args),
        Command::Monitor(args) => cmd::monitor::run(args),
        Command::Declare(args) => cmd::declare::run(args),
        Command::Param(args) => cmd::param::run(args),
        Command::Stop(args) => cmd::stop::run(args),
        Command::Identify(args) => cmd::identify::run(args),
        Command::Ports(args) => cmd::ports::run(args),
        Command::Log(args) => cmd::log::run(args),
        Command::Serve(args) => cmd::serve::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => failure.report(),
    }
}
