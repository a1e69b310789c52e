//! A client of the simulator's pseudo-terminal as an outside process is one: the real host
//! engine ([`host::Driver`]) over the pty's device file, on the wall clock.

use std::fs::File;
use std::io::{Read, Write};
use std::os::fd::AsFd;
use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;
use std::time::Instant;

use host::{Driver, Host, Timing};

/// The pty's device file as the engine's I/O.
pub struct PtyIo {
    port: File,
    start: Instant,
}

impl host::Io for PtyIo {
    fn now_ms(&mut self) -> u64 {
        self.start.elapsed().as_millis() as u64
    }

    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.port.write_all(bytes)
    }

    /// Waits for bytes (20 ms at most, or up to the deadline) and takes what came.
    fn read(&mut self, deadline_ms: u64, buf: &mut Vec<u8>) -> std::io::Result<()> {
        let wait = deadline_ms.saturating_sub(self.now_ms()).min(20) as u16;
        let mut fds = [nix::poll::PollFd::new(
            self.port.as_fd(),
            nix::poll::PollFlags::POLLIN,
        )];
        let _ = nix::poll::poll(&mut fds, nix::poll::PollTimeout::from(wait));
        let mut chunk = [0u8; 1024];
        loop {
            match self.port.read(&mut chunk) {
                Ok(0) => return Ok(()),
                Ok(n) => buf.extend_from_slice(&chunk[..n]),
                // Nothing yet (EIO: the simulator's side of the pty is not open yet).
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::Interrupted
                    ) || e.raw_os_error() == Some(nix::libc::EIO) =>
                {
                    return Ok(())
                }
                Err(e) => return Err(e),
            }
        }
    }
}

/// A host process on the pty at `path` that has sent nothing; `first_seq` should differ
/// between the hosts of one device (it answers a repeated frame from its cache).
pub fn pty_host(path: &Path, first_seq: u16) -> Driver<PtyIo> {
    let port = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(nix::fcntl::OFlag::O_NONBLOCK.bits() | nix::fcntl::OFlag::O_NOCTTY.bits())
        .open(path)
        .expect("open the device path");
    let io = PtyIo {
        port,
        start: Instant::now(),
    };
    Driver::new(Host::new(Timing::standard(), first_seq), io)
}
