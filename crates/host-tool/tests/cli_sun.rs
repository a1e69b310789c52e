//! `host-tool sun`, `host-tool station` and `fk`'s top-face frames through the real binary:
//! values against the library, the figure in every format, and bad input refused (exit 2).

use std::process::{Command, Output};

use serde_json::Value;

fn host_tool(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .args(args)
        .output()
        .expect("run host-tool")
}

fn json(args: &[&str]) -> Value {
    let out = host_tool(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("valid JSON")
}

fn usage_error(args: &[&str], expect_in_message: &str) {
    let out = host_tool(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(stderr.contains(expect_in_message), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
}

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
    // 50° from vertical with a 30° limit: 20° left, bending towards azimuth 135° (base 315°).
    assert!((v["error_deg"].as_f64().unwrap() - 20.0).abs() < 1e-9);
    assert!((v["bend_deg"].as_f64().unwrap() - 30.0).abs() < 1e-12);
    assert!((v["bend_direction_deg"].as_f64().unwrap() - 315.0).abs() < 1e-9);
    assert!(v["better_state"].is_null());
    let dd = json(&["aim", "-j", "--toward", "135,80", "--state", "D&D"]);
    assert_eq!(dd["max_bend_deg"], 0.0);
    assert!((dd["error_deg"].as_f64().unwrap() - 10.0).abs() < 1e-9);
    assert!(dd["better_error_deg"].as_f64().unwrap() < 1e-9);
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
}
