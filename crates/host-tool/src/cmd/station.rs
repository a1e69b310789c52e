//! `host-tool station`: the solar station of paper §7.2 — which catalogue states of the top
//! modules point the top face at the sun through a day, the best schedule with at most K
//! refolds, the folding a person does at each refold, and what it gains over a flat top.
//! The work is in `planner::station` and `planner::sun`.

mod figure;

use std::path::PathBuf;

use geometry::orient;
use geometry::ShapeState;
use nalgebra::Vector3;
use planner::station::{self, Schedule, Station, SunDirection};
use planner::sun::{self, Sample};

use super::states::{designs_from, ordered_object, parse_betas, parse_n, Betas};

/// Most modules in a station's stack.
const MAX_MODULES: usize = 64;
use super::sun::{daylight_parts, site_text, DayArgs, SiteArgs};
use crate::failure::Failure;

/// Arguments of `host-tool station`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Number of polygon sides n of every module (an integer in [3, 64]).
    #[arg(long, default_value = "3", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_n))]
    pub n: u32,
    /// Fold angle(s) β in degrees: one for all modules or one per module, bottom first.
    /// Default: the meter-scale station's golden modules (tan β = 1/φ).
    #[arg(long, default_value = "31.72", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_betas))]
    pub beta: Betas,
    /// Number of stacked modules, [1, 64].
    #[arg(long, default_value = "4", allow_hyphen_values = true,
          value_parser = crate::num::count_in("--modules", 1, MAX_MODULES))]
    pub modules: usize,
    /// How many of the top modules are refolded by hand, [1, --modules].
    #[arg(long, default_value = "2", allow_hyphen_values = true,
          value_parser = crate::num::count_in("--adjustable", 1, MAX_MODULES))]
    pub adjustable: usize,
    /// States of the other (bottom) modules, comma-separated, bottom first (default: all
    /// deployed).
    #[arg(long)]
    pub fixed: Option<String>,
    /// Allow states the geometry marks infeasible (crease strain above 1 %).
    #[arg(long)]
    pub all_states: bool,
    #[command(flatten)]
    pub site: SiteArgs,
    #[command(flatten)]
    pub day: DayArgs,
    /// At most this many refolds over the day (a refold: the states change between two
    /// samples); default: the best state at every sample.
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::usage(parse_max_changes))]
    pub max_changes: Option<usize>,
    /// Compass heading of the base's x axis (towards bottom vertex 0), degrees clockwise from
    /// north. 90: x east, y north.
    #[arg(long, default_value = "90", allow_hyphen_values = true,
          value_parser = crate::arg::heading)]
    pub heading: geometry::orient::Heading,
    /// Print JSON instead of a table.
    #[arg(skip)]
    pub json: bool,
    /// Write the incidence-over-the-day figure (tracked and flat, refolds marked) as SVG.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
    /// The same figure as PNG (600 dpi).
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
    /// The same figure as PDF (vector, font embedded).
    #[arg(long, value_name = "FILE")]
    pub pdf: Option<PathBuf>,
}

fn parse_max_changes(text: &str) -> Result<usize, Failure> {
    let t = text.trim();
    if t.starts_with('-') {
        return Err(Failure::usage(format!(
            "--max-changes must be a whole number of refolds, 0 or more, got '{text}' (a negative budget allows no schedule)"
        )));
    }
    if t.is_empty() || !t.bytes().all(|b| b.is_ascii_digit()) || t.len() > 9 {
        return Err(Failure::usage(format!(
            "--max-changes must be a whole number of refolds, 0 or more, got '{text}'"
        )));
    }
    t.parse()
        .map_err(|_| Failure::usage(format!("--max-changes: '{text}' is not a number")))
}

/// The day's result, everything the table, the JSON and the figure show.
pub struct Day {
    /// Samples (local time, sun).
    pub samples: Vec<Sample>,
    /// The chosen schedule.
    pub schedule: Schedule,
    /// Per-sample beam score of the schedule and of a flat top.
    pub tracked: Vec<f64>,
    /// See `tracked`.
    pub flat: Vec<f64>,
    /// Incidence on the tracked face and on a flat top, degrees (None: sun down).
    pub incidence: Vec<Option<(f64, f64)>>,
    /// Mean beam fractions over the sun-up samples (None: no sample has the sun up).
    pub tracked_fraction: Option<f64>,
    /// See `tracked_fraction`.
    pub flat_fraction: Option<f64>,
}

