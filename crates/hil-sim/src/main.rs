//! `hil-sim`: the simulated crane on a pseudo-terminal, or the transition discovery.
//!
//! ```text
//! hil-sim --pty [--sim-initial STATE] [--seed N] [--sim-fault NAME]... [--sim-speed X]
//!         [--no-operator] [--firmware-elf PATH] [--truth-log FILE]
//! hil-sim discover [--json | --dot]
//! ```
//! The simulator's options have `host-tool`'s names and defaults (`--sim-initial F&P`,
//! `--seed 1`, `--sim-fault`, `--sim-speed`; the old `--initial`, `--fault`, `--speed` are
//! aliases). With `--pty` the first line of stdout ends with the device path; the simulator then
//! runs until SIGINT, SIGTERM or SIGHUP (exit 130, as host-tool, the truth log's last line
//! written). Usage errors exit with 2, runtime failures with 1.
#![forbid(unsafe_code)]

use std::io::Write as _;
use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use geometry::TrunkState;
use hil_sim::discovery::{self, RigConfig};
use hil_sim::pty::PtySim;
use hil_sim::{Fault, SimOptions};

#[derive(Debug, Parser)]
#[command(
    name = "hil-sim",
    version,
    about = "Simulated Yoshimura crane (trunk physics + hardware) running the real firmware controller",
    args_conflicts_with_subcommands = true,
    propagate_version = true,
    after_help = "Examples:\n  hil-sim --pty --sim-initial 'D&F' --sim-speed 5\n  hil-sim discover --dot | dot -Tsvg > graph.svg\n\nExit codes: 0 success, 1 runtime failure, 2 usage error, 130 ended by SIGINT, SIGTERM or SIGHUP.\nState names hold '&': quote them ('D&F')."
)]
struct Cli {
    /// Serve the controller's serial link on a pseudo-terminal (prints the device path).
    #[arg(long)]
    pty: bool,
    /// The trunk's state at start, quoted: 'F&P', 'F&F', 'F&D', 'D&P', 'D&F' or 'D&D'.
    #[arg(long, alias = "initial", value_name = "STATE", default_value = "F&P", value_parser = parse_state)]
    sim_initial: TrunkState,
    /// Seed of the simulation's randomness, any integer (negative ones count modulo 2^64; same
    /// seed, same run).
    #[arg(long, value_name = "N", default_value = "1", allow_negative_numbers = true,
          value_parser = hil_sim::cli::parse_seed)]
    seed: u64,
    /// Inject a fault (repeatable): valve-stuck-closed, valve-stuck-open, leak, servo-stall,
    /// tendon-break, sensor-dropout, link-drop, line-noise.
    #[arg(long = "sim-fault", alias = "fault", value_name = "NAME", value_parser = parse_fault)]
    faults: Vec<Fault>,
    /// Virtual seconds per wall second [range: 0.1–20]: a pty client keeps the hardware's
    /// wall-clock timing, and the controller's link timeout (3 s × speed) goes up to 60 s.
    /// Default 1: real time, as the crane.
    #[arg(long, alias = "speed", value_name = "X", default_value = "1", value_parser = parse_speed, allow_negative_numbers = true)]
    sim_speed: f64,
    /// No simulated operator: manual steps wait for the host or a real person.
    #[arg(long)]
    no_operator: bool,
    /// Append the ground truth to FILE (with --pty): one JSON object per line whenever the
    /// trunk's true state, the actuators' safety or the fault set changes, and once at exit:
    /// {"t_ms", "true_state" (a state or "between"), "pressure_kpa", "actuators_safe", ...}.
    #[arg(long, value_name = "FILE", requires = "pty")]
    truth_log: Option<std::path::PathBuf>,
    /// An object in the simulator's world (repeatable, with --pty): its grasp point X,Y,Z mm
    /// (base frame, z ≥ 0 above the table) and mass (default 0.05 kg), e.g. cup:40,0,60,0.1.
    /// Closing the gripper within 15 mm of it holds it; opening drops it to the table.
    #[arg(long = "object", value_name = "NAME:X,Y,Z[,MASS_KG]", requires = "pty",
          value_parser = parse_object)]
    objects: Vec<hil_sim::world::Object>,
    /// A load hung on the tip, kg (0 to 50; with --pty), whatever the gripper does.
    #[arg(
        long,
        value_name = "M",
        requires = "pty",
        allow_negative_numbers = true
    )]
    tip_load_kg: Option<f64>,
    /// Run this board ELF (`cargo firmware`: target/thumbv7em-none-eabihf/firmware/uno-r4) in
    /// the RA4M1 emulator instead of the host-built controller (processor in the loop).
    #[arg(long, value_name = "PATH")]
    firmware_elf: Option<std::path::PathBuf>,
    /// The simulated trunk's description (TOML, as trunks/pdf.toml, the calibrated default):
    /// its snap forces, wells, pneumatics, tendons and sensor error (docs/simulator.md).
    #[arg(long, visible_alias = "trunk", value_name = "FILE")]
    sim_trunk: Option<std::path::PathBuf>,
    /// Scale every snap force of the simulated trunk by K [range: 0.1 to 10]; a trunk the
    /// physics cannot represent (e.g. 1.35: the top's barriers overlap) is refused.
    #[arg(long, value_name = "K", allow_negative_numbers = true,
          value_parser = hil_sim::cli::parse_trunk_scale)]
    sim_trunk_scale: Option<f64>,
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Deterministic simulation testing: random scenarios (targets, faults with onsets, line
    /// noise, power cuts, host crashes, operator mistakes) checked against invariants.
    Swarm {
        /// Scenarios to run (seeds SEED, SEED+1, …).
        #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u64).range(1..=10_000_000))]
        runs: u64,
        /// The first scenario's seed, any integer (negative ones count modulo 2^64).
        #[arg(long, default_value = "0", allow_negative_numbers = true,
              value_parser = hil_sim::cli::parse_seed)]
        seed: u64,
        /// Run one scenario and print its trace.
        #[arg(long, value_name = "SEED", conflicts_with_all = ["runs", "seed"],
              allow_negative_numbers = true, value_parser = hil_sim::cli::parse_seed)]
        replay: Option<u64>,
        /// Worker threads [default: the machine's cores].
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..=256))]
        threads: Option<u64>,
        /// Print one JSON object (runs, virtual_hours, violations, …).
        #[arg(long)]
        json: bool,
        /// Leave out the operator's mistakes at manual steps (a wrong fold, a refusal).
        #[arg(long)]
        no_operator_mistakes: bool,
        /// Draw each scenario's trunk around the base trunk: every parameter times its own
        /// factor, uniform in [1 - F, 1 + F] [range: 0 <= F < 1]; the drawn trunk is part of
        /// the scenario (printed, and the same under --replay with the same F).
        #[arg(long, value_name = "F", default_value = "0", allow_negative_numbers = true,
              value_parser = hil_sim::cli::parse_trunk_spread)]
        trunk_spread: f64,
        /// The simulated trunk's description (TOML, as trunks/pdf.toml, the calibrated default):
        /// its snap forces, wells, pneumatics, tendons and sensor error (docs/simulator.md).
        #[arg(long, visible_alias = "trunk", value_name = "FILE")]
        sim_trunk: Option<std::path::PathBuf>,
        /// Scale every snap force of the simulated trunk by K [range: 0.1 to 10]; a trunk the
        /// physics cannot represent (e.g. 1.35: the top's barriers overlap) is refused.
        #[arg(long, value_name = "K", allow_negative_numbers = true,
                  value_parser = hil_sim::cli::parse_trunk_scale)]
        sim_trunk_scale: Option<f64>,
        /// Calibrate each scenario's trunk first (host::calibration, as `host-tool calibrate
        /// --sim`), on a twin of its crane with nothing injected and judged by the same
        /// invariants; the scenario then runs as drawn, its plans on the measured thresholds
        /// (the catalogue's when the walk is refused, which is counted).
        #[arg(long)]
        calibrate: bool,
        /// Also count the scenarios whose trunk's physics makes every actuated transition of
        /// the catalogue within the crane's 40 kPa and 185 mm (hil-sim discover on each drawn
        /// trunk), and their targets reached.
        #[arg(long)]
        split_feasible: bool,
    },
    /// Discover the transition graph the simulated trunk supports.
    Discover {
        /// Print JSON (the default).
        #[arg(long, conflicts_with = "dot")]
        json: bool,
        /// Print Graphviz DOT.
        #[arg(long)]
        dot: bool,
    },
}

