//! The crane's tasks through the binary: `pose`, `workspace` (JSON and figure), `grip`,
//! `bend`, `vent` on the simulator and through `serve`, and every refusal with its reason and
//! exit code (2: usage, nothing sent; 1: refused by the device's state).

#[path = "support/cli.rs"]
mod cli;

use std::process::Output;

use cli::cmd;
use serde_json::Value;

fn run(dir: &std::path::Path, args: &[&str]) -> Output {
    cmd(dir, args).output().unwrap()
}

fn code(o: &Output) -> i32 {
    o.status.code().unwrap_or(-1)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn json(o: &Output) -> Value {
    serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&o.stdout)))
}

fn refused(dir: &std::path::Path, args: &[&str], exit: i32, needles: &[&str]) {
    let o = run(dir, args);
    assert_eq!(code(&o), exit, "{args:?}: {}", stderr(&o));
    let e = stderr(&o);
    for n in needles {
        assert!(e.contains(n), "{args:?}: '{n}' not in {e}");
    }
}

#[test]
fn pose_gives_the_geometrys_tip_and_refuses_bends_a_state_cannot_take() {
    let dir = cli::temp("tasks-pose");
    let o = run(&dir, &["pose", "--state", "D&F", "--bend", "20,90", "-j"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v = json(&o);
    // D&F: the folded bottom (59.43 mm) bends 20°, the deployed top (92.71 mm) rides on it.
    let (b, t, th) = (59.427f64, 92.714f64, 20f64.to_radians());
    let y = b * (1.0 - th.cos()) / th + t * th.sin();
    let z = b * th.sin() / th + t * th.cos();
    let tip = &v["tip_mm"];
    assert!(tip[0].as_f64().unwrap().abs() < 1e-3, "{v}");
    assert!((tip[1].as_f64().unwrap() - y).abs() < 0.01, "{v} vs {y}");
    assert!((tip[2].as_f64().unwrap() - z).abs() < 0.01, "{v} vs {z}");
    assert!((v["axis"][1].as_f64().unwrap() - th.sin()).abs() < 1e-5);
    refused(
        &dir,
        &["pose", "--state", "D&D", "--bend", "5,0"],
        2,
        &["D&D is not bent"],
    );
    refused(
        &dir,
        &["pose", "--state", "D&P", "--bend", "9,0"],
        2,
        &[
            "over D&P's limit of 4.18°",
            "nearest feasible bend is 4.18°",
        ],
    );
    refused(
        &dir,
        &["pose", "--state", "F&F", "--bend", "20"],
        2,
        &["expected ANGLE,DIRECTION"],
    );
    refused(&dir, &["pose", "--state", "X&Y"], 2, &["F&P, F&F"]);
    refused(
        &dir,
        &["pose", "--state", "F&F", "--bend", "-1,0"],
        2,
        &["≥ 0°"],
    );
}

#[test]
fn workspace_lists_six_states_and_draws_their_side_view() {
    let dir = cli::temp("tasks-workspace");
    let fig = dir.join("ws.svg");
    let o = run(
        &dir,
        &["workspace", "-j", "--figure", fig.to_str().unwrap()],
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v = json(&o);
    let states = v["states"].as_array().unwrap();
    let names: Vec<&str> = states
        .iter()
        .map(|s| s["state"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["F&P", "F&F", "F&D", "D&P", "D&F", "D&D"]);
    let get = |n: &str, k: &str| {
        states.iter().find(|s| s["state"] == n).unwrap()[k]
            .as_f64()
            .unwrap_or(f64::NAN)
    };
    // Not bent: one point each; D&F (a folded bottom under a long deployed top) reaches
    // furthest sideways.
    assert_eq!(get("F&P", "reach_mm"), 0.0);
    assert_eq!(get("D&D", "reach_mm"), 0.0);
    assert!(get("D&F", "reach_mm") > 2.0 * get("F&F", "reach_mm"));
    assert!(get("F&F", "reach_mm") > get("F&D", "reach_mm"));
    // The controller's limits (30° with a folded module, 8° in D&P) less the take-up margin's
    // 2·2 mm / 60 mm.
    let margin = (4.0f64 / 60.0).to_degrees();
    assert!((get("F&F", "bend_limit_deg") - (30.0 - margin)).abs() < 1e-3);
    assert!((get("D&P", "bend_limit_deg") - (8.0 - margin)).abs() < 1e-3);
    assert!(get("D&D", "bend_limit_deg").is_nan());
    let svg = std::fs::read_to_string(&fig).unwrap();
    for label in ["F&amp;P (not bent)", "D&amp;F ±26.2°", "x (mm)", "z (mm)"] {
        assert!(svg.contains(label), "{label}");
    }
    refused(&dir, &["workspace", "--samples", "1"], 2, &["2 to 10000"]);
    refused(
        &dir,
        &[
            "workspace",
            "--figure",
            dir.join("ws.jpg").to_str().unwrap(),
        ],
        2,
        &[".svg, .png or .pdf"],
    );
}

#[test]
fn primitives_on_the_simulator_and_their_refusals() {
    let dir = cli::temp("tasks-prims");
    // The gripper is fail-closed: a fresh simulator's is closed.
    refused(&dir, &["grip", "close", "--sim"], 1, &["already closed"]);
    let o = run(&dir, &["grip", "open", "--sim", "-j"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["gripper_closed"], false);
    // A bend in D&F ends where the geometry says, within the simulator's stated tolerance
    // (docs/geometry.md: 11 mm for D&F).
    let o = run(
        &dir,
        &[
            "bend",
            "15",
            "--toward",
            "0",
            "--sim",
            "--sim-initial",
            "D&F",
            "-j",
        ],
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["state"], "D&F");
    assert_eq!(v["sim"]["true_state"], "D&F");
    let d: f64 = (0..3)
        .map(|k| v["tip_mm"][k].as_f64().unwrap() - v["sim"]["true_tip_mm"][k].as_f64().unwrap())
        .map(|e| e * e)
        .sum::<f64>()
        .sqrt();
    assert!(d < 11.0, "{v}");
    // --record: the primitive's session in MCAP.
    let rec = dir.join("bend.mcap");
    let o = run(
        &dir,
        &[
            "bend",
            "10",
            "--toward",
            "0",
            "--sim",
            "--sim-initial",
            "F&F",
            "--record",
            rec.to_str().unwrap(),
        ],
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let s = run(&dir, &["log", "summary", rec.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&s.stdout).into_owned();
    assert!(
        text.contains("session.command: bend") && text.contains("/sim/truth"),
        "{text}"
    );
    assert!(v["sim"]["true_tip_mm"][0].as_f64().unwrap() > 20.0, "{v}");
    // Refusals: the state, the limit, the value, the direction.
    refused(
        &dir,
        &["bend", "10", "--toward", "0", "--sim"],
        1,
        &["F&P is not bent"],
    );
    refused(
        &dir,
        &["bend", "0", "--sim", "--sim-initial", "D&D"],
        1,
        &["nothing to straighten"],
    );
    refused(
        &dir,
        &[
            "bend",
            "5",
            "--toward",
            "0",
            "--sim",
            "--sim-initial",
            "D&P",
        ],
        1,
        &["over D&P's limit of 4.18°"],
    );
    refused(&dir, &["bend", "-3", "--sim"], 2, &["≥ 0°"]);
    refused(
        &dir,
        &["bend", "40", "--toward", "0", "--sim"],
        2,
        &["26.18°"],
    );
    refused(&dir, &["bend", "10", "--sim"], 2, &["--toward DIR"]);
    refused(
        &dir,
        &["bend", "ten", "--toward", "0", "--sim"],
        2,
        &["expected a number"],
    );
    refused(&dir, &["bend", "10", "--toward", "0"], 2, &["--sim"]);
    // Nothing to let out at ambient pressure.
    refused(&dir, &["vent", "--sim"], 1, &["nothing to let out"]);
    // The world's options: checked up front, for the simulator only.
    refused(
        &dir,
        &["grip", "open", "--sim", "--object", "cup"],
        2,
        &["NAME:X,Y,Z"],
    );
    refused(
        &dir,
        &["grip", "open", "--sim", "--object", "cup:0,0,-5"],
        2,
        &["z ≥ 0"],
    );
    refused(
        &dir,
        &["grip", "open", "--sim", "--tip-load-kg", "-1"],
        2,
        &["[0, 50]"],
    );
    refused(
        &dir,
        &[
            "grip", "open", "--sim", "--object", "a:0,0,1", "--object", "a:0,0,2",
        ],
        2,
        &["two objects are named 'a'"],
    );
    refused(
        &dir,
        &["grip", "open", "--port", "/dev/null", "--object", "a:0,0,1"],
        2,
        &["need --sim"],
    );
    // An object placed at a closed gripper is not held: only closing catches.
    let o = run(
        &dir,
        &["grip", "open", "--sim", "--object", "cup:0,0,43,0.1", "-j"],
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["grasp"], serde_json::json!([]), "{v}");
    assert_eq!(v["sim"]["world"]["objects"][0]["position_mm"][2], 43.0);
}

#[test]
fn primitives_go_through_a_server_and_keep_its_state() {
    let dir = cli::temp("tasks-serve");
    struct Kill(std::process::Child);
    impl Drop for Kill {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
    let (server, line) = cli::serve(
        &dir,
        &[
            "serve",
            "--sim",
            "--sim-initial",
            "F&F",
            "--sim-speed",
            "20",
            "--no-record",
        ],
    );
    let _server = Kill(server);
    assert!(line.starts_with("serving the simulator on "), "{line}");
    let o = run(&dir, &["grip", "open", "-j"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    assert_eq!(json(&o)["gripper_closed"], false);
    // The server's device remembers: opening again is refused.
    refused(&dir, &["grip", "open"], 1, &["already open"]);
    let o = run(&dir, &["bend", "10", "--toward", "120", "-j"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["state"], "F&F");
    assert!(
        v["servo_deg"][1].as_f64() > v["servo_deg"][0].as_f64(),
        "{v}"
    );
    refused(
        &dir,
        &["grip", "close", "--object", "a:0,0,1"],
        2,
        &["server holds"],
    );
    refused(
        &dir,
        &["grip", "close", "--record", "x.mcap"],
        2,
        &["records its session itself"],
    );
    // Reach through the server: a D&F point from F&F, so the server runs the transition.
    let p = run(&dir, &["pose", "--state", "D&F", "--bend", "10,0", "-j"]);
    let tip = json(&p)["tip_mm"].clone();
    let point = format!("{},{},{}", tip[0], tip[1], tip[2]);
    let o = run(&dir, &["reach", "--point", &point, "-j"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["plan"]["state"], "D&F");
    assert_eq!(v["state"], "D&F");
    assert_eq!(v["state_confirmed"], true);
}

#[test]
fn reach_goes_to_the_cheapest_state_or_refuses_with_the_nearest_point() {
    let dir = cli::temp("tasks-reach");
    // A point of D&F's workspace (12° toward 90°), from F&P: two pneumatic steps, then the
    // bend; the simulator's true tip within the 5 mm tolerance.
    let p = run(&dir, &["pose", "--state", "D&F", "--bend", "12,90", "-j"]);
    let tip = json(&p)["tip_mm"].clone();
    let point = format!("{},{},{}", tip[0], tip[1], tip[2]);
    let o = run(&dir, &["reach", "--point", &point, "--sim", "-j"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["plan"]["state"], "D&F");
    assert_eq!(v["plan"]["transitions"].as_array().unwrap().len(), 2);
    assert_eq!(v["state"], "D&F");
    assert!(v["sim"]["error_mm"].as_f64().unwrap() <= 5.0, "{v}");
    // A dry run plans and moves nothing.
    let o = run(
        &dir,
        &["reach", "--point", &point, "--sim", "--dry-run", "-j"],
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    assert_eq!(json(&o)["dry_run"], true);
    // Out of every workspace: refused up front with the nearest point, its state and distance.
    refused(
        &dir,
        &["reach", "--point", "0,0,300", "--sim"],
        2,
        &[
            "nearest reachable point is (0.0, 0.0, 197.7) mm in D&D",
            "102.3 mm away",
        ],
    );
    refused(
        &dir,
        &["reach", "--point", "0,30,140", "--port", "/dev/null"],
        2,
        &["D&F"],
    );
    refused(
        &dir,
        &["reach", "--point", "1,2", "--sim"],
        2,
        &["expected X,Y,Z"],
    );
    refused(
        &dir,
        &["reach", "--point", "0,0,nan", "--sim"],
        2,
        &["expected X,Y,Z"],
    );
    refused(
        &dir,
        &["reach", "--point", "0,0,43", "--tolerance", "0", "--sim"],
        2,
        &["> 0"],
    );
    // On the simulator the host plans with the workspace calibrated against it: the geometry's
    // F&F reaches 20.8 mm sideways, the simulated F&F only ≈ 13.5 mm, so this point is refused
    // with F&F's nearest.
    refused(
        &dir,
        &["reach", "--point", "20,0,90", "--sim"],
        2,
        &["nearest reachable point is", "in F&F"],
    );
    // Inside it, the true tip ends within the tolerance.
    let o = run(&dir, &["reach", "--point", "12,0,90.5", "--sim", "-j"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["plan"]["state"], "F&F");
    assert!(v["sim"]["error_mm"].as_f64().unwrap() <= 2.0, "{v}");
}

#[test]
fn pick_catches_carries_and_drops_and_says_what_became_of_the_object() {
    let dir = cli::temp("tasks-pick");
    let place = json(&run(
        &dir,
        &["pose", "--state", "F&F", "--bend", "15,180", "-j"],
    ))["tip_mm"]
        .clone();
    let place = format!("{},{},{}", place[0], place[1], place[2]);
    let o = run(
        &dir,
        &[
            "pick",
            "--at",
            "0,0,43.1",
            "--place",
            &place,
            "--sim",
            "--object",
            "cup:0,0,43.1,0.2",
            "-j",
        ],
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["object"], "cup");
    let events: Vec<&str> = v["events"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["event"].as_str().unwrap())
        .collect();
    assert_eq!(events, ["captured", "released"], "{v}");
    let cup = &v["sim"]["objects"][0];
    assert_eq!(cup["held"], false);
    assert_eq!(cup["position_mm"][2], 0.0);
    let x = cup["position_mm"][0].as_f64().unwrap();
    assert!((x - (-12.0)).abs() < 5.0, "{v}");
    // Nothing at the point: the gripper closes on nothing, the run fails and says so.
    let o = run(
        &dir,
        &[
            "pick",
            "--at",
            "0,0,43.1",
            "--place",
            &place,
            "--sim",
            "--object",
            "cup:60,0,0",
            "-j",
        ],
    );
    assert_eq!(code(&o), 1, "{}", stderr(&o));
    let v = json(&o);
    assert!(
        v["error"].as_str().unwrap().contains("nothing was caught"),
        "{v}"
    );
    assert_eq!(
        v["object_fate"],
        "not caught (the simulator's world: nothing at the grasp point)"
    );
    refused(
        &dir,
        &["pick", "--at", "0,0,400", "--place", &place, "--sim"],
        2,
        &["no state reaches"],
    );
}

#[test]
fn the_papers_demonstrations_pass_on_the_simulator_against_the_truth() {
    let dir = cli::temp("tasks-demo");
    let rec = dir.join("demo.mcap");
    let o = run(
        &dir,
        &[
            "demo",
            "manipulation",
            "--sim",
            "-j",
            "--record",
            rec.to_str().unwrap(),
        ],
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    // The recording's /sim/truth carries the true tip and the objects, held or not.
    let csv = dir.join("csv");
    let e = run(
        &dir,
        &[
            "log",
            "export",
            rec.to_str().unwrap(),
            "--csv",
            csv.to_str().unwrap(),
        ],
    );
    assert_eq!(code(&e), 0, "{}", stderr(&e));
    let truth = std::fs::read_to_string(csv.join("sim_truth.csv")).unwrap();
    let header = truth.lines().next().unwrap();
    assert!(
        header.contains("tip_mm_0") && header.contains("objects"),
        "{header}"
    );
    assert!(truth.contains(r#""held"":true"#), "no object was ever held");
    // The 3D scene shows the objects and the gripper.
    let bytes = std::fs::read(&rec).unwrap();
    let mut ids = std::collections::BTreeSet::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        if m.channel.topic == "/scene" {
            for id in ["object-low", "object-middle", "object-high", "gripper"] {
                if m.data.windows(id.len()).any(|w| w == id.as_bytes()) {
                    ids.insert(id);
                }
            }
        }
    }
    assert_eq!(ids.len(), 4, "{ids:?}");
    let v = json(&o);
    assert_eq!(v["ok"], true);
    let verdict = v["verdict"].as_array().unwrap();
    assert_eq!(verdict.len(), 3);
    for p in verdict {
        assert_eq!(p["placed"], true, "{v}");
        assert!(p["from_place_mm"].as_f64().unwrap() <= 5.0);
        assert_eq!(p["position_mm"][2], 0.0);
    }
    assert_eq!(v["state"], "D&F");
    let o = run(&dir, &["demo", "load", "--sim", "-j"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["ok"], true);
    assert_eq!(v["state"], "D&D");
    assert_eq!(v["state_confirmed"], true);
    assert_eq!(v["sim"]["true_state"], "D&D");
    assert_eq!(v["sim"]["tip_load_kg"], 5.7);
    assert!(
        v["sim"]["pressure_kpa"].as_f64().unwrap().abs() <= 0.8,
        "{v}"
    );
    let o = run(&dir, &["demo", "panel", "--sim", "-j"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["state"], "F&D");
    let turns = v["turns"].as_array().unwrap();
    assert_eq!(turns.len(), 8);
    for t in turns {
        assert!(t["facing_error_deg"].as_f64().unwrap() <= 15.0, "{v}");
        assert!(t["true_tilt_deg"].as_f64().unwrap() >= 12.0, "{v}");
    }
    assert!(v["height_span_mm"].as_f64().unwrap() <= 4.0, "{v}");
    refused(
        &dir,
        &["demo", "juggle", "--sim"],
        2,
        &["manipulation", "panel", "load"],
    );
}

#[test]
fn a_load_over_what_the_state_holds_collapses_it_and_the_report_says_so() {
    let dir = cli::temp("tasks-collapse");
    // 9 kg is more than D&F holds (8.11 kg, BENCHMARKS.md): the deployed top buckles. The
    // device's word and the truth then differ, and the command does not claim success.
    let o = run(
        &dir,
        &[
            "grip",
            "open",
            "--sim",
            "--sim-initial",
            "D&F",
            "--tip-load-kg",
            "9",
            "-j",
        ],
    );
    assert_eq!(code(&o), 1, "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["ok"], false);
    assert_eq!(v["sim"]["matches_device"], false);
    assert_ne!(v["sim"]["true_state"], "D&F");
    assert!(
        v["error"].as_str().unwrap().contains("did not notice"),
        "{v}"
    );
    // 5 kg it holds: the same command succeeds.
    let o = run(
        &dir,
        &[
            "grip",
            "open",
            "--sim",
            "--sim-initial",
            "D&F",
            "--tip-load-kg",
            "5",
            "-j",
        ],
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    assert_eq!(json(&o)["sim"]["true_state"], "D&F");
}

/// §6.3's first part (the cup on the straight F&P tip, placed from F&F) with `fault` injected.
fn pick_with_fault(dir: &std::path::Path, fault: &str) -> Output {
    run(
        dir,
        &[
            "pick",
            "--at",
            "0,0,43.1",
            "--place",
            "-12,0,91.5",
            "--sim",
            "--object",
            "cup:0,0,43.1",
            "--sim-fault",
            fault,
            "-j",
        ],
    )
}

#[test]
fn a_fault_mid_pick_ends_safe_and_reports_the_objects_fate() {
    let dir = cli::temp("tasks-fault");
    // A leak stalls the F&P → F&F inflation that carries the caught object: the pick fails,
    // the object is still held (the truth), the device's state is unconfirmed.
    let o = pick_with_fault(&dir, "leak");
    assert_eq!(code(&o), 1, "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["ok"], false);
    assert!(v["error"].as_str().unwrap().contains("E-08"), "{v}");
    // What the crane can tell (its gripper is closed), and the truth beside it.
    assert_eq!(v["object_fate"], "held (the gripper is closed)");
    assert_eq!(v["sim"]["objects"][0]["held"], true);
    // The inflation went above the pressure under which nothing snaps (4 kPa), so the device
    // cannot vouch that the trunk stayed at F&P: it says so (the truth is F&P: the tip is
    // within 10 mm of the packed height, 43.1 mm, far under F&F's 91.5 mm).
    assert_eq!(v["state"], "F&P");
    assert_eq!(v["state_confirmed"], false);
    let z = v["sim"]["tip_mm"][2].as_f64().unwrap();
    assert!((43.1..53.1).contains(&z), "{v}");
}

#[test]
fn a_lost_link_mid_pick_leaves_the_objects_fate_unknown() {
    let dir = cli::temp("tasks-link");
    // The link falls silent 1 s into the carry's step, with the cup in the gripper: the host
    // cannot tell what became of it (the simulator's truth: still held, the device safe).
    let o = pick_with_fault(&dir, "link-drop");
    assert_eq!(code(&o), 1, "{}", stderr(&o));
    let v = json(&o);
    assert!(v["error"].as_str().unwrap().contains("link lost"), "{v}");
    assert_eq!(
        v["object_fate"],
        "unknown (the device does not answer: look at the crane)"
    );
    assert_eq!(v["state"], Value::Null, "no state is claimed: {v}");
    assert_eq!(v["sim"]["objects"][0]["held"], true);
}

#[test]
fn ctrl_c_mid_pick_ends_safe_with_130_and_reports_the_objects_fate() {
    let dir = cli::temp("tasks-sigint");
    // Paced at ×5 so the carry's inflation (≈ 4 s) is still running when the signal comes.
    let mut child = cmd(
        &dir,
        &[
            "pick",
            "--at",
            "0,0,43.1",
            "--place",
            "-12,0,91.5",
            "--sim",
            "--sim-speed",
            "5",
            "--object",
            "cup:0,0,43.1",
            "-j",
        ],
    )
    .stdout(std::process::Stdio::piped())
    .stderr(std::process::Stdio::piped())
    .spawn()
    .unwrap();
    let seen = cli::signal_at_line(
        &mut child,
        "step 1/1 pneumatic F&P → F&F",
        nix::sys::signal::Signal::SIGINT,
    );
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{seen}");
    let v: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {seen}"));
    assert_eq!(v["ok"], false);
    assert!(v["error"].as_str().unwrap().contains("interrupted"), "{v}");
    // The device is in its safe state and the gripper stayed closed on the cup: what the crane
    // reports is what the simulator's truth shows.
    assert_eq!(v["object_fate"], "held (the gripper is closed)", "{v}");
    assert_eq!(v["sim"]["objects"][0]["held"], true, "{v}");
    assert!(
        seen.contains("aborted"),
        "the cut step says it was aborted:\n{seen}"
    );
}