impl Day {
    /// tracked / flat − 1.
    pub fn gain(&self) -> Option<f64> {
        match (self.tracked_fraction, self.flat_fraction) {
            (Some(t), Some(f)) if f > 0.0 => Some(t / f - 1.0),
            _ => None,
        }
    }
}

fn evaluate(station: &Station, samples: Vec<Sample>, schedule: Schedule) -> Day {
    let suns: Vec<SunDirection> = samples.iter().map(direction).collect();
    let up = Vector3::z();
    let configs = station.configurations();
    let tracked: Vec<f64> = schedule
        .choice
        .iter()
        .zip(&suns)
        .map(|(c, s)| station::score(&configs[*c].normal_enu, s))
        .collect();
    let flat: Vec<f64> = suns.iter().map(|s| station::score(&up, s)).collect();
    let incidence = schedule
        .choice
        .iter()
        .zip(&suns)
        .map(|(c, s)| {
            s.up.then(|| {
                (
                    orient::angle_deg(&configs[*c].normal_enu, &s.enu),
                    orient::angle_deg(&up, &s.enu),
                )
            })
        })
        .collect();
    let n_up = suns.iter().filter(|s| s.up).count();
    let mean = |v: &[f64]| (n_up > 0).then(|| v.iter().sum::<f64>() / n_up as f64);
    Day {
        tracked_fraction: mean(&tracked),
        flat_fraction: mean(&flat),
        samples,
        schedule,
        tracked,
        flat,
        incidence,
    }
}

fn direction(s: &Sample) -> SunDirection {
    SunDirection::from_compass(s.sun.azimuth_deg, s.sun.elevation_deg, s.sun.up)
}

fn plan(station: &Station, samples: &[Sample], k: Option<usize>) -> Result<Schedule, Failure> {
    let suns: Vec<SunDirection> = samples.iter().map(direction).collect();
    let scores = station.scores(&suns);
    match k {
        None => Ok(station.best_each(&scores)),
        Some(k) => station
            .best_with_changes(&scores, k)
            .map_err(|e| Failure::usage(e.to_string())),
    }
}

fn num(x: f64) -> String {
    crate::num::json(x).to_string()
}

fn opt(x: Option<f64>) -> String {
    x.map_or_else(|| "null".to_string(), num)
}

fn text(s: &str) -> String {
    serde_json::Value::from(s).to_string()
}

fn vec3(v: &Vector3<f64>) -> String {
    format!("[{},{},{}]", num(v.x), num(v.y), num(v.z))
}

fn states_text(states: &[ShapeState]) -> String {
    states
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(",")
}

/// Eight compass points.
fn compass_word(az: f64) -> &'static str {
    const NAMES: [&str; 8] = ["N", "NE", "E", "SE", "S", "SW", "W", "NW"];
    NAMES[(((az + 22.5).rem_euclid(360.0)) / 45.0) as usize % 8]
}

/// One module's change at a refold.
struct ModuleChange {
    module: usize,
    from: ShapeState,
    to: ShapeState,
    instruction: String,
}

fn refolds(station: &Station, s: &Schedule) -> Vec<(usize, Vec<ModuleChange>)> {
    let configs = station.configurations();
    let first = station.fixed().len();
    let n = station.designs()[0].n();
    s.choice
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[0] != w[1])
        .map(|(i, w)| {
            let (a, b) = (&configs[w[0]].states, &configs[w[1]].states);
            let changes = a
                .iter()
                .zip(b)
                .enumerate()
                .filter(|(_, (x, y))| x != y)
                .map(|(k, (x, y))| ModuleChange {
                    module: first + k + 1,
                    from: *x,
                    to: *y,
                    instruction: station::folding_instruction(n, *x, *y),
                })
                .collect();
            (i + 1, changes)
        })
        .collect()
}

