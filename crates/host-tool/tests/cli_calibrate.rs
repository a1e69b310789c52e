//! `host-tool calibrate`, `calibration show` and `plan --calibration` through the binary: the
//! snap pressures a calibration recovers against the simulator's truth (computed from the
//! trunk's description, not from the calibration), the 36 plans with the profile, and every
//! refusal.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use hil_sim::physics::TrunkSpec;

const STATES: [&str; 6] = ["F&P", "F&F", "F&D", "D&P", "D&F", "D&D"];

fn host_tool(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .args(args)
        .stdin(std::process::Stdio::null())
        .output()
        .expect("host-tool runs")
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli_calibrate");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// The simulator's truth: the gauge pressure (as its sensor reads it) at which each barrier's
/// tension is reached by the gas force on the piston, less the tip's dead load (the modules
/// are in series: the same force on each).
fn truth_kpa(spec: &TrunkSpec) -> [(&'static str, &'static str, f64); 3] {
    let p = |tension_n: f64| {
        let true_kpa = (tension_n + spec.mechanics.tip_load_n) / spec.pneumatics.area_mm2 * 1e3;
        spec.sensor.gain * true_kpa + spec.sensor.offset_kpa
    };
    [
        ("F&P", "F&F", p(spec.bottom.barriers[0].tension_n)),
        ("F&F", "D&F", p(spec.top.barriers[0].tension_n)),
        ("D&F", "D&D", p(spec.bottom.barriers[2].tension_n)),
    ]
}

fn calibrate(scale: &str, out: &Path) -> serde_json::Value {
    let o = host_tool(&[
        "calibrate",
        "--sim",
        "--sim-trunk-scale",
        scale,
        "--out",
        out.to_str().unwrap(),
        "-j",
    ]);
    assert_eq!(o.status.code(), Some(0), "K = {scale}: {}", text(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn plans_reached(scale: &str, profile: Option<&Path>) -> (usize, Vec<String>) {
    let mut ok = 0;
    let mut failed = Vec::new();
    for from in STATES {
        for to in STATES {
            let mut args = vec![
                "plan",
                "--sim",
                "--sim-trunk-scale",
                scale,
                "--sim-initial",
                from,
                "--target",
                to,
                "-j",
            ];
            if let Some(p) = profile {
                args.extend(["--calibration", p.to_str().unwrap()]);
            }
            let o = host_tool(&args);
            let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap_or_default();
            if o.status.code() == Some(0) && v["ok"] == true && v["sim"]["true_state"] == to {
                ok += 1;
            } else {
                failed.push(format!("{from} → {to}: {}", text(&o)));
            }
        }
    }
    (ok, failed)
}

#[test]
fn calibration_recovers_each_snap_within_5_percent_and_the_36_plans_reach_their_targets() {
    for k in [0.75, 0.9, 1.1, 1.2] {
        let scale = k.to_string();
        let path = tmp(&format!("k{scale}.toml"));
        let v = calibrate(&scale, &path);
        let spec = TrunkSpec::pdf().scaled(k).unwrap();
        assert_eq!(v["name"], spec.name.as_str());
        assert_eq!(v["format"], 1);
        assert_eq!(
            v["schema_id"],
            format!("{:#010x}", protocol::SCHEMA_ID).as_str()
        );
        assert!((v["margin"].as_f64().unwrap() - 0.15).abs() < 1e-12);
        // The sensor reads true at rest: its zero within its noise.
        assert!(v["sensor_zero_kpa"].as_f64().unwrap().abs() < 0.3, "{v}");
        for (from, to, truth) in truth_kpa(&spec) {
            let m = v["transition"]
                .as_array()
                .unwrap()
                .iter()
                .find(|m| m["from"] == from && m["to"] == to && m["snap_kpa"].is_array())
                .unwrap_or_else(|| panic!("K = {k}: no {from} → {to} in {v}"));
            let got = m["snap_kpa"][0].as_f64().unwrap();
            let err = (got - truth) / truth;
            assert!(
                err.abs() < 0.05,
                "K = {k}, {from} → {to}: measured {got:.2} kPa, truth {truth:.2} kPa ({:+.1} %)",
                err * 100.0
            );
            // The hold is under the snap (the trunk settled after its drop).
            let hold = m["hold_kpa"].as_f64().unwrap();
            assert!(hold < got && hold > got - 3.0, "{m}");
            assert_eq!(m["held"], true, "{m}");
        }
        // The profile reads back; `show` names the calibrated targets.
        let shown = host_tool(&["calibration", "show", path.to_str().unwrap()]);
        assert_eq!(shown.status.code(), Some(0), "{}", text(&shown));
        assert!(text(&shown).contains("plans use (margin 15 %)"));
        let (with, failed) = plans_reached(&scale, Some(&path));
        let (without, _) = plans_reached(&scale, None);
        eprintln!("K = {k}: {with}/36 plans reached with the profile, {without}/36 without");
        assert_eq!(with, 36, "K = {k}: {failed:#?}");
    }
}

#[test]
fn the_manual_walk_measures_the_unpacking_under_a_deployed_top() {
    let path = tmp("manual.toml");
    let o = host_tool(&[
        "calibrate",
        "--sim",
        "--manual",
        "--out",
        path.to_str().unwrap(),
        "-j",
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(
        t.contains("calibrate 3/10: D&F → D&P by hand (the person folds it when prompted)"),
        "{t}"
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    // The same barrier as F&P → F&F: the bottom's first layer.
    let truth = truth_kpa(&TrunkSpec::pdf())[0].2;
    let m = v["transition"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["from"] == "D&P" && m["to"] == "D&F")
        .unwrap()
        .clone();
    let got = m["snap_kpa"][0].as_f64().unwrap();
    assert!((got - truth).abs() / truth < 0.05, "{got} vs {truth}");
    // Its own snap sets D&P → D&F's target.
    let target = v["targets"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["from"] == "D&P" && t["to"] == "D&F")
        .unwrap()["value"]
        .as_f64()
        .unwrap();
    assert!(
        (target - (got * 1.15 * 10.0).round() / 10.0).abs() < 1e-4,
        "{target}"
    );
}

/// The simulator's calibrated trunk's probe signatures (`firmware::controller::identify::
/// SIM_PROFILE`: the device's own readings on seeds 1–3): F&P, F&F, F&D, D&P, D&F, D&D; F&P½,
/// D&P½.
const SIM_STATES: [f64; 6] = [11.71, 10.81, 10.24, 14.08, 12.94, 12.82];
const SIM_BETWEEN: [f64; 2] = [11.05, 13.20];

fn rates(v: &serde_json::Value, key: &str) -> Vec<f64> {
    v["probe"][key]
        .as_array()
        .unwrap_or_else(|| panic!("no probe.{key} in {v}"))
        .iter()
        .map(|r| r.as_f64().unwrap())
        .collect()
}

fn manual_calibration(trunk: Option<&Path>, out: &Path) -> serde_json::Value {
    let mut args = vec![
        "calibrate",
        "--sim",
        "--manual",
        "--out",
        out.to_str().unwrap(),
        "-j",
    ];
    if let Some(t) = trunk {
        args.extend(["--sim-trunk", t.to_str().unwrap()]);
    }
    let o = host_tool(&args);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// Identification on the simulated `spec` in every state, the controller booted knowing
/// nothing and carrying `profile`: (the truth kept every time, the states decided alone).
fn identify_everywhere(
    spec: &TrunkSpec,
    profile: protocol::ProbeProfile,
) -> (bool, Vec<&'static str>) {
    use hil_sim::host::SimHost;
    use hil_sim::{Sim, SimOptions};
    let mut kept = true;
    let mut decided = Vec::new();
    for s in STATES {
        let mut sim = Sim::new(SimOptions {
            initial: s.parse().unwrap(),
            seed: 7,
            trunk: spec.clone(),
            ..SimOptions::default()
        })
        .with_probe_profile(Some(profile));
        sim.boot_knowing_nothing();
        sim.run_for(50);
        let mut host = SimHost::new();
        host.hello(&mut sim).expect("handshake");
        host.request_ok(&mut sim, protocol::RequestBody::Identify, 1_000)
            .expect("identify starts");
        for _ in 0..40 {
            sim.run_for(250);
            let _ = host.send(&mut sim, protocol::RequestBody::Heartbeat);
            if sim.controller().mode() != protocol::Mode::Running {
                break;
            }
        }
        let st = sim.controller().status();
        kept &= st.candidates.contains(s.parse().unwrap())
            && (!st.state_confirmed || st.state.name() == s);
        if st.state_confirmed {
            decided.push(s);
        }
    }
    (kept, decided)
}

/// `calibrate --manual` probes every state and both half-packed rests: on the calibrated trunk
/// it reads the signatures the device itself measured there within 4 % (the seeds' spread,
/// ±2 %, and the baseline: the constants were measured from ambient, the walk's probes start
/// from the air the vent leaves, up to the device's 0.5 kPa vent tolerance, which reads the
/// half-packed rest 3.3 % slower), and on a trunk whose volumes differ (a reservoir 1.4 × as large:
/// every fill slower) it reads that trunk's, with which identification keeps the truth and
/// decides alone where the simulator's constants would have misled it.
#[test]
fn the_manual_walk_measures_the_probes_signatures_and_identification_decides_from_them() {
    let v = manual_calibration(None, &tmp("probe-pdf.toml"));
    assert_eq!(v["stored_on_device"], true, "{v}");
    for (got, want) in rates(&v, "states")
        .iter()
        .zip(SIM_STATES)
        .chain(rates(&v, "between").iter().zip(SIM_BETWEEN))
    {
        assert!(
            (got - want).abs() < 0.04 * want,
            "{got} vs {want}: {}",
            v["probe"]
        );
    }

    let mut spec = TrunkSpec::pdf();
    spec.name = "large-reservoir".into();
    spec.pneumatics.plenum_m3 *= 1.4;
    let trunk = tmp("large-reservoir.toml");
    std::fs::write(&trunk, spec.to_toml()).unwrap();
    let v = manual_calibration(Some(&trunk), &tmp("probe-large.toml"));
    let (states, between) = (rates(&v, "states"), rates(&v, "between"));
    // Every fill is slower than the simulator's constants say: by more than their window.
    for (got, sim) in states.iter().zip(SIM_STATES) {
        assert!(
            *got < sim * 0.95,
            "{got} vs the constants' {sim}: {}",
            v["probe"]
        );
    }
    let measured = protocol::ProbeProfile {
        states: <[f64; 6]>::try_from(states.as_slice())
            .unwrap()
            .map(|r| r as f32),
        between: <[f64; 2]>::try_from(between.as_slice())
            .unwrap()
            .map(|r| r as f32),
    };
    let (kept, decided) = identify_everywhere(&spec, measured);
    assert!(
        kept,
        "the measured profile lost the truth or confirmed a wrong state"
    );
    // F&P and D&P stand apart from every other state on this trunk too.
    assert!(
        decided.contains(&"F&P") && decided.contains(&"D&P"),
        "{decided:?}"
    );
    let constants = protocol::ProbeProfile {
        states: SIM_STATES.map(|r| r as f32),
        between: SIM_BETWEEN.map(|r| r as f32),
    };
    let (kept_c, by_constants) = identify_everywhere(&spec, constants);
    eprintln!(
        "decided with the measured profile: {decided:?}; with the constants: {by_constants:?} \
         (truth kept: {kept_c})"
    );
    // The constants either lose the truth or decide less.
    assert!(
        !kept_c || by_constants.len() < decided.len(),
        "{by_constants:?} vs {decided:?}"
    );
}

#[test]
fn the_dry_run_lists_the_calibrated_numbers() {
    let path = tmp("k1.toml");
    let v = calibrate("1", &path);
    let snap = |from: &str, to: &str| {
        v["transition"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["from"] == from && m["to"] == to && m["snap_kpa"].is_array())
            .unwrap()["snap_kpa"][0]
            .as_f64()
            .unwrap()
    };
    let o = host_tool(&[
        "plan",
        "--dry-run",
        "--from",
        "F&P",
        "--target",
        "D&D",
        "--calibration",
        path.to_str().unwrap(),
        "-j",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let plan: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for (i, (from, to)) in [("F&P", "F&F"), ("F&F", "D&F"), ("D&F", "D&D")]
        .into_iter()
        .enumerate()
    {
        let want = (snap(from, to) * 1.15 * 10.0).round() / 10.0;
        let first = plan["steps"][i]["primitives"][0].as_str().unwrap();
        assert!(
            first.contains(&format!("inflate toward {want:.1} kPa")),
            "{first} (want {want:.1})"
        );
    }
    // Without the profile: the catalogue's numbers.
    let o = host_tool(&["plan", "--dry-run", "--from", "F&P", "--target", "F&F"]);
    assert!(text(&o).contains("inflate toward 16.0 kPa"), "{}", text(&o));
    // A tendon step: the measured stroke + 15 % (at least + 3 mm), not the catalogue's 120 mm
    // (the listing prints whole mm; the plan carries 0.1 mm).
    let stroke = v["transition"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["from"] == "D&D" && m["to"] == "F&D")
        .unwrap()["stroke_mm"][0]
        .as_f64()
        .unwrap();
    let want = ((stroke * 1.15).max(stroke + 3.0) * 10.0).round() / 10.0;
    let o = host_tool(&[
        "plan",
        "--dry-run",
        "--from",
        "D&D",
        "--target",
        "F&D",
        "--calibration",
        path.to_str().unwrap(),
    ]);
    assert!(
        text(&o).contains(&format!("pull the tendons in by up to {want:.0} mm")),
        "{} (want {want:.0}: the listing's whole mm)",
        text(&o)
    );
}

#[test]
fn a_calibration_that_misses_a_snap_is_refused_and_writes_nothing() {
    // The bottom deploys at 135 N (41.7 kPa): above the device's 40 kPa limit.
    let pdf = include_str!("../../../trunks/pdf.toml");
    assert!(pdf.contains("tension_n = 97.0"));
    let trunk = tmp("stiff-bottom.toml");
    std::fs::write(&trunk, pdf.replace("tension_n = 97.0", "tension_n = 135.0")).unwrap();
    let out = tmp("never.toml");
    let o = host_tool(&[
        "calibrate",
        "--sim",
        "--sim-trunk",
        trunk.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(
        t.contains("calibration refused: D&F → D&D: no snap seen on the ramp"),
        "{t}"
    );
    assert!(t.contains("the limit is 40 kPa"), "{t}");
    assert!(!out.exists());
}

#[test]
fn the_sensors_zero_is_measured_and_one_the_device_cannot_vent_to_is_refused() {
    let pdf = include_str!("../../../trunks/pdf.toml");
    assert!(pdf.contains("offset_kpa = 0.0"));
    for (offset, ok) in [(-0.4, true), (0.4, true), (1.0, false)] {
        let trunk = tmp(&format!("offset{offset}.toml"));
        std::fs::write(
            &trunk,
            pdf.replace("offset_kpa = 0.0", &format!("offset_kpa = {offset:.1}")),
        )
        .unwrap();
        let out = tmp(&format!("offset{offset}-profile.toml"));
        let o = host_tool(&[
            "calibrate",
            "--sim",
            "--sim-trunk",
            trunk.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-j",
        ]);
        let t = text(&o);
        if ok {
            assert_eq!(o.status.code(), Some(0), "{offset}: {t}");
            let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            let zero = v["sensor_zero_kpa"].as_f64().unwrap();
            assert!((zero - offset).abs() < 0.15, "{offset}: zero {zero}");
            // The snaps as the sensor reads them: the truth plus the offset.
            let spec = TrunkSpec::from_toml(&std::fs::read_to_string(&trunk).unwrap()).unwrap();
            for (from, to, truth) in truth_kpa(&spec) {
                let got = v["transition"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .find(|m| m["from"] == from && m["to"] == to && m["snap_kpa"].is_array())
                    .unwrap()["snap_kpa"][0]
                    .as_f64()
                    .unwrap();
                assert!(
                    (got - truth).abs() / truth < 0.05,
                    "{from} → {to}: {got} vs {truth}"
                );
            }
        } else {
            assert_eq!(o.status.code(), Some(1), "{offset}: {t}");
            assert!(
                t.contains("the pressure sensor reads +1.0")
                    && t.contains("0.5 kPa vent tolerance"),
                "{t}"
            );
            assert!(!out.exists());
        }
    }
}

#[test]
fn doctored_profiles_are_refused_naming_what_differs() {
    let path = tmp("k1-doctored.toml");
    calibrate("1", &path);
    let good = std::fs::read_to_string(&path).unwrap();
    let snap_line = |from: &str, to: &str| {
        let at = good
            .find(&format!(
                "from = \"{from}\"\nto = \"{to}\"\nkind = \"pneumatic\"\nsnap_kpa"
            ))
            .unwrap();
        let line = good[at..].lines().nth(3).unwrap().to_string();
        assert!(line.starts_with("snap_kpa = ["), "{line}");
        line
    };
    let unpack = snap_line("F&P", "F&F");
    let pop = snap_line("F&F", "D&F");
    let schema = format!("{:#010x}", protocol::SCHEMA_ID);
    for (what, doctored, reason) in [
        (
            "out of order",
            good.replacen(&pop, "snap_kpa = [12.5]", 1),
            "snaps out of order: the bottom's unpacking at 13.",
        ),
        (
            "out of range",
            good.replacen(&unpack, "snap_kpa = [0.3]", 1),
            "F&P → F&F: a snap at 0.30 kPa, outside the physical range 1 to 40 kPa",
        ),
        (
            "above the limit",
            good.replacen(&unpack, "snap_kpa = [45.0]", 1),
            "a snap at 45.00 kPa, outside the physical range",
        ),
        (
            "missing",
            good.replacen(&format!("{unpack}\n"), "", 1),
            "F&P → F&F: no snap pressure measured",
        ),
        (
            "two snaps",
            good.replacen(&unpack, "snap_kpa = [13.0, 14.0]", 1),
            "2 snaps seen (13.00 kPa, 14.00 kPa)",
        ),
        (
            "another schema",
            good.replacen(&schema, "0x00000001", 1),
            &format!(
                "a profile measured with firmware schema 0x00000001; this host-tool speaks \
                 schema {schema}"
            ),
        ),
        (
            "another format",
            good.replacen("format = 1", "format = 7", 1),
            "a calibration profile of format version 7; this host-tool reads version 1",
        ),
        (
            "not TOML",
            "[[[".to_string(),
            "not a calibration profile (TOML)",
        ),
    ] {
        let p = tmp(&format!("doctored-{}.toml", what.replace(' ', "-")));
        std::fs::write(&p, &doctored).unwrap();
        for args in [
            vec!["calibration", "show", p.to_str().unwrap()],
            vec![
                "plan",
                "--target",
                "D&D",
                "--sim",
                "--calibration",
                p.to_str().unwrap(),
            ],
        ] {
            let o = host_tool(&args);
            let t = text(&o);
            assert_eq!(o.status.code(), Some(2), "{what}, {args:?}: {t}");
            assert!(t.contains(reason), "{what}, {args:?}: {t}");
            assert!(!t.contains("panicked"), "{t}");
        }
    }
    // A profile of another trunk on the simulator.
    let o = host_tool(&[
        "plan",
        "--target",
        "D&D",
        "--sim",
        "--sim-trunk-scale",
        "1.2",
        "--calibration",
        path.to_str().unwrap(),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains(
            "a profile of trunk 'pdf', but the simulator runs trunk 'pdf (snap forces ×1.2)'"
        ),
        "{t}"
    );
    // A pressure limit under a measured snap: the cap would be under it.
    let o = host_tool(&["calibration", "show", "/nonexistent/profile.toml"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("cannot read the profile"));
    let low = tmp("low-limit.toml");
    std::fs::write(
        &low,
        good.replacen("pressure_limit_kpa = 40.0", "pressure_limit_kpa = 25.0", 1),
    )
    .unwrap();
    let o = host_tool(&["calibration", "show", low.to_str().unwrap()]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("outside the physical range 1 to 25 kPa"), "{t}");
}

#[test]
fn usage_errors_exit_2() {
    let out = tmp("usage.toml");
    let o = out.to_str().unwrap();
    for (args, reason) in [
        (vec!["calibrate", "--out", o], "--sim"),
        (
            vec!["calibrate", "--sim", "--out", o, "--name", " "],
            "--name must not be empty",
        ),
        (
            vec!["calibrate", "--sim", "--out", "/nonexistent/dir/p.toml"],
            "cannot write /nonexistent/dir/p.toml",
        ),
        (vec!["calibrate", "--sim"], "--out"),
        (vec!["calibration", "show"], "PROFILE.toml"),
    ] {
        let r = host_tool(&args);
        let t = text(&r);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {t}");
        assert!(t.contains(reason), "{args:?}: {t}");
    }
}

/// A walk from F&D with `fault` injected, refused (exit 1, no profile left): its words.
fn refused_from_fd(fault: &str) -> String {
    let out = tmp(&format!("{fault}.toml"));
    let r = host_tool(&[
        "calibrate",
        "--sim",
        "--sim-initial",
        "F&D",
        "--sim-fault",
        fault,
        "--out",
        out.to_str().unwrap(),
    ]);
    let t = text(&r);
    assert_eq!(r.status.code(), Some(1), "{t}");
    assert!(!out.exists(), "no profile left: {t}");
    assert!(
        t.contains("calibrate 1/8: F&D → F&F by the tendons, pulls from 64 mm"),
        "the cycle begins where the trunk is: {t}"
    );
    t
}

#[test]
fn the_walk_starts_where_the_trunk_is_and_a_fold_that_never_holds_is_refused() {
    // A broken tendon pulls nothing: every pull comes back to its pressure, the host declares
    // F&D each time (the person is never asked), and at the reach the walk is refused.
    let t = refused_from_fd("tendon-break");
    let back = "mm: the sealed trunk came back as it was, not folded";
    assert_eq!(t.matches(back).count(), 24, "64 … 179 mm: {t}");
    assert!(!t.contains("simulated operator"), "{t}");
    assert!(
        t.contains(
            "calibration refused: F&D → F&F: the bottom did not stay folded after any pull up \
             to 184.0 mm (measured so far: nothing yet)"
        ),
        "{t}"
    );
}

#[test]
fn a_leaking_trunk_is_never_declared_from_its_sealed_release() {
    // A torn seam lets the air a fold squeezes out before the release could show it: the
    // pressure falls while the pull holds its length, so the host does not declare F&D from
    // the release; the person is asked after every pull, names the fold at 104 mm, and the
    // walk is refused at the first inflation, which the device stops for the leak.
    let t = refused_from_fd("leak");
    assert!(!t.contains("came back as it was"), "{t}");
    let asked = "mm: not folded (identified: the sealed release could not tell)";
    assert_eq!(t.matches(asked).count(), 8, "64 … 99 mm: {t}");
    assert!(
        t.contains("calibrate 1/8: folds at 104.0 mm of pull"),
        "{t}"
    );
    assert!(t.contains("(E-08)"), "{t}");
}

#[test]
fn a_named_profile_shows_as_text_and_json() {
    let path = tmp("named.toml");
    let o = host_tool(&[
        "calibrate",
        "--sim",
        "--name",
        "bench trunk 3",
        "--out",
        path.to_str().unwrap(),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    // Progress lines on stderr: each step, each measurement.
    for line in [
        "calibrate: sensor zero",
        "calibrate 1/8: F&P → F&F by pressure, a ramp toward 40 kPa",
        "calibrate 1/8: snap at 13.",
        "calibrate 6/8: D&D → F&D by the tendons, a pull toward 185 mm",
        "calibrate 7/8: F&D → F&F by the tendons, pulls from 64 mm, 5 mm longer each",
        "calibrate 7/8: 99.0 mm: the sealed trunk came back as it was, not folded",
        "calibrate 7/8: folds at 104.0 mm of pull",
        "calibrated trunk 'bench trunk 3'",
    ] {
        assert!(t.contains(line), "{line}: {t}");
    }
    // The pulls that came back were the host's to declare: the person is asked once, at the
    // fold (and at the pack, which the device cannot confirm either).
    assert_eq!(
        t.matches("simulated operator: the trunk is F&D").count(),
        0,
        "{t}"
    );
    assert!(t.contains("simulated operator: the trunk is F&F"), "{t}");
    let o = host_tool(&["calibration", "show", path.to_str().unwrap(), "-j"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["name"], "bench trunk 3");
    let targets = v["targets"].as_array().unwrap();
    assert_eq!(targets.len(), 8, "{v}");
    // The searched fold: the shortest holding pull (104 mm; 105 mm at 1 mm steps, the
    // simulator's rig) and 8 mm.
    let fold = targets
        .iter()
        .find(|t| t["from"] == "F&D" && t["to"] == "F&F")
        .unwrap_or_else(|| panic!("no F&D → F&F target: {v}"));
    assert_eq!(fold["value"], 112.0, "{v}");
    // A named profile on the simulator: another trunk's name than the simulated one's.
    let o = host_tool(&[
        "plan",
        "--target",
        "F&F",
        "--sim",
        "--calibration",
        path.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("a profile of trunk 'bench trunk 3'"));
}
