//! clap value parsers for the names the commands take, and the bridge that lets a command's
//! own `&str → Result<T, Failure>` parser (`--n`, `--beta`, `--modules`, …) be one: every
//! value is parsed by clap, so a bad one is a usage error (exit 2, clap's
//! `invalid value 'X' for '--flag <V>': <reason>`) before anything is opened, and the value
//! a command receives is already typed. The numbers' range parsers are `crate::num`'s.

use std::str::FromStr;

use geometry::TrunkState;

use crate::failure::Failure;

/// A clap value parser from a parser whose refusal is a [`Failure`]: its message is clap's
/// reason.
pub fn usage<T, F>(parse: F) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    F: Fn(&str) -> Result<T, Failure> + Clone + Send + Sync + 'static,
{
    move |s: &str| {
        parse(s).map_err(|e| match e {
            Failure::Usage(m) | Failure::Interrupted(m) => m,
            Failure::Runtime(e) => format!("{e:#}"),
        })
    }
}

/// A trunk state (`D&F`; any case, `-` for `&`); the refusal lists the six, with the hint
/// for a shell that cut the word at an unquoted `&`.
pub fn trunk_state(s: &str) -> Result<TrunkState, String> {
    TrunkState::from_str(s).map_err(|e| format!("{e}{}", hil_sim::cli::ampersand_hint(s)))
}

/// A simulator fault's name; the refusal lists the valid ones.
pub fn fault(s: &str) -> Result<hil_sim::Fault, String> {
    hil_sim::Fault::from_str(s).map_err(|e| e.to_string())
}

/// A compass heading in degrees clockwise from north (`--heading`): any finite number,
/// reduced to [0, 360).
pub fn heading(s: &str) -> Result<geometry::orient::Heading, String> {
    let v = s
        .trim()
        .parse::<f64>()
        .map_err(|_| format!("--heading: '{s}' is not a number of degrees"))?;
    geometry::orient::Heading::from_deg(v).map_err(|e| format!("--heading: {e}"))
}

/// A site's number as `flag`, checked by the sun's own rule (`planner::sun`): the refusal is
/// its message.
fn site_number(
    flag: &str,
    expected: &str,
    s: &str,
    check: impl Fn(f64) -> Result<(), planner::sun::SunError>,
) -> Result<f64, String> {
    let v = s
        .trim()
        .parse::<f64>()
        .map_err(|_| format!("{flag}: '{s}' is not a number: expected {expected}"))?;
    check(v).map(|()| v).map_err(|e| format!("{flag}: {e}"))
}

/// `--lat`: degrees north, [-90, 90].
pub fn latitude(s: &str) -> Result<f64, String> {
    site_number("--lat", "degrees in [-90°, 90°]", s, |v| {
        planner::sun::Site::new(v, 0.0, 0.0).map(drop)
    })
}

/// `--lon`: degrees east, [-180, 180].
pub fn longitude(s: &str) -> Result<f64, String> {
    site_number("--lon", "degrees in [-180°, 180°]", s, |v| {
        planner::sun::Site::new(0.0, v, 0.0).map(drop)
    })
}

/// `--elevation-m`: metres above sea level, [-500, 10000].
pub fn elevation_m(s: &str) -> Result<f64, String> {
    site_number("--elevation-m", "metres in [-500, 10000] m", s, |v| {
        planner::sun::Site::new(0.0, 0.0, v).map(drop)
    })
}

