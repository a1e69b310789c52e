//! `host-tool aim`: the bend that points the crane's tip axis (its panel's normal) as close to
//! a direction — a compass azimuth/elevation or the sun — as the trunk state's bend limit
//! allows, and the error left. Pure computation: it moves nothing (docs/sun.md, "aim").
//!
//! A constant-curvature bend of tip angle θ towards base direction φ turns the tip axis from
//! ẑ to (sin θ cos φ, sin θ sin φ, cos θ), whatever the flexible length (that sets where the
//! tip is, not where it points). The limit is the controller's: `CraneConfig::max_bend_deg`
//! in the flexible states, none elsewhere (the controller bends only those).

use chrono::Utc;
use firmware::config::CraneConfig;
use geometry::orient::{self, Heading};
use geometry::TrunkState;
use nalgebra::Vector3;
use planner::sun;

use super::states::ordered_object;
use super::sun::SiteArgs;
use crate::failure::Failure;

/// Arguments of `host-tool aim`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Aim at compass azimuth AZ (degrees clockwise from north) and elevation EL (degrees
    /// above the horizon), e.g. --toward 135,40.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "sun")]
    pub toward: Option<String>,
    /// Aim at the sun (needs --lat, --lon; --time, default now).
    #[arg(long)]
    pub sun: bool,
    /// Latitude, degrees north (with --sun).
    #[arg(long, allow_hyphen_values = true)]
    pub lat: Option<f64>,
    /// Longitude, degrees east (with --sun).
    #[arg(long, allow_hyphen_values = true)]
    pub lon: Option<f64>,
    /// The instant, RFC 3339 with its offset (with --sun; default now).
    #[arg(long)]
    pub time: Option<String>,
    /// The trunk's state, e.g. 'F&D' (the paper's solar demonstration).
    #[arg(long, default_value = "F&D")]
    pub state: String,
    /// Compass heading of the crane base's x axis (tendon 1's side), degrees from north.
    #[arg(long, default_value_t = 90.0, allow_hyphen_values = true)]
    pub heading: f64,
    /// Print JSON instead of text.
    #[arg(short = 'j', long)]
    pub json: bool,
}

/// The best bend in one state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aim {
    /// Bend direction in the base frame, degrees counter-clockwise from x.
    pub direction_deg: f64,
    /// Tip angle of the bend, degrees.
    pub bend_deg: f64,
    /// The state's limit, degrees.
    pub limit_deg: f64,
    /// The tip axis, base frame.
    pub axis: Vector3<f64>,
    /// Angle between the tip axis and the target, degrees.
    pub error_deg: f64,
}

/// The controller's bend limit in `state` (degrees): none outside the flexible states.
pub fn limit_deg(cfg: &CraneConfig, state: TrunkState) -> f64 {
    if state.is_flexible() {
        f64::from(cfg.max_bend_deg_in(state)).max(0.0)
    } else {
        0.0
    }
}

/// The bend within `limit_deg` that brings the tip axis closest to the unit base-frame
/// direction `target`.
pub fn aim(target: &Vector3<f64>, limit_deg: f64) -> Aim {
    let needed = orient::angle_deg(&Vector3::z(), target);
    let horizontal = target.x.hypot(target.y);
    let direction_deg = if horizontal > 1e-12 {
        target.y.atan2(target.x).to_degrees().rem_euclid(360.0)
    } else {
        0.0
    };
    let bend_deg = needed.min(limit_deg);
    let (t, p) = (bend_deg.to_radians(), direction_deg.to_radians());
    let axis = Vector3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
    Aim {
        direction_deg,
        bend_deg,
        limit_deg,
        axis,
        error_deg: orient::angle_deg(&axis, target),
    }
}

fn parse_toward(text: &str) -> Result<(f64, f64), Failure> {
    let bad = || {
        Failure::usage(format!(
            "--toward must be AZ,EL in degrees (azimuth [0, 360) clockwise from north, elevation [-90, 90]), got '{text}'"
        ))
    };
    let (a, e) = text.split_once(',').ok_or_else(bad)?;
    let (a, e): (f64, f64) = (
        a.trim().parse().map_err(|_| bad())?,
        e.trim().parse().map_err(|_| bad())?,
    );
    if !(a.is_finite() && e.is_finite() && (0.0..360.0).contains(&a) && (-90.0..=90.0).contains(&e))
    {
        return Err(bad());
    }
    Ok((a, e))
}

fn num(x: f64) -> String {
    crate::num::json(x).to_string()
}

