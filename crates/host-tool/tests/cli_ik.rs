//! `host-tool ik` through the real binary: the JSON contract, the SVG, the table, and exit code 2
//! with a message that says what is valid on every kind of bad input (never a panic).

#[path = "support/cli.rs"]
mod cli;

use std::path::PathBuf;
use std::process::{Command, Output};

use serde_json::Value;

/// `host-tool ik ARGS`.
fn host_tool(args: &[&str]) -> Output {
    cli::host_tool(&[&["ik"], args].concat())
}

/// `host-tool ik ARGS --json`'s document.
fn json(args: &[&str]) -> Value {
    cli::json(&[&["ik"], args, &["--json"]].concat())
}

/// `host-tool ik ARGS` is a usage error whose message has `expect`.
fn usage_error(args: &[&str], expect: &str) {
    cli::usage_error(&[&["ik"], args].concat(), expect)
}

fn temp_file(name: &str, text: &str) -> PathBuf {
    cli::temp_file("cli_ik", name, text)
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
            "all_states",
            "coverage",
            "edge_mm",
            "elapsed_ms",
            "evaluated",
            "gap",
            "infeasible",
            "lower_bound_rms",
            "optimal",
            "rms",
            "rms_mm",
            "states",
            "stop",
            "tips",
            "tips_mm",
            "warnings"
        ]
    );
    assert_eq!(v["stop"], "finished");
    assert_eq!(v["gap"].as_f64(), Some(0.0));
    assert_eq!(v["lower_bound_rms"].as_f64(), v["rms"].as_f64());
    assert_eq!(v["all_states"], Value::Bool(false));
    assert_eq!(v["infeasible"], serde_json::json!([]));
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
    assert!(text.contains("RMS\u{a0}=\u{a0}"));
    assert!(
        text.contains("β = 35°, 31.72°") && text.contains("(bottom\u{a0}first)"),
        "{text}"
    );
    for view in ["front view (x–z)", "side view (y–z)", "top view (x–y)"] {
        assert!(text.contains(view), "{view}");
    }
    // Module outlines: 2 modules × 4 side edges, 3 boundary polygons, in each of 3 views.
    assert_eq!(text.matches("<polygon").count(), 3 * 3);
}

/// The README's flagship fit: by default only the states the geometry marks feasible (for
/// n = 4, β = 35° the two symmetric ones); `--all-states` reproduces the paper's catalogue and
/// every output names each infeasible state used and its strain.
#[test]
fn feasible_states_by_default_and_all_states_marks_the_infeasible() {
    let args = [
        "--n",
        "4",
        "--beta",
        "35",
        "--modules",
        "10",
        "--target",
        "helix:radius=1,pitch=2,turns=1",
    ];
    let v = json(&args);
    for s in v["states"].as_array().into_iter().flatten() {
        let name = s.as_str().unwrap_or_default();
        assert!(name == "deployed" || name == "folded", "{name}");
    }
    assert_eq!(v["infeasible"], serde_json::json!([]));
    assert_eq!(v["optimal"], Value::Bool(true));
    let feasible_rms = v["rms"].as_f64().expect("rms");

    let mut all = args.to_vec();
    all.push("--all-states");
    let v = json(&all);
    assert_eq!(v["all_states"], Value::Bool(true));
    let all_rms = v["rms"].as_f64().expect("rms");
    assert!(all_rms < feasible_rms, "{all_rms} vs {feasible_rms}");
    let states: Vec<&str> = v["states"]
        .as_array()
        .expect("states")
        .iter()
        .filter_map(Value::as_str)
        .collect();
    let marked = v["infeasible"].as_array().expect("infeasible list");
    let popouts = states
        .iter()
        .filter(|s| s.starts_with("edge") || s.starts_with("vertex"))
        .count();
    assert!(popouts > 0);
    assert_eq!(marked.len(), popouts);
    for entry in marked {
        let module = entry["module"].as_u64().expect("1-based module") as usize;
        assert_eq!(entry["state"].as_str(), Some(states[module - 1]));
        let strain = entry["strain"].as_f64().expect("strain");
        // `host-tool states --n 4 --beta 35`: edge 0.190, vertex 0.201.
        assert!((0.18..0.21).contains(&strain), "{strain}");
    }

    let svg = temp_file("all-states.svg", "");
    let mut with_svg = all.clone();
    with_svg.extend(["--svg", svg.to_str().expect("utf-8 path")]);
    let out = host_tool(&with_svg);
    assert!(out.status.success());
    let table = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        table.matches("INFEASIBLE (strain 0.").count(),
        popouts,
        "{table}"
    );
    assert!(
        table.contains("use states the geometry marks infeasible"),
        "{table}"
    );
    let text = std::fs::read_to_string(&svg).expect("svg written");
    // n = 4 side edges per infeasible module, in a group of their own in each of the 3 views.
    let groups: Vec<usize> = text
        .split(r#"<g class="infeasible">"#)
        .skip(1)
        .map(|g| {
            g[..g.find("</g>").expect("group closed")]
                .matches("<polyline")
                .count()
        })
        .collect();
    assert_eq!(groups, vec![popouts * 4; 3]);
    assert!(
        text.contains(&format!(
            "infeasible state ({popouts} of 10 modules, strain 0.190"
        )) || text.contains(&format!(
            "infeasible state ({popouts} of 10 modules, strain 0.201"
        )),
        "{text}"
    );

    let out = host_tool(&args);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(!table.contains("INFEASIBLE") && table.contains("feasible states only"));
}