/// `--delta-t`: ΔT = TT − UT1 in seconds, [-10000, 10000].
pub fn delta_t(s: &str) -> Result<f64, String> {
    site_number("--delta-t", "seconds in [-10000, 10000] s", s, |v| {
        planner::sun::DeltaT::seconds(v).map(drop)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_state_name_is_accepted_in_each_spelling_and_others_are_refused_with_the_six() {
        for s in TrunkState::ALL {
            let name = s.name();
            assert_eq!(trunk_state(name), Ok(s));
            assert_eq!(trunk_state(&name.replace('&', "-")), Ok(s));
            assert_eq!(trunk_state(&name.to_lowercase()), Ok(s));
            assert_eq!(trunk_state(&format!(" {name} ")), Ok(s));
        }
        for bad in ["X&Y", "", "D", "D&", "DF", "D&F&P"] {
            let e = trunk_state(bad).expect_err(bad);
            assert!(e.contains(geometry::trunk::VALID_STATES_TEXT), "{bad}: {e}");
        }
        // A shell that ran `D&F` unquoted left `D`: the hint says to quote it.
        assert!(
            trunk_state("D").unwrap_err().contains("quote"),
            "{:?}",
            trunk_state("D")
        );
    }

    #[test]
    fn a_usage_failure_becomes_clap_reason_word_for_word() {
        let p = usage(|s: &str| {
            s.parse::<u8>()
                .map_err(|_| Failure::usage(format!("--x must be a byte, got '{s}'")))
        });
        assert_eq!(p("7"), Ok(7));
        assert_eq!(p("300"), Err("--x must be a byte, got '300'".to_string()));
    }

    #[test]
    fn fault_names_parse_and_a_bad_one_lists_them() {
        assert!(fault("leak").is_ok());
        let e = fault("gremlins").unwrap_err();
        assert!(e.contains("servo-stall"), "{e}");
    }

    /// The command line `args` parsed by host-tool's own clap definitions (nothing runs).
    fn parse(args: &[&str]) -> Result<crate::Cli, clap::Error> {
        use clap::Parser as _;
        crate::Cli::try_parse_from(std::iter::once("host-tool").chain(args.iter().copied()))
    }

    /// Each option with the rest of a valid command line, values at both ends of what it
    /// accepts, and values just past them with a fragment of the reason clap then gives.
    struct Case {
        line: &'static [&'static str],
        flag: &'static str,
        ok: &'static [&'static str],
        refused: &'static [&'static str],
        why: &'static str,
    }

    const FK: &[&str] = &["fk", "--n", "3", "--beta", "35", "--states", "deployed"];
    const IK: &[&str] = &[
        "ik",
        "--n",
        "3",
        "--beta",
        "35",
        "--modules",
        "4",
        "--target",
        "helix",
    ];
    const DESIGN: &[&str] = &["design", "--n", "3"];
    const STATION: &[&str] = &["station", "--lat", "37", "--lon", "-80", "--modules", "64"];
    const STATES: &[&str] = &["states", "--n", "3", "--beta", "35"];
    const SUN: &[&str] = &["sun", "--lat", "37", "--lon", "-80"];

    const CASES: &[Case] = &[
        Case {
            line: FK,
            flag: "--n",
            ok: &["3", "64", " 7 "],
            refused: &["2", "65", "3.5", "-3", "x"],
            why: "--n must be an integer in [3, 64]",
        },
        Case {
            line: FK,
            flag: "--beta",
            ok: &["0.001", "89.999", "35,31.72"],
            refused: &["0", "90", "NaN", "inf", "35,", "x"],
            why: "--beta must be",
        },
        Case {
            line: FK,
            flag: "--edge-mm",
            ok: &["0.001", "10000"],
            refused: &["0", "10000.001", "-1", "inf"],
            why: "--edge-mm must be a length in mm in (0, 10000]",
        },
        Case {
            line: STATES,
            flag: "--n",
            ok: &["3", "64"],
            refused: &["2", "65"],
            why: "--n must be an integer in [3, 64]",
        },
        Case {
            line: STATES,
            flag: "--beta",
            ok: &["0.001", "89.999"],
            refused: &["0", "90"],
            why: "--beta must be",
        },
        Case {
            line: STATES,
            flag: "--edge-mm",
            ok: &["0.001", "10000"],
            refused: &["0", "10001"],
            why: "--edge-mm must be",
        },
        Case {
            line: &["pattern"],
            flag: "--n",
            ok: &["3", "64"],
            refused: &["2", "65"],
            why: "--n must be an integer in [3, 64]",
        },
        Case {
            line: &["pattern"],
            flag: "--beta",
            ok: &["35", "35,31.72"],
            refused: &["90", "35,,31"],
            why: "--beta must be",
        },
        Case {
            line: IK,
            flag: "--modules",
            ok: &["1", "10000"],
            refused: &["0", "10001", "-1", "2.5"],
            why: "--modules must be an integer in [1, 10000]",
        },
        Case {
            line: IK,
            flag: "--beam-width",
            ok: &["1", "1000000"],
            refused: &["0", "1000001"],
            why: "--beam-width must be an integer in [1, 1000000]",
        },
        Case {
            line: IK,
            flag: "--window-width",
            ok: &["1", "6"],
            refused: &["0", "7"],
            why: "--window-width must be an integer in [1, 6]",
        },
        Case {
            line: IK,
            flag: "--dp-max-states",
            ok: &["1", "100000000"],
            refused: &["0", "100000001"],
            why: "--dp-max-states must be an integer in [1, 100000000]",
        },
        Case {
            line: IK,
            flag: "--time-limit",
            ok: &["0.001", "1000000"],
            refused: &["0", "1000001", "-1", "x"],
            why: "--time-limit must be a number of seconds in (0, 1000000]",
        },
        Case {
            line: IK,
            flag: "--gap",
            ok: &["0", "0.999"],
            refused: &["1", "-0.01", "NaN"],
            why: "--gap must be a fraction in [0, 1)",
        },
        Case {
            line: IK,
            flag: "--metric",
            ok: &["eq36", "ordered"],
            refused: &["rms"],
            why: "valid metrics are eq36, ordered",
        },
        Case {
            line: IK,
            flag: "--edge-mm",
            ok: &["0.001", "10000"],
            refused: &["0", "10001"],
            why: "--edge-mm must be",
        },
        Case {
            line: DESIGN,
            flag: "--samples",
            ok: &["1", "100"],
            refused: &["0", "101"],
            why: "--samples must be an integer in [1, 100]",
        },
        Case {
            line: DESIGN,
            flag: "--certify",
            ok: &["0", "20"],
            refused: &["21", "-1"],
            why: "--certify must be an integer in [0, 20]",
        },
        Case {
            line: DESIGN,
            flag: "--modules",
            ok: &["1", "10000"],
            refused: &["0", "10001"],
            why: "--modules must be an integer in [1, 10000]",
        },
        Case {
            line: DESIGN,
            flag: "--time-limit",
            ok: &["0.001", "1000000"],
            refused: &["0", "1000001"],
            why: "--time-limit must be",
        },
        Case {
            line: DESIGN,
            flag: "--metric",
            ok: &["eq36", "ordered"],
            refused: &["rms"],
            why: "valid metrics are eq36, ordered",
        },
        Case {
            line: DESIGN,
            flag: "--edge-mm",
            ok: &["0.001", "10000"],
            refused: &["0", "10001"],
            why: "--edge-mm must be",
        },
        Case {
            line: &["station", "--lat", "37", "--lon", "-80"],
            flag: "--modules",
            ok: &["1", "64"],
            refused: &["0", "65"],
            why: "--modules must be an integer in [1, 64]",
        },
        Case {
            line: STATION,
            flag: "--adjustable",
            ok: &["1", "64"],
            refused: &["0", "65"],
            why: "--adjustable must be an integer in [1, 64]",
        },
        Case {
            line: STATION,
            flag: "--n",
            ok: &["3", "64"],
            refused: &["2", "65"],
            why: "--n must be",
        },
        Case {
            line: STATION,
            flag: "--beta",
            ok: &["0.001", "89.999"],
            refused: &["0", "90"],
            why: "--beta must be",
        },
        Case {
            line: STATION,
            flag: "--max-changes",
            ok: &["0", "999999999"],
            refused: &["-1", "2.5", "1000000000"],
            why: "--max-changes must be a whole number of refolds",
        },
        Case {
            line: &["workspace"],
            flag: "--samples",
            ok: &["2", "10000"],
            refused: &["1", "10001", "2.5"],
            why: "from 2 to 10000",
        },
        Case {
            line: &["pose"],
            flag: "--bend",
            ok: &["0,0", "180,-720"],
            refused: &["20", "20,x", "inf,0"],
            why: "expected ANGLE,DIRECTION in degrees",
        },
        Case {
            line: &["reach"],
            flag: "--point",
            ok: &["30,0,140", "-1e3,0,0"],
            refused: &["1,2", "1,2,3,4", "1,2,nan"],
            why: "expected X,Y,Z in mm",
        },
        Case {
            line: &["reach", "--point", "30,0,140"],
            flag: "--tolerance",
            ok: &["0.001", "1e6"],
            refused: &["0", "-1", "inf"],
            why: "expected a distance in mm > 0",
        },
        Case {
            line: &["pick", "--place", "0,0,1"],
            flag: "--at",
            ok: &["30,0,140"],
            refused: &["30,0"],
            why: "invalid --at",
        },
        Case {
            line: &["pick", "--at", "0,0,1"],
            flag: "--place",
            ok: &["30,0,140"],
            refused: &["30,0"],
            why: "invalid --place",
        },
        Case {
            line: &["pick", "--at", "0,0,1", "--place", "0,0,1"],
            flag: "--tolerance",
            ok: &["0.001"],
            refused: &["0"],
            why: "expected a distance in mm > 0",
        },
        Case {
            line: &["aim"],
            flag: "--toward",
            ok: &["0,-90", "359.999,90"],
            refused: &["360,0", "0,90.1", "-0.1,0", "10"],
            why: "--toward must be AZ,EL",
        },
        Case {
            line: &["aim", "--toward", "10,10"],
            flag: "--state",
            ok: &["F&P", "D&D", "d-f"],
            refused: &["X&Y"],
            why: "unknown trunk state",
        },
        Case {
            line: &["plan", "--sim"],
            flag: "--target",
            ok: &["F&P", "D&D", "d-f", "F-D"],
            refused: &["X&Y", "D", ""],
            why: "valid states are F&P, F&F, F&D, D&P, D&F, D&D",
        },
        Case {
            line: &["plan", "--target", "D&D", "--dry-run"],
            flag: "--from",
            ok: &["F&P", "D&F"],
            refused: &["X&Y"],
            why: "valid states are",
        },
        Case {
            line: &["plan", "--target", "D&D"],
            flag: "--sim-initial",
            ok: &["F&P", "D&D"],
            refused: &["X&Y"],
            why: "valid states are",
        },
        Case {
            line: &["plan", "--target", "D&D"],
            flag: "--sim-fault",
            ok: &["leak", "line-noise"],
            refused: &["gremlins"],
            why: "valve-stuck-closed",
        },
        Case {
            line: &["pose"],
            flag: "--state",
            ok: &["F&P", "D&D"],
            refused: &["X&Y"],
            why: "valid states are",
        },
        Case {
            line: &["workspace"],
            flag: "--state",
            ok: &["F&P", "D&D"],
            refused: &["X&Y"],
            why: "valid states are",
        },
        Case {
            line: &["bend", "20"],
            flag: "--toward",
            ok: &["0", "-720", "359.9"],
            refused: &["x", "inf"],
            why: "expected a number of degrees",
        },
        Case {
            line: &["serve", "--sim"],
            flag: "--rate",
            ok: &["1", "50"],
            refused: &["0", "51", "2.5"],
            why: "from 1 to 50",
        },
        Case {
            line: &["serve", "--sim"],
            flag: "--foxglove",
            ok: &["127.0.0.1:0", "localhost:65535", "[::1]:8765"],
            refused: &["127.0.0.1", "1.2.3.4:65536", ":80", "::1:80", "host:80"],
            why: "invalid --foxglove",
        },
        Case {
            line: &["design"],
            flag: "--n",
            ok: &["3", "64", "3..8", "6,3,4"],
            refused: &["2", "65", "5..3", "2..4", "x"],
            why: "--n must be an integer, a list (3,4,6) or a range (3..8)",
        },
        Case {
            line: IK,
            flag: "--dp-tolerance",
            ok: &["0,0", "1e3,360"],
            refused: &["a,b", "-1,0", "1", "1,2,3", "inf,0"],
            why: "--dp-tolerance must be POSITION,ANGLE",
        },
        Case {
            line: &["grip", "open", "--sim"],
            flag: "--tip-load-kg",
            ok: &["0", "50"],
            refused: &["-1", "50.1", "NaN"],
            why: "expected a mass in kg in [0, 50]",
        },
        Case {
            line: IK,
            flag: "--algo",
            ok: &["exact", "exhaustive", "greedy", "beam", "window", "dp"],
            refused: &["annealing"],
            why: "valid algorithms are exact",
        },
        Case {
            line: &["pattern", "--svg", "x.svg"],
            flag: "--legend",
            ok: &["below", "right", "none"],
            refused: &["left"],
            why: "--legend:",
        },
        Case {
            line: &["pattern", "--page-dir", "d"],
            flag: "--page",
            ok: &["a4", "letter"],
            refused: &["a3"],
            why: "--page:",
        },
        Case {
            line: &["pattern", "--parts", "d"],
            flag: "--parts-format",
            ok: &["stl", "3mf", "both"],
            refused: &["obj"],
            why: "--parts-format must be stl, 3mf or both",
        },
        Case {
            line: SUN,
            flag: "--time",
            ok: &["2025-06-21T12:00:00-04:00", "2025-06-21T16:00:00Z"],
            refused: &["noon", "2025-06-21T12:00:00"],
            why: "--time:",
        },
        Case {
            line: SUN,
            flag: "--date",
            ok: &["2025-06-21", "2000-02-29"],
            refused: &["2025-13-01", "2025-02-29", "21/06/2025"],
            why: "--date:",
        },
        Case {
            line: SUN,
            flag: "--tz",
            ok: &["-04:00", "Z", "+05:30"],
            refused: &["4", "EDT"],
            why: "--tz:",
        },
        Case {
            line: SUN,
            flag: "--from",
            ok: &["00:00", "23:59"],
            refused: &["24:00", "9am"],
            why: "--from:",
        },
        Case {
            line: SUN,
            flag: "--to",
            ok: &["00:00", "23:59"],
            refused: &["25:00"],
            why: "--to:",
        },
        Case {
            line: SUN,
            flag: "--every",
            ok: &["1s", "24h", "1h30m"],
            refused: &["0s", "25h", "10"],
            why: "--every:",
        },
        Case {
            line: &["aim", "--sun", "--lat", "37", "--lon", "-80"],
            flag: "--time",
            ok: &["2025-06-21T12:00:00-04:00"],
            refused: &["noon"],
            why: "--time:",
        },
        Case {
            line: &["track", "--lat", "37", "--lon", "-80", "--until", "18:00"],
            flag: "--every",
            ok: &["1s", "24h"],
            refused: &["0s", "25h"],
            why: "--every:",
        },
        Case {
            line: &["grip", "open", "--sim"],
            flag: "--object",
            ok: &["cup:40,0,60,0.1", "b:0,0,0"],
            refused: &["cup", "cup:0,0,-5", "cup:1,2"],
            why: "invalid --object",
        },
    ];

    #[test]
    fn every_moved_option_takes_both_ends_of_its_range_and_refuses_past_them_as_usage() {
        for c in CASES {
            // `pose` needs --state; the cases of --state give it themselves.
            let needs_state = c.line == ["pose"] && c.flag != "--state";
            let with = |v: &'static str| {
                // The line without its own value of the flag, if it has one.
                let mut a: Vec<&str> = Vec::new();
                let mut it = c.line.iter();
                while let Some(&w) = it.next() {
                    if w == c.flag {
                        it.next();
                    } else {
                        a.push(w);
                    }
                }
                if needs_state {
                    a.extend(["--state", "D&F"]);
                }
                a.extend([c.flag, v]);
                a
            };
            for v in c.ok {
                let a = with(v);
                if let Err(e) = parse(&a) {
                    panic!("{a:?} refused: {e}");
                }
            }
            for v in c.refused {
                let a = with(v);
                let e = match parse(&a) {
                    Ok(_) => panic!("{a:?} accepted"),
                    Err(e) => e,
                };
                assert_eq!(
                    e.kind(),
                    clap::error::ErrorKind::ValueValidation,
                    "{a:?}: {e}"
                );
                assert_eq!(e.exit_code(), 2, "{a:?}");
                let msg = e.to_string();
                assert!(msg.contains(c.why), "{a:?}: {msg}");
                assert!(msg.contains(&format!("for '{}", c.flag)), "{a:?}: {msg}");
            }
        }
    }

    #[test]
    fn positional_state_angle_and_parameter_names_are_parsed_by_clap_too() {
        for name in ["pressure-limit-kpa", "telemetry-hz", "link-timeout-ms"] {
            assert!(parse(&["param", "get", name, "--sim"]).is_ok(), "{name}");
            assert!(
                parse(&["param", "set", name, "1", "--sim"]).is_ok(),
                "{name}"
            );
        }
        for action in [
            &["param", "get", "nope"][..],
            &["param", "set", "nope", "1"],
        ] {
            let e = parse(action).map(|_| ()).unwrap_err();
            assert_eq!(e.kind(), clap::error::ErrorKind::ValueValidation, "{e}");
            assert!(
                e.to_string().contains("valid names are pressure-limit-kpa"),
                "{e}"
            );
        }
        assert!(parse(&["declare", "d&f"]).is_ok());
        let e = parse(&["declare", "X&Y"]).map(|_| ()).unwrap_err();
        assert!(e.to_string().contains("valid states are"), "{e}");
        for ok in ["0", "179.5"] {
            assert!(parse(&["bend", ok, "--toward", "0"]).is_ok(), "{ok}");
        }
        for bad in ["-1", "nan", "x"] {
            let e = parse(&["bend", bad, "--toward", "0"])
                .map(|_| ())
                .unwrap_err();
            assert_eq!(
                e.kind(),
                clap::error::ErrorKind::ValueValidation,
                "{bad}: {e}"
            );
            assert!(e.to_string().contains("ANGLE"), "{bad}: {e}");
        }
    }
}
