//! `host-tool sun`, `host-tool station` and `fk`'s top-face frames through the real binary:
//! values against the library, the figure in every format, and bad input refused (exit 2).

#[path = "support/cli.rs"]
mod cli;

use cli::{host_tool, json, usage_error};

use std::process::Command;

use serde_json::Value;

const SITE: [&str; 6] = [
    "--lat",
    "37.2296",
    "--lon",
    "-80.4139",
    "--elevation-m",
    "634",
];

#[test]
fn sun_at_an_instant_matches_pvlib_and_says_when_it_is_down() {
    let mut args = vec![
        "sun",
        "-j",
        "--delta-t",
        "74.744292",
        "--time",
        "2025-06-21T13:00:00-04:00",
    ];
    args.extend(SITE);
    let v = json(&args);
    // pvlib's row for this instant (crates/planner/tests/data/sun_pvlib.csv).
    assert!((v["azimuth_deg"].as_f64().unwrap() - 158.207228577).abs() < 1e-3);
    assert!((v["zenith_deg"].as_f64().unwrap() - 14.686786229).abs() < 1e-3);
    assert!((v["elevation_deg"].as_f64().unwrap() - (90.0 - 14.686786229)).abs() < 1e-3);
    assert_eq!(v["time"], "2025-06-21T13:00:00-04:00");
    assert_eq!(v["up"], true);
    let mut night = vec!["sun", "--time", "2025-06-21T02:00-04:00"];
    night.extend(SITE);
    let out = host_tool(&night);
    assert!(String::from_utf8_lossy(&out.stdout).contains("below the horizon"));
}

#[test]
fn sun_tables_give_sunrise_sunset_and_polar_days() {
    let mut args = vec![
        "sun",
        "-j",
        "--date",
        "2025-06-21",
        "--tz",
        "-04:00",
        "--every",
        "2h",
    ];
    args.extend(SITE);
    let v = json(&args);
    assert_eq!(v["daylight"], "regular");
    assert_eq!(v["samples"].as_array().unwrap().len(), 12);
    assert!(v["sunrise"][0]
        .as_str()
        .unwrap()
        .starts_with("2025-06-21T06:0"));
    let polar = json(&[
        "sun",
        "-j",
        "--lat",
        "-77.85",
        "--lon",
        "166.67",
        "--date",
        "2025-12-21",
        "--tz",
        "+13:00",
    ]);
    assert_eq!(polar["daylight"], "polar-day");
    assert!(polar["samples"]
        .as_array()
        .unwrap()
        .iter()
        .all(|s| s["up"] == true));
    let night = json(&[
        "sun",
        "-j",
        "--lat",
        "78.22",
        "--lon",
        "15.63",
        "--date",
        "2025-12-21",
        "--tz",
        "Z",
    ]);
    assert_eq!(night["daylight"], "polar-night");
    assert!(night["samples"]
        .as_array()
        .unwrap()
        .iter()
        .all(|s| s["up"] == false));
}

