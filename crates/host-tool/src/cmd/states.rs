//! `host-tool states` (skeleton; filled in by its issue).

use crate::failure::Failure;

/// Arguments of `host-tool states`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `host-tool states`.
pub fn run(_args: Args) -> Result<(), Failure> {
    Err(Failure::Runtime(anyhow::anyhow!("`states` is not implemented yet")))
}
