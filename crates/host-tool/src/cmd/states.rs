//! `host-tool states`: the metastable states of one Yoshimura module (n, β).

use geometry::{popout, ModuleDesign, StateInfo};
use serde_json::Value;

use crate::failure::Failure;

/// Arguments of `host-tool states`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Number of polygon sides n (an integer in [3, 64]).
    #[arg(long, allow_hyphen_values = true, required_unless_present = "crane",
          value_parser = crate::arg::usage(parse_n))]
    pub n: Option<u32>,
    /// Fold angle β in degrees, strictly between 0 and 90.
    #[arg(long, allow_hyphen_values = true, required_unless_present = "crane",
          value_parser = crate::arg::usage(parse_beta))]
    pub beta: Option<f64>,
    /// Print lengths in millimetres too, for a valley fold (polygon edge) of this length.
    #[arg(long, value_name = "MM", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_edge_mm))]
    pub edge_mm: Option<f64>,
    /// The crane's trunk instead of one module: its height in each of its six states
    /// (`F&P` … `D&D`), from the firmware's configuration and the geometry.
    #[arg(long, conflicts_with_all = ["n", "beta", "edge_mm"])]
    pub crane: bool,
    /// Print JSON instead of a table.
    #[arg(skip)]
    pub json: bool,
}

/// Parses and validates `--n`.
pub fn parse_n(text: &str) -> Result<u32, Failure> {
    let t = text.trim();
    let bad = || {
        Failure::usage(format!(
            "--n must be an integer in [{}, {}], got '{text}'",
            geometry::MIN_N,
            geometry::MAX_N
        ))
    };
    if t.is_empty() || !t.bytes().all(|b| b.is_ascii_digit()) {
        return Err(bad());
    }
    let n: u32 = t.parse().map_err(|_| bad())?;
    if !(geometry::MIN_N..=geometry::MAX_N).contains(&n) {
        return Err(bad());
    }
    Ok(n)
}

/// Longest `--edge-mm` accepted (as `pattern --edge-mm`): 10 m.
pub const MAX_EDGE_MM: f64 = 10_000.0;

/// Parses `--edge-mm`: the valley fold (polygon edge) length l in mm, in (0, 10000].
pub fn parse_edge_mm(text: &str) -> Result<f64, Failure> {
    let bad = || {
        Failure::usage(format!(
            "--edge-mm must be a length in mm in (0, {MAX_EDGE_MM}] (the valley fold, the polygon edge l), got '{text}'"
        ))
    };
    let v: f64 = text.trim().parse().map_err(|_| bad())?;
    if !(v.is_finite() && v > 0.0 && v <= MAX_EDGE_MM) {
        return Err(bad());
    }
    Ok(v)
}

/// Parses one β in degrees (any finite number; the design checks the range).
pub fn parse_beta(text: &str) -> Result<f64, Failure> {
    let t = text.trim();
    let beta: f64 = t.parse().map_err(|_| {
        Failure::usage(format!(
            "--beta must be a number of degrees strictly between 0 and 90, got '{text}'"
        ))
    })?;
    if !(beta.is_finite() && beta > 0.0 && beta < 90.0) {
        return Err(Failure::usage(format!(
            "--beta must be a finite angle strictly between 0 and 90 degrees, got '{text}'"
        )));
    }
    Ok(beta)
}

/// A `--beta` list: one β for all modules, or one per module, bottom first.
#[derive(Debug, Clone, PartialEq)]
pub struct Betas(pub Vec<f64>);

/// Parses a `--beta` list, each β as [`parse_beta`].
pub fn parse_betas(text: &str) -> Result<Betas, Failure> {
    text.split(',')
        .map(parse_beta)
        .collect::<Result<_, _>>()
        .map(Betas)
}

/// Builds the module designs of a `--beta` list for `m` modules. `count` says where `m` came
/// from, for the error message (e.g. `"--modules is 4"`).
pub fn designs_from(
    n: u32,
    betas: &Betas,
    m: usize,
    count: &str,
) -> Result<Vec<ModuleDesign>, Failure> {
    let betas = &betas.0;
    if betas.len() != 1 && betas.len() != m {
        return Err(Failure::usage(format!(
            "--beta has {} values but {count}; give one β for all modules or one per module, bottom first",
            betas.len()
        )));
    }
    (0..m)
        .map(|i| design_from(n, betas[if betas.len() == 1 { 0 } else { i }]))
        .collect()
}

/// A validated module design from `--n`/`--beta` text.
pub fn design_from(n: u32, beta_deg: f64) -> Result<ModuleDesign, Failure> {
    ModuleDesign::new(n, beta_deg).map_err(|e| Failure::usage(e.to_string()))
}

