//! `host-tool param get [NAME]` / `param set NAME VALUE`: read and change the device's tunable
//! parameters (pressure cap, servo limits and slew, telemetry rate, link timeout).

use clap::Subcommand;
use protocol::{ParamId, RejectReason, RequestBody, ResponseBody};
use serde_json::{json, Value};

use crate::device::{Connection, DeviceArgs};
use crate::failure::Failure;
use host::SessionError;

/// Arguments of `host-tool param`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub action: Action,
}

/// What `param` does.
#[derive(Debug, Subcommand)]
pub enum Action {
    /// Read one parameter, or all of them when NAME is omitted.
    Get {
        /// pressure-limit-kpa, servo-min-deg, servo-max-deg, servo-slew-deg-per-s,
        /// telemetry-hz or link-timeout-ms.
        #[arg(value_name = "NAME")]
        name: Option<String>,
        #[command(flatten)]
        device: DeviceArgs,
        /// Print one JSON object on stdout.
        #[arg(short = 'j', long)]
        json: bool,
    },
    /// Change one parameter (checked against its range before anything is sent).
    Set {
        /// pressure-limit-kpa, servo-min-deg, servo-max-deg, servo-slew-deg-per-s,
        /// telemetry-hz or link-timeout-ms.
        #[arg(value_name = "NAME")]
        name: String,
        /// The new value, in the parameter's unit.
        // Hyphen values allowed so a negative number reaches the range check (exit 2 with the
        // range) instead of being taken for an unknown flag.
        #[arg(value_name = "VALUE", allow_hyphen_values = true)]
        value: String,
        #[command(flatten)]
        device: DeviceArgs,
        /// Print one JSON object on stdout.
        #[arg(short = 'j', long)]
        json: bool,
    },
}

pub use host::text::{param_name, param_unit};

impl Args {
    /// Whether JSON was asked for.
    pub fn json(&self) -> bool {
        match &self.action {
            Action::Get { json, .. } | Action::Set { json, .. } => *json,
        }
    }
}

/// Parses a parameter name; the error lists the six valid names.
pub fn parse_param(name: &str) -> Result<ParamId, Failure> {
    ParamId::ALL
        .iter()
        .copied()
        .find(|&id| param_name(id) == name)
        .ok_or_else(|| {
            let names: Vec<&str> = ParamId::ALL.iter().map(|&id| param_name(id)).collect();
            Failure::usage(format!(
                "unknown parameter '{name}': valid names are {}",
                names.join(", ")
            ))
        })
}

/// Parses a value for `id` and checks it against the parameter's range (the device would
/// refuse it anyway; checking here gives the range in the message and sends nothing).
pub fn parse_value(id: ParamId, value: &str) -> Result<f32, Failure> {
    let (lo, hi) = id.range();
    let out_of_range = || {
        Failure::usage(format!(
            "invalid value '{value}' for {}: it must be a {}number from {} to {} {}",
            param_name(id),
            if id.is_integer() { "whole " } else { "" },
            lo,
            hi,
            param_unit(id)
        ))
    };
    let v: f32 = value.trim().parse().map_err(|_| out_of_range())?;
    if id.accepts(v) {
        Ok(v)
    } else {
        Err(out_of_range())
    }
}

/// An `f32` as JSON with its shortest decimal form (30.1, not 30.100000381469727).
fn json_f32(v: f32) -> Value {
    v.to_string()
        .parse::<f64>()
        .ok()
        .and_then(serde_json::Number::from_f64)
        .map_or(Value::Null, Value::Number)
}

/// A device failure (exit 1), with what the device's reason means for this parameter.
fn device_failure(id: ParamId, err: SessionError) -> Failure {
    let hint = match (&err, id) {
        (
            SessionError::Rejected {
                reason: RejectReason::OutOfRange,
                refusal: None,
                ..
            },
            ParamId::ServoMinDeg | ParamId::ServoMaxDeg,
        ) => " (servo-min-deg must not exceed servo-max-deg)",
        _ => "",
    };
    let mut e = crate::cli::DeviceError::session(&format!("{}: ", param_name(id)), &err);
    e.message += hint;
    Failure::Runtime(anyhow::Error::new(e))
}

/// The device, or the server that holds it.
enum Link {
    Direct(Box<Connection>),
    Server(std::path::PathBuf),
}

impl Link {
    fn open(device: &DeviceArgs) -> Result<Self, Failure> {
        Ok(match crate::client::server_for(device)? {
            Some(path) => Link::Server(path),
            None => Link::Direct(Box::new(device.validate(None)?.connect()?)),
        })
    }

    fn command(
        &mut self,
        body: RequestBody,
    ) -> Result<Result<ResponseBody, SessionError>, Failure> {
        match self {
            Link::Direct(conn) => Ok(conn.session.command(body)),
            Link::Server(path) => crate::client::call(path, body),
        }
    }

    fn close(self) {
        if let Link::Direct(conn) = self {
            conn.close();
        }
    }
}

