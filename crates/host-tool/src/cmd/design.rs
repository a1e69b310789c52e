//! `host-tool design`: which β works. For one n or a range, the β bands in which each family of
//! states is feasible (folded, edge and vertex pop-outs, self-packed; deployed always is), the
//! states' heights and tilts across each band; with `--target`, every β sampled in the bending
//! bands ranked by the RMS a beam search finds, the best few certified by the exact solver.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use geometry::{popout, ModuleDesign};
use planner::ik::bands::{self, Band, Family};
use planner::ik::{self, Algorithm, Catalogue, Control, Metric, Problem, Target};
use serde_json::Value;

use super::ik::{parse_metric, parse_time_limit, read_target, MAX_MODULES};
use super::states::{ordered_object, parse_edge_mm};
use crate::failure::Failure;
use crate::figure::{
    colour, paragraph, text_width, wrap, Anchor, Area, Figure, Legend, Rect, Stroke, Swatch, Ticks,
    ASCENT, CAP, COLUMN_PT, LEADING, SIZE_LABEL, SIZE_TICK, SIZE_TITLE,
};

/// Arguments of `host-tool design`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Number of polygon sides: one (`4`), a list (`3,4,6`) or an inclusive range (`3..8`),
    /// each in [3, 64].
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::usage(parse_ns))]
    pub n: Ns,
    /// Rank βs for this built-in target curve (as `ik --target`; needs --modules).
    #[arg(long, value_name = "SPEC", allow_hyphen_values = true,
          value_parser = crate::arg::usage(super::ik::parse_target))]
    pub target: Option<super::ik::TargetSpec>,
    /// Rank βs for this CSV target (as `ik --target-file`; needs --modules).
    #[arg(long, value_name = "FILE")]
    pub target_file: Option<PathBuf>,
    /// Modules m of the boom to fit (with a target), an integer in [1, 10000].
    #[arg(long, allow_hyphen_values = true,
          value_parser = crate::num::count_in("--modules", 1, MAX_MODULES))]
    pub modules: Option<usize>,
    /// Objective of the ranking: eq36 or ordered (see `ik --metric`).
    #[arg(long, default_value = "eq36", value_parser = crate::arg::usage(parse_metric))]
    pub metric: Metric,
    /// βs tried per bending band (evenly spread inside it, plus its closing angle β_in or
    /// β_out when it lies inside), an integer in [1, 100].
    #[arg(long, default_value = "5", allow_hyphen_values = true,
          value_parser = crate::num::count_in("--samples", 1, 100))]
    pub samples: usize,
    /// How many of the best-ranked βs the exact solver certifies, an integer in [0, 20].
    #[arg(long, default_value = "3", allow_hyphen_values = true,
          value_parser = crate::num::count_in("--certify", 0, 20))]
    pub certify: usize,
    /// Time limit of each certification in seconds (the result then carries its gap).
    #[arg(
        long,
        default_value = "2",
        value_name = "SECONDS",
        allow_hyphen_values = true,
        value_parser = crate::arg::usage(parse_time_limit)
    )]
    pub time_limit: std::time::Duration,
    /// Print heights in millimetres too, for a valley fold (polygon edge) of this length.
    #[arg(long, value_name = "MM", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_edge_mm))]
    pub edge_mm: Option<f64>,
    /// Print JSON instead of text.
    #[arg(skip)]
    pub json: bool,
    /// Write the figure (the feasible bands against β; with a target, the ranking) as SVG.
    #[arg(long, value_name = "OUT")]
    pub svg: Option<PathBuf>,
    /// The same figure as PNG (600 dpi).
    #[arg(long, value_name = "OUT")]
    pub png: Option<PathBuf>,
    /// The same figure as PDF.
    #[arg(long, value_name = "OUT")]
    pub pdf: Option<PathBuf>,
}

/// The state of a family at one β: height d, tilt γ, strain.
#[derive(Debug, Clone, Copy)]
struct Sample {
    beta_deg: f64,
    d: f64,
    gamma_deg: f64,
    strain: f64,
}