/// The version line: the crate version, the protocol version and the wire schema id.
fn version() -> String {
    format!(
        "{} (protocol {}, schema {:#010x})",
        env!("CARGO_PKG_VERSION"),
        protocol::PROTOCOL_VERSION,
        protocol::SCHEMA_ID
    )
}

fn parse_state(s: &str) -> Result<TrunkState, String> {
    s.parse()
        .map_err(|e| format!("{e}{}", hil_sim::cli::ampersand_hint(s)))
}

fn parse_fault(s: &str) -> Result<Fault, String> {
    s.parse().map_err(|e| format!("{e}"))
}

fn parse_object(s: &str) -> Result<hil_sim::world::Object, String> {
    hil_sim::world::Object::parse(s).map_err(|e| e.to_string())
}

fn parse_speed(s: &str) -> Result<f64, String> {
    let v = s
        .trim()
        .parse::<f64>()
        .map_err(|_| format!("`{s}` is not a number"))?;
    hil_sim::pty::check_pty_speed(v)?;
    Ok(v)
}

fn main() -> ExitCode {
    let version: &'static str = Box::leak(version().into_boxed_str());
    let cli = match Cli::command()
        .version(version)
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m))
    {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::from(2)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    match cli.command {
        Some(Command::Swarm {
            runs,
            seed,
            replay,
            threads,
            json,
            no_operator_mistakes,
            trunk_spread,
            sim_trunk,
            sim_trunk_scale,
            calibrate,
            split_feasible,
        }) => {
            let trunk = match hil_sim::cli::sim_trunk(sim_trunk.as_deref(), sim_trunk_scale) {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("hil-sim: {e}");
                    return ExitCode::from(2);
                }
            };
            let opts = hil_sim::swarm::ScenarioOptions {
                mistakes: !no_operator_mistakes,
                trunk,
                trunk_spread,
                calibrate,
            };
            let mut again = replay_options(trunk_spread, sim_trunk.as_deref(), sim_trunk_scale);
            if calibrate {
                again += " --calibrate";
            }
            swarm_command(
                (runs, seed, replay, threads),
                json,
                split_feasible,
                &opts,
                &again,
            )
        }
        Some(Command::Discover { dot, .. }) => {
            let g = discovery::discover(RigConfig::default());
            let out = if dot {
                discovery::to_dot(&g)
            } else {
                match serde_json::to_string_pretty(&discovery::to_json(&g)) {
                    Ok(s) => s + "\n",
                    Err(e) => {
                        eprintln!("hil-sim: {e}");
                        return ExitCode::from(1);
                    }
                }
            };
            print!("{out}");
            ExitCode::SUCCESS
        }
        None if cli.pty => {
            let trunk = match hil_sim::cli::sim_trunk(cli.sim_trunk.as_deref(), cli.sim_trunk_scale)
            {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("hil-sim: {e}");
                    return ExitCode::from(2);
                }
            };
            let opts = SimOptions {
                trunk,
                initial: cli.sim_initial,
                seed: cli.seed,
                faults: cli.faults,
                speed: cli.sim_speed,
                operator: !cli.no_operator,
                firmware_elf: cli.firmware_elf.clone(),
            };
            let log = match cli.truth_log.as_deref().map(|p| {
                std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(p)
                    .map_err(|e| format!("cannot open the truth log {}: {e}", p.display()))
            }) {
                None => None,
                Some(Ok(f)) => Some(f),
                Some(Err(e)) => {
                    eprintln!("hil-sim: {e}");
                    return ExitCode::from(1);
                }
            };
            let (tx, rx) = std::sync::mpsc::channel();
            if let Err(e) = ctrlc::set_handler(move || {
                let _ = tx.send(());
            }) {
                eprintln!("hil-sim: cannot handle signals: {e}");
                return ExitCode::from(1);
            }
            let world = match hil_sim::world::World::with(
                cli.objects.clone(),
                cli.tip_load_kg.unwrap_or(0.0),
            ) {
                Ok(w) => w,
                Err(e) => {
                    eprintln!("hil-sim: {e}");
                    return ExitCode::from(2);
                }
            };
            let sim = match PtySim::spawn_in_world(opts, log, world) {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("hil-sim: {e:#}");
                    return ExitCode::from(1);
                }
            };
            let mut out = std::io::stdout();
            let _ = writeln!(
                out,
                "hil-sim: simulated crane (initial {}, seed {}, speed {}{}) on {}",
                cli.sim_initial,
                cli.seed,
                cli.sim_speed,
                cli.firmware_elf
                    .as_ref()
                    .map_or(String::new(), |p| format!(", board ELF {}", p.display())),
                sim.path().display()
            );
            let _ = out.flush();
            // Until SIGINT, SIGTERM or SIGHUP; then stop cleanly (the truth log's final line)
            // and exit as an interrupted command does (130, as host-tool).
            let _ = rx.recv();
            sim.stop();
            ExitCode::from(130)
        }
        None => {
            eprintln!("hil-sim: nothing to do; use --pty or `hil-sim discover` (see --help)");
            ExitCode::from(2)
        }
    }
}