#[test]
fn sun_and_station_refuse_bad_input_with_the_reason() {
    usage_error(
        &[
            "sun",
            "--lat",
            "90.5",
            "--lon",
            "0",
            "--time",
            "2025-01-01T00:00Z",
        ],
        "[-90°, 90°]",
    );
    usage_error(
        &[
            "sun",
            "--lat",
            "0",
            "--lon",
            "-180.5",
            "--time",
            "2025-01-01T00:00Z",
        ],
        "[-180°, 180°]",
    );
    usage_error(
        &[
            "sun",
            "--lat",
            "0",
            "--lon",
            "0",
            "--time",
            "2025-02-30T00:00Z",
        ],
        "RFC 3339",
    );
    usage_error(
        &[
            "sun",
            "--lat",
            "0",
            "--lon",
            "0",
            "--time",
            "2025-01-01T00:00",
        ],
        "offset",
    );
    usage_error(
        &[
            "sun",
            "--lat",
            "0",
            "--lon",
            "0",
            "--date",
            "2025-13-01",
            "--tz",
            "Z",
        ],
        "calendar date",
    );
    usage_error(
        &["sun", "--lat", "0", "--lon", "0", "--date", "2025-06-01"],
        "--tz",
    );
    usage_error(
        &[
            "sun",
            "--lat",
            "0",
            "--lon",
            "0",
            "--date",
            "2025-06-01",
            "--tz",
            "+25:00",
        ],
        "UTC offset",
    );
    usage_error(
        &[
            "sun",
            "--lat",
            "0",
            "--lon",
            "0",
            "--date",
            "2025-06-01",
            "--tz",
            "Z",
            "--every",
            "0s",
        ],
        "zero",
    );
    usage_error(&["sun", "--lat", "0", "--lon", "0"], "--time");
    let mut st = vec!["station", "--date", "2025-06-21", "--tz", "-04:00"];
    st.extend(SITE);
    let with = |extra: &[&'static str]| {
        let mut a = st.clone();
        a.extend(extra);
        a
    };
    usage_error(&with(&["--max-changes", "-1"]), "negative");
    usage_error(&with(&["--every", "0m"]), "zero");
    usage_error(&with(&["--adjustable", "5"]), "--adjustable");
    usage_error(
        &with(&["--from", "20:00", "--to", "09:00"]),
        "before they start",
    );
    usage_error(&with(&["--fixed", "deployed"]), "--fixed has 1 states");
    usage_error(&with(&["--heading", "nan"]), "heading");
}

fn station(extra: &[&str]) -> Value {
    let mut args = vec![
        "station",
        "-j",
        "--date",
        "2025-06-21",
        "--tz",
        "-04:00",
        "--delta-t",
        "69",
    ];
    args.extend(SITE);
    args.extend(extra);
    json(&args)
}

