//! Figures for print: every picture host-tool draws (`ik --svg/--png/--pdf`, `log plot`) is
//! laid out here in points at single-column width (8.5 cm = 241 pt), written as SVG, and
//! rendered from that one SVG to PNG (resvg, 600 dpi) and PDF (svg2pdf, vector, text kept as
//! text) with the bundled DejaVu Sans only — no system font is ever looked up, so a figure is
//! the same file on every machine.
//!
//! The SVG is written here rather than through a plotting crate because its layout needs what
//! those crates do not give: one scale shared by three orthographic views, labels placed
//! around the data without overlapping, titles wrapped to the measured width of their words.
//! Widths are measured with the font's own advances ([`text_width`]), so every text box is
//! known before it is written; the tests read the SVG back with usvg and check that none
//! leaves the canvas and none overlaps another.

use std::fmt::Write as _;
use std::path::Path;
use std::sync::{Arc, OnceLock};

/// The bundled font (DejaVu Sans 2.37, Bitstream Vera licence: `fonts/LICENSE-DejaVu`).
pub const FONT: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");
/// Its family name, as the SVG names it.
pub const FONT_FAMILY: &str = "DejaVu Sans";
/// Single-column width of a journal page: 8.5 cm in points.
pub const COLUMN_PT: f64 = 8.5 / 2.54 * 72.0;
/// Resolution of the PNG (line art for print).
pub const PNG_DPI: f64 = 600.0;

/// Type sizes in pt at print size.
pub const SIZE_TICK: f64 = 7.0;
/// Axis titles and legend entries.
pub const SIZE_LABEL: f64 = 7.5;
/// The figure's header lines.
pub const SIZE_TITLE: f64 = 8.0;
/// Line height as a multiple of the type size: more than the font's ascent + descent
/// (1.164 em), so stacked lines never touch.
pub const LEADING: f64 = 1.25;
/// The font's cap height (em): a baseline `0.5 × CAP × size` below a centre line centres
/// capitals and digits on it.
pub const CAP: f64 = 0.729;
/// Ascent and descent of the font (em), the vertical extent of a line of text.
pub const ASCENT: f64 = 0.928;
/// See [`ASCENT`].
pub const DESCENT: f64 = 0.236;

/// Colours (Okabe–Ito, distinguishable with the common colour-vision deficiencies).
pub mod colour {
    /// Blue.
    pub const BLUE: &str = "#0072B2";
    /// Vermillion.
    pub const VERMILLION: &str = "#D55E00";
    /// Orange.
    pub const ORANGE: &str = "#E69F00";
    /// Bluish green.
    pub const GREEN: &str = "#009E73";
    /// Reddish purple.
    pub const PURPLE: &str = "#CC79A7";
    /// Sky blue.
    pub const SKY: &str = "#56B4E9";
    /// Black.
    pub const BLACK: &str = "#000000";
    /// Dark grey (secondary lines, text).
    pub const GREY: &str = "#555555";
    /// Light grey (grid).
    pub const LIGHT: &str = "#DDDDDD";
}

/// An output format of a figure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Scalable vector graphics (text as text; names DejaVu Sans).
    Svg,
    /// 600 dpi raster, resolution recorded in the file.
    Png,
    /// Vector PDF, one page the size of the figure, the font subset embedded.
    Pdf,
}

impl Format {
    /// The formats by name, as `--format` takes them.
    pub const NAMES: &'static str = "svg, png, pdf";

    /// The format a file name's extension names (case-insensitive), if any.
    pub fn from_path(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Format::parse(&ext).ok()
    }

    /// Parses `svg`, `png` or `pdf`.
    pub fn parse(text: &str) -> Result<Format, String> {
        match text.trim().to_ascii_lowercase().as_str() {
            "svg" => Ok(Format::Svg),
            "png" => Ok(Format::Png),
            "pdf" => Ok(Format::Pdf),
            _ => Err(format!(
                "unknown figure format '{text}': expected one of {}",
                Format::NAMES
            )),
        }
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            Format::Svg => "svg",
            Format::Png => "png",
            Format::Pdf => "pdf",
        }
    }
}

