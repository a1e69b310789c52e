//! `host-tool log plot`: the pressure and servo traces of a recording against device time,
//! one journal column wide, with the snap-throughs (the simulator's truth), the states the
//! device confirmed, the states a person or the host declared (drawn apart: a declaration is
//! not the device's evidence) and the faults raised marked through both panels.

use std::path::Path;

use super::{secs, Log};
use crate::figure::{
    colour, paragraph, wrap, Anchor, Area, Figure, Legend, Rect, Stroke, Swatch, Ticks, COLUMN_PT,
    DESCENT, LEADING, SIZE_LABEL, SIZE_TICK, SIZE_TITLE,
};

/// What a recording holds for the plot.
pub struct Traces {
    /// (device time s, measured pressure kPa, servo commands °).
    pub telemetry: Vec<(f64, f64, [f64; 3])>,
    /// (device time s, true pressure kPa, snap count) with the simulator.
    pub truth: Vec<(f64, f64, u64)>,
    /// Device times of the simulator's snap-throughs.
    pub snaps: Vec<f64>,
    /// (device time s, state) the device confirmed.
    pub reached: Vec<(f64, String)>,
    /// (device time s, state) declared (`DeclareState`: the operator, or the host on the
    /// operator's word): the device holds it as confirmed, the plot does not.
    pub declared: Vec<(f64, String)>,
    /// (device time s, `E-04`) faults raised.
    pub faults: Vec<(f64, String)>,
}

/// How long after a `DeclareState` request the device's `StateReached` for that state counts
/// as the declaration's (the request's round trip and the device's next loop pass).
const DECLARE_WINDOW_S: f64 = 2.0;

/// Reads the traces from a recording.
pub fn traces(log: &Log) -> Traces {
    let telemetry: Vec<(f64, f64, [f64; 3])> = log
        .topic("/telemetry")
        .filter_map(|m| {
            let p = m.data["pressure_kpa"].as_f64()?;
            let s = &m.data["servo_deg"];
            Some((
                secs(m.log_ns),
                p,
                [s[0].as_f64()?, s[1].as_f64()?, s[2].as_f64()?],
            ))
        })
        .collect();
    let truth: Vec<(f64, f64, u64)> = log
        .topic("/sim/truth")
        .filter_map(|m| {
            Some((
                secs(m.log_ns),
                m.data["pressure_kpa"].as_f64()?,
                m.data["snaps"].as_u64()?,
            ))
        })
        .collect();
    let snaps = truth
        .windows(2)
        .filter(|w| w[1].2 > w[0].2)
        .map(|w| w[1].0)
        .collect();
    let declares: Vec<(f64, &serde_json::Value)> = log
        .topic("/link/requests")
        .filter(|m| m.data["name"] == "DeclareState")
        .map(|m| (secs(m.log_ns), &m.data["body"]["DeclareState"]))
        .collect();
    let (mut reached, mut declared) = (Vec::new(), Vec::new());
    for m in log
        .topic("/events")
        .filter(|m| m.data["kind"] == "state-reached")
        .filter(|m| m.data["event"]["StateReached"]["confirmed"] == true)
    {
        let ts = secs(m.log_ns);
        let name = m.data["text"]
            .as_str()
            .unwrap_or("")
            .trim_start_matches("state ")
            .to_string();
        let state = &m.data["event"]["StateReached"]["state"];
        let by_declaration = declares
            .iter()
            .any(|(td, s)| *s == state && *td <= ts && ts - td <= DECLARE_WINDOW_S);
        if by_declaration {
            declared.push((ts, name));
        } else {
            reached.push((ts, name));
        }
    }
    let faults = log
        .topic("/faults")
        .filter(|m| m.data["raised"] == true)
        .filter_map(|m| Some((secs(m.log_ns), m.data["code"].as_str()?.to_string())))
        .collect();
    Traces {
        telemetry,
        truth,
        snaps,
        reached,
        declared,
        faults,
    }
}

