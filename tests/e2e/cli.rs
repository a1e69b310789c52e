//! The command line against an outside simulator (`hil-sim --pty`): a device refusal that
//! names its field, `monitor` restoring the telemetry rate whatever ends it and printing at a
//! readable rate, and `hil-sim` agreeing with `host-tool` on flags and exit codes.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use e2e::{binary, hil_sim_pty, host_tool, run};

const LIMIT: Duration = Duration::from_secs(60);

fn telemetry_hz(port: &str) -> f64 {
    let out = host_tool(&["param", "get", "telemetry-hz", "-p", port, "-j"], LIMIT);
    assert_eq!(out.code(), 0, "{}", out.stderr);
    out.json()["params"][0]["value"].as_f64().expect("a value")
}

#[test]
fn a_refused_plan_names_the_step_what_it_needs_the_limit_and_how_to_change_it() {
    let sim = hil_sim_pty(&["--sim-speed", "20"]);
    let out = host_tool(
        &["param", "set", "pressure-limit-kpa", "10", "-p", &sim.path],
        LIMIT,
    );
    assert_eq!(out.code(), 0, "{}", out.stderr);
    let out = host_tool(&["plan", "--target", "D&F", "-p", &sim.path, "-j"], LIMIT);
    assert_eq!(out.code(), 1, "{}", out.stderr);
    let v = out.json();
    let f = &v["failure"];
    assert_eq!(f["kind"], "refused", "{v}");
    assert_eq!(f["reject"], "out-of-range", "{v}");
    assert_eq!(f["step"]["index"], 0, "{v}");
    assert_eq!(f["step"]["to"], "F&F", "{v}");
    assert_eq!(f["refused"]["field"], "pressure", "{v}");
    assert_eq!(f["refused"]["value"].as_f64(), Some(16.0), "{v}");
    assert_eq!(f["refused"]["limit"].as_f64(), Some(10.0), "{v}");
    let msg = v["error"].as_str().unwrap_or_default();
    for part in [
        "step 1/2 (pneumatic F&P → F&F)",
        "16 kPa",
        "pressure limit of 10 kPa",
        // The hint names what the whole plan needs (F&F → D&F inflates toward 24.5 kPa), so
        // one change lets every step run.
        "host-tool param set pressure-limit-kpa 24.5` (the whole plan needs up to 24.5 kPa, in step 2)",
    ] {
        assert!(msg.contains(part), "{part:?} missing: {msg}");
    }
    // A parameter the device refuses against another one names both.
    let out = host_tool(
        &["param", "set", "servo-min-deg", "170", "-p", &sim.path],
        LIMIT,
    );
    assert_eq!(out.code(), 0, "{}", out.stderr);
    let out = host_tool(
        &[
            "param",
            "set",
            "servo-max-deg",
            "100",
            "-p",
            &sim.path,
            "-j",
        ],
        LIMIT,
    );
    assert_eq!(out.code(), 1);
    let v = out.json();
    assert_eq!(v["refused"]["field"], "servo-max-deg", "{v}");
    assert_eq!(v["refused"]["limit"].as_f64(), Some(170.0), "{v}");
    assert!(
        v["error"]
            .as_str()
            .unwrap_or_default()
            .contains("would pass servo-min-deg = 170 deg"),
        "{v}"
    );
}

