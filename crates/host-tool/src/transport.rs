//! The byte transport to a device, as the host engine's I/O ([`host::Io`]): a serial port on
//! the wall clock (a real crane, or a simulator's pseudo-terminal), or the simulator in-process
//! on its virtual clock ([`hil_sim::pair::SimIo`]).

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use hil_sim::pair::SimIo;

/// The link's baud rate (ignored by USB CDC-ACM and ptys, used by a real UART bridge).
pub const BAUD: u32 = 115_200;

/// How long one read may block: short, so the engine's deadlines stay precise and a signal is
/// seen within a few ms.
const READ_TIMEOUT: Duration = Duration::from_millis(2);
/// Longest wait of one [`host::Io::read`] on a serial port, so the shell looks at its signals
/// (Ctrl-C, SIGTERM, SIGHUP) at least this often.
const MAX_WAIT: Duration = Duration::from_millis(20);

/// An open serial port.
pub type Port = Box<dyn serialport::SerialPort>;

/// A serial port on the wall clock.
pub struct SerialIo {
    port: Port,
    start: Instant,
}

impl SerialIo {
    /// The I/O over an open port; its clock starts now.
    pub fn new(port: Port) -> Self {
        Self {
            port,
            start: Instant::now(),
        }
    }
}

impl host::Io for SerialIo {
    fn now_ms(&mut self) -> u64 {
        self.start.elapsed().as_millis() as u64
    }

    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()
    }

    fn read(&mut self, deadline_ms: u64, buf: &mut Vec<u8>) -> std::io::Result<()> {
        let until =
            (self.start + Duration::from_millis(deadline_ms)).min(Instant::now() + MAX_WAIT);
        let mut chunk = [0u8; 512];
        loop {
            match self.port.read(&mut chunk) {
                Ok(0) => {}
                Ok(n) => {
                    buf.extend_from_slice(&chunk[..n]);
                    return Ok(());
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::TimedOut
                            | std::io::ErrorKind::WouldBlock
                            | std::io::ErrorKind::Interrupted
                    ) => {}
                Err(e) => return Err(e),
            }
            if Instant::now() >= until {
                return Ok(());
            }
        }
    }
}

/// The engine's I/O: a serial port or the in-process simulator.
pub enum AnyIo {
    /// A serial device (a crane, or an outside simulator's pty).
    Serial(SerialIo),
    /// The simulator, in-process on its own clock.
    Sim(Box<SimIo>),
}

impl host::Io for AnyIo {
    fn now_ms(&mut self) -> u64 {
        match self {
            AnyIo::Serial(io) => io.now_ms(),
            AnyIo::Sim(io) => io.now_ms(),
        }
    }

    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        match self {
            AnyIo::Serial(io) => io.write(bytes),
            AnyIo::Sim(io) => io.write(bytes),
        }
    }

    fn read(&mut self, deadline_ms: u64, buf: &mut Vec<u8>) -> std::io::Result<()> {
        match self {
            AnyIo::Serial(io) => io.read(deadline_ms, buf),
            AnyIo::Sim(io) => io.read(deadline_ms, buf),
        }
    }
}

/// Opens the serial device at `path` (8N1, no flow control, 115200 baud). A port held by
/// another process is named with that process, if the system tells.
pub fn open(path: &str) -> anyhow::Result<Port> {
    open_at(path, BAUD)
}