/// A JSON object with keys in the given order (serde_json's map would sort them).
pub fn ordered_object(entries: &[(&str, String)]) -> String {
    let body: Vec<String> = entries
        .iter()
        .map(|(k, v)| format!("{}:{v}", Value::from(*k)))
        .collect();
    format!("{{{}}}", body.join(","))
}

fn num(x: f64) -> String {
    crate::num::json(x).to_string()
}

fn opt_num(x: Option<f64>) -> String {
    x.map_or_else(|| "null".to_string(), num)
}

fn state_json(info: &StateInfo, edge_mm: Option<f64>) -> String {
    ordered_object(&[
        ("name", Value::from(info.state.to_string()).to_string()),
        ("d", num(info.pose.d)),
        ("d_mm", opt_num(edge_mm.map(|e| info.pose.d * e))),
        ("gamma_deg", num(info.pose.gamma.to_degrees())),
        ("psi_deg", num(info.pose.psi.to_degrees())),
        ("theta_deg", opt_num(info.theta.map(f64::to_degrees))),
        ("feasible", Value::from(info.feasible).to_string()),
        ("max_strain", num(info.max_strain)),
    ])
}

/// Runs `host-tool states`.
pub fn run(args: Args) -> Result<(), Failure> {
    if args.crane {
        return crane(args.json);
    }
    let (Some(n), Some(beta)) = (args.n, args.beta) else {
        return Err(Failure::usage(
            "give --n N and --beta DEG for one module, or --crane for the crane's trunk",
        ));
    };
    let edge_mm = args.edge_mm;
    let design = design_from(n, beta)?;
    let infos: Vec<StateInfo> = design
        .shape_states()
        .map(|s| design.state_info(s))
        .collect();
    let beta_in = popout::beta_in_deg(n);
    let beta_out = popout::beta_out_deg(n);
    if args.json {
        let states: Vec<String> = infos.iter().map(|i| state_json(i, edge_mm)).collect();
        let mm = |v: f64| opt_num(edge_mm.map(|e| v * e));
        let json = ordered_object(&[
            ("n", n.to_string()),
            ("beta_deg", num(beta)),
            ("edge_mm", opt_num(edge_mm)),
            ("w", num(design.w())),
            ("a", num(design.a())),
            ("r", num(design.r())),
            ("w_mm", mm(design.w())),
            ("a_mm", mm(design.a())),
            ("r_mm", mm(design.r())),
            (
                "flat_foldable_beta_deg",
                num(design.flat_foldable_beta_deg()),
            ),
            ("zeta_deg", opt_num(design.zeta().map(f64::to_degrees))),
            ("r_in", opt_num(design.r_in())),
            ("beta_in_deg", opt_num(beta_in)),
            ("beta_out_deg", opt_num(beta_out)),
            ("states", format!("[{}]", states.join(","))),
        ]);
        crate::cli::print_json_text(&json);
        return Ok(());
    }
    crate::out_raw!("{}", table(&design, &infos, beta_in, beta_out, edge_mm));
    Ok(())
}

/// `states --crane`: the crane trunk's height in each of its six states.
fn crane(json: bool) -> Result<(), Failure> {
    use geometry::trunk::TrunkState;
    let cfg = protocol::CraneGeometry::default();
    let t = &cfg;
    // The geometry crate's closed forms (the firmware's f32 twin agrees to 1e-4 relative,
    // `crates/firmware/tests/config_heights.rs`), in f32 as the controller holds them.
    let model = planner::task::Workspace::of_crane(&cfg, [None; 6]).ok();
    let heights: Vec<(TrunkState, Option<f32>)> = TrunkState::ALL
        .iter()
        .map(|&s| (s, model.as_ref().map(|w| w.heights().height_mm(s) as f32)))
        .collect();
    let module = |m: &protocol::ModuleConfig| {
        ordered_object(&[
            ("n", m.n.to_string()),
            ("beta_deg", crate::num::json32(m.beta_deg).to_string()),
            ("edge_mm", crate::num::json32(m.edge_mm).to_string()),
            ("layers", m.layers.to_string()),
        ])
    };
    if json {
        let states: Vec<String> = heights
            .iter()
            .map(|(s, h)| {
                ordered_object(&[
                    ("name", Value::from(s.name()).to_string()),
                    (
                        "height_mm",
                        h.map_or("null".into(), |h| crate::num::json32(h).to_string()),
                    ),
                    ("flexible", Value::from(s.is_flexible()).to_string()),
                ])
            })
            .collect();
        crate::cli::print_json_text(&ordered_object(&[
            ("top", module(&t.top)),
            ("bottom", module(&t.bottom)),
            (
                "packed_layer_mm",
                crate::num::json32(cfg.packed_layer_mm).to_string(),
            ),
            ("states", format!("[{}]", states.join(","))),
        ]));
        return Ok(());
    }
    crate::out!("the crane's trunk, TOP&BOTTOM (a module is a group of layers of one β):");
    for (name, m) in [("top", &t.top), ("bottom", &t.bottom)] {
        crate::out!(
            "  {name:<6} module: n = {}, β = {}°, {} layers, edge {} mm",
            m.n,
            m.beta_deg,
            m.layers,
            m.edge_mm
        );
    }
    crate::out!(
        "  a self-packed layer is {} mm high (its panels stacked)",
        cfg.packed_layer_mm
    );
    crate::out!();
    crate::out!("  {:<6} {:>12}  bends (joystick)", "state", "height (mm)");
    for (s, h) in &heights {
        crate::out!(
            "  {:<6} {:>12}  {}",
            s.name(),
            h.map_or("—".to_string(), |h| format!("{h:.1}")),
            if s.is_flexible() { "yes" } else { "no" }
        );
    }
    crate::out!();
    crate::out!("  height = Σ layers × d (folded or deployed, `host-tool states --n 3 --beta …`) × edge, or layers × the packed layer");
    Ok(())
}

