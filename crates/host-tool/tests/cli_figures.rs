//! Every figure host-tool writes, read back by independent readers: the SVG through usvg
//! (text laid out with the bundled font: every text box inside the canvas, none overlapping
//! another, type at least 7 pt at one-column width; the axis titles, tick labels, legend
//! entries and state labels present), the PNG decoded by `png` (size for 8.5 cm at 600 dpi,
//! its resolution recorded, not blank, the data colours present), the PDF parsed by `lopdf`
//! (one page of the figure's size in pt, the font embedded, the labels extractable as text).

#[path = "support/cli.rs"]
mod cli;

use cli::host_tool;

use std::path::{Path, PathBuf};

use resvg::usvg;

const FONT: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");
/// 8.5 cm in pt.
const COLUMN_PT: f64 = 8.5 / 2.54 * 72.0;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cli-figures-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn ok(out: &std::process::Output) {
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A text element as laid out: its content, box (pt, y down) and smallest font size.
#[derive(Debug)]
struct Text {
    text: String,
    bbox: (f64, f64, f64, f64),
    size: f64,
}

fn texts(group: &usvg::Group, out: &mut Vec<Text>) {
    for node in group.children() {
        match node {
            usvg::Node::Group(g) => texts(g, out),
            usvg::Node::Text(t) => {
                let b = t.abs_bounding_box();
                let text: String = t.chunks().iter().map(|c| c.text()).collect();
                let size = t
                    .chunks()
                    .iter()
                    .flat_map(|c| c.spans())
                    .map(|s| f64::from(s.font_size().get()))
                    .fold(f64::INFINITY, f64::min);
                out.push(Text {
                    text,
                    // Canvas px (the viewBox scaled to the size) back to pt.
                    bbox: (
                        0.75 * f64::from(b.left()),
                        0.75 * f64::from(b.top()),
                        0.75 * f64::from(b.right()),
                        0.75 * f64::from(b.bottom()),
                    ),
                    size,
                });
            }
            _ => {}
        }
    }
}

/// Reads an SVG figure with usvg and the bundled font only; checks the layout rules and
/// returns its texts.
fn check_svg(path: &Path) -> Vec<Text> {
    let data = std::fs::read_to_string(path).expect("svg written");
    assert!(data.starts_with("<svg") && data.trim_end().ends_with("</svg>"));
    let mut opt = usvg::Options {
        font_family: "DejaVu Sans".into(),
        ..Default::default()
    };
    opt.fontdb_mut().load_font_data(FONT.to_vec());
    let tree = usvg::Tree::from_str(&data, &opt).expect("usvg reads the SVG");
    // Sized in pt (usvg reports CSS px, 4/3 of a pt); the viewBox is in pt.
    let w = f64::from(tree.size().width()) * 0.75;
    let h = f64::from(tree.size().height()) * 0.75;
    assert!((w - COLUMN_PT).abs() < 0.01, "width {w} pt");
    assert!(h > 100.0 && h < 1.6 * COLUMN_PT, "height {h} pt");
    let mut all = Vec::new();
    texts(tree.root(), &mut all);
    assert!(all.len() > 10, "{} texts", all.len());
    let eps = 0.01;
    for t in &all {
        let (l, top, r, b) = t.bbox;
        assert!(
            l >= -eps && top >= -eps && r <= w + eps && b <= h + eps,
            "{:?} leaves the {w}×{h} pt canvas: {:?}",
            t.text,
            t.bbox
        );
        assert!(t.size >= 7.0 - 1e-6, "{:?} is set at {} pt", t.text, t.size);
    }
    for (i, a) in all.iter().enumerate() {
        for b in &all[i + 1..] {
            let overlap = a.bbox.0 < b.bbox.2 - eps
                && b.bbox.0 < a.bbox.2 - eps
                && a.bbox.1 < b.bbox.3 - eps
                && b.bbox.1 < a.bbox.3 - eps;
            assert!(
                !overlap,
                "{:?} {:?} overlaps {:?} {:?}",
                a.text, a.bbox, b.text, b.bbox
            );
        }
    }
    all
}

fn has(texts: &[Text], s: &str) -> bool {
    texts.iter().any(|t| t.text == s)
}

fn has_part(texts: &[Text], s: &str) -> bool {
    texts
        .iter()
        .any(|t| t.text.replace('\u{a0}', " ").contains(s))
}

/// Decodes a PNG figure; checks its size, resolution and that it shows something in `colour`.
fn check_png(path: &Path, colour: [u8; 3]) {
    let file = std::fs::File::open(path).expect("png written");
    let decoder = png::Decoder::new(std::io::BufReader::new(file));
    let mut reader = decoder.read_info().expect("a PNG");
    let info = reader.info();
    // 8.5 cm at 600 dpi.
    assert_eq!(info.width, 2008);
    let dims = info.pixel_dims.expect("pHYs");
    assert_eq!((dims.xppu, dims.unit), (23622, png::Unit::Meter));
    let mut buf = vec![0; reader.output_buffer_size()];
    let frame = reader.next_frame(&mut buf).expect("decodes");
    assert_eq!(frame.color_type, png::ColorType::Rgb);
    let px: Vec<[u8; 3]> = buf[..frame.buffer_size()]
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    let ink = px.iter().filter(|p| **p != [255, 255, 255]).count();
    let frac = ink as f64 / px.len() as f64;
    assert!(
        (0.01..0.5).contains(&frac),
        "{:.3} of the pixels inked",
        frac
    );
    let near = |p: &[u8; 3]| (0..3).all(|k| (i16::from(p[k]) - i16::from(colour[k])).abs() <= 8);
    let coloured = px.iter().filter(|p| near(p)).count();
    assert!(coloured > 2000, "{coloured} pixels of {colour:?}");
}

/// Parses a PDF figure; checks one page of `height_pt`, the embedded font and the text.
fn check_pdf(path: &Path, height_pt: f64, words: &[&str]) {
    let data = std::fs::read(path).expect("pdf written");
    assert!(data.starts_with(b"%PDF-1."));
    let doc = lopdf::Document::load_mem(&data).expect("lopdf reads the PDF");
    let pages = doc.get_pages();
    assert_eq!(pages.len(), 1);
    let page = doc.get_object(pages[&1]).unwrap().as_dict().unwrap();
    let media: Vec<f64> = page
        .get(b"MediaBox")
        .unwrap()
        .as_array()
        .unwrap()
        .iter()
        .map(|o| {
            o.as_float()
                .map(f64::from)
                .or_else(|_| o.as_i64().map(|i| i as f64))
                .unwrap()
        })
        .collect();
    assert!((media[2] - media[0] - COLUMN_PT).abs() < 0.05, "{media:?}");
    assert!(
        (media[3] - media[1] - height_pt).abs() < 0.05,
        "{media:?} vs {height_pt}"
    );
    let embedded = doc.objects.values().any(|o| {
        o.as_dict()
            .is_ok_and(|d| d.has(b"FontFile2") || d.has(b"FontFile3"))
    });
    assert!(embedded, "no embedded font");
    // lopdf puts every positioned glyph on a line of its own.
    let text = doc
        .extract_text(&[1])
        .expect("text extracts")
        .replace('\n', "");
    for w in words {
        assert!(text.contains(w), "{w:?} not in the PDF's text:\n{text}");
    }
}

fn svg_height_pt(path: &Path) -> f64 {
    let s = std::fs::read_to_string(path).unwrap();
    let h = s.split("height=\"").nth(1).unwrap();
    h[..h.find("pt\"").unwrap()].parse().unwrap()
}

#[test]
fn ik_figure_in_three_formats_with_axes_legend_and_tip_states() {
    let d = dir("ik");
    let (svg, png, pdf) = (d.join("fit.svg"), d.join("fit.png"), d.join("fit.pdf"));
    ok(&host_tool(&[
        "ik",
        "--n",
        "3",
        "--beta",
        "31.72",
        "--modules",
        "10",
        "--target",
        "helix:radius=1,pitch=2,turns=1",
        "--svg",
        svg.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--pdf",
        pdf.to_str().unwrap(),
    ]));
    let t = check_svg(&svg);
    for label in [
        "x (l)",
        "y (l)",
        "z (l)",
        "top view (x–y)",
        "front view (x–z)",
        "side view (y–z)",
        "target curve",
        "module rings",
        "module side edges",
        "tip (top centroid)",
        "origin (base centre)",
    ] {
        assert!(has(&t, label), "no {label:?}");
    }
    // Tick labels in l with a true minus sign, on every axis.
    for tick in ["0", "1", "−1"] {
        assert!(
            t.iter().filter(|x| x.text == tick).count() >= 3,
            "tick {tick}"
        );
    }
    assert!(has_part(&t, "RMS = 0.1778 l (proven optimal)"));
    assert!(has_part(&t, "tip state:"));
    // The fit (docs/ik.md): edge and vertex pop-outs and one folded module, labelled.
    let labels = t
        .iter()
        .filter(|x| ["F", "E0", "E1", "E2", "V1"].contains(&x.text.as_str()))
        .count();
    assert!(labels >= 7, "{labels} tip labels");
    check_png(&png, [0x00, 0x72, 0xB2]);
    check_pdf(
        &pdf,
        svg_height_pt(&svg),
        &["x (l)", "target curve", "front view"],
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// A long β list and a long target path: the title wraps or shortens, never overflows.
#[test]
fn ik_titles_wrap_or_shorten_and_infeasible_states_have_their_legend() {
    let d = dir("ik-long");
    let deep = d.join("a-directory-name-long-enough-to-overflow-any-title-line/and-deeper");
    std::fs::create_dir_all(&deep).unwrap();
    let csv = deep.join("target-curve-with-a-long-name.csv");
    std::fs::write(&csv, "0,0,0\n0.3,0,0.6\n0.6,0.2,1.2\n0.8,0.5,1.6\n").unwrap();
    let betas: Vec<String> = (0..16)
        .map(|i| {
            if i % 2 == 0 {
                "35".into()
            } else {
                "31.72".into()
            }
        })
        .collect();
    let svg = d.join("long.svg");
    ok(&host_tool(&[
        "ik",
        "--n",
        "4",
        "--beta",
        &betas.join(","),
        "--modules",
        "16",
        "--target-file",
        csv.to_str().unwrap(),
        "--algo",
        "greedy",
        "--all-states",
        "--svg",
        svg.to_str().unwrap(),
    ]));
    let t = check_svg(&svg);
    assert!(has_part(&t, "β from 31.72° to 35°"), "{t:?}");
    assert!(has_part(&t, "target /tmp/"), "{t:?}");
    assert!(has_part(&t, "…"), "the path is shortened");
    assert!(has_part(&t, "target-curve-with-a-long-name.csv"));
    let text = std::fs::read_to_string(&svg).unwrap();
    if text.contains(r#"class="infeasible""#) {
        assert!(has_part(&t, "infeasible state ("), "legend entry");
        // One group of infeasible edges per view.
        assert_eq!(text.matches(r#"class="infeasible""#).count(), 3);
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn log_plot_in_three_formats_by_extension_or_format() {
    let d = dir("plot");
    let rec = d.join("plan.mcap");
    ok(&host_tool(&[
        "plan",
        "--sim",
        "--seed",
        "7",
        "--target",
        "D&D",
        "--record",
        rec.to_str().unwrap(),
        "--json",
    ]));
    let r = rec.to_str().unwrap();
    let svg = d.join("plot.svg");
    ok(&host_tool(&[
        "log",
        "plot",
        r,
        "--out",
        svg.to_str().unwrap(),
    ]));
    let t = check_svg(&svg);
    for label in [
        "pressure (kPa)",
        "servo (°)",
        "device time (s)",
        "pressure, measured",
        "pressure, true (simulator)",
        "servo 1",
        "servo 2",
        "servo 3",
        "snap-through (simulator)",
        "state confirmed by the device",
        "F&F",
        "D&F",
        "D&D",
        // Ticks: time in s, pressure in kPa (seed 7 peaks at 30.1 kPa).
        "0",
        "2",
        "10",
        "30",
    ] {
        assert!(has(&t, label), "no {label:?}");
    }
    assert!(has_part(&t, "plan.mcap — simulator seed 7"));
    // Seed 7's run: four snap-throughs through both panels, three confirmed states.
    let text = std::fs::read_to_string(&svg).unwrap();
    let group = |class: &str| {
        text.split(&format!(r#"<g class="{class}">"#))
            .skip(1)
            .map(|g| g[..g.find("</g>").unwrap()].matches("<line").count())
            .collect::<Vec<_>>()
    };
    assert_eq!(group("snap-throughs"), vec![4, 4]);
    assert_eq!(group("states-confirmed"), vec![3, 3]);

    let png = d.join("plot.png");
    ok(&host_tool(&[
        "log",
        "plot",
        r,
        "--out",
        png.to_str().unwrap(),
    ]));
    check_png(&png, [0x00, 0x72, 0xB2]);
    // No extension: --format says it.
    let pdf = d.join("plot-pdf");
    ok(&host_tool(&[
        "log",
        "plot",
        r,
        "--out",
        pdf.to_str().unwrap(),
        "--format",
        "pdf",
    ]));
    check_pdf(
        &pdf,
        svg_height_pt(&svg),
        &["pressure (kPa)", "device time (s)", "D&F"],
    );

    // Refused up front, nothing written: an unknown extension, an unknown format, a
    // contradiction.
    for (out, format, why) in [
        ("plot.jpg", None, "cannot tell the figure format"),
        ("plot", Some("eps"), "unknown figure format 'eps'"),
        ("plot.png", Some("pdf"), "--format pdf contradicts"),
    ] {
        let path = d.join(format!("refused-{out}"));
        let mut args = vec!["log", "plot", r, "--out", path.to_str().unwrap()];
        if let Some(f) = format {
            args.extend(["--format", f]);
        }
        let o = host_tool(&args);
        assert_eq!(o.status.code(), Some(2), "{out} {format:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(why), "{err}");
        assert!(!path.exists(), "{out} written");
    }
    let _ = std::fs::remove_dir_all(&d);
}
