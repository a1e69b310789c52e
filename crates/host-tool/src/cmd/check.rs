//! `host-tool check`: the pre-flight check.

use crate::device::DeviceArgs;
use crate::failure::Failure;

/// Arguments of `host-tool check`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Print one JSON object.
    #[arg(short = 'j', long)]
    pub json: bool,
}

/// Runs `host-tool check`.
pub fn run(_args: Args) -> Result<(), Failure> {
    Ok(())
}
