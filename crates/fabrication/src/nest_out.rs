//! Writers of the cut sheets ([`crate::nest`]): one DXF and one SVG per sheet, and the JSON
//! description of the layout.
//!
//! Layers (DXF) and groups (SVG): `CUT` the parts' cut paths (closed polylines, already offset
//! for the kerf: cut on the line), `HOLES` the insert holes (circles, offset inward for the
//! kerf), `LABEL` the ids (engrave or mark; never cut), `SHEET` the sheet's outline (for
//! reference; do not cut). DXF: `$INSUNITS` = 4 (mm), R2010, y up, the sheet's lower-left corner
//! at the origin. SVG: 1:1 in millimetres.

use std::fmt::Write as _;

use dxf::entities::{Circle, Entity, EntityType, LwPolyline, Text};
use dxf::enums::{AcadVersion, HorizontalTextJustification, Units, VerticalTextJustification};
use dxf::tables::Layer;
use dxf::{Color, Drawing, LwPolylineVertex, Point};
use serde_json::{json, Value};

use crate::nest::{local_corners, KitFacet, Nest, Part};

/// A text to place: position on the sheet (mm), height (mm), rotation (degrees, counter-
/// clockwise, y up) and the text.
#[derive(Debug, Clone, PartialEq)]
pub struct Label {
    /// Centre of the text.
    pub at_mm: [f64; 2],
    /// Cap height.
    pub height_mm: f64,
    /// Rotation of its baseline, degrees counter-clockwise.
    pub rotation_deg: f64,
    /// The text.
    pub text: String,
    /// Whether it is the part's own id (else a neighbour's, along an edge).
    pub own: bool,
}

/// The labels of a part: its id at the incentre, upright in the facet's frame; each neighbour's
/// id inside the edge it shares, reading along that edge.
pub fn labels(f: &KitFacet, part: &Part) -> Vec<Label> {
    let c = local_corners(f);
    let a = (c[2][0] - c[0][0]).hypot(c[2][1] - c[0][1]);
    let r = f.base_mm * f.height_mm / (f.base_mm + 2.0 * a);
    let own_h = (0.3 * r).clamp(1.0, 30.0);
    let nb_h = 0.6 * own_h;
    let turn = part.placement.rotation_deg();
    let mut out = vec![Label {
        at_mm: part.placement.apply([0.0, r]),
        height_mm: own_h,
        rotation_deg: turn,
        text: f.id.clone(),
        own: true,
    }];
    for (e, nb) in f.neighbours.iter().enumerate() {
        let Some(nb) = nb else { continue };
        let (s, t) = (c[e], c[(e + 1) % 3]);
        let d = [t[0] - s[0], t[1] - s[1]];
        let len = d[0].hypot(d[1]);
        let u = [d[0] / len, d[1] / len];
        let inward = [-u[1], u[0]];
        let off = 0.8 * nb_h + 0.5 * nb_h;
        let mid = [
            0.5 * (s[0] + t[0]) + inward[0] * off,
            0.5 * (s[1] + t[1]) + inward[1] * off,
        ];
        out.push(Label {
            at_mm: part.placement.apply(mid),
            height_mm: nb_h,
            rotation_deg: (turn + u[1].atan2(u[0]).to_degrees()).rem_euclid(360.0),
            text: nb.clone(),
            own: false,
        });
    }
    out
}

/// ACI colours of the layers.
const LAYERS: [(&str, u8); 4] = [("CUT", 1), ("HOLES", 3), ("LABEL", 5), ("SHEET", 8)];

/// The DXF drawing of sheet `index`.
pub fn dxf_sheet(nest: &Nest, index: usize) -> Drawing {
    let mut d = Drawing::new();
    d.header.version = AcadVersion::R2010;
    d.header.default_drawing_units = Units::Millimeters;
    for (name, aci) in LAYERS {
        d.add_layer(Layer {
            name: name.to_string(),
            color: Color::from_index(aci),
            ..Default::default()
        });
    }
    let poly = |pts: &[[f64; 2]], layer: &str| {
        let mut p = LwPolyline {
            vertices: pts
                .iter()
                .map(|q| LwPolylineVertex {
                    x: q[0],
                    y: q[1],
                    ..Default::default()
                })
                .collect(),
            ..Default::default()
        };
        p.set_is_closed(true);
        let mut e = Entity::new(EntityType::LwPolyline(p));
        e.common.layer = layer.to_string();
        e
    };
    let [w, h] = nest.params.sheet_mm;
    d.add_entity(poly(&[[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]], "SHEET"));
    let half_kerf = 0.5 * nest.params.kerf_mm;
    for part in &nest.sheets[index] {
        d.add_entity(poly(&part.cut_mm, "CUT"));
        for hole in &part.holes {
            let mut e = Entity::new(EntityType::Circle(Circle::new(
                Point::new(hole.at_mm[0], hole.at_mm[1], 0.0),
                0.5 * hole.diameter_mm - half_kerf,
            )));
            e.common.layer = "HOLES".to_string();
            d.add_entity(e);
        }
        for label in labels(&nest.facets[part.facet], part) {
            let at = Point::new(label.at_mm[0], label.at_mm[1], 0.0);
            let mut t = Text {
                location: at.clone(),
                second_alignment_point: at,
                text_height: label.height_mm,
                value: label.text,
                rotation: label.rotation_deg,
                horizontal_text_justification: HorizontalTextJustification::Center,
                vertical_text_justification: VerticalTextJustification::Middle,
                ..Default::default()
            };
            t.relative_x_scale_factor = 1.0;
            let mut e = Entity::new(EntityType::Text(t));
            e.common.layer = "LABEL".to_string();
            d.add_entity(e);
        }
    }
    d
}

