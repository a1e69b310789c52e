//! Designing with the tool, through the real binary: `ik`'s warnings and coverage on designs
//! that cannot bend and on bad targets, the README's and `--help`'s examples (they bend and
//! cover), `design`'s bands against the geometry's β_in/β_out, `states --crane`/`--edge-mm`,
//! `model --states 'F&P'`.

#[path = "support/cli.rs"]
mod cli;

use std::path::PathBuf;

use cli::{host_tool, usage_error};
use serde_json::Value;

/// `ARGS --json`'s document.
fn json(args: &[&str]) -> Value {
    cli::json(&[args, &["--json"]].concat())
}

fn stdout(args: &[&str]) -> String {
    let out = host_tool(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("UTF-8")
}

fn temp_file(name: &str, text: &str) -> PathBuf {
    cli::temp_file("cli_design", name, text)
}

fn kinds(v: &Value) -> Vec<String> {
    v["warnings"]
        .as_array()
        .expect("warnings array")
        .iter()
        .map(|w| w["kind"].as_str().expect("kind").to_string())
        .collect()
}

fn warning<'a>(v: &'a Value, kind: &str) -> &'a Value {
    v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|w| w["kind"] == kind)
        .unwrap_or_else(|| panic!("no {kind} warning in {}", v["warnings"]))
}

/// Whether any tip leaves the z axis (the boom bends) and some state is a pop-out.
fn bends(v: &Value) -> bool {
    let off_axis = v["tips"]
        .as_array()
        .unwrap()
        .iter()
        .any(|t| t[0].as_f64().unwrap().hypot(t[1].as_f64().unwrap()) > 1e-6);
    let popout = v["states"].as_array().unwrap().iter().any(|s| {
        let s = s.as_str().unwrap();
        s.starts_with("edge-") || s.starts_with("vertex-")
    });
    off_axis && popout
}

