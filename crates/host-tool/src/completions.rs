//! Shell completion scripts: clap_complete's, with the values of the options that take names
//! (trunk states, fault names, solvers, metrics, ports) and clap_complete's bash script repaired
//! for a binary whose name has a hyphen.

use clap::builder::PossibleValuesParser;
use clap::{Command, ValueHint};
use clap_complete::Shell;

/// The completion script for `shell`.
pub fn script(shell: Shell, cmd: Command) -> String {
    let mut cmd = with_values(cmd);
    let mut out = Vec::new();
    clap_complete::generate(shell, &mut cmd, "host-tool", &mut out);
    let text = String::from_utf8_lossy(&out).into_owned();
    match shell {
        // clap_complete names a subcommand's case arm after the binary with its `-` escaped
        // once more (`host__subcmd__tool__subcmd__plan`) than the `cmd` it compares with
        // (`host__tool__subcmd__plan`), so no option of any subcommand completed.
        Shell::Bash => text.replace("host__subcmd__tool", "host__tool"),
        _ => text,
    }
}

/// The trunk states as a shell can take them unquoted (`F-P`, which every command accepts as
/// `F&P`).
fn state_words() -> Vec<String> {
    geometry::TrunkState::ALL
        .iter()
        .map(|s| s.name().replace('&', "-"))
        .collect()
}

/// `cmd` with the possible values of its name-taking options (for the script only: the parsing
/// command keeps its own parsers and their messages).
fn with_values(cmd: Command) -> Command {
    let states = state_words();
    let faults: Vec<String> = hil_sim::fault::Fault::ALL
        .iter()
        .map(|f| f.name().to_owned())
        .collect();
    let name = cmd.get_name().to_owned();
    let ids: Vec<String> = cmd
        .get_arguments()
        .map(|a| a.get_id().as_str().to_owned())
        .collect();
    let mut cmd = cmd;
    for id in ids {
        let values: Option<Vec<String>> = match (name.as_str(), id.as_str()) {
            ("plan", "target" | "from") | ("declare", "state") | (_, "sim_initial") => {
                Some(states.clone())
            }
            (_, "sim_faults") => Some(faults.clone()),
            ("ik", "algo") => Some(
                planner::ik::Algorithm::NAMES
                    .iter()
                    .map(|n| (*n).to_owned())
                    .collect(),
            ),
            ("ik", "metric") => Some(
                [planner::ik::Metric::Eq36, planner::ik::Metric::Ordered]
                    .map(|m| m.name().to_owned())
                    .to_vec(),
            ),
            _ => None,
        };
        cmd = cmd.mut_arg(&id, |a| match values {
            Some(v) => a.value_parser(PossibleValuesParser::new(v)),
            None if id == "port" => a.value_hint(ValueHint::FilePath),
            None => a,
        });
    }
    let subs: Vec<String> = cmd
        .get_subcommands()
        .map(|s| s.get_name().to_owned())
        .collect();
    for sub in subs {
        cmd = cmd.mut_subcommand(&sub, with_values);
    }
    cmd
}