/// Points of a trace thinned to what a resolution of `res` pt shows: per column its first,
/// lowest, highest and last point, in time order (peaks survive).
fn thin(pts: &[(f64, f64)], res: f64) -> Vec<(f64, f64)> {
    if pts.len() < 4 {
        return pts.to_vec();
    }
    let mut out: Vec<(f64, f64)> = Vec::new();
    let mut i = 0;
    while i < pts.len() {
        let col = (pts[i].0 / res).floor();
        let mut j = i;
        let (mut lo, mut hi) = (i, i);
        while j < pts.len() && (pts[j].0 / res).floor() == col {
            if pts[j].1 < pts[lo].1 {
                lo = j;
            }
            if pts[j].1 > pts[hi].1 {
                hi = j;
            }
            j += 1;
        }
        let mut keep = vec![i, lo, hi, j - 1];
        keep.sort_unstable();
        keep.dedup();
        out.extend(keep.into_iter().map(|k| pts[k]));
        i = j;
    }
    out
}

const MARGIN: f64 = 3.0;
const PRESSURE_H: f64 = 92.0;
const SERVO_H: f64 = 58.0;
/// Between the panels: room for a tick label straddling each frame's edge.
const PANEL_GAP: f64 = 10.0;

const SERVO: [(&str, Stroke); 3] = [
    ("servo 1", Stroke::solid(colour::ORANGE, 0.9)),
    ("servo 2", Stroke::dashed(colour::PURPLE, 0.9, "3 1.5")),
    ("servo 3", Stroke::dashed(colour::SKY, 0.9, "0.8 1.2")),
];
const MEASURED: Stroke = Stroke::solid(colour::BLUE, 0.9);
const TRUE_P: Stroke = Stroke::dashed(colour::BLACK, 0.6, "2 1.5");
const SNAP: Stroke = Stroke::solid(colour::VERMILLION, 0.6);
const REACHED: Stroke = Stroke::dashed(colour::GREEN, 0.7, "3 2");
const DECLARED: Stroke = Stroke::dashed(colour::GREY, 0.7, "1 1.5");
const FAULT: Stroke = Stroke::solid(colour::PURPLE, 1.0);

