//! The conventions every command shares: how much is said (`-q` errors only, `-v` debug
//! detail), JSON on stdout (one object, numbers tidied; an error object on failure), a closed
//! stdout noticed, the terminal's width, and the version line.

use std::io::Write as _;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

use serde_json::Value;

/// 0: errors only (`-q`), 1: normal, 2: debug detail (`-v`: frames decoded, retries,
/// timings), 3+: and each frame's bytes (`-vv`).
static VERBOSITY: AtomicU8 = AtomicU8::new(1);
/// A JSON object (or the first JSON line) was printed on stdout.
static JSON_PRINTED: AtomicBool = AtomicBool::new(false);
/// A write to stdout failed (`| head` closed it): the command ends quietly.
static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Sets how much is said: `quiet` → errors only; each `verbose` → more detail.
pub fn set_verbosity(quiet: bool, verbose: u8) {
    let level = if quiet { 0 } else { 1 + verbose };
    VERBOSITY.store(level, Ordering::Relaxed);
}

/// Whether notes and progress are shown (not `-q`).
pub fn notes() -> bool {
    VERBOSITY.load(Ordering::Relaxed) >= 1
}

/// Whether debug detail is shown (`-v`).
pub fn debug() -> bool {
    VERBOSITY.load(Ordering::Relaxed) >= 2
}

/// Whether each frame's bytes are shown too (`-vv`).
pub fn trace_bytes() -> bool {
    VERBOSITY.load(Ordering::Relaxed) >= 3
}

/// Writes `text` to stdout; a failed write marks stdout closed (see [`stdout_closed`]).
pub fn write_stdout(args: std::fmt::Arguments<'_>) {
    let mut out = std::io::stdout().lock();
    if out.write_fmt(args).and_then(|()| out.flush()).is_err() {
        STDOUT_CLOSED.store(true, Ordering::SeqCst);
    }
}

/// Whether stdout went away (a reader such as `head` closed it).
pub fn stdout_closed() -> bool {
    STDOUT_CLOSED.load(Ordering::SeqCst)
}

/// Prints one JSON value on its own line, numbers tidied (`crate::num::clean`).
pub fn print_json(v: Value) {
    JSON_PRINTED.store(true, Ordering::SeqCst);
    write_stdout(format_args!("{}\n", crate::num::clean(v)));
}

/// Prints JSON text built in order (`states`, `fk`, `ik` keep their keys' order), its numbers
/// already tidied.
pub fn print_json_text(text: &str) {
    JSON_PRINTED.store(true, Ordering::SeqCst);
    write_stdout(format_args!("{text}\n"));
}

/// Whether the command already printed its JSON (then a failure adds no second object).
pub fn json_printed() -> bool {
    JSON_PRINTED.load(Ordering::SeqCst)
}

/// Columns to wrap text to on stderr: `COLUMNS` when set, else the terminal's width, else none
/// (a pipe or a file gets the lines whole).
pub fn width() -> Option<usize> {
    if let Some(c) = std::env::var("COLUMNS")
        .ok()
        .and_then(|c| c.trim().parse::<usize>().ok())
        .filter(|&c| c >= 20)
    {
        return Some(c);
    }
    console::Term::stderr()
        .size_checked()
        .map(|(_, cols)| usize::from(cols))
        .filter(|&c| c >= 20)
}

/// `text` wrapped to [`width`]; continuation lines keep the first line's indent plus two.
pub fn wrap(text: &str) -> String {
    let Some(w) = width() else {
        return text.to_string();
    };
    let mut out = String::with_capacity(text.len() + 16);
    for line in text.split_inclusive('\n') {
        let (body, nl) = match line.strip_suffix('\n') {
            Some(b) => (b, "\n"),
            None => (line, ""),
        };
        if textwrap::core::display_width(body) <= w {
            out.push_str(line);
            continue;
        }
        let indent = body.len() - body.trim_start().len();
        let rest = " ".repeat(indent + 2);
        let opts = textwrap::Options::new(w)
            .initial_indent(&body[..indent])
            .subsequent_indent(&rest);
        out.push_str(&textwrap::fill(body.trim_start(), opts));
        out.push_str(nl);
    }
    out
}