/// The trunk options a `--replay` needs to run the same scenario.
fn replay_options(spread: f64, file: Option<&std::path::Path>, scale: Option<f64>) -> String {
    let mut s = String::new();
    if spread > 0.0 {
        s += &format!(" --trunk-spread {spread}");
    }
    if let Some(f) = file {
        s += &format!(" --sim-trunk {}", f.display());
    }
    if let Some(k) = scale {
        s += &format!(" --sim-trunk-scale {k}");
    }
    s
}

fn swarm_command(
    (runs, seed, replay, threads): (u64, u64, Option<u64>, Option<u64>),
    json: bool,
    split: bool,
    opts: &hil_sim::swarm::ScenarioOptions,
    again: &str,
) -> ExitCode {
    use hil_sim::swarm;
    // The options were checked above: a scenario cannot fail to be drawn.
    let make = |seed: u64| {
        swarm::Scenario::generate_with(seed, opts)
            .unwrap_or_else(|e| unreachable!("checked options: {e}"))
    };
    let mut out = std::io::stdout();
    if let Some(seed) = replay {
        let scenario = make(seed);
        let rep = swarm::run(&scenario, true);
        if json {
            let _ = writeln!(
                out,
                "{}",
                report_json(1, rep.virtual_ms, &rep.violations, &[])
            );
        } else {
            let _ = writeln!(out, "{}", scenario.describe());
            let _ = write!(out, "{}", rep.trace);
            match &rep.calibration {
                Some(Ok(ms)) => {
                    let _ = writeln!(
                        out,
                        "calibrated in {:.1} s of virtual time",
                        *ms as f64 / 1000.0
                    );
                }
                Some(Err(e)) => {
                    let _ = writeln!(out, "{e}: the plans used the catalogue's thresholds");
                }
                None => {}
            }
            let _ = writeln!(
                out,
                "reached {}/{} targets in {:.1} s of virtual time; {} violation(s)",
                rep.reached,
                scenario.targets.len(),
                rep.virtual_ms as f64 / 1000.0,
                rep.violations.len()
            );
        }
        return if rep.violations.is_empty() {
            ExitCode::SUCCESS
        } else {
            ExitCode::from(1)
        };
    }
    let threads = threads.map_or_else(
        || std::thread::available_parallelism().map_or(1, |n| n.get()),
        |t| t as usize,
    );
    let wall = std::time::Instant::now();
    let rep = swarm::swarm_split(seed, runs, threads, &make, split);
    let wall_s = wall.elapsed().as_secs_f64();
    // Each failing seed, shrunk to the smallest scenario that still fails.
    let mut seeds: Vec<u64> = rep.violations.iter().map(|v| v.seed).collect();
    seeds.dedup();
    let shrunk: Vec<String> = seeds
        .iter()
        .take(10)
        .map(|&s| swarm::shrink(&make(s)).describe())
        .collect();
    if json {
        let mut v = report_json(rep.runs, rep.virtual_ms, &rep.violations, &shrunk);
        v["targets"] = serde_json::json!(rep.targets);
        v["reached"] = serde_json::json!(rep.reached);
        v["wall_s"] = serde_json::json!(wall_s);
        if let Some((n, t, r)) = rep.feasible {
            v["feasible"] = serde_json::json!({"runs": n, "targets": t, "reached": r});
        }
        if opts.calibrate {
            v["calibrations"] = serde_json::json!(rep.calibrations);
            v["calibrations_refused"] = serde_json::json!(rep.calibrations_refused);
            v["calibration_virtual_hours"] = serde_json::json!(rep.calibration_ms as f64 / 3.6e6);
        }
        let _ = writeln!(out, "{v}");
    } else {
        let _ = writeln!(
            out,
            "{} runs, {:.1} virtual hours in {:.1} s of wall time ({:.0}× real time); \
             {}/{} targets reached; {} violation(s)",
            rep.runs,
            rep.virtual_ms as f64 / 3.6e6,
            wall_s,
            rep.virtual_ms as f64 / 1000.0 / wall_s.max(1e-9),
            rep.reached,
            rep.targets,
            rep.violations.len()
        );
        if opts.calibrate {
            let _ = writeln!(
                out,
                "  calibrations: {} walked in {:.1} virtual hours, {} refused (those scenarios \
                 ran on the catalogue's thresholds)",
                rep.calibrations,
                rep.calibration_ms as f64 / 3.6e6,
                rep.calibrations_refused
            );
        }
        if let Some((n, t, r)) = rep.feasible {
            let _ = writeln!(
                out,
                "  on the {n} trunks whose physics makes every catalogue transition within the \
                 crane's limits: {r}/{t} targets reached"
            );
        }
        for v in &rep.violations {
            let _ = writeln!(
                out,
                "  seed {} at {} ms: {}: {}  (hil-sim swarm --replay {}{again})",
                v.seed, v.t_ms, v.invariant, v.detail, v.seed
            );
        }
        for s in &shrunk {
            let _ = writeln!(out, "  shrunk: {s}");
        }
    }
    if rep.violations.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

fn report_json(
    runs: u64,
    virtual_ms: u64,
    violations: &[hil_sim::swarm::Violation],
    shrunk: &[String],
) -> serde_json::Value {
    serde_json::json!({
        "runs": runs,
        "virtual_hours": virtual_ms as f64 / 3.6e6,
        "violations": violations.iter().map(|v| serde_json::json!({
            "seed": v.seed,
            "t_ms": v.t_ms,
            "invariant": v.invariant,
            "detail": v.detail,
        })).collect::<Vec<_>>(),
        "shrunk": shrunk,
    })
}