/// Reads one parameter from the device.
fn get(conn: &mut Link, id: ParamId) -> Result<f32, Failure> {
    match conn
        .command(RequestBody::GetParam(id))?
        .map_err(|e| device_failure(id, e))?
    {
        ResponseBody::Param { id: got, value } if got == id => Ok(value),
        other => Err(Failure::Runtime(anyhow::anyhow!(
            "unexpected answer to GetParam({}): {other:?}",
            param_name(id)
        ))),
    }
}

/// One parameter as a JSON object.
fn param_json(id: ParamId, value: f32) -> Value {
    let (lo, hi) = id.range();
    json!({
        "name": param_name(id),
        "value": json_f32(value),
        "unit": param_unit(id),
        "min": json_f32(lo),
        "max": json_f32(hi),
    })
}

/// One parameter as a line of text.
fn param_line(id: ParamId, value: f32) -> String {
    let (lo, hi) = id.range();
    format!(
        "{:<22}{} {} (range {}–{})",
        param_name(id),
        value,
        param_unit(id),
        lo,
        hi
    )
}

/// Runs `host-tool param`.
pub fn run(args: Args) -> Result<(), Failure> {
    match args.action {
        Action::Get { name, device, json } => {
            // Everything the user typed is checked before a device is opened.
            let ids = match name {
                Some(n) => vec![parse_param(&n)?],
                None => ParamId::ALL.to_vec(),
            };
            let mut conn = Link::open(&device)?;
            let mut values = Vec::with_capacity(ids.len());
            for &id in &ids {
                values.push((id, get(&mut conn, id)?));
            }
            conn.close();
            if json {
                let params: Vec<Value> = values.iter().map(|&(id, v)| param_json(id, v)).collect();
                crate::cli::print_json(json!({ "params": params }));
            } else {
                for (id, v) in values {
                    crate::out!("{}", param_line(id, v));
                }
            }
            Ok(())
        }
        Action::Set {
            name,
            value,
            device,
            json,
        } => {
            let id = parse_param(&name)?;
            let value = parse_value(id, &value)?;
            let mut conn = Link::open(&device)?;
            let previous = get(&mut conn, id)?;
            let now = match conn
                .command(RequestBody::SetParam { id, value })?
                .map_err(|e| device_failure(id, e))?
            {
                ResponseBody::Param { id: got, value } if got == id => value,
                // The device confirms a write with the value it now holds; read it if not.
                _ => get(&mut conn, id)?,
            };
            conn.close();
            if json {
                let mut v = param_json(id, now);
                v["previous"] = json_f32(previous);
                crate::cli::print_json(v);
            } else {
                crate::out!(
                    "{} set: {} {} (was {} {})",
                    param_name(id),
                    now,
                    param_unit(id),
                    previous,
                    param_unit(id)
                );
            }
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_round_trips_and_names_are_distinct() {
        for id in ParamId::ALL {
            assert_eq!(parse_param(param_name(id)).unwrap(), id);
        }
        let Err(Failure::Usage(msg)) = parse_param("pressure_limit_kpa") else {
            panic!("snake case is not a valid name")
        };
        for id in ParamId::ALL {
            assert!(msg.contains(param_name(id)), "{msg}");
        }
    }

    #[test]
    fn values_are_checked_against_the_range_with_its_bounds_in_the_message() {
        assert_eq!(parse_value(ParamId::PressureLimitKpa, "30").unwrap(), 30.0);
        assert_eq!(parse_value(ParamId::PressureLimitKpa, "60").unwrap(), 60.0);
        for bad in ["60.5", "-1", "NaN", "inf", "thirty", ""] {
            let Err(Failure::Usage(msg)) = parse_value(ParamId::PressureLimitKpa, bad) else {
                panic!("{bad} accepted")
            };
            assert!(msg.contains("from 0 to 60 kPa"), "{msg}");
        }
        assert!(parse_value(ParamId::LinkTimeoutMs, "199").is_err());
    }

    #[test]
    fn a_device_refusal_is_a_runtime_failure_with_its_reason() {
        let err = SessionError::Rejected {
            request: "SetParam",
            reason: RejectReason::OutOfRange,
            refusal: None,
        };
        let Failure::Runtime(e) = device_failure(ParamId::ServoMinDeg, err) else {
            panic!("a refusal is exit 1")
        };
        let msg = format!("{e:#}");
        assert!(msg.contains("a value is out of range"), "{msg}");
        assert!(msg.contains("must not exceed servo-max-deg"), "{msg}");
        // A device that names the field: its value and the limit are in the message.
        let err = SessionError::Rejected {
            request: "SetParam",
            reason: RejectReason::OutOfRange,
            refusal: Some(protocol::Refusal {
                step: None,
                field: protocol::RefusedField::Param(ParamId::ServoMinDeg),
                value: 120.0,
                limit: 100.0,
            }),
        };
        let Failure::Runtime(e) = device_failure(ParamId::ServoMinDeg, err) else {
            panic!("a refusal is exit 1")
        };
        let msg = format!("{e:#}");
        assert!(
            msg.contains("servo-min-deg 120 deg would pass servo-max-deg = 100 deg"),
            "{msg}"
        );
    }

    #[test]
    fn json_values_keep_their_short_decimal_form() {
        assert_eq!(json_f32(30.1).to_string(), "30.1");
        assert_eq!(json_f32(f32::NAN), Value::Null);
    }
}
