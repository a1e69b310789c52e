//! `host-tool ik` through the real binary: the JSON contract, the SVG, the table, and exit code 2
//! with a message that says what is valid on every kind of bad input (never a panic).

use std::path::PathBuf;
use std::process::{Command, Output};

use serde_json::Value;

fn host_tool(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .arg("ik")
        .args(args)
        .output()
        .expect("run host-tool")
}

fn json(args: &[&str]) -> Value {
    let mut a = args.to_vec();
    a.push("--json");
    let out = host_tool(&a);
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

fn temp_file(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cli_ik_{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write temp file");
    p
}

const BOOM: [&str; 6] = ["--n", "4", "--beta", "35", "--modules", "6"];

#[test]
fn json_has_exactly_the_documented_keys() {
    let mut args = BOOM.to_vec();
    args.extend([
        "--target",
        "helix:radius=1,pitch=4,turns=1",
        "--algo",
        "exact",
    ]);
    let v = json(&args);
    let obj = v.as_object().expect("object");
    let mut keys: Vec<&str> = obj.keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(
        keys,
        [
            "elapsed_ms",
            "evaluated",
            "optimal",
            "rms",
            "states",
            "tips"
        ]
    );
    assert_eq!(v["states"].as_array().map(Vec::len), Some(6));
    assert_eq!(v["tips"].as_array().map(Vec::len), Some(6));
    assert_eq!(v["optimal"], Value::Bool(true));
    assert!(v["rms"].as_f64().is_some_and(|r| r.is_finite() && r >= 0.0));
    assert!(v["evaluated"].as_u64().is_some_and(|e| e > 0));
    for t in v["tips"].as_array().into_iter().flatten() {
        assert_eq!(t.as_array().map(Vec::len), Some(3));
    }
}

#[test]
fn exact_equals_exhaustive_and_heuristics_are_no_better() {
    let mut base = vec!["--n", "3", "--beta", "31.72", "--modules", "4"];
    base.extend(["--target", "sine:amplitude=0.5,wavelength=2,length=2"]);
    let rms = |algo: &[&str]| {
        let mut a = base.clone();
        a.extend(algo);
        json(&a)["rms"].as_f64().expect("rms")
    };
    let exact = rms(&["--algo", "exact"]);
    let exhaustive = rms(&["--algo", "exhaustive"]);
    assert!(
        (exact - exhaustive).abs() <= 1e-9,
        "{exact} vs {exhaustive}"
    );
    for algo in [
        &["--algo", "greedy"][..],
        &["--algo", "beam", "--beam-width", "3"],
        &["--algo", "window", "--window-width", "2"],
        &["--algo", "dp"],
        &["--algo", "exact", "--metric", "ordered"],
    ] {
        let r = rms(algo);
        assert!(r.is_finite());
        if !algo.contains(&"ordered") {
            assert!(r >= exact - 1e-12, "{algo:?}: {r} < {exact}");
        }
    }
}

#[test]
fn target_file_per_module_beta_and_svg() {
    let csv = temp_file("target.csv", "x,y,z\n0,0,0\n0.2,0,0.6\n0.5,0.1,1.2\n");
    let svg = csv.with_file_name("fit.svg");
    let out = host_tool(&[
        "--n",
        "4",
        "--beta",
        "35,31.72",
        "--modules",
        "2",
        "--target-file",
        csv.to_str().expect("utf-8 path"),
        "--svg",
        svg.to_str().expect("utf-8 path"),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(
        table.contains("RMS") && table.contains("proven optimal"),
        "{table}"
    );
    let text = std::fs::read_to_string(&svg).expect("svg written");
    assert!(text.starts_with("<svg") && text.trim_end().ends_with("</svg>"));
    assert!(text.contains("RMS = "));
    for view in ["front (x–z)", "side (y–z)", "top (x–y)"] {
        assert!(text.contains(view), "{view}");
    }
    // Module outlines: 2 modules × 4 side edges, 3 boundary polygons, in each of 3 views.
    assert_eq!(text.matches("<polygon").count(), 3 * 3);
}

#[test]
fn feasible_only_restricts_the_candidates() {
    let mut args = BOOM.to_vec();
    args.extend(["--target", "arc", "--feasible-only", "--algo", "greedy"]);
    let v = json(&args);
    // For n = 4, β = 35° the geometry marks only the symmetric states feasible.
    for s in v["states"].as_array().into_iter().flatten() {
        let name = s.as_str().unwrap_or_default();
        assert!(name == "deployed" || name == "folded", "{name}");
    }
}

#[test]
fn bad_input_is_a_usage_error_with_a_clear_message() {
    fn with<'a>(extra: &[&'a str]) -> Vec<&'a str> {
        let mut a = BOOM.to_vec();
        a.extend(extra);
        a
    }
    usage_error(
        &with(&["--target", "helix", "--algo", "magic"]),
        "valid algorithms are exact, exhaustive, greedy, beam, window, dp",
    );
    usage_error(
        &with(&["--target", "helix", "--metric", "l1"]),
        "valid metrics are eq36, ordered",
    );
    usage_error(
        &with(&["--target", "spiral"]),
        "valid generators are helix, sine, arc",
    );
    usage_error(
        &with(&["--target", "helix:radius=1,colour=red"]),
        "valid parameters are radius, pitch, turns, samples",
    );
    usage_error(
        &with(&["--target", "helix:radius=nan"]),
        "not a finite number",
    );
    usage_error(&with(&["--target", "sine:wavelength=-1"]), "must be > 0");
    usage_error(&with(&[]), "give a target");
    usage_error(
        &[
            "--n",
            "4",
            "--beta",
            "35",
            "--modules",
            "0",
            "--target",
            "helix",
        ],
        "at least 1",
    );
    usage_error(
        &[
            "--n",
            "4",
            "--beta",
            "35",
            "--modules",
            "x",
            "--target",
            "helix",
        ],
        "--modules must be an integer",
    );
    usage_error(
        &[
            "--n",
            "2",
            "--beta",
            "35",
            "--modules",
            "3",
            "--target",
            "helix",
        ],
        "--n must be an integer",
    );
    usage_error(
        &[
            "--n",
            "4",
            "--beta",
            "35,30",
            "--modules",
            "3",
            "--target",
            "helix",
        ],
        "one β for all modules or one per module",
    );
    usage_error(
        &with(&["--target", "helix", "--algo", "beam", "--beam-width", "0"]),
        "--beam-width",
    );
    usage_error(
        &with(&["--target", "helix", "--algo", "dp", "--dp-tolerance", "a,b"]),
        "--dp-tolerance",
    );

    let empty = temp_file("empty.csv", "");
    usage_error(
        &with(&["--target-file", empty.to_str().unwrap_or_default()]),
        "no points",
    );
    let header_only = temp_file("header.csv", "x,y,z\n");
    usage_error(
        &with(&["--target-file", header_only.to_str().unwrap_or_default()]),
        "no points",
    );
    let malformed = temp_file("bad.csv", "0,0,0\n1,2\n");
    usage_error(
        &with(&["--target-file", malformed.to_str().unwrap_or_default()]),
        "line 2",
    );
    let nan = temp_file("nan.csv", "0,0,0\n\n1,NaN,2\n");
    usage_error(
        &with(&["--target-file", nan.to_str().unwrap_or_default()]),
        "line 3",
    );
    let word = temp_file("word.csv", "0,0,0\n1,two,3\n");
    usage_error(
        &with(&["--target-file", word.to_str().unwrap_or_default()]),
        "line 2",
    );
    usage_error(
        &with(&["--target-file", "/nonexistent/target.csv"]),
        "cannot read",
    );
    // An endless file is refused after 64 MiB instead of exhausting memory.
    usage_error(&with(&["--target-file", "/dev/zero"]), "larger than 64 MiB");
    // A generator whose point count would exhaust memory is refused before allocating.
    usage_error(
        &with(&["--target", "helix:radius=1,pitch=1,turns=1e9"]),
        "at most 1000000 points",
    );
    usage_error(
        &with(&[
            "--target-file",
            nan.to_str().unwrap_or_default(),
            "--target",
            "helix",
        ]),
        "not both",
    );
}

#[test]
fn help_documents_the_generators() {
    let out = host_tool(&["--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    for word in [
        "helix:radius=",
        "pitch",
        "turns",
        "sine:amplitude=",
        "wavelength",
        "arc:radius=",
        "angle",
        "--feasible-only",
        "--metric",
        "--beam-width",
        "--svg",
    ] {
        assert!(help.contains(word), "--help lacks {word}:\n{help}");
    }
}
