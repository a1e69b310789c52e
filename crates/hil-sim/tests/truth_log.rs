//! `hil-sim --pty --truth-log FILE`: the ground truth for outside clients, ended by a signal.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};

#[test]
fn the_truth_log_gets_a_first_line_and_a_last_one_at_sigterm() {
    let dir = std::env::temp_dir().join(format!("hil-sim-truth-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("truth.jsonl");
    let _ = std::fs::remove_file(&path);
    let mut child = Command::new(env!("CARGO_BIN_EXE_hil-sim"))
        .args(["--pty", "--initial", "D&F", "--truth-log"])
        .arg(&path)
        .stdout(Stdio::piped())
        .spawn()
        .expect("hil-sim starts");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    assert!(line.contains("/dev/"), "{line}");
    let status = Command::new("sh")
        .arg("-c")
        .arg(format!("kill -TERM {}", child.id()))
        .status()
        .unwrap();
    assert!(status.success());
    let exit = child.wait().unwrap();
    assert_eq!(
        exit.code(),
        Some(130),
        "SIGTERM ends it cleanly, as an interrupt: {exit:?}"
    );
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).expect("one JSON object per line"))
        .collect();
    assert!(lines.len() >= 2, "{text}");
    for v in &lines {
        for key in ["t_ms", "true_state", "pressure_kpa", "actuators_safe"] {
            assert!(v.get(key).is_some(), "{key} missing in {v}");
        }
    }
    assert_eq!(lines[0]["true_state"], "D&F");
    assert_eq!(lines[0]["t_ms"], 0);
    let last = lines.last().unwrap();
    assert_eq!(last["true_state"], "D&F");
    assert_eq!(last["actuators_safe"], true);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_truth_log_without_the_pty_is_a_usage_error() {
    let out = Command::new(env!("CARGO_BIN_EXE_hil-sim"))
        .args(["--truth-log", "/tmp/x.jsonl"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--pty"));
}