fn fmt_opt(x: Option<f64>, unit: &str) -> String {
    x.map_or_else(|| "—".to_string(), |v| format!("{v:.4}{unit}"))
}

fn table(
    design: &ModuleDesign,
    infos: &[StateInfo],
    beta_in: Option<f64>,
    beta_out: Option<f64>,
    edge_mm: Option<f64>,
) -> String {
    let mut s = String::new();
    s += &format!(
        "Yoshimura module n = {}, β = {}°   (lengths in units of the edge l{})\n",
        design.n(),
        design.beta_deg(),
        edge_mm.map_or(String::new(), |e| format!(" = {e} mm"))
    );
    if let Some(e) = edge_mm {
        s += &format!(
            "  w = {:.2} mm   a = {:.2} mm   r = {:.2} mm\n",
            design.w() * e,
            design.a() * e,
            design.r() * e
        );
    }
    s += &format!(
        "  w = {:.4}   a = {:.4}   r = {:.4}   flat-foldable β = {:.4}°\n",
        design.w(),
        design.a(),
        design.r(),
        design.flat_foldable_beta_deg()
    );
    s += &format!(
        "  self-packed: {}   ζ = {}   r_in = {}\n",
        if design.can_self_pack() {
            "yes (d = 0)"
        } else {
            "no"
        },
        fmt_opt(design.zeta().map(f64::to_degrees), "°"),
        fmt_opt(design.r_in(), "")
    );
    s += &format!(
        "  β_in = {}   β_out = {}\n\n",
        fmt_opt(beta_in, "°"),
        fmt_opt(beta_out, "°")
    );
    s += &format!(
        "  {:<11} {:>8}{} {:>9} {:>9} {:>9} {:>9} {:>10}\n",
        "state",
        "d",
        if edge_mm.is_some() {
            format!(" {:>9}", "d (mm)")
        } else {
            String::new()
        },
        "γ (°)",
        "ψ (°)",
        "θ (°)",
        "feasible",
        "strain"
    );
    for i in infos {
        s += &format!(
            "  {:<11} {:>8.4}{} {:>9.3} {:>9.3} {:>9} {:>9} {:>10.2e}\n",
            i.state.to_string(),
            i.pose.d,
            edge_mm.map_or(String::new(), |e| format!(" {:>9.2}", i.pose.d * e)),
            i.pose.gamma.to_degrees(),
            i.pose.psi.to_degrees(),
            i.theta
                .map_or_else(|| "—".to_string(), |t| format!("{:.3}", t.to_degrees())),
            if i.feasible { "yes" } else { "no" },
            i.max_strain
        );
    }
    s += &format!(
        "\n  feasible = state exists for this β, d ≤ w and strain ≤ {} (see docs/geometry.md)\n",
        geometry::STRAIN_TOLERANCE
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_n_accepts_only_integers_in_range() {
        assert_eq!(parse_n("3").ok(), Some(3));
        assert_eq!(parse_n(" 64 ").ok(), Some(64));
        for bad in ["2", "65", "-3", "3.0", "x", "", "99999999999"] {
            assert!(parse_n(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn parse_beta_rejects_nan_and_out_of_range() {
        assert_eq!(parse_beta("35").ok(), Some(35.0));
        for bad in ["NaN", "inf", "0", "90", "-5", "abc", ""] {
            assert!(parse_beta(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn ordered_object_keeps_key_order() {
        let s = ordered_object(&[("b", "1".into()), ("a", "null".into())]);
        assert_eq!(s, r#"{"b":1,"a":null}"#);
    }

    #[test]
    fn state_names_parse_for_the_design() {
        assert!(geometry::ShapeState::parse("edge-2", 3).is_ok());
    }
}
