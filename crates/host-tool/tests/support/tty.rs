//! Running `host-tool` on a pseudo-terminal of a given width, as a person's terminal runs it:
//! stdin, stdout and stderr are the terminal, which is also its controlling terminal (so ^C
//! typed on it is a SIGINT from the line discipline, as at a keyboard).

#![allow(dead_code)]

use std::fs::File;
use std::io::{Read, Write};
use std::os::fd::OwnedFd;
use std::os::unix::process::CommandExt as _;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// What the terminal has shown so far, and whether the program closed it.
#[derive(Default)]
struct Screen {
    bytes: Vec<u8>,
    closed: bool,
}

/// `host-tool` running on a pty.
pub struct Tty {
    child: Child,
    master: File,
    screen: Arc<(Mutex<Screen>, Condvar)>,
}

impl Tty {
    /// Starts `host-tool ARGS` on a new pty of `cols` columns (TIOCSWINSZ at creation), with
    /// `env` set and `COLUMNS`/`CRANE_PORT` removed unless `env` sets them.
    pub fn spawn(args: &[&str], cols: u16, env: &[(&str, &str)]) -> Tty {
        let size = nix::pty::Winsize {
            ws_row: 40,
            ws_col: cols,
            ws_xpixel: 0,
            ws_ypixel: 0,
        };
        let pty = nix::pty::openpty(Some(&size), None).expect("a pty");
        let slave = |fd: &OwnedFd| Stdio::from(fd.try_clone().expect("dup the pty"));
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_host-tool"));
        cmd.args(args)
            .env_remove("COLUMNS")
            .env_remove("CRANE_PORT")
            .envs(env.iter().copied())
            .stdin(slave(&pty.slave))
            .stdout(slave(&pty.slave))
            .stderr(slave(&pty.slave));
        // SAFETY: runs in the child between fork and exec and calls only async-signal-safe
        // functions (setsid, ioctl) on the child's own stdin, which is the pty's slave: a new
        // session whose controlling terminal is the pty.
        unsafe {
            cmd.pre_exec(|| {
                if nix::libc::setsid() == -1
                    || nix::libc::ioctl(0, nix::libc::TIOCSCTTY as _, 0) == -1
                {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        let child = cmd.spawn().expect("host-tool starts on the pty");
        // Only the child holds the slave now: the master reads EOF (EIO) once it exits.
        drop(pty.slave);
        let master = File::from(pty.master);
        let screen = Arc::new((Mutex::new(Screen::default()), Condvar::new()));
        let mut reader = master.try_clone().expect("dup the master");
        let shared = screen.clone();
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            loop {
                let n = reader.read(&mut buf).unwrap_or(0);
                let (lock, cv) = &*shared;
                let mut s = lock.lock().expect("screen");
                if n == 0 {
                    s.closed = true;
                    cv.notify_all();
                    return;
                }
                s.bytes.extend_from_slice(&buf[..n]);
                cv.notify_all();
            }
        });
        Tty {
            child,
            master,
            screen,
        }
    }

    /// Everything shown so far.
    pub fn text(&self) -> String {
        let s = self.screen.0.lock().expect("screen");
        String::from_utf8_lossy(&s.bytes).into_owned()
    }

    /// Waits until the output holds `needle` (true) or `limit` passes or the program closes
    /// the terminal without it (false).
    pub fn wait_for(&self, needle: &str, limit: Duration) -> bool {
        let deadline = Instant::now() + limit;
        let (lock, cv) = &*self.screen;
        let mut s = lock.lock().expect("screen");
        loop {
            if String::from_utf8_lossy(&s.bytes).contains(needle) {
                return true;
            }
            let now = Instant::now();
            if s.closed || now >= deadline {
                return false;
            }
            s = cv.wait_timeout(s, deadline - now).expect("screen").0;
        }
    }

    /// Types `bytes` on the terminal (`b"\x03"` is ^C).
    pub fn type_keys(&mut self, bytes: &[u8]) {
        self.master.write_all(bytes).expect("write to the pty");
    }

    /// Waits for the program to end (killing it after `limit`) and for the terminal to drain;
    /// gives its exit status and everything it showed.
    pub fn finish(mut self, limit: Duration) -> (ExitStatus, String) {
        let deadline = Instant::now() + limit;
        let status = loop {
            if let Some(status) = self.child.try_wait().expect("wait") {
                break status;
            }
            if Instant::now() >= deadline {
                let _ = self.child.kill();
                panic!(
                    "host-tool did not end within {limit:?}; it showed:\n{}",
                    self.text()
                );
            }
            // Woken by output or after 50 ms, to look at the child again.
            let (lock, cv) = &*self.screen;
            let s = lock.lock().expect("screen");
            let _ = cv.wait_timeout(s, Duration::from_millis(50));
        };
        // The reader sees EOF once the child (and any child of its) closed the slave.
        let (lock, cv) = &*self.screen;
        let mut s = lock.lock().expect("screen");
        let drained = Instant::now() + Duration::from_secs(5);
        while !s.closed && Instant::now() < drained {
            s = cv
                .wait_timeout(s, Duration::from_millis(100))
                .expect("screen")
                .0;
        }
        (status, String::from_utf8_lossy(&s.bytes).into_owned())
    }
}

/// The terminal's lines as a person sees them: split at `\r` and `\n` (a progress bar
/// redraws over its line after `\r`).
pub fn segments(shown: &str) -> Vec<&str> {
    shown
        .split(['\r', '\n'])
        .filter(|l| !l.is_empty())
        .collect()
}

/// Display columns of a line, escape sequences (colours, cursor moves) not counted.
pub fn columns(line: &str) -> usize {
    textwrap::core::display_width(line)
}
