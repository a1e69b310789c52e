//! `host-tool`: the command line of the Yoshimura crane.
//!
//! Arguments are parsed by clap, validated into a config once, then the command runs.
//! Exit codes: 0 success, 1 runtime failure (device, link, plan), 2 usage error, 130
//! interrupted (SIGINT, SIGTERM, SIGHUP; the crane made safe first).
#![forbid(unsafe_code)]

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

/// A note on stderr, left out with `-q`, wrapped to the terminal's width (`cli::wrap`). A
/// closed stderr (the terminal went away) is no reason to die mid-plan: the run goes on to its
/// safe end.
#[macro_export]
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        if $crate::cli::notes() {
            let text = $crate::cli::wrap(&format!($($t)*));
            let _ = writeln!(std::io::stderr(), "{text}");
        }
    }};
}

/// Text on stderr without a newline (as [`say!`]).
#[macro_export]
macro_rules! say_raw {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        if $crate::cli::notes() {
            let _ = write!(std::io::stderr(), $($t)*);
        }
    }};
}

/// Debug detail on stderr, only with `-v` (frames, retries, timings).
#[macro_export]
macro_rules! debug {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        if $crate::cli::debug() {
            let _ = writeln!(std::io::stderr(), $($t)*);
        }
    }};
}

/// A line on stdout; a closed stdout (`| head`) ends nothing abruptly (it is noted, see
/// `cli::stdout_closed`).
#[macro_export]
macro_rules! out {
    () => {
        $crate::cli::write_stdout(format_args!("\n"))
    };
    ($($t:tt)*) => {
        $crate::cli::write_stdout(format_args!("{}\n", format_args!($($t)*)))
    };
}

/// Text on stdout without a newline (as [`out!`]).
#[macro_export]
macro_rules! out_raw {
    ($($t:tt)*) => {
        $crate::cli::write_stdout(format_args!($($t)*))
    };
}

mod arg;
mod cli;
mod client;
mod cmd;
mod completions;
mod device;
mod f32_or_nan;
mod failure;
mod figure;
mod keyboard;
mod mission;
mod num;
mod outcome;
mod progress;
mod record;
mod scene;
mod serve_protocol;
mod shell;
mod sim;
mod sockets;
mod state_name;
mod trace;
mod transport;

/// Design, plan and command Yoshimura-origami cranes (or their simulator).
#[derive(Debug, Parser)]
#[command(
    name = "host-tool",
    version,
    about = "Plan, command and inspect a Yoshimura crane (or its simulator); design it, make its \
             parts, and answer geometry and inverse-kinematics queries",
    propagate_version = true,
    after_help = EXAMPLES
)]
struct Cli {
    /// Say more on stderr, on commands that talk to a crane (or the simulator): each protocol
    /// frame decoded (-vv: and its bytes), retries, timings. The others have no more to say.
    #[arg(short, long, global = true, action = clap::ArgAction::Count, conflicts_with = "quiet")]
    verbose: u8,
    /// Say nothing but errors (and the output asked for).
    #[arg(short, long, global = true)]
    quiet: bool,
    /// Print JSON on stdout: the command's own objects, and every failure as one error object.
    /// Every command that has results takes it (anywhere on the line); the others refuse it.
    #[arg(short = 'j', long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: Command,
}

/// `host-tool man`: the page of `path` (a subcommand, its subcommand …; none: host-tool's own)
/// to stdout, or with `dir` every page into that directory, each named as the SUBCOMMANDS
/// sections refer to them (`host-tool-plan(1)` is `host-tool-plan.1`).
fn man(
    root: clap::Command,
    path: &[String],
    dir: Option<&std::path::Path>,
) -> Result<(), failure::Failure> {
    let root = root.disable_help_subcommand(true);
    if let Some(dir) = dir {
        std::fs::create_dir_all(dir).map_err(|e| {
            failure::Failure::usage(format!("cannot create {}: {e}", dir.display()))
        })?;
        clap_mangen::generate_to(root, dir).map_err(|e| {
            failure::Failure::Runtime(anyhow::anyhow!("writing into {}: {e}", dir.display()))
        })?;
        let mut pages: Vec<String> = std::fs::read_dir(dir)
            .map(|it| {
                it.filter_map(|e| e.ok())
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .filter(|n| n.starts_with("host-tool") && n.ends_with(".1"))
                    .collect()
            })
            .unwrap_or_default();
        pages.sort();
        say!("{}: {} pages", dir.display(), pages.len());
        for p in pages {
            out!("{}", dir.join(p).display());
        }
        return Ok(());
    }
    let mut cmd = root;
    cmd.build();
    let mut walked = vec![cmd.get_name().to_string()];
    for name in path {
        let next = cmd.find_subcommand(name).cloned();
        let Some(sub) = next else {
            let names: Vec<&str> = cmd
                .get_subcommands()
                .filter(|s| !s.is_hide_set())
                .map(|s| s.get_name())
                .collect();
            return Err(failure::Failure::usage(if names.is_empty() {
                format!(
                    "{} has no subcommands: no page for '{name}'",
                    walked.join(" ")
                )
            } else {
                format!(
                    "{} has no subcommand '{name}'; it has {}",
                    walked.join(" "),
                    names.join(", ")
                )
            }));
        };
        walked.push(sub.get_name().to_string());
        cmd = sub;
    }
    let mut out = Vec::new();
    clap_mangen::Man::new(cmd)
        .render(&mut out)
        .map_err(|e| failure::Failure::Runtime(anyhow::anyhow!("rendering the man page: {e}")))?;
    out_raw!("{}", String::from_utf8_lossy(&out));
    Ok(())
}

