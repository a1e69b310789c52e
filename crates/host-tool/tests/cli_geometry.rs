//! `host-tool states` and `host-tool fk` through the real binary: JSON shapes, tables, and
//! exit code 2 with a helpful message on bad input (never a panic).

#[path = "support/cli.rs"]
mod cli;

use cli::{host_tool, json, usage_error};

const STATE_KEYS: [&str; 8] = [
    "name",
    "d",
    "d_mm",
    "gamma_deg",
    "psi_deg",
    "theta_deg",
    "feasible",
    "max_strain",
];
const TOP_KEYS: [&str; 15] = [
    "n",
    "beta_deg",
    "edge_mm",
    "w",
    "a",
    "r",
    "w_mm",
    "a_mm",
    "r_mm",
    "flat_foldable_beta_deg",
    "zeta_deg",
    "r_in",
    "beta_in_deg",
    "beta_out_deg",
    "states",
];

#[test]
fn states_json_has_exactly_the_documented_shape() {
    let v = json(&["states", "--n", "4", "--beta", "35", "--json"]);
    let obj = v.as_object().unwrap();
    let mut keys: Vec<&str> = obj.keys().map(String::as_str).collect();
    keys.sort_unstable();
    let mut want = TOP_KEYS.to_vec();
    want.sort_unstable();
    assert_eq!(keys, want);
    assert_eq!(v["n"], 4);
    assert_eq!(v["beta_deg"], 35.0);
    assert!((v["w"].as_f64().unwrap() - 35f64.to_radians().tan()).abs() < 1e-12);
    assert!((v["flat_foldable_beta_deg"].as_f64().unwrap() - 22.5).abs() < 1e-12);
    assert!(v["zeta_deg"].is_f64() && v["r_in"].is_f64());
    let states = v["states"].as_array().unwrap();
    assert_eq!(states.len(), 10);
    let names: Vec<&str> = states.iter().map(|s| s["name"].as_str().unwrap()).collect();
    assert_eq!(
        names,
        [
            "deployed", "folded", "edge-0", "edge-1", "edge-2", "edge-3", "vertex-0", "vertex-1",
            "vertex-2", "vertex-3"
        ]
    );
    for s in states {
        let mut k: Vec<&str> = s.as_object().unwrap().keys().map(String::as_str).collect();
        k.sort_unstable();
        let mut want = STATE_KEYS.to_vec();
        want.sort_unstable();
        assert_eq!(k, want);
        assert!(s["feasible"].is_boolean() && s["max_strain"].is_f64());
    }
    assert_eq!(states[0]["theta_deg"], 180.0);
    assert!(states[2]["theta_deg"].is_null());
}

#[test]
fn states_json_nulls_zeta_and_r_in_outside_the_self_packed_range() {
    let v = json(&["states", "--n", "3", "--beta", "50", "--json"]);
    assert!(v["zeta_deg"].is_null() && v["r_in"].is_null());
    let v = json(&["states", "--n", "3", "--beta", "20", "--json"]);
    assert!(v["zeta_deg"].is_null());
    assert!(
        v["states"][1]["theta_deg"].is_null(),
        "folded does not exist below 90°/n"
    );
    assert_eq!(v["states"][1]["feasible"], false);
}

#[test]
fn golden_module_states_are_all_feasible_and_exact() {
    let v = json(&[
        "states",
        "--n",
        "3",
        "--beta",
        "31.717474411461005",
        "--json",
    ]);
    for s in v["states"].as_array().unwrap() {
        assert_eq!(s["feasible"], true, "{s}");
        assert!(s["max_strain"].as_f64().unwrap() < 1e-9);
    }
    assert!((v["beta_in_deg"].as_f64().unwrap() - 31.717474411461005).abs() < 1e-6);
    assert!((v["beta_out_deg"].as_f64().unwrap() - 31.717474411461005).abs() < 1e-6);
}

