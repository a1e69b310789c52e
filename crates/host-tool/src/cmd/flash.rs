//! `host-tool flash`: write the crane's firmware to an UNO R4 through its Arduino bootloader,
//! verify it, and check that the board then answers as this host's firmware.
//!
//! Steps: find the board (`--port`, `$CRANE_PORT`, or the one UNO R4 by USB VID:PID), check the
//! image (an ELF or a `.bin` from the application's flash origin 0x4000, fitting its 240 KiB,
//! a vector table there), the 1200-baud touch (the WiFi's ESP32-S3 bridge then pulses the
//! RA4M1's reset twice: its bootloader stays), the bootloader's SAM-BA dialect at 230 400 Bd
//! ([`samba`]: identify, write 4 KiB blocks, verify each by CRC-16), reset into the new
//! firmware, and the protocol's handshake at 115 200 Bd: its version, protocol and schema id
//! against this host's. A verify that fails leaves the board in its bootloader (parked, every
//! actuator released: docs/hardware.md), so a half-written image never runs.
//!
//! The UNO R4 Minima's bootloader is USB DFU only; this command refuses it and prints the
//! `dfu-util` line instead (docs/flashing.md).

pub mod image;
pub mod samba;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use serde_json::json;
use serialport::{SerialPortInfo, SerialPortType};

use crate::failure::Failure;
use crate::transport::ARDUINO_VID;
use samba::{Samba, BLOCK};

/// Arguments of `host-tool flash`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The board's serial port, e.g. /dev/ttyACM0. Default: $CRANE_PORT, else the one UNO R4
    /// plugged in (by USB VID:PID; asked on a terminal when several).
    #[arg(short, long, value_name = "PATH")]
    pub port: Option<String>,
    /// Which board is on --port when its USB id cannot be read (a pseudo-terminal, a port the
    /// system lists without one); with a USB id it must agree.
    #[arg(long, value_enum)]
    pub board: Option<BoardKind>,
    /// The firmware: an ELF (the `uno-r4` binary) or a flat .bin from 0x4000 (dist/uno-r4.bin)
    /// [default: this checkout's `cargo firmware` build,
    /// target/thumbv7em-none-eabihf/firmware/uno-r4].
    #[arg(long, value_name = "FILE")]
    pub image: Option<PathBuf>,
    /// Also write the checked flat image (what goes to 0x4000) to FILE: an ELF's `.bin`
    /// without objcopy.
    #[arg(long, value_name = "FILE.bin")]
    pub save_bin: Option<PathBuf>,
    /// Check the image (and write --save-bin) only: no board is looked for or touched.
    #[arg(long)]
    pub dry_run: bool,
    /// Print one JSON object.
    #[arg(skip)]
    pub json: bool,
}

/// The two boards the firmware runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BoardKind {
    /// Arduino UNO R4 WiFi (USB 2341:1002; SAM-BA bootloader behind the ESP32-S3 bridge).
    Wifi,
    /// Arduino UNO R4 Minima (USB 2341:0069; USB DFU bootloader 2341:0369).
    Minima,
}

impl BoardKind {
    fn name(self) -> &'static str {
        match self {
            BoardKind::Wifi => "UNO R4 WiFi",
            BoardKind::Minima => "UNO R4 Minima",
        }
    }
}

/// The board a USB id is, with whether it is in its bootloader.
pub fn board_of(vid: u16, pid: u16) -> Option<(BoardKind, bool)> {
    if vid != ARDUINO_VID {
        return None;
    }
    match pid {
        0x1002 => Some((BoardKind::Wifi, false)),
        0x006D => Some((BoardKind::Wifi, true)),
        0x0069 => Some((BoardKind::Minima, false)),
        0x0369 => Some((BoardKind::Minima, true)),
        _ => None,
    }
}

/// The board to flash.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Target {
    /// Its serial port.
    pub path: String,
    /// Which board.
    pub board: BoardKind,
    /// Already in its bootloader (no touch needed).
    pub in_bootloader: bool,
}