/// `--time-limit` and `--gap` stop `exact` with `optimal: false`, a certified lower bound below
/// the incumbent and the relative gap between them.
#[test]
fn time_limit_and_gap_stop_exact_with_a_certified_gap() {
    let hard = [
        "--n",
        "6",
        "--beta",
        "35",
        "--modules",
        "100",
        "--target",
        "helix:radius=2,pitch=10,turns=3",
        "--all-states",
    ];
    let mut a = hard.to_vec();
    a.extend(["--time-limit", "0.3"]);
    let v = json(&a);
    assert_eq!(v["optimal"], Value::Bool(false));
    assert_eq!(v["stop"], "time-limit");
    let rms = v["rms"].as_f64().expect("rms");
    let lb = v["lower_bound_rms"].as_f64().expect("bound");
    let gap = v["gap"].as_f64().expect("gap");
    assert!(lb >= 0.0 && lb <= rms, "{lb} {rms}");
    assert!((gap - (rms - lb) / rms).abs() < 1e-9, "{gap} {rms} {lb}");
    assert!(v["elapsed_ms"].as_f64().expect("ms") < 30_000.0);

    let mut a = BOOM.to_vec();
    a.extend([
        "--target",
        "sine:amplitude=1,wavelength=4,length=5",
        "--all-states",
        "--gap",
        "0.5",
    ]);
    let v = json(&a);
    let gap = v["gap"].as_f64().expect("gap");
    assert!(gap <= 0.5, "{gap}");
    match v["stop"].as_str() {
        Some("gap") => assert_eq!(v["optimal"], Value::Bool(false)),
        Some("finished") => assert_eq!(v["optimal"], Value::Bool(true)),
        other => panic!("stop {other:?}"),
    }
    // Heuristics prove nothing: no bound, no gap.
    let mut a = BOOM.to_vec();
    a.extend(["--target", "helix", "--algo", "beam"]);
    let v = json(&a);
    assert_eq!(v["lower_bound_rms"], Value::Null);
    assert_eq!(v["gap"], Value::Null);
}

