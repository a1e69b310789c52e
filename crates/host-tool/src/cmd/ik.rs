//! `host-tool ik`: fit a stacked Yoshimura boom to a 3D curve (paper §4.2).
//!
//! Arguments are validated into a [`Config`] once; then the problem is built from the geometry
//! catalogue, solved with a Ctrl-C handler and a progress line on stderr, and printed as a
//! table or as JSON, optionally with an SVG drawing.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use geometry::ModuleDesign;
use planner::ik::{self, dp::DpParams, Algorithm, Catalogue, Control, Metric, Problem, Target};
use serde_json::Value;

use super::states::{designs_from, ordered_object, parse_betas, parse_n, Betas};
use crate::failure::Failure;

mod figure;

fn target_long_help() -> String {
    format!(
        "Built-in target curve: NAME or NAME:key=value,key=value,… (units of l, the valley fold \
         length; omitted parameters take their defaults). The boom starts at the origin growing \
         along +z, so the curves start there too.\n\n{}\nExample: --target helix:radius=1,pitch=4,turns=1",
        ik::target::generators_help()
    )
}

/// Arguments of `host-tool ik`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Number of polygon sides n of every module (an integer in [3, 64]).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::usage(parse_n))]
    pub n: u32,
    /// Fold angle(s) β in degrees: one for all modules or one per module, comma-separated,
    /// bottom module first (the crane trunk is `35,31.72`).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::usage(parse_betas))]
    pub beta: Betas,
    /// Number of modules m (an integer in [1, 10000]); each module here is one layer (one
    /// Yoshimura unit, n-gon to n-gon).
    #[arg(long, allow_hyphen_values = true,
          value_parser = crate::num::count_in("--modules", 1, MAX_MODULES))]
    pub modules: usize,
    /// Target polyline as CSV: one `x,y,z` row per point in units of l, optional header row,
    /// blank lines and `#` comments ignored; `-` reads stdin.
    #[arg(long, value_name = "FILE")]
    pub target_file: Option<PathBuf>,
    /// Built-in target curve: helix, sine or arc with named parameters, e.g.
    /// `helix:radius=1,pitch=4,turns=1` (see --help for every parameter).
    #[arg(long, value_name = "SPEC", long_help = target_long_help(), allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_target))]
    pub target: Option<TargetSpec>,
    /// Solver: exact (proven optimum), exhaustive (every sequence), greedy, beam, window, dp.
    #[arg(long, default_value = "exact", value_parser = crate::arg::usage(parse_algo))]
    pub algo: Algo,
    /// Beam width k for `--algo beam` (≥ 1).
    #[arg(long, default_value = "64", allow_hyphen_values = true,
          value_parser = crate::num::count_in("--beam-width", 1, 1_000_000))]
    pub beam_width: usize,
    /// Window width w for `--algo window` (2–4 as in the paper; 1–6 accepted).
    #[arg(long, default_value = "3", allow_hyphen_values = true,
          value_parser = crate::num::count_in("--window-width", 1, 6))]
    pub window_width: usize,
    /// Frame-merging tolerances of `--algo dp`: `POSITION,ANGLE` in units of l and degrees
    /// (`0,0` merges only equal frames: exact but slow).
    #[arg(long, default_value = "0.1,5", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_dp_tolerance))]
    pub dp_tolerance: (f64, f64),
    /// Most frames `--algo dp` keeps per module layer.
    #[arg(long, default_value = "20000", allow_hyphen_values = true,
          value_parser = crate::num::count_in("--dp-max-states", 1, 100_000_000))]
    pub dp_max_states: usize,
    /// Objective: eq36 (RMS distance from each tip to its nearest point on the target) or
    /// ordered (tip i matched to the point at arc length i·L/m, covering the whole curve).
    #[arg(long, default_value = "eq36", value_parser = crate::arg::usage(parse_metric))]
    pub metric: Metric,
    /// Use the paper's full catalogue of 2(n+1) states, including those the geometry marks
    /// infeasible (crease strain above 1 %); every output then marks each infeasible state used
    /// and its strain. Default: only the feasible states (see `host-tool states`).
    #[arg(long)]
    pub all_states: bool,
    /// Only the feasible states: the default, accepted for compatibility.
    #[arg(long)]
    pub feasible_only: bool,
    /// Stop after this many seconds (> 0) and report the best boom so far; `exact` also
    /// reports its certified lower bound and gap.
    #[arg(long, value_name = "SECONDS", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_time_limit))]
    pub time_limit: Option<Duration>,
    /// `--algo exact` only: stop as soon as the certified relative gap
    /// (RMS − lower bound) / RMS is at most FRACTION (in [0, 1); 0 = prove the optimum).
    #[arg(long, value_name = "FRACTION", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_gap))]
    pub gap: Option<f64>,
    /// Print JSON: `{"states", "rms", "optimal", "lower_bound_rms", "gap", "stop",
    /// "evaluated", "elapsed_ms", "tips", "all_states", "infeasible", "coverage", "warnings",
    /// "edge_mm", "rms_mm", "tips_mm"}` (the last three `null` without --edge-mm).
    #[arg(skip)]
    pub json: bool,
    /// Write the figure of the fit (target and boom in three orthographic views, one column
    /// wide) as SVG to this file.
    #[arg(long, value_name = "OUT")]
    pub svg: Option<PathBuf>,
    /// The same figure as PNG (600 dpi).
    #[arg(long, value_name = "OUT")]
    pub png: Option<PathBuf>,
    /// The same figure as PDF (vector, font embedded).
    #[arg(long, value_name = "OUT")]
    pub pdf: Option<PathBuf>,
    /// Print lengths in millimetres too (RMS, tips), for a valley fold (polygon edge) of this
    /// length; the target and the generators' parameters stay in units of l.
    #[arg(long, value_name = "MM", allow_hyphen_values = true,
          value_parser = crate::arg::usage(super::states::parse_edge_mm))]
    pub edge_mm: Option<f64>,
    /// Write a 3D model of the fitted boom as binary glTF 2.0 (l = 75 mm; strain in red).
    #[arg(long, value_name = "FILE")]
    pub gltf: Option<PathBuf>,
}