fn face() -> &'static ttf_parser::Face<'static> {
    static FACE: OnceLock<ttf_parser::Face<'static>> = OnceLock::new();
    FACE.get_or_init(|| ttf_parser::Face::parse(FONT, 0).expect("the bundled font parses"))
}

/// Width in pt of `text` set at `size` pt in the bundled font (sum of advances; kerning only
/// narrows it).
pub fn text_width(text: &str, size: f64) -> f64 {
    let f = face();
    let upem = f64::from(f.units_per_em());
    let fallback = f.glyph_index('?');
    text.chars()
        .map(|c| {
            f.glyph_index(c)
                .or(fallback)
                .and_then(|g| f.glyph_hor_advance(g))
                .map_or(0.6 * upem, f64::from)
        })
        .sum::<f64>()
        * size
        / upem
}

/// `text` shortened in the middle with "…" to at most `max` pt at `size` pt.
pub fn shorten(text: &str, size: f64, max: f64) -> String {
    if text_width(text, size) <= max {
        return text.to_string();
    }
    let chars: Vec<char> = text.chars().collect();
    // Keep more of the end (a file name's last component, a list's last values).
    for keep in (1..chars.len()).rev() {
        let head = keep / 3;
        let tail = keep - head;
        let s: String = chars[..head]
            .iter()
            .chain(std::iter::once(&'…'))
            .chain(&chars[chars.len() - tail..])
            .collect();
        if text_width(&s, size) <= max {
            return s;
        }
    }
    "…".to_string()
}

/// Splits `text` at spaces into lines at most `max` pt wide at `size` pt; a word wider than
/// a line is shortened. A no-break space (U+00A0) keeps its neighbours on one line.
pub fn wrap(text: &str, size: f64, max: f64) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split(' ').filter(|w| !w.is_empty()) {
        let word = shorten(word, size, max);
        let joined = if line.is_empty() {
            word.clone()
        } else {
            format!("{line} {word}")
        };
        if text_width(&joined, size) <= max || line.is_empty() {
            line = joined;
        } else {
            lines.push(std::mem::replace(&mut line, word));
        }
    }
    if !line.is_empty() || lines.is_empty() {
        lines.push(line);
    }
    lines
}

/// A number for a tick label: `decimals` places, a true minus sign, never "−0".
pub fn number(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    let zero = s
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.');
    if zero {
        s.trim_start_matches('-').to_string()
    } else if let Some(rest) = s.strip_prefix('-') {
        format!("−{rest}")
    } else {
        s
    }
}

/// Round tick positions: a step of 1, 2 or 5 × 10^k.
#[derive(Clone, Debug, PartialEq)]
pub struct Ticks {
    /// The step.
    pub step: f64,
    /// The positions, ascending.
    pub values: Vec<f64>,
}

impl Ticks {
    /// The smallest round step of at least `min_step`.
    pub fn step_at_least(min_step: f64) -> f64 {
        let min_step = min_step.max(1e-12);
        let mag = 10f64.powf(min_step.log10().floor());
        [1.0, 2.0, 5.0, 10.0]
            .iter()
            .map(|m| m * mag)
            .find(|s| *s >= min_step * (1.0 - 1e-9))
            .unwrap_or(10.0 * mag)
    }

    /// Ticks of `step` inside [lo, hi].
    pub fn within(lo: f64, hi: f64, step: f64) -> Ticks {
        let first = (lo / step - 1e-9).ceil() as i64;
        let last = (hi / step + 1e-9).floor() as i64;
        Ticks {
            step,
            values: (first..=last).map(|i| i as f64 * step).collect(),
        }
    }

    /// At most about `count` round ticks from at or below `lo` to at or above `hi` (the axis
    /// then spans the first to the last).
    pub fn covering(lo: f64, hi: f64, count: usize) -> Ticks {
        let span = (hi - lo).max(1e-9);
        let step = Ticks::step_at_least(span / count.max(1) as f64);
        let first = (lo / step + 1e-9).floor() as i64;
        let last = ((hi / step - 1e-9).ceil() as i64).max(first + 1);
        Ticks {
            step,
            values: (first..=last).map(|i| i as f64 * step).collect(),
        }
    }