fn usb_id(p: &SerialPortInfo) -> Option<(u16, u16, Option<&str>)> {
    match &p.port_type {
        SerialPortType::UsbPort(u) => Some((u.vid, u.pid, u.product.as_deref())),
        _ => None,
    }
}

/// Which board to flash, from the ports the system lists, `--port` (or `$CRANE_PORT`) and
/// `--board`; `ask` picks among several boards on a terminal.
pub fn resolve(
    ports: &[SerialPortInfo],
    port: Option<&str>,
    board: Option<BoardKind>,
    ask: Option<&mut crate::cmd::ports::Ask<'_>>,
) -> Result<Target, Failure> {
    let ids = "USB 2341:1002 UNO R4 WiFi, 2341:0069 UNO R4 Minima (bootloaders 2341:006D, \
               2341:0369)";
    if let Some(path) = port {
        if path.trim().is_empty() {
            return Err(Failure::usage(
                "--port needs a device path, e.g. /dev/ttyACM0",
            ));
        }
        let listed = ports.iter().find(|p| p.port_name == path).and_then(usb_id);
        return match (listed, board) {
            (Some((vid, pid, product)), given) => match board_of(vid, pid) {
                Some((b, boot)) if given.is_none_or(|g| g == b) => Ok(Target {
                    path: path.to_string(),
                    board: b,
                    in_bootloader: boot,
                }),
                Some((b, _)) => Err(Failure::usage(format!(
                    "{path} is an {} by its USB id {vid:04x}:{pid:04x}, not the {} --board names",
                    b.name(),
                    given.map_or("", BoardKind::name)
                ))),
                None => Err(Failure::Runtime(anyhow::anyhow!(
                    "{path} is USB {vid:04x}:{pid:04x}{}, not an UNO R4 ({ids}): wrong board, \
                     nothing was written",
                    product.map(|p| format!(" ({p})")).unwrap_or_default()
                ))),
            },
            (None, Some(b)) => Ok(Target {
                path: path.to_string(),
                board: b,
                in_bootloader: false,
            }),
            (None, None) => Err(Failure::usage(format!(
                "which board is on {path}? The system gives it no USB id: say --board wifi or \
                 --board minima"
            ))),
        };
    }
    let found: Vec<(String, BoardKind, bool)> = ports
        .iter()
        .filter_map(|p| {
            let (vid, pid, _) = usb_id(p)?;
            let (b, boot) = board_of(vid, pid)?;
            board
                .is_none_or(|g| g == b)
                .then(|| (p.port_name.clone(), b, boot))
        })
        .collect();
    if found.is_empty() {
        let seen: Vec<String> = ports
            .iter()
            .map(|p| match usb_id(p) {
                Some((v, d, _)) => format!("{} (USB {v:04x}:{d:04x})", p.port_name),
                None => p.port_name.clone(),
            })
            .collect();
        return Err(Failure::usage(format!(
            "no {} is plugged in ({ids}); {}: plug it in, or give --port PATH (and --board)",
            board.map_or("UNO R4", BoardKind::name),
            if seen.is_empty() {
                "no serial port at all".to_string()
            } else {
                format!("ports seen: {}", seen.join(", "))
            }
        )));
    }
    let named: Vec<(String, &str)> = found
        .iter()
        .map(|(p, b, boot)| {
            (
                p.clone(),
                if *boot {
                    match b {
                        BoardKind::Wifi => "UNO R4 WiFi (bootloader)",
                        BoardKind::Minima => "UNO R4 Minima (bootloader)",
                    }
                } else {
                    b.name()
                },
            )
        })
        .collect();
    let path = crate::cmd::ports::choose(&named, ask)?;
    let (path, board, in_bootloader) = found
        .into_iter()
        .find(|(p, _, _)| *p == path)
        .ok_or_else(|| Failure::usage(format!("{path} is none of the boards found")))?;
    Ok(Target {
        path,
        board,
        in_bootloader,
    })
}