/// Where the target came from.
#[derive(Debug)]
pub(crate) enum TargetSource {
    File(PathBuf),
    Generator(String),
}

/// A validated `ik` request.
#[derive(Debug)]
pub struct Config {
    designs: Vec<ModuleDesign>,
    target: Target,
    source: TargetSource,
    metric: Metric,
    algorithm: Algorithm,
    all_states: bool,
    time_limit: Option<Duration>,
    gap: f64,
    json: bool,
    /// (flag, format, path) of every figure asked for.
    figures: Vec<(&'static str, crate::figure::Format, PathBuf)>,
    gltf: Option<PathBuf>,
    edge_mm: Option<f64>,
}

/// Largest target file read (a million `x,y,z` rows fit easily; `/dev/zero` does not).
const MAX_TARGET_FILE_BYTES: u64 = 64 << 20;

/// Reads a text file of at most `limit` bytes.
fn read_bounded(path: &std::path::Path, limit: u64) -> std::io::Result<String> {
    read_bounded_from(std::fs::File::open(path)?, limit)
}

/// Reads at most `limit` bytes of text from `r`.
fn read_bounded_from(r: impl std::io::Read, limit: u64) -> std::io::Result<String> {
    use std::io::Read;
    let mut text = String::new();
    r.take(limit + 1).read_to_string(&mut text)?;
    if text.len() as u64 > limit {
        return Err(std::io::Error::other(format!(
            "larger than {} MiB; a target curve needs far fewer points",
            limit >> 20
        )));
    }
    Ok(text)
}

/// Longest `--time-limit` accepted, in seconds (about 11.6 days).
const MAX_TIME_LIMIT_S: f64 = 1e6;

pub(crate) fn parse_time_limit(text: &str) -> Result<Duration, Failure> {
    let v: f64 = text.trim().parse().map_err(|_| {
        Failure::usage(format!(
            "--time-limit must be a number of seconds in (0, {MAX_TIME_LIMIT_S}], got '{text}'"
        ))
    })?;
    if !(v.is_finite() && v > 0.0 && v <= MAX_TIME_LIMIT_S) {
        return Err(Failure::usage(format!(
            "--time-limit must be a number of seconds in (0, {MAX_TIME_LIMIT_S}], got '{text}'"
        )));
    }
    Ok(Duration::from_secs_f64(v))
}

fn parse_gap(text: &str) -> Result<f64, Failure> {
    let bad = || {
        Failure::usage(format!(
            "--gap must be a fraction in [0, 1) (e.g. 0.01 for 1 %), got '{text}'"
        ))
    };
    let v: f64 = text.trim().parse().map_err(|_| bad())?;
    if !(v.is_finite() && (0.0..1.0).contains(&v)) {
        return Err(bad());
    }
    Ok(v)
}

/// `--algo`: a solver by name (its parameters are options of their own).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Algo {
    /// Branch and bound, proven optimal.
    Exact,
    /// Every sequence.
    Exhaustive,
    /// Greedy.
    Greedy,
    /// Beam search (`--beam-width`).
    Beam,
    /// Sliding window (`--window-width`).
    Window,
    /// Dynamic programming over merged frames (`--dp-tolerance`, `--dp-max-states`).
    Dp,
}

