//! `host-tool ports`: serial ports, with Arduino UNO R4 boards recognised by USB id.

use std::io::{IsTerminal as _, Write as _};

use serde_json::json;
use serialport::SerialPortType;

use crate::failure::Failure;
use crate::transport::arduino_board;

/// Arguments of `host-tool ports`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print a JSON array on stdout.
    #[arg(skip)]
    pub json: bool,
}

/// The serial ports of this machine.
pub fn list() -> Result<Vec<serialport::SerialPortInfo>, Failure> {
    // serialport's sysfs scan panics when /sys/class/tty is missing (containers): check first.
    if cfg!(target_os = "linux") && !std::path::Path::new("/sys/class/tty").is_dir() {
        return Ok(Vec::new());
    }
    serialport::available_ports()
        .map_err(|e| Failure::Runtime(anyhow::anyhow!("listing serial ports: {e}")))
}

/// Whether a USB id is an UNO R4 running its sketch (not its bootloader): one the crane's
/// firmware can answer on.
pub fn is_uno_r4(vid: u16, pid: u16) -> bool {
    matches!(
        arduino_board(vid, pid),
        Some("UNO R4 WiFi" | "UNO R4 Minima")
    )
}

/// The port of the crane when none was given: the only UNO R4 plugged in; with several, the
/// one the operator picks on a terminal; otherwise a usage error listing them.
pub fn detect() -> Result<String, Failure> {
    let found: Vec<(String, &'static str)> = list()?
        .into_iter()
        .filter_map(|p| match p.port_type {
            SerialPortType::UsbPort(u) if is_uno_r4(u.vid, u.pid) => {
                arduino_board(u.vid, u.pid).map(|b| (p.port_name, b))
            }
            _ => None,
        })
        .collect();
    let terminal = std::io::stdin().is_terminal() && std::io::stderr().is_terminal();
    choose(&found, terminal.then_some(&mut ask as &mut Ask<'_>))
}

/// Asks the operator with a prompt; the answer, if any.
pub type Ask<'a> = dyn FnMut(&str) -> Option<String> + 'a;

/// Reads the operator's choice after showing `prompt`.
pub fn ask(prompt: &str) -> Option<String> {
    let _ = write!(std::io::stderr(), "{prompt}");
    let mut line = String::new();
    std::io::stdin().read_line(&mut line).ok()?;
    Some(line.trim().to_string())
}

/// [`detect`]'s rule over the UNO R4 ports found: one → it; several → `ask` (a number or a
/// path) when there is a terminal, else an error listing them; none → the usage error.
pub fn choose(found: &[(String, &str)], ask: Option<&mut Ask<'_>>) -> Result<String, Failure> {
    let listing = || {
        found
            .iter()
            .enumerate()
            .map(|(i, (p, b))| format!("  {}) {p} ({b})", i + 1))
            .collect::<Vec<_>>()
            .join("\n")
    };
    match (found, ask) {
        ([], _) => {
            // A killed server leaves its socket: say so, rather than only that no board is here.
            let dead: Vec<String> = crate::sockets::stale_servers()
                .into_iter()
                .map(|(device, sock)| {
                    format!(
                        "the server of {device} is not running (a killed `host-tool serve` left {})",
                        sock.display()
                    )
                })
                .collect();
            Err(Failure::usage(format!(
                "this command acts on a crane and no UNO R4 is plugged in{}: give --port PATH \
                 (or set CRANE_PORT; `host-tool ports` lists the ports) or --sim for the \
                 built-in simulator{}",
                if dead.is_empty() {
                    String::new()
                } else {
                    format!(", and no server answers: {}", dead.join("; "))
                },
                if dead.is_empty() {
                    ""
                } else {
                    "; start `host-tool serve` again to serve that device (it replaces the old socket)"
                }
            )))
        }
        ([(path, board)], _) => {
            crate::say!("using {path} ({board}), the only UNO R4 found");
            Ok(path.clone())
        }
        (_, Some(ask)) => {
            let answer = ask(&format!(
                "{} UNO R4 boards are plugged in:\n{}\nwhich one (number)? ",
                found.len(),
                listing()
            ))
            .unwrap_or_default();
            let pick = answer
                .parse::<usize>()
                .ok()
                .and_then(|i| i.checked_sub(1))
                .and_then(|i| found.get(i))
                .or_else(|| found.iter().find(|(p, _)| *p == answer));
            pick.map(|(p, _)| p.clone()).ok_or_else(|| {
                Failure::usage(format!(
                    "'{answer}' is none of the {} boards; give --port PATH",
                    found.len()
                ))
            })
        }
        (_, None) => Err(Failure::usage(format!(
            "{} UNO R4 boards are plugged in; say which with --port PATH (or CRANE_PORT):\n{}",
            found.len(),
            listing()
        ))),
    }
}

/// Runs `host-tool ports`.
pub fn run(args: Args) -> Result<(), Failure> {
    let ports = list()?;
    let rows: Vec<_> = ports
        .iter()
        .map(|p| match &p.port_type {
            SerialPortType::UsbPort(usb) => json!({
                "path": p.port_name,
                "type": "usb",
                "vid": format!("{:04x}", usb.vid),
                "pid": format!("{:04x}", usb.pid),
                "product": usb.product,
                "manufacturer": usb.manufacturer,
                "serial_number": usb.serial_number,
                "board": arduino_board(usb.vid, usb.pid),
                "uno_r4": is_uno_r4(usb.vid, usb.pid),
            }),
            SerialPortType::PciPort => json!({"path": p.port_name, "type": "pci", "board": null}),
            SerialPortType::BluetoothPort => {
                json!({"path": p.port_name, "type": "bluetooth", "board": null})
            }
            SerialPortType::Unknown => {
                json!({"path": p.port_name, "type": "unknown", "board": null})
            }
        })
        .collect();
    if args.json {
        crate::cli::print_json(serde_json::Value::Array(rows));
        return Ok(());
    }
    if rows.is_empty() {
        crate::out!("no serial ports found (use --sim to try host-tool without hardware)");
        return Ok(());
    }
    crate::out!(
        "{:<20} {:<7} {:<9} {}",
        "PORT",
        "TYPE",
        "VID:PID",
        "PRODUCT / BOARD"
    );
    for r in &rows {
        let mut line = format!(
            "{:<20} {:<7}",
            r["path"].as_str().unwrap_or("?"),
            r["type"].as_str().unwrap_or("?")
        );
        match (r["vid"].as_str(), r["pid"].as_str()) {
            (Some(vid), Some(pid)) => line += &format!(" {vid}:{pid}"),
            _ => line += "          ",
        }
        if let Some(product) = r["product"].as_str() {
            line += &format!(" \"{product}\"");
        }
        if let Some(board) = r["board"].as_str() {
            line += &format!("  ← {board}");
            if r["uno_r4"] == true {
                line += " (a crane's board: used when no --port is given)";
            }
        }
        crate::out!("{}", line.trim_end());
    }
    if !rows.iter().any(|r| r["uno_r4"] == true) {
        crate::out!(
            "no UNO R4 found: plug the crane's board in (USB), or give --port PATH; --sim runs the built-in simulator"
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn found(n: usize) -> Vec<(String, &'static str)> {
        (0..n)
            .map(|i| (format!("/dev/ttyACM{i}"), "UNO R4 WiFi"))
            .collect()
    }

    #[test]
    fn the_only_uno_r4_is_used_several_are_asked_for_or_listed() {
        assert_eq!(choose(&found(1), None).ok(), Some("/dev/ttyACM0".into()));
        let Err(Failure::Usage(none)) = choose(&[], None) else {
            panic!("no board is a usage error")
        };
        assert!(none.contains("--port") && none.contains("CRANE_PORT") && none.contains("--sim"));
        let Err(Failure::Usage(many)) = choose(&found(2), None) else {
            panic!("two boards without a terminal is a usage error")
        };
        assert!(
            many.contains("/dev/ttyACM0") && many.contains("/dev/ttyACM1"),
            "{many}"
        );
        let mut second = |prompt: &str| {
            assert!(prompt.contains("2) /dev/ttyACM1"), "{prompt}");
            Some("2".to_string())
        };
        assert_eq!(
            choose(&found(2), Some(&mut second)).ok(),
            Some("/dev/ttyACM1".into())
        );
        let mut by_path = |_: &str| Some("/dev/ttyACM0".to_string());
        assert_eq!(
            choose(&found(3), Some(&mut by_path)).ok(),
            Some("/dev/ttyACM0".into())
        );
        let mut wrong = |_: &str| Some("7".to_string());
        assert!(matches!(
            choose(&found(2), Some(&mut wrong)),
            Err(Failure::Usage(_))
        ));
    }

    #[test]
    fn only_a_sketch_running_uno_r4_counts_as_a_crane() {
        // arduino/ArduinoCore-renesas boards.txt: unor4wifi 2341:1002, minima 2341:0069; their
        // second ids (006D, 0369) are the bootloaders.
        assert!(is_uno_r4(0x2341, 0x1002));
        assert!(is_uno_r4(0x2341, 0x0069));
        assert!(!is_uno_r4(0x2341, 0x006D));
        assert!(!is_uno_r4(0x2341, 0x0369));
        assert!(!is_uno_r4(0x2341, 0x0043));
        assert!(!is_uno_r4(0x1a86, 0x7523));
    }
}
