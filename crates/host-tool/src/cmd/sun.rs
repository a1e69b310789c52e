//! `host-tool sun`: where the sun is (NREL SPA), at one instant or through a day, with the
//! day's sunrise and sunset. The work is in `planner::sun`.

use chrono::{DateTime, FixedOffset, Utc};
use planner::sun::{self, Atmosphere, DayGrid, Daylight, DeltaT, Sample, Site, SunPosition};

use super::states::ordered_object;
use crate::failure::Failure;

/// The observer and the air, shared by `sun` and `station`.
#[derive(Debug, Clone, clap::Args)]
pub struct SiteArgs {
    /// Latitude in degrees north, [-90, 90] (south negative).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::latitude)]
    pub lat: f64,
    /// Longitude in degrees east, [-180, 180] (west negative).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::longitude)]
    pub lon: f64,
    /// Elevation above sea level in metres, [-500, 10000].
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true,
          value_parser = crate::arg::elevation_m)]
    pub elevation_m: f64,
    /// ΔT = TT − UT1 in seconds, [-10000, 10000]. Default: the Espenak–Meeus estimate for the
    /// month (solar-positioning's delta_t, refitted to IERS data from 2015; about 69 s in 2025).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::delta_t)]
    pub delta_t: Option<f64>,
    /// Air pressure for the refraction correction, hPa (0, 2000]; default pvlib's 1013.25.
    #[arg(long, default_value_t = 1013.25, allow_hyphen_values = true,
          value_parser = crate::num::ranged(crate::num::Low::Above(0.0), 2000.0, " hPa"))]
    pub pressure_hpa: f64,
    /// Air temperature for the refraction correction, °C [-90, 60] (Earth's surface records);
    /// default pvlib's 12.
    #[arg(long, default_value_t = 12.0, allow_hyphen_values = true,
          value_parser = crate::num::ranged(crate::num::Low::From(planner::sun::TEMPERATURE_RANGE_C.0), planner::sun::TEMPERATURE_RANGE_C.1, " °C"))]
    pub temperature_c: f64,
}

/// A day's samples, shared by `sun` and `station` (each has its own defaults).
#[derive(Debug, Clone, clap::Args)]
pub struct DayArgs {
    /// Local calendar date YYYY-MM-DD of a day of samples.
    #[arg(long, value_parser = crate::arg::usage(|s: &str| time_arg("--date", sun::parse_date, s)))]
    pub date: Option<chrono::NaiveDate>,
    /// The local clock's offset from UTC, ±HH:MM (e.g. -04:00 for EDT) or Z; needed with --date.
    #[arg(long, allow_hyphen_values = true,
          value_parser = crate::arg::usage(|s: &str| time_arg("--tz", sun::parse_offset, s)))]
    pub tz: Option<FixedOffset>,
    /// First sample, local HH:MM.
    #[arg(long, value_parser = crate::arg::usage(|s: &str| time_arg("--from", sun::parse_clock, s)))]
    pub from: Option<chrono::NaiveTime>,
    /// Last sample at or before this local HH:MM.
    #[arg(long, value_parser = crate::arg::usage(|s: &str| time_arg("--to", sun::parse_clock, s)))]
    pub to: Option<chrono::NaiveTime>,
    /// Step between samples: a whole number with s, m or h (e.g. 10m, 1h30m), 1 s to 24 h.
    #[arg(long, value_parser = crate::arg::usage(|s: &str| time_arg("--every", sun::parse_duration, s)))]
    pub every: Option<chrono::Duration>,
}

/// One of the time options through `parse`, its refusal prefixed with the flag.
pub fn time_arg<T>(
    flag: &str,
    parse: fn(&str) -> Result<T, sun::SunError>,
    text: &str,
) -> Result<T, Failure> {
    parse(text).map_err(|e| Failure::usage(format!("{flag}: {e}")))
}

/// `--time`: one instant, RFC 3339 with its offset.
pub fn parse_time(text: &str) -> Result<DateTime<FixedOffset>, Failure> {
    time_arg("--time", sun::parse_instant, text)
}

fn usage(e: sun::SunError) -> Failure {
    Failure::usage(e.to_string())
}