/// Parses `--algo`; the refusal lists the solvers.
fn parse_algo(text: &str) -> Result<Algo, Failure> {
    Ok(match text.trim() {
        "exact" => Algo::Exact,
        "exhaustive" => Algo::Exhaustive,
        "greedy" => Algo::Greedy,
        "beam" => Algo::Beam,
        "window" => Algo::Window,
        "dp" => Algo::Dp,
        other => {
            return Err(Failure::usage(format!(
                "unknown --algo '{other}'; valid algorithms are {}",
                Algorithm::NAMES.join(", ")
            )))
        }
    })
}

/// Parses `--dp-tolerance`: `POSITION,ANGLE`, both finite and ≥ 0.
fn parse_dp_tolerance(text: &str) -> Result<(f64, f64), Failure> {
    let nums: Vec<Option<f64>> = text
        .split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
        })
        .collect();
    match nums[..] {
        [Some(pos), Some(ang)] => Ok((pos, ang)),
        _ => Err(Failure::usage(format!(
            "--dp-tolerance must be POSITION,ANGLE (units of l, degrees; both ≥ 0), got '{text}'"
        ))),
    }
}

/// Reads the target from `--target-file` or `--target` (exactly one must be given).
/// `--target SPEC`: a built-in curve, generated, with the spec it came from.
#[derive(Debug, Clone)]
pub struct TargetSpec {
    /// The spec as given.
    pub spec: String,
    /// Its points.
    pub target: Target,
}

/// Parses `--target SPEC` (`ik` and `design`).
pub(crate) fn parse_target(spec: &str) -> Result<TargetSpec, Failure> {
    let target =
        ik::target::generate(spec).map_err(|e| Failure::usage(format!("--target: {e}")))?;
    Ok(TargetSpec {
        spec: spec.to_string(),
        target,
    })
}

pub(crate) fn read_target(
    target_file: Option<&PathBuf>,
    target: Option<&TargetSpec>,
) -> Result<(Target, TargetSource), Failure> {
    Ok(match (target_file, target) {
        (Some(_), Some(_)) => {
            return Err(Failure::usage(
                "give either --target-file or --target, not both",
            ))
        }
        (None, None) => {
            return Err(Failure::usage(format!(
                "give a target: --target-file FILE (CSV rows x,y,z) or --target SPEC, one of:\n{}",
                ik::target::generators_help()
            )))
        }
        (Some(path), None) => {
            let text = if super::output::is_stdout(path) {
                read_bounded_from(std::io::stdin().lock(), MAX_TARGET_FILE_BYTES)
            } else {
                read_bounded(path, MAX_TARGET_FILE_BYTES)
            }
            .map_err(|e| {
                Failure::usage(format!("cannot read --target-file {}: {e}", path.display()))
            })?;
            let t = ik::target::parse_csv(&text)
                .map_err(|e| Failure::usage(format!("--target-file {}: {e}", path.display())))?;
            (t, TargetSource::File(path.clone()))
        }
        (None, Some(t)) => (t.target.clone(), TargetSource::Generator(t.spec.clone())),
    })
}

/// Parses `--metric`.
pub(crate) fn parse_metric(text: &str) -> Result<Metric, Failure> {
    match text.trim() {
        "eq36" => Ok(Metric::Eq36),
        "ordered" => Ok(Metric::Ordered),
        other => Err(Failure::usage(format!(
            "unknown --metric '{other}'; valid metrics are eq36, ordered"
        ))),
    }
}

/// Longest boom accepted (the heuristics are linear in m; exact and exhaustive are not).
pub(crate) const MAX_MODULES: usize = 10_000;

