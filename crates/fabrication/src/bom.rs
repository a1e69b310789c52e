//! Bills of materials (part, quantity, unit, specification; no prices or vendors), as CSV.
//!
//! Two builds: the **crane** (the printed dual-material trunk panel of §5.3, the printed caps,
//! tendon locators and gripper mount of [`crate::parts`] with their magnets, screws and tendons,
//! and the electronics of `docs/hardware.md`) and the meter-scale **kit** of §7.1 (HDPE facets,
//! hinges of two printed PLA-CF leaves and a pin, M4 screws and heat-set inserts). Filament
//! masses are solid volumes (the panel's, each printed part's mesh) times a nominal density
//! ([`TPU_G_PER_CM3`], [`NYLON_G_PER_CM3`], [`PLA_G_PER_CM3`], [`PLA_CF_G_PER_CM3`]; your
//! filament's datasheet decides): printed solid, an upper bound for sparser infill; a slicer's
//! purge and supports come on top.

use crate::kit::Kit;
use crate::nest::Nest;
use crate::panel::Panel;
use crate::parts::{HoleRole, Part, INSERT_LENGTH_MM, PIN_HOLE_MM};

/// Nominal density of TPU 95A, g/cm³.
pub const TPU_G_PER_CM3: f64 = 1.21;
/// Nominal density of nylon (PA6/PA66 filament), g/cm³.
pub const NYLON_G_PER_CM3: f64 = 1.14;
/// Nominal density of PLA filament, g/cm³.
pub const PLA_G_PER_CM3: f64 = 1.24;
/// Nominal density of carbon-fibre-filled PLA (PLA-CF) filament, g/cm³ (datasheets give
/// 1.2-1.3).
pub const PLA_CF_G_PER_CM3: f64 = 1.29;

/// A printing filament: its name, nominal density and a display colour for 3MF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Filament {
    /// Name, as the BOM and the 3MF say it.
    pub name: &'static str,
    /// Nominal density, g/cm³.
    pub g_per_cm3: f64,
    /// sRGB display colour, `#RRGGBBAA`.
    pub colour: &'static str,
}

/// PLA: the crane's lower cap, tendon locators and gripper mount (rigid, easy to print, never
/// heated after assembly).
pub const PLA: Filament = Filament {
    name: "PLA",
    g_per_cm3: PLA_G_PER_CM3,
    colour: "#E6E6E6FF",
};
/// PLA-CF: the kit's hinge leaves (§7.1).
pub const PLA_CF: Filament = Filament {
    name: "PLA-CF",
    g_per_cm3: PLA_CF_G_PER_CM3,
    colour: "#2E2E2EFF",
};
/// Nylon: the panel's facets (§5.3) and the crane's upper cap, which is installed before the
/// trunk's last 140 °C heat treatment (PLA softens near 60 °C).
pub const NYLON: Filament = Filament {
    name: "nylon (PA)",
    g_per_cm3: NYLON_G_PER_CM3,
    colour: "#EDE8D8FF",
};

/// Grams, rounded to 0.1 g.
fn grams(g: f64) -> f64 {
    (g * 10.0).round() / 10.0
}

/// The printed parts' rows: one per part (pieces), then one filament row per material (the
/// parts' total mass printed solid).
fn printed_rows(parts: &[&Part]) -> Vec<BomRow> {
    let mut rows = Vec::new();
    for p in parts {
        rows.push(row(
            "printed",
            &format!("{} ({}.stl / .3mf)", p.name.replace('-', " "), p.name),
            p.quantity as f64,
            "pcs",
            &format!(
                "{}: {:.2} cm³, {:.1} g each printed solid at {} g/cm³",
                p.material.name,
                p.volume_mm3() / 1000.0,
                p.mass_g(),
                p.material.g_per_cm3
            ),
        ));
    }
    let mut materials: Vec<Filament> = Vec::new();
    for p in parts {
        if !materials.contains(&p.material) {
            materials.push(p.material);
        }
    }
    for m in materials {
        let of: Vec<&&Part> = parts.iter().filter(|p| p.material == m).collect();
        let cm3: f64 = of
            .iter()
            .map(|p| p.quantity as f64 * p.volume_mm3() / 1000.0)
            .sum();
        let list: Vec<String> = of
            .iter()
            .map(|p| format!("{} × {}", p.quantity, p.name))
            .collect();
        rows.push(row(
            "printed",
            &format!("{} filament (printed parts)", m.name),
            grams(cm3 * m.g_per_cm3),
            "g",
            &format!(
                "{cm3:.2} cm³ at {} g/cm³ printed solid ({}); sparser infill uses less, purge and supports come on top",
                m.g_per_cm3,
                list.join(", ")
            ),
        ));
    }
    rows
}