fn sample(n: u32, family: Family, beta_deg: f64) -> Option<Sample> {
    let design = ModuleDesign::new(n, beta_deg).ok()?;
    Some(match family.representative() {
        Some(s) => {
            let info = design.state_info(s);
            Sample {
                beta_deg,
                d: info.pose.d,
                gamma_deg: info.pose.gamma.to_degrees(),
                strain: info.max_strain,
            }
        }
        None => Sample {
            beta_deg,
            d: 0.0,
            gamma_deg: 0.0,
            strain: 0.0,
        },
    })
}

/// One n's design space.
struct Space {
    n: u32,
    beta_in: Option<f64>,
    beta_out: Option<f64>,
    flat_foldable: f64,
    /// Every band with its states at its low end, middle and high end.
    bands: Vec<(Band, Vec<Sample>)>,
}

/// The highest β at which a band's states are sampled: d = tan β grows without bound as
/// β → 90°.
const SAMPLE_MAX_DEG: f64 = 85.0;

fn space(n: u32) -> Space {
    let bands = bands::bands(n)
        .into_iter()
        .map(|b| {
            let samples = [b.lo_deg, b.mid_deg(), b.hi_deg.min(SAMPLE_MAX_DEG)]
                .iter()
                .filter_map(|&beta| sample(n, b.family, beta))
                .collect();
            (b, samples)
        })
        .collect();
    Space {
        n,
        beta_in: popout::beta_in_deg(n),
        beta_out: popout::beta_out_deg(n),
        flat_foldable: ModuleDesign::new(n, 45.0)
            .map(|d| d.flat_foldable_beta_deg())
            .unwrap_or(f64::NAN),
        bands,
    }
}

/// One ranked β.
struct Fit {
    n: u32,
    beta_deg: f64,
    /// The bands (families) it lies in.
    families: Vec<&'static str>,
    solution: ik::Solution,
    coverage: f64,
    /// Whether the exact solver ran on it.
    certified: bool,
    /// The kinds of the fit's warnings ([`ik::diagnose::assess`]).
    warnings: Vec<&'static str>,
}

/// The kinds of the warnings of `s` on `problem`.
fn warning_kinds(
    problem: &Problem,
    designs: &[ModuleDesign],
    s: &ik::Solution,
) -> Vec<&'static str> {
    ik::diagnose::assess(problem, designs, true, &s.tips, s.rms, &Control::new())
        .into_iter()
        .map(|w| w.kind)
        .collect()
}

/// The βs tried for `n`: `samples` evenly inside each bending band ((k + ½)/samples of its
/// width) and its closing angle if inside.
fn candidate_betas(space: &Space, samples: usize) -> Vec<f64> {
    let mut betas = Vec::new();
    for (b, _) in &space.bands {
        if !b.family.bends() {
            continue;
        }
        for k in 0..samples {
            betas.push(b.lo_deg + (k as f64 + 0.5) / samples as f64 * (b.hi_deg - b.lo_deg));
        }
        if let Some(c) = b.family.closing_angle_deg(space.n) {
            if b.contains(c) {
                betas.push(c);
            }
        }
    }
    betas.sort_by(f64::total_cmp);
    betas.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    betas
}

/// The `--n` of `design`: the sides to try, ascending, each once.
#[derive(Debug, Clone, PartialEq)]
pub struct Ns(pub Vec<u32>);

fn parse_ns(text: &str) -> Result<Ns, Failure> {
    let bad = || {
        Failure::usage(format!(
            "--n must be an integer, a list (3,4,6) or a range (3..8) of integers in [{}, {}], got '{text}'",
            geometry::MIN_N,
            geometry::MAX_N
        ))
    };
    let mut out = Vec::new();
    for part in text.split(',') {
        if let Some((a, b)) = part.split_once("..") {
            let a = super::states::parse_n(a).map_err(|_| bad())?;
            let b = super::states::parse_n(b).map_err(|_| bad())?;
            if a > b {
                return Err(bad());
            }
            out.extend(a..=b);
        } else {
            out.push(super::states::parse_n(part).map_err(|_| bad())?);
        }
    }
    out.sort_unstable();
    out.dedup();
    Ok(Ns(out))
}

