//! `host-tool ports`: serial ports, with Arduino UNO R4 boards recognised by USB id.

use serde_json::json;
use serialport::SerialPortType;

use crate::failure::Failure;
use crate::transport::arduino_board;

/// Arguments of `host-tool ports`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print a JSON array on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `host-tool ports`.
pub fn run(args: Args) -> Result<(), Failure> {
    // serialport's sysfs scan panics when /sys/class/tty is missing (containers): check first.
    let ports = if cfg!(target_os = "linux") && !std::path::Path::new("/sys/class/tty").is_dir() {
        Vec::new()
    } else {
        serialport::available_ports().map_err(|e| anyhow::anyhow!("listing serial ports: {e}"))?
    };
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
        crate::out!("{}", serde_json::Value::Array(rows));
        return Ok(());
    }
    if rows.is_empty() {
        crate::out!("no serial ports found (use --sim, or the default simulator, to try host-tool without hardware)");
        return Ok(());
    }
    for r in &rows {
        let mut line = format!(
            "{:<20} {}",
            r["path"].as_str().unwrap_or("?"),
            r["type"].as_str().unwrap_or("?")
        );
        if let (Some(vid), Some(pid)) = (r["vid"].as_str(), r["pid"].as_str()) {
            line += &format!(" {vid}:{pid}");
        }
        if let Some(product) = r["product"].as_str() {
            line += &format!(" \"{product}\"");
        }
        if let Some(board) = r["board"].as_str() {
            line += &format!("  ← {board}");
        }
        crate::out!("{line}");
    }
    Ok(())
}
