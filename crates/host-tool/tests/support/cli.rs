//! Running `host-tool` in the CLI tests: one command run to its end ([`host_tool`], with
//! [`json`] and [`usage_error`] on top), and, for tests that start servers, each test with its
//! own socket directory (XDG_RUNTIME_DIR, [`cmd`]), so servers of parallel tests never meet.

#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

use serde_json::Value;

/// `host-tool ARGS` run to its end, with no stdin and without the caller's $CRANE_PORT and
/// $COLUMNS (a developer's shell does not change what the tests see).
pub fn host_tool(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .args(args)
        .env_remove("CRANE_PORT")
        .env_remove("COLUMNS")
        .stdin(Stdio::null())
        .output()
        .expect("host-tool runs")
}

/// The one JSON document `host-tool ARGS` prints on success (a failure fails the test with
/// its stderr).
pub fn json(args: &[&str]) -> Value {
    let out = host_tool(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("valid JSON")
}

/// `host-tool ARGS` is a usage error (exit 2) whose message has `expect`, and no panic.
pub fn usage_error(args: &[&str], expect: &str) {
    let out = host_tool(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(stderr.contains(expect), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
}

/// A file `name` holding `text` in the test binary `test`'s own directory.
pub fn temp_file(test: &str, name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("{test}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write temp file");
    p
}

/// `host-tool ARGS` with its socket directory in `dir` and no stdin.
pub fn cmd(dir: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_host-tool"));
    c.args(args)
        .env("XDG_RUNTIME_DIR", dir)
        .stdin(Stdio::null());
    c
}

/// A fresh, empty directory for the test `name`.
pub fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Starts `host-tool serve ARGS` and returns it with its first stderr line (the "serving …"
/// line, printed once it listens); its stderr is drained from then on so it never blocks.
pub fn serve(dir: &Path, args: &[&str]) -> (Child, String) {
    let mut child = cmd(dir, args).stderr(Stdio::piped()).spawn().unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    err.read_line(&mut line).unwrap();
    std::thread::spawn(move || for _ in err.lines() {});
    (child, line)
}

/// Reads `child`'s stderr until a line that starts with `prefix`, sends the child `signal`,
/// then reads its stderr to the end: everything it said. A child that ends first fails the
/// test, naming what it said.
pub fn signal_at_line(child: &mut Child, prefix: &str, signal: nix::sys::signal::Signal) -> String {
    use std::io::Read;
    let mut err = BufReader::new(child.stderr.take().expect("stderr piped"));
    let mut seen = String::new();
    loop {
        let mut line = String::new();
        assert!(
            err.read_line(&mut line).unwrap() > 0,
            "no line starting '{prefix}' in:\n{seen}"
        );
        seen.push_str(&line);
        if line.starts_with(prefix) {
            break;
        }
    }
    nix::sys::signal::kill(nix::unistd::Pid::from_raw(child.id() as i32), signal).unwrap();
    err.read_to_string(&mut seen).unwrap();
    seen
}
