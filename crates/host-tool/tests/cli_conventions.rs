//! The command line's conventions through the real binary: one JSON error object on every
//! failure, numbers in their shortest form, integer and range messages that say what is
//! expected, quoting hints, outputs checked before the work, `-` for stdin/stdout, exit 130 on
//! an interrupt, `-q`/`-v`, `CRANE_PORT`, completions, the man page, `--version`, and text
//! wrapped to the terminal's width.

use std::io::{BufRead as _, BufReader, Write as _};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

fn cmd() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_host-tool"));
    c.env_remove("CRANE_PORT").env_remove("COLUMNS");
    c
}

fn host_tool(args: &[&str]) -> Output {
    cmd()
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("host-tool runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A help text with its line breaks (wrapped to the terminal's width) as single spaces.
fn help(args: &[&str]) -> String {
    text(&host_tool(args).stdout)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// Stdout as exactly one JSON object.
fn one_object(out: &Output) -> Value {
    let s = text(&out.stdout);
    let lines: Vec<&str> = s.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(
        lines.len(),
        1,
        "one JSON line expected: {s}{}",
        text(&out.stderr)
    );
    serde_json::from_str(lines[0]).unwrap_or_else(|e| panic!("not JSON ({e}): {s}"))
}

#[test]
fn every_failing_command_prints_one_json_error_object_with_the_exit_codes_meaning() {
    // (arguments, exit code): usage errors of each device command, and a runtime failure.
    let cases: &[(&[&str], i32)] = &[
        (&["status", "-j"], 2),
        (&["stop", "--json"], 2),
        (&["declare", "X&Y", "--sim", "-j"], 2),
        (&["declare", "D&D", "-j"], 2),
        (&["param", "get", "nope", "--sim", "-j"], 2),
        (&["param", "set", "telemetry-hz", "99", "--sim", "-j"], 2),
        (&["plan", "--target", "X", "--dry-run", "-j"], 2),
        (
            &["plan", "--target", "D&F", "--dry-run", "--from", "Q", "-j"],
            2,
        ),
        (&["monitor", "--sim", "--rate", "0", "-j"], 2),
        (&["status", "--port", "/nonexistent/tty", "-j"], 1),
        (&["identify", "--port", "/nonexistent/tty", "-j"], 1),
        // A clap error (an unknown flag) too.
        (&["status", "--sim", "--bogus", "-j"], 2),
        // Values clap's value parsers refuse.
        (
            &[
                "fk", "--n", "65", "--beta", "35", "--states", "deployed", "-j",
            ],
            2,
        ),
        (&["reach", "--point", "1,2", "--sim", "-j"], 2),
        (&["workspace", "--samples", "1", "-j"], 2),
        (&["aim", "--toward", "360,0", "-j"], 2),
    ];
    for (args, code) in cases {
        let out = host_tool(args);
        assert_eq!(
            out.status.code(),
            Some(*code),
            "{args:?}: {}",
            text(&out.stderr)
        );
        let v = one_object(&out);
        assert_eq!(v["ok"], false, "{args:?}: {v}");
        assert_eq!(v["exit_code"], *code, "{args:?}: {v}");
        let meaning = v["exit"].as_str().unwrap_or_default();
        assert!(
            meaning.starts_with(if *code == 2 {
                "usage error"
            } else {
                "runtime failure"
            }),
            "{args:?}: {v}"
        );
        assert!(!v["error"].as_str().unwrap_or_default().is_empty(), "{v}");
        for key in ["fault_code", "reject", "refused"] {
            assert!(v.get(key).is_some(), "{key} missing: {v}");
        }
    }
}

/// Every number in a JSON text, as written.
fn numbers(json: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut in_string = false;
    for c in json.chars() {
        if c == '"' {
            in_string = !in_string;
        }
        if !in_string && (c.is_ascii_digit() || c == '.' || c == '-' || c == 'e') {
            cur.push(c);
        } else if !cur.is_empty() {
            out.push(std::mem::take(&mut cur));
        }
    }
    out
}

#[test]
fn json_numbers_are_shortest_without_f32_widening_arithmetic_noise_or_negative_zero() {
    // The dry run's expected time is a sum (5.2 + 6.9 = 12.100000000000001 in f64); a status
    // carries the device's f32 values (servo angles, pressure).
    for args in [
        &["plan", "--target", "D&F", "--dry-run", "-j"][..],
        &["status", "--sim", "--sim-initial", "D&D", "-j"][..],
        &["stop", "--sim", "-j"][..],
        &["param", "get", "--sim", "-j"][..],
    ] {
        let out = host_tool(args);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{args:?}: {}",
            text(&out.stderr)
        );
        let s = text(&out.stdout);
        for n in numbers(&s) {
            let digits = n.trim_start_matches('-').replace('.', "");
            let significant = digits.trim_start_matches('0').trim_end_matches('0').len();
            assert!(
                significant <= 10,
                "{args:?}: {n} is not in its shortest form: {s}"
            );
            assert_ne!(n, "-0.0", "{args:?}: {s}");
        }
    }
    let v = one_object(&host_tool(&["plan", "--target", "D&F", "--dry-run", "-j"]));
    assert_eq!(v["expected_s"].to_string(), "12.1", "{v}");
}

#[test]
fn a_negative_seed_is_a_seed() {
    let out = host_tool(&["status", "--sim", "--seed", "-3", "-j"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert_eq!(one_object(&out)["state"], "F&P");
    let out = host_tool(&["status", "--sim", "--seed", "1.5"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("not a whole number"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn monitor_durations_outside_their_range_are_refused_before_anything_runs() {
    // 1e20 s once panicked (exit 101) making a `Duration`; 0 and a negative one never end.
    for bad in ["1e20", "0", "-1", "inf", "nan"] {
        let out = host_tool(&["monitor", "--sim", "--duration", bad]);
        assert_eq!(out.status.code(), Some(2), "--duration {bad}");
        let err = text(&out.stderr);
        assert!(
            err.contains("greater than 0 and at most 1000000000"),
            "--duration {bad}: {err}"
        );
    }
    // The smallest sensible value runs.
    let out = host_tool(&["monitor", "--sim", "--duration", "0.001", "-j"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
}

#[test]
fn integer_options_refuse_fractions_saying_what_is_expected() {
    let out = host_tool(&["monitor", "--sim", "--rate", "1.5", "--duration", "0.1"]);
    assert_eq!(out.status.code(), Some(2));
    let err = text(&out.stderr);
    assert!(
        err.contains("'1.5' is not a whole number") && err.contains("from 1 to 50"),
        "{err}"
    );
    assert!(!err.contains("invalid digit"), "{err}");
    // An integer parameter: refused, not truncated to 1000.
    let out = host_tool(&["param", "set", "link-timeout-ms", "1000.5", "--sim"]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stdout));
    assert!(text(&out.stderr).contains("whole number from 200 to 60000 ms"));
    // Its edges are accepted.
    for v in ["200", "60000"] {
        let out = host_tool(&["param", "set", "link-timeout-ms", v, "--sim", "-j"]);
        assert_eq!(out.status.code(), Some(0), "{v}: {}", text(&out.stderr));
        let got = one_object(&out)["value"].as_f64();
        assert_eq!(got, v.parse::<f64>().ok(), "{v}");
    }
}

#[test]
fn range_messages_agree_with_each_other_and_with_the_help() {
    let base = ["ik", "--n", "6", "--beta", "35", "--target", "helix"];
    for m in ["0", "100000", "-1", "2.5"] {
        let mut a = base.to_vec();
        a.extend(["--modules", m]);
        let out = host_tool(&a);
        assert_eq!(out.status.code(), Some(2), "{m}");
        let err = text(&out.stderr);
        assert!(
            err.contains("--modules must be an integer in [1, 10000]"),
            "{m}: {err}"
        );
    }
    let h = help(&["ik", "--help"]);
    assert!(h.contains("[1, 10000]"), "{h}");
    let h = help(&["plan", "--help"]);
    assert!(h.contains("0.1–1000"), "{h}");
    assert!(h.contains("[default: 1]"), "the seed's default: {h}");
    let h = help(&["monitor", "--help"]);
    assert!(h.contains("1–50") && h.contains("[default: 10]"), "{h}");
}

#[test]
fn help_examples_are_quoted_and_an_unquoted_ampersand_gets_a_hint() {
    let h = help(&["--help"]);
    assert!(h.contains("--target 'D&F'"), "{h}");
    assert!(!h.contains("--target D&F"), "{h}");
    // `host-tool plan --target D&F --sim` unquoted: the shell runs `host-tool plan --target D`.
    let out = host_tool(&["plan", "--target", "D"]);
    assert_eq!(out.status.code(), Some(2));
    let err = text(&out.stderr);
    assert!(
        err.contains("Quote state names, e.g. --target 'D&F'"),
        "{err}"
    );
    let out = host_tool(&["declare", "F", "--sim"]);
    assert!(
        text(&out.stderr).contains("did you mean 'F&…'"),
        "{}",
        text(&out.stderr)
    );
    // A state's two letters without the `&`, or with another separator: the state they name.
    for (typed, meant) in [("DF", "D&F"), ("f/p", "F&P"), ("d d", "D&D")] {
        let out = host_tool(&["plan", "--target", typed, "--sim"]);
        assert_eq!(out.status.code(), Some(2), "{typed}");
        let err = text(&out.stderr);
        assert!(
            err.contains(&format!("Did you mean '{meant}'?")),
            "{typed}: {err}"
        );
    }
    // Letters that name no state get the list and no guess.
    let err = text(&host_tool(&["plan", "--target", "PD", "--sim"]).stderr);
    assert!(
        err.contains("F&P, F&F, F&D, D&P, D&F, D&D") && !err.contains("Did you mean"),
        "{err}"
    );
}

#[test]
fn a_negative_speed_is_refused_with_the_range_not_as_an_unknown_argument() {
    for bad in ["-1", "0", "1001"] {
        let out = host_tool(&["plan", "--target", "D&F", "--sim", "--sim-speed", bad]);
        assert_eq!(out.status.code(), Some(2), "{bad}");
        let err = text(&out.stderr);
        assert!(
            err.contains("expected a number from 0.1 to 1000"),
            "{bad}: {err}"
        );
    }
    // The range's ends are accepted (a dry run moves nothing and paces nothing).
    for edge in ["0.1", "1000"] {
        let out = host_tool(&[
            "plan",
            "--target",
            "D&F",
            "--sim",
            "--sim-speed",
            edge,
            "--dry-run",
        ]);
        assert_eq!(out.status.code(), Some(0), "{edge}: {}", text(&out.stderr));
    }
}

#[test]
fn ports_prints_a_header_and_says_when_no_uno_r4_is_found() {
    let out = host_tool(&["ports"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let shown = text(&out.stdout);
    let listed: Value = serde_json::from_slice(&host_tool(&["ports", "-j"]).stdout).unwrap();
    let rows = listed.as_array().unwrap();
    if rows.is_empty() {
        assert!(shown.starts_with("no serial ports found"), "{shown}");
        return;
    }
    assert!(shown.starts_with("PORT "), "{shown}");
    assert_eq!(
        shown.lines().count(),
        rows.len() + 1 + usize::from(!rows.iter().any(|r| r["uno_r4"] == true))
    );
    let no_board = shown.contains("no UNO R4 found");
    assert_eq!(
        no_board,
        !rows.iter().any(|r| r["uno_r4"] == true),
        "{shown}"
    );
}

/// A solve that takes its whole time limit (exact, n = 4, m = 30: far from proven in 5 s).
const IK: [&str; 11] = [
    "ik",
    "--n",
    "4",
    "--beta",
    "35",
    "--modules",
    "30",
    "--target",
    "helix:radius=1,pitch=4,turns=1",
    "--all-states",
    "--time-limit",
];

#[test]
fn an_output_file_is_checked_before_the_solve_and_dash_is_stdout() {
    let start = Instant::now();
    let mut a = IK.to_vec();
    a.extend(["5", "--svg", "/nonexistent/x.svg"]);
    let out = host_tool(&a);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("cannot write --svg /nonexistent/x.svg"));
    // Refused up front: not after the 5 s solve.
    assert!(
        start.elapsed() < Duration::from_secs(3),
        "{:?}",
        start.elapsed()
    );

    let out = host_tool(&[
        "ik",
        "--n",
        "4",
        "--beta",
        "35",
        "--modules",
        "3",
        "--target",
        "helix",
        "--svg",
        "-",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let svg = text(&out.stdout);
    assert!(
        svg.contains("<svg") && svg.trim_end().ends_with("</svg>"),
        "{svg}"
    );
    let out = host_tool(&[
        "ik",
        "--n",
        "4",
        "--beta",
        "35",
        "--modules",
        "3",
        "--target",
        "helix",
        "--svg",
        "-",
        "--json",
    ]);
    assert_eq!(out.status.code(), Some(2));
}

/// `host-tool ik` for m modules with the target CSV on stdin (`--target-file -`).
fn ik_from_stdin(modules: &str, csv: &[u8]) -> Output {
    let mut child = cmd()
        .args([
            "ik",
            "--n",
            "4",
            "--beta",
            "35",
            "--modules",
            modules,
            "--target-file",
            "-",
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("host-tool runs");
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(csv)
        .expect("write stdin");
    child.wait_with_output().expect("host-tool ends")
}

#[test]
fn a_target_file_dash_reads_stdin_and_one_point_is_one_point() {
    let out = ik_from_stdin("2", b"x,y,z\n0,0,1\n0,0,2\n");
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("(2 points,"),
        "{}",
        text(&out.stdout)
    );
    let out = ik_from_stdin("1", b"0,0,1\n");
    let table = text(&out.stdout);
    if out.status.code() == Some(0) {
        assert!(table.contains("(1 point,"), "{table}");
    } else {
        // A single point may be refused as unfittable; then the message says why.
        assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
    }
}

#[test]
fn ctrl_c_during_a_solve_prints_the_best_boom_and_exits_130() {
    let mut a = IK.to_vec();
    a.extend(["600", "--json"]);
    let mut child = cmd()
        .args(&a[..])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("host-tool runs");
    // The progress line comes after a second of solving: then it is interrupted.
    let mut err = BufReader::new(child.stderr.take().expect("stderr"));
    let mut line = String::new();
    while err.read_line(&mut line).expect("stderr") > 0 && !line.contains("evaluated") {
        line.clear();
    }
    let pid = nix::unistd::Pid::from_raw(child.id() as i32);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT).expect("SIGINT");
    let out = child.wait_with_output().expect("host-tool ends");
    assert_eq!(out.status.code(), Some(130));
    let v: Value = serde_json::from_slice(&out.stdout).expect("the best boom as JSON");
    assert_eq!(v["stop"], "interrupted", "{v}");
    assert_eq!(v["states"].as_array().map(Vec::len), Some(30), "{v}");
}

#[test]
fn quiet_says_nothing_but_errors_and_verbose_shows_frames_decoded_retries_and_timings() {
    let out = host_tool(&["plan", "--target", "D&F", "--sim", "-q"]);
    assert_eq!(out.status.code(), Some(0));
    assert_eq!(text(&out.stderr), "");
    let out = host_tool(&["plan", "--target", "X", "--sim", "-q"]);
    assert!(text(&out.stderr).contains("error: invalid value 'X' for '--target <STATE>'"));
    let out = host_tool(&["status", "--sim", "-v"]);
    assert_eq!(out.status.code(), Some(0));
    let err = text(&out.stderr);
    // Each frame decoded on the engine's clock: the request's name and sequence number, the
    // answer's result, body and round trip; events by name; no raw bytes at -v.
    let line = |pat: &str| err.lines().find(|l| l.contains(pat)).unwrap_or_default();
    assert!(line("→ #1 Hello{protocol ").contains(" ms → "), "{err}");
    let status = line("← #2 ok Status{F&P confirmed, standalone,");
    assert!(
        status.contains(" ms ← ") && status.ends_with(" ms)"),
        "{err}"
    );
    assert!(line("→ #2 GetStatus").contains(" ms → "), "{err}");
    assert!(err.contains("← event "), "{err}");
    assert!(!err.contains(" bytes:"), "{err}");
    assert!(err.contains("handshake with the simulator:"), "{err}");
    assert!(
        err.contains("link: 1 request, 0 retried, 0 corrupt frames dropped"),
        "{err}"
    );
    // -vv: and each frame's bytes.
    let err = text(&host_tool(&["status", "--sim", "-vv"]).stderr);
    assert!(
        err.contains("→ #2 GetStatus") && err.contains(" bytes: 00 "),
        "{err}"
    );
    // Retries are marked on the resent request: under line noise some answers are lost.
    let out = host_tool(&[
        "plan",
        "--target",
        "D&D",
        "--sim",
        "--sim-fault",
        "line-noise",
        "--seed",
        "11",
        "-v",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let err = text(&out.stderr);
    let retry = line_in(&err, "(retry 1 of #");
    assert!(
        retry.contains(" ms → #") && retry.ends_with(" ms after the first)"),
        "{err}"
    );
    assert!(err.contains("a corrupt frame, dropped ("), "{err}");
}

fn line_in<'a>(text: &'a str, pat: &str) -> &'a str {
    text.lines().find(|l| l.contains(pat)).unwrap_or_default()
}

#[test]
fn the_port_comes_from_crane_port_and_p_is_port() {
    let out = cmd()
        .args(["status", "-j"])
        .env("CRANE_PORT", "/nonexistent/crane")
        .stdin(Stdio::null())
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stderr));
    assert!(one_object(&out)["error"]
        .as_str()
        .unwrap_or_default()
        .contains("/nonexistent/crane"));
    // --sim wins over the environment.
    let out = cmd()
        .args(["status", "--sim", "-j"])
        .env("CRANE_PORT", "/nonexistent/crane")
        .stdin(Stdio::null())
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let out = host_tool(&["status", "-p", "/nonexistent/p"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("cannot open serial port /nonexistent/p"));
    // No port, no board: the usage error says every way to give one.
    let out = host_tool(&["status"]);
    assert_eq!(out.status.code(), Some(2));
    let err = text(&out.stderr);
    assert!(
        err.contains("CRANE_PORT") && err.contains("--sim") && err.contains("--port"),
        "{err}"
    );
}

/// What bash's completion offers for `words` (the last one being completed), running the
/// generated script in bash as a person's Tab would.
fn bash_completes(words: &[&str]) -> Vec<String> {
    let script = text(&host_tool(&["completions", "bash"]).stdout);
    let dir = std::env::temp_dir().join(format!("host-tool-compl-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("host-tool.bash");
    std::fs::write(&file, script).unwrap();
    let quoted: Vec<String> = words.iter().map(|w| format!("'{w}'")).collect();
    let n = words.len();
    let prev = if n >= 2 { words[n - 2] } else { "" };
    let program = format!(
        "source '{}'; COMP_WORDS=({}); COMP_CWORD={}; COMP_LINE='{}'; COMP_POINT=${{#COMP_LINE}}; \
         _host__tool host-tool '{}' '{}'; printf '%s\\n' \"${{COMPREPLY[@]}}\"",
        file.display(),
        quoted.join(" "),
        n - 1,
        words.join(" "),
        words[n - 1],
        prev
    );
    let out = Command::new("bash")
        .args(["--norc", "--noprofile", "-c", &program])
        .output()
        .expect("bash runs");
    assert!(out.status.success(), "{}", text(&out.stderr));
    text(&out.stdout).lines().map(str::to_owned).collect()
}

#[test]
fn bash_completes_subcommand_options_and_their_values() {
    let options = bash_completes(&["host-tool", "plan", "--"]);
    for o in ["--target", "--sim", "--sim-fault", "--port"] {
        assert!(options.iter().any(|x| x == o), "plan --<TAB>: {options:?}");
    }
    let states = bash_completes(&["host-tool", "plan", "--target", ""]);
    assert_eq!(states, ["F-P", "F-F", "F-D", "D-P", "D-F", "D-D"]);
    let d = bash_completes(&["host-tool", "declare", "D"]);
    assert_eq!(d, ["D-P", "D-F", "D-D"]);
    let faults = bash_completes(&["host-tool", "status", "--sim-fault", "l"]);
    assert_eq!(faults, ["leak", "link-drop", "line-noise"]);
    let algo = bash_completes(&["host-tool", "ik", "--algo", ""]);
    assert_eq!(algo.len(), 6, "{algo:?}");
    assert!(algo.contains(&"exact".to_owned()) && algo.contains(&"dp".to_owned()));
    let metric = bash_completes(&["host-tool", "ik", "--metric", ""]);
    assert_eq!(metric, ["eq36", "ordered"]);
    // Every completed state is one the commands take.
    for s in states {
        let out = host_tool(&["plan", "--target", &s, "--sim", "--dry-run", "-j"]);
        assert_eq!(out.status.code(), Some(0), "{s}: {}", text(&out.stderr));
    }
}

#[test]
fn completions_and_the_man_page() {
    for (shell, mark) in [
        ("bash", "complete -F"),
        ("zsh", "#compdef host-tool"),
        ("fish", "complete -c host-tool"),
    ] {
        let out = host_tool(&["completions", shell]);
        assert_eq!(out.status.code(), Some(0), "{shell}");
        let s = text(&out.stdout);
        assert!(s.contains(mark), "{shell}: {}", &s[..s.len().min(300)]);
        assert!(s.contains("monitor") && s.contains("sim-speed"), "{shell}");
    }
    assert_eq!(host_tool(&["completions", "tcsh"]).status.code(), Some(2));
    let man = text(&host_tool(&["man"]).stdout);
    assert!(
        man.contains(".TH host-tool"),
        "{}",
        &man[..man.len().min(300)]
    );
    assert!(
        man.contains("completions") && man.contains("protocol 2"),
        "man"
    );
    // NAME says the name once, then what it does.
    let name = man.lines().skip_while(|l| *l != ".SH NAME").nth(1).unwrap();
    assert!(name.starts_with("host\\-tool \\- Plan"), "{name}");
    assert_eq!(name.matches("host\\-tool").count(), 1, "{name}");
    // Every page SUBCOMMANDS points to can be made: with --dir they are all written, named as
    // the references name them; one is printed by its path.
    let dir = std::env::temp_dir().join(format!("man-{}", std::process::id()));
    let out = host_tool(&["man", "--dir", dir.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let pages: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(text(&out.stdout).lines().count(), pages.len());
    let mut referenced = 0;
    for page in &pages {
        let roff = std::fs::read_to_string(dir.join(page)).unwrap();
        for r in roff.lines().filter(|l| l.ends_with("(1)")) {
            let file = format!("{}.1", r.trim_end_matches("(1)").replace("\\-", "-"));
            assert!(pages.contains(&file), "{page} refers to {r}: no {file}");
            referenced += 1;
        }
    }
    // Every subcommand but the top page is referenced from its parent's page.
    assert_eq!(referenced, pages.len() - 1, "{pages:?}");
    let plan = text(&host_tool(&["man", "plan"]).stdout);
    assert!(
        plan.contains(".TH host-tool-plan 1") && plan.contains("\\-\\-target"),
        "{plan}"
    );
    let export = text(&host_tool(&["man", "log", "export"]).stdout);
    assert!(export.contains(".TH host-tool-log-export 1"), "{export}");
    for (args, says) in [
        (
            &["man", "nope"][..],
            "has no subcommand 'nope'; it has states",
        ),
        (
            &["man", "log", "nope"][..],
            "it has summary, export, plot, recover",
        ),
        (&["man", "plan", "x"][..], "plan has no subcommands"),
    ] {
        let out = host_tool(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(
            text(&out.stderr).contains(says),
            "{args:?}: {}",
            text(&out.stderr)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn version_names_the_protocol_the_schema_and_the_commit_and_status_compares_them() {
    let v = text(&host_tool(&["--version"]).stdout);
    let schema = format!("schema {:#010x}", protocol::SCHEMA_ID);
    assert!(
        v.contains(&format!("protocol {}", protocol::PROTOCOL_VERSION)),
        "{v}"
    );
    assert!(v.contains(&schema) && v.contains("commit "), "{v}");
    let s = text(&host_tool(&["status", "--sim"]).stdout);
    assert!(s.contains(&schema), "{s}");
    assert!(
        s.contains("the same protocol and schema as the device"),
        "{s}"
    );
    let j = one_object(&host_tool(&["status", "--sim", "-j"]));
    assert_eq!(j["versions_match"], true);
    assert_eq!(j["host"]["schema_id"], j["device"]["schema_id"]);
}

#[test]
fn long_lines_wrap_to_the_terminal_width() {
    let out = cmd()
        .args(["plan", "--target", "D&D", "--dry-run"])
        .env("COLUMNS", "60")
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(0));
    let s = text(&out.stdout);
    assert!(s.contains("why:"), "{s}");
    for line in s.lines() {
        assert!(
            line.chars().count() <= 60,
            "{} columns: {line}",
            line.chars().count()
        );
    }
    // Without a width (a pipe), lines are whole.
    let whole = text(&host_tool(&["plan", "--target", "D&D", "--dry-run"]).stdout);
    assert!(whole.lines().any(|l| l.chars().count() > 60), "{whole}");
}

#[test]
fn monitor_prints_a_header_a_readable_rate_and_no_two_samples_at_one_time() {
    let out = host_tool(&["monitor", "--sim", "--duration", "1.5", "--rate", "4"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let s = text(&out.stdout);
    let mut lines = s.lines();
    let header = lines.next().unwrap_or_default();
    assert!(
        header.contains("device time") && header.contains("pressure"),
        "{s}"
    );
    let times: Vec<&str> = lines
        .filter(|l| l.contains(" kPa "))
        .map(|l| l.split_whitespace().next().unwrap_or_default())
        .collect();
    assert!(times.len() >= 3, "{s}");
    // 1.5 s at 4 lines per second (+1 for the first).
    assert!(times.len() <= 7, "{} lines: {s}", times.len());
    let mut seen = std::collections::HashSet::new();
    for t in &times {
        assert!(seen.insert(*t), "two samples at {t} s: {s}");
    }
}

/// `host-tool ARGS` with a stdout whose reader is already gone (`| true`, `| head` after its
/// line): every write fails with EPIPE.
fn into_a_closed_pipe(args: &[&str]) -> Output {
    let (read, write) = nix::unistd::pipe().expect("a pipe");
    drop(read);
    cmd()
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::from(write))
        .stderr(Stdio::piped())
        .output()
        .expect("host-tool runs")
}

#[test]
fn a_closed_stdout_ends_each_command_quietly_without_a_panic() {
    for args in [
        &["ports"][..],
        &["ports", "-j"][..],
        &[
            "fk",
            "--n",
            "6",
            "--beta",
            "35",
            "--states",
            "deployed,folded",
        ][..],
        &["states", "--n", "6", "--beta", "35"][..],
        &["plan", "--target", "D&F", "--sim", "--json"][..],
        &["plan", "--target", "D&F", "--dry-run"][..],
        &["status", "--sim"][..],
        &["param", "get", "--sim"][..],
        &["completions", "bash"][..],
        &["man"][..],
    ] {
        let out = into_a_closed_pipe(args);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {err}");
        assert!(
            !err.contains("panicked") && !err.contains("Broken pipe"),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn json_is_global_and_refused_where_a_command_has_none() {
    // Before the subcommand, after it, or among its options: the same object.
    let after = one_object(&host_tool(&["status", "--sim", "-j"]));
    for args in [
        &["-j", "status", "--sim"][..],
        &["--json", "status", "--sim"][..],
        &["status", "-j", "--sim"][..],
    ] {
        let v = one_object(&host_tool(args));
        assert_eq!(v["state"], after["state"], "{args:?}");
        assert_eq!(v["candidates"], after["candidates"], "{args:?}");
    }
    // A nested subcommand takes it too.
    let v = one_object(&host_tool(&["-j", "param", "get", "--sim"]));
    assert!(v["params"].is_array(), "{v}");
    // Commands that write files or text refuse it, with one error object.
    for (args, name) in [
        (&["-j", "log", "summary", "x.mcap"][..], "log"),
        (&["man", "-j"][..], "man"),
        (&["completions", "bash", "--json"][..], "completions"),
    ] {
        let out = host_tool(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let v = one_object(&out);
        assert!(
            v["error"]
                .as_str()
                .unwrap()
                .contains(&format!("`host-tool {name}` has no JSON output")),
            "{v}"
        );
    }
}