    /// Decimal places that show the step exactly.
    pub fn decimals(&self) -> usize {
        let mut d = 0;
        while d < 6
            && ((self.step * 10f64.powi(d as i32)).round() - self.step * 10f64.powi(d as i32)).abs()
                > 1e-6
        {
            d += 1;
        }
        d
    }

    /// The label of each tick.
    pub fn labels(&self) -> Vec<String> {
        let d = self.decimals();
        self.values.iter().map(|v| number(*v, d)).collect()
    }

    /// The first and last tick.
    pub fn range(&self) -> (f64, f64) {
        (
            *self.values.first().unwrap_or(&0.0),
            *self.values.last().unwrap_or(&1.0),
        )
    }
}

/// How a line is drawn.
#[derive(Clone, Copy, Debug)]
pub struct Stroke {
    /// Colour.
    pub colour: &'static str,
    /// Width in pt.
    pub width: f64,
    /// SVG dash array in pt, e.g. "3 1.5".
    pub dash: Option<&'static str>,
}

impl Stroke {
    /// A solid line.
    pub const fn solid(colour: &'static str, width: f64) -> Stroke {
        Stroke {
            colour,
            width,
            dash: None,
        }
    }

    /// A dashed line.
    pub const fn dashed(colour: &'static str, width: f64, dash: &'static str) -> Stroke {
        Stroke {
            colour,
            width,
            dash: Some(dash),
        }
    }

    fn attrs(&self) -> String {
        let mut s = format!(
            r#" fill="none" stroke="{}" stroke-width="{}" stroke-linejoin="round""#,
            self.colour,
            num(self.width)
        );
        if let Some(d) = self.dash {
            let _ = write!(s, r#" stroke-dasharray="{d}""#);
        }
        s
    }
}

/// Horizontal alignment of a text at its anchor point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Anchor {
    /// The text starts at x.
    Start,
    /// The text is centred on x.
    Middle,
    /// The text ends at x.
    End,
}

/// A mark a legend shows.
#[derive(Clone, Copy, Debug)]
pub enum Swatch {
    /// A line sample.
    Line(Stroke),
    /// A filled dot.
    Dot(&'static str),
    /// A ring.
    Ring(&'static str),
}

/// A rectangle (x, y, width, height) in pt, y down.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    /// Left.
    pub x: f64,
    /// Top.
    pub y: f64,
    /// Width.
    pub w: f64,
    /// Height.
    pub h: f64,
}

impl Rect {
    /// Whether the two overlap (touching edges do not).
    pub fn overlaps(&self, o: &Rect) -> bool {
        self.x < o.x + o.w && o.x < self.x + self.w && self.y < o.y + o.h && o.y < self.y + self.h
    }