impl SiteArgs {
    /// The validated site, ΔT (if given) and air.
    pub fn validate(&self) -> Result<(Site, Option<DeltaT>, Atmosphere), Failure> {
        let site = Site::new(self.lat, self.lon, self.elevation_m).map_err(|e| {
            Failure::usage(match e {
                sun::SunError::Latitude(_) => format!("--lat: {e}"),
                sun::SunError::Longitude(_) => format!("--lon: {e}"),
                _ => format!("--elevation-m: {e}"),
            })
        })?;
        let dt = self
            .delta_t
            .map(DeltaT::seconds)
            .transpose()
            .map_err(|e| Failure::usage(format!("--delta-t: {e}")))?;
        let air = Atmosphere {
            pressure_hpa: self.pressure_hpa,
            temperature_c: self.temperature_c,
        };
        let ok = self.pressure_hpa.is_finite()
            && self.pressure_hpa > 0.0
            && self.pressure_hpa <= 2000.0
            && (planner::sun::TEMPERATURE_RANGE_C.0..=planner::sun::TEMPERATURE_RANGE_C.1)
                .contains(&self.temperature_c);
        if !ok {
            return Err(Failure::usage(format!(
                "--pressure-hpa {} / --temperature-c {}: pressure must be in (0, 2000] hPa and temperature in [-90, 60] °C",
                self.pressure_hpa, self.temperature_c
            )));
        }
        Ok((site, dt, air))
    }
}

impl DayArgs {
    /// The validated grid, with `defaults` (from, to, every) for what is not given.
    pub fn grid(&self, defaults: (&str, &str, &str)) -> Result<DayGrid, Failure> {
        let date = self
            .date
            .ok_or_else(|| Failure::usage("--date YYYY-MM-DD is needed"))?;
        let offset = self.tz.ok_or_else(|| {
            Failure::usage(
                "--date needs --tz ±HH:MM, the offset from UTC of the clock --from/--to are read on (e.g. --tz -04:00 for EDT)",
            )
        })?;
        let from = match self.from {
            Some(t) => t,
            None => time_arg("--from", sun::parse_clock, defaults.0)?,
        };
        let to = match self.to {
            Some(t) => t,
            None => time_arg("--to", sun::parse_clock, defaults.1)?,
        };
        let every = match self.every {
            Some(d) => d,
            None => time_arg("--every", sun::parse_duration, defaults.2)?,
        };
        DayGrid::new(date, offset, from, to, every).map_err(|e| Failure::usage(e.to_string()))
    }
}

/// Arguments of `host-tool sun`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub site: SiteArgs,
    /// One instant, RFC 3339 with its offset (e.g. 2025-06-21T12:00:00-04:00); or use --date.
    #[arg(long, conflicts_with_all = ["date", "tz", "from", "to", "every"],
          value_parser = crate::arg::usage(parse_time))]
    pub time: Option<DateTime<FixedOffset>>,
    #[command(flatten)]
    pub day: DayArgs,
    /// Print JSON instead of a table.
    #[arg(skip)]
    pub json: bool,
}

fn num(x: f64) -> String {
    crate::num::json(x).to_string()
}

fn text(s: &str) -> String {
    serde_json::Value::from(s).to_string()
}

/// Latitude/longitude as a person reads them.
pub fn site_text(site: &Site) -> String {
    let (lat, lon) = (site.lat_deg(), site.lon_deg());
    format!(
        "{:.4}° {}, {:.4}° {}, {} m",
        lat.abs(),
        if lat < 0.0 { "S" } else { "N" },
        lon.abs(),
        if lon < 0.0 { "W" } else { "E" },
        crate::num::tidy(site.elevation_m())
    )
}

fn position_json(time: &DateTime<FixedOffset>, p: &SunPosition) -> String {
    ordered_object(&[
        ("time", text(&time.to_rfc3339())),
        ("azimuth_deg", num(p.azimuth_deg)),
        ("zenith_deg", num(p.zenith_deg)),
        ("elevation_deg", num(p.elevation_deg)),
        ("up", p.up.to_string()),
    ])
}