/// The figure files asked for.
fn figures(args: &Args) -> Vec<(&'static str, crate::figure::Format, PathBuf)> {
    [
        ("--svg", crate::figure::Format::Svg, args.svg.clone()),
        ("--png", crate::figure::Format::Png, args.png.clone()),
        ("--pdf", crate::figure::Format::Pdf, args.pdf.clone()),
    ]
    .into_iter()
    .filter_map(|(f, fmt, p)| Some((f, fmt, p?)))
    .collect()
}

/// A ranking request: the target, the boom length and the solver settings.
struct Ranking {
    target: Target,
    label: String,
    m: usize,
    metric: Metric,
    samples: usize,
    certify: usize,
    time_limit: Duration,
}

/// Runs `host-tool design`.
pub fn run(args: Args) -> Result<(), Failure> {
    let ns = args.n.0.clone();
    let edge_mm = args.edge_mm;
    let samples = args.samples;
    let certify = args.certify;
    let time_limit = args.time_limit;
    let metric = args.metric;
    let ranking = if args.target.is_some() || args.target_file.is_some() {
        let Some(m) = args.modules else {
            return Err(Failure::usage(
                "--target/--target-file needs --modules M (the length of the boom to fit)",
            ));
        };
        let (target, source) = read_target(args.target_file.as_ref(), args.target.as_ref())?;
        Some(Ranking {
            target,
            label: match source {
                super::ik::TargetSource::File(p) => p.display().to_string(),
                super::ik::TargetSource::Generator(s) => s,
            },
            m,
            metric,
            samples,
            certify,
            time_limit,
        })
    } else {
        if args.modules.is_some() {
            return Err(Failure::usage(
                "--modules is for ranking βs against a target: give --target or --target-file too",
            ));
        }
        None
    };
    let figs = figures(&args);
    if args.json && figs.iter().any(|(_, _, p)| super::output::is_stdout(p)) {
        return Err(Failure::usage(
            "a figure to stdout (-) and --json both write to stdout; give the figure a file name",
        ));
    }
    let files: Vec<(&str, &std::path::Path)> =
        figs.iter().map(|(f, _, p)| (*f, p.as_path())).collect();
    let outputs = super::output::open_all(&files)?;
    let spaces: Vec<Space> = ns.iter().map(|&n| space(n)).collect();
    let fits = match &ranking {
        Some(r) => Some(rank(&spaces, r)?),
        None => None,
    };
    if !outputs.is_empty() {
        let fig = figure(&spaces, fits.as_deref(), ranking.as_ref());
        for (out, (_, format, _)) in outputs.into_iter().zip(&figs) {
            let bytes = fig.encode(*format).map_err(|e| {
                Failure::Runtime(anyhow::anyhow!("cannot draw {}: {e}", out.flag()))
            })?;
            out.write(|w| w.write_all(&bytes))?;
        }
    }
    if args.json {
        crate::cli::print_json_text(&json(&spaces, fits.as_deref(), ranking.as_ref(), edge_mm));
    } else if !figs.iter().any(|(_, _, p)| super::output::is_stdout(p)) {
        text(&spaces, fits.as_deref(), ranking.as_ref(), edge_mm);
    }
    Ok(())
}

