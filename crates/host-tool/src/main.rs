//! `host-tool`: the command line of the Yoshimura crane.
//!
//! Arguments are parsed by clap, validated into a config once, then the command runs.
//! Exit codes: 0 success, 1 runtime failure (device, link, plan), 2 usage error.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cmd;
mod failure;

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
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::States(args) => cmd::states::run(args),
        Command::Fk(args) => cmd::fk::run(args),
        Command::Ik(args) => cmd::ik::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => failure.report(),
    }
}