/// How many holes of `role` the parts have, each part counted `quantity` times, and where
/// (e.g. `3 in the upper cap`).
fn holes_of(parts: &[&Part], role: HoleRole) -> (usize, Vec<String>) {
    let mut total = 0;
    let mut at = Vec::new();
    for p in parts {
        let k = p.holes.iter().filter(|h| h.role == role).count();
        if k > 0 {
            total += k * p.quantity;
            at.push(format!("{} in each {}", k, p.name.replace('-', " ")));
        }
    }
    (total, at)
}

/// One line of a bill of materials.
#[derive(Debug, Clone, PartialEq)]
pub struct BomRow {
    /// Group: `trunk`, `kit`, `printed`, `hardware`, `electronics`, `power`, `pneumatics`.
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
    /// The crane: the printed panel's materials, the printed `parts` (the caps, tendon
    /// locators and gripper mount of [`crate::parts::crane_parts`]) with their magnets, gripper
    /// screws and tendons, and the electronics of `docs/hardware.md`.
    pub fn crane(panel: &Panel, parts: &[Part]) -> Self {
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
        let parts: Vec<&Part> = parts.iter().collect();
        rows.extend(printed_rows(&parts));
        let (magnets, at) = holes_of(&parts, HoleRole::Magnet);
        if magnets > 0 {
            rows.push(row(
                "hardware",
                "disc magnet",
                magnets as f64,
                "pcs",
                &format!(
                    "⌀6 × 3 mm N52 in the ⌀{} × {} mm pockets ({}); glue them in with the poles set so each pair attracts",
                    crate::parts::MAGNET_POCKET_MM[0],
                    crate::parts::MAGNET_POCKET_MM[1],
                    at.join(", ")
                ),
            ));
        }
        let (screws, _) = holes_of(&parts, HoleRole::Gripper);
        if screws > 0 {
            rows.push(row(
                "hardware",
                "M3 screw",
                screws as f64,
                "pcs",
                &format!(
                    "M3 through the gripper mount's ⌀{} holes ({} mm thick) into the gripper: length {} mm + the gripper's thread",
                    crate::parts::GRIPPER_HOLES.0,
                    crate::parts::GRIPPER_MOUNT_MM,
                    crate::parts::GRIPPER_MOUNT_MM
                ),
            ));
        }
        if let Some(cap) = parts.iter().find(|p| p.name == "upper-cap") {
            let tendons = cap
                .holes
                .iter()
                .filter(|h| h.role == HoleRole::Tendon)
                .count();
            rows.push(row(
                "hardware",
                "tendon line",
                tendons as f64,
                "pcs",
                &format!(
                    "braided line up to 1.5 mm (the tendon holes are ⌀{} mm) at r = {} mm: knotted over the upper cap, through both tendon locators and the lower cap to its servo; each at least the trunk's deployed height plus the run to the servo",
                    crate::parts::TENDON_HOLE_MM,
                    cap.dimension("tendon_radius_mm").unwrap_or(f64::NAN)
                ),
            ));
        }
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

    /// The meter-scale kit: facets (and the sheets of `nest` when given), hinges of two printed
    /// `leaf` parts ([`crate::parts::hinge_leaf`]) and a pin, screws, inserts.
    pub fn kit(kit: &Kit, nest: Option<&Nest>, leaf: &Part) -> Self {
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
        let leaves_per_hinge = if kit.hinges.is_empty() {
            2
        } else {
            leaf.quantity / kit.hinges.len()
        };
        rows.push(row(
            "kit",
            "hinge",
            kit.hinges.len() as f64,
            "pcs",
            &format!(
                "{leaves_per_hinge} printed {} hinge leaves and a pin; two M4 screws in each leaf",
                leaf.material.name
            ),
        ));
        rows.extend(printed_rows(&[leaf]));
        let pin = leaf.dimension("pin_length_mm").unwrap_or(f64::NAN);
        rows.push(row(
            "kit",
            "hinge pin",
            kit.hinges.len() as f64,
            "pcs",
            &format!(
                "⌀3 × {pin} mm steel dowel (ISO 2338) or M3 × {pin} screw, in the leaves' ⌀{PIN_HOLE_MM} mm pin hole"
            ),
        ));
        let screw = leaf.dimension("screw_length_mm").unwrap_or(f64::NAN);
        rows.push(row(
            "kit",
            "M4 screw",
            kit.screws() as f64,
            "pcs",
            &format!(
                "M4 × {screw} button head (ISO 7380), through a {} mm hinge leaf into an insert",
                leaf.dimension("leaf_mm").unwrap_or(f64::NAN)
            ),
        ));
        rows.push(row(
            "kit",
            "M4 heat-set insert",
            kit.screws() as f64,
            "pcs",
            &format!(
                "M4 × {INSERT_LENGTH_MM} mm, set into the {} mm HDPE facets",
                leaf.dimension("panel_mm").unwrap_or(f64::NAN)
            ),
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