/// Beam (k = 64) at every candidate β of every n, ranked by RMS; the best `certify` then get
/// the exact solver with the time limit.
fn rank(spaces: &[Space], r: &Ranking) -> Result<Vec<Fit>, Failure> {
    let mut fits = Vec::new();
    for sp in spaces {
        for beta in candidate_betas(sp, r.samples) {
            let design =
                ModuleDesign::new(sp.n, beta).map_err(|e| Failure::usage(e.to_string()))?;
            let designs = vec![design; r.m];
            let Ok(catalogue) = Catalogue::from_designs(&designs, true) else {
                continue;
            };
            let problem = Problem::new(catalogue, r.target.clone(), r.metric);
            if problem.check_fittable().is_err() {
                continue;
            }
            let solution = ik::solve(&problem, Algorithm::Beam { width: 64 }, &Control::new())
                .map_err(|e| Failure::usage(e.to_string()))?;
            let families = sp
                .bands
                .iter()
                .filter(|(b, _)| b.family.bends() && b.contains(beta))
                .map(|(b, _)| b.family.name())
                .collect();
            fits.push(Fit {
                n: sp.n,
                beta_deg: beta,
                families,
                coverage: ik::diagnose::problem_coverage(&problem, &solution.tips).fraction(),
                warnings: warning_kinds(&problem, &designs, &solution),
                solution,
                certified: false,
            });
        }
    }
    if fits.is_empty() {
        let all: Vec<String> = spaces.iter().map(|s| format!("n = {}", s.n)).collect();
        return Err(Failure::usage(format!(
            "no β with a feasible bending state can fit the target for {}: no pop-out band, or the target is shorter than one module (see the bands without --target)",
            all.join(", ")
        )));
    }
    fits.sort_by(|a, b| a.solution.rms.total_cmp(&b.solution.rms));
    for fit in fits.iter_mut().take(r.certify) {
        let design =
            ModuleDesign::new(fit.n, fit.beta_deg).map_err(|e| Failure::usage(e.to_string()))?;
        let designs = vec![design; r.m];
        let catalogue =
            Catalogue::from_designs(&designs, true).map_err(|e| Failure::usage(e.to_string()))?;
        let problem = Problem::new(catalogue, r.target.clone(), r.metric);
        let mut control = Control::new();
        control.deadline = Some(Instant::now() + r.time_limit);
        let s = ik::solve(&problem, Algorithm::Exact, &control)
            .map_err(|e| Failure::usage(e.to_string()))?;
        fit.coverage = ik::diagnose::problem_coverage(&problem, &s.tips).fraction();
        fit.warnings = warning_kinds(&problem, &designs, &s);
        fit.solution = s;
        fit.certified = true;
    }
    fits.sort_by(|a, b| a.solution.rms.total_cmp(&b.solution.rms));
    Ok(fits)
}

fn num(x: f64) -> String {
    crate::num::json(x).to_string()
}

fn opt_num(x: Option<f64>) -> String {
    x.map_or_else(|| "null".into(), num)
}

