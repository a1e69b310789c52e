//! `host-tool aim`: the bend that points the crane's tip axis (its panel's normal) as close to
//! a direction — a compass azimuth/elevation or the sun — as the trunk state's bend limit
//! allows, and the error left; with `--sim` or `--port` it bends the crane there (and with
//! `--change-state` first takes the state that aims closest). `host-tool track` aims again
//! and again through a day (docs/sun.md, "aim" and "track").
//!
//! A constant-curvature bend of tip angle θ towards base direction φ turns the tip axis from
//! ẑ to (sin θ cos φ, sin θ sin φ, cos θ), whatever the flexible length (that sets where the
//! tip is, not where it points). The limit is the one a host commands a held bend within
//! ([`Workspace::held_limits`]: the controller's limit less the tendons' take-up margin) in
//! the flexible states, none elsewhere (the controller bends only those). On the simulator the
//! workspace is the calibrated one ([`crate::cmd::task::calibrate_for_sim`]): the bend to
//! command is found on its model of the tip, which the true tip follows within
//! [`SIM_AXIS_TOLERANCE_DEG`].

use chrono::{DateTime, Utc};
use geometry::orient::{self, Heading};
use geometry::{BottomState, TopState, TrunkState};
use nalgebra::Vector3;
use planner::sun;
use planner::task::Workspace;
use serde_json::{json, Value};

use super::sun::SiteArgs;
use crate::cmd::prim::{bend_step, crane_config, run_step, Link};
use crate::cmd::task::WorldArgs;
use crate::device::DeviceArgs;
use crate::failure::Failure;

/// How far the simulator's true tip axis may be from the axis the calibrated model predicts
/// for the bend commanded, degrees. Measured (docs/sun.md, "aim"): at most 0.46° in F&D over
/// 24 directions at the full bend right after the state is reached, as the calibration saw
/// it; up to 1.88° after half an hour to hours at rest in the state (the trunk settles as its residual
/// pressure leaks away, and the calibration does not see that).
pub const SIM_AXIS_TOLERANCE_DEG: f64 = 2.5;

/// Arguments of `host-tool aim`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Aim at compass azimuth AZ (degrees clockwise from north) and elevation EL (degrees
    /// above the horizon), e.g. --toward 135,40.
    #[arg(long, value_name = "AZ,EL", allow_hyphen_values = true, conflicts_with = "sun",
          value_parser = crate::arg::usage(parse_toward))]
    pub toward: Option<(f64, f64)>,
    /// Aim at the sun (needs --lat, --lon; --time, default now).
    #[arg(long)]
    pub sun: bool,
    /// Latitude, degrees north (with --sun).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::latitude)]
    pub lat: Option<f64>,
    /// Longitude, degrees east (with --sun).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::longitude)]
    pub lon: Option<f64>,
    /// The instant, RFC 3339 with its offset (with --sun; default now).
    #[arg(long, value_parser = crate::arg::usage(super::sun::parse_time))]
    pub time: Option<DateTime<chrono::FixedOffset>>,
    /// Compute for this trunk state without a crane, e.g. 'F&D' [default without --sim or
    /// --port: F&D, the paper's solar demonstration]; with a crane its own state is used.
    #[arg(long, value_name = "STATE", conflicts_with_all = ["sim", "port", "change_state"],
          value_parser = crate::arg::trunk_state)]
    pub state: Option<TrunkState>,
    /// Compass heading of the crane base's x axis (tendon 0's side), degrees from north.
    #[arg(long, default_value = "90", allow_hyphen_values = true,
          value_parser = crate::arg::heading)]
    pub heading: Heading,
    /// When another state aims closer, go there first (the planner's cheapest plan).
    #[arg(long)]
    pub change_state: bool,
    /// Show what would be done and move nothing.
    #[arg(long)]
    pub dry_run: bool,
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Record the session to this MCAP file (`host-tool log` reads it).
    #[arg(long, value_name = "FILE.mcap", conflicts_with = "dry_run")]
    pub record: Option<std::path::PathBuf>,
    /// Print JSON instead of text.
    #[arg(skip)]
    pub json: bool,
}