    /// Whether `o` lies inside this one.
    pub fn contains(&self, o: &Rect) -> bool {
        o.x >= self.x - 1e-9
            && o.y >= self.y - 1e-9
            && o.x + o.w <= self.x + self.w + 1e-9
            && o.y + o.h <= self.y + self.h + 1e-9
    }
}

/// The box of a one-line text at baseline (x, y).
pub fn text_box(x: f64, y: f64, size: f64, anchor: Anchor, text: &str) -> Rect {
    let w = text_width(text, size);
    let left = match anchor {
        Anchor::Start => x,
        Anchor::Middle => x - w / 2.0,
        Anchor::End => x - w,
    };
    Rect {
        x: left,
        y: y - ASCENT * size,
        w,
        h: (ASCENT + DESCENT) * size,
    }
}

fn num(v: f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.to_string()
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A figure being drawn: a canvas in pt, y down, and the SVG elements on it.
#[derive(Debug)]
pub struct Figure {
    width: f64,
    height: f64,
    body: String,
    texts: Vec<(Rect, String)>,
}

impl Figure {
    /// An empty white canvas.
    pub fn new(width: f64, height: f64) -> Figure {
        Figure {
            width,
            height,
            body: String::new(),
            texts: Vec::new(),
        }
    }

    /// Width in pt.
    #[cfg(test)]
    pub fn width(&self) -> f64 {
        self.width
    }

    /// Height in pt.
    #[cfg(test)]
    pub fn height(&self) -> f64 {
        self.height
    }

    /// Opens a group (`<g class=…>`), e.g. to name a kind of mark.
    pub fn begin(&mut self, class: &str) {
        let _ = writeln!(self.body, r#"<g class="{}">"#, esc(class));
    }

    /// Closes the group [`Figure::begin`] opened.
    pub fn end(&mut self) {
        self.body.push_str("</g>\n");
    }

    /// An open polyline.
    pub fn polyline(&mut self, pts: &[(f64, f64)], stroke: Stroke) {
        if pts.len() < 2 {
            return;
        }
        let _ = writeln!(
            self.body,
            r#"<polyline points="{}"{}/>"#,
            points(pts),
            stroke.attrs()
        );
    }

    /// A closed polygon.
    pub fn polygon(&mut self, pts: &[(f64, f64)], stroke: Stroke) {
        let _ = writeln!(
            self.body,
            r#"<polygon points="{}"{}/>"#,
            points(pts),
            stroke.attrs()
        );
    }

    /// A straight line.
    pub fn line(&mut self, a: (f64, f64), b: (f64, f64), stroke: Stroke) {
        let _ = writeln!(
            self.body,
            r#"<line x1="{}" y1="{}" x2="{}" y2="{}"{}/>"#,
            num(a.0),
            num(a.1),
            num(b.0),
            num(b.1),
            stroke.attrs()
        );
    }

    /// A filled dot of radius `r`.
    pub fn dot(&mut self, c: (f64, f64), r: f64, fill: &str) {
        let _ = writeln!(
            self.body,
            r#"<circle cx="{}" cy="{}" r="{}" fill="{fill}"/>"#,
            num(c.0),
            num(c.1),
            num(r)
        );
    }

    /// A ring of radius `r`.
    pub fn ring(&mut self, c: (f64, f64), r: f64, stroke: Stroke) {
        let _ = writeln!(
            self.body,
            r#"<circle cx="{}" cy="{}" r="{}"{}/>"#,
            num(c.0),
            num(c.1),
            num(r),
            stroke.attrs()
        );
    }

    /// A filled rectangle (no outline).
    pub fn fill_rect(&mut self, r: Rect, fill: &str) {
        let _ = writeln!(
            self.body,
            r#"<rect x="{}" y="{}" width="{}" height="{}" fill="{fill}"/>"#,
            num(r.x),
            num(r.y),
            num(r.w),
            num(r.h)
        );
    }

    /// A rectangle outline.
    pub fn rect(&mut self, r: Rect, stroke: Stroke) {
        let _ = writeln!(
            self.body,
            r#"<rect x="{}" y="{}" width="{}" height="{}"{}/>"#,
            num(r.x),
            num(r.y),
            num(r.w),
            num(r.h),
            stroke.attrs()
        );
    }

    /// One line of text with its baseline at (x, y); returns its box.
    pub fn text(
        &mut self,
        x: f64,
        y: f64,
        size: f64,
        anchor: Anchor,
        fill: &str,
        text: &str,
    ) -> Rect {
        self.text_impl(x, y, size, anchor, fill, text, false)
    }

    /// As [`Figure::text`], on a white halo so that it reads over lines.
    pub fn label(
        &mut self,
        x: f64,
        y: f64,
        size: f64,
        anchor: Anchor,
        fill: &str,
        text: &str,
    ) -> Rect {
        self.text_impl(x, y, size, anchor, fill, text, true)
    }

    #[allow(clippy::too_many_arguments)]
    fn text_impl(
        &mut self,
        x: f64,
        y: f64,
        size: f64,
        anchor: Anchor,
        fill: &str,
        text: &str,
        halo: bool,
    ) -> Rect {
        let b = text_box(x, y, size, anchor, text);
        let halo = if halo {
            r##" stroke="#FFFFFF" stroke-width="1.6" stroke-linejoin="round" paint-order="stroke""##
        } else {
            ""
        };
        let _ = writeln!(
            self.body,
            r#"<text x="{}" y="{}" font-size="{}"{}{}{halo}>{}</text>"#,
            num(x),
            num(y),
            num(size),
            anchor_attr(anchor),
            fill_attr(fill),
            esc(text)
        );
        self.texts.push((b, text.to_string()));
        b
    }

    /// One line of text turned 90° counter-clockwise (reading upwards), centred on (x, y)
    /// along its length, its baseline on the vertical line through x + cap/2 (so the glyphs
    /// straddle x); returns its box.
    pub fn text_up(&mut self, x: f64, y: f64, size: f64, fill: &str, text: &str) -> Rect {
        let w = text_width(text, size);
        let bx = x + 0.5 * CAP * size;
        let _ = writeln!(
            self.body,
            r#"<text transform="translate({} {}) rotate(-90)" font-size="{}" text-anchor="middle"{}>{}</text>"#,
            num(bx),
            num(y),
            num(size),
            fill_attr(fill),
            esc(text)
        );
        let b = Rect {
            x: bx - ASCENT * size,
            y: y - w / 2.0,
            w: (ASCENT + DESCENT) * size,
            h: w,
        };
        self.texts.push((b, text.to_string()));
        b
    }

    /// The boxes of the texts written so far.
    #[cfg(test)]
    pub fn text_boxes(&self) -> &[(Rect, String)] {
        &self.texts
    }

    /// The SVG document.
    pub fn svg(&self) -> String {
        let (w, h) = (num(self.width), num(self.height));
        let mut out = String::new();
        let _ = writeln!(
            out,
            r#"<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{w}pt" height="{h}pt" viewBox="0 0 {w} {h}" font-family="{FONT_FAMILY}, sans-serif">"#
        );
        let _ = writeln!(out, r##"<rect width="{w}" height="{h}" fill="#FFFFFF"/>"##);
        out.push_str(&self.body);
        out.push_str("</svg>\n");
        out
    }

    /// The figure in `format`.
    pub fn encode(&self, format: Format) -> Result<Vec<u8>, String> {
        let svg = self.svg();
        match format {
            Format::Svg => Ok(svg.into_bytes()),
            Format::Png => png_from_svg(&svg),
            Format::Pdf => pdf_from_svg(&svg),
        }
    }
}

fn anchor_attr(a: Anchor) -> &'static str {
    match a {
        Anchor::Start => "",
        Anchor::Middle => r#" text-anchor="middle""#,
        Anchor::End => r#" text-anchor="end""#,
    }
}

fn fill_attr(fill: &str) -> String {
    if fill == colour::BLACK {
        String::new()
    } else {
        format!(r#" fill="{fill}""#)
    }
}

fn points(pts: &[(f64, f64)]) -> String {
    let mut s = String::new();
    for (i, (x, y)) in pts.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        let _ = write!(s, "{},{}", num(*x), num(*y));
    }
    s
}

/// usvg options that know only the bundled font.
pub fn usvg_options() -> resvg::usvg::Options<'static> {
    let mut db = resvg::usvg::fontdb::Database::new();
    db.load_font_data(FONT.to_vec());
    db.set_sans_serif_family(FONT_FAMILY);
    resvg::usvg::Options {
        font_family: FONT_FAMILY.to_string(),
        fontdb: Arc::new(db),
        ..Default::default()
    }
}

fn tree(svg: &str) -> Result<resvg::usvg::Tree, String> {
    resvg::usvg::Tree::from_str(svg, &usvg_options()).map_err(|e| format!("SVG: {e}"))
}

/// CSS px (1/96 in) per pt.
const PX_PER_PT: f64 = 96.0 / 72.0;

fn png_from_svg(svg: &str) -> Result<Vec<u8>, String> {
    let tree = tree(svg)?;
    let size = tree.size();
    let scale = PNG_DPI / 96.0;
    let w = (f64::from(size.width()) * scale).round() as u32;
    let h = (f64::from(size.height()) * scale).round() as u32;
    let mut pixmap = resvg::tiny_skia::Pixmap::new(w, h)
        .ok_or_else(|| format!("a {w}×{h} px image cannot be made"))?;
    pixmap.fill(resvg::tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        resvg::tiny_skia::Transform::from_scale(scale as f32, scale as f32),
        &mut pixmap.as_mut(),
    );
    // Opaque (white underneath): premultiplied RGBA is plain RGB.
    let rgb: Vec<u8> = pixmap
        .data()
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Best);
        let per_metre = (PNG_DPI / 0.0254).round() as u32;
        enc.set_pixel_dims(Some(png::PixelDimensions {
            xppu: per_metre,
            yppu: per_metre,
            unit: png::Unit::Meter,
        }));
        let mut writer = enc.write_header().map_err(|e| format!("PNG: {e}"))?;
        writer
            .write_image_data(&rgb)
            .map_err(|e| format!("PNG: {e}"))?;
    }
    Ok(out)
}