fn json(
    spaces: &[Space],
    fits: Option<&[Fit]>,
    r: Option<&Ranking>,
    edge_mm: Option<f64>,
) -> String {
    let designs: Vec<String> = spaces
        .iter()
        .map(|sp| {
            let bands: Vec<String> = sp
                .bands
                .iter()
                .map(|(b, samples)| {
                    let s: Vec<String> = samples
                        .iter()
                        .map(|s| {
                            ordered_object(&[
                                ("beta_deg", num(s.beta_deg)),
                                ("d", num(s.d)),
                                ("d_mm", opt_num(edge_mm.map(|e| s.d * e))),
                                ("gamma_deg", num(s.gamma_deg)),
                                ("max_strain", num(s.strain)),
                            ])
                        })
                        .collect();
                    ordered_object(&[
                        ("family", Value::from(b.family.name()).to_string()),
                        ("bends", Value::from(b.family.bends()).to_string()),
                        ("lo_deg", num(b.lo_deg)),
                        ("hi_deg", num(b.hi_deg)),
                        ("samples", format!("[{}]", s.join(","))),
                    ])
                })
                .collect();
            ordered_object(&[
                ("n", sp.n.to_string()),
                ("beta_in_deg", opt_num(sp.beta_in)),
                ("beta_out_deg", opt_num(sp.beta_out)),
                ("flat_foldable_beta_deg", num(sp.flat_foldable)),
                ("bands", format!("[{}]", bands.join(","))),
            ])
        })
        .collect();
    let fits = fits.map_or_else(
        || "null".to_string(),
        |fits| {
            let list: Vec<String> = fits
                .iter()
                .map(|f| {
                    let states: Vec<Value> = f
                        .solution
                        .names
                        .iter()
                        .map(|n| Value::from(n.as_str()))
                        .collect();
                    ordered_object(&[
                        ("n", f.n.to_string()),
                        ("beta_deg", num(f.beta_deg)),
                        ("families", Value::from(f.families.clone()).to_string()),
                        ("rms", num(f.solution.rms)),
                        ("rms_mm", opt_num(edge_mm.map(|e| f.solution.rms * e))),
                        ("coverage", num(f.coverage)),
                        (
                            "solver",
                            Value::from(if f.certified { "exact" } else { "beam" }).to_string(),
                        ),
                        ("optimal", Value::from(f.solution.optimal).to_string()),
                        ("gap", opt_num(f.solution.gap)),
                        ("warnings", Value::from(f.warnings.clone()).to_string()),
                        ("states", Value::from(states).to_string()),
                    ])
                })
                .collect();
            format!("[{}]", list.join(","))
        },
    );
    ordered_object(&[
        ("edge_mm", opt_num(edge_mm)),
        ("designs", format!("[{}]", designs.join(","))),
        (
            "target",
            r.map_or("null".into(), |r| Value::from(r.label.as_str()).to_string()),
        ),
        ("modules", r.map_or("null".into(), |r| r.m.to_string())),
        (
            "metric",
            r.map_or("null".into(), |r| Value::from(r.metric.name()).to_string()),
        ),
        ("fits", fits),
    ])
}

fn length(v: f64, edge_mm: Option<f64>) -> String {
    match edge_mm {
        Some(e) => format!("{v:.4} l = {:.2} mm", v * e),
        None => format!("{v:.4} l"),
    }
}

fn text(spaces: &[Space], fits: Option<&[Fit]>, r: Option<&Ranking>, edge_mm: Option<f64>) {
    let opt = |x: Option<f64>| x.map_or_else(|| "—".to_string(), |v| format!("{v:.4}°"));
    for sp in spaces {
        crate::out!(
            "n = {}: β_in = {}, β_out = {}, flat-foldable β = {:.4}° (deployed is feasible at every β)",
            sp.n,
            opt(sp.beta_in),
            opt(sp.beta_out),
            sp.flat_foldable
        );
        crate::out!(
            "  {:<12} {:>21}   {:<40} {}",
            "family",
            "feasible for β in",
            "height d (low end, middle, high end ≤ 85°)",
            "tilt γ"
        );
        if sp.bands.is_empty() {
            crate::out!("  no family but deployed is feasible anywhere in (0°, 90°)");
        }
        for (b, samples) in &sp.bands {
            let ds: Vec<String> = samples.iter().map(|s| format!("{:.4}", s.d)).collect();
            let gs: Vec<String> = samples
                .iter()
                .map(|s| format!("{:.2}°", s.gamma_deg))
                .collect();
            let unit = match edge_mm {
                Some(e) => format!(
                    " l ({} mm)",
                    samples
                        .iter()
                        .map(|s| format!("{:.1}", s.d * e))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                None => " l".to_string(),
            };
            crate::out!(
                "  {:<12} {:>9.4}° – {:>8.4}°   {:<40} {}",
                b.family.name(),
                b.lo_deg,
                b.hi_deg,
                format!("{}{unit}", ds.join(", ")),
                gs.join(", ")
            );
        }
        if !sp.bands.iter().any(|(b, _)| b.family.bends()) {
            crate::out!("  no pop-out (bending state) is feasible at any β: a boom of n = {} is a straight column", sp.n);
        }
        crate::out!();
    }
    let (Some(fits), Some(r)) = (fits, r) else {
        crate::out!(
            "feasible = crease strain ≤ {} % (docs/geometry.md); bands located to {:e}° by bisection",
            geometry::STRAIN_TOLERANCE * 100.0,
            bands::BAND_TOLERANCE_DEG
        );
        return;
    };
    crate::out!(
        "fits of m = {} modules to {} ({}), best first; beam search (k = 64), the first {} certified by the exact solver ({:.1} s each)",
        r.m,
        r.label,
        r.metric.name(),
        r.certify.min(fits.len()),
        r.time_limit.as_secs_f64()
    );
    crate::out!(
        "  {:>3} {:>10} {:<12} {:>22} {:>9}  {:<24} warnings",
        "n",
        "β",
        "pop-outs",
        "RMS",
        "coverage",
        "solver"
    );
    for f in fits {
        let status = if !f.certified {
            "beam".to_string()
        } else if f.solution.optimal {
            "exact, proven optimal".to_string()
        } else {
            format!(
                "exact, gap {:.2} % ({})",
                100.0 * f.solution.gap.unwrap_or(1.0),
                f.solution.stop.name()
            )
        };
        crate::out!(
            "  {:>3} {:>9.4}° {:<12} {:>22} {:>8.1}%  {status:<24} {}",
            f.n,
            f.beta_deg,
            f.families.join("+"),
            length(f.solution.rms, edge_mm),
            100.0 * f.coverage,
            if f.warnings.is_empty() {
                "—".to_string()
            } else {
                f.warnings.join(", ")
            }
        );
    }
}

/// Colour of a family's bars.
fn family_colour(f: Family) -> &'static str {
    match f {
        Family::Folded => colour::SKY,
        Family::Edge => colour::VERMILLION,
        Family::Vertex => colour::GREEN,
        Family::SelfPacked => colour::ORANGE,
    }
}