impl Args {
    /// Parses and validates everything, reading the target file.
    pub fn validate(self) -> Result<Config, Failure> {
        let n = self.n;
        let m = self.modules;
        let designs = designs_from(n, &self.beta, m, &format!("--modules is {m}"))?;
        let (target, source) = read_target(self.target_file.as_ref(), self.target.as_ref())?;
        let metric = self.metric;
        let algorithm = match self.algo {
            Algo::Exact => Algorithm::Exact,
            Algo::Exhaustive => Algorithm::Exhaustive,
            Algo::Greedy => Algorithm::Greedy,
            Algo::Beam => Algorithm::Beam {
                width: self.beam_width,
            },
            Algo::Window => Algorithm::Window {
                width: self.window_width,
            },
            Algo::Dp => {
                let (pos, ang) = self.dp_tolerance;
                Algorithm::Dp(DpParams {
                    position_tolerance: pos,
                    angle_tolerance_deg: ang,
                    max_states: self.dp_max_states,
                })
            }
        };
        if self.all_states && self.feasible_only {
            return Err(Failure::usage(
                "--all-states and --feasible-only contradict each other; feasible states are the default, --all-states adds the infeasible ones",
            ));
        }
        let time_limit = self.time_limit;
        let gap = self.gap;
        if gap.is_some() && algorithm != Algorithm::Exact {
            return Err(Failure::usage(format!(
                "--gap needs --algo exact (the only solver that proves a lower bound); got --algo {}",
                algorithm.name()
            )));
        }
        Ok(Config {
            designs,
            target,
            source,
            metric,
            algorithm,
            all_states: self.all_states,
            time_limit,
            gap: gap.unwrap_or(0.0),
            json: self.json,
            figures: [
                ("--svg", crate::figure::Format::Svg, self.svg),
                ("--png", crate::figure::Format::Png, self.png),
                ("--pdf", crate::figure::Format::Pdf, self.pdf),
            ]
            .into_iter()
            .filter_map(|(flag, format, path)| Some((flag, format, path?)))
            .collect(),
            gltf: self.gltf,
            edge_mm: self.edge_mm,
        })
    }
}

/// Shows progress on stderr once a solve has run for a second: a spinner line on a terminal,
/// a plain line every few seconds otherwise.
fn spawn_progress(
    control: Control,
    done: Arc<AtomicBool>,
    algo: &'static str,
    m: usize,
    total: Option<u128>,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let start = Instant::now();
        let tty = std::io::stderr().is_terminal();
        let mut last_line = Instant::now();
        let mut bar: Option<indicatif::ProgressBar> = None;
        while !done.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(100));
            if start.elapsed() < Duration::from_secs(1) {
                continue;
            }
            let evaluated = control.evaluated.load(Ordering::Relaxed);
            let best = control.best_rms(m);
            let best_text = best.map_or_else(|| "-".to_string(), |r| format!("{r:.6}"));
            let of = total.map_or(String::new(), |t| format!(" of {t}"));
            let bound = if algo == "exact" {
                let lb = control.lower_bound_rms(m);
                let gap = best.map_or(1.0, |b| ik::relative_gap(b, lb));
                format!(", lower bound {lb:.6}, gap {:.2} %", 100.0 * gap)
            } else {
                String::new()
            };
            let msg = format!(
                "{algo}: {evaluated}{of} evaluated, best RMS {best_text}{bound}, {:.1} s (Ctrl-C returns the best so far)",
                start.elapsed().as_secs_f64()
            );
            if tty {
                let b = bar.get_or_insert_with(|| {
                    let b = indicatif::ProgressBar::new_spinner();
                    b.enable_steady_tick(Duration::from_millis(120));
                    b
                });
                b.set_message(msg);
            } else if last_line.elapsed() >= Duration::from_secs(2) || bar.is_none() {
                crate::say!("{msg}");
                last_line = Instant::now();
                bar = Some(indicatif::ProgressBar::hidden());
            }
        }
        if let Some(b) = bar {
            b.finish_and_clear();
        }
    })
}