/// The best bend in one state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aim {
    /// The direction to command, base frame, degrees counter-clockwise from x.
    pub direction_deg: f64,
    /// The tip angle to command, degrees.
    pub bend_deg: f64,
    /// The state's limit, degrees (0 where it is not bent).
    pub limit_deg: f64,
    /// The tip axis the workspace predicts for that command, base frame.
    pub axis: Vector3<f64>,
    /// Angle between that axis and the target, degrees.
    pub error_deg: f64,
}

/// The closed form in a workspace without calibration: the bend within `limit_deg` that
/// brings the tip axis closest to the unit base-frame direction `target`.
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

/// The predicted tip axis of `state` in `ws` under a commanded bend.
fn predicted_axis(ws: &Workspace, state: TrunkState, bend_deg: f64, dir_deg: f64) -> Vector3<f64> {
    ws.tip(state, bend_deg, dir_deg)
        .map_or_else(|_| Vector3::z(), |t| Vector3::from(t.axis).normalize())
}

/// The command in `state` of `ws` whose predicted tip axis is nearest `target`: the closed form
/// where the state has no calibration, else found on the calibrated model (the direction by
/// the model's lean, the angle by golden section on the predicted error, twice around).
pub fn aim_in(ws: &Workspace, state: TrunkState, target: &Vector3<f64>) -> Aim {
    let limit = ws.limit_deg(state).unwrap_or(0.0);
    let Some(c) = ws.calibration(state) else {
        return aim(target, limit);
    };
    if limit <= 0.0 {
        return aim(target, 0.0);
    }
    let closed = aim(target, limit);
    let facing = closed.direction_deg.to_radians();
    let mut dir = c.command_toward(facing).to_degrees().rem_euclid(360.0);
    let err = |a: f64, d: f64| orient::angle_deg(&predicted_axis(ws, state, a, d), target);
    let mut bend = 0.0;
    for _ in 0..2 {
        let (mut lo, mut hi) = (0.0f64, limit);
        let g = 0.5 * (5f64.sqrt() - 1.0);
        for _ in 0..60 {
            let (x1, x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
            if err(x1, dir) <= err(x2, dir) {
                hi = x2;
            } else {
                lo = x1;
            }
        }
        bend = 0.5 * (lo + hi);
        // The predicted axis' azimuth against the target's: turn the command by the miss.
        let ax = predicted_axis(ws, state, bend, dir);
        if ax.x.hypot(ax.y) > 1e-9 && closed.bend_deg > 1e-9 {
            let miss = ax.y.atan2(ax.x).to_degrees() - closed.direction_deg;
            dir = (dir - ((miss + 540.0).rem_euclid(360.0) - 180.0)).rem_euclid(360.0);
        }
    }
    let axis = predicted_axis(ws, state, bend, dir);
    Aim {
        direction_deg: dir,
        bend_deg: bend,
        limit_deg: limit,
        axis,
        error_deg: orient::angle_deg(&axis, target),
    }
}

/// The state that aims closer than `here` in `state` (`None` when none does by 0.01°).
pub fn better_state(
    ws: &Workspace,
    state: TrunkState,
    target: &Vector3<f64>,
) -> Option<(TrunkState, Aim)> {
    let here = aim_in(ws, state, target);
    TrunkState::ALL
        .iter()
        .map(|s| (*s, aim_in(ws, *s, target)))
        .filter(|(_, a)| a.error_deg < here.error_deg - 0.01)
        .min_by(|a, b| a.1.error_deg.total_cmp(&b.1.error_deg))
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
    direction(a, e).map_err(|_| bad())
}

/// A compass direction checked: azimuth in [0, 360), elevation in [-90, 90], degrees.
pub fn direction(az: f64, el: f64) -> Result<(f64, f64), String> {
    if az.is_finite()
        && el.is_finite()
        && (0.0..360.0).contains(&az)
        && (-90.0..=90.0).contains(&el)
    {
        Ok((az, el))
    } else {
        Err(format!(
            "the direction must be AZ, EL in degrees (azimuth [0, 360) clockwise from north, elevation [-90, 90]), got {az}, {el}"
        ))
    }
}

/// The site of `--lat`/`--lon` at sea level, in the standard air.
pub fn site_of(lat: f64, lon: f64) -> Result<(sun::Site, sun::Atmosphere), Failure> {
    let site = SiteArgs {
        lat,
        lon,
        elevation_m: 0.0,
        delta_t: None,
        pressure_hpa: 1013.25,
        temperature_c: 12.0,
    };
    let (site, _, air) = site.validate()?;
    Ok((site, air))
}

/// The sun's compass azimuth and elevation at `t`, `None` below the horizon (elevation given).
pub fn sun_at(
    site: &sun::Site,
    air: &sun::Atmosphere,
    t: &DateTime<Utc>,
) -> Result<Result<(f64, f64), f64>, Failure> {
    let dt = sun::default_delta_t(t).map_err(|e| Failure::usage(e.to_string()))?;
    let p = sun::position(site, t, dt, air).map_err(|e| Failure::usage(e.to_string()))?;
    Ok(if p.up {
        Ok((p.azimuth_deg, p.elevation_deg))
    } else {
        Err(p.elevation_deg)
    })
}

/// The instant `--time` gave (parsed by clap: RFC 3339 with its offset), or now.
pub fn instant(time: Option<DateTime<chrono::FixedOffset>>) -> DateTime<chrono::FixedOffset> {
    time.unwrap_or_else(|| {
        chrono::DateTime::<Utc>::from(std::time::SystemTime::now()).fixed_offset()
    })
}

fn num(x: f64) -> Value {
    crate::num::json(x)
}

/// `x` rounded to `digits` decimals.
pub fn round(x: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (x * k).round() / k
}

/// The JSON of an aim in `state` at a compass target.
pub fn aim_json(state: TrunkState, a: &Aim, better: Option<&(TrunkState, Aim)>) -> Value {
    json!({
        "state": state.name(),
        "bend_direction_deg": num(round(a.direction_deg, 6)),
        "bend_deg": num(round(a.bend_deg, 6)),
        "max_bend_deg": num(round(a.limit_deg, 6)),
        "tip_axis": [num(round(a.axis.x, 9)), num(round(a.axis.y, 9)), num(round(a.axis.z, 9))],
        "error_deg": num(round(a.error_deg, 6)),
        "better_state": better.map(|(s, _)| s.name()),
        "better_error_deg": better.map(|(_, b)| num(round(b.error_deg, 6))),
    })
}

/// What one aim of the crane did: the device's and (on the simulator) the truth's view.
pub struct Aimed {
    /// The state it was aimed in.
    pub state: TrunkState,
    /// The command.
    pub aim: Aim,
    /// The simulator's true tip axis, its angle from the target and from the predicted axis,
    /// degrees.
    pub truth: Option<(Vector3<f64>, f64, f64)>,
}

impl Aimed {
    /// Whether the true tip axis (when known) is within [`SIM_AXIS_TOLERANCE_DEG`] of the
    /// predicted one, and so within the reported error plus the tolerance of the target.
    pub fn within_tolerance(&self) -> bool {
        self.truth
            .is_none_or(|(_, _, miss)| miss <= SIM_AXIS_TOLERANCE_DEG)
    }
}

/// Aims the crane on `link` at the compass direction (`az`, `el`): in its state, or, with
/// `change_state`, first in the state that aims closest.
pub fn aim_crane(
    link: &mut Link,
    cfg: &protocol::CraneGeometry,
    heading: Heading,
    (az, el): (f64, f64),
    change_state: bool,
) -> Result<Aimed, Failure> {
    let ws = crate::cmd::task::task_workspace(cfg)?;
    let target = heading.base_of(az, el).into_inner();
    let mut state = crate::cmd::prim::ready(link)?.state;
    if change_state {
        if let Some((better, _)) = better_state(&ws, state, &target) {
            crate::say!("{better} aims closer than {state}: going there first");
            crate::cmd::reach::go_to_state(link, better)?;
            state = better;
        }
    }
    let a = aim_in(&ws, state, &target);
    if state.is_flexible() {
        let (step, _) = bend_step(&ws, cfg, state, a.bend_deg, a.direction_deg)?;
        let end = run_step(link, step)?;
        if let Some(e) = end.error {
            return Err(Failure::Runtime(anyhow::anyhow!("the bend: {e}")));
        }
    }
    let truth = link.sim().map(|sim| {
        let axis = Vector3::from(sim.true_tip().axis).normalize();
        (
            axis,
            orient::angle_deg(&axis, &target),
            orient::angle_deg(&axis, &a.axis),
        )
    });
    Ok(Aimed {
        state,
        aim: a,
        truth,
    })
}

/// The JSON of the truth of an aim.
pub fn truth_json(heading: Heading, truth: Option<(Vector3<f64>, f64, f64)>) -> Value {
    truth.map_or(Value::Null, |(axis, err, miss)| {
        let (az, el) = heading.compass_of(&axis);
        json!({
            "true_tip_axis": [num(round(axis.x, 6)), num(round(axis.y, 6)), num(round(axis.z, 6))],
            "true_azimuth_deg": num(round(az, 3)),
            "true_elevation_deg": num(round(el, 3)),
            "true_error_deg": num(round(err, 3)),
            "model_miss_deg": num(round(miss, 3)),
        })
    })
}

/// Runs `host-tool aim`.
pub fn run(args: Args) -> Result<(), Failure> {
    let heading = args.heading;
    let (az, el) = match (args.toward, args.sun) {
        (Some(t), false) => t,
        (None, true) => {
            let (Some(lat), Some(lon)) = (args.lat, args.lon) else {
                return Err(Failure::usage("--sun needs --lat DEG and --lon DEG"));
            };
            let (site, air) = site_of(lat, lon)?;
            let t = instant(args.time).with_timezone(&Utc);
            sun_at(&site, &air, &t)?.map_err(|el| {
                Failure::Runtime(anyhow::anyhow!(
                    "the sun is below the horizon at {} (elevation {el:.2}°): nothing to aim at",
                    t.to_rfc3339(),
                ))
            })?
        }
        _ => {
            return Err(Failure::usage(
                "give --toward AZ,EL or --sun --lat DEG --lon DEG [--time RFC3339]",
            ))
        }
    };
    let on_crane = args.device.sim || args.device.port.is_some();
    if !on_crane && args.change_state {
        return Err(Failure::usage(
            "--change-state moves a crane: give --sim or --port",
        ));
    }
    let cfg = crane_config(&args.device);
    if args.device.sim {
        crate::cmd::task::calibrate_for_sim(&cfg)?;
    }
    let ws = crate::cmd::task::task_workspace(&cfg)?;
    let target = heading.base_of(az, el).into_inner();
    let head = json!({
        "target_azimuth_deg": num(az),
        "target_elevation_deg": num(el),
        "heading_deg": num(heading.deg()),
    });
    let mut link = if on_crane {
        Some(Link::open_recorded(
            &args.device,
            &WorldArgs::default().parse()?,
            args.record.as_deref(),
            "aim",
        )?)
    } else {
        None
    };
    let state = match (&mut link, args.state) {
        (Some(l), _) => l.status()?.state,
        (None, Some(s)) => s,
        (None, None) => TrunkState::new(TopState::Folded, BottomState::Deployed),
    };
    let here = aim_in(&ws, state, &target);
    let better = better_state(&ws, state, &target);
    let Some(mut link) = link.filter(|_| !args.dry_run) else {
        let mut v = head;
        merge(&mut v, aim_json(state, &here, better.as_ref()));
        v["moved"] = Value::Bool(false);
        if args.json {
            crate::cli::print_json(v);
        } else {
            print_aim(az, el, heading, state, &here);
            if let Some((s, a)) = &better {
                crate::out!(
                    "{s} aims closer (error {:.2}°, limit {:.1}°): --change-state takes it there first",
                    a.error_deg,
                    a.limit_deg
                );
            }
            let said = if on_crane {
                "(dry run: nothing was sent to the device)"
            } else {
                "computed only: nothing was sent to a crane (give --sim or --port to aim one)"
            };
            crate::out!("{said}");
        }
        return Ok(());
    };
    let r = aim_crane(&mut link, &cfg, heading, (az, el), args.change_state);
    let st = link.status().ok();
    link.close();
    let aimed = r?;
    let within = aimed.within_tolerance();
    if args.json {
        let mut v = head;
        merge(&mut v, aim_json(aimed.state, &aimed.aim, None));
        v["moved"] = Value::Bool(true);
        v["state_confirmed"] = json!(st.as_ref().map(|s| s.state_confirmed));
        v["sim"] = truth_json(heading, aimed.truth);
        v["sim_tolerance_deg"] = num(SIM_AXIS_TOLERANCE_DEG);
        v["ok"] = Value::Bool(within);
        crate::cli::print_json(v);
    } else {
        print_aim(az, el, heading, aimed.state, &aimed.aim);
        if let Some((_, e, miss)) = aimed.truth {
            crate::out!(
                "simulator: the true tip axis is {e:.2}° from the target (reported {:.2}°), {miss:.2}° from the model's (tolerance {SIM_AXIS_TOLERANCE_DEG}°){}",
                aimed.aim.error_deg,
                if within { "" } else { ": MISSED" }
            );
        }
    }
    if within {
        Ok(())
    } else {
        Err(Failure::Runtime(anyhow::anyhow!(
            "the true tip axis ended further from the model's than its {SIM_AXIS_TOLERANCE_DEG}° tolerance"
        )))
    }
}

fn merge(into: &mut Value, from: Value) {
    if let (Some(a), Value::Object(b)) = (into.as_object_mut(), from) {
        a.extend(b);
    }
}

fn print_aim(az: f64, el: f64, heading: Heading, state: TrunkState, a: &Aim) {
    crate::out!(
        "aim in {state} at azimuth {az:.2}°, elevation {el:.2}° (base x faces {}°): bend {:.2}° towards {:.1}° from base x (limit {:.1}°), tip axis error {:.2}°",
        crate::num::tidy(heading.deg()),
        a.bend_deg,
        a.direction_deg,
        a.limit_deg,
        a.error_deg
    );
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
    fn limits_are_the_held_limits_under_the_controllers() {
        let cfg = protocol::CraneGeometry::default();
        let ws = crate::cmd::pose::crane_workspace(&cfg).unwrap();
        let extra =
            (2.0 * f64::from(cfg.take_up_margin_mm) / f64::from(cfg.tendon_radius_mm)).to_degrees();
        let t = Heading::default().base_of(0.0, 0.0).into_inner();
        for s in TrunkState::ALL {
            let a = aim_in(&ws, s, &t);
            let want = cfg
                .bend_limit_deg(s)
                .map_or(0.0, |l| (f64::from(l) - extra).max(0.0));
            assert!((a.limit_deg - want).abs() < 1e-9, "{s}: {}", a.limit_deg);
            // The horizon is beyond every limit: the bend is the limit.
            assert!((a.bend_deg - want).abs() < 1e-9, "{s}");
        }
        assert!(parse_toward("360,10").is_err() && parse_toward("10,91").is_err());
        assert!(parse_toward("135,40").is_ok());
    }

    #[test]
    fn on_a_calibrated_model_the_predicted_axis_meets_a_target_within_reach() {
        use planner::task::Calibration;
        let cfg = protocol::CraneGeometry::default();
        let fd: TrunkState = "F&D".parse().unwrap();
        let c = Calibration {
            gain: 0.7,
            gain_between: 0.6,
            bottom_share: 0.3,
            sag_mm_per_rad: 4.0,
            lean_rad: 0.1,
        };
        let ws = crate::cmd::pose::crane_workspace(&cfg)
            .unwrap()
            .with_calibration(fd, c)
            .unwrap();
        let h = Heading::default();
        for (az, el) in [(90.0, 80.0), (200.0, 82.0), (330.0, 85.0)] {
            let t = h.base_of(az, el).into_inner();
            let a = aim_in(&ws, fd, &t);
            assert!(a.error_deg < 0.01, "{az},{el}: {a:?}");
            // The command is larger than the bend wanted (gain < 1) and within the limit.
            assert!(
                a.bend_deg > 90.0 - el && a.bend_deg <= a.limit_deg + 1e-9,
                "{a:?}"
            );
        }
        // Out of reach: the limit, and the error the model predicts there.
        let t = h.base_of(200.0, 20.0).into_inner();
        let a = aim_in(&ws, fd, &t);
        assert!(
            (a.bend_deg - a.limit_deg).abs() < 1e-6 && a.error_deg > 40.0,
            "{a:?}"
        );
    }
}