/// Examples for `--help`: quoted where a shell would split them (`&` backgrounds a command).
const EXAMPLES: &str = "Examples:
  host-tool plan --target 'D&F' --sim           # the main job, on the built-in simulator
  host-tool plan --target 'D&F' -p /dev/ttyACM0 # a real crane
  host-tool status -j                           # one JSON object (CRANE_PORT or the only UNO R4)
  host-tool station --lat 37.2296 --lon -80.4139 --date 2025-06-21 --tz -04:00 --max-changes 4
  host-tool design --n 3..8 --png bands.png     # which β lets a module bend (pop-outs feasible)
  host-tool ik --n 3 --beta 31.72 --modules 14 --target helix:pitch=2 --metric ordered
  host-tool states --crane                      # the trunk's height in each state (mm)
  host-tool completions bash > ~/.local/share/bash-completion/completions/host-tool

Exit codes: 0 success, 1 runtime failure (device, link, plan), 2 usage error, 130 interrupted.
State names hold '&': quote them ('D&F').";

#[derive(Debug, Subcommand)]
enum Command {
    /// The metastable states of one Yoshimura module (n, β).
    States(cmd::states::Args),
    /// Forward kinematics of a stack of modules: the tip of each module.
    Fk(cmd::fk::Args),
    /// Inverse kinematics: fit a stacked boom to a target curve.
    Ik(cmd::ik::Args),
    /// Where the sun is (NREL SPA): azimuth and zenith at --time, or a table through --date.
    Sun(cmd::sun::Args),
    /// The solar station: which top-module states face the sun through a day, and the refolds.
    Station(cmd::station::Args),
    /// The bend that points the tip axis (a panel) at a direction or the sun, and the error
    /// left; with --sim or --port the crane is bent there.
    Aim(cmd::aim::Args),
    /// Follow the sun through a day: aim the crane's panel every --every until --until.
    Track(cmd::track::Args),
    /// Which β works: the β bands where each family of states is feasible for n (or a range),
    /// heights and tilts; with --target, βs ranked by their fit.
    Design(cmd::design::Args),
    /// Files to make a trunk: crease pattern (SVG, DXF, FOLD), printable panel (3MF, STL), kit.
    Pattern(cmd::pattern::Args),
    /// A 3D model of a stack in given states: glTF, OBJ, STL (strain of infeasible states in red).
    Model(cmd::model::Args),
    /// Take the crane (--port) or the simulator (--sim) to a trunk state, e.g. --target 'D&F'.
    Plan(cmd::plan::Args),
    /// Measure the trunk's snap pressures, holds and strokes into a profile (--out FILE).
    Calibrate(cmd::calibrate::Args),
    /// Read a calibration profile: calibration show PROFILE.toml.
    Calibration(cmd::calibrate::ShowArgs),
    /// Run a mission: a TOML file of steps (state, bend, grip, reach, vent, wait, aim,
    /// identify, prompt), validated whole first; resumable after a stop.
    Run(cmd::run::Args),
    /// One status snapshot of the crane (or the simulator).
    Status(cmd::status::Args),
    /// Live telemetry until Ctrl-C or --duration.
    Monitor(cmd::monitor::Args),
    /// Tell the device the trunk's true state (after folding it by hand), e.g. declare 'D&D'.
    Declare(cmd::declare::Args),
    /// Read (`param get [NAME]`) or change (`param set NAME VALUE`) a device parameter.
    Param(cmd::param::Args),
    /// Abort whatever runs; report the safe state.
    Stop(cmd::stop::Args),
    /// Link signing: pair the crane with a new key (signing on), turn it off, or show it.
    Signing(cmd::signing::Args),
    /// Identify an unconfirmed trunk state: the crane's probes, then the operator.
    Identify(cmd::identify::Args),
    /// List serial ports; recognise Arduino UNO R4 boards.
    Ports(cmd::ports::Args),
    /// Write the firmware to an UNO R4 through its bootloader, verify it, and handshake.
    Flash(cmd::flash::Args),
    /// Pre-flight check of a crane (or the simulator): sensor, valves, servos, gripper, e-stop
    /// and buttons, a pass/fail table.
    Check(cmd::check::Args),
    /// Where the tip is for a trunk state and a bend, e.g. pose --state 'D&F' --bend 20,90.
    Pose(cmd::pose::PoseArgs),
    /// Each state's reachable tips for the bends it allows: table, JSON, side-view figure.
    Workspace(cmd::pose::WorkspaceArgs),
    /// Open or close the gripper: grip open|close.
    Grip(cmd::prim::GripArgs),
    /// Bend the trunk: bend ANGLE --toward DIR (degrees); bend 0 straightens.
    Bend(cmd::prim::BendArgs),
    /// Let the air out while the trunk keeps its state.
    Vent(cmd::prim::VentArgs),
    /// Put the tip at a point: reach --point X,Y,Z (mm), refused when no state reaches it.
    Reach(cmd::reach::Args),
    /// Pick an object up and put it elsewhere: pick --at X,Y,Z --place X,Y,Z (§6.3's cycle).
    Pick(cmd::demo::PickArgs),
    /// The paper's demonstrations with a verdict: demo manipulation|panel|load.
    Demo(cmd::demo::DemoArgs),
    /// Read a recording (MCAP): summary, CSV export, pressure/servo plot, recovery.
    Log(cmd::log::Args),
    /// Own the link to a crane (or the simulator), record it, and serve other terminals'
    /// status/stop/declare/monitor/plan over a local socket.
    Serve(cmd::serve::Args),
    /// Print a shell completion script: `host-tool completions bash|zsh|fish`.
    Completions {
        /// The shell.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print a man page (roff): `host-tool man | man -l -`, `host-tool man plan`, or write
    /// every page with `--dir DIR`.
    Man {
        /// The subcommand whose page to print (e.g. `plan`, `log export`) [default: host-tool's].
        #[arg(value_name = "SUBCOMMAND")]
        path: Vec<String>,
        /// Write every page (host-tool.1, host-tool-plan.1, …) into DIR (created if missing).
        #[arg(long, value_name = "DIR", conflicts_with = "path")]
        dir: Option<std::path::PathBuf>,
    },
}

impl Command {
    /// Whether the command was asked for JSON (`-j/--json`).
    fn json(&self) -> bool {
        match self {
            Command::States(a) => a.json,
            Command::Fk(a) => a.json,
            Command::Ik(a) => a.json,
            Command::Sun(a) => a.json,
            Command::Station(a) => a.json,
            Command::Aim(a) => a.json,
            Command::Track(a) => a.json,
            Command::Design(a) => a.json,
            Command::Pattern(a) => a.json,
            Command::Plan(a) => a.json,
            Command::Calibrate(a) => a.json,
            Command::Calibration(a) => a.json(),
            Command::Run(a) => a.json,
            Command::Status(a) | Command::Stop(a) => a.json,
            Command::Monitor(a) => a.json,
            Command::Declare(a) => a.json,
            Command::Signing(a) => a.json,
            Command::Param(a) => a.json(),
            Command::Identify(a) => a.json,
            Command::Ports(a) => a.json,
            Command::Flash(a) => a.json,
            Command::Check(a) => a.json,
            Command::Pose(a) => a.json,
            Command::Workspace(a) => a.json,
            Command::Grip(a) => a.json,
            Command::Bend(a) => a.json,
            Command::Vent(a) => a.json,
            Command::Reach(a) => a.json,
            Command::Pick(a) => a.json,
            Command::Demo(a) => a.json,
            _ => false,
        }
    }