/// The day's sunrise/sunset as JSON fields and as a sentence.
pub fn daylight_parts(d: &Daylight) -> (Vec<(&'static str, String)>, String) {
    let times = |v: &[DateTime<FixedOffset>]| {
        format!(
            "[{}]",
            v.iter()
                .map(|t| text(&t.to_rfc3339()))
                .collect::<Vec<_>>()
                .join(",")
        )
    };
    let hm = |v: &[DateTime<FixedOffset>]| {
        v.iter()
            .map(|t| t.format("%H:%M").to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    match d {
        Daylight::PolarDay => (
            vec![
                ("daylight", text("polar-day")),
                ("sunrise", "[]".into()),
                ("sunset", "[]".into()),
            ],
            "polar day: the sun does not set on this date".into(),
        ),
        Daylight::PolarNight => (
            vec![
                ("daylight", text("polar-night")),
                ("sunrise", "[]".into()),
                ("sunset", "[]".into()),
            ],
            "polar night: the sun does not rise on this date".into(),
        ),
        Daylight::Regular { rises, sets } => {
            let mut s = String::new();
            if rises.is_empty() {
                s.push_str("no sunrise");
            } else {
                s.push_str(&format!("sunrise {}", hm(rises)));
            }
            if sets.is_empty() {
                s.push_str(", no sunset");
            } else {
                s.push_str(&format!(", sunset {}", hm(sets)));
            }
            s.push_str(" (local)");
            (
                vec![
                    ("daylight", text("regular")),
                    ("sunrise", times(rises)),
                    ("sunset", times(sets)),
                ],
                s,
            )
        }
    }
}

/// Runs `host-tool sun`.
pub fn run(args: Args) -> Result<(), Failure> {
    let (site, dt, air) = args.site.validate()?;
    if let Some(time) = args.time {
        let u = time.with_timezone(&Utc);
        let dt = match dt {
            Some(d) => d,
            None => sun::default_delta_t(&u).map_err(usage)?,
        };
        let p = sun::position(&site, &u, dt, &air).map_err(usage)?;
        if args.json {
            let mut body = position_json(&time, &p);
            body.pop();
            body.push_str(&format!(
                ",\"delta_t_s\":{},\"lat_deg\":{},\"lon_deg\":{},\"elevation_m\":{}}}",
                num(dt.value()),
                num(site.lat_deg()),
                num(site.lon_deg()),
                num(site.elevation_m())
            ));
            crate::cli::print_json_text(&body);
            return Ok(());
        }
        crate::out!(
            "sun at {} from {} (ΔT {} s, {} hPa, {} °C)",
            time.to_rfc3339(),
            site_text(&site),
            crate::num::fixed(dt.value(), 1),
            crate::num::tidy(air.pressure_hpa),
            crate::num::tidy(air.temperature_c)
        );
        crate::out!(
            "  azimuth {:.4}° (clockwise from north), zenith {:.4}°, elevation {:.4}°",
            p.azimuth_deg,
            p.zenith_deg,
            p.elevation_deg
        );
        if !p.up {
            crate::out!(
                "  the sun is below the horizon (its upper limb is under it: elevation {:.2}°)",
                p.elevation_deg
            );
        }
        return Ok(());
    }
    if args.day.date.is_none() {
        return Err(Failure::usage(
            "give --time RFC3339 (one instant) or --date YYYY-MM-DD --tz ±HH:MM [--from HH:MM --to HH:MM --every DURATION] (a day)",
        ));
    }
    let grid = args.day.grid(("00:00", "23:59", "1h"))?;
    let (dt, samples) = sun::day(&site, &grid, dt, &air).map_err(usage)?;
    let light = sun::daylight(&site, grid.date, grid.offset, dt).map_err(usage)?;
    let (light_fields, light_text) = daylight_parts(&light);
    if args.json {
        let list: Vec<String> = samples
            .iter()
            .map(|s: &Sample| position_json(&s.time, &s.sun))
            .collect();
        let mut fields = vec![
            ("lat_deg", num(site.lat_deg())),
            ("lon_deg", num(site.lon_deg())),
            ("elevation_m", num(site.elevation_m())),
            ("date", text(&grid.date.to_string())),
            ("tz", text(&grid.offset.to_string())),
            ("delta_t_s", num(dt.value())),
        ];
        fields.extend(light_fields);
        fields.push(("samples", format!("[{}]", list.join(","))));
        crate::cli::print_json_text(&ordered_object(&fields));
        return Ok(());
    }
    crate::out!(
        "sun on {} (UTC{}) from {} (ΔT {} s): {light_text}",
        grid.date,
        grid.offset,
        site_text(&site),
        crate::num::fixed(dt.value(), 1)
    );
    crate::out!(
        "  {:<6} {:>10} {:>10} {:>10}",
        "time",
        "azimuth°",
        "zenith°",
        "elevation°"
    );
    for s in &samples {
        let note = if s.sun.up { "" } else { "  below the horizon" };
        crate::out!(
            "  {:<6} {:>10.4} {:>10.4} {:>10.4}{note}",
            s.time.format("%H:%M"),
            s.sun.azimuth_deg,
            s.sun.zenith_deg,
            s.sun.elevation_deg
        );
    }
    Ok(())
}
