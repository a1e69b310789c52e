//! `--trunk FILE`: one description carries the trunk's design and its physics. `pattern` and
//! `model` make the files of its `[design]`, `plan --sim` and `calibrate --sim` simulate it;
//! a design that is infeasible, outside the crane's topology, disagrees with its heights, or
//! comes with the design flags it replaces, is refused (exit 2, the reason).

#[path = "support/cli.rs"]
mod cli;

use cli::host_tool;

use std::path::{Path, PathBuf};

use hil_sim::physics::design::ModuleDesignSpec;
use hil_sim::physics::{TrunkDesign, TrunkSpec};

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli_trunk");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn repo(path: &str) -> String {
    format!("{}/../../{path}", env!("CARGO_MANIFEST_DIR"))
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn text(out: &std::process::Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// The PDF trunk's physics printed to `design`, written to `name`.
fn trunk_file(name: &str, design: TrunkDesign) -> PathBuf {
    let spec = TrunkSpec::pdf().with_design(name, design).unwrap();
    let path = tmp(&format!("{name}.toml"));
    std::fs::write(&path, spec.to_toml()).unwrap();
    path
}

/// A description whose `[design]` is `design` as written, the rest the PDF trunk's (for
/// refusals: the design is checked before the heights).
fn raw_design_file(name: &str, design: TrunkDesign) -> PathBuf {
    let mut spec = TrunkSpec::pdf();
    spec.design = Some(design);
    let path = tmp(&format!("{name}.toml"));
    std::fs::write(&path, spec.to_toml()).unwrap();
    path
}

fn design(n: u32, edge_mm: f64, top: (f64, u32), bottom: (f64, u32)) -> TrunkDesign {
    TrunkDesign {
        n,
        edge_mm,
        top: ModuleDesignSpec {
            beta_deg: top.0,
            layers: top.1,
        },
        bottom: ModuleDesignSpec {
            beta_deg: bottom.0,
            layers: bottom.1,
        },
    }
}

/// The DXF without what two runs differ in: its entity handles' random UUIDs and its times.
fn dxf_lines(path: &Path) -> Vec<String> {
    let uuid =
        |l: &str| l.len() == 36 && l.bytes().filter(|&b| b == b'-').count() == 4 && l.is_ascii();
    // The header's times ($TDCREATE, $TDUPDATE, …: the clock's, to the second) are
    // dropped with their group code, so two files written a second apart still compare.
    let mut skip = 0;
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| {
            if skip > 0 {
                skip -= 1;
                return false;
            }
            if l.trim().starts_with("$TD") {
                skip = 2;
            }
            !uuid(l.trim())
        })
        .map(str::to_string)
        .collect()
}

/// `pattern` with `args` writing SVG, DXF and FOLD into files named after `tag`.
fn pattern(tag: &str, args: &[&str]) -> (String, Vec<String>, String) {
    let (svg, dxf, fold) = (
        tmp(&format!("{tag}.svg")),
        tmp(&format!("{tag}.dxf")),
        tmp(&format!("{tag}.fold")),
    );
    let mut all = vec![
        "pattern",
        "--svg",
        s(&svg),
        "--dxf",
        s(&dxf),
        "--fold",
        s(&fold),
    ];
    all.extend_from_slice(args);
    let out = host_tool(&all);
    assert_eq!(out.status.code(), Some(0), "{args:?}: {}", text(&out));
    (
        std::fs::read_to_string(&svg).unwrap(),
        dxf_lines(&dxf),
        std::fs::read_to_string(&fold).unwrap(),
    )
}

#[test]
fn pattern_of_the_pdf_file_is_the_pattern_of_its_flags() {
    let pdf = repo("trunks/pdf.toml");
    let of_file = pattern("pdf-file", &["--trunk", &pdf]);
    let of_flags = pattern(
        "pdf-flags",
        &[
            "--n",
            "3",
            "--beta",
            "35,31.72",
            "--layers",
            "2",
            "--edge-mm",
            "75",
        ],
    );
    // And the defaults, which are the PDF trunk.
    let of_defaults = pattern("pdf-defaults", &[]);
    assert!(
        of_file == of_flags,
        "--trunk pdf.toml differs from its flags"
    );
    assert!(
        of_file == of_defaults,
        "--trunk pdf.toml differs from the defaults"
    );
    // The SVG's legend names the trunk (the 3 mm gap under the 35° module included).
    assert!(of_file.0.contains("n = 3"), "{}", &of_file.0[..400]);
}