/// Draws the figure of `t`; `title` names the recording. `None` when there is too little
/// telemetry to plot.
pub fn render(t: &Traces, title: &str) -> Option<Figure> {
    let tel = &t.telemetry;
    if tel.len() < 2 {
        return None;
    }
    let width = COLUMN_PT;
    let inner = width - 2.0 * MARGIN;
    let title_lines = wrap(title, SIZE_TITLE, inner);
    let (t0, t1) = (tel[0].0, tel[tel.len() - 1].0.max(tel[0].0 + 1e-3));
    let sub = wrap(
        &format!(
            "{} telemetry samples over {:.2}\u{a0}s of device time",
            tel.len(),
            t1 - t0
        ),
        SIZE_LABEL,
        inner,
    );

    let pressures = tel.iter().map(|s| s.1).chain(t.truth.iter().map(|s| s.1));
    let (pmin, pmax) = pressures.fold((0.0f64, 1.0f64), |(a, b), p| (a.min(p), b.max(p)));
    let pt = Ticks::covering(pmin, pmax, 4);
    let servos = tel.iter().flat_map(|s| s.2);
    let (smin, smax) = servos.fold((0.0f64, 10.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let st = Ticks::covering(smin, smax, 3);
    let left = Area::left_of(&[pt.labels(), st.labels()].concat());

    // Time ticks inside the recorded span, at least 22 pt apart.
    let plot_w = inner - left - 2.0;
    let step = Ticks::step_at_least(22.0 / plot_w * (t1 - t0));
    // An end within 3 % of the span from a tick snaps to it (a run from 0.001 s starts at 0).
    let near = 0.03 * (t1 - t0);
    let (t0, t1) = (
        if t0 - (t0 / step).floor() * step <= near {
            (t0 / step).floor() * step
        } else {
            t0
        },
        if (t1 / step).ceil() * step - t1 <= near {
            (t1 / step).ceil() * step
        } else {
            t1
        },
    );
    let tt = Ticks::within(t0, t1, step);

    let mut legend = Legend::new();
    legend.add(Swatch::Line(MEASURED), "pressure, measured");
    if !t.truth.is_empty() {
        legend.add(Swatch::Line(TRUE_P), "pressure, true (simulator)");
    }
    let constant: Option<f64> = {
        let first = tel[0].2[0];
        tel.iter()
            .all(|s| s.2.iter().all(|v| *v == first))
            .then_some(first)
    };
    for (name, stroke) in SERVO {
        legend.add(Swatch::Line(stroke), name);
    }
    if !t.snaps.is_empty() {
        legend.add(Swatch::Line(SNAP), "snap-through (simulator)");
    }
    if !t.reached.is_empty() {
        legend.add(Swatch::Line(REACHED), "state confirmed by the device");
    }
    if !t.declared.is_empty() {
        legend.add(
            Swatch::Line(DECLARED),
            "state declared (a person's or the host's word)",
        );
    }
    if !t.faults.is_empty() {
        legend.add(Swatch::Line(FAULT), "fault raised (its code below)");
    }
    let mut notes = Vec::new();
    if let Some(v) = constant {
        notes.push(format!(
            "All three servo commands stay at {}° throughout.",
            crate::figure::number(v, 1)
        ));
    } else if tel.iter().all(|s| s.2[0] == s.2[1] && s.2[1] == s.2[2]) {
        notes.push("The three servo commands are equal throughout (one trace).".to_string());
    }
    let note_lines: Vec<String> = notes
        .iter()
        .flat_map(|n| wrap(n, SIZE_LABEL, inner))
        .collect();

    let head_h = title_lines.len() as f64 * LEADING * SIZE_TITLE
        + sub.len() as f64 * LEADING * SIZE_LABEL
        + 2.0;
    // Room above the pressure panel for the state labels.
    let label_h = if t.reached.is_empty() && t.declared.is_empty() {
        2.0
    } else {
        LEADING * SIZE_TICK
    };
    let x0 = MARGIN + left;
    let p_area = Area {
        rect: Rect {
            x: x0,
            y: MARGIN + head_h + label_h,
            w: plot_w,
            h: PRESSURE_H,
        },
        u: (t0, t1),
        v: pt.range(),
    };
    let s_area = Area {
        rect: Rect {
            x: x0,
            y: p_area.rect.y + PRESSURE_H + PANEL_GAP,
            w: plot_w,
            h: SERVO_H,
        },
        u: (t0, t1),
        v: st.range(),
    };
    let legend_top = s_area.rect.y + SERVO_H + Area::below() + 1.0;
    let height =
        legend_top + legend.height(inner) + note_lines.len() as f64 * LEADING * SIZE_LABEL + MARGIN;
    let mut fig = Figure::new(width, height);

    let y = paragraph(
        &mut fig,
        MARGIN,
        MARGIN,
        SIZE_TITLE,
        colour::BLACK,
        &title_lines,
    );
    paragraph(&mut fig, MARGIN, MARGIN + y, SIZE_LABEL, colour::GREY, &sub);

    p_area.axes(&mut fig, &tt, &pt, None, Some("pressure (kPa)"), true);
    s_area.axes(
        &mut fig,
        &tt,
        &st,
        Some("device time (s)"),
        Some("servo (°)"),
        true,
    );
    // Events through both panels, under the traces.
    for area in [&p_area, &s_area] {
        let (top, bottom) = (area.rect.y, area.rect.y + area.rect.h);
        fig.begin("snap-throughs");
        for &ts in &t.snaps {
            let (x, _) = area.map(ts, 0.0);
            fig.line((x, top), (x, bottom), SNAP);
        }
        fig.end();
        for (class, marks, stroke) in [
            ("states-confirmed", &t.reached, REACHED),
            ("states-declared", &t.declared, DECLARED),
            ("faults", &t.faults, FAULT),
        ] {
            fig.begin(class);
            for (ts, _) in marks {
                let (x, _) = area.map(*ts, 0.0);
                fig.line((x, top), (x, bottom), stroke);
            }
            fig.end();
        }
    }
    // Fault codes inside the pressure panel's foot, right of their line, clear of each other.
    fig.begin("fault-labels");
    let mut last_right = f64::NEG_INFINITY;
    let foot = p_area.rect.y + p_area.rect.h - 1.5 - DESCENT * SIZE_TICK;
    for (ts, code) in &t.faults {
        let (x, _) = p_area.map(*ts, 0.0);
        let w = crate::figure::text_width(code, SIZE_TICK);
        let lx = (x + 1.0).min(p_area.rect.x + p_area.rect.w - w - 1.0);
        if lx < last_right + 2.0 {
            continue;
        }
        fig.text(lx, foot, SIZE_TICK, Anchor::Start, colour::PURPLE, code);
        last_right = lx + w;
    }
    fig.end();
    // State labels above the pressure panel, centred on their line, kept inside the canvas
    // and clear of each other.
    fig.begin("state-labels");
    let mut last_right = f64::NEG_INFINITY;
    let base = p_area.rect.y - 1.5 - DESCENT * SIZE_TICK;
    let mut labels: Vec<(f64, String, &str)> = t
        .reached
        .iter()
        .map(|(ts, n)| (*ts, n.clone(), colour::GREEN))
        .chain(
            t.declared
                .iter()
                .map(|(ts, n)| (*ts, format!("{n} (declared)"), colour::GREY)),
        )
        .collect();
    labels.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (ts, name, ink) in &labels {
        let (x, _) = p_area.map(*ts, 0.0);
        let w = crate::figure::text_width(name, SIZE_TICK);
        let cx = x.clamp(MARGIN + w / 2.0, width - MARGIN - w / 2.0);
        if cx - w / 2.0 < last_right + 2.0 {
            continue;
        }
        fig.text(cx, base, SIZE_TICK, Anchor::Middle, ink, name);
        last_right = cx + w / 2.0;
    }
    fig.end();

    let res = 0.25 * (t1 - t0) / plot_w;
    let mut trace = |class: &str, area: &Area, pts: Vec<(f64, f64)>, stroke: Stroke| {
        let mapped: Vec<(f64, f64)> = thin(&pts, res)
            .into_iter()
            .map(|(a, b)| area.map(a, b))
            .collect();
        fig.begin(class);
        fig.polyline(&mapped, stroke);
        fig.end();
    };
    if !t.truth.is_empty() {
        let pts = t
            .truth
            .iter()
            .filter(|s| s.0 >= t0 && s.0 <= t1)
            .map(|s| (s.0, s.1))
            .collect();
        trace("pressure-true", &p_area, pts, TRUE_P);
    }
    let pts = tel.iter().map(|s| (s.0, s.1)).collect();
    trace("pressure-measured", &p_area, pts, MEASURED);
    for (k, (name, stroke)) in SERVO.iter().enumerate() {
        let pts = tel.iter().map(|s| (s.0, s.2[k])).collect();
        trace(&name.replace(' ', "-"), &s_area, pts, *stroke);
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
    Some(fig)
}

/// The figure's title: the file name, and the device the session recorded.
pub fn title(path: &Path, log: &Log) -> String {
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    match log.metadata.iter().find_map(|(_, m)| m.get("device")) {
        Some(d) => format!("{name} — {}", d.trim_end_matches(" faults []")),
        None => name,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_the_peaks_in_time_order() {
        let pts: Vec<(f64, f64)> = (0..1000)
            .map(|i| {
                (
                    i as f64 * 0.001,
                    if i == 537 { 9.0 } else { (i % 7) as f64 },
                )
            })
            .collect();
        let t = thin(&pts, 0.1);
        assert!(t.len() <= 4 * 10 + 4, "{}", t.len());
        assert!(t.contains(&(0.537, 9.0)));
        assert!(t.windows(2).all(|w| w[0].0 <= w[1].0));
        assert_eq!(t.first(), pts.first());
        assert_eq!(t.last(), pts.last());
    }
}
