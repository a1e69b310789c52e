//! A simulated UNO R4 WiFi on a pseudo-terminal, for `host-tool flash`: the ESP32-S3 bridge
//! and the RA4M1's Arduino bootloader as their sources behave.
//!
//! - The bridge (`arduino/uno-r4-wifi-usb-bridge`, `UNOR4USBBridge.ino`): the host's line
//!   coding at 1200 Bd resets the RA4M1 twice, so its bootloader stays; any other rate is
//!   the rate of the RA4M1's UART from then on. Here the pty's termios (`TCGETS2`: the speed
//!   the client set) stands for the line coding, and bytes pass only when the client's rate
//!   is the one the RA4M1 side runs at (230 400 Bd in the bootloader, 115 200 Bd in the
//!   firmware); at any other rate they are lost, as garbled bytes would be.
//! - The bootloader (`arduino/arduino-renesas-bootloader`, `src/bossa.c`): the commands `N`,
//!   `V`, `I`, `X`, `S`, `Y`, `Z`, `K` parsed as it parses them (a 64-byte command buffer, a
//!   command ends at `#`, arguments read at offsets 1 and 10), an 8 KiB RAM buffer, the flash
//!   at 0x4000 with its erase of 4 KiB at every 2 KiB-aligned write; everything else
//!   unanswered. `K` resets: into "the firmware", which is the simulator (the host-built
//!   controller through `hil_sim::Sim`, on the wall clock) answering the crane's protocol.
//! - Its faults, as the real one shows them: no answer (a board that reset or lost its
//!   cable), a write acknowledged but not done (`R_FLASH_LP_Write`'s error ignored), and
//!   another board's bootloader (a different version line).

#![allow(dead_code)]

use std::io::{Read, Write};
use std::os::fd::{AsFd, AsRawFd, OwnedFd};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Application flash: 0x4000..0x40000.
const FLASH_LEN: usize = 240 * 1024;

/// How the simulated board misbehaves.
#[derive(Debug, Clone, Default)]
pub struct Faults {
    /// Answer `V#` with this instead of the UNO R4 WiFi's version line.
    pub version: Option<String>,
    /// Stop answering at the write (`Y dst,size#`) of this offset.
    pub silent_at_write: Option<u32>,
    /// Acknowledge the write of this offset without writing it.
    pub unwritten: Option<u32>,
}

/// What the simulated board saw and did.
#[derive(Debug, Default)]
pub struct Log {
    /// Every command, in order (without their data).
    pub commands: Vec<String>,
    /// Times the bridge reset the RA4M1 into the bootloader (1200-baud touches).
    pub touches: u32,
    /// Times it reset into the firmware (`K#`).
    pub resets: u32,
    /// The application flash at the end.
    pub flash: Vec<u8>,
    /// Every line rate the client set, in order.
    pub bauds: Vec<u32>,
}

