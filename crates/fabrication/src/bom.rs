//! Bills of materials (part, quantity, unit, specification; no prices or vendors), as CSV.
//!
//! Two builds: the **crane** (the printed dual-material trunk panel of §5.3 and the
//! electronics of `docs/hardware.md`) and the meter-scale **kit** of §7.1 (HDPE facets, PLA-CF
//! hinges, M4 screws and heat-set inserts). Filament masses are the panel's solid volumes times
//! a nominal density ([`TPU_G_PER_CM3`], [`NYLON_G_PER_CM3`]; your filament's datasheet
//! decides); a slicer's purge and supports come on top.

use crate::kit::Kit;
use crate::nest::Nest;
use crate::panel::Panel;

/// Nominal density of TPU 95A, g/cm³.
pub const TPU_G_PER_CM3: f64 = 1.21;
/// Nominal density of nylon (PA6/PA66 filament), g/cm³.
pub const NYLON_G_PER_CM3: f64 = 1.14;

/// One line of a bill of materials.
#[derive(Debug, Clone, PartialEq)]
pub struct BomRow {
    /// Group: `trunk`, `kit`, `electronics`, `power`, `pneumatics`.
    pub section: &'static str,
    /// What it is.
    pub part: String,
    /// How many (or how much).
    pub quantity: f64,
    /// Unit of the quantity (`pcs`, `g`, `m²`).
    pub unit: &'static str,
    /// What to buy or make.
    pub specification: String,
}

/// A bill of materials.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Bom {
    /// Its lines, in order.
    pub rows: Vec<BomRow>,
}

fn row(section: &'static str, part: &str, quantity: f64, unit: &'static str, spec: &str) -> BomRow {
    BomRow {
        section,
        part: part.to_string(),
        quantity,
        unit,
        specification: spec.to_string(),
    }
}

impl Bom {
    /// The crane: the printed panel's materials and the electronics of `docs/hardware.md`.
    pub fn crane(panel: &Panel) -> Self {
        let base_cm3 = panel.base.volume() / 1000.0;
        let facets_cm3 = panel.facets.volume() / 1000.0;
        let (w, h) = panel.sheet_mm;
        let mut rows = vec![
            row(
                "trunk",
                "TPU 95A filament (base sheet)",
                (base_cm3 * TPU_G_PER_CM3 * 10.0).round() / 10.0,
                "g",
                &format!(
                    "{:.2} cm³ at {TPU_G_PER_CM3} g/cm³; base sheet {w:.1} × {h:.1} × {} mm",
                    base_cm3, panel.params.base_mm
                ),
            ),
            row(
                "trunk",
                "nylon filament (facets)",
                (facets_cm3 * NYLON_G_PER_CM3 * 10.0).round() / 10.0,
                "g",
                &format!(
                    "{:.2} cm³ at {NYLON_G_PER_CM3} g/cm³; {} facets {} mm thick",
                    facets_cm3, panel.facet_count, panel.params.facet_mm
                ),
            ),
        ];
        let e = |part: &str, q: f64, spec: &str| row("electronics", part, q, "pcs", spec);
        rows.extend([
            e("Arduino UNO R4", 1.0, "WiFi or Minima (RA4M1); the firmware runs on both"),
            e("tendon servo", 3.0, "MG996R-class, 5-6 V, 50 Hz PWM 0.5-2.5 ms; on D8, D9, A4"),
            e("gripper", 1.0, "normally closed (spring or worm drive), on/off driver input on A5"),
            e("pressure sensor", 1.0, "0-5 V ratiometric output, on A0"),
            e("joystick", 1.0, "two-axis, 10 kΩ potentiometers, on A1/A2"),
            e("push button", 5.0, "momentary, to GND (step up, step down, gripper, confirm, show pressure)"),
            e("e-stop", 1.0, "two-pole mushroom switch, normally closed: one pole in the valve supply, one to the input"),
            e("4-digit display", 1.0, "TM1637 seven-segment module, on D0/D1"),
            e("logic-level N-MOSFET", 2.0, "IRLZ44N-class, one per valve (and the gripper if it is a solenoid)"),
            e("flyback diode", 2.0, "1N4007-class, across each valve coil"),
            e("resistor 10 kΩ", 5.0, "gate pull-downs (2) and servo signal pull-downs (3)"),
            e("electrolytic capacitor", 1.0, "1000 µF, ≥ 10 V, across the servo rail"),
        ]);
        rows.extend([
            row(
                "pneumatics",
                "solenoid valve",
                2.0,
                "pcs",
                "12 V normally closed: inlet and exhaust",
            ),
            row(
                "pneumatics",
                "air supply",
                1.0,
                "pcs",
                "compressor or reservoir with a regulator, tube to the trunk's lower cap",
            ),
            row(
                "power",
                "servo supply",
                1.0,
                "pcs",
                "5-6 V, ≥ 3 A (never the UNO's 5 V pin)",
            ),
            row(
                "power",
                "valve supply",
                1.0,
                "pcs",
                "12 V (the coils' voltage)",
            ),
        ]);
        Bom { rows }
    }

    /// The meter-scale kit: facets (and the sheets of `nest` when given), hinges, screws, inserts.
    pub fn kit(kit: &Kit, nest: Option<&Nest>) -> Self {
        let mut rows = Vec::new();
        match nest {
            Some(n) => {
                let [w, h] = n.params.sheet_mm;
                rows.push(row(
                    "kit",
                    "HDPE sheet",
                    n.sheets.len() as f64,
                    "pcs",
                    &format!("{w} × {h} mm, laser-cut to the cut sheets (thickness: your choice; the paper gives none)"),
                ));
            }
            None => {
                let area: f64 = kit.facets.iter().map(|f| f.area_mm2 * f.count as f64).sum();
                rows.push(row(
                    "kit",
                    "HDPE sheet (facet area, before nesting)",
                    (area / 1e6 * 1000.0).round() / 1000.0,
                    "m²",
                    "give --nest WIDTHxHEIGHT for a sheet count",
                ));
            }
        }
        for f in &kit.facets {
            rows.push(row(
                "kit",
                &format!("facet, module {}", f.module + 1),
                f.count as f64,
                "pcs",
                &format!(
                    "isosceles triangle, base {:.1} mm, legs {:.1} mm, base angles {}°",
                    f.base_mm, f.leg_mm, f.beta_deg
                ),
            ));
        }
        rows.push(row(
            "kit",
            "hinge",
            kit.hinges.len() as f64,
            "pcs",
            "printed PLA-CF, two leaves, two M4 screws in each",
        ));
        rows.push(row(
            "kit",
            "M4 screw",
            kit.screws() as f64,
            "pcs",
            "M4, through a hinge leaf into an insert",
        ));
        rows.push(row(
            "kit",
            "M4 heat-set insert",
            kit.screws() as f64,
            "pcs",
            "M4, set into the HDPE facets",
        ));
        Bom { rows }
    }

    /// The CSV text: a header, then one line per row (RFC 4180 quoting).
    pub fn to_csv(&self) -> String {
        let quote = |s: &str| {
            if s.contains([',', '"', '\n']) {
                format!("\"{}\"", s.replace('"', "\"\""))
            } else {
                s.to_string()
            }
        };
        let mut out = String::from("section,part,quantity,unit,specification\n");
        for r in &self.rows {
            out += &format!(
                "{},{},{},{},{}\n",
                quote(r.section),
                quote(&r.part),
                r.quantity,
                quote(r.unit),
                quote(&r.specification)
            );
        }
        out
    }
}
