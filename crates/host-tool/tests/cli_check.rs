//! `host-tool check` through the binary: the simulator's crane passes every line it can check,
//! each injected fault fails the line that sees it (with its fault code), and what no line can
//! see is said, never passed.

#[path = "support/cli.rs"]
mod cli;

use cli::cmd;
use serde_json::Value;

fn check(dir: &std::path::Path, extra: &[&str]) -> (i32, Value) {
    let mut args = vec!["check", "--sim", "-j"];
    args.extend_from_slice(extra);
    let out = cmd(dir, &args).output().unwrap();
    let v = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stderr)));
    (out.status.code().unwrap_or(-1), v)
}

fn line<'a>(v: &'a Value, name: &str) -> &'a Value {
    v["lines"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["name"] == name)
        .unwrap_or_else(|| panic!("no line '{name}' in {v}"))
}

fn number(s: &Value) -> f64 {
    let t = s.as_str().unwrap();
    t.trim_start_matches(['+', '−'])
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn a_sound_crane_passes_every_line_it_can_check() {
    let dir = cli::temp("check-clean");
    let (code, v) = check(&dir, &[]);
    assert_eq!(code, 0, "{v}");
    assert_eq!(v["ok"], true);
    for name in [
        "link",
        "sensor zero",
        "inlet valve",
        "hold (valves closed)",
        "exhaust valve",
        "servos",
        "gripper",
        "e-stop and confirm",
        "gripper button",
    ] {
        assert_eq!(line(&v, name)["result"], "pass", "{name}: {v}");
    }
    // The measured values, within the check's own limits: ambient within 0.5 kPa, a 3 kPa
    // inflation risen at least 2.5 kPa, under 0.5 kPa lost in 3 s sealed, vented under 1 kPa.
    assert!(
        number(&line(&v, "sensor zero")["measured"]).abs() <= 0.5,
        "{v}"
    );
    assert!(number(&line(&v, "inlet valve")["measured"]) >= 2.5, "{v}");
    assert!(
        number(&line(&v, "hold (valves closed)")["measured"]) <= 0.5,
        "{v}"
    );
    assert!(number(&line(&v, "exhaust valve")["measured"]) <= 1.0, "{v}");
    // What the protocol cannot see is not passed.
    for name in ["step up/down buttons", "show-pressure button"] {
        assert_eq!(line(&v, name)["result"], "not-checked", "{name}");
    }
    // The crane ends as it began: vented, the state unchanged (the 3 kPa is under every snap).
    assert_eq!(v["ended_safe"], true);
    assert_eq!(v["sim"]["true_state"], "F&P");
    assert_eq!(v["sim"]["actuators_safe"], true);
}

#[test]
fn each_fault_fails_the_line_that_sees_it_and_the_rest_are_not_run() {
    let dir = cli::temp("check-faults");
    for (fault, failed, says) in [
        ("valve-stuck-closed", "inlet valve", "E-12"),
        ("valve-stuck-open", "hold (valves closed)", "E-11"),
        ("leak", "hold (valves closed)", "leak"),
        // The sensor is lost 1 s into the first step that runs long enough: the hold.
        ("sensor-dropout", "hold (valves closed)", "E-02"),
        ("link-drop", "hold (valves closed)", "no response"),
    ] {
        let (code, v) = check(&dir, &["--sim-fault", fault]);
        assert_eq!(code, 1, "{fault}: {v}");
        assert_eq!(v["ok"], false);
        let l = line(&v, failed);
        assert_eq!(l["result"], "fail", "{fault}: {v}");
        assert!(l["note"].as_str().unwrap().contains(says), "{fault}: {l}");
        // Exactly one failed line; everything after it not run.
        let lines = v["lines"].as_array().unwrap();
        let at = lines.iter().position(|l| l["result"] == "fail").unwrap();
        assert_eq!(lines.iter().filter(|l| l["result"] == "fail").count(), 1);
        assert!(
            lines[at + 1..].iter().all(|l| l["result"] == "not-run"),
            "{fault}: {v}"
        );
        // The actuators are safe whatever failed (after a lost link, by the device's own
        // watchdog) — but for a stuck-open inlet, which passes air whatever is commanded: the
        // device then holds the exhaust open, and the trunk stays under the first snap.
        assert_eq!(
            v["sim"]["actuators_safe"],
            fault != "valve-stuck-open",
            "{fault}: {v}"
        );
        assert_eq!(v["sim"]["true_state"], "F&P", "{fault}: {v}");
        assert_eq!(v["ended_safe"], fault != "link-drop", "{fault}: {v}");
    }
}

#[test]
fn faults_no_unloaded_check_can_see_pass_and_the_servo_line_says_why() {
    let dir = cli::temp("check-unseen");
    // A noisy line is retried through; a sagging servo supply and a tendon that snaps over
    // 15 N show only under load: the servo line is a pull inside the slack, and says so.
    for fault in ["line-noise", "servo-stall", "tendon-break"] {
        let (code, v) = check(&dir, &["--sim-fault", fault]);
        assert_eq!(code, 0, "{fault}: {v}");
        let note = line(&v, "servos")["note"].as_str().unwrap().to_string();
        assert!(note.contains("shows only under load"), "{note}");
    }
}

#[test]
fn without_the_simulator_a_person_must_be_at_a_terminal() {
    let dir = cli::temp("check-tty");
    let out = cmd(&dir, &["check", "--port", "/dev/null"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("run it on a terminal"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
