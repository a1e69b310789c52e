//! `host-tool pattern` and `host-tool model` through the real binary: the files are written
//! and parse, defaults are printed in --help, and bad input is a usage error (exit 2) that
//! says what is valid, checked before any file is written.

#[path = "support/cli.rs"]
mod cli;

use cli::{host_tool, usage_error};

use std::path::{Path, PathBuf};
use std::process::Output;

use serde_json::Value;

fn ok(args: &[&str]) -> Output {
    let out = host_tool(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        let p = std::env::temp_dir().join(format!("host-tool-fab-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }

    fn file(&self, name: &str) -> String {
        self.0.join(name).to_string_lossy().into_owned()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[test]
fn pattern_help_prints_the_paper_defaults() {
    let out = ok(&["pattern", "--help"]);
    // Help is wrapped to the terminal's width: compare it with its line breaks as spaces.
    let help = String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    for want in [
        "[default: 3]",
        "[default: 35,31.72]",
        "[default: 2]",
        "[default: 75]",
        "[default: 5]",
    ] {
        assert!(help.contains(want), "missing {want} in\n{help}");
    }
}

#[test]
fn pattern_writes_svg_dxf_and_fold_of_the_crane_trunk() {
    let dir = TempDir::new("pattern");
    let (svg, dxf, fold) = (dir.file("t.svg"), dir.file("t.dxf"), dir.file("t.fold"));
    ok(&["pattern", "--svg", &svg, "--dxf", &dxf, "--fold", &fold]);
    let text = std::fs::read_to_string(&svg).unwrap();
    // 230 mm wide (3 × 75 + 5 mm seam) plus margins; the page is in millimetres.
    assert!(text.contains(r#"width="250.000mm""#), "{}", &text[..300]);
    for colour in ["#ff0000", "#0000ff", "#000000", "#00ff00", "#ff00ff"] {
        assert!(text.contains(colour), "{colour}");
    }
    assert!(text.contains("50 mm"), "scale bar label");
    let dxf_text = std::fs::read_to_string(&dxf).unwrap();
    for layer in ["MOUNTAIN", "VALLEY", "CUT", "BOUNDARY", "VIRTUAL"] {
        assert!(dxf_text.contains(layer), "{layer}");
    }
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&fold).unwrap()).unwrap();
    assert_eq!(doc["file_spec"], 1.2);
    // Default frames: the catalogue states feasible for both the 35° and the 31.72° module.
    let titles: Vec<&str> = doc["file_frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["frame_title"].as_str().unwrap())
        .collect();
    assert_eq!(titles, ["deployed", "folded"]);
    // 4 layers × 8n faces.
    assert_eq!(doc["faces_vertices"].as_array().unwrap().len(), 4 * 8 * 3);
    for f in doc["file_frames"].as_array().unwrap() {
        assert_eq!(f["yoshimura:states_feasible"], true);
        assert!(f["yoshimura:max_strain"].as_f64().unwrap() < 1e-9);
    }
}

#[test]
fn pattern_frames_per_module_and_infeasible_states_are_recorded() {
    let dir = TempDir::new("frames");
    let fold = dir.file("t.fold");
    let out = ok(&[
        "pattern",
        "--fold",
        &fold,
        "--states",
        "self-packed/folded,edge-0",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("frame 'edge-0' is not isometric"),
        "{stderr}"
    );
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&fold).unwrap()).unwrap();
    let frames = doc["file_frames"].as_array().unwrap();
    assert_eq!(
        frames[0]["yoshimura:layer_states"],
        serde_json::json!(["self-packed", "self-packed", "folded", "folded"])
    );
    assert_eq!(frames[1]["yoshimura:states_feasible"], false);
    assert!(frames[1]["yoshimura:max_strain"].as_f64().unwrap() > 0.01);
}

#[test]
fn pattern_usage_errors_say_what_is_valid_and_write_nothing() {
    let dir = TempDir::new("usage");
    let svg = dir.file("never.svg");
    let fold = dir.file("never.fold");
    usage_error(&["pattern"], "give at least one of --svg FILE");
    usage_error(&["pattern", "--svg", &svg, "--n", "2"], "[3, 64]");
    usage_error(
        &[
            "pattern",
            "--svg",
            &svg,
            "--beta",
            "35,31.72,30",
            "--layers",
            "1,2",
        ],
        "--layers has 2 values",
    );
    usage_error(&["pattern", "--svg", &svg, "--layers", "0"], "[1, 1000]");
    usage_error(&["pattern", "--svg", &svg, "--layers", "1001"], "[1, 1000]");
    usage_error(
        &["pattern", "--svg", &svg, "--layers", "600,500"],
        "at most 1000",
    );
    usage_error(&["pattern", "--svg", &svg, "--edge-mm", "0"], "(0, 10000]");
    usage_error(
        &["pattern", "--svg", &svg, "--edge-mm", "NaN"],
        "(0, 10000]",
    );
    usage_error(
        &["pattern", "--svg", &svg, "--seam-mm", "38"],
        "[0, 37.5] mm",
    );
    usage_error(
        &["pattern", "--svg", &svg, "--seam-mm", "-1"],
        "[0, 37.5] mm",
    );
    usage_error(
        &["pattern", "--svg", &svg, "--states", "folded"],
        "give --fold FILE too",
    );
    usage_error(
        &["pattern", "--fold", &fold, "--states", "edge-3"],
        "edge-0 … edge-2",
    );
    usage_error(
        &["pattern", "--fold", &fold, "--states", "a/b/c"],
        "names 3 modules but the trunk has 2",
    );
    usage_error(
        &[
            "pattern", "--fold", &fold, "--beta", "20", "--states", "folded",
        ],
        "folded needs β ≥ 90°/n",
    );
    usage_error(
        &["pattern", "--fold", &fold, "--states", "deployed,,folded"],
        "comma-separated",
    );
    usage_error(
        &["pattern", "--svg", "/nonexistent-dir/x.svg"],
        "cannot write --svg",
    );
    usage_error(&["pattern", "--svg", &dir.file("")], "is a directory");
    assert!(!Path::new(&svg).exists() && !Path::new(&fold).exists());
}

#[test]
fn pattern_edges_of_the_ranges_work() {
    let dir = TempDir::new("edges");
    let f = dir.file("t.fold");
    for args in [
        vec![
            "--n",
            "3",
            "--beta",
            "0.001",
            "--layers",
            "1",
            "--edge-mm",
            "0.001",
            "--seam-mm",
            "0",
        ],
        vec![
            "--n",
            "64",
            "--beta",
            "89.999",
            "--layers",
            "1",
            "--edge-mm",
            "10000",
            "--seam-mm",
            "5000",
        ],
        vec![
            "--n",
            "3",
            "--beta",
            "30",
            "--layers",
            "1000",
            "--seam-mm",
            "37.5",
        ],
    ] {
        let mut all = vec!["pattern", "--fold", &f];
        all.extend(args);
        ok(&all);
        let doc: Value = serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
        assert!(doc["faces_vertices"].as_array().unwrap().len() >= 24);
    }
}

#[test]
fn pattern_writes_the_panel_and_the_kit() {
    let dir = TempDir::new("panel");
    let (mf, stl, kit) = (dir.file("p.3mf"), dir.file("stl"), dir.file("kit.json"));
    ok(&["pattern", "--3mf", &mf, "--stl-dir", &stl]);
    let bytes = std::fs::read(&mf).unwrap();
    assert_eq!(&bytes[..2], b"PK", "a zip package");
    for f in ["base-tpu.stl", "facets-nylon.stl"] {
        let len = std::fs::metadata(Path::new(&stl).join(f)).unwrap().len();
        // Binary STL: 84-byte header + 50 bytes per triangle.
        assert_eq!((len - 84) % 50, 0, "{f}");
    }
    let out = ok(&[
        "pattern",
        "--beta",
        "31.72",
        "--layers",
        "4",
        "--edge-mm",
        "609.6",
        "--kit",
        &kit,
    ]);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("hinges 180   screws 720"), "{table}");
    let json: Value = serde_json::from_str(&std::fs::read_to_string(&kit).unwrap()).unwrap();
    assert_eq!(json["hinges"], 180);
    assert_eq!(json["screws"], 720);
}

#[test]
fn panel_usage_errors_say_what_is_valid() {
    let dir = TempDir::new("panel-usage");
    let mf = dir.file("never.3mf");
    usage_error(
        &["pattern", "--svg", &dir.file("x.svg"), "--gap-mm", "2"],
        "give --3mf FILE or --stl-dir DIR too",
    );
    usage_error(
        &["pattern", "--3mf", &mf, "--gap-mm", "0"],
        "must be in (0, ",
    );
    usage_error(
        &["pattern", "--3mf", &mf, "--gap-mm", "30"],
        "below twice the smallest facet's inradius",
    );
    usage_error(
        &["pattern", "--3mf", &mf, "--gap-mm", "1,2,3"],
        "--gap-mm has 3 values but the trunk has 2 modules",
    );
    usage_error(
        &["pattern", "--3mf", &mf, "--gap-mm", "x"],
        "gap widths in mm",
    );
    usage_error(&["pattern", "--3mf", &mf, "--facet-mm", "0"], "(0, 20] mm");
    usage_error(&["pattern", "--3mf", &mf, "--base-mm", "21"], "(0, 20] mm");
    std::fs::write(dir.file("file"), b"x").unwrap();
    usage_error(
        &["pattern", "--stl-dir", &dir.file("file")],
        "is not a directory",
    );
    assert!(!Path::new(&mf).exists());
}

#[test]
fn model_writes_gltf_obj_and_stl() {
    let dir = TempDir::new("model");
    let (glb, obj, stl) = (dir.file("m.glb"), dir.file("m.obj"), dir.file("m.stl"));
    let out = ok(&[
        "model",
        "--states",
        "self-packed,folded",
        "--gltf",
        &glb,
        "--obj",
        &obj,
        "--stl",
        &stl,
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("self-packed,self-packed,folded,folded"),
        "{text}"
    );
    assert!(
        text.contains("strained faces drawn red"),
        "packed under folded does not close: {text}"
    );
    let bytes = std::fs::read(&glb).unwrap();
    assert_eq!(&bytes[..4], b"glTF");
    assert_eq!(fabrication::model::validate_glb(&bytes).unwrap(), 96);
    assert_eq!(
        std::fs::read_to_string(&obj)
            .unwrap()
            .lines()
            .filter(|l| l.starts_with("f "))
            .count(),
        96
    );
    assert_eq!(std::fs::metadata(&stl).unwrap().len(), 84 + 50 * 96);
    // One state per layer; a feasible stack is not reported as strained.
    let out = ok(&[
        "model",
        "--beta",
        "31.72",
        "--layers",
        "4",
        "--states",
        "edge-0,deployed,vertex-1,folded",
        "--gltf",
        &glb,
    ]);
    assert!(!String::from_utf8_lossy(&out.stdout).contains("strained"));
}

#[test]
fn model_usage_errors_say_what_is_valid() {
    let dir = TempDir::new("model-usage");
    let glb = dir.file("never.glb");
    usage_error(&["model"], "give at least one of --gltf FILE");
    usage_error(
        &[
            "model",
            "--gltf",
            &glb,
            "--states",
            "deployed,folded,deployed",
        ],
        "one per module (2) or one per layer (4)",
    );
    usage_error(
        &["model", "--gltf", &glb, "--states", "vertex-9"],
        "vertex-0 … vertex-2",
    );
    usage_error(
        &["model", "--gltf", &glb, "--states", "deployed,,folded"],
        "comma-separated",
    );
    usage_error(
        &["model", "--gltf", &glb, "--states", "flat-folded"],
        "flat-folded does not exist",
    );
    usage_error(
        &["model", "--gltf", "/nonexistent-dir/m.glb"],
        "cannot write --gltf",
    );
    assert!(!Path::new(&glb).exists());
}

#[test]
fn ik_writes_the_fitted_boom_as_gltf() {
    let dir = TempDir::new("ik");
    let glb = dir.file("fit.glb");
    ok(&[
        "ik",
        "--n",
        "3",
        "--beta",
        "31.72",
        "--modules",
        "6",
        "--target",
        "helix:radius=1,pitch=4,turns=1",
        "--algo",
        "greedy",
        "--gltf",
        &glb,
    ]);
    let bytes = std::fs::read(&glb).unwrap();
    assert_eq!(fabrication::model::validate_glb(&bytes).unwrap(), 6 * 24);
    usage_error(
        &[
            "ik",
            "--n",
            "3",
            "--beta",
            "31.72",
            "--modules",
            "6",
            "--target",
            "helix",
            "--gltf",
            "/nonexistent-dir/x.glb",
        ],
        "cannot write --gltf",
    );
}

#[test]
fn pattern_nest_writes_every_sheet_and_says_what_it_wrote() {
    let dir = TempDir::new("nest");
    let (cut, kit) = (dir.file("cut"), dir.file("kit.json"));
    let args = [
        "pattern",
        "--beta",
        "31.72",
        "--layers",
        "4",
        "--edge-mm",
        "609.6",
        "--nest",
        "1220x2440",
        "--nest-dir",
        &cut,
        "--kit",
        &kit,
    ];
    // Without -j: the kit's table on stdout, one "wrote" line per file on stderr.
    let out = ok(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(String::from_utf8_lossy(&out.stdout).contains("hinges 180"));
    for f in [
        "sheet-1.dxf",
        "sheet-1.svg",
        "sheet-2.dxf",
        "sheet-2.svg",
        "nest.json",
    ] {
        assert!(stderr.contains(&format!("{f} (")), "{f} in\n{stderr}");
        assert!(Path::new(&cut).join(f).is_file());
    }
    assert!(!Path::new(&cut).join("sheet-3.dxf").exists());
    assert!(
        stderr.contains(
            "48 facets, 720 insert holes on 2 sheets of 1220 × 2440 mm (area bound: 1 sheet"
        ),
        "{stderr}"
    );
    // With -j: one JSON object on stdout, every file with its real size; no table.
    let mut j = args.to_vec();
    j.push("-j");
    let out = ok(&j);
    let v: Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    let files = v["files"].as_array().unwrap();
    assert_eq!(files.len(), 6, "{v}");
    for f in files {
        let len = std::fs::metadata(f["path"].as_str().unwrap())
            .unwrap()
            .len();
        assert_eq!(f["bytes"].as_u64(), Some(len), "{f}");
    }
    assert_eq!(v["nest"]["sheets"], 2);
    assert_eq!(v["nest"]["area_bound_sheets"], 1);
    assert_eq!(v["nest"]["holes"], 720);
    // kit.json and nest.json carry no float noise: 1/6 is written with 15 significant digits.
    for f in [kit.clone(), format!("{cut}/nest.json")] {
        let text = std::fs::read_to_string(&f).unwrap();
        assert!(!text.contains("0.16666666666666666"), "{f}");
        let noisy = text
            .split(|c: char| !(c.is_ascii_digit() || c == '.'))
            .filter(|t| t.contains('.'))
            .find(|t| {
                let significant = t.trim_start_matches(['0', '.']);
                significant.chars().filter(char::is_ascii_digit).count() > 15
            });
        assert_eq!(noisy, None, "{f}");
    }
    let sheet: Value =
        serde_json::from_str(&std::fs::read_to_string(format!("{cut}/nest.json")).unwrap())
            .unwrap();
    assert_eq!(sheet["sheets"][0]["parts"].as_array().unwrap().len(), 36);
}

#[test]
fn pattern_svg_json_reports_the_page() {
    let dir = TempDir::new("svg-json");
    let svg = dir.file("t.svg");
    let out = ok(&["pattern", "--svg", &svg, "-j"]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["files"][0]["flag"], "--svg");
    assert_eq!(v["files"][0]["pages"], 1);
    assert_eq!(v["files"][0]["page_mm"][0], 250.0);
    assert_eq!(v["files"][0]["sheet_mm"][0], 230.0);
    assert_eq!(v["files"][0]["legend"], "below");
    // The legend's box: below the 197.7 mm sheet (10 mm margin + 4 mm gap), inside the page.
    let bx: Vec<f64> = v["files"][0]["legend_box_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let ph = v["files"][0]["page_mm"][1].as_f64().unwrap();
    assert!((bx[1] - (10.0 + 197.745 + 4.0)).abs() < 1e-2, "{bx:?}");
    assert!(bx[0] >= 10.0 && bx[0] + bx[2] <= 240.0 && bx[1] + bx[3] <= ph - 10.0 + 1e-9);
    // Right of the sheet: the page widens, the sheet keeps its place; none: the sheet alone.
    for (legend, page_w, page_h) in [
        ("right", None, Some(197.745 + 20.0)),
        ("none", Some(250.0), Some(217.745)),
    ] {
        let out = ok(&["pattern", "--svg", &svg, "--legend", legend, "-j"]);
        let v: Value = serde_json::from_slice(&out.stdout).unwrap();
        let f = &v["files"][0];
        assert_eq!(f["legend"], legend);
        let [pw, ph] = [0, 1].map(|k| f["page_mm"][k].as_f64().unwrap());
        if let Some(w) = page_w {
            assert!((pw - w).abs() < 1e-3, "{legend}: {pw}");
        } else {
            let bx = f["legend_box_mm"].as_array().unwrap();
            let x = bx[0].as_f64().unwrap();
            assert!((x - (10.0 + 230.0 + 8.0)).abs() < 1e-9, "{legend}: {bx:?}");
            assert!((pw - (x + bx[2].as_f64().unwrap() + 10.0)).abs() < 1e-3);
        }
        if let Some(h) = page_h {
            assert!((ph - h).abs() < 1e-2, "{legend}: {ph}");
        }
        let text = std::fs::read_to_string(&svg).unwrap();
        assert_eq!(text.contains(r#"<g id="legend""#), legend != "none");
    }
    usage_error(
        &["pattern", "--svg", &svg, "--legend", "left"],
        "--legend: the legend goes below, right or none, got 'left'",
    );
    usage_error(
        &["pattern", "--bom", &dir.file("b.csv"), "--legend", "right"],
        "give --svg FILE or --page PAPER too",
    );
}

#[test]
fn nest_usage_errors_say_what_is_valid() {
    let dir = TempDir::new("nest-usage");
    let cut = dir.file("cut");
    let paper = ["--beta", "31.72", "--layers", "4", "--edge-mm", "609.6"];
    let with = |extra: &[&str]| {
        let mut a = vec!["pattern"];
        a.extend_from_slice(&paper);
        a.extend_from_slice(extra);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let run = |a: Vec<String>, msg: &str| {
        let refs: Vec<&str> = a.iter().map(String::as_str).collect();
        usage_error(&refs, msg);
    };
    run(with(&["--nest", "1220x2440"]), "give --nest-dir DIR");
    run(
        with(&["--nest", "1220", "--nest-dir", &cut]),
        "WIDTHxHEIGHT in mm",
    );
    run(
        with(&["--nest", "600x400", "--nest-dir", &cut]),
        "does not fit",
    );
    run(
        with(&["--nest", "1220x2440", "--nest-dir", &cut, "--kerf-mm", "-1"]),
        "--kerf-mm must be in [0, 5]",
    );
    run(
        with(&[
            "--nest",
            "1220x2440",
            "--nest-dir",
            &cut,
            "--margin-mm",
            "700",
        ]),
        "--margin-mm must be",
    );
    run(
        with(&[
            "--nest",
            "1220x2440",
            "--nest-dir",
            &cut,
            "--spacing-mm",
            "nan",
        ]),
        "--spacing-mm must be",
    );
    run(
        with(&["--kit", &dir.file("k.json"), "--kerf-mm", "0.3"]),
        "give --nest WIDTHxHEIGHT too",
    );
    // The crane's 75 mm facets are too small for M4 hinges; the message gives the smallest edge.
    usage_error(
        &["pattern", "--nest", "600x400", "--nest-dir", &cut],
        "needs --edge-mm ≥ 243.3",
    );
    assert!(
        !Path::new(&cut).join("sheet-1.dxf").exists(),
        "nothing written on a usage error"
    );
}

#[test]
fn pattern_bom_writes_the_crane_or_the_kit() {
    let dir = TempDir::new("bom");
    let (crane, kit) = (dir.file("crane.csv"), dir.file("kit.csv"));
    let out = ok(&["pattern", "--bom", &crane]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("bill of materials (crane"));
    let text = std::fs::read_to_string(&crane).unwrap();
    assert!(text.starts_with("section,part,quantity,unit,specification\n"));
    assert!(text.contains("electronics,tendon servo,3,pcs,"), "{text}");
    assert!(
        text.contains("trunk,TPU 95A filament (base sheet),"),
        "{text}"
    );
    // The printed parts are in the crane's BOM without --parts, sized by --tendon-radius-mm.
    for want in [
        "printed,upper cap (upper-cap.stl / .3mf),1,pcs,\"nylon (PA): ",
        "printed,lower cap (lower-cap.stl / .3mf),1,pcs,\"PLA: ",
        "printed,tendon locator (tendon-locator.stl / .3mf),2,pcs,",
        "printed,gripper mount (gripper-mount.stl / .3mf),1,pcs,",
        "printed,PLA filament (printed parts),",
        "hardware,disc magnet,6,pcs,",
        "hardware,M3 screw,4,pcs,",
        "hardware,tendon line,3,pcs,",
    ] {
        assert!(text.contains(want), "{want} in\n{text}");
    }
    assert!(text.contains("at r = 60 mm"), "{text}");
    ok(&["pattern", "--bom", &crane, "--tendon-radius-mm", "80", "-q"]);
    let text = std::fs::read_to_string(&crane).unwrap();
    assert!(text.contains("at r = 80 mm"), "{text}");
    usage_error(
        &["pattern", "--bom", &crane, "--panel-mm", "8"],
        "--panel-mm and --fold-max-deg size the kit's hinge leaf",
    );
    ok(&[
        "pattern",
        "--beta",
        "31.72",
        "--layers",
        "4",
        "--edge-mm",
        "609.6",
        "--nest",
        "1220x2440",
        "--nest-dir",
        &dir.file("cut"),
        "--bom",
        &kit,
    ]);
    let text = std::fs::read_to_string(&kit).unwrap();
    for want in [
        "kit,HDPE sheet,2,pcs,",
        "kit,hinge,180,pcs,",
        "printed,hinge leaf (hinge-leaf.stl / .3mf),360,pcs,\"PLA-CF: ",
        "printed,PLA-CF filament (printed parts),",
        "kit,hinge pin,180,pcs,\"⌀3 × 35 mm steel dowel",
        "kit,M4 screw,720,pcs,\"M4 × 8 button head",
        "kit,M4 heat-set insert,720,pcs,\"M4 × 5.7 mm, set into the 6 mm HDPE facets\"",
    ] {
        assert!(text.contains(want), "{want} in\n{text}");
    }
    assert!(!text.contains("electronics") && !text.contains("upper cap"));
    // The hinge leaf is sized by --panel-mm: a 12 mm panel takes M4 × 8 still (leaf 3 +
    // insert 5.7), the inserts sit in 12 mm.
    let kit_json = dir.file("kit.json");
    let paper = ["--beta", "31.72", "--layers", "4", "--edge-mm", "609.6"];
    let mut a = vec![
        "pattern",
        "--kit",
        &kit_json,
        "--bom",
        &kit,
        "--panel-mm",
        "12",
        "-q",
    ];
    a.extend(paper);
    ok(&a);
    let text = std::fs::read_to_string(&kit).unwrap();
    assert!(text.contains("set into the 12 mm HDPE facets"), "{text}");
    let mut a = vec![
        "pattern",
        "--kit",
        &kit_json,
        "--bom",
        &kit,
        "--tendon-radius-mm",
        "400",
    ];
    a.extend(paper);
    usage_error(&a, "--tendon-radius-mm sizes the crane's caps");
}

#[test]
fn pattern_page_tiles_the_crease_pattern_and_refuses_other_paper() {
    let dir = TempDir::new("pages");
    let pages = dir.file("pages");
    // Without a legend the 230 × 197.7 mm sheet takes two portrait pages; with the legend
    // below it, two landscape pages (the legend on the second, below the sheet).
    let out = ok(&[
        "pattern",
        "--page",
        "a4",
        "--page-dir",
        &pages,
        "--legend",
        "below",
        "-j",
    ]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let files = v["files"].as_array().unwrap();
    assert_eq!(files.len(), 2, "{v}");
    assert_eq!(files[0]["page_mm"], serde_json::json!([297.0, 210.0]));
    let legend: Vec<bool> = files
        .iter()
        .map(|f| f["legend"].as_bool().unwrap())
        .collect();
    assert_eq!(legend, [false, true]);
    let out = ok(&[
        "pattern",
        "--page",
        "a4",
        "--page-dir",
        &pages,
        "--legend",
        "right",
        "-j",
    ]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let legend: Vec<bool> = v["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["legend"].as_bool().unwrap())
        .collect();
    assert_eq!(legend.iter().filter(|x| **x).count(), 1, "{v}");
    let out = ok(&[
        "pattern",
        "--page",
        "a4",
        "--page-dir",
        &pages,
        "--legend",
        "none",
        "-j",
    ]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let files = v["files"].as_array().unwrap();
    assert_eq!(files.len(), 2, "{v}");
    assert_eq!(files[0]["pages"], 2);
    assert_eq!(files[0]["page_mm"], serde_json::json!([210.0, 297.0]));
    assert!(files.iter().all(|f| f["legend"] == false));
    for (i, f) in files.iter().enumerate() {
        let name = format!("page-{}.svg", i + 1);
        assert!(f["path"].as_str().unwrap().ends_with(&name));
        let text = std::fs::read_to_string(Path::new(&pages).join(&name)).unwrap();
        assert!(text.contains(r#"width="210mm" height="297mm""#));
        assert!(text.contains(r#"class="registration""#));
    }
    usage_error(
        &["pattern", "--page", "a3", "--page-dir", &pages],
        "a4 or letter",
    );
    usage_error(&["pattern", "--page", "a4"], "give --page-dir DIR");
    usage_error(
        &["pattern", "--page-dir", &pages, "--svg", &dir.file("x.svg")],
        "give --page a4|letter too",
    );
}

#[test]
fn pattern_parts_writes_one_stl_per_part_and_says_what_it_wrote() {
    let dir = TempDir::new("parts");
    let parts = dir.file("parts");
    let out = ok(&[
        "pattern",
        "--beta",
        "31.72",
        "--layers",
        "4",
        "--edge-mm",
        "609.6",
        "--parts",
        &parts,
        "--tendon-radius-mm",
        "400",
        "-j",
    ]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let all = v["files"].as_array().unwrap();
    // By default an STL and a 3MF of every part, side by side.
    let names: Vec<(&str, &str)> = all
        .iter()
        .map(|f| (f["part"].as_str().unwrap(), f["format"].as_str().unwrap()))
        .collect();
    let expect = [
        "hinge-leaf",
        "upper-cap",
        "lower-cap",
        "tendon-locator",
        "gripper-mount",
    ];
    assert_eq!(
        names,
        expect
            .iter()
            .flat_map(|p| [(*p, "stl"), (*p, "3mf")])
            .collect::<Vec<_>>()
    );
    for f in all.iter().filter(|f| f["format"] == "3mf") {
        let path = f["path"].as_str().unwrap();
        assert!(path.ends_with(&format!("{}.3mf", f["part"].as_str().unwrap())));
        let bytes = std::fs::read(path).unwrap();
        assert_eq!(f["bytes"].as_u64(), Some(bytes.len() as u64));
        assert_eq!(&bytes[..2], b"PK", "{path}: a zip package");
        let mass = f["mass_g"].as_f64().unwrap();
        let want =
            f["volume_mm3"].as_f64().unwrap() / 1000.0 * f["density_g_per_cm3"].as_f64().unwrap();
        assert!((mass - want).abs() < 1e-9, "{path}: {mass} g vs {want}");
    }
    let files: Vec<&Value> = all.iter().filter(|f| f["format"] == "stl").collect();
    for f in files.iter().copied() {
        assert_eq!(f["flag"], "--parts");
        let path = f["path"].as_str().unwrap();
        let bytes = std::fs::metadata(path).unwrap().len();
        assert_eq!(f["bytes"].as_u64(), Some(bytes), "{path}");
        // Binary STL: 84-byte header and count, 50 bytes a triangle.
        assert_eq!(f["triangles"].as_u64(), Some((bytes - 84) / 50), "{path}");
        assert!(f["volume_mm3"].as_f64().unwrap() > 0.0);
        for h in f["holes"].as_array().unwrap() {
            if h["role"] == "tendon" {
                let c = h["centre_mm"].as_array().unwrap();
                let r = c[0].as_f64().unwrap().hypot(c[1].as_f64().unwrap());
                assert!((r - 400.0).abs() < 0.01, "{path}: tendon hole at r = {r}");
            }
        }
    }
    // The paper's kit: 180 hinges, two leaves each.
    assert_eq!(files[0]["quantity"], 360);
    assert_eq!(
        files[0]["dimensions"]["screw_inset_mm"].as_f64(),
        Some(12.0)
    );
    assert_eq!(files[0]["material"], "PLA-CF");
    assert_eq!(files[1]["material"], "nylon (PA)");
    assert_eq!(files[2]["material"], "PLA");
    let _ = std::fs::remove_dir_all(&parts);
    let out = ok(&["pattern", "--parts", &parts, "--parts-format", "stl"]);
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(
        text.contains("hinge-leaf.stl") && text.contains("triangles") && !text.contains(".3mf"),
        "{text}"
    );
    let mut written: Vec<String> = std::fs::read_dir(&parts)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    written.sort();
    assert_eq!(
        written,
        [
            "gripper-mount.stl",
            "hinge-leaf.stl",
            "lower-cap.stl",
            "tendon-locator.stl",
            "upper-cap.stl"
        ]
    );
    let out = ok(&["pattern", "--parts", &parts, "--parts-format", "3MF", "-j"]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["files"]
        .as_array()
        .unwrap()
        .iter()
        .all(|f| f["format"] == "3mf"));
    assert_eq!(v["files"].as_array().unwrap().len(), 5);
}

#[test]
fn parts_usage_errors_say_what_is_valid_and_write_nothing() {
    let dir = TempDir::new("parts-bad");
    let parts = dir.file("parts");
    for (args, want) in [
        (
            vec!["--tendon-radius-mm", "40"],
            "--tendon-radius-mm must be in [51.31, 1000] mm",
        ),
        (vec!["--tendon-radius-mm", "nan"], "--tendon-radius-mm"),
        (
            vec!["--panel-mm", "3"],
            "--panel-mm must be a sheet thickness",
        ),
        (vec!["--panel-mm", "60"], "[5.7, 50]"),
        (vec!["--fold-max-deg", "0"], "--fold-max-deg must be"),
        (vec!["--fold-max-deg", "181"], "(0, 180]"),
    ] {
        let mut a = vec!["pattern", "--parts", &parts];
        a.extend(args);
        usage_error(&a, want);
        assert!(!Path::new(&parts).exists(), "{a:?} wrote {parts}");
    }
    usage_error(
        &["pattern", "--svg", &dir.file("x.svg"), "--panel-mm", "8"],
        "give --parts DIR too",
    );
    usage_error(
        &[
            "pattern",
            "--svg",
            &dir.file("x.svg"),
            "--tendon-radius-mm",
            "70",
        ],
        "give --parts DIR too (or --bom FILE, without --kit and --nest)",
    );
    usage_error(
        &["pattern", "--parts", &parts, "--parts-format", "obj"],
        "--parts-format must be stl, 3mf or both, got 'obj'",
    );
    assert!(!Path::new(&parts).exists());
    usage_error(
        &[
            "pattern",
            "--svg",
            &dir.file("x.svg"),
            "--parts-format",
            "stl",
        ],
        "--parts-format chooses the files of --parts; give --parts DIR too",
    );
    // A small trunk's tendons may run closer than the gripper mount's fixing circle allows.
    usage_error(
        &[
            "pattern",
            "--edge-mm",
            "10",
            "--parts",
            &parts,
            "--tendon-radius-mm",
            "20",
        ],
        "needs a tendon radius of at least 33 mm",
    );
    assert!(!Path::new(&parts).exists());
    // A smaller trunk takes a smaller tendon radius.
    ok(&[
        "pattern",
        "--edge-mm",
        "40",
        "--parts",
        &parts,
        "--tendon-radius-mm",
        "37",
        "-q",
    ]);
}
