//! `hil-sim swarm` as a user runs it: the JSON report, a replay, and the edges of its ranges.

use std::time::Duration;

use e2e::{binary, run};

const LIMIT: Duration = Duration::from_secs(60);

#[test]
fn a_swarm_reports_runs_hours_and_violations_as_json() {
    let out = run(
        &binary("hil-sim"),
        &[
            "swarm",
            "--runs",
            "2",
            "--seed",
            "7",
            "--threads",
            "1",
            "--no-operator-mistakes",
            "--json",
        ],
        LIMIT,
    );
    assert_eq!(out.code(), 0, "{}", out.stderr);
    let v = out.json();
    assert_eq!(v["runs"], 2);
    assert!(v["virtual_hours"].as_f64().unwrap() > 0.0, "{v}");
    assert_eq!(v["violations"].as_array().unwrap().len(), 0, "{v}");
}

#[test]
fn a_replay_prints_the_scenario_and_its_trace() {
    let out = run(
        &binary("hil-sim"),
        &["swarm", "--replay", "12", "--no-operator-mistakes"],
        LIMIT,
    );
    assert_eq!(out.code(), 0, "{}", out.stderr);
    assert!(out.stdout.starts_with("seed 12:"), "{}", out.stdout);
    assert!(out.stdout.contains("power cut"), "{}", out.stdout);
    assert!(out.stdout.contains("0 violation(s)"), "{}", out.stdout);
}

#[test]
fn values_outside_the_ranges_are_usage_errors() {
    for args in [
        &["swarm", "--runs", "0"][..],
        &["swarm", "--runs", "10000001"][..],
        &["swarm", "--threads", "0"][..],
        &["swarm", "--threads", "257"][..],
        // Any integer is a seed (negative ones modulo 2^64, as host-tool); a fraction is not.
        &["swarm", "--seed", "1.5"][..],
    ] {
        let out = run(&binary("hil-sim"), args, LIMIT);
        assert_eq!(out.code(), 2, "{args:?}: {}", out.stderr);
    }
}