/// Ctrl-C (SIGINT) while `exact` runs returns the incumbent with its certified gap, exit 0.
#[cfg(unix)]
#[test]
fn ctrl_c_returns_the_incumbent_with_its_gap() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .args([
            "ik",
            "--n",
            "6",
            "--beta",
            "35",
            "--modules",
            "100",
            "--target",
            "helix:radius=2,pitch=10,turns=3",
            "--all-states",
            "--json",
            "--time-limit",
            "60",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn host-tool");
    // The progress line (after a second of solving) shows the bound and the gap.
    let mut stderr = BufReader::new(child.stderr.take().expect("stderr"));
    let mut line = String::new();
    stderr.read_line(&mut line).expect("progress line");
    assert!(
        line.contains("lower bound") && line.contains("gap"),
        "{line}"
    );
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill");
    assert!(status.success());
    let out = child.wait_with_output().expect("wait");
    // Interrupted: exit 130, as every command on Ctrl-C, after the best boom so far.
    assert_eq!(out.status.code(), Some(130));
    let v: Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(v["optimal"], Value::Bool(false));
    assert_eq!(v["stop"], "interrupted");
    assert!(v["gap"].as_f64().is_some_and(|g| (0.0..=1.0).contains(&g)));
    assert_eq!(v["states"].as_array().map(Vec::len), Some(100));
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
        "an integer in [1, 10000]",
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
    // Inputs that cannot be fitted.
    let huge = temp_file("huge.csv", "0,0,0\n1e308,0,1e308\n");
    usage_error(
        &with(&["--target-file", huge.to_str().unwrap_or_default()]),
        "within ±1000000 l",
    );
    let far = temp_file("far.csv", "0,0,0\n0,0,2e6\n");
    usage_error(
        &with(&["--target-file", far.to_str().unwrap_or_default()]),
        "too far away",
    );
    let point = temp_file("point.csv", "0,0,1\n");
    usage_error(
        &with(&["--target-file", point.to_str().unwrap_or_default()]),
        "shorter than one module",
    );
    // Folded n = 4, β = 35° is 0.5646 l long: a 0.5 l segment is shorter.
    let short = temp_file("short.csv", "0,0,0\n0,0,0.5\n");
    usage_error(
        &with(&["--target-file", short.to_str().unwrap_or_default()]),
        "shorter than one module",
    );
    usage_error(
        &with(&["--target", "sine:length=0.1"]),
        "shorter than one module",
    );
    // Stopping rules.
    for bad in ["0", "-1", "nan", "inf", "1e7", "ten"] {
        usage_error(
            &with(&["--target", "helix", "--time-limit", bad]),
            "--time-limit",
        );
    }
    for bad in ["1", "-0.1", "nan", "1.5", "x"] {
        usage_error(
            &with(&["--target", "helix", "--gap", bad]),
            "--gap must be a fraction in [0, 1)",
        );
    }
    usage_error(
        &with(&["--target", "helix", "--algo", "beam", "--gap", "0.01"]),
        "--gap needs --algo exact",
    );
    usage_error(
        &with(&["--target", "helix", "--all-states", "--feasible-only"]),
        "contradict",
    );
}

/// The edges of the accepted ranges work.
#[test]
fn range_edges_of_the_stopping_options_are_accepted() {
    let mut a = BOOM.to_vec();
    a.extend(["--target", "helix", "--gap", "0", "--time-limit", "1000000"]);
    let v = json(&a);
    assert_eq!(v["optimal"], Value::Bool(true));
    let mut a = BOOM.to_vec();
    a.extend([
        "--target",
        "helix",
        "--gap",
        "0.999999",
        "--time-limit",
        "1e-9",
    ]);
    let v = json(&a);
    assert!(v["rms"].as_f64().is_some_and(f64::is_finite));
    assert_eq!(v["states"].as_array().map(Vec::len), Some(6));
    // A target exactly one module long is accepted: the shortest feasible state of n = 4,
    // β = 35° is folded, d as `host-tool states` reports it.
    let states = Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .args(["states", "--n", "4", "--beta", "35", "--json"])
        .output()
        .expect("run host-tool states");
    let states: Value = serde_json::from_slice(&states.stdout).expect("states JSON");
    let d = states["states"]
        .as_array()
        .and_then(|s| s.iter().find(|s| s["name"] == "folded"))
        .and_then(|s| s["d"].as_f64())
        .expect("folded d");
    let f = temp_file("one-module.csv", &format!("0,0,0\n0,0,{d}\n"));
    let v = json(&[
        "--n",
        "4",
        "--beta",
        "35",
        "--modules",
        "1",
        "--target-file",
        f.to_str().unwrap_or_default(),
    ]);
    assert!(v["rms"].as_f64().is_some_and(|r| r < 1e-9), "{v}");
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
        "--all-states",
        "--time-limit",
        "--gap",
        "--metric",
        "--beam-width",
        "--svg",
    ] {
        assert!(help.contains(word), "--help lacks {word}:\n{help}");
    }
}
