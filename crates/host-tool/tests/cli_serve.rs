//! `host-tool serve` with clients in other processes, as people at several terminals use it:
//! a plan runs through the server, `stop` from a second process aborts it, `monitor` from a
//! third prints samples; a server that dies is reported by its clients. Each test has its own
//! socket directory (XDG_RUNTIME_DIR).

#[path = "support/cli.rs"]
mod cli;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};

use cli::cmd;

/// Starts `serve` on the simulator and waits for its "serving" line (it listens from then on).
fn serve(dir: &Path, extra: &[&str]) -> Child {
    let mut args = vec!["serve", "--sim", "--seed", "7", "--sim-speed", "2"];
    args.extend_from_slice(extra);
    let (child, line) = cli::serve(dir, &args);
    assert!(line.starts_with("serving the simulator on "), "{line}");
    child
}

/// A plan client; returns it and a reader of its stderr (progress lines).
fn plan(dir: &Path) -> (Child, BufReader<std::process::ChildStderr>) {
    let mut child = cmd(dir, &["plan", "--target", "D&D", "--json"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let err = BufReader::new(child.stderr.take().unwrap());
    (child, err)
}

fn wait_for(err: &mut BufReader<std::process::ChildStderr>, what: &str) -> String {
    let mut seen = String::new();
    loop {
        let mut line = String::new();
        assert!(
            err.read_line(&mut line).unwrap() > 0,
            "no '{what}' in:\n{seen}"
        );
        seen.push_str(&line);
        if line.contains(what) {
            return seen;
        }
    }
}

#[test]
fn stop_and_monitor_from_other_processes_while_a_plan_runs_through_serve() {
    let dir = cli::temp("serve-stop");
    let rec = dir.join("serve.mcap");
    let mut server = serve(&dir, &["--record", rec.to_str().unwrap()]);
    let (mut planner, mut progress) = plan(&dir);
    let before = wait_for(&mut progress, "step 2/3 started");
    assert!(
        before
            .lines()
            .any(|l| l.starts_with("step 1 ") && l.contains(": done in ")),
        "{before}"
    );

    // A third terminal: monitor at 5 Hz keeps to its rate though the server streams at 50 Hz:
    // a header, then samples at least 200 ms of device time apart.
    let out = cmd(&dir, &["monitor", "--duration", "0.5", "--rate", "5"])
        .output()
        .unwrap();
    let shown = String::from_utf8_lossy(&out.stdout).into_owned();
    assert_eq!(out.status.code(), Some(0), "{shown}");
    let mut shown_lines = shown.lines();
    assert!(
        shown_lines.next().is_some_and(|h| h.contains("pressure")),
        "no header: {shown}"
    );
    // 0.5 s of wall time at 2× is 1 s of device time: 5 samples at 5 Hz (± the ends).
    let samples = shown_lines.filter(|l| l.contains("kPa")).count();
    assert!(
        (2..=7).contains(&samples),
        "{samples} samples at 5 Hz:\n{shown}"
    );
    let out = cmd(
        &dir,
        &["monitor", "--duration", "0.5", "--rate", "5", "--json"],
    )
    .output()
    .unwrap();
    let t: Vec<u64> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|v| v["type"] == "telemetry")
        .map(|v| v["uptime_ms"].as_u64().unwrap())
        .collect();
    assert!(t.len() >= 2, "{t:?}");
    assert!(t.windows(2).all(|w| w[1] - w[0] >= 200), "{t:?}");

    // At 50 Hz it prints the server's every sample (50 Hz device time, paced 2×).
    let out = cmd(
        &dir,
        &["monitor", "--duration", "0.5", "--rate", "50", "--json"],
    )
    .output()
    .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let samples: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .filter(|v: &serde_json::Value| v["type"] == "telemetry")
        .collect();
    // 0.5 s of wall time at 2× is 1 s of device time: ~50 samples; at least half of them.
    assert!(samples.len() >= 25, "{} samples", samples.len());
    let t: Vec<u64> = samples
        .iter()
        .map(|s| s["uptime_ms"].as_u64().unwrap())
        .collect();
    assert!(
        t.windows(2).all(|w| w[1] > w[0]),
        "device time goes forward"
    );
    assert!(
        samples.iter().any(|s| s["inlet_open"] == true),
        "the step inflates"
    );

    // A status from another terminal mid-step: the step is moving the trunk, so no state is
    // claimed confirmed (issue 26 item 2); the text says where from and toward what.
    let out = cmd(&dir, &["status", "--json"]).output().unwrap();
    assert_eq!(out.status.code(), Some(0));
    let st: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(st["mode"], "running", "{st}");
    assert_eq!(st["state_confirmed"], false, "{st}");
    assert!(st["interrupted"].is_null(), "{st}");
    let (from, to) = (
        st["moving"]["from"]
            .as_str()
            .unwrap_or_else(|| panic!("no moving step: {st}")),
        st["moving"]["to"].as_str().unwrap(),
    );
    assert_eq!(st["state"], from, "{st}");
    let candidates: Vec<&str> = st["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_str().unwrap())
        .collect();
    assert!(
        candidates.contains(&from) && candidates.contains(&to),
        "{st}"
    );
    if let Some(truth) = st["sim"]["true_state"].as_str() {
        assert!(
            candidates.contains(&truth),
            "{truth} not among {candidates:?}"
        );
    }
    let out = cmd(&dir, &["status"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(&format!("moving from {from} toward "))
            && text.contains("not confirmed while the step runs"),
        "{text}"
    );

    // A second terminal: stop.
    let out = cmd(&dir, &["stop", "--json"]).output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["aborted"], true);
    assert_eq!(v["safe"], true, "{v}");
    let latency = v["abort_latency_ms"]
        .as_u64()
        .expect("latency through the server");
    assert!(latency <= 200, "stop took {latency} ms of device time");

    // The plan ends: aborted, not reached; its cut step's line says so, with its duration.
    let status = planner.wait().unwrap();
    assert_eq!(status.code(), Some(1));
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut progress, &mut rest).unwrap();
    assert!(
        rest.lines()
            .any(|l| l.starts_with("step ") && l.contains(": aborted in ") && l.ends_with(" s")),
        "{rest}"
    );
    assert!(!rest.contains("FAILED"), "{rest}");
    let mut stdout = String::new();
    std::io::Read::read_to_string(&mut planner.stdout.take().unwrap(), &mut stdout).unwrap();
    let outcome: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(outcome["ok"], false);
    assert_eq!(outcome["failure"]["kind"], "aborted", "{outcome}");
    // Stopped in step 2 (or, on a machine slow enough, step 3): never completed.
    let step = outcome["failure"]["step"]["index"].as_u64().unwrap();
    assert!((1..=2).contains(&step), "{outcome}");
    assert_eq!(outcome["sim"]["actuators_safe"], true, "{outcome}");

    // SIGTERM: the server ends cleanly (exit 130, as every interrupted command) and its
    // recording is complete.
    let term = Command::new("kill")
        .args(["-TERM", &server.id().to_string()])
        .status()
        .unwrap();
    assert!(term.success());
    assert_eq!(server.wait().unwrap().code(), Some(130));
    let sum = cmd(&dir, &["log", "summary", rec.to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&sum.stdout);
    assert!(
        text.contains("complete (summary and footer present)"),
        "{text}"
    );
    assert!(
        text.contains("/plan ") && text.contains("/telemetry "),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn clients_say_the_server_went_away_when_it_dies() {
    let dir = cli::temp("serve-gone");
    let mut server = serve(&dir, &["--no-record"]);
    let (mut planner, mut progress) = plan(&dir);
    wait_for(&mut progress, "step 1/3 started");
    server.kill().unwrap();
    server.wait().unwrap();
    let rest = wait_for(&mut progress, "error");
    assert!(rest.contains("the server went away"), "{rest}");
    assert_eq!(planner.wait().unwrap().code(), Some(1));
    // No server: a command without --port/--sim is the usual usage error again, and it names
    // the server that is gone (its socket is left behind by the kill) rather than only the
    // missing board.
    let out = cmd(&dir, &["status"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("the server of the simulator is not running (a killed `host-tool serve` left")
            && err.contains("start `host-tool serve` again"),
        "{err}"
    );
    // A new server replaces the stale socket and serves again.
    let mut again = serve(&dir, &["--no-record"]);
    let out = cmd(&dir, &["status", "-j"]).output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    again.kill().unwrap();
    again.wait().unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// `serve` ended by a signal says so and exits 130: with nothing running, and with a plan it
/// aborts (the plan's client then reports the abort).
#[test]
fn a_signalled_server_says_why_it_stopped_and_exits_130() {
    use nix::sys::signal::{kill, Signal};
    use nix::unistd::Pid;
    for (signal, with_plan) in [(Signal::SIGINT, false), (Signal::SIGTERM, true)] {
        let dir = cli::temp(&format!("serve-signal-{with_plan}"));
        let mut server = cmd(
            &dir,
            &[
                "serve",
                "--sim",
                "--seed",
                "7",
                "--sim-speed",
                "2",
                "--no-record",
            ],
        )
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
        let mut err = BufReader::new(server.stderr.take().unwrap());
        wait_for(&mut err, "serving the simulator on ");
        let planner = with_plan.then(|| {
            let (p, mut progress) = plan(&dir);
            wait_for(&mut progress, "step 1/3 started");
            (p, progress)
        });
        kill(Pid::from_raw(server.id() as i32), signal).unwrap();
        let said = wait_for(&mut err, "interrupted");
        assert_eq!(server.wait().unwrap().code(), Some(130), "{signal}: {said}");
        if let Some((mut p, mut progress)) = planner {
            assert!(
                said.contains("was aborted and the device is in its safe state"),
                "{said}"
            );
            let rest = wait_for(&mut progress, "error");
            assert_ne!(p.wait().unwrap().code(), Some(0), "{rest}");
        } else {
            assert!(
                said.contains("the server stopped (nothing was running)"),
                "{said}"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn the_socket_is_the_users_only_and_param_goes_through_the_server() {
    use std::os::unix::fs::PermissionsExt;
    let dir = cli::temp("serve-perm");
    let mut server = serve(&dir, &["--no-record"]);
    let sock_dir = dir.join("host-tool");
    let mode = std::fs::metadata(&sock_dir).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o700, "{mode:o}");
    let mode = std::fs::metadata(sock_dir.join("sim.sock"))
        .unwrap()
        .permissions()
        .mode();
    assert_eq!(mode & 0o777, 0o600, "{mode:o}");
    // `param` goes through the server: a write, then a read from another process.
    let out = cmd(&dir, &["param", "set", "link-timeout-ms", "5000", "--json"])
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        (v["previous"].as_f64(), v["value"].as_f64()),
        (Some(3000.0), Some(5000.0))
    );
    let out = cmd(&dir, &["param", "get", "link-timeout-ms", "--json"])
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["params"][0]["value"].as_f64(), Some(5000.0), "{v}");
    // A refusal through the server keeps the device's reason.
    let out = cmd(&dir, &["param", "set", "servo-max-deg", "0", "--json"])
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = cmd(&dir, &["param", "set", "servo-min-deg", "10"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    // The device names the field and the limit it passes, through the server too.
    assert!(
        err.contains("servo-min-deg 10 deg would pass servo-max-deg = 0 deg"),
        "{err}"
    );
    // A second server for the same device is refused.
    let out = cmd(&dir, &["serve", "--sim", "--no-record"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("already serves"));
    server.kill().unwrap();
    server.wait().unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// `param save`, then `param load` of an edited file through the server, then `param diff`:
/// the device holds the file's values; a file of another schema is refused before anything is
/// written, naming the parameters that differ.
#[test]
fn parameter_files_save_load_and_diff_through_serve() {
    let dir = cli::temp("serve-params");
    let rec = dir.join("serve.mcap");
    let mut server = serve(&dir, &["--record", rec.to_str().unwrap()]);
    let file = dir.join("crane.params.json");
    let f = file.to_str().unwrap();
    let out = cmd(&dir, &["param", "save", f, "-j"]).output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    assert_eq!(saved["format"], "yoshimura-crane-params");
    assert_eq!(saved["schema_id"], protocol::SCHEMA_ID);
    assert_eq!(saved["params"].as_object().unwrap().len(), 6);
    let mut edited = saved.clone();
    edited["params"]["telemetry-hz"] = 7.into();
    edited["params"]["pressure-limit-kpa"] = 33.5.into();
    std::fs::write(&file, edited.to_string()).unwrap();
    let json = |args: &[&str]| -> serde_json::Value {
        let out = cmd(&dir, args).output().unwrap();
        assert_eq!(
            out.status.code(),
            Some(0),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let before = json(&["param", "diff", f, "-j"]);
    assert_eq!(before["differ"].as_array().unwrap().len(), 2, "{before}");
    let dry = json(&["param", "load", f, "--dry-run", "-j"]);
    assert_eq!(dry["written"], 0);
    assert_eq!(
        json(&["param", "diff", f, "-j"])["differ"]
            .as_array()
            .unwrap()
            .len(),
        2
    );
    let load = json(&["param", "load", f, "-j"]);
    assert_eq!(load["written"], 2, "{load}");
    let after = json(&["param", "diff", f, "-j"]);
    assert_eq!(after["differ"].as_array().unwrap().len(), 0, "{after}");
    let got = json(&["param", "get", "pressure-limit-kpa", "-j"]);
    assert_eq!(got["params"][0]["value"], 33.5);
    // Another firmware's file: refused (exit 1), nothing written.
    let mut other = edited.clone();
    other["schema_id"] = 5.into();
    other["params"]["telemetry-hz"] = 9.into();
    std::fs::write(&file, other.to_string()).unwrap();
    let out = cmd(&dir, &["param", "load", f]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("schema 0x00000005") && err.contains("differ: telemetry-hz"),
        "{err}"
    );
    assert_eq!(
        json(&["param", "get", "telemetry-hz", "-j"])["params"][0]["value"],
        7
    );
    // A bad file is a usage error naming the problem.
    std::fs::write(&file, r#"{"format":"yoshimura-crane-params","version":1,"schema_id":1,"params":{"link-timeout-ms":250.5}}"#).unwrap();
    let out = cmd(&dir, &["param", "load", f]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr)
        .contains("link-timeout-ms = 250.5: expected a whole number"));
    let out = cmd(&dir, &["param", "save", dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    server.kill().unwrap();
    let _ = server.wait();
}

/// `identify` through a server: after a plan the leak made fail, the device's state is
/// unconfirmed; the server identifies it (its probes, then the simulated operator) and the
/// client reports what the direct command would.
#[test]
fn identify_goes_through_the_server() {
    let dir = cli::temp("serve-identify");
    let (mut server, line) = cli::serve(
        &dir,
        &[
            "serve",
            "--sim",
            "--sim-fault",
            "leak",
            "--no-record",
            "--sim-speed",
            "1000",
        ],
    );
    assert!(line.starts_with("serving the simulator on "), "{line}");
    let out = cmd(&dir, &["plan", "--target", "D&F", "-j"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["state_confirmed"], false, "{v}");
    let out = cmd(&dir, &["identify", "-j"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["identified"], true, "{v}");
    assert_eq!(v["state_confirmed"], true, "{v}");
    assert_eq!(v["state"], v["sim"]["true_state"], "{v}");
    assert_eq!(v["candidates"], serde_json::json!([v["state"]]), "{v}");
    assert!(err.contains("simulated operator: the trunk is"), "{err}");
    // Confirmed now: a second identify says so at once.
    let out = cmd(&dir, &["identify"]).output().unwrap();
    assert_eq!(out.status.code(), Some(0));
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("(confirmed already)"),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    server.kill().unwrap();
    server.wait().unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// `status` says which server answered, and on the simulator flags a device whose belief the
/// truth contradicts (here after a wrong `declare` through the server).
#[test]
fn status_names_the_server_and_flags_a_wrong_belief() {
    let dir = cli::temp("serve-wrong");
    let (mut server, line) = cli::serve(&dir, &["serve", "--sim", "--no-record"]);
    assert!(line.starts_with("serving the simulator on "), "{line}");
    let out = cmd(&dir, &["status"]).output().unwrap();
    let shown = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        shown.starts_with("answered by:  the `host-tool serve` server at ")
            && shown.contains("sim.sock"),
        "{shown}"
    );
    assert!(!shown.contains("WRONG"), "{shown}");
    // Taking the session over is the server's business: refused up front, saying why.
    let out = cmd(&dir, &["status", "--take-over"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let why = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(
        why.contains("--take-over") && why.contains("a `host-tool serve` server holds it"),
        "{why}"
    );
    let out = cmd(&dir, &["declare", "D&D"]).output().unwrap();
    assert_eq!(out.status.code(), Some(0));
    let out = cmd(&dir, &["status"]).output().unwrap();
    let shown = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        shown.contains("true state F&P")
            && shown.contains("THE DEVICE IS WRONG: it holds D&D as confirmed"),
        "{shown}"
    );
    let v: serde_json::Value =
        serde_json::from_slice(&cmd(&dir, &["status", "-j"]).output().unwrap().stdout).unwrap();
    assert_eq!(v["sim"]["matches_device"], false, "{v}");
    assert!(v["server"].as_str().unwrap().ends_with("sim.sock"), "{v}");
    // The true state declared: no warning, and the JSON agrees.
    cmd(&dir, &["declare", "F&P"]).output().unwrap();
    let v: serde_json::Value =
        serde_json::from_slice(&cmd(&dir, &["status", "-j"]).output().unwrap().stdout).unwrap();
    assert_eq!(v["sim"]["matches_device"], true, "{v}");
    server.kill().unwrap();
    server.wait().unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// Under a low pressure limit the device refuses the plan at its first step over it; the hint
/// names the limit the whole plan needs (F&P → D&D: 16, 24.5 and 35 kPa), not the first step's.
#[test]
fn a_refusal_under_a_low_pressure_limit_names_the_plans_most() {
    let dir = cli::temp("serve-limit");
    let (mut server, line) = cli::serve(&dir, &["serve", "--sim", "--no-record"]);
    assert!(line.starts_with("serving the simulator on "), "{line}");
    let out = cmd(&dir, &["param", "set", "pressure-limit-kpa", "10"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    for (target, hint) in [
        (
            "D&D",
            "`host-tool param set pressure-limit-kpa 35` (the whole plan needs up to 35 kPa, in step 3)",
        ),
        ("F&F", "`host-tool param set pressure-limit-kpa 16` (at most 60)"),
    ] {
        let out = cmd(&dir, &["plan", "--target", target, "-j"]).output().unwrap();
        assert_eq!(out.status.code(), Some(1), "{target}");
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let e = v["error"].as_str().unwrap();
        assert!(
            e.contains("it needs 16 kPa, above the pressure limit of 10 kPa") && e.contains(hint),
            "{target}: {e}"
        );
    }
    server.kill().unwrap();
    server.wait().unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// A client that writes lines that are not requests (bad JSON, an unknown `op`, a missing or
/// malformed field, a state that does not exist) gets one error line each, saying why, and the
/// server goes on serving: the same connection's next request, and another client's, are
/// answered.
#[test]
fn a_malformed_or_unknown_request_gets_an_error_reply_and_the_server_serves_on() {
    use std::io::Write;
    let dir = cli::temp("serve-bad-request");
    let mut server = serve(&dir, &["--no-record"]);
    let sock = dir.join("host-tool").join("sim.sock");
    let mut s = std::os::unix::net::UnixStream::connect(&sock).unwrap();
    let mut r = BufReader::new(s.try_clone().unwrap());
    let mut ask = |line: &str| -> serde_json::Value {
        s.write_all(line.as_bytes()).unwrap();
        s.write_all(b"\n").unwrap();
        let mut reply = String::new();
        assert!(r.read_line(&mut reply).unwrap() > 0, "no reply to {line}");
        serde_json::from_str(&reply).unwrap()
    };
    for (line, why) in [
        ("this is not json", "bad request line: expected"),
        (r#"{"op":"dance"}"#, "unknown variant `dance`"),
        (r#"{"request":null}"#, "missing field `op`"),
        (r#"{"op":"plan"}"#, "missing field `target`"),
        (
            r#"{"op":"plan","target":"X&Y"}"#,
            "invalid trunk state 'X&Y'",
        ),
        (
            r#"{"op":"call","request":{"Fly":1}}"#,
            "unknown variant `Fly`",
        ),
        (
            r#"{"op":"call","request":{"RunStep":{"kind":"Tendon"}}}"#,
            "bad request line",
        ),
    ] {
        let v = ask(line);
        let e = v["error"].as_str().unwrap_or_else(|| panic!("{line}: {v}"));
        assert!(e.contains(why), "{line}: {e}");
        assert_eq!(v.as_object().map(|o| o.len()), Some(1), "{v}");
    }
    // The same connection, then another process, still get answers.
    let v = ask(r#"{"op":"snapshot","request":null}"#);
    assert_eq!(v["status"]["state"]["top"], "Folded", "{v}");
    assert_eq!(v["truth"]["true_state"], "F&P", "{v}");
    let out = cmd(&dir, &["status", "--json"]).output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    server.kill().unwrap();
    server.wait().unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}
