//! The byte transport to a device: a serial port, real or a simulator's pseudo-terminal.
//!
//! There is exactly one code path: `--sim` opens the simulator's pty with the same
//! `serialport` calls as a USB serial device, so what the end-to-end tests exercise is what a
//! real crane gets.

use std::time::Duration;

use anyhow::Context;

/// The link's baud rate (ignored by USB CDC-ACM and ptys, used by a real UART bridge).
pub const BAUD: u32 = 115_200;

/// How long one read may block: short, so the session's own deadlines stay precise.
const READ_TIMEOUT: Duration = Duration::from_millis(2);

/// An open serial port.
pub type Port = Box<dyn serialport::SerialPort>;

/// Opens the serial device at `path` (8N1, no flow control, 115200 baud).
pub fn open(path: &str) -> anyhow::Result<Port> {
    let port = serialport::new(path, BAUD)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(READ_TIMEOUT)
        .open()
        .with_context(|| format!("cannot open serial port {path}"))?;
    // Bytes the device sent before we listened would only be decoded as noise. Only the
    // input: whatever is queued toward the device is its business (and it survives garbage).
    let _ = port.clear(serialport::ClearBuffer::Input);
    Ok(port)
}

/// The USB vendor id of Arduino boards.
pub const ARDUINO_VID: u16 = 0x2341;

/// The Arduino board a USB id belongs to, if it is one the crane runs on
/// (ids from Arduino's `boards.txt` for the Renesas UNO R4 core: the sketch PID and the
/// bootloader PID of each board).
pub fn arduino_board(vid: u16, pid: u16) -> Option<&'static str> {
    if vid != ARDUINO_VID {
        return None;
    }
    match pid {
        0x1002 => Some("UNO R4 WiFi"),
        0x006D => Some("UNO R4 WiFi (bootloader)"),
        0x0069 => Some("UNO R4 Minima"),
        0x0369 => Some("UNO R4 Minima (bootloader)"),
        _ => Some("Arduino (not an UNO R4)"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uno_r4_boards_are_recognised_by_usb_id() {
        assert_eq!(arduino_board(0x2341, 0x1002), Some("UNO R4 WiFi"));
        assert_eq!(arduino_board(0x2341, 0x0069), Some("UNO R4 Minima"));
        assert_eq!(
            arduino_board(0x2341, 0x0369),
            Some("UNO R4 Minima (bootloader)")
        );
        assert_eq!(
            arduino_board(0x2341, 0x0043),
            Some("Arduino (not an UNO R4)")
        );
        assert_eq!(arduino_board(0x1a86, 0x7523), None);
    }
}
