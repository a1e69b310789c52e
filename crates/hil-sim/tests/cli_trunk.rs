//! The trunk options through the `hil-sim` binary: a description from a file, the snap-force
//! scale and the swarm's spread; everything the physics cannot represent refused with the
//! reason (exit 2), never a panic.

use std::process::{Command, Output};

fn hil_sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hil-sim"))
        .args(args)
        .output()
        .expect("hil-sim runs")
}

fn refused(args: &[&str], reason: &str) {
    let out = hil_sim(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(err.contains(reason), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
}

fn temp_file(name: &str, text: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("hil-sim-cli-trunk-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_force_scale_the_physics_cannot_represent_is_refused_with_the_reason() {
    // × 1.35: the top's pop-out peak passes its buckling valley (it panicked before).
    refused(
        &["swarm", "--runs", "1", "--sim-trunk-scale", "1.35"],
        "the top module cannot be represented: barrier 0",
    );
    refused(&["--pty", "--sim-trunk-scale", "1.35"], "barrier 0");
    for k in ["0", "-1", "11", "nan", "x"] {
        refused(&["swarm", "--runs", "1", "--sim-trunk-scale", k], "scale");
    }
}

#[test]
fn a_spread_outside_0_to_1_is_refused() {
    for f in ["1", "-0.1", "2", "nan", "x"] {
        refused(&["swarm", "--runs", "1", "--trunk-spread", f], "spread");
    }
}

#[test]
fn a_trunk_file_is_read_checked_and_refused_with_the_reason() {
    let pdf = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../trunks/pdf.toml"
    ))
    .unwrap();
    // The calibrated file itself runs.
    let path = temp_file("pdf.toml", &pdf);
    let out = hil_sim(&[
        "swarm",
        "--runs",
        "2",
        "--sim-trunk",
        path.to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("2 runs"));
    // Not there, not TOML, an unknown key, a zero area, a snap order the crane is not built on,
    // a top with one well.
    refused(
        &[
            "swarm",
            "--runs",
            "1",
            "--sim-trunk",
            "/nonexistent/trunk.toml",
        ],
        "cannot read the trunk file",
    );
    let cases = [
        ("junk.toml", "this is = = not toml".to_string(), "not valid"),
        (
            "unknown.toml",
            pdf.replacen("[sensor]", "[sensor]\ncolour = 1.0", 1),
            "not valid",
        ),
        (
            "area.toml",
            pdf.replace("area_mm2 = 3247.595264191646", "area_mm2 = 0.0"),
            "pneumatics.area_mm2 must be finite and positive",
        ),
        (
            "order.toml",
            pdf.replace("tension_n = 62.0", "tension_n = 40.0"),
            "the snap order is not the crane's",
        ),
        (
            "wells.toml",
            pdf.replacen(
                "[[top.wells]]\nheight_mm = 33.10482703659852\nstiffness_n_per_mm = 1.4\n",
                "",
                1,
            ),
            "the top module needs 2 wells",
        ),
    ];
    for (name, text, reason) in cases {
        let path = temp_file(name, &text);
        refused(
            &[
                "swarm",
                "--runs",
                "1",
                "--sim-trunk",
                path.to_str().unwrap(),
            ],
            reason,
        );
        refused(&["--pty", "--sim-trunk", path.to_str().unwrap()], reason);
    }
}

#[test]
fn a_drawn_trunk_is_part_of_the_scenario_and_replayed() {
    let out = hil_sim(&["swarm", "--replay", "1234", "--trunk-spread", "0.25"]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let first = text.lines().next().unwrap().to_string();
    assert!(first.contains("trunk drawn ±0.25"), "{first}");
    assert!(first.contains("top barriers ×["), "{first}");
    // Same seed, same spread: the same trunk and the same run.
    let again = hil_sim(&["swarm", "--replay", "1234", "--trunk-spread", "0.25"]);
    assert_eq!(String::from_utf8_lossy(&again.stdout), text);
    // Another spread draws another trunk for the same scenario.
    let other = hil_sim(&["swarm", "--replay", "1234", "--trunk-spread", "0.1"]);
    let other_first = String::from_utf8_lossy(&other.stdout)
        .lines()
        .next()
        .unwrap()
        .to_string();
    assert_ne!(other_first, first);
    assert_eq!(
        first.split(", trunk drawn").next(),
        other_first.split(", trunk drawn").next()
    );
}

#[test]
fn trunk_is_sim_trunks_alias() {
    let pdf = concat!(env!("CARGO_MANIFEST_DIR"), "/../../trunks/n4.toml");
    let long = hil_sim(&["swarm", "--replay", "77", "--sim-trunk", pdf]);
    let short = hil_sim(&["swarm", "--replay", "77", "--trunk", pdf]);
    assert_eq!(
        long.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&long.stderr)
    );
    assert!(String::from_utf8_lossy(&long.stdout).contains("trunk n4"));
    assert_eq!(long.stdout, short.stdout);
    refused(
        &["--trunk", "/nonexistent/trunk.toml", "--pty"],
        "cannot read the trunk file /nonexistent/trunk.toml",
    );
}
