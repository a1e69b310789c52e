//! Usage errors exit 2 and say what is valid; nothing is opened.

use std::time::Duration;

use e2e::{host_tool, STATES};

const LIMIT: Duration = Duration::from_secs(20);

#[test]
fn an_invalid_target_exits_2_listing_the_six_states() {
    let out = host_tool(&["plan", "--target", "X&Y"], LIMIT);
    assert_eq!(out.code(), 2, "{}", out.stderr);
    assert!(out.stderr.contains("X&Y"), "{}", out.stderr);
    for s in STATES {
        assert!(out.stderr.contains(s), "{s} missing from: {}", out.stderr);
    }
    // Rejected before any device was opened: no simulator announcement.
    assert!(!out.stderr.contains("simulator on"), "{}", out.stderr);
}

#[test]
fn simulator_options_with_a_port_exit_2() {
    let out = host_tool(
        &[
            "plan",
            "--target",
            "D&F",
            "--port",
            "/dev/ttyACM9",
            "--sim-fault",
            "leak",
        ],
        LIMIT,
    );
    assert_eq!(out.code(), 2, "{}", out.stderr);
    assert!(out.stderr.contains("--sim-fault"), "{}", out.stderr);
}

#[test]
fn an_unknown_fault_exits_2_listing_the_faults() {
    let out = host_tool(
        &["plan", "--target", "D&F", "--sim-fault", "gremlins"],
        LIMIT,
    );
    assert_eq!(out.code(), 2, "{}", out.stderr);
    for f in [
        "valve-stuck-closed",
        "servo-stall",
        "link-drop",
        "line-noise",
    ] {
        assert!(out.stderr.contains(f), "{f} missing from: {}", out.stderr);
    }
}

#[test]
fn a_missing_port_is_a_runtime_failure_naming_it() {
    let out = host_tool(
        &["status", "--port", "/dev/does-not-exist-crane", "--json"],
        LIMIT,
    );
    assert_eq!(out.code(), 1, "{}", out.stderr);
    assert!(
        out.stderr.contains("/dev/does-not-exist-crane"),
        "{}",
        out.stderr
    );
}

#[test]
fn a_dry_run_prints_the_plan_and_starts_nothing() {
    let out = host_tool(
        &[
            "plan",
            "--target",
            "D&P",
            "--dry-run",
            "--from",
            "F&P",
            "--json",
        ],
        LIMIT,
    );
    assert_eq!(out.code(), 0, "{}", out.stderr);
    let v = out.json();
    let steps = v["steps"].as_array().unwrap();
    let path: Vec<(&str, &str, &str)> = steps
        .iter()
        .map(|s| {
            (
                s["kind"].as_str().unwrap(),
                s["from"].as_str().unwrap(),
                s["to"].as_str().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        path,
        [
            ("pneumatic", "F&P", "F&F"),
            ("pneumatic", "F&F", "D&F"),
            ("manual", "D&F", "D&P")
        ]
    );
    assert!(!out.stderr.contains("simulator on"), "{}", out.stderr);
}
