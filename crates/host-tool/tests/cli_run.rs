//! Missions through the binary (`host-tool run MISSION.toml`): the paper's three
//! demonstrations in `missions/` pass on the simulator; every refusal of the validation names
//! its line and reason with exit code 2 and nothing sent; `skip` goes on and `stop` stops
//! safe; a time limit fails its step by name; a stopped mission resumes at its first
//! unfinished step; Ctrl-C ends safe with 130; a mission runs through `serve`. The simulator
//! runs on virtual time: no test sleeps.

#[path = "support/cli.rs"]
mod cli;

use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};

use cli::cmd;
use serde_json::Value;

fn run(dir: &Path, args: &[&str]) -> Output {
    cmd(dir, args).env_remove("CRANE_PORT").output().unwrap()
}

fn code(o: &Output) -> i32 {
    o.status.code().unwrap_or(-1)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The JSON Lines of a `run -j`: the steps, then the summary.
fn lines(o: &Output) -> (Vec<Value>, Value) {
    let mut all: Vec<Value> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    let summary = all.pop().expect("a summary line");
    assert_eq!(summary["summary"], true, "{summary}");
    (all, summary)
}

/// A copy of the example mission `name` in `dir` (a failed run's progress file lands there,
/// not in the repository).
fn example(dir: &Path, name: &str) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../missions")
        .join(name);
    let dst = dir.join(name);
    std::fs::copy(&src, &dst).unwrap_or_else(|e| panic!("{}: {e}", src.display()));
    dst
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn progress(mission: &Path) -> Value {
    let p = PathBuf::from(format!("{}.progress", mission.display()));
    let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    serde_json::from_str(&text).unwrap()
}

fn has_progress(mission: &Path) -> bool {
    Path::new(&format!("{}.progress", mission.display())).exists()
}

/// Every step of a summary's run ok and the device confirming `state` at the end.
fn passed(o: &Output, steps: usize, state: &str) -> (Vec<Value>, Value) {
    assert_eq!(code(o), 0, "{}", stderr(o));
    let (all, summary) = lines(o);
    assert_eq!(summary["ok"], true, "{summary}");
    assert_eq!(summary["done"], steps, "{summary}");
    assert_eq!(all.len(), steps);
    assert!(all.iter().all(|s| s["ok"] == true), "{all:?}");
    assert_eq!(summary["state"], state, "{summary}");
    assert_eq!(summary["state_confirmed"], true, "{summary}");
    (all, summary)
}

#[test]
fn the_manipulation_mission_places_the_three_objects() {
    let dir = cli::temp("run-manipulation");
    let m = example(&dir, "manipulation.toml");
    let o = run(
        &dir,
        &[
            "run",
            s(&m),
            "--sim",
            "--object",
            "low:0,0,43.1",
            "--object",
            "middle:7.8,0,90.5",
            "--object",
            "high:23.5,0,149.4",
            "-j",
        ],
    );
    let (steps, summary) = passed(&o, 17, "D&F");
    // Each close caught its object.
    let caught: Vec<&str> = steps
        .iter()
        .filter(|s| s["kind"] == "grip" && s["detail"]["gripper_closed"] == true)
        .filter_map(|s| s["detail"]["grasp"][0]["object"].as_str())
        .collect();
    assert_eq!(caught, ["low", "middle", "high"], "{steps:?}");
    // On the table below its place point, within the reach tolerance (5 mm).
    let places = [
        ("low", -6.2, 0.0),
        ("middle", -3.9, -6.8),
        ("high", -20.7, 0.0),
    ];
    let objects = summary["sim"]["world"]["objects"].as_array().unwrap();
    for (name, x, y) in places {
        let o = objects.iter().find(|o| o["name"] == name).unwrap();
        let p = &o["position_mm"];
        let d = (p[0].as_f64().unwrap() - x).hypot(p[1].as_f64().unwrap() - y);
        assert!(d <= 5.0, "{name}: {d} mm from its place point: {o}");
        assert_eq!(p[2].as_f64().unwrap(), 0.0, "{o}");
        assert_eq!(o["held"], false, "{o}");
    }
    assert!(!has_progress(&m));
}

#[test]
fn the_panel_mission_turns_the_panel_in_f_and_d() {
    let dir = cli::temp("run-panel");
    let m = example(&dir, "panel.toml");
    let o = run(&dir, &["run", s(&m), "--sim", "-j"]);
    let (steps, _) = passed(&o, 11, "F&D");
    let bends: Vec<f64> = steps
        .iter()
        .filter(|s| s["kind"] == "bend" && s["detail"]["bend_deg"] == 20.0)
        .map(|s| s["detail"]["toward_deg"].as_f64().unwrap())
        .collect();
    assert_eq!(bends, [0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0]);
    assert!(steps
        .iter()
        .all(|s| s["detail"]["state"] == "D&D" || s["detail"]["state"] == "F&D"));
}

#[test]
fn the_load_mission_holds_5_7_kg_in_d_and_d_without_air() {
    let dir = cli::temp("run-load");
    let m = example(&dir, "load.toml");
    let o = run(&dir, &["run", s(&m), "--sim", "-j"]);
    let (steps, summary) = passed(&o, 6, "D&D");
    let sim = &summary["sim"];
    assert_eq!(sim["true_state"], "D&D", "{summary}");
    assert_eq!(sim["world"]["tip_load_kg"], 5.7, "{summary}");
    // "No air": the controller's vent tolerance (0.5 kPa) and twice the sensor's noise.
    assert!(
        sim["pressure_kpa"].as_f64().unwrap().abs() <= 0.8,
        "{summary}"
    );
    // The hold is 60 s on the simulator's clock (to its 1 ms).
    let hold = steps.iter().find(|s| s["name"] == "hold").unwrap();
    assert!(
        (hold["duration_s"].as_f64().unwrap() - 60.0).abs() <= 0.001,
        "{hold}"
    );
}

/// `text` refused: exit 2, each `(line, needle)` on a `FILE:LINE:` line of stderr, and no
/// recording started (nothing was opened, nothing sent).
fn refused(dir: &Path, text: &str, extra: &[&str], expected: &[(usize, &str)]) {
    let m = write(dir, "bad.toml", text);
    let rec = dir.join("bad.mcap");
    let mut args = vec!["run", s(&m), "--record", s(&rec)];
    args.extend_from_slice(extra);
    let o = run(dir, &args);
    let e = stderr(&o);
    assert_eq!(code(&o), 2, "{text}\n{e}");
    assert!(e.contains("nothing was sent to the crane"), "{e}");
    for (line, needle) in expected {
        let want = format!("{}:{line}: ", m.display());
        assert!(
            e.lines().any(|l| l.contains(&want) && l.contains(needle)),
            "'{want}…{needle}' not in:\n{e}"
        );
    }
    assert!(
        !rec.exists(),
        "a recording was started for a refused mission"
    );
}

#[test]
fn every_refusal_names_its_line_and_reason_and_sends_nothing() {
    let dir = cli::temp("run-refusals");
    let sim = &["--sim"][..];
    refused(
        &dir,
        "[[step]]\nstate = \"F&P\"\n\n[[step]]\njump = 3\n",
        sim,
        &[(5, "unknown step kind 'jump'")],
    );
    refused(
        &dir,
        "[[step]]\nstate = \"X&Y\"\n",
        sim,
        &[(2, "unknown state 'X&Y'")],
    );
    refused(
        &dir,
        "[[step]]\nstate = \"D&P\"\n[[step]]\nbend = { angle = 9, toward = 0 }\n",
        sim,
        &[(4, "over D&P's limit of 4.18°")],
    );
    refused(
        &dir,
        "[[step]]\nstate = \"D&D\"\n[[step]]\nbend = { angle = 5, toward = 0 }\n",
        sim,
        &[(4, "where step 1 leaves the trunk: D&D is not bent")],
    );
    refused(
        &dir,
        "[[step]]\nbend = { angle = 80, toward = 0 }\n",
        sim,
        &[(2, "no state bends more than")],
    );
    refused(
        &dir,
        "[[step]]\nbend = { angle = 10 }\n",
        sim,
        &[(2, "a bend needs toward")],
    );
    refused(
        &dir,
        "[[step]]\nreach = [0, 0, 500]\n",
        sim,
        &[(2, "no state reaches (0.0, 0.0, 500.0) mm")],
    );
    refused(
        &dir,
        "[[step]]\nwait = \"60s\"\ntime_limit = \"30s\"\n",
        sim,
        &[(3, "can never end within its time limit")],
    );
    refused(
        &dir,
        "[[step]]\nwait = \"5 minutes\"\n",
        sim,
        &[(2, "not a duration")],
    );
    refused(
        &dir,
        "[[step]]\ngrip = \"open\"\non_failure = \"retry\"\n",
        sim,
        &[(3, "on_failure must be \"stop\"")],
    );
    refused(
        &dir,
        "[[step]]\ngrip = \"half\"\n",
        sim,
        &[(2, "grip must be \"open\" or \"close\"")],
    );
    refused(
        &dir,
        "[[step]]\naim = { toward = [400, 10] }\n",
        sim,
        &[(2, "azimuth [0, 360)")],
    );
    refused(
        &dir,
        "[[step]]\naim = { sun = true, lat = 37.2296, lon = -80.4139, time = \"2025-06-21T23:30-04:00\" }\n",
        sim,
        &[(2, "the sun is below the horizon")],
    );
    refused(
        &dir,
        "[[step]]\nprompt = { text = \"hang it\", tip_load_kg = 80 }\n",
        sim,
        &[(2, "tip_load_kg 80")],
    );
    refused(
        &dir,
        "[[step]]\nstate = \"D&F\"\ngrip = \"open\"\n",
        sim,
        &[(3, "a step does one thing")],
    );
    refused(&dir, "[[step]]\nstate = \"F&P\n", sim, &[(2, "")]);
    refused(&dir, "name = \"nothing\"\n", sim, &[(1, "no steps")]);
    // A prompt on a crane needs a person at a terminal (stdin is /dev/null here): refused
    // before the port is opened.
    refused(
        &dir,
        "[[step]]\nprompt = \"look\"\n",
        &["--port", "/dev/no-such-crane"],
        &[(2, "run the mission on a terminal")],
    );
    // All the problems of a file at once, in line order.
    refused(
        &dir,
        "[[step]]\nstate = \"D&D\"\n[[step]]\nbend = { angle = 5, toward = 0 }\n[[step]]\nwait = \"0s\"\n",
        sim,
        &[(4, "D&D is not bent"), (6, "not a duration")],
    );
    // The options' own refusals.
    let m = write(
        &dir,
        "two.toml",
        "[[step]]\ngrip = \"open\"\n[[step]]\ngrip = \"close\"\n",
    );
    let o = run(&dir, &["run", s(&m), "--sim", "--resume-from", "3"]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("has 2 steps"), "{}", stderr(&o));
    let o = run(&dir, &["run", s(&m), "--sim", "--resume"]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("no progress file"), "{}", stderr(&o));
    let o = run(&dir, &["run", s(&dir.join("none.toml")), "--sim"]);
    assert_eq!(code(&o), 2);
    assert!(
        stderr(&o).contains("cannot read the mission"),
        "{}",
        stderr(&o)
    );
    let o = run(&dir, &["run", s(&m)]);
    assert_eq!(code(&o), 2, "neither --port nor --sim: {}", stderr(&o));
    // A dry run validates and lists, with no device.
    let o = run(&dir, &["run", s(&m), "--dry-run", "-j"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["steps"].as_array().unwrap().len(), 2, "{v}");
}

/// The simulator starts in F&P, which does not bend: a bend first fails at run time (the
/// validation does not know the device's state yet).
const FAILS_FIRST: &str = "[[step]]\nbend = { angle = 10, toward = 0 }\n";

#[test]
fn skip_goes_on_and_stop_stops_safe_leaving_the_progress_file() {
    let dir = cli::temp("run-policies");
    let m = write(
        &dir,
        "skip.toml",
        &format!("{FAILS_FIRST}on_failure = \"skip\"\n[[step]]\ngrip = \"open\"\n"),
    );
    let o = run(&dir, &["run", s(&m), "--sim", "-j"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let (steps, summary) = lines(&o);
    assert_eq!(steps.len(), 2);
    assert_eq!(steps[0]["ok"], false);
    assert_eq!(steps[0]["skipped"], true);
    assert!(
        steps[0]["error"]
            .as_str()
            .unwrap()
            .contains("F&P is not bent"),
        "{}",
        steps[0]
    );
    assert_eq!(steps[1]["ok"], true);
    assert_eq!(summary["ok"], true);
    assert_eq!(summary["skipped"], serde_json::json!([1]));
    assert_eq!(summary["done"], 1);
    assert!(!has_progress(&m));

    let m = write(
        &dir,
        "stop.toml",
        &format!("{FAILS_FIRST}[[step]]\ngrip = \"open\"\n"),
    );
    let o = run(&dir, &["run", s(&m), "--sim", "-j"]);
    assert_eq!(code(&o), 1, "{}", stderr(&o));
    let (steps, summary) = lines(&o);
    assert_eq!(steps.len(), 1, "step 2 must not run: {steps:?}");
    assert_eq!(summary["stopped_at"], 1);
    assert!(
        stderr(&o).contains("error: step 1 (bend, line 2): "),
        "{}",
        stderr(&o)
    );
    // Stopped safe: nothing on the device runs or holds air, and the gripper was not touched.
    assert_eq!(summary["sim"]["true_state"], "F&P", "{summary}");
    assert_eq!(summary["state_confirmed"], true, "{summary}");
    let p = progress(&m);
    assert_eq!(p["next_step"], 1, "{p}");
    assert_eq!(p["interrupted"], false, "{p}");
}

#[test]
fn a_step_over_its_time_limit_is_aborted_and_fails_by_name() {
    let dir = cli::temp("run-limit");
    // F&P → D&D takes about 11 s of the simulator's time.
    let m = write(
        &dir,
        "limit.toml",
        "[[step]]\ngrip = \"open\"\n[[step]]\nstate = \"D&D\"\ntime_limit = \"2s\"\n[[step]]\ngrip = \"close\"\n",
    );
    let o = run(&dir, &["run", s(&m), "--sim", "-j"]);
    assert_eq!(code(&o), 1, "{}", stderr(&o));
    let (steps, summary) = lines(&o);
    assert_eq!(steps.len(), 2);
    let e = steps[1]["error"].as_str().unwrap();
    assert!(e.starts_with("exceeded its time limit of 2 s"), "{e}");
    // Aborted at the limit: the poll (100 ms) and the abort's answer, not the whole plan.
    let took = steps[1]["duration_s"].as_f64().unwrap();
    assert!((2.0..3.0).contains(&took), "{took}");
    assert!(
        summary["error"]
            .as_str()
            .unwrap()
            .starts_with("step 2 (state, line 4): exceeded its time limit of 2 s"),
        "{summary}"
    );
    assert_eq!(progress(&m)["next_step"], 2);
}

#[test]
fn a_stopped_mission_resumes_at_its_first_unfinished_step() {
    let dir = cli::temp("run-resume");
    let m = write(
        &dir,
        "resume.toml",
        "[[step]]\ngrip = \"open\"\n\n[[step]]\nstate = \"D&F\"\ntime_limit = \"2m\"\n\n[[step]]\ngrip = \"close\"\n",
    );
    // The inlet stuck closed: step 2 cannot pressurise.
    let o = run(
        &dir,
        &[
            "run",
            s(&m),
            "--sim",
            "--sim-fault",
            "valve-stuck-closed",
            "-j",
        ],
    );
    assert_eq!(code(&o), 1, "{}", stderr(&o));
    let (steps, summary) = lines(&o);
    assert_eq!((steps.len(), summary["stopped_at"].as_u64()), (2, Some(2)));
    let p = progress(&m);
    assert_eq!(
        (p["next_step"].as_u64(), p["line"].as_u64()),
        (Some(2), Some(5))
    );

    // Fixed: --resume starts at step 2, and the completed mission removes its progress file.
    let o = run(&dir, &["run", s(&m), "--sim", "--resume", "-j"]);
    let (steps, summary) = lines(&o);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let ran: Vec<u64> = steps.iter().map(|s| s["step"].as_u64().unwrap()).collect();
    assert_eq!(ran, [2, 3]);
    assert_eq!(summary["from_step"], 2);
    assert_eq!(summary["state"], "D&F");
    assert!(!has_progress(&m));

    // --resume-from N starts there whatever the file says.
    let o = run(&dir, &["run", s(&m), "--sim", "--resume-from", "3", "-j"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let (steps, _) = lines(&o);
    assert_eq!(steps.len(), 1);
    assert_eq!(steps[0]["step"], 3);

    // A progress file of another text of the mission is not trusted.
    let o = run(
        &dir,
        &["run", s(&m), "--sim", "--sim-fault", "valve-stuck-closed"],
    );
    assert_eq!(code(&o), 1);
    std::fs::write(&m, "[[step]]\ngrip = \"close\"\n").unwrap();
    let o = run(&dir, &["run", s(&m), "--sim", "--resume"]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("changed since"), "{}", stderr(&o));
}

#[test]
fn ctrl_c_during_a_wait_ends_safe_with_130_and_resumes_there() {
    let dir = cli::temp("run-sigint");
    let m = write(
        &dir,
        "wait.toml",
        "[[step]]\ngrip = \"open\"\n[[step]]\nwait = \"1h\"\n",
    );
    // Paced: the hour would take 3 min of wall time; the signal comes as soon as it starts.
    let mut child = cmd(&dir, &["run", s(&m), "--sim", "--sim-speed", "20", "-j"])
        .env_remove("CRANE_PORT")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let seen = cli::signal_at_line(
        &mut child,
        "step 2/2 (line 4): wait 3600 s",
        nix::sys::signal::Signal::SIGINT,
    );
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{seen}");
    assert!(
        seen.contains("interrupted while a mission waited"),
        "{seen}"
    );
    let (_, summary) = lines(&out);
    assert_eq!(summary["stopped_at"], 2, "{summary}");
    let p = progress(&m);
    assert_eq!(
        (p["next_step"].as_u64(), &p["interrupted"]),
        (Some(2), &Value::Bool(true))
    );
}

#[test]
fn a_mission_runs_through_serve() {
    let dir = cli::temp("run-serve");
    let (mut server, line) = cli::serve(
        &dir,
        &[
            "serve",
            "--sim",
            "--seed",
            "3",
            "--sim-speed",
            "100",
            "--no-record",
        ],
    );
    assert!(line.starts_with("serving the simulator on "), "{line}");
    let m = write(
        &dir,
        "served.toml",
        "[[step]]\ngrip = \"open\"\n[[step]]\nstate = \"F&F\"\n[[step]]\nbend = { angle = 10, toward = 90 }\n[[step]]\nbend = { angle = 0 }\n",
    );
    // A recording is the server's to make.
    let rec = dir.join("client.mcap");
    let o = run(&dir, &["run", s(&m), "--record", s(&rec)]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(
        stderr(&o).contains("records its session itself"),
        "{}",
        stderr(&o)
    );
    let o = run(&dir, &["run", s(&m), "-j"]);
    passed(&o, 4, "F&F");
    // What the server cannot do is refused up front.
    let bad = write(&dir, "identify.toml", "[[step]]\nidentify = true\n");
    let o = run(&dir, &["run", s(&bad)]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(
        stderr(&o).contains(":2: step 1 (identify): a mission's identify step does not go through")
    );
    server.kill().unwrap();
    server.wait().unwrap();
}

#[test]
fn a_recorded_mission_is_a_readable_recording() {
    let dir = cli::temp("run-record");
    let m = write(
        &dir,
        "rec.toml",
        "name = \"recorded\"\n[[step]]\ngrip = \"open\"\n[[step]]\nstate = \"F&F\"\n",
    );
    let rec = dir.join("run.mcap");
    let o = run(&dir, &["run", s(&m), "--sim", "--record", s(&rec), "-q"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let o = run(&dir, &["log", "summary", s(&rec)]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("session.command: run"), "{text}");
    assert!(text.contains("complete"), "{text}");
}