fn pdf_from_svg(svg: &str) -> Result<Vec<u8>, String> {
    let tree = tree(svg)?;
    // The SVG is sized in pt (usvg reads it as CSS px at 96 dpi): at 96 dpi the page is the
    // figure's size in pt.
    svg2pdf::to_pdf(
        &tree,
        svg2pdf::ConversionOptions::default(),
        svg2pdf::PageOptions {
            dpi: (72.0 * PX_PER_PT) as f32,
        },
    )
    .map_err(|e| format!("PDF: {e}"))
}

/// A legend: entries laid out in rows that fit `width`, each a swatch and its label.
pub struct Legend {
    entries: Vec<(Swatch, String)>,
}

/// Width of a legend swatch in pt.
const SWATCH: f64 = 12.0;
/// Gap between a swatch and its label, and between entries.
const SWATCH_GAP: f64 = 3.0;
const ENTRY_GAP: f64 = 8.0;

impl Legend {
    /// An empty legend.
    pub fn new() -> Legend {
        Legend {
            entries: Vec::new(),
        }
    }

    /// Adds an entry.
    pub fn add(&mut self, swatch: Swatch, label: impl Into<String>) {
        self.entries.push((swatch, label.into()));
    }

    /// The labels, in order.
    pub fn labels(&self) -> impl Iterator<Item = &str> {
        self.entries.iter().map(|(_, l)| l.as_str())
    }