/// `host-tool monitor` at 25 Hz on `port`, its output piped.
fn monitor(port: &str) -> std::process::Child {
    Command::new(binary("host-tool"))
        .args(["monitor", "-p", port, "--rate", "25"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("monitor starts")
}

#[test]
fn monitor_restores_the_telemetry_rate_when_its_stdout_closes() {
    let sim = hil_sim_pty(&["--sim-speed", "5"]);
    assert_eq!(telemetry_hz(&sim.path), 10.0);
    let mut mon = monitor(&sim.path);
    {
        // `| head -2`: two lines read, then the pipe closes.
        let mut lines = BufReader::new(mon.stdout.take().expect("stdout")).lines();
        for _ in 0..2 {
            lines.next().expect("a line").expect("text");
        }
    }
    let start = Instant::now();
    let status = loop {
        if let Some(s) = mon.try_wait().expect("wait") {
            break s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "monitor kept running with its stdout closed"
        );
        std::thread::yield_now();
    };
    let mut err = String::new();
    std::io::Read::read_to_string(&mut mon.stderr.take().expect("stderr"), &mut err).ok();
    assert_eq!(
        status.code(),
        Some(0),
        "a closed stdout ends it quietly: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        telemetry_hz(&sim.path),
        10.0,
        "the device's rate is restored"
    );
}

#[test]
fn monitor_restores_the_telemetry_rate_on_ctrl_c_and_exits_130() {
    let sim = hil_sim_pty(&["--sim-speed", "5"]);
    let mut mon = monitor(&sim.path);
    let mut lines = BufReader::new(mon.stdout.take().expect("stdout")).lines();
    // Its header and a first sample: the rate is set.
    for _ in 0..2 {
        lines.next().expect("a line").expect("text");
    }
    let pid = nix::unistd::Pid::from_raw(mon.id() as i32);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT).expect("SIGINT");
    // Drain stdout so it never blocks on a full pipe.
    let drain = std::thread::spawn(move || lines.count());
    let status = mon.wait().expect("monitor ends");
    let _ = drain.join();
    assert_eq!(status.code(), Some(130));
    assert_eq!(telemetry_hz(&sim.path), 10.0);
}

#[test]
fn monitor_against_a_fast_pty_prints_at_most_its_rate_of_lines_per_second() {
    // At ×20 the device's 10 Hz telemetry is 200 samples per wall second.
    let sim = hil_sim_pty(&["--sim-speed", "20"]);
    let out = host_tool(
        &["monitor", "-p", &sim.path, "--rate", "5", "--duration", "2"],
        LIMIT,
    );
    assert_eq!(out.code(), 0, "{}", out.stderr);
    let samples = out.stdout.lines().filter(|l| l.contains(" kPa ")).count();
    assert!(
        (3..=12).contains(&samples),
        "{samples} lines in 2 s:\n{}",
        out.stdout
    );
}

#[test]
fn hil_sim_takes_host_tools_simulator_flags_and_defaults() {
    let sim = hil_sim_pty(&["--sim-initial", "D&F", "--sim-fault", "leak"]);
    // The same defaults as host-tool's simulator: seed 1; real time (×1) for an outside client.
    assert!(
        sim.first_line.contains("initial D&F, seed 1, speed 1)"),
        "{}",
        sim.first_line
    );
    let out = host_tool(&["status", "-p", &sim.path, "-j"], LIMIT);
    assert_eq!(out.json()["state"], "D&F");
    let sim = hil_sim_pty(&["--seed", "-3"]);
    assert!(
        sim.first_line.contains("seed 18446744073709551613"),
        "{}",
        sim.first_line
    );
    // A state cut at its & by the shell gets the quoting hint, exit 2.
    let out = run(
        &binary("hil-sim"),
        &["--pty", "--sim-initial", "D"],
        Duration::from_secs(10),
    );
    assert_eq!(out.code(), 2);
    assert!(out.stderr.contains("--target 'D&F'"), "{}", out.stderr);
}

#[test]
fn hil_sim_exits_130_on_a_signal_and_every_subcommand_has_version() {
    let sim = hil_sim_pty(&["--sim-speed", "1"]);
    let pid = nix::unistd::Pid::from_raw(sim.pid() as i32);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT).expect("SIGINT");
    assert_eq!(sim.wait_code(), Some(130));
    for args in [&["-V"][..], &["discover", "-V"], &["swarm", "--version"]] {
        let out = run(&binary("hil-sim"), args, Duration::from_secs(10));
        assert_eq!(out.code(), 0, "{args:?}: {}", out.stderr);
        assert!(
            out.stdout
                .contains(&format!("schema {:#010x}", protocol::SCHEMA_ID)),
            "{args:?}: {}",
            out.stdout
        );
    }
}
