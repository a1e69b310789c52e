//! `host-tool flash` against a simulated UNO R4 WiFi on a pseudo-terminal (`support/bootloader.rs`:
//! the bridge's 1200-baud touch, the Arduino bootloader's SAM-BA commands and its failures,
//! then the simulator answering the protocol after the reset).

#[path = "support/bootloader.rs"]
mod bootloader;

use std::path::PathBuf;
use std::process::{Command, Output};

use bootloader::{Board, Faults};
use protocol::{PROTOCOL_VERSION, SCHEMA_ID};

/// A 10 340-byte image (two whole 4 KiB blocks and a part): a vector table for 0x4000 (stack
/// at the top of SRAM, a Thumb reset vector inside), then deterministic bytes.
fn image_bytes() -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&0x2000_8000u32.to_le_bytes());
    b.extend_from_slice(&0x0000_4101u32.to_le_bytes());
    let mut x: u32 = 12345;
    while b.len() < 10_340 {
        x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        b.push((x >> 16) as u8);
    }
    b
}

fn write_image(name: &str, bytes: &[u8]) -> PathBuf {
    let p = std::env::temp_dir().join(format!("flash-{name}-{}.bin", std::process::id()));
    std::fs::write(&p, bytes).unwrap();
    p
}

fn flash(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .arg("flash")
        .args(args)
        .env_remove("CRANE_PORT")
        .stdin(std::process::Stdio::null())
        .output()
        .expect("host-tool runs")
}

fn text(o: &[u8]) -> String {
    String::from_utf8_lossy(o).into_owned()
}