/// Writes the DXF of sheet `index`.
pub fn write_dxf<W: std::io::Write + ?Sized>(
    nest: &Nest,
    index: usize,
    out: &mut W,
) -> std::io::Result<()> {
    dxf_sheet(nest, index)
        .save(out)
        .map_err(|e| std::io::Error::other(format!("DXF: {e}")))
}

/// The SVG of sheet `index`, 1:1 in mm (y down in the file; the same drawing as the DXF).
pub fn svg_sheet(nest: &Nest, index: usize, title: &str) -> String {
    let [w, h] = nest.params.sheet_mm;
    let y = |p: [f64; 2]| (p[0], h - p[1]);
    let stroke = (w.max(h) / 1500.0).clamp(0.1, 2.0);
    let mut s = String::new();
    let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}mm" height="{h}mm" viewBox="0 0 {w} {h}">"#
    );
    let _ = writeln!(
        s,
        "<title>{}</title>",
        title.replace('&', "&amp;").replace('<', "&lt;")
    );
    let _ = writeln!(
        s,
        r##"<g id="sheet" fill="none" stroke="#808080" stroke-width="{stroke}"><rect x="0" y="0" width="{w}" height="{h}"/></g>"##
    );
    let _ = writeln!(
        s,
        r##"<g id="cut" fill="none" stroke="#ff0000" stroke-width="{stroke}">"##
    );
    for part in &nest.sheets[index] {
        let pts: Vec<String> = part
            .cut_mm
            .iter()
            .map(|&p| {
                let (x, yy) = y(p);
                format!("{x:.4},{yy:.4}")
            })
            .collect();
        let _ = writeln!(s, r#"<polygon points="{}"/>"#, pts.join(" "));
    }
    s += "</g>\n";
    let _ = writeln!(
        s,
        r##"<g id="holes" fill="none" stroke="#00a000" stroke-width="{stroke}">"##
    );
    let half_kerf = 0.5 * nest.params.kerf_mm;
    for part in &nest.sheets[index] {
        for hole in &part.holes {
            let (x, yy) = y(hole.at_mm);
            let _ = writeln!(
                s,
                r#"<circle cx="{x:.4}" cy="{yy:.4}" r="{:.4}"/>"#,
                0.5 * hole.diameter_mm - half_kerf
            );
        }
    }
    s += "</g>\n";
    let _ = writeln!(
        s,
        r##"<g id="label" font-family="sans-serif" fill="#0000ff" text-anchor="middle" dominant-baseline="central">"##
    );
    for part in &nest.sheets[index] {
        for label in labels(&nest.facets[part.facet], part) {
            let (x, yy) = y(label.at_mm);
            let _ = writeln!(
                s,
                r#"<text x="{x:.4}" y="{yy:.4}" font-size="{:.3}" transform="rotate({:.4} {x:.4} {yy:.4})"{}>{}</text>"#,
                label.height_mm,
                -label.rotation_deg,
                if label.own {
                    r#" font-weight="bold""#
                } else {
                    ""
                },
                label.text
            );
        }
    }
    s += "</g>\n</svg>\n";
    s
}

/// The layout as JSON (numbers as computed; the caller tidies them). `files` names each sheet's
/// DXF and SVG.
pub fn to_json(nest: &Nest, files: &[(String, String)]) -> Value {
    let p = &nest.params;
    json!({
        "sheet_mm": p.sheet_mm,
        "kerf_mm": p.kerf_mm,
        "margin_mm": p.margin_mm,
        "spacing_mm": p.spacing_mm,
        "insert_hole_mm": p.hole_mm,
        "rows_along": if nest.turned { "height" } else { "width" },
        "facets": nest.part_count(),
        "holes": nest.hole_count(),
        "sheets_used": nest.sheets.len(),
        "area_bound_sheets": nest.area_bound,
        "facet_area_mm2": nest.facet_area_mm2,
        "cut_area_mm2": nest.cut_area_mm2,
        "utilisation": nest.utilisation(),
        "sheets": nest.sheets.iter().enumerate().map(|(i, parts)| json!({
            "index": i + 1,
            "dxf": files.get(i).map(|f| f.0.clone()),
            "svg": files.get(i).map(|f| f.1.clone()),
            "parts": parts.iter().map(|part| {
                let f = &nest.facets[part.facet];
                json!({
                    "id": f.id,
                    "module": f.module + 1,
                    "layer": f.layer + 1,
                    "neighbours": { "base": f.neighbours[0], "right_leg": f.neighbours[1], "left_leg": f.neighbours[2] },
                    "pattern_corners_mm": f.corners_mm,
                    "rotation_deg": part.placement.rotation_deg(),
                    "offset_mm": part.placement.offset_mm,
                    "outline_mm": part.outline_mm,
                    "cut_mm": part.cut_mm,
                    "holes": part.holes.len(),
                })
            }).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    })
}
