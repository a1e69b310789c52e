//! `host-tool fk` (skeleton; filled in by its issue).

use crate::failure::Failure;

/// Arguments of `host-tool fk`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `host-tool fk`.
pub fn run(_args: Args) -> Result<(), Failure> {
    Err(Failure::Runtime(anyhow::anyhow!("`fk` is not implemented yet")))
}
