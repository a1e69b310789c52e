//! `host-tool track --sun`: the crane's panel follows the sun through a day — every `--every`
//! from `--time` to `--until` it aims again ([`crate::cmd::aim::aim_crane`]); with the sun
//! under the horizon it straightens and waits. On the simulator the day runs on its virtual
//! clock (as fast as the CPU allows, or paced by `--sim-speed`), recorded like any session.
//! Ctrl-C (SIGINT, SIGTERM, SIGHUP) aborts a bend under way and ends with the crane in its
//! safe state (docs/sun.md, "track").

use std::sync::atomic::Ordering;

use chrono::{DateTime, Duration, FixedOffset, NaiveTime, Utc};
use planner::sun;
use serde_json::{json, Value};

use crate::cmd::aim::{self, SIM_AXIS_TOLERANCE_DEG};
use crate::cmd::prim::{bend_step, crane_config, run_step, Link};
use crate::cmd::task::WorldArgs;
use crate::device::DeviceArgs;
use crate::failure::Failure;

/// The longest day `track` plans: from `--time` to `--until` at most this long.
pub const MAX_SPAN_H: i64 = 48;

/// Arguments of `host-tool track`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Follow the sun (the only target `track` has; may be left out).
    #[arg(long)]
    pub sun: bool,
    /// Latitude, degrees north, [-90, 90].
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::latitude)]
    pub lat: f64,
    /// Longitude, degrees east, [-180, 180].
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::longitude)]
    pub lon: f64,
    /// When tracking starts, RFC 3339 with its offset (default now); with --sim the virtual
    /// day starts here.
    #[arg(long, value_parser = crate::arg::usage(super::sun::parse_time))]
    pub time: Option<DateTime<FixedOffset>>,
    /// When it ends: local HH:MM in --time's offset (the next such time after the start), or
    /// RFC 3339; at most 48 h after the start.
    #[arg(long)]
    pub until: String,
    /// Time between aims: a whole number with s, m or h (e.g. 10m), 1 s to 24 h.
    #[arg(long, default_value = "10m",
          value_parser = crate::arg::usage(|s: &str| super::sun::time_arg("--every", sun::parse_duration, s)))]
    pub every: Duration,
    /// Compass heading of the crane base's x axis (tendon 0's side), degrees from north.
    #[arg(long, default_value = "90", allow_hyphen_values = true,
          value_parser = crate::arg::heading)]
    pub heading: geometry::orient::Heading,
    /// When another state aims closer, go there first (the planner's cheapest plan).
    #[arg(long)]
    pub change_state: bool,
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Record the session to this MCAP file (`host-tool log` reads it).
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<std::path::PathBuf>,
    /// Print JSON Lines: one object per aim, then a summary object (`"summary": true`).
    #[arg(skip)]
    pub json: bool,
}

/// Parses `--until` against the start.
pub fn parse_until(
    text: &str,
    start: &DateTime<FixedOffset>,
) -> Result<DateTime<FixedOffset>, Failure> {
    let t = text.trim();
    let end = if let Ok(hm) = NaiveTime::parse_from_str(t, "%H:%M") {
        let day = start.date_naive();
        let at = |d: chrono::NaiveDate| d.and_time(hm).and_local_timezone(*start.offset()).single();
        match at(day) {
            Some(e) if e > *start => e,
            _ => day
                .succ_opt()
                .and_then(at)
                .ok_or_else(|| Failure::usage(format!("--until '{text}': no such time")))?,
        }
    } else {
        sun::parse_instant(t).map_err(|e| {
            Failure::usage(format!(
                "--until: expected local HH:MM or an RFC 3339 time: {e}"
            ))
        })?
    };
    if end <= *start {
        return Err(Failure::usage(format!(
            "--until {} is not after the start {}",
            end.to_rfc3339(),
            start.to_rfc3339()
        )));
    }
    if end - *start > Duration::hours(MAX_SPAN_H) {
        return Err(Failure::usage(format!(
            "--until {} is more than {MAX_SPAN_H} h after the start {}: track plans at most two days at a time",
            end.to_rfc3339(),
            start.to_rfc3339()
        )));
    }
    Ok(end)
}

/// Lets the link's clock reach `at_ms`, in slices that notice Ctrl-C (then the failure says
/// `interrupted {during}: nothing was moving; …`).
pub fn wait_until(link: &mut Link, at_ms: u64, during: &str) -> Result<(), Failure> {
    let interrupted = crate::shell::interrupt_flag();
    loop {
        if interrupted.load(Ordering::SeqCst) {
            return Err(Failure::Interrupted(format!(
                "interrupted {during}: nothing was moving; the crane holds its bend"
            )));
        }
        let now = link.now_ms();
        if now >= at_ms {
            return Ok(());
        }
        link.wait((at_ms - now).min(500))?;
    }
}

fn emit(json_out: bool, v: &Value, text: &str) {
    if json_out {
        crate::cli::print_json(v.clone());
    } else {
        crate::out!("{text}");
    }
}