/// Draws one row per `(n, family)` of `rows` in `area` (rows top to bottom): the family's
/// bands as bars (at least 1.2 pt wide so that a narrow pop-out band shows), the closing angle
/// β_in/β_out as a thin black tick, the row's label left of the area.
fn band_rows(fig: &mut Figure, area: &Area, spaces: &[Space], rows: &[(u32, Family)], row_h: f64) {
    fig.begin("bands");
    for (k, (n, family)) in rows.iter().enumerate() {
        let v_mid = rows.len() as f64 - k as f64 - 0.5;
        let (_, y) = area.map(area.u.0, v_mid);
        fig.text(
            area.rect.x - 3.0,
            y + 0.5 * CAP * SIZE_TICK,
            SIZE_TICK,
            Anchor::End,
            colour::BLACK,
            &format!("n = {n} {}", family.name()),
        );
        let Some(sp) = spaces.iter().find(|s| s.n == *n) else {
            continue;
        };
        for (b, _) in sp.bands.iter().filter(|(b, _)| b.family == *family) {
            let lo = b.lo_deg.max(area.u.0);
            let hi = b.hi_deg.min(area.u.1);
            if lo > hi {
                continue;
            }
            let (x0, _) = area.map(lo, v_mid);
            let (x1, _) = area.map(hi, v_mid);
            let w = (x1 - x0).max(1.2);
            fig.fill_rect(
                Rect {
                    x: 0.5 * (x0 + x1) - 0.5 * w,
                    y: y - 0.4 * row_h,
                    w,
                    h: 0.8 * row_h,
                },
                family_colour(*family),
            );
        }
        if let Some(c) = family.closing_angle_deg(*n) {
            if (area.u.0..=area.u.1).contains(&c) {
                let (x, _) = area.map(c, v_mid);
                fig.line(
                    (x, y - 0.5 * row_h),
                    (x, y + 0.5 * row_h),
                    Stroke::solid(colour::BLACK, 0.5),
                );
            }
        }
    }
    fig.end();
}

/// `3–8` for a contiguous run, else `3, 4, 6`.
fn describe_ns(spaces: &[Space]) -> String {
    let ns: Vec<u32> = spaces.iter().map(|s| s.n).collect();
    match (ns.first(), ns.last()) {
        (Some(a), Some(b)) if ns.len() > 2 && (b - a) as usize + 1 == ns.len() => {
            format!("{a}–{b}")
        }
        _ => ns.iter().map(u32::to_string).collect::<Vec<_>>().join(", "),
    }
}