    fn entry_width(&self, i: usize) -> f64 {
        SWATCH + SWATCH_GAP + text_width(&self.entries[i].1, SIZE_LABEL)
    }

    /// Rows of entry indices when flowed into `width`.
    fn rows(&self, width: f64) -> Vec<Vec<usize>> {
        let mut rows: Vec<Vec<usize>> = Vec::new();
        let mut x = 0.0;
        for i in 0..self.entries.len() {
            let w = self.entry_width(i);
            match rows.last_mut() {
                Some(row) if x + ENTRY_GAP + w <= width => {
                    row.push(i);
                    x += ENTRY_GAP + w;
                }
                _ => {
                    rows.push(vec![i]);
                    x = w;
                }
            }
        }
        rows
    }

    /// Height in pt when flowed into `width`.
    pub fn height(&self, width: f64) -> f64 {
        self.rows(width).len() as f64 * LEADING * SIZE_LABEL
    }

    /// Draws it flowed into `width` from (x, top).
    pub fn draw(&self, fig: &mut Figure, x: f64, top: f64, width: f64) {
        fig.begin("legend");
        let line = LEADING * SIZE_LABEL;
        for (r, row) in self.rows(width).iter().enumerate() {
            let mid = top + (r as f64 + 0.5) * line;
            let base = mid + 0.5 * CAP * SIZE_LABEL;
            let mut cx = x;
            for &i in row {
                let (swatch, label) = &self.entries[i];
                match *swatch {
                    Swatch::Line(s) => fig.line((cx, mid), (cx + SWATCH, mid), s),
                    Swatch::Dot(c) => fig.dot((cx + SWATCH / 2.0, mid), 1.6, c),
                    Swatch::Ring(c) => {
                        fig.ring((cx + SWATCH / 2.0, mid), 2.2, Stroke::solid(c, 0.8))
                    }
                }
                fig.text(
                    cx + SWATCH + SWATCH_GAP,
                    base,
                    SIZE_LABEL,
                    Anchor::Start,
                    colour::BLACK,
                    label,
                );
                cx += self.entry_width(i) + ENTRY_GAP;
            }
        }
        fig.end();
    }
}

/// Draws lines of text from `top` (its first line's top), left-aligned at x; returns the
/// height used.
pub fn paragraph(
    fig: &mut Figure,
    x: f64,
    top: f64,
    size: f64,
    fill: &str,
    lines: &[String],
) -> f64 {
    let line = LEADING * size;
    for (i, l) in lines.iter().enumerate() {
        let base =
            top + i as f64 * line + ASCENT * size + 0.5 * (LEADING - ASCENT - DESCENT) * size;
        fig.text(x, base, size, Anchor::Start, fill, l);
    }
    lines.len() as f64 * line
}