/// Runs `host-tool aim`.
pub fn run(args: Args) -> Result<(), Failure> {
    let state: TrunkState = args.state.parse().map_err(|_| {
        Failure::usage(format!(
            "--state '{}' is not a trunk state; expected one of F&P, F&F, F&D, D&P, D&F, D&D",
            args.state
        ))
    })?;
    let heading =
        Heading::from_deg(args.heading).map_err(|e| Failure::usage(format!("--heading: {e}")))?;
    let (az, el) = match (&args.toward, args.sun) {
        (Some(t), false) => parse_toward(t)?,
        (None, true) => {
            let (Some(lat), Some(lon)) = (args.lat, args.lon) else {
                return Err(Failure::usage("--sun needs --lat DEG and --lon DEG"));
            };
            let site = SiteArgs {
                lat,
                lon,
                elevation_m: 0.0,
                delta_t: None,
                pressure_hpa: 1013.25,
                temperature_c: 12.0,
            };
            let (site, _, air) = site.validate()?;
            let t = match &args.time {
                Some(t) => sun::parse_instant(t)
                    .map_err(|e| Failure::usage(format!("--time: {e}")))?
                    .with_timezone(&Utc),
                None => chrono::DateTime::<Utc>::from(std::time::SystemTime::now()),
            };
            let dt = sun::default_delta_t(&t).map_err(|e| Failure::usage(e.to_string()))?;
            let p =
                sun::position(&site, &t, dt, &air).map_err(|e| Failure::usage(e.to_string()))?;
            if !p.up {
                return Err(Failure::Runtime(anyhow::anyhow!(
                    "the sun is below the horizon at {} (elevation {:.2}°): nothing to aim at",
                    t.to_rfc3339(),
                    p.elevation_deg
                )));
            }
            (p.azimuth_deg, p.elevation_deg)
        }
        _ => {
            return Err(Failure::usage(
                "give --toward AZ,EL or --sun --lat DEG --lon DEG [--time RFC3339]",
            ))
        }
    };
    let target = heading.base_of(az, el).into_inner();
    let cfg = CraneConfig::default();
    let here = aim(&target, limit_deg(&cfg, state));
    // Another state that reaches closer (the paper's F&P → D&D → F&D for the panel).
    let better = TrunkState::ALL
        .iter()
        .map(|s| (*s, aim(&target, limit_deg(&cfg, *s))))
        .filter(|(_, a)| a.error_deg < here.error_deg - 1e-9)
        .min_by(|a, b| a.1.error_deg.total_cmp(&b.1.error_deg));
    if args.json {
        crate::cli::print_json_text(&ordered_object(&[
            ("target_azimuth_deg", num(az)),
            ("target_elevation_deg", num(el)),
            ("heading_deg", num(heading.deg())),
            (
                "state",
                serde_json::Value::from(state.to_string()).to_string(),
            ),
            ("bend_direction_deg", num(here.direction_deg)),
            ("bend_deg", num(here.bend_deg)),
            ("max_bend_deg", num(here.limit_deg)),
            (
                "tip_axis",
                format!(
                    "[{},{},{}]",
                    num(here.axis.x),
                    num(here.axis.y),
                    num(here.axis.z)
                ),
            ),
            ("error_deg", num(here.error_deg)),
            (
                "better_state",
                better.map_or_else(
                    || "null".into(),
                    |(s, _)| serde_json::Value::from(s.to_string()).to_string(),
                ),
            ),
            (
                "better_error_deg",
                better.map_or_else(|| "null".into(), |(_, a)| num(a.error_deg)),
            ),
        ]));
        return Ok(());
    }
    crate::out!(
        "aim in {state} at azimuth {az:.2}°, elevation {el:.2}° (base x faces {}°): bend {:.2}° towards {:.1}° from base x (limit {:.1}°), tip axis error {:.2}°",
        crate::num::tidy(heading.deg()),
        here.bend_deg,
        here.direction_deg,
        here.limit_deg,
        here.error_deg
    );
    if let Some((s, a)) = better {
        crate::out!(
            "{s} reaches closer (error {:.2}°, limit {:.1}°): take it first, e.g. host-tool plan --target '{s}'",
            a.error_deg,
            a.limit_deg
        );
    }
    crate::out!("computed only: nothing was sent to a crane");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aim_reaches_within_the_limit_and_reports_the_rest() {
        let h = Heading::default();
        // 20° from vertical, towards the east: within 30°, so no error.
        let t = h.base_of(90.0, 70.0).into_inner();
        let a = aim(&t, 30.0);
        assert!(a.error_deg < 1e-9 && (a.bend_deg - 20.0).abs() < 1e-9);
        assert!((a.axis - t).norm() < 1e-9);
        // 50° from vertical: the limit leaves 20°, and the bend leans the right way.
        let t = h.base_of(200.0, 40.0).into_inner();
        let a = aim(&t, 30.0);
        assert!((a.error_deg - 20.0).abs() < 1e-9 && (a.bend_deg - 30.0).abs() < 1e-12);
        let (az, _) = h.compass_of(&a.axis);
        assert!((az - 200.0).abs() < 1e-9);
        // No bend: the error is the zenith angle.
        assert!((aim(&t, 0.0).error_deg - 50.0).abs() < 1e-9);
    }

    #[test]
    fn limits_are_the_controllers() {
        let cfg = CraneConfig::default();
        let fd: TrunkState = "F&D".parse().unwrap();
        let dp: TrunkState = "D&P".parse().unwrap();
        let dd: TrunkState = "D&D".parse().unwrap();
        assert_eq!(limit_deg(&cfg, fd), f64::from(cfg.joystick.max_bend_deg));
        assert_eq!(
            limit_deg(&cfg, dp),
            f64::from(cfg.joystick.stiff_max_bend_deg)
        );
        assert_eq!(limit_deg(&cfg, dd), 0.0);
        assert!(parse_toward("360,10").is_err() && parse_toward("10,91").is_err());
        assert!(parse_toward("135,40").is_ok());
    }
}
