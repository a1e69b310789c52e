//! How a command fails: a usage error (exit 2), a runtime failure (exit 1), or an interrupt
//! (exit 130, after the crane was made safe).

use std::io::Write as _;
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

    /// Prints the failure on stderr (and with `json`, unless the command printed its own JSON
    /// already, one error object on stdout) and returns its exit code.
    pub fn report(self, json: bool) -> std::process::ExitCode {
        let (code, prefix, message, device) = match &self {
            Failure::Usage(msg) => (2u8, "error", msg.clone(), None),
            Failure::Runtime(err) => (
                1,
                "error",
                format!("{err:#}"),
                err.downcast_ref::<crate::cli::DeviceError>(),
            ),
            Failure::Interrupted(msg) => (130, "interrupted", msg.clone(), None),
        };
        if json && !crate::cli::json_printed() {
            crate::cli::print_json(crate::cli::error_json(&message, code, device));
        }
        // Errors are shown even with -q; a closed stderr is no reason to panic.
        let _ = writeln!(
            std::io::stderr(),
            "{prefix}: {}",
            crate::cli::wrap(&message).trim_end()
        );
        ExitCode::from(code)
    }
}

impl From<anyhow::Error> for Failure {
    fn from(err: anyhow::Error) -> Self {
        Failure::Runtime(err)
    }
}
