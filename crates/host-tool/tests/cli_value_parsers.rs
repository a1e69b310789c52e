//! The numbers and names clap's value parsers check, through the real binary: each option's
//! lowest and highest accepted values run the command, and the values just past them are a
//! usage error (exit 2) naming the option, the value and the range before anything runs.

#[path = "support/cli.rs"]
mod cli;

use cli::{cmd, temp};

/// One option: the rest of a command line that runs, values the parser accepts (the command
/// then exits with `ok_exit`; the stderr then has `ok_says`, empty for anything), and values
/// it refuses with `why` in the message.
struct Edge {
    line: &'static [&'static str],
    flag: &'static str,
    ok: &'static [&'static str],
    ok_exit: i32,
    ok_says: &'static str,
    refused: &'static [&'static str],
    why: &'static str,
}

const NOON: &str = "2025-06-21T12:00:00Z";
const SUN: &[&str] = &["sun", "--lat", "0", "--lon", "0", "--time", NOON];
const FK: &[&str] = &["fk", "--n", "3", "--beta", "35", "--states", "deployed"];
const STATION: &[&str] = &[
    "station",
    "--lat",
    "37",
    "--lon",
    "-80",
    "--modules",
    "2",
    "--date",
    "2025-06-21",
    "--tz",
    "Z",
];
/// Parsed, then refused for want of a crane: the option was accepted.
const NO_CRANE: &str = "give --sim or --port";
const HELIX: &str = "helix:radius=1,pitch=4,turns=1";