/// Runs `host-tool ik`.
pub fn run(args: Args) -> Result<(), Failure> {
    let cfg = args.validate()?;
    let to_stdout = cfg
        .figures
        .iter()
        .any(|(_, _, p)| super::output::is_stdout(p));
    if cfg.json && to_stdout {
        return Err(Failure::usage(
            "a figure to stdout (-) and --json both write to stdout; give the figure a file name",
        ));
    }
    let gltf = super::model::open_ik_gltf(cfg.gltf.as_deref())?;
    let catalogue = Catalogue::from_designs(&cfg.designs, !cfg.all_states)
        .map_err(|e| Failure::usage(e.to_string()))?;
    let m = catalogue.len();
    let total = catalogue.sequences();
    let problem = Problem::new(catalogue, cfg.target.clone(), cfg.metric);
    problem
        .check_fittable()
        .map_err(|e| Failure::usage(e.to_string()))?;
    let figure_files: Vec<(&str, &std::path::Path)> = cfg
        .figures
        .iter()
        .map(|(f, _, p)| (*f, p.as_path()))
        .collect();
    let figure_files = super::output::open_all(&figure_files)?;
    let mut control = Control::new();
    control.deadline = cfg.time_limit.map(|t| Instant::now() + t);
    control.target_gap = cfg.gap;
    {
        let stop = control.stop.clone();
        // A second handler cannot be installed (tests calling run twice): Ctrl-C then kills.
        let _ = ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst));
    }
    let done = Arc::new(AtomicBool::new(false));
    let progress = spawn_progress(
        control.clone(),
        done.clone(),
        cfg.algorithm.name(),
        m,
        matches!(cfg.algorithm, Algorithm::Exhaustive).then_some(total),
    );
    let result = ik::solve(&problem, cfg.algorithm, &control);
    done.store(true, Ordering::Relaxed);
    let _ = progress.join();
    let solution = match result {
        Ok(s) if s.rms.is_finite() => s,
        other => {
            super::output::discard(figure_files);
            return Err(Failure::usage(match other {
                Err(e) => e.to_string(),
                Ok(s) => ik::IkError::NotFinite(s.rms).to_string(),
            }));
        }
    };
    match solution.stop {
        // Said once, by the interrupted exit (130) after the output.
        ik::Stop::Interrupted => {}
        ik::Stop::TimeLimit => {
            crate::say!(
                "time limit reached: showing the best boom found so far (not proven optimal)"
            )
        }
        ik::Stop::Gap | ik::Stop::Finished => {}
    }
    // The `cannot-bend` warning's beam search over the full catalogue gets at most 2 s (m =
    // 10 000 would take longer); stopped, the warning just leaves its RMS out.
    let assess_control = Control {
        stop: control.stop.clone(),
        deadline: Some(Instant::now() + Duration::from_secs(2)),
        ..Control::new()
    };
    let report = Report {
        coverage: ik::diagnose::problem_coverage(&problem, &solution.tips),
        warnings: ik::diagnose::assess(
            &problem,
            &cfg.designs,
            cfg.all_states,
            &solution.tips,
            solution.rms,
            &assess_control,
        ),
    };
    if to_stdout {
        for w in &report.warnings {
            crate::say!("warning: {}", w.message);
        }
    }
    super::model::write_ik_gltf(gltf, &cfg.designs, &solution.names)?;
    if !figure_files.is_empty() {
        let fig = figure::render(
            &problem,
            &cfg.designs,
            &solution,
            &figure_header(&cfg, &solution, &report),
        );
        for (out, (_, format, _)) in figure_files.into_iter().zip(&cfg.figures) {
            let bytes = fig.encode(*format).map_err(|e| {
                Failure::Runtime(anyhow::anyhow!("cannot draw {}: {e}", out.flag()))
            })?;
            out.write(|w| w.write_all(&bytes))?;
        }
    }
    if cfg.json {
        crate::cli::print_json_text(&solution_json(&cfg, &problem, &solution, &report));
    } else if !to_stdout {
        print_table(&cfg, &problem, &solution, &report);
    }
    if solution.stop == ik::Stop::Interrupted {
        return Err(Failure::Interrupted(
            "the solve was stopped by Ctrl-C; the best boom found so far is shown".into(),
        ));
    }
    Ok(())
}

/// The modules of the solution whose state the geometry marks infeasible:
/// (1-based module, state name, strain).
fn infeasible_used<'a>(problem: &'a Problem, s: &'a ik::Solution) -> Vec<(usize, &'a str, f64)> {
    problem
        .catalogue
        .infeasible(&s.states)
        .map(|(i, c)| (i + 1, c.name.as_str(), c.strain))
        .collect()
}

/// One line naming every infeasible state used, or an empty string.
fn infeasible_note(problem: &Problem, s: &ik::Solution) -> String {
    let used = infeasible_used(problem, s);
    if used.is_empty() {
        return String::new();
    }
    let list: Vec<String> = used
        .iter()
        .map(|(i, name, strain)| format!("{i} {name} (strain {strain:.3})"))
        .collect();
    format!(
        "{} of {} modules use states the geometry marks infeasible (crease strain above {} %; --all-states): module {}",
        used.len(),
        s.states.len(),
        geometry::STRAIN_TOLERANCE * 100.0,
        list.join(", ")
    )
}

