//! How a command fails: a usage error (exit 2), a runtime failure (exit 1), or an interrupt
//! (exit 130, after the crane was made safe).

use std::process::ExitCode;

/// Why a command did not succeed.
#[derive(Debug)]
pub enum Failure {
    /// The user asked for something invalid; the message says what is valid. Exit code 2.
    Usage(String),
    /// The command was valid but failed (device, link, plan, I/O). Exit code 1.
    Runtime(anyhow::Error),
    /// Stopped by SIGINT, SIGTERM or SIGHUP after making the crane safe. Exit code 130.
    Interrupted(String),
}

impl Failure {
    /// A usage error with `message`.
    pub fn usage(message: impl Into<String>) -> Self {
        Failure::Usage(message.into())
    }

    /// Prints the failure on stderr and returns its exit code.
    pub fn report(self) -> std::process::ExitCode {
        match self {
            Failure::Usage(msg) => {
                crate::say!("error: {msg}");
                ExitCode::from(2)
            }
            Failure::Runtime(err) => {
                crate::say!("error: {err:#}");
                ExitCode::from(1)
            }
            Failure::Interrupted(msg) => {
                crate::say!("interrupted: {msg}");
                ExitCode::from(130)
            }
        }
    }
}

impl From<anyhow::Error> for Failure {
    fn from(err: anyhow::Error) -> Self {
        Failure::Runtime(err)
    }
}