/// The figure: one row per (n, family) with the family's feasible bands as bars against β
/// over (0°, 90°); below it the bending families (edge, vertex) of the n that have any,
/// zoomed to their bands; with a ranking, a third panel: RMS against β of every β tried, the
/// certified ones ringed.
fn figure(spaces: &[Space], fits: Option<&[Fit]>, r: Option<&Ranking>) -> Figure {
    let title = format!(
        "Feasible β bands of Yoshimura modules, n = {} (crease strain ≤ {} %; deployed: every β)",
        describe_ns(spaces),
        geometry::STRAIN_TOLERANCE * 100.0
    );
    let margin = 4.0;
    let width = COLUMN_PT;
    let title_lines = wrap(&title, SIZE_TITLE, width - 2.0 * margin);
    let rows: Vec<(u32, Family)> = spaces
        .iter()
        .flat_map(|s| Family::ALL.iter().map(move |&f| (s.n, f)))
        .collect();
    let zoom_rows: Vec<(u32, Family)> = spaces
        .iter()
        .filter(|s| s.bands.iter().any(|(b, _)| b.family.bends()))
        .flat_map(|s| [(s.n, Family::Edge), (s.n, Family::Vertex)])
        .collect();
    let label_w = rows
        .iter()
        .map(|(n, f)| text_width(&format!("n = {n} {}", f.name()), SIZE_TICK))
        .fold(0.0, f64::max);
    let row_h = 7.5;
    let left = margin + label_w + 6.0;
    let area_w = width - left - margin - 6.0;
    let title_h = title_lines.len() as f64 * LEADING * SIZE_TITLE + 4.0;
    let bands_h = row_h * rows.len() as f64;
    let zoom_h = row_h * zoom_rows.len() as f64;
    let head_h = LEADING * SIZE_LABEL + 2.0;
    let mut legend = Legend::new();
    for f in Family::ALL {
        legend.add(Swatch::Line(Stroke::solid(family_colour(f), 3.0)), f.name());
    }
    legend.add(
        Swatch::Line(Stroke::solid(colour::BLACK, 0.5)),
        "β_in (edge), β_out (vertex)",
    );
    let legend_h = legend.height(width - 2.0 * margin);
    let rank_h = 100.0;
    let mut height = margin + title_h + bands_h + Area::below() + 4.0 + legend_h + margin;
    if !zoom_rows.is_empty() {
        height += 8.0 + head_h + zoom_h + Area::below();
    }
    let rank_head = r.map(|r| {
        wrap(
            &format!(
                "RMS of m = {} modules fitted to {} ({}); ringed: certified by exact",
                r.m,
                r.label,
                r.metric.name()
            ),
            SIZE_LABEL,
            width - 2.0 * margin,
        )
    });
    if let (Some(_), Some(lines)) = (fits, &rank_head) {
        height += 8.0 + lines.len() as f64 * LEADING * SIZE_LABEL + 2.0 + rank_h + Area::below();
    }
    let mut fig = Figure::new(width, height);
    paragraph(
        &mut fig,
        margin,
        margin,
        SIZE_TITLE,
        colour::BLACK,
        &title_lines,
    );
    let mut top = margin + title_h;
    let area = Area {
        rect: Rect {
            x: left,
            y: top,
            w: area_w,
            h: bands_h,
        },
        u: (0.0, 90.0),
        v: (0.0, rows.len() as f64),
    };
    let no_ticks = Ticks {
        step: 1.0,
        values: Vec::new(),
    };
    area.axes(
        &mut fig,
        &Ticks::within(0.0, 90.0, 15.0),
        &no_ticks,
        Some("fold angle β (°)"),
        None,
        true,
    );
    band_rows(&mut fig, &area, spaces, &rows, row_h);
    top += bands_h + Area::below() + 4.0;
    legend.draw(&mut fig, margin, top, width - 2.0 * margin);
    top += legend_h;
    if !zoom_rows.is_empty() {
        top += 8.0;
        let (lo, hi) = spaces
            .iter()
            .flat_map(|s| s.bands.iter())
            .filter(|(b, _)| b.family.bends())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (b, _)| {
                (lo.min(b.lo_deg), hi.max(b.hi_deg))
            });
        let ut = Ticks::covering(lo - 0.3, hi + 0.3, 5);
        fig.text(
            margin,
            top + ASCENT * SIZE_LABEL,
            SIZE_LABEL,
            Anchor::Start,
            colour::BLACK,
            "the pop-out (bending) bands, zoomed",
        );
        top += head_h;
        let zoom = Area {
            rect: Rect {
                x: left,
                y: top,
                w: area_w,
                h: zoom_h,
            },
            u: ut.range(),
            v: (0.0, zoom_rows.len() as f64),
        };
        zoom.axes(
            &mut fig,
            &ut,
            &no_ticks,
            Some("fold angle β (°)"),
            None,
            true,
        );
        band_rows(&mut fig, &zoom, spaces, &zoom_rows, row_h);
        top += zoom_h + Area::below();
    }
    if let (Some(fits), Some(_)) = (fits, r) {
        top += 8.0;
        let lo = fits
            .iter()
            .map(|f| f.beta_deg)
            .fold(f64::INFINITY, f64::min);
        let hi = fits
            .iter()
            .map(|f| f.beta_deg)
            .fold(f64::NEG_INFINITY, f64::max);
        let ut = Ticks::covering(lo - 0.1, hi + 0.1, 5);
        let rmax = fits.iter().map(|f| f.solution.rms).fold(0.0, f64::max);
        let vt = Ticks::covering(0.0, rmax.max(1e-6), 4);
        let left2 = margin + Area::left_of(&vt.labels());
        let head_lines = rank_head.clone().unwrap_or_default();
        top += paragraph(
            &mut fig,
            margin,
            top,
            SIZE_LABEL,
            colour::BLACK,
            &head_lines,
        ) + 2.0;
        let area2 = Area {
            rect: Rect {
                x: left2,
                y: top,
                w: width - left2 - margin - 6.0,
                h: rank_h,
            },
            u: ut.range(),
            v: vt.range(),
        };
        area2.axes(
            &mut fig,
            &ut,
            &vt,
            Some("fold angle β (°)"),
            Some("RMS (l)"),
            true,
        );
        fig.begin("ranking");
        for f in fits {
            let c = if f.families.contains(&"vertex") && !f.families.contains(&"edge") {
                family_colour(Family::Vertex)
            } else {
                family_colour(Family::Edge)
            };
            let p = area2.map(f.beta_deg, f.solution.rms);
            fig.dot(p, 1.6, c);
            if f.certified {
                fig.ring(p, 3.0, Stroke::solid(colour::BLACK, 0.7));
            }
        }
        fig.end();
    }
    fig
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn n_accepts_one_a_list_and_a_range() {
        assert_eq!(parse_ns("4").ok(), Some(Ns(vec![4])));
        assert_eq!(parse_ns("6,3,4").ok(), Some(Ns(vec![3, 4, 6])));
        assert_eq!(parse_ns("3..5").ok(), Some(Ns(vec![3, 4, 5])));
        for bad in ["", "2", "5..3", "3..65", "x", "3..", "..4"] {
            assert!(parse_ns(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn candidates_lie_in_bending_bands() {
        let sp = space(4);
        let betas = candidate_betas(&sp, 5);
        assert!(!betas.is_empty());
        for b in betas {
            assert!(
                sp.bands
                    .iter()
                    .any(|(band, _)| band.family.bends() && band.contains(b)),
                "{b}"
            );
            assert!(
                Family::Edge.feasible(4, b) || Family::Vertex.feasible(4, b),
                "{b}"
            );
        }
    }
}
