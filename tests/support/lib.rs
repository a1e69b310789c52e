//! Helpers shared by the end-to-end tests: find the real binaries, run them with a time limit,
//! read their JSON.
//!
//! `cargo test --workspace` builds a package's binaries only for that package's own integration
//! tests, so the binaries are located next to the test executable (`target/<profile>/deps/..`)
//! rather than through `CARGO_BIN_EXE_*` (which only a package's own tests get).
#![forbid(unsafe_code)]

use std::ffi::OsStr;
use std::io::{BufRead, BufReader, Read};
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// The six trunk states, in `TrunkState::ALL` order.
pub const STATES: [&str; 6] = ["F&P", "F&F", "F&D", "D&P", "D&F", "D&D"];

/// The edges the device cannot confirm without a calibration profile (`docs/firmware.md`,
/// "Truth without the simulator's constants"): the fold by hand, the fold over a packed bottom
/// and the two folds under the pinning tendons end unconfirmed, and the operator identifies
/// the state before the plan goes on.
pub const OPERATOR_IDENTIFIED: [(&str, &str); 4] = [
    ("D&F", "D&P"),
    ("D&P", "F&P"),
    ("F&D", "F&F"),
    ("F&F", "F&P"),
];

/// Whether a plan's JSON step `s` ended as it may: confirmed by the device, or (one of
/// [`OPERATOR_IDENTIFIED`]) unconfirmed with the run's state then identified by the operator.
pub fn step_ended_honestly(s: &serde_json::Value, run: &serde_json::Value) -> bool {
    s["ok"] == true
        || (run["identified"] == true
            && OPERATOR_IDENTIFIED
                .iter()
                .any(|(a, b)| s["from"] == *a && s["to"] == *b))
}

/// The path of a workspace binary (`host-tool`, `hil-sim`) built for the same profile as the
/// running test. Panics with the command to run when it is missing.
pub fn binary(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("the test knows its own path");
    // target/<profile>/deps/<test>-<hash> → target/<profile>/<name>
    let dir = exe
        .parent()
        .and_then(|deps| deps.parent())
        .expect("the test runs from target/<profile>/deps");
    let path = dir.join(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    assert!(
        path.is_file(),
        "{} is missing: run `cargo build --workspace --bins` (with the same profile, e.g. \
         --release) before the end-to-end tests",
        path.display()
    );
    path
}

/// What a finished process left.
#[derive(Debug)]
pub struct Output {
    /// Its exit status.
    pub status: ExitStatus,
    /// Everything on stdout.
    pub stdout: String,
    /// Everything on stderr.
    pub stderr: String,
    /// Wall time it took.
    pub elapsed: Duration,
}

impl Output {
    /// The exit code (-1 when killed by a signal).
    pub fn code(&self) -> i32 {
        self.status.code().unwrap_or(-1)
    }

    /// Stdout as one JSON value; panics with both streams when it is not.
    pub fn json(&self) -> serde_json::Value {
        serde_json::from_str(self.stdout.trim()).unwrap_or_else(|e| {
            panic!(
                "stdout is not one JSON value ({e}):\n--- stdout\n{}\n--- stderr\n{}",
                self.stdout, self.stderr
            )
        })
    }
}

/// Runs `program args`, stdin closed, killing it after `limit`; panics on a timeout.
pub fn run(program: &PathBuf, args: &[&str], limit: Duration) -> Output {
    let start = Instant::now();
    let mut child = Command::new(program)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {}: {e}", program.display()));
    let out_reader = drain(child.stdout.take());
    let err_reader = drain(child.stderr.take());
    let Some(status) = wait_with_limit(&mut child, limit) else {
        let _ = child.kill();
        let _ = child.wait();
        panic!(
            "{} {args:?} did not finish within {limit:?}:\n{}",
            program.display(),
            err_reader.join().unwrap_or_default()
        )
    };
    Output {
        status,
        stdout: out_reader.join().unwrap_or_default(),
        stderr: err_reader.join().unwrap_or_default(),
        elapsed: start.elapsed(),
    }
}

/// Runs `host-tool args` with a time limit.
pub fn host_tool(args: &[&str], limit: Duration) -> Output {
    run(&binary("host-tool"), args, limit)
}

fn drain<R: Read + Send + 'static>(pipe: Option<R>) -> std::thread::JoinHandle<String> {
    std::thread::spawn(move || {
        let mut s = String::new();
        if let Some(mut p) = pipe {
            let _ = p.read_to_string(&mut s);
        }
        s
    })
}

fn wait_with_limit(child: &mut Child, limit: Duration) -> Option<ExitStatus> {
    let deadline = Instant::now() + limit;
    loop {
        if let Ok(Some(status)) = child.try_wait() {
            return Some(status);
        }
        if Instant::now() >= deadline {
            return None;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Runs `jobs` on `threads` worker threads and returns their results in order.
pub fn parallel<T: Send, R: Send>(
    jobs: Vec<T>,
    threads: usize,
    f: impl Fn(T) -> R + Sync,
) -> Vec<R> {
    let queue = std::sync::Mutex::new(jobs.into_iter().enumerate().collect::<Vec<_>>());
    let results = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..threads.max(1) {
            scope.spawn(|| loop {
                let job = queue.lock().map(|mut q| q.pop()).ok().flatten();
                let Some((i, job)) = job else { break };
                let r = f(job);
                if let Ok(mut v) = results.lock() {
                    v.push((i, r));
                }
            });
        }
    });
    let mut v = results.into_inner().unwrap_or_default();
    v.sort_by_key(|(i, _)| *i);
    v.into_iter().map(|(_, r)| r).collect()
}

/// A small deterministic byte generator (xorshift64*), so garbage is the same on every run.
pub struct Noise(u64);

impl Noise {
    /// A generator from `seed` (any value).
    pub fn new(seed: u64) -> Self {
        Self(seed | 1)
    }

    /// The next byte.
    pub fn byte(&mut self) -> u8 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 56) as u8
    }

    /// `n` bytes.
    pub fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.byte()).collect()
    }
}

/// A `hil-sim --pty` process, killed when dropped.
pub struct PtyProcess {
    child: Child,
    /// The device path it serves.
    pub path: String,
    /// The line it printed first (naming the path).
    pub first_line: String,
}

impl PtyProcess {
    /// Its process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Waits for it to end (at most 20 s) and gives its exit code (`None`: killed by a signal
    /// or still running).
    pub fn wait_code(mut self) -> Option<i32> {
        wait_with_limit(&mut self.child, Duration::from_secs(20)).and_then(|s| s.code())
    }
}

impl Drop for PtyProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts `hil-sim --pty ARGS…` and waits for the line that names its device path.
pub fn hil_sim_pty<S: AsRef<OsStr>>(args: &[S]) -> PtyProcess {
    let mut child = Command::new(binary("hil-sim"))
        .arg("--pty")
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("hil-sim starts");
    let mut first_line = String::new();
    BufReader::new(child.stdout.take().expect("stdout is piped"))
        .read_line(&mut first_line)
        .expect("hil-sim prints its device path");
    let path = first_line
        .split_whitespace()
        .last()
        .expect("a path")
        .to_string();
    PtyProcess {
        child,
        path,
        first_line,
    }
}
