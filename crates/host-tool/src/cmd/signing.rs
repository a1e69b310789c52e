//! `host-tool signing pair|off|show`: link signing (docs/host.md, "Link signing"). `pair`
//! makes a new random key, writes it to `--key-file` (readable by the user only) and gives it
//! to the device, which keeps it in its store and from then on requires every session-bound
//! request to be signed with it; `off` (signed, so it needs the key in force) turns signing off
//! and makes the device forget the key; `show` says whether the device signs.

use std::io::{Read, Write};
use std::path::PathBuf;

use protocol::RequestBody;
use serde_json::json;

use crate::cli::DeviceError;
use crate::device::DeviceArgs;
use crate::failure::Failure;

/// Arguments of `host-tool signing`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// What to do.
    #[command(subcommand)]
    pub action: Action,
    /// Print one JSON object on stdout.
    #[arg(skip)]
    pub json: bool,
}

/// `signing` subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum Action {
    /// Pair: a new random key into --key-file (created, never overwritten), given to the device;
    /// signing is on from then on. While signing is already on, --link-key must hold the key in
    /// force (the new key replaces it).
    Pair {
        /// Where to write the new key (32 hex digits; mode 0600). It must not exist.
        #[arg(long, value_name = "FILE")]
        key_file: PathBuf,
        #[command(flatten)]
        device: DeviceArgs,
    },
    /// Turn signing off; the device forgets its key (needs --link-key: the change is signed).
    Off {
        #[command(flatten)]
        device: DeviceArgs,
    },
    /// Whether the device signs its link (from the handshake).
    Show {
        #[command(flatten)]
        device: DeviceArgs,
    },
}

/// Runs `host-tool signing`.
pub fn run(args: Args) -> Result<(), Failure> {
    match args.action {
        Action::Pair { key_file, device } => pair(&key_file, &device, args.json),
        Action::Off { device } => off(&device, args.json),
        Action::Show { device } => show(&device, args.json),
    }
}

fn show(device: &DeviceArgs, json: bool) -> Result<(), Failure> {
    let conn = device.validate(None)?.connect()?;
    let on = conn.info.signing;
    if json {
        crate::cli::print_json(json!({ "ok": true, "signing": on }));
    } else {
        crate::out!("link signing: {}", if on { "on" } else { "off" });
    }
    Ok(())
}

/// A new key from the system's random source.
fn new_key() -> Result<protocol::sign::LinkKey, Failure> {
    let mut key = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut key))
        .map_err(|e| Failure::Runtime(anyhow::anyhow!("cannot read /dev/urandom: {e}")))?;
    Ok(key)
}

fn pair(key_file: &std::path::Path, device: &DeviceArgs, json: bool) -> Result<(), Failure> {
    if key_file.exists() {
        return Err(Failure::usage(format!(
            "{} exists: `signing pair` writes a new key and never overwrites one (move it away \
             first, or give another --key-file)",
            key_file.display()
        )));
    }
    let cfg = device.validate(None)?;
    let key = new_key()?;
    // Written before the device gets it, so a key the device keeps is never lost here.
    let mut f = {
        use std::os::unix::fs::OpenOptionsExt;
        std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(0o600)
            .open(key_file)
            .map_err(|e| Failure::usage(format!("cannot create {}: {e}", key_file.display())))?
    };
    let hex: String = key.iter().map(|b| format!("{b:02x}")).collect();
    writeln!(f, "{hex}")
        .map_err(|e| Failure::Runtime(anyhow::anyhow!("writing {}: {e}", key_file.display())))?;
    drop(f);
    let result = set_on(&cfg, key);
    if result.is_err() {
        // The device did not take it: the file would name a key nobody uses.
        let _ = std::fs::remove_file(key_file);
    }
    result?;
    if json {
        crate::cli::print_json(json!({
            "ok": true,
            "signing": true,
            "key_file": key_file.display().to_string(),
        }));
    } else {
        crate::out!(
            "paired: link signing is on; the key is in {} (give it to every command with \
             --link-key {} or ${}={})",
            key_file.display(),
            key_file.display(),
            crate::device::LINK_KEY_ENV,
            key_file.display()
        );
    }
    Ok(())
}

fn set_on(cfg: &crate::device::DeviceConfig, key: protocol::sign::LinkKey) -> Result<(), Failure> {
    let mut conn = cfg.connect()?;
    conn.session
        .command(RequestBody::SetSigning { key, enabled: true })
        .map_err(|e| refused("pairing", &e))?;
    Ok(())
}

fn off(device: &DeviceArgs, json: bool) -> Result<(), Failure> {
    let mut conn = device.validate(None)?.connect()?;
    if !conn.info.signing {
        if json {
            crate::cli::print_json(json!({ "ok": true, "signing": false }));
        } else {
            crate::out!("link signing is already off");
        }
        return Ok(());
    }
    conn.session
        .command(RequestBody::SetSigning {
            key: [0; 16],
            enabled: false,
        })
        .map_err(|e| refused("turning signing off", &e))?;
    if json {
        crate::cli::print_json(json!({ "ok": true, "signing": false }));
    } else {
        crate::out!("link signing is off; the device forgot its key");
    }
    Ok(())
}

fn refused(what: &str, e: &host::SessionError) -> Failure {
    let hint = match e {
        host::SessionError::Rejected {
            reason: protocol::RejectReason::NotAllowed,
            ..
        } => " (this firmware has no link signing, or its store cannot keep a key)",
        _ => "",
    };
    Failure::Runtime(anyhow::Error::new(DeviceError::session(
        &format!("{what} failed{hint}: "),
        e,
    )))
}