/// The git commit this binary was built from (`unknown` when built without a `.git`).
pub const GIT_COMMIT: &str = env!("HOST_TOOL_GIT_COMMIT");

/// The version line: the crate version, the protocol version, the wire schema id and the
/// commit.
pub fn version() -> String {
    format!(
        "{} (protocol {}, schema {:#010x}, commit {})",
        env!("CARGO_PKG_VERSION"),
        protocol::PROTOCOL_VERSION,
        protocol::SCHEMA_ID,
        GIT_COMMIT
    )
}

/// What an exit code means, for the JSON error object and the docs.
pub fn exit_meaning(code: u8) -> &'static str {
    match code {
        0 => "success",
        1 => "runtime failure (device, link, plan or I/O)",
        2 => "usage error (nothing was sent to a device)",
        130 => "interrupted (SIGINT, SIGTERM or SIGHUP; the crane was made safe first)",
        _ => "failure",
    }
}

/// The JSON error object of a failed command: `{"ok": false, "error", "exit_code", "exit",
/// "fault_code", "reject", "refused"}`.
pub fn error_json(message: &str, code: u8, device: Option<&DeviceError>) -> Value {
    serde_json::json!({
        "ok": false,
        "error": message,
        "exit_code": code,
        "exit": exit_meaning(code),
        "fault_code": device.and_then(|d| d.fault_code.clone()),
        "reject": device.and_then(|d| d.reject),
        "refused": device.and_then(|d| d.refused.clone()),
    })
}

/// A device's refusal or fault, kept beside the message so `--json` can give its codes.
#[derive(Debug)]
pub struct DeviceError {
    /// For people.
    pub message: String,
    /// `E-04`, where the device reported a fault.
    pub fault_code: Option<String>,
    /// `out-of-range`, where the device refused.
    pub reject: Option<&'static str>,
    /// `{"step", "field", "value", "limit"}`, where the refusal named a field.
    pub refused: Option<Value>,
}

impl std::fmt::Display for DeviceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for DeviceError {}

/// The JSON form of a device's named refusal.
pub fn refusal_json(r: &protocol::Refusal) -> Value {
    serde_json::to_value(Refused::of(r)).unwrap_or(Value::Null)
}

/// A device's refusal that names a field: `{"step", "field", "value", "limit"}`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
pub struct Refused {
    /// The refused step, 1-based (none: the plan as a whole).
    pub step: Option<u16>,
    /// The field (`host::text::refused_field_name`).
    pub field: String,
    /// Its value (null: not a number).
    pub value: Option<f64>,
    /// The limit it broke (null: not a number).
    pub limit: Option<f64>,
}

impl Refused {
    /// The refusal `r`, its numbers as the `f32`s they are (`num::widen`).
    pub fn of(r: &protocol::Refusal) -> Self {
        let number = |x: f32| x.is_finite().then(|| crate::num::widen(x));
        Self {
            step: r.step.map(|s| u16::from(s) + 1),
            field: host::text::refused_field_name(r.field).to_string(),
            value: number(r.value),
            limit: number(r.limit),
        }
    }
}

impl DeviceError {
    /// A session error, with its refusal's codes.
    pub fn session(context: &str, e: &host::SessionError) -> Self {
        let (reject, refused) = match e {
            host::SessionError::Rejected {
                reason, refusal, ..
            } => (
                Some(host::text::reject_name(*reason)),
                refusal.as_ref().map(refusal_json),
            ),
            _ => (None, None),
        };
        Self {
            message: if context.is_empty() {
                e.to_string()
            } else {
                format!("{context}{e}")
            },
            fault_code: None,
            reject,
            refused,
        }
    }
}
