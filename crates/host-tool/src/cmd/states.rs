//! `host-tool states`: the metastable states of one Yoshimura module (n, β).

use geometry::{popout, ModuleDesign, StateInfo};
use serde_json::Value;

use crate::failure::Failure;

/// Arguments of `host-tool states`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Number of polygon sides n (an integer in [3, 64]).
    #[arg(long, allow_hyphen_values = true)]
    pub n: String,
    /// Fold angle β in degrees, strictly between 0 and 90.
    #[arg(long, allow_hyphen_values = true)]
    pub beta: String,
    /// Print JSON instead of a table.
    #[arg(short = 'j', long)]
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

/// Parses a `--beta` list (one β for all `m` modules, or one per module, bottom first) and builds
/// the module designs. `count` says where `m` came from, for the error message
/// (e.g. `"--modules is 4"`).
pub fn designs_from(
    n: u32,
    beta_list: &str,
    m: usize,
    count: &str,
) -> Result<Vec<ModuleDesign>, Failure> {
    let betas = beta_list
        .split(',')
        .map(parse_beta)
        .collect::<Result<Vec<f64>, Failure>>()?;
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

fn state_json(info: &StateInfo) -> String {
    ordered_object(&[
        ("name", Value::from(info.state.to_string()).to_string()),
        ("d", num(info.pose.d)),
        ("gamma_deg", num(info.pose.gamma.to_degrees())),
        ("psi_deg", num(info.pose.psi.to_degrees())),
        ("theta_deg", opt_num(info.theta.map(f64::to_degrees))),
        ("feasible", Value::from(info.feasible).to_string()),
        ("max_strain", num(info.max_strain)),
    ])
}

/// Runs `host-tool states`.
pub fn run(args: Args) -> Result<(), Failure> {
    let n = parse_n(&args.n)?;
    let beta = parse_beta(&args.beta)?;
    let design = design_from(n, beta)?;
    let infos: Vec<StateInfo> = design
        .shape_states()
        .map(|s| design.state_info(s))
        .collect();
    let beta_in = popout::beta_in_deg(n);
    let beta_out = popout::beta_out_deg(n);
    if args.json {
        let states: Vec<String> = infos.iter().map(state_json).collect();
        let json = ordered_object(&[
            ("n", n.to_string()),
            ("beta_deg", num(beta)),
            ("w", num(design.w())),
            ("a", num(design.a())),
            ("r", num(design.r())),
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
    crate::out_raw!("{}", table(&design, &infos, beta_in, beta_out));
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
) -> String {
    let mut s = String::new();
    s += &format!(
        "Yoshimura module n = {}, β = {}°   (lengths in units of the edge l)\n",
        design.n(),
        design.beta_deg()
    );
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
        "  {:<11} {:>8} {:>9} {:>9} {:>9} {:>9} {:>10}\n",
        "state", "d", "γ (°)", "ψ (°)", "θ (°)", "feasible", "strain"
    );
    for i in infos {
        s += &format!(
            "  {:<11} {:>8.4} {:>9.3} {:>9.3} {:>9} {:>9} {:>10.2e}\n",
            i.state.to_string(),
            i.pose.d,
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