#[test]
fn station_schedules_respect_the_budget_and_beat_the_flat_top() {
    let free = station(&["--every", "20m"]);
    let k2 = station(&["--every", "20m", "--max-changes", "2"]);
    let k0 = station(&["--every", "20m", "--max-changes", "0"]);
    let f = |v: &Value, k: &str| v[k].as_f64().unwrap();
    assert_eq!(free["samples"].as_array().unwrap().len(), 34); // 09:00 … 20:00
    assert!(k2["changes"].as_u64().unwrap() <= 2);
    assert_eq!(k0["changes"], 0);
    assert_eq!(
        k2["refolds"].as_array().unwrap().len() as u64,
        k2["changes"].as_u64().unwrap()
    );
    let flat = f(&free, "flat_beam_fraction");
    assert!((flat - f(&k2, "flat_beam_fraction")).abs() < 1e-12);
    assert!(f(&free, "tracked_beam_fraction") >= f(&k2, "tracked_beam_fraction") - 1e-12);
    assert!(f(&k2, "tracked_beam_fraction") >= f(&k0, "tracked_beam_fraction") - 1e-12);
    assert!(f(&k0, "tracked_beam_fraction") >= flat - 1e-12);
    assert!(
        f(&free, "tracked_beam_fraction") > flat * 1.2,
        "tracking gains over 20 %"
    );
    let gain = f(&k2, "gain");
    assert!((gain - (f(&k2, "tracked_beam_fraction") / flat - 1.0)).abs() < 1e-12);
    // Every sample's incidence is the angle between its normal and the sun.
    for s in k2["samples"].as_array().unwrap() {
        let n: Vec<f64> = s["normal"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert!(((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() - 1.0).abs() < 1e-12);
        let inc = s["incidence_deg"].as_f64().unwrap();
        assert!((s["beam"].as_f64().unwrap() - inc.to_radians().cos().max(0.0)).abs() < 1e-9);
        assert_eq!(s["states"].as_array().unwrap().len(), 2);
    }
    // Each refold names its modules and a folding instruction in pattern terms.
    for r in k2["refolds"].as_array().unwrap() {
        for m in r["modules"].as_array().unwrap() {
            assert!(m["module"].as_u64().unwrap() >= 3);
            assert!(m["instruction"].as_str().unwrap().contains("facets"));
        }
    }
}

#[test]
fn station_without_feasible_pop_outs_says_what_it_costs() {
    let v = station(&["--n", "4", "--beta", "35", "--every", "1h"]);
    assert_eq!(v["pop_outs_available"], false);
    assert_eq!(v["tracked_beam_fraction"], v["flat_beam_fraction"]);
    assert_eq!(v["gain"].as_f64().unwrap(), 0.0);
    let note = v["note"].as_str().unwrap();
    assert!(
        note.contains("no pop-out state") && note.contains("forgoes"),
        "{note}"
    );
}

#[test]
fn station_in_polar_night_has_nothing_to_track() {
    let v = json(&[
        "station",
        "-j",
        "--lat",
        "78.22",
        "--lon",
        "15.63",
        "--date",
        "2025-12-21",
        "--tz",
        "Z",
        "--every",
        "1h",
    ]);
    assert!(v["tracked_beam_fraction"].is_null() && v["gain"].is_null());
    assert!(v["samples"]
        .as_array()
        .unwrap()
        .iter()
        .all(|s| s["incidence_deg"].is_null()));
}

#[test]
fn station_figure_in_every_format() {
    let dir = std::env::temp_dir().join(format!("cli-station-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (svg, png, pdf) = (dir.join("s.svg"), dir.join("s.png"), dir.join("s.pdf"));
    let mut args = vec![
        "station",
        "--date",
        "2025-06-21",
        "--tz",
        "-04:00",
        "--max-changes",
        "4",
        "--every",
        "30m",
    ];
    args.extend(SITE);
    let (s, p, d) = (
        svg.to_str().unwrap(),
        png.to_str().unwrap(),
        pdf.to_str().unwrap(),
    );
    args.extend(["--svg", s, "--png", p, "--pdf", d]);
    let out = host_tool(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains(r#"class="tracked""#) && text.contains(r#"class="flat""#));
    assert_eq!(
        text.matches("stroke-dasharray=\"1.5 1.5\"").count(),
        4 + 1,
        "4 refolds + legend"
    );
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    assert!(std::fs::read(&pdf).unwrap().starts_with(b"%PDF"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn fk_frames_carry_unit_normals_and_their_compass_direction() {
    let golden = "31.717474411461005";
    let v = json(&[
        "fk",
        "--n",
        "3",
        "--beta",
        golden,
        "--states",
        "deployed,edge-0",
        "--json",
        "--heading",
        "0",
    ]);
    assert_eq!(v["heading_deg"], 0.0);
    let frames = v["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 2);
    assert_eq!(frames[0]["normal"], serde_json::json!([0.0, 0.0, 1.0]));
    assert_eq!(frames[0]["normal_elevation_deg"], 90.0);
    let n: Vec<f64> = frames[1]["normal"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    // edge-0 leans towards edge 0's midpoint, at 60° in the base frame; tips equal origins.
    assert!((n[1].atan2(n[0]).to_degrees() - 60.0).abs() < 1e-9);
    assert_eq!(frames[1]["origin"], v["tips"][1]);
    // Heading 0: base x is north, so 60° counter-clockwise from x is azimuth 300°.
    assert!((frames[1]["normal_azimuth_deg"].as_f64().unwrap() - 300.0).abs() < 1e-9);
    let rot = &frames[1]["rotation"];
    for k in 0..3 {
        assert!(
            (rot[k][2].as_f64().unwrap() - n[k]).abs() < 1e-15,
            "third column is the normal"
        );
    }
    let east = json(&[
        "fk", "--n", "3", "--beta", golden, "--states", "edge-0", "--json",
    ]);
    assert!((east["frames"][0]["normal_azimuth_deg"].as_f64().unwrap() - 30.0).abs() < 1e-9);
}

#[test]
fn aim_points_within_the_limit_names_a_better_state_and_refuses_a_set_sun() {
    let v = json(&["aim", "-j", "--toward", "135,40", "--state", "F&D"]);
    // 50° from vertical with the held limit (the controller's 30° less the tendons' take-up
    // margin): the rest is the error, bending towards azimuth 135° (base 315°).
    let limit = v["max_bend_deg"].as_f64().unwrap();
    assert!(limit > 25.0 && limit < 30.0, "{limit}");
    assert!((v["error_deg"].as_f64().unwrap() - (50.0 - limit)).abs() < 1e-6);
    assert!((v["bend_deg"].as_f64().unwrap() - limit).abs() < 1e-9);
    assert!((v["bend_direction_deg"].as_f64().unwrap() - 315.0).abs() < 1e-9);
    assert!(v["better_state"].is_null());
    assert_eq!(v["moved"], false);
    let dd = json(&["aim", "-j", "--toward", "135,80", "--state", "D&D"]);
    assert_eq!(dd["max_bend_deg"], 0.0);
    assert!((dd["error_deg"].as_f64().unwrap() - 10.0).abs() < 1e-9);
    assert!(dd["better_error_deg"].as_f64().unwrap() < 1e-6);
    let out = host_tool(&[
        "aim",
        "--sun",
        "--lat",
        "37.2296",
        "--lon",
        "-80.4139",
        "--time",
        "2025-06-21T02:00-04:00",
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("below the horizon"));
    usage_error(&["aim", "--toward", "400,10"], "AZ,EL");
    usage_error(&["aim", "--sun", "--lat", "37"], "--lon");
    usage_error(
        &["aim", "--toward", "10,10", "--state", "X&Y"],
        "trunk state",
    );
    usage_error(&["aim", "--toward", "10,10", "--change-state"], "--sim");
    usage_error(
        &["aim", "--toward", "10,10", "--state", "F&D", "--sim"],
        "--state",
    );
}

/// The simulator's true tip axis after `aim --sim`, against the reported error plus the
/// calibrated model's tolerance, for targets within and beyond the bend limit and in several
/// compass directions.
#[test]
fn aim_on_the_simulator_points_the_true_tip_within_the_reported_error() {
    for (toward, want_err) in [
        ("90,80", 0.0),
        ("200,75", 0.0),
        ("330,66", 0.0),
        ("45,40", 20.0),
    ] {
        let v = json(&[
            "aim",
            "-j",
            "--sim",
            "--sim-initial",
            "F&D",
            "--toward",
            toward,
        ]);
        assert_eq!(v["ok"], true, "{toward}: {v}");
        assert_eq!(v["moved"], true);
        assert_eq!(v["state"], "F&D");
        assert_eq!(v["state_confirmed"], true, "{toward}: {v}");
        let reported = v["error_deg"].as_f64().unwrap();
        assert!(reported >= want_err - 1e-6, "{toward}: {v}");
        let tol = v["sim_tolerance_deg"].as_f64().unwrap();
        let truth = v["sim"]["true_error_deg"].as_f64().unwrap();
        assert!(
            truth <= reported + tol,
            "{toward}: true {truth}° vs reported {reported}°"
        );
    }
    // From D&D (not bent) with --change-state: the state that aims closest is taken first.
    let v = json(&[
        "aim",
        "-j",
        "--sim",
        "--sim-initial",
        "D&D",
        "--toward",
        "90,70",
        "--change-state",
    ]);
    assert_eq!(v["ok"], true, "{v}");
    assert_ne!(v["state"], "D&D", "{v}");
    assert!(v["error_deg"].as_f64().unwrap() < 1e-3, "{v}");
    assert!(
        v["sim"]["true_error_deg"].as_f64().unwrap() <= v["sim_tolerance_deg"].as_f64().unwrap()
    );
}

#[test]
fn track_follows_the_sun_on_the_virtual_clock_and_straightens_at_sunset() {
    // Blacksburg, the June solstice, 19:00–21:00 EDT every 30 min: the sun sets ≈ 20:50.
    let out = host_tool(&[
        "track",
        "--sun",
        "--lat",
        "37.2296",
        "--lon",
        "-80.4139",
        "--time",
        "2025-06-21T19:00-04:00",
        "--until",
        "21:00",
        "--every",
        "30m",
        "--sim",
        "--sim-initial",
        "F&D",
        "-j",
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 6, "{lines:?}");
    let up: Vec<&Value> = lines.iter().filter(|l| l["sun_up"] == true).collect();
    assert_eq!(up.len(), 4, "{lines:?}");
    for l in &up {
        let tol = SIM_TOLERANCE;
        assert!(
            l["sim"]["true_error_deg"].as_f64().unwrap() <= l["error_deg"].as_f64().unwrap() + tol,
            "{l}"
        );
    }
    // The low evening sun is beyond the limit: each aim bends the whole limit, westward.
    assert!(
        up.iter().all(|l| l["bend_deg"] == l["max_bend_deg"]),
        "{up:?}"
    );
    let down = &lines[4];
    assert_eq!(down["sun_up"], false);
    assert_eq!(down["straightened"], true);
    let summary = &lines[5];
    assert_eq!(summary["summary"], true);
    assert_eq!(summary["ok"], true);
    assert_eq!(summary["aims"], 4);
    assert_eq!(summary["state"], "F&D");
    assert_eq!(summary["state_confirmed"], true);
    // Bad ranges are refused before anything moves.
    let base = [
        "track",
        "--lat",
        "37",
        "--lon",
        "-80",
        "--time",
        "2025-06-21T09:00-04:00",
        "--sim",
    ];
    let with = |extra: &[&'static str]| -> Vec<&'static str> { [&base[..], extra].concat() };
    usage_error(&with(&["--until", "08:00", "--every", "0m"]), "--every");
    usage_error(&with(&["--until", "2025-06-24T09:00-04:00"]), "48 h");
    usage_error(&with(&["--until", "2025-06-21T08:00-04:00"]), "not after");
    usage_error(&with(&["--until", "xx"]), "HH:MM");
    usage_error(
        &[
            "track", "--lat", "91", "--lon", "0", "--until", "10:00", "--sim",
        ],
        "--lat",
    );
    usage_error(
        &["track", "--lat", "37", "--lon", "-80", "--until", "10:00"],
        "--sim",
    );
}

/// The model tolerance `aim` reports with (`SIM_AXIS_TOLERANCE_DEG`).
const SIM_TOLERANCE: f64 = 2.5;

/// Ctrl-C while the tracker waits for its next aim ends it at once, exit 130, with the crane
/// holding its last bend and its state still confirmed, and the summary saying so.
#[test]
fn ctrl_c_between_aims_ends_the_track_safely() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .args([
            "track",
            "--sun",
            "--lat",
            "37.2296",
            "--lon",
            "-80.4139",
            "--time",
            "2025-06-21T12:00-04:00",
            "--until",
            "20:00",
            "--every",
            "1h",
            "--sim",
            "--sim-initial",
            "F&D",
            "--sim-speed",
            "1",
            "-j",
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("host-tool runs");
    let mut out = BufReader::new(child.stdout.take().expect("stdout"));
    let mut first = String::new();
    out.read_line(&mut first).expect("the first aim");
    let first: Value = serde_json::from_str(&first).expect("JSON");
    assert_eq!(first["sun_up"], true, "{first}");
    // An hour of virtual time at 1× is an hour of wall time: the signal lands in the wait.
    let pid = nix::unistd::Pid::from_raw(child.id() as i32);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT).expect("SIGINT");
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut out, &mut rest).expect("stdout");
    let status = child.wait().expect("host-tool ends");
    assert_eq!(status.code(), Some(130));
    let summary: Value = serde_json::from_str(rest.trim()).expect("one summary object");
    assert_eq!(summary["summary"], true);
    assert_eq!(summary["ok"], false);
    assert_eq!(summary["aims"], 1);
    assert!(
        summary["error"].as_str().unwrap().contains("interrupted"),
        "{summary}"
    );
    assert_eq!(summary["state"], "F&D");
    assert_eq!(summary["state_confirmed"], true);
}