#[test]
fn an_image_is_written_verified_and_the_firmware_then_answers_the_handshake() {
    let img = image_bytes();
    let path = write_image("good", &img);
    let board = Board::start(Faults::default());
    let out = flash(&[
        "--port",
        &board.path,
        "--board",
        "wifi",
        "--image",
        path.to_str().unwrap(),
        "-j",
    ]);
    let log = board.stop();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{} {:?}",
        text(&out.stderr),
        log.commands
    );
    assert_eq!(log.bauds, [1200, 230_400, 115_200]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(v["ok"], true);
    assert_eq!(v["verified"], true);
    assert_eq!(v["image"]["bytes"], 10_340);
    assert_eq!(v["image"]["blocks"], 3);
    assert_eq!(v["device"]["protocol_version"], PROTOCOL_VERSION);
    assert_eq!(v["device"]["schema_id"], format!("{SCHEMA_ID:#010x}"));
    assert_eq!(v["host"]["schema_id"], format!("{SCHEMA_ID:#010x}"));
    assert_eq!(v["device"]["firmware_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(v["versions_match"], true);
    // One touch, one reset; the flash holds the image, the last block's padding zeros after it.
    assert_eq!((log.touches, log.resets), (1, 1));
    assert_eq!(&log.flash[..img.len()], &img[..]);
    assert!(log.flash[img.len()..3 * 4096].iter().all(|b| *b == 0));
    assert!(log.flash[3 * 4096..].iter().all(|b| *b == 0xFF));
    // bossac's sequence, command for command.
    let c = &log.commands;
    let first: Vec<&str> = c.iter().take(4).map(String::as_str).collect();
    assert_eq!(first[0], "N#");
    assert_eq!(&first[1..], ["V#", "I#", "X00000000#"], "{c:?}");
    for (i, off) in [0x0000, 0x1000, 0x2000].iter().enumerate() {
        let at = 4 + 3 * i;
        assert_eq!(c[at], "S00000000,00001000#", "{c:?}");
        assert_eq!(c[at + 1], "Y00000000,0#");
        assert_eq!(c[at + 2], format!("Y{off:08X},00001000#"));
    }
    assert_eq!(c[13], "Z00000000,00001000#");
    assert_eq!(c[14], "Z00001000,00001000#");
    assert_eq!(c[15], format!("Z00002000,{:08X}#", 10_340 - 8192));
    assert_eq!(c.last().map(String::as_str), Some("K#"));
}

#[test]
fn the_text_report_names_the_device_and_the_host_versions() {
    let path = write_image("text", &image_bytes());
    let board = Board::start(Faults::default());
    let out = flash(&[
        "--port",
        &board.path,
        "--board",
        "wifi",
        "--image",
        path.to_str().unwrap(),
    ]);
    board.stop();
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let o = text(&out.stdout);
    let device = format!("protocol {PROTOCOL_VERSION}, schema {SCHEMA_ID:#010x}");
    assert_eq!(o.matches(&device).count(), 2, "{o}");
    assert!(o.contains("flashed and verified: 10340 bytes"), "{o}");
    assert!(o.contains("hil-sim simulator"), "{o}");
}

#[test]
fn a_write_the_bootloader_never_acknowledges_fails_naming_the_block() {
    let path = write_image("silent", &image_bytes());
    let board = Board::start(Faults {
        silent_at_write: Some(0x1000),
        ..Faults::default()
    });
    let out = flash(&[
        "--port",
        &board.path,
        "--board",
        "wifi",
        "--image",
        path.to_str().unwrap(),
    ]);
    let log = board.stop();
    assert_eq!(out.status.code(), Some(1));
    let e = text(&out.stderr);
    assert!(e.contains("writing block 2/3 at 0x05000"), "{e}");
    assert!(
        e.contains("no answer to Y00001000,00001000# within 5000 ms"),
        "{e}"
    );
    assert!(e.contains("run flash again"), "{e}");
    assert_eq!(log.resets, 0);
}

#[test]
fn a_write_that_did_not_take_fails_the_verify_and_the_board_is_not_started() {
    let img = image_bytes();
    let path = write_image("unwritten", &img);
    let board = Board::start(Faults {
        unwritten: Some(0x2000),
        ..Faults::default()
    });
    let out = flash(&[
        "--port",
        &board.path,
        "--board",
        "wifi",
        "--image",
        path.to_str().unwrap(),
        "-j",
    ]);
    let log = board.stop();
    assert_eq!(out.status.code(), Some(1));
    let e = text(&out.stderr);
    let want = bootloader::crc16(&img[0x2000..]);
    // The block was erased (0xFF) and never written.
    let erased = bootloader::crc16(&vec![0xFF; img.len() - 0x2000]);
    assert!(e.contains("verify failed: 1 of 3 blocks differ"), "{e}");
    assert!(
        e.contains(&format!(
            "0x06000 (flash CRC {erased:#06x}, image {want:#06x})"
        )),
        "{e}"
    );
    assert!(e.contains("stays in its bootloader"), "{e}");
    // No `K#`: a half-written image never runs.
    assert_eq!(log.resets, 0);
    assert!(!log.commands.iter().any(|c| c == "K#"));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(
        (v["ok"].clone(), v["exit_code"].clone()),
        (false.into(), 1.into())
    );
}

#[test]
fn another_boards_bootloader_is_refused_before_anything_is_written() {
    let path = write_image("other", &image_bytes());
    // An Arduino Zero's (SAMD21) SAM-BA bootloader line.
    let board = Board::start(Faults {
        version: Some("v2.0 [Arduino:XYZ] Mar 19 2018 09:45:14".into()),
        ..Faults::default()
    });
    let out = flash(&[
        "--port",
        &board.path,
        "--board",
        "wifi",
        "--image",
        path.to_str().unwrap(),
    ]);
    let log = board.stop();
    assert_eq!(out.status.code(), Some(1));
    let e = text(&out.stderr);
    assert!(e.contains("is not an UNO R4 WiFi"), "{e}");
    assert!(e.contains("v2.0 [Arduino:XYZ]"), "{e}");
    assert!(e.contains("nothing was written"), "{e}");
    assert!(
        !log.commands
            .iter()
            .any(|c| c.starts_with('S') || c.starts_with('Y')),
        "{:?}",
        log.commands
    );
}

#[test]
fn images_that_are_not_for_this_flash_map_are_refused_before_the_board_is_touched() {
    let board = Board::start(Faults::default());
    // Linked for 0x0000 (a bare chip): its reset vector lies below 0x4000.
    let mut at_zero = image_bytes();
    at_zero[4..8].copy_from_slice(&0x0000_0101u32.to_le_bytes());
    let p = write_image("origin", &at_zero);
    let out = flash(&[
        "--port",
        &board.path,
        "--board",
        "wifi",
        "--image",
        p.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let e = text(&out.stderr);
    assert!(
        e.contains("another flash origin") && e.contains("nothing was sent"),
        "{e}"
    );
    // Larger than the 240 KiB behind the bootloader.
    let mut big = image_bytes();
    big.resize(240 * 1024 + 1, 0);
    let p = write_image("big", &big);
    let out = flash(&[
        "--port",
        &board.path,
        "--board",
        "wifi",
        "--image",
        p.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("do not fit"),
        "{}",
        text(&out.stderr)
    );
    // The Minima: refused with dfu-util's line.
    let p = write_image("minima", &image_bytes());
    let out = flash(&[
        "--port",
        &board.path,
        "--board",
        "minima",
        "--image",
        p.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let e = text(&out.stderr);
    assert!(e.contains("dfu-util --device 0x2341:0x0369 -a 0 -D"), "{e}");
    // A pty has no USB id: the board must be named.
    let out = flash(&["--port", &board.path, "--image", p.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("--board wifi"),
        "{}",
        text(&out.stderr)
    );
    let log = board.stop();
    assert_eq!(log.touches, 0);
    assert!(log.commands.is_empty(), "{:?}", log.commands);
}

#[test]
fn without_an_image_and_without_a_build_it_says_how_to_get_one() {
    let out = Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .args(["flash", "--port", "/dev/null", "--board", "wifi"])
        .env("CARGO_TARGET_DIR", "/nonexistent-target")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let e = text(&out.stderr);
    assert!(
        e.contains("/nonexistent-target/thumbv7em-none-eabihf/firmware/uno-r4")
            && e.contains("cargo firmware")
            && e.contains("dist/uno-r4.bin"),
        "{e}"
    );
}

/// The release image in `dist/` is what its manifest says (bytes, CRC-16 as the bootloader's
/// verify computes it, SHA-256 line) and speaks this checkout's protocol and schema: a maker
/// who flashes it without a toolchain gets a board this host-tool talks to.
#[test]
fn the_shipped_image_matches_its_manifest_and_this_protocol() {
    let dist = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../dist");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dist.join("uno-r4.json")).unwrap()).unwrap();
    let bin = dist.join("uno-r4.bin");
    let out = flash(&["--image", bin.to_str().unwrap(), "--dry-run", "-j"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let image = &report["image"];
    assert_eq!(image["bytes"], manifest["bytes"]);
    assert_eq!(
        image["bytes"].as_u64().unwrap(),
        std::fs::metadata(&bin).unwrap().len()
    );
    assert_eq!(image["crc16"], manifest["crc16"]);
    assert_eq!(image["initial_sp"], "0x20008000");
    assert_eq!(
        manifest["protocol_version"].as_u64(),
        Some(u64::from(PROTOCOL_VERSION))
    );
    assert_eq!(
        manifest["schema_id"].as_str(),
        Some(format!("{SCHEMA_ID:#010x}").as_str())
    );
    let sha_line = std::fs::read_to_string(dist.join("uno-r4.bin.sha256")).unwrap();
    assert_eq!(
        sha_line.split_whitespace().collect::<Vec<_>>(),
        [manifest["sha256"].as_str().unwrap(), "uno-r4.bin"]
    );
}