#[test]
fn states_table_is_readable() {
    let out = host_tool(&["states", "--n", "3", "--beta", "35"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for needle in ["deployed", "folded", "edge-2", "vertex-0", "feasible", "ζ"] {
        assert!(text.contains(needle), "{needle}\n{text}");
    }
}

#[test]
fn fk_json_gives_one_tip_per_module_bottom_first() {
    let v = json(&[
        "fk",
        "--n",
        "3",
        "--beta",
        "35",
        "--states",
        "deployed,deployed",
        "--json",
    ]);
    let obj = v.as_object().unwrap();
    assert_eq!(obj.len(), 6); // tips, infeasible, heading_deg, frames, edge_mm, tips_mm
    assert_eq!(v["infeasible"], serde_json::json!([]));
    assert!(v["edge_mm"].is_null() && v["tips_mm"].is_null());
    let tips = v["tips"].as_array().unwrap();
    assert_eq!(tips.len(), 2);
    let w = 35f64.to_radians().tan();
    for (k, tip) in tips.iter().enumerate() {
        let xyz: Vec<f64> = tip
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(xyz.len(), 3);
        assert!(xyz[0].abs() < 1e-12 && xyz[1].abs() < 1e-12);
        assert!((xyz[2] - w * (k + 1) as f64).abs() < 1e-12);
    }
}

#[test]
fn fk_accepts_one_beta_per_module_and_symmetric_extras() {
    let v = json(&[
        "fk",
        "--n",
        "3",
        "--beta",
        "35,31.72",
        "--states",
        "self-packed,edge-1",
        "--json",
    ]);
    let tips = v["tips"].as_array().unwrap();
    assert_eq!(tips.len(), 2);
    assert_eq!(tips[0], serde_json::json!([0.0, 0.0, 0.0]));
    assert_eq!(v["infeasible"], serde_json::json!([]));
}

/// fk accepts only feasible states unless `--all-states`; then every output marks them.
#[test]
fn fk_refuses_infeasible_states_unless_all_states_and_marks_them() {
    // n = 3, β = 35°: vertex pop-outs carry a crease strain far above 1 %.
    let args = [
        "fk",
        "--n",
        "3",
        "--beta",
        "35",
        "--states",
        "folded,vertex-2",
    ];
    let out = host_tool(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("module 2 state 'vertex-2' is infeasible")
            && stderr.contains("--all-states"),
        "{stderr}"
    );
    let mut all = args.to_vec();
    all.push("--all-states");
    let out = host_tool(&all);
    assert!(out.status.success());
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("vertex-2"), "{table}");
    assert_eq!(table.matches("INFEASIBLE (strain").count(), 1, "{table}");
    assert!(table.contains("1 of 2 modules use states the geometry marks infeasible"));
    all.push("--json");
    let v = json(&all);
    let marked = v["infeasible"].as_array().unwrap();
    assert_eq!(marked.len(), 1);
    assert_eq!(marked[0]["module"], 2);
    assert_eq!(marked[0]["state"], "vertex-2");
    let strain = marked[0]["strain"].as_f64().unwrap();
    assert!(strain > geometry_tolerance(), "{strain}");
    // The pop-outs of n = 3 at β = 31.72° are feasible: accepted without the flag.
    let v = json(&[
        "fk",
        "--n",
        "3",
        "--beta",
        "31.72",
        "--states",
        "deployed,edge-0,vertex-2",
        "--json",
    ]);
    assert_eq!(v["tips"].as_array().map(Vec::len), Some(3));
    assert_eq!(v["infeasible"], serde_json::json!([]));
}

/// `geometry::STRAIN_TOLERANCE`, as documented by `host-tool states`.
fn geometry_tolerance() -> f64 {
    0.01
}

#[test]
fn bad_input_exits_2_saying_what_is_valid() {
    usage_error(&["states", "--n", "2", "--beta", "30"], "[3, 64]");
    usage_error(&["states", "--n", "three", "--beta", "30"], "integer");
    usage_error(&["states", "--n", "3.5", "--beta", "30"], "integer");
    usage_error(&["states", "--n", "-4", "--beta", "30"], "integer");
    usage_error(&["states", "--n", "3", "--beta", "NaN"], "between 0 and 90");
    usage_error(&["states", "--n", "3", "--beta", "90"], "between 0 and 90");
    usage_error(&["states", "--n", "3", "--beta", "-10"], "between 0 and 90");
    usage_error(&["states", "--n", "3", "--beta", "abc"], "between 0 and 90");
    usage_error(
        &[
            "fk",
            "--n",
            "3",
            "--beta",
            "35",
            "--states",
            "deployed,sideways",
        ],
        "deployed, folded, edge-0 … edge-2",
    );
    usage_error(
        &["fk", "--n", "3", "--beta", "35", "--states", "edge-3"],
        "edge-0 … edge-2",
    );
    usage_error(
        &[
            "fk",
            "--n",
            "3",
            "--beta",
            "30,31,32",
            "--states",
            "deployed,folded",
        ],
        "one β for all modules or one per module",
    );
    usage_error(
        &[
            "fk",
            "--n",
            "3",
            "--beta",
            "30,x",
            "--states",
            "deployed,folded",
        ],
        "between 0 and 90",
    );
    usage_error(
        &["fk", "--n", "3", "--beta", "50", "--states", "self-packed"],
        "45",
    );
    usage_error(
        &["fk", "--n", "3", "--beta", "35", "--states", ""],
        "comma-separated",
    );
    usage_error(
        &["fk", "--n", "1", "--beta", "35", "--states", "folded"],
        "[3, 64]",
    );
    // clap's own usage errors (missing arguments) also exit 2
    let out = host_tool(&["states", "--n", "3"]);
    assert_eq!(out.status.code(), Some(2));
}
