//! Where the `host-tool serve` servers' sockets live: a directory only the user can enter
//! (`$XDG_RUNTIME_DIR/host-tool`, else `/tmp/host-tool-UID`, mode 0700; each socket 0600), one
//! per device: the port's path with `/` as `_`, or `sim` for a simulator.

use std::os::unix::net::UnixStream;
use std::path::PathBuf;

/// The directory of the servers' sockets (created 0700 by [`socket_dir_create`]).
pub fn socket_dir() -> PathBuf {
    match std::env::var_os("XDG_RUNTIME_DIR") {
        Some(d) if !d.is_empty() => PathBuf::from(d).join("host-tool"),
        _ => PathBuf::from(format!("/tmp/host-tool-{}", uid())),
    }
}

/// This process's user id (the owner of `/proc/self`).
fn uid() -> u32 {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata("/proc/self").map_or(0, |m| m.uid())
}

/// Creates the socket directory, user-only; refuses one that others can enter or that
/// belongs to someone else.
pub fn socket_dir_create() -> anyhow::Result<PathBuf> {
    use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
    let dir = socket_dir();
    if !dir.exists() {
        std::fs::DirBuilder::new()
            .mode(0o700)
            .recursive(true)
            .create(&dir)?;
    }
    let meta = std::fs::metadata(&dir)?;
    if meta.uid() != uid() {
        anyhow::bail!("{} belongs to another user", dir.display());
    }
    if meta.permissions().mode() & 0o077 != 0 {
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700))?;
    }
    Ok(dir)
}

/// The socket's file name for a device: `sim`, or the port's path.
pub fn socket_name(port: Option<&str>) -> String {
    match port {
        None => "sim.sock".into(),
        Some(p) => format!("{}.sock", p.replace('/', "_")),
    }
}

/// The devices whose server socket is left behind by a server that no longer runs (killed
/// before it could remove it): the device (`the simulator` or the port) and the socket.
pub fn stale_servers() -> Vec<(String, PathBuf)> {
    let Ok(entries) = std::fs::read_dir(socket_dir()) else {
        return Vec::new();
    };
    let mut stale: Vec<(String, PathBuf)> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "sock"))
        .filter(|p| UnixStream::connect(p).is_err())
        .filter_map(|p| {
            let stem = p.file_stem()?.to_string_lossy().into_owned();
            let device = if stem == "sim" {
                "the simulator".to_string()
            } else {
                stem.replace('_', "/")
            };
            Some((device, p))
        })
        .collect();
    stale.sort();
    stale
}