    /// Passes the global `-j/--json` to the command; `false` when the command has no JSON output.
    fn set_json(&mut self, on: bool) -> bool {
        match self {
            Command::States(a) => a.json = on,
            Command::Fk(a) => a.json = on,
            Command::Ik(a) => a.json = on,
            Command::Sun(a) => a.json = on,
            Command::Station(a) => a.json = on,
            Command::Aim(a) => a.json = on,
            Command::Track(a) => a.json = on,
            Command::Design(a) => a.json = on,
            Command::Pattern(a) => a.json = on,
            Command::Plan(a) => a.json = on,
            Command::Run(a) => a.json = on,
            Command::Status(a) | Command::Stop(a) => a.json = on,
            Command::Monitor(a) => a.json = on,
            Command::Declare(a) => a.json = on,
            Command::Signing(a) => a.json = on,
            Command::Param(a) => a.set_json(on),
            Command::Identify(a) => a.json = on,
            Command::Ports(a) => a.json = on,
            Command::Flash(a) => a.json = on,
            Command::Check(a) => a.json = on,
            Command::Pose(a) => a.json = on,
            Command::Workspace(a) => a.json = on,
            Command::Grip(a) => a.json = on,
            Command::Bend(a) => a.json = on,
            Command::Vent(a) => a.json = on,
            Command::Reach(a) => a.json = on,
            Command::Pick(a) => a.json = on,
            Command::Demo(a) => a.json = on,
            Command::Calibrate(a) => a.json = on,
            Command::Calibration(a) => a.set_json(on),
            _ => return false,
        }
        true
    }
}

/// Whether the raw arguments ask for JSON (for errors before the arguments parse).
fn json_in_args() -> bool {
    std::env::args_os()
        .skip(1)
        .take_while(|a| a != "--")
        .any(|a| a == "--json" || a == "-j")
}

fn main() -> ExitCode {
    let version: &'static str = Box::leak(cli::version().into_boxed_str());
    let matches = Cli::command().version(version).try_get_matches();
    let mut cli = match matches.and_then(|m| Cli::from_arg_matches(&m)) {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            if code == 2 && json_in_args() {
                let text = e.to_string();
                let first = text.lines().next().unwrap_or("");
                cli::print_json(cli::error_json(
                    first.strip_prefix("error: ").unwrap_or(first),
                    2,
                    None,
                ));
            }
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    cli::set_verbosity(cli.quiet, cli.verbose);
    if cli.json && !cli.command.set_json(true) {
        let name = std::env::args()
            .skip(1)
            .find(|a| !a.starts_with('-'))
            .unwrap_or_default();
        return failure::Failure::usage(format!(
            "-j/--json: `host-tool {name}` has no JSON output (it writes files or text); \
             the commands with results take it"
        ))
        .report(true);
    }
    let json = cli.command.json();
    let result = match cli.command {
        Command::States(args) => cmd::states::run(args),
        Command::Fk(args) => cmd::fk::run(args),
        Command::Ik(args) => cmd::ik::run(args),
        Command::Sun(args) => cmd::sun::run(args),
        Command::Station(args) => cmd::station::run(args),
        Command::Aim(args) => cmd::aim::run(args),
        Command::Track(args) => cmd::track::run(args),
        Command::Design(args) => cmd::design::run(args),
        Command::Pattern(args) => cmd::pattern::run(args),
        Command::Model(args) => cmd::model::run(args),
        Command::Plan(args) => cmd::plan::run(args),
        Command::Calibrate(args) => cmd::calibrate::run(args),
        Command::Calibration(args) => cmd::calibrate::run_show(args),
        Command::Run(args) => cmd::run::run(args),
        Command::Status(args) => cmd::status::run(args),
        Command::Monitor(args) => cmd::monitor::run(args),
        Command::Declare(args) => cmd::declare::run(args),
        Command::Param(args) => cmd::param::run(args),
        Command::Stop(args) => cmd::stop::run(args),
        Command::Signing(args) => cmd::signing::run(args),
        Command::Identify(args) => cmd::identify::run(args),
        Command::Ports(args) => cmd::ports::run(args),
        Command::Flash(args) => cmd::flash::run(args),
        Command::Check(args) => cmd::check::run(args),
        Command::Log(args) => cmd::log::run(args),
        Command::Pose(args) => cmd::pose::run_pose(args),
        Command::Workspace(args) => cmd::pose::run_workspace(args),
        Command::Grip(args) => cmd::prim::run_grip(args),
        Command::Bend(args) => cmd::prim::run_bend(args),
        Command::Vent(args) => cmd::prim::run_vent(args),
        Command::Reach(args) => cmd::reach::run(args),
        Command::Pick(args) => cmd::demo::run_pick(args),
        Command::Demo(args) => cmd::demo::run_demo(args),
        Command::Serve(args) => cmd::serve::run(args),
        Command::Completions { shell } => {
            out_raw!("{}", completions::script(shell, Cli::command()));
            Ok(())
        }
        Command::Man { path, dir } => man(Cli::command().version(version), &path, dir.as_deref()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => failure.report(json),
    }
}