/// What the fit covers and what it cannot be trusted to show ([`ik::diagnose`]).
struct Report {
    coverage: ik::diagnose::Coverage,
    warnings: Vec<ik::diagnose::Warning>,
}

fn warnings_json(report: &Report) -> String {
    let list: Vec<String> = report
        .warnings
        .iter()
        .map(|w| {
            ordered_object(&[
                ("kind", Value::from(w.kind).to_string()),
                ("message", Value::from(w.message.as_str()).to_string()),
                ("value", crate::num::json(w.value).to_string()),
                ("limit", crate::num::json(w.limit).to_string()),
            ])
        })
        .collect();
    format!("[{}]", list.join(","))
}

fn opt_value(x: Option<f64>) -> String {
    x.map_or_else(|| "null".to_string(), |v| crate::num::json(v).to_string())
}

fn solution_json(cfg: &Config, problem: &Problem, s: &ik::Solution, report: &Report) -> String {
    let states: Vec<Value> = s.names.iter().map(|n| Value::from(n.as_str())).collect();
    let infeasible: Vec<String> = infeasible_used(problem, s)
        .into_iter()
        .map(|(i, name, strain)| {
            ordered_object(&[
                ("module", i.to_string()),
                ("state", Value::from(name).to_string()),
                ("strain", crate::num::json(strain).to_string()),
            ])
        })
        .collect();
    let tips: Vec<Value> = s
        .tips
        .iter()
        .map(|p| {
            Value::from(vec![
                crate::num::json(p.x),
                crate::num::json(p.y),
                crate::num::json(p.z),
            ])
        })
        .collect();
    ordered_object(&[
        ("states", Value::from(states).to_string()),
        ("rms", crate::num::json(s.rms).to_string()),
        ("optimal", Value::from(s.optimal).to_string()),
        ("lower_bound_rms", opt_value(s.lower_bound_rms)),
        ("gap", opt_value(s.gap)),
        ("stop", Value::from(s.stop.name()).to_string()),
        ("evaluated", Value::from(s.evaluated).to_string()),
        (
            "elapsed_ms",
            crate::num::json(s.elapsed.as_secs_f64() * 1e3).to_string(),
        ),
        ("tips", Value::from(tips).to_string()),
        ("all_states", Value::from(cfg.all_states).to_string()),
        ("infeasible", format!("[{}]", infeasible.join(","))),
        (
            "coverage",
            crate::num::json(report.coverage.fraction()).to_string(),
        ),
        ("warnings", warnings_json(report)),
        ("edge_mm", opt_value(cfg.edge_mm)),
        ("rms_mm", opt_value(cfg.edge_mm.map(|e| s.rms * e))),
        (
            "tips_mm",
            cfg.edge_mm.map_or("null".into(), |e| {
                let t: Vec<Value> = s
                    .tips
                    .iter()
                    .map(|p| {
                        Value::from(vec![
                            crate::num::json(p.x * e),
                            crate::num::json(p.y * e),
                            crate::num::json(p.z * e),
                        ])
                    })
                    .collect();
                Value::from(t).to_string()
            }),
        ),
    ])
}

fn describe_boom(cfg: &Config) -> String {
    let n = cfg.designs[0].n();
    let first = cfg.designs[0].beta_deg();
    if cfg.designs.iter().all(|d| d.beta_deg() == first) {
        format!("m = {} modules, n = {n}, β = {first}°", cfg.designs.len())
    } else {
        let betas: Vec<String> = cfg
            .designs
            .iter()
            .map(|d| format!("{}", d.beta_deg()))
            .collect();
        format!(
            "m = {} modules, n = {n}, β = {}° (bottom first)",
            cfg.designs.len(),
            betas.join(",")
        )
    }
}

fn describe_target(cfg: &Config) -> String {
    match &cfg.source {
        TargetSource::File(p) => p.display().to_string(),
        TargetSource::Generator(s) => s.clone(),
    }
}