/// A plot area with linear axes: data (u, v) to canvas (x, y).
#[derive(Clone, Copy, Debug)]
pub struct Area {
    /// The area on the canvas.
    pub rect: Rect,
    /// Data range shown horizontally.
    pub u: (f64, f64),
    /// Data range shown vertically (upwards).
    pub v: (f64, f64),
}

impl Area {
    /// Canvas point of a data point.
    pub fn map(&self, u: f64, v: f64) -> (f64, f64) {
        (
            self.rect.x + (u - self.u.0) / (self.u.1 - self.u.0) * self.rect.w,
            self.rect.y + self.rect.h - (v - self.v.0) / (self.v.1 - self.v.0) * self.rect.h,
        )
    }

    /// Draws the frame, ticks outwards, tick labels and the axis titles (`None` leaves an axis
    /// unlabelled: its ticks are drawn, its numbers not). `grid` draws light grid lines.
    pub fn axes(
        &self,
        fig: &mut Figure,
        ut: &Ticks,
        vt: &Ticks,
        u_title: Option<&str>,
        v_title: Option<&str>,
        grid: bool,
    ) {
        let r = self.rect;
        let tick = 2.5;
        fig.begin("axes");
        let bottom = r.y + r.h;
        for (t, label) in ut.values.iter().zip(ut.labels()) {
            let (x, _) = self.map(*t, self.v.0);
            if grid {
                fig.line((x, r.y), (x, bottom), Stroke::solid(colour::LIGHT, 0.4));
            }
            fig.line(
                (x, bottom),
                (x, bottom + tick),
                Stroke::solid(colour::BLACK, 0.5),
            );
            if u_title.is_some() {
                fig.text(
                    x,
                    bottom + tick + 1.0 + ASCENT * SIZE_TICK,
                    SIZE_TICK,
                    Anchor::Middle,
                    colour::BLACK,
                    &label,
                );
            }
        }
        let mut widest: f64 = 0.0;
        for (t, label) in vt.values.iter().zip(vt.labels()) {
            let (_, y) = self.map(self.u.0, *t);
            if grid {
                fig.line((r.x, y), (r.x + r.w, y), Stroke::solid(colour::LIGHT, 0.4));
            }
            fig.line((r.x - tick, y), (r.x, y), Stroke::solid(colour::BLACK, 0.5));
            if v_title.is_some() {
                let b = fig.text(
                    r.x - tick - 1.5,
                    y + 0.5 * CAP * SIZE_TICK,
                    SIZE_TICK,
                    Anchor::End,
                    colour::BLACK,
                    &label,
                );
                widest = widest.max(b.w);
            }
        }
        fig.rect(r, Stroke::solid(colour::BLACK, 0.6));
        if let Some(t) = u_title {
            fig.text(
                r.x + r.w / 2.0,
                bottom + tick + 1.0 + (LEADING + ASCENT) * SIZE_TICK + 1.0,
                SIZE_LABEL,
                Anchor::Middle,
                colour::BLACK,
                t,
            );
        }
        if let Some(t) = v_title {
            let x = r.x - tick - 1.5 - widest - 2.0 - 0.5 * (ASCENT + DESCENT) * SIZE_LABEL;
            fig.text_up(x, r.y + r.h / 2.0, SIZE_LABEL, colour::BLACK, t);
        }
        fig.end();
    }

    /// Space below the area that labelled horizontal ticks and their title take.
    pub fn below() -> f64 {
        2.5 + 1.0 + (LEADING + ASCENT) * SIZE_TICK + 1.0 + DESCENT * SIZE_LABEL + 1.0
    }

    /// Space left of the area that labelled vertical ticks `labels` and the title take.
    pub fn left_of(labels: &[String]) -> f64 {
        let widest = labels
            .iter()
            .map(|l| text_width(l, SIZE_TICK))
            .fold(0.0, f64::max);
        2.5 + 1.5 + widest + 2.0 + (ASCENT + DESCENT) * SIZE_LABEL + 1.0
    }
}