/// The edges; `@K`, `@F` and `@D` in a line are a kit file, a 3MF file and a directory.
const EDGES: &[Edge] = &[
    Edge {
        line: &["sun", "--lon", "0", "--time", NOON],
        flag: "--lat",
        ok: &["-90", "90", " 0 "],
        ok_exit: 0,
        ok_says: "",
        refused: &["-90.001", "90.001", "nan", "x"],
        why: "[-90°, 90°]",
    },
    Edge {
        line: &["sun", "--lat", "0", "--time", NOON],
        flag: "--lon",
        ok: &["-180", "180"],
        ok_exit: 0,
        ok_says: "",
        refused: &["-180.001", "180.001", "inf"],
        why: "[-180°, 180°]",
    },
    Edge {
        line: SUN,
        flag: "--elevation-m",
        ok: &["-500", "10000"],
        ok_exit: 0,
        ok_says: "",
        refused: &["-500.1", "10000.1"],
        why: "[-500, 10000] m",
    },
    Edge {
        line: SUN,
        flag: "--delta-t",
        ok: &["-10000", "10000"],
        ok_exit: 0,
        ok_says: "",
        refused: &["-10000.1", "10000.1", "inf"],
        why: "[-10000, 10000] s",
    },
    Edge {
        line: SUN,
        flag: "--pressure-hpa",
        ok: &["0.001", "2000"],
        ok_exit: 0,
        ok_says: "",
        refused: &["0", "2000.001", "nan", "-1"],
        why: "expected a number greater than 0 and at most 2000 hPa",
    },
    // At midnight the sun is below the horizon, where SPA applies no refraction (at noon
    // SPA's refraction formula refuses -272.999 °C: a zenith angle outside [0°, 180°]).
    Edge {
        line: &[
            "sun",
            "--lat",
            "0",
            "--lon",
            "0",
            "--time",
            "2025-06-21T12:00:00Z",
        ],
        flag: "--temperature-c",
        ok: &["-90", "60"],
        ok_exit: 0,
        ok_says: "",
        refused: &["-90.001", "60.001", "-272.999", "inf"],
        why: "expected a number from -90 to 60 °C",
    },
    Edge {
        line: &[
            "station",
            "--lon",
            "-80",
            "--modules",
            "2",
            "--date",
            "2025-06-21",
            "--tz",
            "Z",
        ],
        flag: "--lat",
        ok: &["-90", "90"],
        ok_exit: 0,
        ok_says: "",
        refused: &["-90.5", "90.5"],
        why: "[-90°, 90°]",
    },
    Edge {
        line: STATION,
        flag: "--heading",
        ok: &["0", "359.999", "-1e308", "1e308"],
        ok_exit: 0,
        ok_says: "",
        refused: &["nan", "inf", "east"],
        why: "--heading:",
    },
    Edge {
        line: FK,
        flag: "--heading",
        ok: &["0", "359.999", "-1e308", "1e308"],
        ok_exit: 0,
        ok_says: "",
        refused: &["nan", "-inf", "x"],
        why: "--heading:",
    },
    Edge {
        line: &["aim", "--toward", "135,40"],
        flag: "--heading",
        ok: &["-1e308", "1e308"],
        ok_exit: 0,
        ok_says: "",
        refused: &["nan", "inf"],
        why: "--heading:",
    },
    // The sun is up at the north pole in June and at the south pole in December.
    Edge {
        line: &["aim", "--sun", "--lon", "0", "--time", NOON],
        flag: "--lat",
        ok: &["90"],
        ok_exit: 0,
        ok_says: "",
        refused: &["90.001"],
        why: "[-90°, 90°]",
    },
    Edge {
        line: &[
            "aim",
            "--sun",
            "--lon",
            "0",
            "--time",
            "2025-12-21T12:00:00Z",
        ],
        flag: "--lat",
        ok: &["-90"],
        ok_exit: 0,
        ok_says: "",
        refused: &["-90.001"],
        why: "[-90°, 90°]",
    },
    Edge {
        line: &["aim", "--sun", "--lat", "90", "--time", NOON],
        flag: "--lon",
        ok: &["-180", "180"],
        ok_exit: 0,
        ok_says: "",
        refused: &["-180.001", "180.001"],
        why: "[-180°, 180°]",
    },
    Edge {
        line: &["track", "--lon", "0", "--until", "10:00"],
        flag: "--lat",
        ok: &["-90", "90"],
        ok_exit: 2,
        ok_says: NO_CRANE,
        refused: &["-90.001", "90.001"],
        why: "[-90°, 90°]",
    },
    Edge {
        line: &["track", "--lat", "0", "--until", "10:00"],
        flag: "--lon",
        ok: &["-180", "180"],
        ok_exit: 2,
        ok_says: NO_CRANE,
        refused: &["-180.001", "180.001"],
        why: "[-180°, 180°]",
    },
    Edge {
        line: &["track", "--lat", "0", "--lon", "0", "--until", "10:00"],
        flag: "--heading",
        ok: &["-1e308", "1e308"],
        ok_exit: 2,
        ok_says: NO_CRANE,
        refused: &["nan"],
        why: "--heading:",
    },
    Edge {
        line: &["pattern", "--seam-mm", "0", "--kit", "@K"],
        flag: "--edge-mm",
        ok: &["0.001", "10000"],
        ok_exit: 0,
        ok_says: "",
        refused: &["0", "10000.001", "-1", "nan"],
        why: "--edge-mm must be a length in mm in (0, 10000]",
    },
    Edge {
        line: &["model", "--obj", "@F"],
        flag: "--edge-mm",
        ok: &["0.001", "10000"],
        ok_exit: 0,
        ok_says: "",
        refused: &["0", "10000.001"],
        why: "--edge-mm must be a length in mm in (0, 10000]",
    },
    Edge {
        line: &["pattern", "--beta", "35", "--kit", "@K"],
        flag: "--layers",
        ok: &["1", "1000"],
        ok_exit: 0,
        ok_says: "",
        refused: &["0", "1001", "1.5", "-1", "4,"],
        why: "--layers must be one integer in [1, 1000] for every module or one per module",
    },
    Edge {
        line: &["pattern", "--3mf", "@F"],
        flag: "--gap-mm",
        ok: &["1.5", "3,1.5"],
        ok_exit: 0,
        ok_says: "",
        refused: &["a", "3,,1.5"],
        why: "--gap-mm must be gap widths in mm",
    },
    Edge {
        line: &[
            "pattern",
            "--edge-mm",
            "609.6",
            "--beta",
            "31.72",
            "--layers",
            "4",
            "--kit",
            "@K",
            "--nest-dir",
            "@D",
        ],
        flag: "--nest",
        ok: &["100000x100000"],
        ok_exit: 0,
        ok_says: "",
        refused: &["0x2440", "100000.1x2440", "1220", "1220x-1"],
        why: "--nest: a sheet is WIDTHxHEIGHT in mm, each in (0, 100000]",
    },
    Edge {
        line: &["ik", "--n", "3", "--beta", "35", "--modules", "2"],
        flag: "--target",
        ok: &[HELIX],
        ok_exit: 0,
        ok_says: "",
        refused: &["blob", "helix:radius=-1"],
        why: "--target:",
    },
    Edge {
        line: &[
            "design",
            "--n",
            "3",
            "--modules",
            "2",
            "--samples",
            "1",
            "--certify",
            "0",
        ],
        flag: "--target",
        ok: &[HELIX],
        ok_exit: 0,
        ok_says: "",
        refused: &["blob", "sine:amplitude=x"],
        why: "--target:",
    },
    Edge {
        line: &["log", "plot", "@D/none.mcap", "--out", "@D/f.svg"],
        flag: "--format",
        ok: &[],
        ok_exit: 0,
        ok_says: "",
        refused: &["gif", ""],
        why: "--format: unknown figure format",
    },
];