#[test]
fn the_issue_s_designs_that_cannot_bend_are_warned_in_json_and_text() {
    // n = 6, β = 35° (the old --help example) and n = 4, β = 35° (the paper's boom): only
    // deployed and folded are feasible, so the proven optimum is a straight column.
    for (n, m, target) in [
        ("6", "8", "helix:radius=1,pitch=4"),
        ("6", "30", "sine"),
        ("4", "10", "helix:radius=1,pitch=2,turns=1"),
    ] {
        let args = [
            "ik",
            "--n",
            n,
            "--beta",
            "35",
            "--modules",
            m,
            "--target",
            target,
        ];
        let v = json(&args);
        assert_eq!(v["optimal"], true, "{args:?}");
        assert!(!bends(&v), "{args:?}: {}", v["states"]);
        let w = warning(&v, "cannot-bend");
        let msg = w["message"].as_str().unwrap();
        assert!(msg.contains(&format!("n = {n}, β = 35°")), "{msg}");
        assert!(msg.contains("only deployed, folded"), "{msg}");
        // The β band where pop-outs are feasible (n = 4: the edge band near β_in = 23.36°;
        // n = 6: none) and what --all-states would give, below this fit's RMS.
        if n == "4" {
            assert!(msg.contains("22.66–24.05° (edge)"), "{msg}");
        } else {
            assert!(
                msg.contains("no pop-out of n = 6 is feasible at any β"),
                "{msg}"
            );
        }
        let alt: f64 = msg
            .split("beam search finds RMS ")
            .nth(1)
            .and_then(|t| t.split(' ').next())
            .and_then(|t| t.parse().ok())
            .unwrap_or_else(|| panic!("no --all-states RMS in {msg}"));
        assert!(alt < v["rms"].as_f64().unwrap(), "{alt} vs {}", v["rms"]);
        // A column beside a helix or far past a short sine covers little of it.
        let cov = v["coverage"].as_f64().unwrap();
        assert!((0.0..0.9).contains(&cov), "{args:?}: coverage {cov}");
        assert_eq!(warning(&v, "coverage")["value"].as_f64(), Some(cov));
        // The same in the table.
        let text = stdout(&args);
        assert!(
            text.contains("warning    no feasible state of n = "),
            "{text}"
        );
        assert!(text.contains("coverage   "), "{text}");
    }
    // The figure says it too, under its header.
    let svg = temp_file("column.svg", "");
    let out = host_tool(&[
        "ik",
        "--n",
        "6",
        "--beta",
        "35",
        "--modules",
        "8",
        "--target",
        "helix:radius=1,pitch=4",
        "--svg",
        svg.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("warning: no feasible state bends"), "{text}");
    assert!(
        text.contains("warning: the fit covers 21 % of the target"),
        "{text}"
    );
    // The 30-module column is 19.4 l tall against a 7.3 l sine: the boom is too long.
    let v = json(&[
        "ik",
        "--n",
        "6",
        "--beta",
        "35",
        "--modules",
        "30",
        "--target",
        "sine",
    ]);
    let w = warning(&v, "boom-too-long");
    assert!(w["value"].as_f64().unwrap() > 19.0 && w["limit"].as_f64().unwrap() < 7.5);
}

#[test]
fn a_design_that_bends_has_no_cannot_bend_warning_and_all_states_gives_none() {
    let v = json(&[
        "ik",
        "--n",
        "4",
        "--beta",
        "35",
        "--modules",
        "6",
        "--target",
        "helix",
        "--all-states",
    ]);
    assert!(
        !kinds(&v).contains(&"cannot-bend".to_string()),
        "{}",
        v["warnings"]
    );
}

/// The `ik` command lines of the README (continuation lines joined) and of `--help`.
fn example_commands() -> Vec<Vec<String>> {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../README.md"))
        .expect("README");
    let joined = readme.replace("\\\n", " ");
    let mut out: Vec<Vec<String>> = joined
        .lines()
        .filter_map(|l| l.split("-p host-tool -- ").nth(1))
        .filter(|c| c.starts_with("ik "))
        .map(|c| {
            c.split('#')
                .next()
                .unwrap()
                .split_whitespace()
                .map(String::from)
                .collect()
        })
        .collect();
    let help = stdout(&["--help"]);
    out.extend(
        help.lines()
            .filter_map(|l| l.trim().strip_prefix("host-tool ik "))
            .map(|c| {
                std::iter::once("ik".to_string())
                    .chain(
                        c.split('#')
                            .next()
                            .unwrap()
                            .split_whitespace()
                            .map(String::from),
                    )
                    .collect()
            }),
    );
    out
}

#[test]
fn the_readme_and_help_examples_bend_and_cover_the_target() {
    let commands = example_commands();
    assert!(commands.len() >= 2, "{commands:?}");
    for cmd in commands {
        // Drop the figure outputs: this test is about the fit.
        let mut args: Vec<&str> = Vec::new();
        let mut skip = false;
        for a in &cmd {
            if skip {
                skip = false;
                continue;
            }
            if ["--svg", "--png", "--pdf", "--gltf"].contains(&a.as_str()) {
                skip = true;
                continue;
            }
            args.push(a);
        }
        let v = json(&args);
        assert!(bends(&v), "{args:?}: {}", v["states"]);
        let cov = v["coverage"].as_f64().unwrap();
        assert!(cov >= 0.9, "{args:?}: covers {cov}");
        assert_eq!(v["warnings"], serde_json::json!([]), "{args:?}");
        assert_eq!(v["infeasible"], serde_json::json!([]), "{args:?}");
        assert!(
            args.contains(&"ordered"),
            "{args:?}: covering examples use --metric ordered"
        );
    }
}

#[test]
fn bad_targets_get_a_warning_or_a_refusal_naming_the_number() {
    let boom = ["ik", "--n", "3", "--beta", "31.72", "--modules", "6"];
    // A curve that doubles back on itself: up 3 l and straight back down.
    let hairpin = temp_file("hairpin.csv", "x,y,z\n0,0,0\n0,0,3\n0.05,0,0\n");
    let mut a = boom.to_vec();
    a.extend(["--target-file", hairpin.to_str().unwrap()]);
    let v = json(&a);
    let w = warning(&v, "doubles-back");
    assert!(w["value"].as_f64().unwrap() > 170.0, "{w}");
    assert!(
        w["message"].as_str().unwrap().contains("turns by 17"),
        "{w}"
    );
    // Longer than the boom can reach: 6 modules of at most 0.618 l against 20 l.
    let mut a = boom.to_vec();
    a.extend([
        "--target",
        "sine:amplitude=0.5,length=20",
        "--metric",
        "ordered",
    ]);
    let v = json(&a);
    let w = warning(&v, "too-long");
    let reach = w["limit"].as_f64().unwrap();
    assert!(
        (reach - 6.0 * 31.72f64.to_radians().tan()).abs() < 1e-9,
        "{w}"
    );
    assert!(w["message"]
        .as_str()
        .unwrap()
        .contains(&format!("{reach:.4} l")));
    assert!(kinds(&v).contains(&"coverage".to_string()));
    // A helix tighter than the tightest pop-out bends (n = 4, β = 23.36°: edge pop-outs tilt
    // 24.9° over 0.216 l, κ = 2 sin(γ/2)/step = 2.0 /l; the helix needs 0.2/(0.2² + (0.4/2π)²)
    // = 4.5 /l).
    let v = json(&[
        "ik",
        "--n",
        "4",
        "--beta",
        "23.36",
        "--modules",
        "6",
        "--target",
        "helix:radius=0.2,pitch=0.4,turns=2",
        "--algo",
        "beam",
    ]);
    let w = warning(&v, "curvature");
    assert!(w["value"].as_f64().unwrap() > 0.9, "{w}");
    let msg = w["message"].as_str().unwrap();
    assert!(msg.contains("the tightest bend is 2.000 /l"), "{msg}");
    // An empty file and a one-point file are refused, saying why.
    let empty = temp_file("empty.csv", "x,y,z\n");
    let mut a = boom.to_vec();
    a.extend(["--target-file", empty.to_str().unwrap()]);
    usage_error(&a, "no points");
    let one = temp_file("one.csv", "0,0,1\n");
    let mut a = boom.to_vec();
    a.extend(["--target-file", one.to_str().unwrap()]);
    usage_error(&a, "is 0 l long, shorter than one module");
}

#[test]
fn design_bands_agree_with_the_geometry_s_closing_angles() {
    let v = json(&["design", "--n", "3..6"]);
    let designs = v["designs"].as_array().unwrap();
    assert_eq!(designs.len(), 4);
    for d in designs {
        let n = d["n"].as_u64().unwrap() as u32;
        let beta_in = geometry::popout::beta_in_deg(n).unwrap();
        let beta_out = geometry::popout::beta_out_deg(n).unwrap();
        assert!((d["beta_in_deg"].as_f64().unwrap() - beta_in).abs() < 1e-12);
        assert!((d["beta_out_deg"].as_f64().unwrap() - beta_out).abs() < 1e-12);
        let bands = d["bands"].as_array().unwrap();
        let band = |family: &str| -> Vec<(f64, f64)> {
            bands
                .iter()
                .filter(|b| b["family"] == family)
                .map(|b| (b["lo_deg"].as_f64().unwrap(), b["hi_deg"].as_f64().unwrap()))
                .collect()
        };
        for (family, closing, state) in [
            ("edge", beta_in, geometry::ShapeState::Edge(0)),
            ("vertex", beta_out, geometry::ShapeState::Vertex(0)),
        ] {
            let feasible = |b: f64| {
                geometry::ModuleDesign::new(n, b)
                    .map(|d| d.state_info(state).feasible)
                    .unwrap_or(false)
            };
            let found = band(family);
            // Feasible at its closing angle ⇔ a band contains it.
            assert_eq!(
                feasible(closing),
                found.iter().any(|&(lo, hi)| (lo..=hi).contains(&closing)),
                "n = {n} {family}: {found:?} vs {closing}"
            );
            // Each band's ends are feasible and just outside them is not.
            for &(lo, hi) in &found {
                assert!(feasible(lo) && feasible(hi) && feasible(0.5 * (lo + hi)));
                assert!(
                    !feasible(lo - 1e-5) && !feasible(hi + 1e-5),
                    "n = {n} {family}"
                );
            }
        }
        // n = 3 has both pop-out families near 31.7°, n = 4 the edge band 22.66–24.05°
        // (the issue's 22.8–24°), n = 5 and 6 none (their pop-outs need > 1 % strain).
        match n {
            3 => assert!(!band("edge").is_empty() && !band("vertex").is_empty()),
            4 => {
                let e = band("edge");
                assert!(
                    e.len() == 1 && (e[0].0 - 22.66).abs() < 0.01 && (e[0].1 - 24.05).abs() < 0.01,
                    "{e:?}"
                );
                assert!(band("vertex").is_empty());
            }
            _ => assert!(band("edge").is_empty() && band("vertex").is_empty()),
        }
        // Self-packing: (90°/n, 45°].
        let sp = band("self-packed");
        assert_eq!(sp.len(), 1);
        assert!((sp[0].0 - 90.0 / n as f64).abs() < 1e-5 && (sp[0].1 - 45.0).abs() < 1e-5);
    }
    // --edge-mm: every height in mm too.
    let v = json(&["design", "--n", "3", "--edge-mm", "75"]);
    assert_eq!(v["edge_mm"], 75.0);
    for b in v["designs"][0]["bands"].as_array().unwrap() {
        for smp in b["samples"].as_array().unwrap() {
            let d = smp["d"].as_f64().unwrap();
            assert!((smp["d_mm"].as_f64().unwrap() - 75.0 * d).abs() < 1e-9);
            assert!(smp["beta_deg"].as_f64().unwrap() <= 85.0);
        }
    }
    let text = stdout(&["design", "--n", "6"]);
    assert!(
        text.contains("no pop-out (bending state) is feasible at any β"),
        "{text}"
    );
}

#[test]
fn design_ranks_betas_by_fit_and_certifies_the_best() {
    let v = json(&[
        "design",
        "--n",
        "3,4",
        "--target",
        "helix:radius=1,pitch=2,turns=1",
        "--modules",
        "14",
        "--metric",
        "ordered",
        "--samples",
        "3",
        "--certify",
        "2",
    ]);
    let fits = v["fits"].as_array().unwrap();
    assert!(fits.len() >= 4, "{fits:?}");
    let rms: Vec<f64> = fits.iter().map(|f| f["rms"].as_f64().unwrap()).collect();
    assert!(rms.windows(2).all(|w| w[0] <= w[1]), "{rms:?}");
    assert_eq!(fits[0]["solver"], "exact");
    assert_eq!(fits[1]["solver"], "exact");
    assert!(fits[2..].iter().all(|f| f["solver"] == "beam"));
    // The best is an n = 3 β in its pop-out band and matches ik at that β.
    assert_eq!(fits[0]["n"], 3);
    let beta = fits[0]["beta_deg"].as_f64().unwrap();
    assert!((31.2..32.3).contains(&beta), "{beta}");
    let ik = json(&[
        "ik",
        "--n",
        "3",
        "--beta",
        &format!("{beta}"),
        "--modules",
        "14",
        "--target",
        "helix:radius=1,pitch=2,turns=1",
        "--metric",
        "ordered",
    ]);
    if fits[0]["optimal"] == true {
        assert!((ik["rms"].as_f64().unwrap() - rms[0]).abs() < 1e-9);
    }
    // n = 4 (d ≤ 0.45 l per module) cannot reach the 6.59 l helix with 14 modules.
    let n4 = fits.iter().find(|f| f["n"] == 4).expect("an n = 4 fit");
    assert!(n4["warnings"]
        .as_array()
        .unwrap()
        .contains(&Value::from("too-long")));
    usage_error(
        &["design", "--n", "4", "--target", "helix"],
        "needs --modules",
    );
    usage_error(&["design", "--n", "4", "--modules", "3"], "give --target");
    usage_error(&["design", "--n", "2..4"], "[3, 64]");
    usage_error(&["design", "--n", "5..3"], "range");
    usage_error(
        &["design", "--n", "6", "--target", "helix", "--modules", "4"],
        "no β with a feasible bending state",
    );
}

#[test]
fn design_draws_its_figure() {
    let svg = temp_file("bands.svg", "");
    let out = host_tool(&["design", "--n", "3,4", "--svg", svg.to_str().unwrap()]);
    assert!(out.status.success());
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") || text.contains("<svg"), "{text}");
    // One bar per band: n = 3 folded, edge, vertex, self-packed; n = 4 folded, edge,
    // self-packed, each drawn twice where it bends (full range and zoom).
    let bars = text.matches("<rect").count();
    assert!(bars >= 7 + 3, "{bars}");
    assert!(text.contains("the pop-out (bending) bands, zoomed"));
}

#[test]
fn states_crane_gives_the_trunk_height_per_state_and_edge_mm_scales_lengths() {
    let v = json(&["states", "--crane"]);
    let states = v["states"].as_array().unwrap();
    let h: Vec<(String, f64)> = states
        .iter()
        .map(|s| {
            (
                s["name"].as_str().unwrap().to_string(),
                s["height_mm"].as_f64().unwrap(),
            )
        })
        .collect();
    // docs/firmware.md: F&P 43.1, F&F 92.5, F&D 138.1, D&P 102.7, D&F 152.1, D&D 197.7 mm.
    let want = [
        ("F&P", 43.1),
        ("F&F", 92.5),
        ("F&D", 138.1),
        ("D&P", 102.7),
        ("D&F", 152.1),
        ("D&D", 197.7),
    ];
    for ((name, got), (wname, wh)) in h.iter().zip(want) {
        assert_eq!(name, wname);
        assert!((got - wh).abs() < 0.06, "{name}: {got} vs {wh}");
    }
    assert!(stdout(&["states", "--crane"]).contains("D&D"));
    usage_error(&["states", "--crane", "--n", "3"], "cannot be used with");
    let v = json(&["states", "--n", "3", "--beta", "31.72", "--edge-mm", "75"]);
    assert_eq!(v["edge_mm"], 75.0);
    for s in v["states"].as_array().unwrap() {
        let d = s["d"].as_f64().unwrap();
        assert!((s["d_mm"].as_f64().unwrap() - 75.0 * d).abs() < 1e-9);
    }
    let v = json(&["states", "--n", "3", "--beta", "31.72"]);
    assert!(v["edge_mm"].is_null() && v["states"][0]["d_mm"].is_null());
    let v = json(&[
        "fk",
        "--n",
        "3",
        "--beta",
        "31.72",
        "--states",
        "deployed,edge-0",
        "--edge-mm",
        "75",
    ]);
    for (t, tm) in v["tips"]
        .as_array()
        .unwrap()
        .iter()
        .zip(v["tips_mm"].as_array().unwrap())
    {
        for k in 0..3 {
            assert!((tm[k].as_f64().unwrap() - 75.0 * t[k].as_f64().unwrap()).abs() < 1e-9);
        }
    }
    let v = json(&[
        "ik",
        "--n",
        "3",
        "--beta",
        "31.72",
        "--modules",
        "4",
        "--target",
        "helix",
        "--edge-mm",
        "75",
    ]);
    assert!((v["rms_mm"].as_f64().unwrap() - 75.0 * v["rms"].as_f64().unwrap()).abs() < 1e-9);
    for bad in ["0", "-1", "NaN", "1e9", "x"] {
        usage_error(
            &["states", "--n", "3", "--beta", "30", "--edge-mm", bad],
            "--edge-mm",
        );
        usage_error(
            &[
                "fk",
                "--n",
                "3",
                "--beta",
                "30",
                "--states",
                "deployed",
                "--edge-mm",
                bad,
            ],
            "--edge-mm",
        );
    }
}

#[test]
fn model_accepts_the_crane_s_state_names() {
    let glb = temp_file("trunk.glb", "");
    let out = stdout(&["model", "--states", "F&P", "--gltf", glb.to_str().unwrap()]);
    assert!(
        out.contains("in states self-packed,self-packed,folded,folded"),
        "{out}"
    );
    assert!(out.contains("expected at a packed boundary"), "{out}");
    let out = stdout(&["model", "--states", "d-d", "--gltf", glb.to_str().unwrap()]);
    assert!(out.contains("deployed,deployed,deployed,deployed"), "{out}");
    usage_error(
        &["model", "--states", "X&P", "--gltf", glb.to_str().unwrap()],
        "valid states are F&P",
    );
    usage_error(
        &[
            "model",
            "--beta",
            "35",
            "--states",
            "F&P",
            "--gltf",
            glb.to_str().unwrap(),
        ],
        "needs a two-module trunk",
    );
}