/// Runs `host-tool track`.
pub fn run(args: Args) -> Result<(), Failure> {
    let heading = args.heading;
    let (site, air) = aim::site_of(args.lat, args.lon)?;
    let start = aim::instant(args.time);
    let end = parse_until(&args.until, &start)?;
    let every = args.every;
    if !(args.device.sim || args.device.port.is_some()) {
        return Err(Failure::usage(
            "track moves a crane: give --sim or --port (aim --sun computes one aim without one)",
        ));
    }
    let cfg = crane_config(&args.device);
    if args.device.sim {
        crate::cmd::task::calibrate_for_sim(&cfg)?;
    }
    let ws = crate::cmd::task::task_workspace(&cfg)?;
    let mut link = Link::open_recorded(
        &args.device,
        &WorldArgs::default().parse()?,
        args.record.as_deref(),
        "track",
    )?;
    let t0 = link.now_ms();
    let every_ms = every.num_milliseconds().max(1) as u64;
    let mut aims = 0u32;
    let mut missed = 0u32;
    let mut worst_true = 0.0f64;
    let mut errors = Vec::new();
    let result = (|| -> Result<(), Failure> {
        for k in 0u64.. {
            let at = start + Duration::milliseconds((k * every_ms) as i64);
            if at > end {
                return Ok(());
            }
            wait_until(&mut link, t0 + k * every_ms, "between aims")?;
            let utc = at.with_timezone(&Utc);
            let local = at.format("%Y-%m-%d %H:%M:%S%:z").to_string();
            match aim::sun_at(&site, &air, &utc)? {
                Err(el) => {
                    let st = link.status()?;
                    let mut straightened = false;
                    if st.state.is_flexible() && crate::cmd::prim::blocked(&st).is_none() {
                        let (step, _) = bend_step(&ws, &cfg, st.state, 0.0, 0.0)?;
                        let end = run_step(&mut link, step)?;
                        if let Some(e) = end.error {
                            return Err(Failure::Runtime(anyhow::anyhow!("straightening: {e}")));
                        }
                        straightened = true;
                    }
                    emit(
                        args.json,
                        &json!({"time": at.to_rfc3339(), "sun_up": false,
                                "sun_elevation_deg": aim::round(el, 2),
                                "straightened": straightened}),
                        &format!(
                            "{local}  the sun is below the horizon (elevation {el:.2}°){}",
                            if straightened { ": straightened" } else { "" }
                        ),
                    );
                }
                Ok((az, el)) => {
                    let a = aim::aim_crane(&mut link, &cfg, heading, (az, el), args.change_state)?;
                    aims += 1;
                    let within = a.within_tolerance();
                    if !within {
                        missed += 1;
                    }
                    if let Some((_, _, miss)) = a.truth {
                        worst_true = worst_true.max(miss);
                    }
                    let mut v = json!({"time": at.to_rfc3339(), "sun_up": true,
                                       "sun_azimuth_deg": aim::round(az, 3),
                                       "sun_elevation_deg": aim::round(el, 3)});
                    if let (Some(o), Value::Object(b)) =
                        (v.as_object_mut(), aim::aim_json(a.state, &a.aim, None))
                    {
                        o.extend(b);
                    }
                    v["sim"] = aim::truth_json(heading, a.truth);
                    let truth = a.truth.map_or(String::new(), |(_, e, miss)| {
                        format!(
                            "; simulator: true error {e:.2}°, {miss:.2}° from the model's{}",
                            if within { "" } else { " MISSED" }
                        )
                    });
                    emit(
                        args.json,
                        &v,
                        &format!(
                            "{local}  sun az {az:.1}° el {el:.1}°: {} bent {:.2}° toward {:.1}°, error {:.2}°{truth}",
                            a.state, a.aim.bend_deg, a.aim.direction_deg, a.aim.error_deg
                        ),
                    );
                }
            }
        }
        Ok(())
    })();
    if let Err(e) = &result {
        errors.push(crate::cmd::reach::failure_text(e));
    }
    let st = link.status().ok();
    link.close();
    let ok = result.is_ok() && missed == 0;
    let sim = args.device.sim;
    if args.json {
        crate::cli::print_json(json!({
            "summary": true,
            "ok": ok,
            "aims": aims,
            "missed": missed,
            "worst_model_miss_deg": sim.then_some(aim::round(worst_true, 2)),
            "state": st.as_ref().map(|s| s.state.name()),
            "state_confirmed": st.as_ref().map(|s| s.state_confirmed),
            "error": errors.first(),
        }));
    } else {
        crate::out!(
            "{aims} aims from {} to {}{}",
            start.to_rfc3339(),
            end.to_rfc3339(),
            if sim {
                format!(
                    "; simulator: the true tip axis at most {worst_true:.2}° from the model's, {missed} beyond its {SIM_AXIS_TOLERANCE_DEG}° tolerance"
                )
            } else {
                String::new()
            }
        );
    }
    result?;
    if missed == 0 {
        Ok(())
    } else {
        Err(Failure::Runtime(anyhow::anyhow!(
            "{missed} of {aims} aims left the true tip axis further than {SIM_AXIS_TOLERANCE_DEG}° from the model's"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn until_is_the_next_local_time_or_an_instant_within_two_days() {
        let s = sun::parse_instant("2025-06-21T09:00-04:00").unwrap();
        assert_eq!(
            parse_until("20:00", &s).unwrap().to_rfc3339(),
            "2025-06-21T20:00:00-04:00"
        );
        // Before the start's clock time: the next day.
        assert_eq!(
            parse_until("08:00", &s).unwrap().to_rfc3339(),
            "2025-06-22T08:00:00-04:00"
        );
        assert!(parse_until("2025-06-21T08:00-04:00", &s).is_err());
        assert!(parse_until("2025-06-23T09:00-04:00", &s).is_ok());
        assert!(parse_until("2025-06-23T09:01-04:00", &s).is_err());
        assert!(parse_until("25:00", &s).is_err());
    }
}