#[test]
fn each_option_takes_both_ends_of_its_range_and_refuses_the_values_past_them_with_exit_2() {
    let dir = temp("value-parsers");
    let kit = dir.join("kit.json");
    let file = dir.join("out.3mf");
    let obj = dir.join("out.obj");
    let place = |a: &str, e: &Edge| -> String {
        let f = if e.line.first() == Some(&"model") {
            &obj
        } else {
            &file
        };
        a.replace("@K", kit.to_str().unwrap())
            .replace("@F", f.to_str().unwrap())
            .replace("@D", dir.to_str().unwrap())
    };
    for e in EDGES {
        let run = |v: &str| {
            let mut args: Vec<String> = e.line.iter().map(|a| place(a, e)).collect();
            args.push(format!("{}={v}", e.flag));
            let refs: Vec<&str> = args.iter().map(String::as_str).collect();
            let out = cmd(&dir, &refs).output().expect("run host-tool");
            (
                out.status.code(),
                String::from_utf8_lossy(&out.stderr).into_owned(),
                args,
            )
        };
        for v in e.ok {
            let (code, stderr, args) = run(v);
            assert_eq!(code, Some(e.ok_exit), "{args:?} should run: {stderr}");
            assert!(
                !stderr.contains("invalid value") && stderr.contains(e.ok_says),
                "{args:?}: {stderr}"
            );
        }
        for v in e.refused {
            let (code, stderr, args) = run(v);
            assert_eq!(code, Some(2), "{args:?} should be refused: {stderr}");
            assert!(
                stderr.contains(&format!("invalid value '{v}' for '{}", e.flag))
                    && stderr.contains(e.why),
                "{args:?}: expected '{}' in: {stderr}",
                e.why
            );
            assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        }
    }
}

#[test]
fn a_layers_list_is_still_checked_against_the_modules_after_parsing() {
    let dir = temp("value-parsers-layers");
    let kit = dir.join("kit.json");
    let out = cmd(
        &dir,
        &[
            "pattern",
            "--beta",
            "35,31.72,30",
            "--layers",
            "2,2",
            "--kit",
            kit.to_str().unwrap(),
        ],
    )
    .output()
    .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--layers has 2 values but --beta has 3 modules"),
        "{stderr}"
    );
    assert!(!kit.exists());
}
