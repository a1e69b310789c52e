//! `host-tool --sim --sim-trunk FILE --sim-trunk-scale K`: another simulated trunk, or the
//! refusal of one the physics cannot represent (exit 2, the reason), never a panic.

#[path = "support/cli.rs"]
mod cli;

use cli::host_tool;

#[test]
fn a_trunk_the_physics_cannot_represent_is_refused_before_anything_runs() {
    for (args, reason) in [
        (
            vec!["status", "--sim", "--sim-trunk-scale", "1.35"],
            "barrier 0",
        ),
        (vec!["status", "--sim", "--sim-trunk-scale", "0"], "scale"),
        (vec!["status", "--sim", "--sim-trunk-scale", "nan"], "scale"),
        (
            vec!["status", "--sim", "--sim-trunk", "/nonexistent/trunk.toml"],
            "cannot read the trunk file",
        ),
        (
            vec!["status", "--port", "/dev/null", "--sim-trunk-scale", "1.1"],
            "only applies to the simulator",
        ),
    ] {
        let out = host_tool(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(reason), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn a_stiffer_simulated_trunk_runs_a_plan() {
    let pdf = concat!(env!("CARGO_MANIFEST_DIR"), "/../../trunks/pdf.toml");
    let out = host_tool(&[
        "plan",
        "--target",
        "D&D",
        "--sim",
        "--sim-trunk",
        pdf,
        "--sim-trunk-scale",
        "1.2",
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