/// The figure's short form of a warning.
fn short_warning(w: &ik::diagnose::Warning) -> String {
    match w.kind {
        "cannot-bend" => "no feasible state bends: a straight column".to_string(),
        "curvature" => "the target bends faster than any feasible state".to_string(),
        "doubles-back" => format!("the target doubles back ({:.0}° turn)", w.value),
        "too-long" => format!(
            "the target ({:.2} l) is longer than the boom reaches ({:.2} l)",
            w.value, w.limit
        ),
        "boom-too-long" => format!(
            "the boom ({:.2} l at its shortest) is longer than the target ({:.2} l)",
            w.value, w.limit
        ),
        "coverage" => format!("the fit covers {:.0} % of the target", 100.0 * w.value),
        _ => w.message.clone(),
    }
}

fn figure_header(cfg: &Config, s: &ik::Solution, report: &Report) -> figure::Header {
    figure::Header {
        algorithm: cfg.algorithm.name().to_string(),
        target: describe_target(cfg),
        metric: cfg.metric.name().to_string(),
        rms: s.rms,
        status: if s.optimal {
            "proven optimal".to_string()
        } else if let Some(gap) = s.gap {
            format!("≤ {:.2} % above the optimum", 100.0 * gap)
        } else {
            String::new()
        },
        warnings: report.warnings.iter().map(short_warning).collect(),
    }
}

fn print_table(cfg: &Config, problem: &Problem, s: &ik::Solution, report: &Report) {
    let status = if s.optimal {
        "proven optimal".to_string()
    } else {
        let why = match s.stop {
            ik::Stop::Interrupted => "interrupted, best so far",
            ik::Stop::TimeLimit => "time limit reached, best so far",
            ik::Stop::Gap => "gap reached",
            ik::Stop::Finished => "no optimality proof",
        };
        format!("{why}; not proven optimal")
    };
    crate::out!("algorithm  {} ({status})", cfg.algorithm.name());
    crate::out!("boom       {}", describe_boom(cfg));
    crate::out!(
        "target     {} ({}, length {:.4} l)",
        describe_target(cfg),
        crate::num::plural(cfg.target.points().len(), "point", "points"),
        cfg.target.length()
    );
    crate::out!(
        "metric     {}, {}",
        cfg.metric.name(),
        if cfg.all_states {
            "all catalogue states (--all-states)"
        } else {
            "feasible states only"
        }
    );
    match cfg.edge_mm {
        Some(e) => crate::out!(
            "RMS        {:.9} l = {:.4} mm (edge l = {e} mm)",
            s.rms,
            s.rms * e
        ),
        None => crate::out!("RMS        {:.9} l", s.rms),
    }
    if let (Some(lb), Some(gap)) = (s.lower_bound_rms, s.gap) {
        crate::out!(
            "bound      RMS ≥ {lb:.9} l (certified; gap {:.4} %)",
            100.0 * gap
        );
    }
    crate::out!("evaluated  {}", s.evaluated);
    crate::out!("elapsed    {:.3} ms", s.elapsed.as_secs_f64() * 1e3);
    crate::out!(
        "coverage   {:.1} % of the target's {:.4} l lies within one module step ({:.4} l) of a tip",
        100.0 * report.coverage.fraction(),
        report.coverage.length,
        report.coverage.radius
    );
    let note = infeasible_note(problem, s);
    if !note.is_empty() {
        crate::out!("warning    {note}");
    }
    for w in &report.warnings {
        crate::out!("warning    {}", w.message);
    }
    crate::out!();
    let (scale, unit) = cfg.edge_mm.map_or((1.0, "l"), |e| (e, "mm"));
    crate::out!(
        "{:>4}  {:<10} {:>10} {:>10} {:>10} {:>10}  feasibility",
        "i",
        "state",
        format!("x ({unit})"),
        format!("y ({unit})"),
        format!("z ({unit})"),
        format!("error ({unit})")
    );
    for (i, (name, p)) in s.names.iter().zip(&s.tips).enumerate() {
        let err = problem.objective.cost(i, p).sqrt();
        let c = &problem.catalogue.candidates(i)[s.states[i]];
        let mark = if c.feasible {
            "feasible".to_string()
        } else {
            format!("INFEASIBLE (strain {:.3})", c.strain)
        };
        let w = |v: f64| crate::num::fixed_w(v, 5, 10);
        crate::out!(
            "{:>4}  {:<10} {} {} {} {}  {mark}",
            i + 1,
            name,
            w(p.x * scale),
            w(p.y * scale),
            w(p.z * scale),
            w(err * scale)
        );
    }
}