/// The `dfu-util` line for the Minima (docs/flashing.md), for `bin`.
fn minima_refusal(bin: &str) -> String {
    format!(
        "the UNO R4 Minima's bootloader speaks USB DFU only, which host-tool does not: \
         double-tap its reset button (the LED fades), then run\n  \
         dfu-util --device 0x2341:0x0369 -a 0 -D {bin} -Q\n\
         (dfu-util's own package; `host-tool flash` writes the WiFi)"
    )
}

/// The default image: this checkout's `cargo firmware` build.
fn default_image() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../target")));
    target.join("thumbv7em-none-eabihf/firmware/uno-r4")
}

fn runtime(msg: impl std::fmt::Display) -> Failure {
    Failure::Runtime(anyhow::anyhow!("{msg}"))
}

/// How long the bootloader has to answer after the touch: the bridge's two 100 ms reset
/// pulses, the bootloader's start, and a USB re-open.
const BOOTLOADER_WAIT: Duration = Duration::from_secs(5);

/// How long the touch's resets take before the bootloader listens.
const TOUCH_SETTLE: Duration = Duration::from_millis(500);

/// The 1200-baud touch: opening the port at 1200 Bd makes the WiFi's bridge reset the RA4M1
/// twice (its double tap: the bootloader stays); bossac drops DTR and closes, so does this.
fn touch(path: &str) -> Result<(), Failure> {
    let mut port = serialport::new(path, 1200)
        .timeout(Duration::from_millis(10))
        .open_native()
        .map_err(|e| runtime(format!("cannot open {path} at 1200 Bd for the touch: {e}")))?;
    // A pseudo-terminal has no modem lines: nothing to drop.
    let _ = serialport::SerialPort::write_data_terminal_ready(&mut port, false);
    drop(port);
    // The bridge pulses the reset for 3 × 100 ms inside its line-coding callback, then the
    // bootloader starts: a port opened at another rate before that would only change the
    // rate under a board still in reset.
    std::thread::sleep(TOUCH_SETTLE);
    Ok(())
}