/// The simulated board, on its own thread.
pub struct Board {
    /// The pty's device path for `--port`.
    pub path: String,
    log: Arc<Mutex<Log>>,
    stop: Arc<std::sync::atomic::AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Board {
    /// Starts a board in its firmware (answering the protocol), with `faults`.
    pub fn start(faults: Faults) -> Board {
        let pty = nix::pty::openpty(None, None).expect("a pty");
        let mut t = nix::sys::termios::tcgetattr(pty.slave.as_fd()).expect("termios");
        nix::sys::termios::cfmakeraw(&mut t);
        nix::sys::termios::tcsetattr(pty.slave.as_fd(), nix::sys::termios::SetArg::TCSANOW, &t)
            .expect("raw mode");
        let path = nix::unistd::ttyname(pty.slave.as_fd())
            .expect("pty name")
            .to_string_lossy()
            .into_owned();
        let flags = nix::fcntl::fcntl(pty.master.as_raw_fd(), nix::fcntl::FcntlArg::F_GETFL)
            .expect("flags");
        nix::fcntl::fcntl(
            pty.master.as_raw_fd(),
            nix::fcntl::FcntlArg::F_SETFL(
                nix::fcntl::OFlag::from_bits_truncate(flags) | nix::fcntl::OFlag::O_NONBLOCK,
            ),
        )
        .expect("non-blocking");
        let log = Arc::new(Mutex::new(Log {
            flash: vec![0xFF; FLASH_LEN],
            ..Log::default()
        }));
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let thread = {
            let (log, stop) = (log.clone(), stop.clone());
            std::thread::spawn(move || run(pty.master, pty.slave, faults, &log, &stop))
        };
        Board {
            path,
            log,
            stop,
            thread: Some(thread),
        }
    }

    /// Stops the board and returns what it saw.
    pub fn stop(mut self) -> Log {
        self.stop.store(true, std::sync::atomic::Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            t.join().expect("the board's thread");
        }
        std::mem::take(&mut *self.log.lock().expect("log"))
    }
}

/// The speed the client set on the pty (`TCGETS2`: serialport sets any rate with `BOTHER`).
fn client_baud(slave: &OwnedFd) -> u32 {
    let mut t: nix::libc::termios2 = unsafe { std::mem::zeroed() };
    // SAFETY: TCGETS2 writes one `termios2` into the struct the pointer names, which lives
    // for the call; the fd is the pty's open slave.
    let r = unsafe { nix::libc::ioctl(slave.as_raw_fd(), nix::libc::TCGETS2 as _, &mut t) };
    if r == 0 {
        t.c_ospeed
    } else {
        0
    }
}

enum Mode {
    /// Running the firmware: the simulator.
    Firmware(Box<hil_sim::Sim>, Instant),
    /// In the bootloader.
    Bootloader(Loader),
    /// Gone silent (reset mid-write, cable lost).
    Dead,
}

struct Loader {
    cmd: Vec<u8>,
    /// Raw bytes still expected for an `S`, and where they go.
    receiving: Option<(usize, usize)>,
    buffer: Vec<u8>,
    copy_offset: usize,
}

fn firmware() -> Mode {
    let sim = hil_sim::Sim::new(hil_sim::SimOptions {
        seed: 1,
        speed: 1.0,
        ..hil_sim::SimOptions::default()
    });
    Mode::Firmware(Box::new(sim), Instant::now())
}

fn run(
    master: OwnedFd,
    slave: OwnedFd,
    faults: Faults,
    log: &Mutex<Log>,
    stop: &std::sync::atomic::AtomicBool,
) {
    let mut master = std::fs::File::from(master);
    let mut mode = firmware();
    let mut last_baud = client_baud(&slave);
    let mut buf = [0u8; 8192];
    while !stop.load(std::sync::atomic::Ordering::SeqCst) {
        // host-tool takes TIOCEXCL on the port; the test's copy of the slave outlives its
        // opens, so the flag is cleared here, as the last close would clear it.
        // SAFETY: TIOCNXCL takes no argument; the fd is the open slave.
        unsafe { nix::libc::ioctl(slave.as_raw_fd(), nix::libc::TIOCNXCL as _) };
        let baud = client_baud(&slave);
        if baud != last_baud {
            last_baud = baud;
            log.lock().expect("log").bauds.push(baud);
            if baud == 1200 {
                // The bridge's double reset: the bootloader stays.
                log.lock().expect("log").touches += 1;
                mode = Mode::Bootloader(Loader {
                    cmd: Vec::new(),
                    receiving: None,
                    buffer: vec![0; 8192],
                    copy_offset: 0,
                });
            }
        }
        let n: usize = master.read(&mut buf).unwrap_or_default();
        let input = &buf[..n];
        match &mut mode {
            Mode::Dead => {}
            Mode::Firmware(sim, since) => {
                if baud == 115_200 && !input.is_empty() {
                    sim.write_host_bytes(input);
                }
                let target = sim.now_ms().max(since.elapsed().as_millis() as u64);
                while sim.now_ms() < target {
                    sim.step();
                }
                let out = sim.read_device_bytes();

                if baud == 115_200 && !out.is_empty() {
                    let _ = master.write_all(&out);
                }
            }
            Mode::Bootloader(l) => {
                if baud != 230_400 {
                    // The bootloader's UART runs at 230 400 Bd: anything else is noise.
                } else {
                    let mut reply = Vec::new();
                    let mut next = None;
                    for &b in input {
                        if let Some((at, left)) = l.receiving.as_mut() {
                            if *at < l.buffer.len() {
                                l.buffer[*at] = b;
                                *at += 1;
                                *left -= 1;
                            }
                            if *left == 0 {
                                l.receiving = None;
                            }
                            continue;
                        }
                        if l.cmd.len() < 64 {
                            l.cmd.push(b);
                        }
                        if l.cmd.last() != Some(&b'#') {
                            continue;
                        }
                        let cmd = String::from_utf8_lossy(&l.cmd).into_owned();
                        l.cmd.clear();
                        log.lock().expect("log").commands.push(cmd.clone());
                        let arg = |at: usize| {
                            let s = cmd.get(at..).unwrap_or("");
                            let hex: String =
                                s.chars().take_while(|c| c.is_ascii_hexdigit()).collect();
                            usize::from_str_radix(&hex, 16).unwrap_or(0)
                        };
                        match cmd.as_bytes()[0] {
                            b'N' => reply.extend_from_slice(b"\n\r"),
                            b'V' => {
                                let v = faults.version.clone().unwrap_or_else(|| {
                                    "Arduino Bootloader (SAM-BA extended) 2.0 [Arduino:IKXYZ]"
                                        .into()
                                });
                                reply.extend_from_slice(v.as_bytes());
                                reply.extend_from_slice(b"\n\r");
                            }
                            b'I' => reply.extend_from_slice(b"nRF52840-QIAA\n\r"),
                            b'X' => reply.extend_from_slice(b"X\n\r"),
                            b'S' => l.receiving = Some((arg(1), arg(10))),
                            b'Y' => {
                                let (a1, a2) = (arg(1), arg(10));
                                if a2 == 0 {
                                    l.copy_offset = a1;
                                } else {
                                    if faults.silent_at_write == Some(a1 as u32) {
                                        next = Some(Mode::Dead);
                                        break;
                                    }
                                    let mut lg = log.lock().expect("log");
                                    if (0x4000 + a1) % 2048 == 0 && a1 < FLASH_LEN {
                                        let end = (a1 + 4096).min(FLASH_LEN);
                                        lg.flash[a1..end].fill(0xFF);
                                    }
                                    if faults.unwritten != Some(a1 as u32) {
                                        let src = &l.buffer[l.copy_offset..l.copy_offset + a2];
                                        lg.flash[a1..a1 + a2].copy_from_slice(src);
                                    }
                                }
                                reply.extend_from_slice(b"Y\n\r");
                            }
                            b'Z' => {
                                let (a, size) = (arg(1), arg(10).min(4096));
                                let crc = crc16(&log.lock().expect("log").flash[a..a + size]);
                                reply.extend_from_slice(format!("Z{crc:08X}#\n\r").as_bytes());
                            }
                            b'K' => {
                                log.lock().expect("log").resets += 1;
                                next = Some(firmware());
                                break;
                            }
                            _ => {}
                        }
                    }
                    if !reply.is_empty() {
                        let _ = master.write_all(&reply);
                    }
                    if let Some(m) = next {
                        mode = m;
                    }
                }
            }
        }
        if n == 0 {
            std::thread::sleep(Duration::from_millis(1));
        }
    }
}

/// CRC-16/XMODEM, the bootloader's `serial_add_crc`.
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0;
    for &b in bytes {
        crc ^= u16::from(b) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
        }
    }
    crc
}
