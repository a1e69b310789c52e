//! `host-tool declare` and `host-tool param` as a user runs them, against the built-in
//! simulator (`--sim`): the real binary, the real controller behind a pseudo-terminal.

#[path = "support/cli.rs"]
mod cli;

use cli::host_tool;

use std::process::Output;

use protocol::ParamId;
use serde_json::Value;

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn json(out: &Output) -> Value {
    serde_json::from_str(stdout(out).trim())
        .unwrap_or_else(|e| panic!("not one JSON object ({e}): {}{}", stdout(out), stderr(out)))
}

const NAMES: [&str; 6] = [
    "pressure-limit-kpa",
    "servo-min-deg",
    "servo-max-deg",
    "servo-slew-deg-per-s",
    "telemetry-hz",
    "link-timeout-ms",
];

#[test]
fn declare_changes_the_state_the_device_reports() {
    // The simulator starts at F&P; the declaration is what the device then reports, confirmed.
    let out = host_tool(&["declare", "D&D", "--sim"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(
        text.contains("the device now reports D&D, confirmed"),
        "{text}"
    );
    // --sim was asked for: no note about a missing --port.
    assert!(!stderr(&out).contains("no --port"), "{}", stderr(&out));

    let out = host_tool(&["declare", "F&D", "--sim", "--sim-initial", "D&F", "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let v = json(&out);
    assert_eq!(v["declared"], "F&D");
    assert_eq!(v["state"], "F&D");
    assert_eq!(v["state_confirmed"], true);
    // The physics did not move: only the controller was told (the simulator's truth says so).
    assert_eq!(v["sim"]["true_state"], "D&F");
}

#[test]
fn an_invalid_declared_state_is_a_usage_error_listing_the_six_states() {
    let out = host_tool(&["declare", "D&X", "--sim"]);
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    for s in ["F&P", "F&F", "F&D", "D&P", "D&F", "D&D"] {
        assert!(err.contains(s), "{err}");
    }
    // Refused before any device is opened.
    assert!(!err.contains("built-in simulator"), "{err}");
}

#[test]
fn param_get_lists_all_six_within_their_ranges() {
    let out = host_tool(&["param", "get", "--sim", "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let v = json(&out);
    let params = v["params"].as_array().expect("params array");
    assert_eq!(params.len(), 6, "{v}");
    for (p, (name, id)) in params.iter().zip(NAMES.iter().zip(ParamId::ALL)) {
        assert_eq!(p["name"], *name, "{p}");
        let (lo, hi) = id.range();
        let value = p["value"].as_f64().expect("numeric value");
        assert!(
            (f64::from(lo)..=f64::from(hi)).contains(&value),
            "{name} = {value} outside {lo}..={hi}"
        );
        assert_eq!(p["min"].as_f64(), Some(f64::from(lo)), "{p}");
        assert_eq!(p["max"].as_f64(), Some(f64::from(hi)), "{p}");
        assert!(p["unit"].is_string(), "{p}");
    }
    // The firmware's default pressure cap, exactly.
    assert_eq!(params[0]["value"].as_f64(), Some(40.0));

    let out = host_tool(&["param", "get", "--sim"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = stdout(&out);
    assert_eq!(text.lines().count(), 6, "{text}");
    for name in NAMES {
        assert!(text.contains(name), "{text}");
    }

    let out = host_tool(&["param", "get", "link-timeout-ms", "--sim", "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let v = json(&out);
    assert_eq!(v["params"].as_array().map(Vec::len), Some(1), "{v}");
    assert_eq!(v["params"][0]["name"], "link-timeout-ms");
    assert_eq!(v["params"][0]["unit"], "ms");
}

#[test]
fn param_set_changes_the_value_the_device_holds() {
    let out = host_tool(&["param", "set", "pressure-limit-kpa", "30", "--sim"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(
        text.contains("pressure-limit-kpa set: 30 kPa (was 40 kPa)"),
        "{text}"
    );

    let out = host_tool(&[
        "param",
        "set",
        "servo-slew-deg-per-s",
        "45.5",
        "--sim",
        "--json",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let v = json(&out);
    assert_eq!(v["name"], "servo-slew-deg-per-s");
    assert_eq!(v["value"].as_f64(), Some(45.5));
    assert_eq!(v["previous"].as_f64(), Some(90.0));
    assert_eq!(v["unit"], "deg/s");
    assert_eq!(v["min"].as_f64(), Some(1.0));
    assert_eq!(v["max"].as_f64(), Some(600.0));
}

#[test]
fn out_of_range_values_are_usage_errors_naming_the_range() {
    for (name, value, range) in [
        ("pressure-limit-kpa", "61", "from 0 to 60 kPa"),
        ("pressure-limit-kpa", "-5", "from 0 to 60 kPa"),
        ("link-timeout-ms", "100", "from 200 to 60000 ms"),
        ("telemetry-hz", "fast", "from 0 to 50 Hz"),
    ] {
        let out = host_tool(&["param", "set", name, value, "--sim"]);
        assert_eq!(out.status.code(), Some(2), "{name} {value}");
        let err = stderr(&out);
        assert!(err.contains(range), "{name} {value}: {err}");
        // Checked locally: nothing was sent, no simulator was started.
        assert!(!err.contains("built-in simulator"), "{err}");
    }
}

#[test]
fn unknown_names_are_usage_errors_listing_the_valid_names() {
    for args in [
        &["param", "get", "pressure", "--sim"][..],
        &["param", "set", "pressure_limit_kpa", "30", "--sim"][..],
    ] {
        let out = host_tool(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = stderr(&out);
        assert!(err.contains("unknown parameter"), "{err}");
        for name in NAMES {
            assert!(err.contains(name), "{err}");
        }
    }
}