impl Default for Legend {
    fn default() -> Self {
        Legend::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widths_come_from_the_font() {
        // DejaVu Sans: digits are 0.636 em, a space 0.318 em.
        assert!((text_width("0", 10.0) - 6.36).abs() < 0.01);
        assert!((text_width("00 00", 10.0) - (4.0 * 6.36 + 3.18)).abs() < 0.02);
        assert!(text_width("β = 31.72°", 8.0) > 0.0);
    }

    #[test]
    fn wrapping_keeps_every_line_within_the_width() {
        let text = "exact fit of m = 12 modules, n = 3, β = 35°, 31.72°, 35°, 31.72°, 35° to /a/very/long/path/that/does/not/fit/on/one/line/at/all/target-file-name.csv";
        let lines = wrap(text, 8.0, 120.0);
        assert!(lines.len() > 2, "{lines:?}");
        for l in &lines {
            assert!(text_width(l, 8.0) <= 120.0 + 1e-9, "{l}");
        }
        assert!(
            lines.iter().any(|l| l.contains('…') && l.ends_with(".csv")),
            "{lines:?}"
        );
        assert_eq!(wrap("", 8.0, 100.0), vec![String::new()]);
        assert_eq!(shorten("abc", 8.0, 100.0), "abc");
    }

    #[test]
    fn numbers_use_a_minus_sign_and_no_negative_zero() {
        assert_eq!(number(-0.0001, 1), "0.0");
        assert_eq!(number(-1.5, 1), "−1.5");
        assert_eq!(number(2.0, 0), "2");
    }

    #[test]
    fn ticks_are_round_and_cover_or_fit_the_range() {
        let t = Ticks::covering(0.0, 31.7, 6);
        assert_eq!(t.step, 10.0);
        assert_eq!(t.values, vec![0.0, 10.0, 20.0, 30.0, 40.0]);
        let t = Ticks::covering(-0.2, 30.0, 6);
        assert!(
            t.values[0] <= -0.2 && *t.values.last().unwrap() >= 30.0,
            "{t:?}"
        );
        assert_eq!(Ticks::step_at_least(0.3), 0.5);
        assert_eq!(Ticks::step_at_least(0.5), 0.5);
        assert_eq!(Ticks::step_at_least(7.0), 10.0);
        let t = Ticks::within(-1.63, 0.12, 0.5);
        assert_eq!(t.values, vec![-1.5, -1.0, -0.5, 0.0]);
        assert_eq!(t.labels(), vec!["−1.5", "−1.0", "−0.5", "0.0"]);
        assert_eq!(Ticks::within(0.0, 3.0, 0.2).decimals(), 1);
        assert_eq!(Ticks::within(0.0, 3.0, 2.0).decimals(), 0);
    }

    #[test]
    fn formats_by_extension_and_name() {
        assert_eq!(Format::from_path(Path::new("a/fit.PDF")), Some(Format::Pdf));
        assert_eq!(Format::from_path(Path::new("fit.png")), Some(Format::Png));
        assert_eq!(Format::from_path(Path::new("fit")), None);
        assert_eq!(Format::from_path(Path::new("fit.jpg")), None);
        assert!(Format::parse("eps").unwrap_err().contains("svg, png, pdf"));
    }

    #[test]
    fn every_format_encodes_and_is_the_same_twice() {
        let mut f = Figure::new(COLUMN_PT, 100.0);
        let area = Area {
            rect: Rect {
                x: 40.0,
                y: 10.0,
                w: 190.0,
                h: 60.0,
            },
            u: (0.0, 1.0),
            v: (0.0, 1.0),
        };
        let t = Ticks::within(0.0, 1.0, 0.5);
        area.axes(&mut f, &t, &t, Some("time (s)"), Some("p (kPa)"), true);
        f.polyline(
            &[area.map(0.0, 0.0), area.map(1.0, 1.0)],
            Stroke::solid(colour::BLUE, 1.0),
        );
        let png = f.encode(Format::Png).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(png, f.encode(Format::Png).unwrap());
        let pdf = f.encode(Format::Pdf).unwrap();
        assert!(pdf.starts_with(b"%PDF-"));
        assert_eq!(pdf, f.encode(Format::Pdf).unwrap());
    }
}
