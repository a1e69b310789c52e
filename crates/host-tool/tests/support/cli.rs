//! Running `host-tool` in the CLI tests: each test has its own socket directory
//! (XDG_RUNTIME_DIR), so servers of parallel tests never meet.

#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

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
