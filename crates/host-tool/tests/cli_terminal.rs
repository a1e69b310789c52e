//! `host-tool` on a terminal, as a person runs it: a pseudo-terminal 60 columns wide (its
//! window size set with TIOCSWINSZ), the progress bar drawn on it, ^C typed on it.

use std::time::Duration;

#[path = "support/tty.rs"]
mod tty;

use tty::{columns, segments, Tty};

const LIMIT: Duration = Duration::from_secs(60);

#[test]
fn on_a_60_column_terminal_the_progress_bar_and_every_line_fit_and_why_lines_wrap() {
    // ×8: the 12 s plan takes 1.5 s of wall time, long enough for the bars to be drawn.
    let t = Tty::spawn(
        &["plan", "--target", "D&F", "--sim", "--sim-speed", "8"],
        60,
        &[],
    );
    let (status, shown) = t.finish(LIMIT);
    assert_eq!(status.code(), Some(0), "{shown}");
    // The bar was drawn (its message carries the pressure), over its own line.
    assert!(
        segments(&shown)
            .iter()
            .any(|l| l.contains("step 1/2") && l.contains(" kPa")),
        "no progress bar drawn:\n{shown}"
    );
    for line in segments(&shown) {
        assert!(
            columns(line) <= 60,
            "{} columns on a 60-column terminal: {line:?}\n{shown}",
            columns(line)
        );
    }
    // The "why" lines, longer than 60 columns whole (see a pipe's), continue on the next line,
    // indented under their start.
    let piped = std::process::Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .args(["plan", "--target", "D&F", "--dry-run"])
        .env_remove("COLUMNS")
        .output()
        .expect("runs");
    let whole = String::from_utf8_lossy(&piped.stdout);
    let long_why = whole
        .lines()
        .find(|l| l.trim_start().starts_with("why:") && l.chars().count() > 60)
        .unwrap_or_else(|| panic!("a why line longer than 60 columns: {whole}"));
    let lines: Vec<&str> = shown.lines().map(|l| l.trim_end_matches('\r')).collect();
    let at = lines
        .iter()
        .position(|l| long_why.starts_with(l.trim_end()) && l.contains("why:"))
        .unwrap_or_else(|| panic!("the why line is not shown wrapped:\n{shown}"));
    let indent = |l: &str| l.len() - l.trim_start().len();
    let base = indent(lines[at]);
    let paragraph: Vec<&str> = std::iter::once(lines[at])
        .chain(
            lines[at + 1..]
                .iter()
                .copied()
                .take_while(|l| indent(l) == base + 2),
        )
        .collect();
    assert!(paragraph.len() > 1, "not wrapped: {paragraph:?}");
    assert_eq!(
        paragraph.join(" ").split_whitespace().collect::<Vec<_>>(),
        long_why.split_whitespace().collect::<Vec<_>>(),
        "{shown}"
    );
}

#[test]
fn ctrl_c_typed_on_the_terminal_mid_plan_aborts_it_and_exits_130() {
    let mut t = Tty::spawn(
        &["plan", "--target", "D&F", "--sim", "--sim-speed", "2"],
        80,
        &[],
    );
    assert!(
        t.wait_for("step 1/2", LIMIT),
        "the first step never started:\n{}",
        t.text()
    );
    t.type_keys(b"\x03");
    let (status, shown) = t.finish(LIMIT);
    assert_eq!(status.code(), Some(130), "{shown}");
    assert!(shown.contains("aborted by the operator"), "{shown}");
    assert!(shown.contains("its safe state"), "{shown}");
}