/// As [`open`], at `baud` (the bootloader's rate for `flash`).
pub fn open_at(path: &str, baud: u32) -> anyhow::Result<Port> {
    // serialport takes TIOCEXCL and an exclusive `flock` itself (root ignores TIOCEXCL, the
    // flock keeps a second host-tool out even then); its own refusal names nobody, so a port
    // that will not open is checked for a holder before its error is passed on.
    let port = match serialport::new(path, baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(READ_TIMEOUT)
        .open_native()
    {
        Ok(port) => port,
        Err(e) => {
            // Whatever the error, a holder of the lock is the reason to name.
            if let Some(holder) = lock_holder(path) {
                anyhow::bail!(in_use(path, &holder));
            }
            return Err(anyhow::Error::new(e).context(format!("cannot open serial port {path}")));
        }
    };
    // One host per crane: the lock serialport took, checked (a build of it that did not take
    // one would let a second host in).
    {
        use std::os::fd::AsRawFd;
        #[allow(deprecated)]
        let locked = nix::fcntl::flock(
            port.as_raw_fd(),
            nix::fcntl::FlockArg::LockExclusiveNonblock,
        );
        if locked.is_err() {
            let holder = lock_holder(path).unwrap_or_else(|| "another process".to_string());
            anyhow::bail!(in_use(path, &holder));
        }
    }
    let port: Port = Box::new(port);
    // Bytes the device sent before we listened would only be decoded as noise. Only the
    // input: whatever is queued toward the device is its business (and it survives garbage).
    let _ = port.clear(serialport::ClearBuffer::Input);
    Ok(port)
}

/// The refusal of a port another process holds: who holds it, and the two ways on.
fn in_use(path: &str, holder: &str) -> String {
    format!(
        "serial port {path} is in use by {holder}: only one host drives the crane at a time. \
         Stop the crane from there (Ctrl-C in that terminal) or with the crane's e-stop; to \
         command it from several terminals, run `host-tool serve --port {path}` in one and \
         `status`, `stop`, `plan`, `param`, `declare` and `monitor` in the others go through it"
    )
}

/// The process that holds the advisory lock on `path` (from `/proc/locks`, Linux), as
/// "process PID (COMMAND LINE)"; none when the system does not tell.
fn lock_holder(path: &str) -> Option<String> {
    use std::os::unix::fs::MetadataExt;
    let meta = std::fs::metadata(path).ok()?;
    let locks = std::fs::read_to_string("/proc/locks").ok()?;
    let me = std::process::id().to_string();
    let pid = locks_holder(&locks, meta.dev(), meta.ino(), &me)?;
    let cmd = std::fs::read(format!("/proc/{pid}/cmdline"))
        .map(|b| {
            String::from_utf8_lossy(&b)
                .split('\0')
                .filter(|s| !s.is_empty())
                .collect::<Vec<_>>()
                .join(" ")
        })
        .unwrap_or_default();
    Some(if cmd.is_empty() {
        format!("process {pid}")
    } else {
        format!("process {pid} ({cmd})")
    })
}

/// The pid (not `me`) holding a `flock` on the file (`dev`, `ino`) in `/proc/locks`' text,
/// whose lines read "1: FLOCK  ADVISORY  WRITE 12345 88:05:7 0 EOF" (the device's major and
/// minor in hex, the inode in decimal).
fn locks_holder(locks: &str, dev: u64, ino: u64, me: &str) -> Option<String> {
    // Linux's st_dev encoding (glibc's gnu_dev_major/minor).
    let major = ((dev >> 8) & 0xfff) | ((dev >> 32) & !0xfff);
    let minor = (dev & 0xff) | ((dev >> 12) & !0xff);
    for line in locks.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        // A lock waiting for another is marked "->" and shifts the fields by one.
        let f: Vec<&str> = f.into_iter().filter(|w| *w != "->").collect();
        if f.len() < 6 || f[1] != "FLOCK" || f[4] == me {
            continue;
        }
        let mut id = f[5].split(':');
        let (Some(ma), Some(mi), Some(i)) = (id.next(), id.next(), id.next()) else {
            continue;
        };
        let same = u64::from_str_radix(ma, 16).ok() == Some(major)
            && u64::from_str_radix(mi, 16).ok() == Some(minor)
            && i.parse::<u64>().ok() == Some(ino);
        if same {
            return Some(f[4].to_string());
        }
    }
    None
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
    fn the_lock_holder_is_read_from_proc_locks_by_device_and_inode() {
        let locks = "1: POSIX  ADVISORY  WRITE 900 00:19:7 0 EOF\n\
                     2: FLOCK  ADVISORY  WRITE 4242 00:1a:7 0 EOF\n\
                     3: FLOCK  ADVISORY  WRITE 4343 00:19:7 0 EOF\n\
                     3: -> FLOCK  ADVISORY  WRITE 4444 00:19:7 0 EOF\n";
        // dev 0x19 = major 0, minor 25: the POSIX lock and the other device's inode 7 are not it.
        assert_eq!(locks_holder(locks, 0x19, 7, "1"), Some("4343".into()));
        assert_eq!(locks_holder(locks, 0x1a, 7, "1"), Some("4242".into()));
        // Our own lock is not a holder to name; nor is a file nobody locked.
        assert_eq!(locks_holder(locks, 0x1a, 7, "4242"), None);
        assert_eq!(locks_holder(locks, 0x19, 8, "1"), None);
        // Major 136 (pty slaves), minor 3.
        let pts = "5: FLOCK  ADVISORY  WRITE 77 88:03:6 0 EOF\n";
        assert_eq!(locks_holder(pts, (136 << 8) | 3, 6, "1"), Some("77".into()));
    }

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
