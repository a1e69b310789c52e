//! Outside clients on `hil-sim --pty`: `host-tool --port` keeps the hardware's wall-clock
//! timing, and the pty holds it at every speed it accepts; faster speeds are refused up front.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Duration;

use e2e::{binary, hil_sim_pty, host_tool, run};

const LIMIT: Duration = Duration::from_secs(60);

#[test]
fn a_plan_over_the_pty_at_the_fastest_accepted_speed_reaches_its_target() {
    let sim = hil_sim_pty(&["--initial", "F&P", "--speed", "20", "--seed", "2"]);
    let out = host_tool(
        &["plan", "--target", "D&F", "--port", &sim.path, "--json"],
        LIMIT,
    );
    let v = out.json();
    assert_eq!(out.code(), 0, "{v}\n{}", out.stderr);
    assert_eq!(v["final_state"], "D&F");
    assert_eq!(v["state_confirmed"], true);
}

#[test]
fn the_slowest_accepted_speed_answers_status() {
    let sim = hil_sim_pty(&["--initial", "D&D", "--speed", "0.1"]);
    let out = host_tool(&["status", "--port", &sim.path, "--json"], LIMIT);
    assert_eq!(out.code(), 0, "{}", out.stderr);
    assert_eq!(out.json()["state"], "D&D");
}

#[test]
fn speeds_the_pty_cannot_hold_are_refused_with_the_reason() {
    for bad in ["20.5", "1000", "inf", "0", "-3", "fast", "0.09", "1e-9"] {
        let out = run(
            &binary("hil-sim"),
            &["--pty", "--speed", bad],
            Duration::from_secs(10),
        );
        assert_eq!(out.code(), 2, "--speed {bad}: {}", out.stderr);
        assert!(
            out.stderr.contains("speed") || out.stderr.contains("number"),
            "{}",
            out.stderr
        );
    }
    let out = run(
        &binary("hil-sim"),
        &["--pty", "--speed", "100"],
        Duration::from_secs(10),
    );
    assert!(out.stderr.contains("60 s"), "{}", out.stderr);
}

/// `host-tool plan` over the pty, stopped by `signal` once its first step runs: it aborts on
/// the device, waits for the safe state and exits 130; `status` afterwards shows the safe mode.
fn signal_mid_plan(signal: nix::sys::signal::Signal) {
    let sim = hil_sim_pty(&["--initial", "F&P", "--speed", "2", "--seed", "4"]);
    let mut plan = Command::new(binary("host-tool"))
        .args(["plan", "--target", "D&D", "--port", &sim.path, "--json"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("host-tool starts");
    let mut err = BufReader::new(plan.stderr.take().expect("stderr is piped"));
    let mut line = String::new();
    loop {
        line.clear();
        assert!(
            err.read_line(&mut line).expect("stderr") > 0,
            "host-tool ended early"
        );
        if line.starts_with("step 1/3") {
            break;
        }
    }
    let pid = nix::unistd::Pid::from_raw(plan.id() as i32);
    nix::sys::signal::kill(pid, signal).expect("signal sent");
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).expect("stderr");
    let status = plan.wait().expect("host-tool exits");
    assert_eq!(status.code(), Some(130), "{signal}: {rest}");
    assert!(rest.contains("aborted by the operator"), "{rest}");
    let out = host_tool(&["status", "--port", &sim.path, "--json"], LIMIT);
    let v = out.json();
    assert_eq!(v["mode"], "safe", "{signal}: {v}");
    assert_eq!(v["inlet_open"], false, "{v}");
}

#[test]
fn sigterm_during_a_plan_aborts_it_to_the_safe_state() {
    signal_mid_plan(nix::sys::signal::Signal::SIGTERM);
}

#[test]
fn sighup_during_a_plan_aborts_it_to_the_safe_state() {
    signal_mid_plan(nix::sys::signal::Signal::SIGHUP);
}

#[test]
fn sigint_during_a_plan_aborts_it_to_the_safe_state() {
    signal_mid_plan(nix::sys::signal::Signal::SIGINT);
}

/// A second terminal without `serve`: `stop --port P` while `plan` holds P is refused naming
/// the plan's process (pid and command line) and pointing to `host-tool serve`; the plan goes
/// on untouched and is stopped from its own terminal.
#[test]
fn a_second_host_on_a_held_port_names_the_holder_and_points_to_serve() {
    let sim = hil_sim_pty(&["--initial", "F&P", "--speed", "2", "--seed", "4"]);
    let mut plan = Command::new(binary("host-tool"))
        .args(["plan", "--target", "D&D", "--port", &sim.path, "--json"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("host-tool starts");
    let mut err = BufReader::new(plan.stderr.take().expect("stderr is piped"));
    let mut line = String::new();
    loop {
        line.clear();
        assert!(
            err.read_line(&mut line).expect("stderr") > 0,
            "host-tool ended early"
        );
        if line.starts_with("step 1/3") {
            break;
        }
    }
    let out = host_tool(&["stop", "--port", &sim.path], LIMIT);
    assert_eq!(out.code(), 1, "{}", out.stderr);
    assert!(
        out.stderr.contains(&format!(
            "in use by process {} ({} plan --target D&D --port {}",
            plan.id(),
            binary("host-tool").display(),
            sim.path
        )),
        "{}",
        out.stderr
    );
    assert!(
        out.stderr
            .contains(&format!("run `host-tool serve --port {}`", sim.path)),
        "{}",
        out.stderr
    );
    assert!(!out.stderr.contains("Unable to acquire"), "{}", out.stderr);
    // The refused host sent nothing: the plan is still running, and stops from its terminal.
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(plan.id() as i32),
        nix::sys::signal::Signal::SIGINT,
    )
    .expect("signal sent");
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).expect("stderr");
    let status = plan.wait().expect("host-tool exits");
    assert_eq!(status.code(), Some(130), "{rest}");
    assert!(rest.contains("aborted by the operator"), "{rest}");
}
