//! The lines a person types on the terminal, read by one thread for the whole process.
//!
//! Reading stdin blocks, so it happens on a thread. There is one such thread, started at the
//! first use: a reader per use would outlive its use and swallow the next line typed for
//! another (an Enter meant for "place the object" taken by the previous plan's reader).

use std::io::IsTerminal;
use std::sync::mpsc::{self, Receiver};
use std::sync::{Mutex, OnceLock};

/// The process's reader: `None` when stdin is not a terminal (never block on a pipe or
/// /dev/null).
fn reader() -> Option<&'static Mutex<Receiver<String>>> {
    static LINES: OnceLock<Option<Mutex<Receiver<String>>>> = OnceLock::new();
    LINES
        .get_or_init(|| {
            if !std::io::stdin().is_terminal() {
                return None;
            }
            let (tx, rx) = mpsc::channel();
            std::thread::spawn(move || {
                let mut line = String::new();
                while std::io::stdin().read_line(&mut line).is_ok_and(|n| n > 0) {
                    if tx.send(std::mem::take(&mut line)).is_err() {
                        break;
                    }
                }
            });
            Some(Mutex::new(rx))
        })
        .as_ref()
}

/// Whether a person can type answers: stdin is a terminal.
pub fn available() -> bool {
    reader().is_some()
}

/// The next line typed, if one is waiting (never blocks).
pub fn try_line() -> Option<String> {
    let rx = reader()?.lock().unwrap_or_else(|e| e.into_inner());
    rx.try_recv().ok()
}

/// Forgets what was typed before now (a line typed ahead answers no question asked later).
pub fn discard_typed() {
    while try_line().is_some() {}
}

/// Waits for the next line typed; `None` when stdin is not a terminal or was closed.
pub fn next_line() -> Option<String> {
    let rx = reader()?.lock().unwrap_or_else(|e| e.into_inner());
    rx.recv().ok()
}
