//! The station's figure: the incidence angle on the tracked top face and on a flat top through
//! the day (local time), one journal column wide, the refolds marked, the night left blank.

use super::{hours_of, Day};
use crate::figure::{
    colour, paragraph, wrap, Anchor, Area, Figure, Legend, Rect, Stroke, Swatch, Ticks, COLUMN_PT,
    DESCENT, LEADING, SIZE_LABEL, SIZE_TICK, SIZE_TITLE,
};

/// What the figure says besides the data.
pub struct Header<'a> {
    /// First line.
    pub title: String,
    /// Legend entry of the tracked face.
    pub tracked_label: String,
    /// The local clock's offset (s), for the axis title.
    pub offset_s: i32,
    /// The day.
    pub day: &'a Day,
    /// Sample indices where a refold happens.
    pub refold_samples: Vec<usize>,
}

const MARGIN: f64 = 3.0;
const PLOT_H: f64 = 120.0;
const TRACKED: Stroke = Stroke::solid(colour::BLUE, 1.0);
const FLAT: Stroke = Stroke::dashed(colour::VERMILLION, 0.9, "3 1.5");
const REFOLD: Stroke = Stroke::dashed(colour::GREEN, 0.6, "1.5 1.5");

/// Runs of consecutive samples with the sun up, as polylines of (hour, value).
fn runs(day: &Day, pick: impl Fn(&(f64, f64)) -> f64) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut open = false;
    for (s, inc) in day.samples.iter().zip(&day.incidence) {
        match inc {
            Some(i) => {
                if !open {
                    out.push(Vec::new());
                    open = true;
                }
                if let Some(run) = out.last_mut() {
                    run.push((hours_of(&s.time), pick(i)));
                }
            }
            None => open = false,
        }
    }
    out
}

/// Draws the figure.
pub fn render(h: &Header<'_>) -> Figure {
    let day = h.day;
    let width = COLUMN_PT;
    let inner = width - 2.0 * MARGIN;
    let title = wrap(&h.title, SIZE_TITLE, inner);
    let f = |x: Option<f64>| x.map_or_else(|| "n/a".to_string(), |v| format!("{v:.3}"));
    let gain = day
        .gain()
        .map_or_else(|| "n/a".to_string(), |g| format!("{:+.1} %", g * 100.0));
    let sub = wrap(
        &format!(
            "beam fraction tracked {}, flat {}, gain {gain}; {} refolds",
            f(day.tracked_fraction),
            f(day.flat_fraction),
            day.schedule.changes
        ),
        SIZE_LABEL,
        inner,
    );
    let hours: Vec<f64> = day.samples.iter().map(|s| hours_of(&s.time)).collect();
    let (h0, h1) = match (hours.first(), hours.last()) {
        (Some(a), Some(b)) if b > a => (*a, *b),
        (Some(a), _) => (*a, *a + 1.0),
        _ => (0.0, 24.0),
    };
    let ht = {
        let step = if h1 - h0 > 8.0 { 2.0 } else { 1.0 };
        let t = Ticks::within(h0, h1, step);
        if t.values.len() >= 2 {
            t
        } else {
            Ticks::covering(h0, h1, 4)
        }
    };
    let (u0, u1) = (h0.min(ht.range().0), h1.max(ht.range().1));
    let max_inc = day
        .incidence
        .iter()
        .flatten()
        .map(|i| i.0.max(i.1))
        .fold(90.0f64, f64::max);
    let vt = Ticks::within(0.0, (max_inc / 30.0).ceil() * 30.0, 30.0);
    let left = Area::left_of(&vt.labels());
    let mut legend = Legend::new();
    legend.add(Swatch::Line(TRACKED), h.tracked_label.as_str());
    legend.add(Swatch::Line(FLAT), "flat top");
    if !h.refold_samples.is_empty() {
        legend.add(Swatch::Line(REFOLD), "refold");
    }
    let mut notes = Vec::new();
    if day.tracked_fraction.is_none() {
        notes.push("The sun is below the horizon at every sample.".to_string());
    } else if day.incidence.iter().any(Option::is_none) {
        notes.push("Gaps: the sun is below the horizon.".to_string());
    }
    if max_inc > 90.0 {
        notes.push("Above 90° the sun is behind the face (no beam).".to_string());
    }
    let note_lines: Vec<String> = notes
        .iter()
        .flat_map(|n| wrap(n, SIZE_LABEL, inner))
        .collect();
    let head_h = title.len() as f64 * LEADING * SIZE_TITLE
        + sub.len() as f64 * LEADING * SIZE_LABEL
        + 2.0
        + LEADING * SIZE_TICK;
    let area = Area {
        rect: Rect {
            x: MARGIN + left,
            y: MARGIN + head_h,
            w: inner - left - 6.0,
            h: PLOT_H,
        },
        u: (u0, u1),
        v: vt.range(),
    };
    let legend_top = area.rect.y + PLOT_H + Area::below() + 1.0;
    let height =
        legend_top + legend.height(inner) + note_lines.len() as f64 * LEADING * SIZE_LABEL + MARGIN;
    let mut fig = Figure::new(width, height);
    let y = paragraph(&mut fig, MARGIN, MARGIN, SIZE_TITLE, colour::BLACK, &title);
    paragraph(&mut fig, MARGIN, MARGIN + y, SIZE_LABEL, colour::GREY, &sub);
    let offset =
        chrono::FixedOffset::east_opt(h.offset_s).map_or_else(String::new, |o| format!(", UTC{o}"));
    area.axes(
        &mut fig,
        &ht,
        &vt,
        Some(&format!("local time (h{offset})")),
        Some("incidence (°)"),
        true,
    );
    let (top, bottom) = (area.rect.y, area.rect.y + area.rect.h);
    fig.begin("refolds");
    for &t in &h.refold_samples {
        if let Some(s) = day.samples.get(t) {
            let (x, _) = area.map(hours_of(&s.time), 0.0);
            fig.line((x, top), (x, bottom), REFOLD);
        }
    }
    fig.end();
    if !h.refold_samples.is_empty() {
        let base = top - 1.5 - DESCENT * SIZE_TICK;
        fig.text(
            area.rect.x + area.rect.w,
            base,
            SIZE_TICK,
            Anchor::End,
            colour::GREEN,
            &format!("{} refolds", h.refold_samples.len()),
        );
    }
    for (class, stroke, pick) in [("flat", FLAT, 1usize), ("tracked", TRACKED, 0usize)] {
        fig.begin(class);
        for run in runs(day, |i| if pick == 0 { i.0 } else { i.1 }) {
            let pts: Vec<(f64, f64)> = run.iter().map(|(u, v)| area.map(*u, *v)).collect();
            if pts.len() == 1 {
                fig.dot(pts[0], 0.8, stroke.colour);
            } else {
                fig.polyline(&pts, stroke);
            }
        }
        fig.end();
    }
    legend.draw(&mut fig, MARGIN, legend_top, inner);
    paragraph(
        &mut fig,
        MARGIN,
        legend_top + legend.height(inner),
        SIZE_LABEL,
        colour::BLACK,
        &note_lines,
    );
    fig
}
