//! `host-tool ik` (skeleton; filled in by its issue).

use crate::failure::Failure;

/// Arguments of `host-tool ik`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `host-tool ik`.
pub fn run(_args: Args) -> Result<(), Failure> {
    Err(Failure::Runtime(anyhow::anyhow!(
        "`ik` is not implemented yet"
    )))
}