#[test]
fn a_trunk_of_other_dimensions_gets_its_files() {
    // trunks/n4.toml: n = 4, 75 mm edges, 23° over 30°.
    let n4 = repo("trunks/n4.toml");
    let of_file = pattern("n4-file", &["--trunk", &n4]);
    let of_flags = pattern(
        "n4-flags",
        &[
            "--n",
            "4",
            "--beta",
            "30,23",
            "--layers",
            "2",
            "--edge-mm",
            "75",
        ],
    );
    assert!(
        of_file == of_flags,
        "--trunk n4.toml differs from its flags"
    );
    assert_ne!(of_file.2, pattern("n4-pdf", &[]).2);
    // A 90 mm n = 3 trunk: the sheet is 90/75 of the PDF's 225 × 197.7 mm (plus the 5 mm
    // seam tab).
    let l90 = trunk_file("l90", design(3, 90.0, (31.72, 2), (35.0, 2)));
    let out = host_tool(&[
        "--json",
        "pattern",
        "--trunk",
        s(&l90),
        "--dxf",
        s(&tmp("l90.dxf")),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let sheet = &v["files"][0]["sheet_mm"];
    let (w, h) = (sheet[0].as_f64().unwrap(), sheet[1].as_f64().unwrap());
    assert!((w - (225.0 * 1.2 + 5.0)).abs() < 0.1, "{v}");
    assert!((h - 197.745 * 1.2).abs() < 0.1, "{v}");
    // Its model in a crane state: the bottom self-packed, the top folded.
    let stl = tmp("n4.stl");
    let out = host_tool(&["model", "--trunk", &n4, "--states", "F&P", "--stl", s(&stl)]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let t = text(&out);
    assert!(
        t.contains("n = 4") && t.contains("self-packed,self-packed,folded,folded"),
        "{t}"
    );
    assert!(std::fs::metadata(&stl).unwrap().len() > 1000);
}

fn plan_json(trunk: &str, initial: &str, target: &str) -> serde_json::Value {
    let out = host_tool(&[
        "--json",
        "plan",
        "--sim",
        "--trunk",
        trunk,
        "--sim-initial",
        initial,
        "--target",
        target,
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn plan_sim_trunk_reaches_targets_on_a_trunk_of_other_dimensions() {
    // A 70 mm n = 3 trunk of 30.5° over 33° (every one of the 30 plans holds on it, measured;
    // docs/simulator.md, "Your own trunk"): the pneumatic and the tendon transitions.
    let small = trunk_file("l70", design(3, 70.0, (30.5, 2), (33.0, 2)));
    for (from, to) in [("F&P", "D&D"), ("D&D", "F&P"), ("F&F", "D&P")] {
        let v = plan_json(s(&small), from, to);
        assert_eq!(v["sim"]["true_state"], to, "{from} → {to}: {v}");
    }
    // n = 4 (trunks/n4.toml): inflation from F&P takes it to D&D.
    let v = plan_json(&repo("trunks/n4.toml"), "F&P", "D&D");
    assert_eq!(v["sim"]["true_state"], "D&D", "{v}");
    // --sim-trunk is the same flag.
    let out = host_tool(&["plan", "--sim", "--sim-trunk", s(&small), "--target", "F&F"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
}

#[test]
fn calibrate_sim_takes_the_trunk() {
    let small = trunk_file("cal-l70", design(3, 70.0, (30.5, 2), (33.0, 2)));
    let profile = tmp("cal-l70-profile.toml");
    let out = host_tool(&[
        "calibrate",
        "--sim",
        "--trunk",
        s(&small),
        "--out",
        s(&profile),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let p = std::fs::read_to_string(&profile).unwrap();
    assert!(p.contains("name = \"cal-l70\""), "{p}");
}

fn refused(args: &[&str], reason: &str) {
    let out = host_tool(args);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {t}");
    assert!(t.contains(reason), "{args:?}: wanted '{reason}' in: {t}");
    assert!(!t.contains("panicked"), "{args:?}: {t}");
}

/// Each command that takes `--trunk` refuses `file` with `reason`.
fn refused_everywhere(file: &Path, reason: &str) {
    let f = s(file);
    refused(
        &["pattern", "--trunk", f, "--dxf", s(&tmp("x.dxf"))],
        reason,
    );
    refused(&["model", "--trunk", f, "--stl", s(&tmp("x.stl"))], reason);
    refused(&["plan", "--sim", "--trunk", f, "--target", "F&F"], reason);
    refused(
        &[
            "calibrate",
            "--sim",
            "--trunk",
            f,
            "--out",
            s(&tmp("x-profile.toml")),
        ],
        reason,
    );
}

#[test]
fn designs_outside_the_crane_are_refused_with_the_reason() {
    let pdf = TrunkDesign::PDF;
    for (name, d, reason) in [
        ("n2", TrunkDesign { n: 2, ..pdf }, "n = 2 is too small"),
        ("n65", TrunkDesign { n: 65, ..pdf }, "n = 65 is too large"),
        (
            "edge0",
            TrunkDesign {
                edge_mm: 0.0,
                ..pdf
            },
            "design.edge_mm = 0",
        ),
        (
            "edge-big",
            TrunkDesign {
                edge_mm: 10_000.5,
                ..pdf
            },
            "design.edge_mm = 10000.5",
        ),
        (
            "beta90",
            design(3, 75.0, (90.0, 2), (35.0, 2)),
            "beta = 90 deg is out of range",
        ),
        (
            "bottom-46",
            design(3, 75.0, (31.72, 2), (45.01, 2)),
            "the bottom module cannot self-pack at design.bottom.beta_deg = 45.01",
        ),
        (
            "bottom-30",
            design(3, 75.0, (29.0, 2), (30.0, 2)),
            "cannot self-pack",
        ),
        (
            "top-30",
            design(3, 75.0, (30.0, 2), (35.0, 2)),
            "the top module cannot be tendon-folded at design.top.beta_deg = 30",
        ),
        (
            "top-n4",
            design(4, 75.0, (22.5, 2), (30.0, 2)),
            "90°/n = 22.5000°",
        ),
        (
            "top-steeper",
            design(3, 75.0, (35.0, 2), (35.0, 2)),
            "the top must have the smaller β",
        ),
        (
            "bottom-3-layers",
            design(3, 75.0, (31.72, 2), (35.0, 3)),
            "design.bottom.layers = 3",
        ),
        (
            "bottom-1-layer",
            design(3, 75.0, (31.72, 2), (35.0, 1)),
            "design.bottom.layers = 1",
        ),
        (
            "top-3-layers",
            design(3, 75.0, (31.72, 3), (35.0, 2)),
            "design.top.layers = 3",
        ),
        (
            "top-0-layers",
            design(3, 75.0, (31.72, 0), (35.0, 2)),
            "design.top.layers = 0",
        ),
    ] {
        refused_everywhere(&raw_design_file(name, d), reason);
    }
}

#[test]
fn the_edges_of_the_design_ranges_are_accepted() {
    // Bottom β 45° (the self-packing range's closed end), top β just above 90°/n, one top
    // layer, n = 64, an edge of 10 m: designs the check admits (their patterns are made; the
    // physics of such a trunk is a separate question, asked by plan --sim).
    for (name, d) in [
        ("bottom-45", design(3, 75.0, (31.72, 2), (45.0, 2))),
        ("top-30.01", design(3, 75.0, (30.01, 2), (35.0, 2))),
        ("top-1-layer", design(3, 75.0, (31.72, 1), (35.0, 2))),
        ("n64", design(64, 75.0, (1.5, 2), (2.0, 2))),
        ("n4-22.6", design(4, 75.0, (22.6, 2), (30.0, 2))),
        ("edge-10m", design(3, 10_000.0, (31.72, 2), (35.0, 2))),
    ] {
        let f = trunk_file(name, d);
        let out = host_tool(&["pattern", "--trunk", s(&f), "--dxf", s(&tmp("edge.dxf"))]);
        assert_eq!(out.status.code(), Some(0), "{name}: {}", text(&out));
    }
}

#[test]
fn a_description_that_disagrees_with_its_design_is_refused() {
    // The n = 4 design over the PDF trunk's heights.
    let mut spec = TrunkSpec::pdf();
    spec.design = Some(design(4, 75.0, (23.0, 2), (30.0, 2)));
    let f = tmp("disagrees.toml");
    std::fs::write(&f, spec.to_toml()).unwrap();
    refused_everywhere(
        &f,
        "top.wells[0].height_mm (F) = 33.10482703659852 but the design gives 13.9153",
    );
    // The piston area alone off by 1 %.
    let mut spec = TrunkSpec::pdf();
    spec.pneumatics.area_mm2 *= 1.01;
    std::fs::write(&f, spec.to_toml()).unwrap();
    refused_everywhere(&f, "pneumatics.area_mm2");
}

#[test]
fn flags_files_and_ports_that_do_not_go_with_trunk_are_refused() {
    let pdf = repo("trunks/pdf.toml");
    for (flag, value) in [
        ("--n", "3"),
        ("--beta", "35,31.72"),
        ("--layers", "2"),
        ("--edge-mm", "75"),
    ] {
        for cmd in ["pattern", "model"] {
            let out_flag = if cmd == "pattern" { "--dxf" } else { "--stl" };
            refused(
                &[
                    cmd,
                    "--trunk",
                    &pdf,
                    flag,
                    value,
                    out_flag,
                    s(&tmp("c.out")),
                ],
                &format!("'--trunk <FILE>' cannot be used with '{flag}"),
            );
        }
    }
    let missing = "/nonexistent/trunk.toml";
    refused(
        &["pattern", "--trunk", missing, "--dxf", s(&tmp("m.dxf"))],
        "cannot read the trunk file /nonexistent/trunk.toml",
    );
    refused(
        &["model", "--trunk", missing, "--stl", s(&tmp("m.stl"))],
        "cannot read the trunk file /nonexistent/trunk.toml",
    );
    refused(
        &["plan", "--sim", "--trunk", missing, "--target", "F&F"],
        "cannot read the trunk file /nonexistent/trunk.toml",
    );
    refused(
        &[
            "calibrate",
            "--sim",
            "--trunk",
            missing,
            "--out",
            s(&tmp("m.toml")),
        ],
        "cannot read the trunk file /nonexistent/trunk.toml",
    );
    // A description without [design] is physics only: the simulator runs it, a pattern cannot
    // be made of it.
    let mut old = TrunkSpec::pdf();
    old.design = None;
    let f = tmp("physics-only.toml");
    std::fs::write(&f, old.to_toml()).unwrap();
    refused(
        &["pattern", "--trunk", s(&f), "--dxf", s(&tmp("o.dxf"))],
        "has no [design] table",
    );
    let out = host_tool(&["plan", "--sim", "--trunk", s(&f), "--target", "F&F"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    // With a real crane the trunk measures itself: `calibrate --port P --trunk FILE` takes
    // its name from the description (tests/e2e/pty.rs), every other command refuses it.
    refused(
        &[
            "calibrate",
            "--port",
            "/dev/null",
            "--trunk",
            missing,
            "--out",
            s(&tmp("p.toml")),
        ],
        "invalid trunk /nonexistent/trunk.toml: cannot read the trunk file",
    );
    refused(
        &[
            "plan",
            "--port",
            "/dev/null",
            "--trunk",
            &pdf,
            "--target",
            "F&F",
        ],
        "--sim-trunk (--trunk) only applies to the simulator",
    );
}
