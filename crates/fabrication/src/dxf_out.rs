//! DXF crease pattern (the `dxf` crate): one layer per line kind (MOUNTAIN, VALLEY, CUT,
//! BOUNDARY, VIRTUAL), `$INSUNITS` = millimetres, coordinates 1:1 in mm, y up.

use dxf::entities::{Entity, EntityType, Line};
use dxf::enums::{AcadVersion, Units};
use dxf::tables::Layer;
use dxf::{Color, Drawing, Point};

use crate::pattern::{LineKind, Pattern};

/// AutoCAD colour index of each layer (the SVG colours: red, blue, white/black, green, magenta).
pub fn aci(kind: LineKind) -> u8 {
    match kind {
        LineKind::Mountain => 1,
        LineKind::Valley => 5,
        LineKind::Boundary => 7,
        LineKind::Cut => 3,
        LineKind::Virtual => 6,
    }
}

/// Builds the drawing.
pub fn drawing(pattern: &Pattern) -> Drawing {
    let l = pattern.trunk().edge_mm();
    let mut d = Drawing::new();
    d.header.version = AcadVersion::R2010;
    d.header.default_drawing_units = Units::Millimeters;
    for kind in LineKind::ALL {
        d.add_layer(Layer {
            name: kind.layer_name().to_string(),
            color: Color::from_index(aci(kind)),
            ..Default::default()
        });
    }
    for (a, b, kind) in pattern.lines() {
        let mut e = Entity::new(EntityType::Line(Line::new(
            Point::new(a[0] * l, a[1] * l, 0.0),
            Point::new(b[0] * l, b[1] * l, 0.0),
        )));
        e.common.layer = kind.layer_name().to_string();
        d.add_entity(e);
    }
    d
}

/// Writes the DXF to `out`.
pub fn write<W: std::io::Write + ?Sized>(pattern: &Pattern, out: &mut W) -> std::io::Result<()> {
    drawing(pattern)
        .save(out)
        .map_err(|e| std::io::Error::other(format!("DXF: {e}")))
}