/// Runs `host-tool station`.
pub fn run(args: Args) -> Result<(), Failure> {
    let n = args.n;
    let m = args.modules;
    let adjustable = args.adjustable;
    if adjustable > m {
        return Err(Failure::usage(format!(
            "--adjustable must be an integer in [1, {m}] (at most --modules), got '{adjustable}'"
        )));
    }
    let designs = designs_from(n, &args.beta, m, &format!("--modules is {m}"))?;
    let heading = args.heading;
    let fixed = args
        .fixed
        .as_deref()
        .map(|list| {
            list.split(',')
                .map(|s| {
                    ShapeState::parse(s, n)
                        .map_err(|e| Failure::usage(format!("--fixed '{}': {e}", s.trim())))
                })
                .collect::<Result<Vec<_>, _>>()
        })
        .transpose()?;
    let k = args.max_changes;
    let (site, dt, air) = args.site.validate()?;
    let grid = args.day.grid(("09:00", "20:00", "10m"))?;
    let station = Station::new(designs.clone(), adjustable, fixed, heading, args.all_states)
        .map_err(|e| Failure::usage(e.to_string()))?;
    let figures: Vec<(&'static str, crate::figure::Format, PathBuf)> = [
        ("--svg", crate::figure::Format::Svg, args.svg.clone()),
        ("--png", crate::figure::Format::Png, args.png.clone()),
        ("--pdf", crate::figure::Format::Pdf, args.pdf.clone()),
    ]
    .into_iter()
    .filter_map(|(f, fmt, p)| p.map(|p| (f, fmt, p)))
    .collect();
    let to_stdout = figures.iter().any(|(_, _, p)| super::output::is_stdout(p));
    if args.json && to_stdout {
        return Err(Failure::usage(
            "a figure to stdout (-) and --json both write to stdout; give the figure a file name",
        ));
    }
    let list: Vec<(&str, &std::path::Path)> =
        figures.iter().map(|(f, _, p)| (*f, p.as_path())).collect();
    let outputs = super::output::open_all(&list)?;

    let (dt, samples) = match sun::day(&site, &grid, dt, &air) {
        Ok(x) => x,
        Err(e) => {
            super::output::discard(outputs);
            return Err(Failure::usage(e.to_string()));
        }
    };
    let light = sun::daylight(&site, grid.date, grid.offset, dt)
        .map_err(|e| Failure::usage(e.to_string()))?;
    let schedule = plan(&station, &samples, k)?;
    let day = evaluate(&station, samples.clone(), schedule);
    let folds = refolds(&station, &day.schedule);

    // Without a feasible pop-out the top never tilts: say so, and what the strained
    // catalogue would have given.
    let no_pop_outs = if station.has_pop_outs() {
        None
    } else {
        let strained = Station::new(
            designs.clone(),
            adjustable,
            Some(station.fixed().to_vec()),
            heading,
            true,
        )
        .ok()
        .filter(Station::has_pop_outs)
        .and_then(|s| {
            plan(&s, &samples, k)
                .ok()
                .map(|p| evaluate(&s, samples.clone(), p))
        });
        Some(strained.and_then(|d| d.tracked_fraction))
    };
    let note = no_pop_outs.map(|strained| {
        let d = &designs[m - 1];
        let mut s = format!(
            "no pop-out state of n = {}, β = {}° is feasible (every one strains its creases by more than {} %): only deployed and folded remain and both keep the top level, so tracking gains nothing over a flat top",
            d.n(),
            crate::num::tidy(d.beta_deg()),
            geometry::STRAIN_TOLERANCE * 100.0
        );
        if let (Some(t), Some(f)) = (strained, day.flat_fraction) {
            s.push_str(&format!(
                "; the strained catalogue (--all-states) would reach a beam fraction of {:.3} against {:.3} flat ({:+.1} %), which this design forgoes",
                t,
                f,
                if f > 0.0 { (t / f - 1.0) * 100.0 } else { 0.0 }
            ));
        }
        s
    });
    let (light_fields, light_text) = daylight_parts(&light);
    let configs = station.configurations();

    if !outputs.is_empty() {
        let fig = figure::render(&figure::Header {
            title: format!(
                "Station at {} on {} (UTC{})",
                site_text(&site),
                grid.date,
                grid.offset
            ),
            tracked_label: match k {
                Some(k) => format!("tracked (at most {k} refolds)"),
                None => "tracked (best state every sample)".to_string(),
            },
            offset_s: grid.offset.local_minus_utc(),
            day: &day,
            refold_samples: folds.iter().map(|(t, _)| *t).collect(),
        });
        for (out, (_, format, _)) in outputs.into_iter().zip(&figures) {
            let bytes = fig.encode(*format).map_err(|e| {
                Failure::Runtime(anyhow::anyhow!("cannot draw {}: {e}", out.flag()))
            })?;
            out.write(|w| w.write_all(&bytes))?;
        }
    }

    if args.json {
        let samples_json: Vec<String> = day
            .samples
            .iter()
            .enumerate()
            .map(|(t, s)| {
                let c = &configs[day.schedule.choice[t]];
                let (az, el) = heading.compass_of(&c.normal_base);
                ordered_object(&[
                    ("time", text(&s.time.to_rfc3339())),
                    ("azimuth_deg", num(s.sun.azimuth_deg)),
                    ("zenith_deg", num(s.sun.zenith_deg)),
                    ("elevation_deg", num(s.sun.elevation_deg)),
                    ("up", s.sun.up.to_string()),
                    (
                        "states",
                        format!(
                            "[{}]",
                            c.states
                                .iter()
                                .map(|x| text(&x.to_string()))
                                .collect::<Vec<_>>()
                                .join(",")
                        ),
                    ),
                    ("normal", vec3(&c.normal_base)),
                    ("normal_azimuth_deg", num(az)),
                    ("normal_elevation_deg", num(el)),
                    ("incidence_deg", opt(day.incidence[t].map(|i| i.0))),
                    ("flat_incidence_deg", opt(day.incidence[t].map(|i| i.1))),
                    ("beam", num(day.tracked[t])),
                    ("flat_beam", num(day.flat[t])),
                ])
            })
            .collect();
        let folds_json: Vec<String> = folds
            .iter()
            .map(|(t, changes)| {
                let ch: Vec<String> = changes
                    .iter()
                    .map(|c| {
                        ordered_object(&[
                            ("module", c.module.to_string()),
                            ("from", text(&c.from.to_string())),
                            ("to", text(&c.to.to_string())),
                            ("instruction", text(&c.instruction)),
                        ])
                    })
                    .collect();
                ordered_object(&[
                    ("time", text(&day.samples[*t].time.to_rfc3339())),
                    ("modules", format!("[{}]", ch.join(","))),
                ])
            })
            .collect();
        let betas: Vec<String> = designs.iter().map(|d| num(d.beta_deg())).collect();
        let mut fields = vec![
            ("n", n.to_string()),
            ("beta_deg", format!("[{}]", betas.join(","))),
            ("modules", m.to_string()),
            ("adjustable", adjustable.to_string()),
            (
                "fixed",
                format!(
                    "[{}]",
                    station
                        .fixed()
                        .iter()
                        .map(|x| text(&x.to_string()))
                        .collect::<Vec<_>>()
                        .join(",")
                ),
            ),
            ("configurations", configs.len().to_string()),
            ("pop_outs_available", station.has_pop_outs().to_string()),
            ("heading_deg", num(heading.deg())),
            ("lat_deg", num(site.lat_deg())),
            ("lon_deg", num(site.lon_deg())),
            ("elevation_m", num(site.elevation_m())),
            ("date", text(&grid.date.to_string())),
            ("tz", text(&grid.offset.to_string())),
            ("delta_t_s", num(dt.value())),
        ];
        fields.extend(light_fields);
        fields.extend([
            (
                "max_changes",
                k.map_or_else(|| "null".to_string(), |k| k.to_string()),
            ),
            ("samples", format!("[{}]", samples_json.join(","))),
            ("refolds", format!("[{}]", folds_json.join(","))),
            ("tracked_beam_fraction", opt(day.tracked_fraction)),
            ("flat_beam_fraction", opt(day.flat_fraction)),
            ("gain", opt(day.gain())),
            ("changes", day.schedule.changes.to_string()),
            ("note", note.as_deref().map_or_else(|| "null".into(), text)),
        ]);
        crate::cli::print_json_text(&ordered_object(&fields));
        return Ok(());
    }
    if to_stdout {
        return Ok(());
    }
    let top = designs[m - 1];
    crate::out!(
        "station: {m} modules n = {n}, β = {}°, the top {adjustable} adjustable ({} configurations), heading {}° (base x, towards vertex 0 of every module, faces {}° {})",
        crate::num::tidy(top.beta_deg()),
        configs.len(),
        crate::num::tidy(heading.deg()),
        crate::num::tidy(heading.deg()),
        compass_word(heading.deg())
    );
    crate::out!(
        "  {} on {} (UTC{}), ΔT {} s: {light_text}",
        site_text(&site),
        grid.date,
        grid.offset,
        crate::num::fixed(dt.value(), 1)
    );
    crate::out!(
        "  {:<6} {:<22} {:>9} {:>9} {:>10} {:>6}",
        "time",
        "states (adjustable)",
        "face az°",
        "face el°",
        "incidence°",
        "beam"
    );
    for (t, s) in day.samples.iter().enumerate() {
        let c = &configs[day.schedule.choice[t]];
        let (az, el) = heading.compass_of(&c.normal_base);
        let inc =
            day.incidence[t].map_or_else(|| "sun down".to_string(), |i| format!("{:.2}", i.0));
        crate::out!(
            "  {:<6} {:<22} {:>9.1} {:>9.1} {:>10} {:>6.3}",
            s.time.format("%H:%M"),
            states_text(&c.states),
            az,
            el,
            inc,
            day.tracked[t]
        );
    }
    if folds.is_empty() {
        crate::out!("no refolds: the first states hold all day");
    } else {
        crate::out!(
            "refolds (facets numbered within the module's layer as `host-tool pattern` numbers them):"
        );
        for (t, changes) in &folds {
            for c in changes {
                crate::out!(
                    "  {}  module {}: {} → {}: {}",
                    day.samples[*t].time.format("%H:%M"),
                    c.module,
                    c.from,
                    c.to,
                    c.instruction
                );
            }
        }
    }
    let f3 = |x: Option<f64>| x.map_or_else(|| "n/a".to_string(), |v| format!("{v:.4}"));
    crate::out!(
        "tracked_beam_fraction {}, flat_beam_fraction {}, gain {}, changes {}{}",
        f3(day.tracked_fraction),
        f3(day.flat_fraction),
        day.gain()
            .map_or_else(|| "n/a".to_string(), |g| format!("{:+.1} %", g * 100.0)),
        day.schedule.changes,
        k.map_or_else(String::new, |k| format!(" (at most {k})"))
    );
    if day.tracked_fraction.is_none() {
        crate::out!("the sun is below the horizon at every sample: there is nothing to track");
    }
    if let Some(note) = note {
        crate::out!("note: {note}");
    }
    Ok(())
}

/// Shared with the figure.
pub(crate) fn hours_of(time: &chrono::DateTime<chrono::FixedOffset>) -> f64 {
    use chrono::Timelike;
    f64::from(time.hour()) + f64::from(time.minute()) / 60.0 + f64::from(time.second()) / 3600.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn max_changes_refuses_negatives_with_the_reason() {
        let e = parse_max_changes("-1").err().map(|e| format!("{e:?}"));
        assert!(e.unwrap_or_default().contains("negative"));
        assert_eq!(parse_max_changes("4").ok(), Some(4));
        assert!(parse_max_changes("2.5").is_err());
    }

    #[test]
    fn compass_words() {
        assert_eq!(compass_word(0.0), "N");
        assert_eq!(compass_word(359.0), "N");
        assert_eq!(compass_word(100.0), "E");
        assert_eq!(compass_word(225.0), "SW");
    }
}
