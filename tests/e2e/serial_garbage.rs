//! Garbage on the device's serial line never stops it answering `status`: a separate
//! `hil-sim --pty` process, random bytes written to its pty, then `host-tool status --port`.

use std::io::Write;
use std::time::Duration;

use e2e::{hil_sim_pty, host_tool, Noise};

#[test]
fn garbage_on_the_line_never_stops_the_device_answering_status() {
    let sim = hil_sim_pty(&["--initial", "D&F", "--seed", "3"]);
    let path = sim.path.clone();
    let result = std::panic::catch_unwind(|| {
        let mut noise = Noise::new(0x5eed);
        for round in 0..5 {
            {
                let mut port = std::fs::OpenOptions::new()
                    .write(true)
                    .open(&path)
                    .expect("the pty opens for writing");
                // Random bytes, then a run of delimiters and an over-long frame.
                port.write_all(&noise.bytes(4096)).unwrap();
                port.write_all(&[0u8; 16]).unwrap();
                port.write_all(&vec![0x42; 2000]).unwrap();
                port.write_all(&noise.bytes(512)).unwrap();
            }
            let out = host_tool(
                &["status", "--port", &path, "--json"],
                Duration::from_secs(20),
            );
            assert_eq!(out.code(), 0, "round {round}: {}", out.stderr);
            let v = out.json();
            assert_eq!(v["state"], "D&F", "round {round}: {v}");
            assert!(
                v["frames_dropped"].as_u64().unwrap() > 0,
                "round {round}: {v}"
            );
            assert!(
                v["sim"].is_null(),
                "a --port device is not the built-in simulator: {v}"
            );
        }
    });
    drop(sim);
    if let Err(panic) = result {
        std::panic::resume_unwind(panic);
    }
}