/// Opens the port at the bootloader's rate and waits for its answer to `N#`.
fn reach_bootloader(path: &str) -> Result<Samba<crate::transport::Port>, Failure> {
    let start = Instant::now();
    let mut last = String::new();
    while start.elapsed() < BOOTLOADER_WAIT {
        match crate::transport::open_at(path, samba::BOOTLOADER_BAUD) {
            Ok(port) => {
                let mut s = Samba::new(port);
                match s.hello(Duration::from_millis(250)) {
                    Ok(()) => {
                        // Earlier `N#`s may be answered late: let them pass.
                        s.drain(Duration::from_millis(50));
                        return Ok(s);
                    }
                    Err(e) => last = e.to_string(),
                }
            }
            Err(e) => {
                last = format!("{e:#}");
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    }
    Err(runtime(format!(
        "no bootloader answered on {path} within {} s of the 1200-baud touch ({last}); \
         double-tap the board's reset button (the LED fades in and out) and run flash again: \
         nothing was written",
        BOOTLOADER_WAIT.as_secs()
    )))
}

/// Runs `host-tool flash`.
pub fn run(args: Args) -> Result<(), Failure> {
    let image_path = args.image.clone().unwrap_or_else(default_image);
    if args.image.is_none() && !image_path.exists() {
        return Err(Failure::usage(format!(
            "no firmware image at {}: build it with `cargo firmware` (or `bash .ci/firmware.sh`), \
             or give --image FILE (a release image: dist/uno-r4.bin, docs/flashing.md)",
            image_path.display()
        )));
    }
    let image = image::load(&image_path).map_err(|e| {
        Failure::usage(format!(
            "refusing the image: {e}; nothing was sent to a board"
        ))
    })?;
    let blocks = image.bytes.len().div_ceil(BLOCK);
    if let Some(out) = &args.save_bin {
        std::fs::write(out, &image.bytes)
            .map_err(|e| Failure::usage(format!("cannot write {}: {e}", out.display())))?;
        crate::say!("wrote {} ({} bytes)", out.display(), image.bytes.len());
    }
    if args.dry_run {
        let crc = samba::crc16(&image.bytes);
        if args.json {
            crate::cli::print_json(json!({
                "ok": true,
                "image": {"path": image_path.display().to_string(), "bytes": image.bytes.len(),
                          "blocks": blocks, "crc16": format!("{crc:#06x}"),
                          "initial_sp": format!("{:#010x}", image.initial_sp),
                          "reset_vector": format!("{:#010x}", image.reset_vector)},
                "saved": args.save_bin.as_ref().map(|p| p.display().to_string()),
            }));
        } else {
            crate::out!(
                "{}: {} bytes ({blocks} blocks of 4 KiB) for {:#06x}, stack {:#010x}, reset \
                 {:#010x}, CRC-16 {crc:#06x}: a valid image (dry run: no board touched)",
                image_path.display(),
                image.bytes.len(),
                image::FLASH_ORIGIN,
                image.initial_sp,
                image.reset_vector
            );
        }
        return Ok(());
    }
    if args.board == Some(BoardKind::Minima) {
        return Err(Failure::usage(minima_refusal(
            &image_path.display().to_string(),
        )));
    }
    let port = args.port.clone().or_else(|| {
        std::env::var(crate::device::PORT_ENV)
            .ok()
            .filter(|p| !p.trim().is_empty())
    });
    let ports = if port.is_some() && args.board.is_some() {
        // The board is named: the system's list adds nothing but must not contradict it.
        crate::cmd::ports::list().unwrap_or_default()
    } else {
        crate::cmd::ports::list()?
    };
    let terminal = {
        use std::io::IsTerminal as _;
        std::io::stdin().is_terminal() && std::io::stderr().is_terminal()
    };
    let mut ask = crate::cmd::ports::ask;
    let target = resolve(
        &ports,
        port.as_deref(),
        args.board,
        terminal.then_some(&mut ask as &mut crate::cmd::ports::Ask<'_>),
    )?;
    if target.board == BoardKind::Minima {
        return Err(runtime(format!(
            "{} is an UNO R4 Minima: {}",
            target.path,
            minima_refusal(&image_path.display().to_string())
        )));
    }
    let path = target.path.clone();
    crate::say!(
        "flashing {} ({} bytes, {blocks} blocks of 4 KiB from {:#06x}) to the {} on {path}",
        image_path.display(),
        image.bytes.len(),
        image::FLASH_ORIGIN,
        target.board.name()
    );
    if !target.in_bootloader {
        touch(&path)?;
    }
    let mut sb = reach_bootloader(&path)?;
    let sam = |e: samba::SambaError| runtime(format!("{path}: {e}"));
    let version = sb.version().map_err(sam)?;
    let chip = sb.identify().ok();
    if let Some(why) = samba::not_ours(&version, chip.as_deref()) {
        return Err(runtime(format!(
            "{path} is not an UNO R4 WiFi: {why}; nothing was written"
        )));
    }
    crate::debug!("bootloader: {version}; chip id {chip:?}");
    let started = Instant::now();
    let progress = {
        use std::io::IsTerminal as _;
        std::io::stderr().is_terminal()
    };
    sb.erase().map_err(sam)?;
    for (i, chunk) in image.bytes.chunks(BLOCK).enumerate() {
        let offset = (i * BLOCK) as u32;
        sb.write_block(offset, chunk).map_err(|e| {
            runtime(format!(
                "{path}: writing block {}/{blocks} at {:#07x}: {e}; the application area is \
                 partly written and the board stays in its bootloader: run flash again",
                i + 1,
                image::FLASH_ORIGIN + offset
            ))
        })?;
        if progress {
            crate::say_raw!("\rwritten {}/{blocks} blocks", i + 1);
        }
    }
    if progress {
        crate::say!("");
    }
    let written_ms = started.elapsed().as_millis();
    let mut bad = Vec::new();
    for (i, chunk) in image.bytes.chunks(BLOCK).enumerate() {
        let offset = (i * BLOCK) as u32;
        let got = sb.checksum(offset, chunk.len()).map_err(|e| {
            runtime(format!(
                "{path}: verifying block {}/{blocks}: {e}; the board stays in its bootloader",
                i + 1
            ))
        })?;
        let want = samba::crc16(chunk);
        if got != want {
            bad.push(format!(
                "{:#07x} (flash CRC {got:#06x}, image {want:#06x})",
                image::FLASH_ORIGIN + offset
            ));
        }
    }
    if !bad.is_empty() {
        return Err(runtime(format!(
            "{path}: verify failed: {} of {blocks} blocks differ from the image: {}; the board \
             stays in its bootloader (nothing runs; every actuator pin released): run flash \
             again, and if it fails again the board's flash may be worn",
            bad.len(),
            bad.join(", ")
        )));
    }
    crate::say!(
        "wrote {blocks} blocks in {} ms, verified each by CRC-16; resetting into the firmware",
        written_ms
    );
    sb.reset().map_err(sam)?;
    drop(sb);
    // The bootloader waits 500 ms after the reset before it starts the application; the
    // port stays at the bootloader's rate until `K#` has left.
    std::thread::sleep(TOUCH_SETTLE);
    let conn = handshake(&path)?;
    let info = conn.info.clone();
    let _ = conn.close();
    let host_fw = env!("CARGO_PKG_VERSION");
    let fw = format!(
        "{}.{}.{}",
        info.firmware_version[0], info.firmware_version[1], info.firmware_version[2]
    );
    let same_fw = fw == host_fw;
    if args.json {
        crate::cli::print_json(json!({
            "ok": true,
            "port": path,
            "board": target.board.name(),
            "image": {"path": image_path.display().to_string(), "bytes": image.bytes.len(),
                      "blocks": blocks, "crc16": format!("{:#06x}", samba::crc16(&image.bytes))},
            "verified": true,
            "bootloader": version,
            "device": {
                "firmware_version": fw,
                "protocol_version": info.protocol_version,
                "schema_id": format!("{:#010x}", info.schema_id),
                "board": host::text::board(info.board),
                "reset_cause": format!("{:?}", info.reset_cause),
            },
            "host": {
                "version": host_fw,
                "protocol_version": protocol::PROTOCOL_VERSION,
                "schema_id": format!("{:#010x}", protocol::SCHEMA_ID),
            },
            "versions_match": same_fw,
        }));
    } else {
        crate::out!(
            "flashed and verified: {} bytes on {path}",
            image.bytes.len()
        );
        crate::out!(
            "device: firmware {fw}, protocol {}, schema {:#010x}, {}",
            info.protocol_version,
            info.schema_id,
            host::text::board(info.board)
        );
        crate::out!(
            "host:   host-tool {host_fw}, protocol {}, schema {:#010x}: {}",
            protocol::PROTOCOL_VERSION,
            protocol::SCHEMA_ID,
            if same_fw {
                "the same"
            } else {
                "the same protocol and schema; another firmware version"
            }
        );
    }
    Ok(())
}

/// Opens the port at the link's rate and does the handshake, retrying while the board boots
/// (its bootloader waits 500 ms after the reset).
fn handshake(path: &str) -> Result<crate::device::Connection, Failure> {
    let start = Instant::now();
    let cfg = crate::device::DeviceConfig::Port(path.to_string());
    loop {
        match cfg.connect() {
            Ok(c) => return Ok(c),
            // Another protocol or schema: the answer is final.
            Err(
                e @ crate::device::ConnectError::Handshake {
                    source: host::SessionError::VersionMismatch(_),
                    ..
                },
            ) => {
                return Err(runtime(format!(
                    "the image was written and verified, but the firmware it runs is not this \
                     host's: {e}"
                )))
            }
            Err(e) if start.elapsed() > Duration::from_secs(8) => {
                return Err(runtime(format!(
                    "the image was written and verified, but the board did not answer the \
                     handshake after its reset: {e}"
                )))
            }
            Err(_) => std::thread::sleep(Duration::from_millis(200)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serialport::UsbPortInfo;

    fn usb(path: &str, vid: u16, pid: u16) -> SerialPortInfo {
        SerialPortInfo {
            port_name: path.into(),
            port_type: SerialPortType::UsbPort(UsbPortInfo {
                vid,
                pid,
                serial_number: None,
                manufacturer: None,
                product: Some("a product".into()),
            }),
        }
    }

    #[test]
    fn the_board_is_found_by_its_usb_id() {
        let ports = [
            usb("/dev/ttyUSB0", 0x1a86, 0x7523),
            usb("/dev/ttyACM0", 0x2341, 0x1002),
        ];
        let t = resolve(&ports, None, None, None).unwrap();
        assert_eq!(
            t,
            Target {
                path: "/dev/ttyACM0".into(),
                board: BoardKind::Wifi,
                in_bootloader: false
            }
        );
        let boot = resolve(&[usb("/dev/ttyACM3", 0x2341, 0x006D)], None, None, None).unwrap();
        assert!(boot.in_bootloader && boot.board == BoardKind::Wifi);
        let minima = resolve(&[usb("/dev/ttyACM1", 0x2341, 0x0069)], None, None, None).unwrap();
        assert_eq!(minima.board, BoardKind::Minima);
    }

    #[test]
    fn no_board_or_another_board_is_refused_naming_what_was_seen() {
        let Err(Failure::Usage(none)) = resolve(&[], None, None, None) else {
            panic!("no port is a usage error")
        };
        assert!(
            none.contains("no serial port at all") && none.contains("2341:1002"),
            "{none}"
        );
        // An Arduino Uno R3 (2341:0043) and a CH340: neither is an UNO R4.
        let other = [
            usb("/dev/ttyACM0", 0x2341, 0x0043),
            usb("/dev/ttyUSB0", 0x1a86, 0x7523),
        ];
        let Err(Failure::Usage(msg)) = resolve(&other, None, None, None) else {
            panic!("other boards only is a usage error")
        };
        assert!(msg.contains("/dev/ttyACM0 (USB 2341:0043)"), "{msg}");
        // Named by --port, another board is a wrong board (exit 1, nothing written).
        let Err(Failure::Runtime(e)) = resolve(&other, Some("/dev/ttyUSB0"), None, None) else {
            panic!("a port with another USB id is refused")
        };
        assert!(e.to_string().contains("1a86:7523"), "{e}");
        // A --board that contradicts the USB id.
        let wifi = [usb("/dev/ttyACM0", 0x2341, 0x1002)];
        assert!(matches!(
            resolve(&wifi, Some("/dev/ttyACM0"), Some(BoardKind::Minima), None),
            Err(Failure::Usage(_))
        ));
        // Only a Minima plugged in, the WiFi asked for.
        let minima = [usb("/dev/ttyACM1", 0x2341, 0x0069)];
        assert!(matches!(
            resolve(&minima, None, Some(BoardKind::Wifi), None),
            Err(Failure::Usage(_))
        ));
    }

    #[test]
    fn a_port_without_a_usb_id_needs_board() {
        let Err(Failure::Usage(msg)) = resolve(&[], Some("/dev/pts/7"), None, None) else {
            panic!("no board named")
        };
        assert!(msg.contains("--board wifi"), "{msg}");
        let t = resolve(&[], Some("/dev/pts/7"), Some(BoardKind::Wifi), None).unwrap();
        assert_eq!(t.board, BoardKind::Wifi);
        // Several boards, no terminal: listed.
        let two = [
            usb("/dev/ttyACM0", 0x2341, 0x1002),
            usb("/dev/ttyACM1", 0x2341, 0x1002),
        ];
        let Err(Failure::Usage(msg)) = resolve(&two, None, None, None) else {
            panic!("two boards, no terminal")
        };
        assert!(msg.contains("/dev/ttyACM1"), "{msg}");
    }
}
