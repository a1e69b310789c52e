//! Every constant of the trunk model, with where it comes from. `docs/simulator.md` gives the
//! longer reasoning; a number changed here must be changed there.

use geometry::{ModuleDesign, ShapeState};

use super::design::TrunkDesign;
use super::multistable::{Barrier, CurveError, MultistableCurve, Well};

/// Polygon sides of both modules. n = 3 because (i) it gives the largest state height
/// differences (folded d = √(tan²β − tan²(90°/n)), eq 10–11: for n = 3 the 31.72° module folds
/// to 36 % of its deployed height, for n = 4 only to 74 %), which is what makes the crane's
/// states useful, and (ii) a three-unit hybrid sample of n = 3 units with 75 mm edges travels
/// ~120 mm from folded to deployed, closest to the paper's 105 mm (n = 4: 78 mm, n = 5: 67 mm).
pub const N_SIDES: u32 = 3;
/// Valley-fold (polygon edge) length of both modules, mm (paper §5.4).
pub const EDGE_MM: f64 = 75.0;
/// Top module fold angle (tan β = 1/φ, paper §5.4).
pub const TOP_BETA_DEG: f64 = 31.72;
/// Bottom module fold angle (paper §5.4).
pub const BOTTOM_BETA_DEG: f64 = 35.0;
/// Layers (units) of the bottom module: it self-packs "layer by layer" in two snaps (§5.4), and
/// only "the bottom two units" need manual folding (§6.2).
pub const BOTTOM_LAYERS: u32 = 2;
/// Layers of the top module: two, the same build as the bottom (the paper's trunk is built from
/// two panels rolled into one cylinder, §5.3); gives a 33 → 93 mm top module.
pub const TOP_LAYERS: u32 = 2;
/// Height of one self-packed layer, mm: the hyperfolded layer's d → 0 (Table 1), but its
/// panels stack; ~4 printed panels of TPU 95A base plus nylon facets, ~1.25 mm each (§5.3).
pub const PACKED_LAYER_MM: f64 = 5.0;

/// Slant height d of one folded layer in units of the edge, from the geometry crate's catalogue
/// (eqs 10–11: d = √(w² − tan²(90°/n)) with w = tan β; 0 at or below the flat-foldable β).
pub fn folded_d(beta_deg: f64, n: u32) -> f64 {
    layer_d(beta_deg, n, ShapeState::Folded)
}

/// Slant height d of one deployed layer in units of the edge (Table 1: d = w = tan β), from the
/// geometry crate's catalogue.
pub fn deployed_d(beta_deg: f64) -> f64 {
    layer_deployed_d(beta_deg, N_SIDES)
}

/// Slant height d of one deployed layer of an n-gon module in units of the edge (d = w = tan β).
pub fn layer_deployed_d(beta_deg: f64, n: u32) -> f64 {
    layer_d(beta_deg, n, ShapeState::Deployed)
}

fn layer_d(beta_deg: f64, n: u32, s: ShapeState) -> f64 {
    // 0 for a design outside the valid range (n in [3, 64], 0° < β < 90°): the designs are
    // checked before (`TrunkDesign::check`).
    ModuleDesign::new(n, beta_deg).map_or(0.0, |d| d.pose(s).d)
}

/// Effective piston area of the trunk, mm²: dV/dH of one layer. A deployed n = 3 layer is a
/// triangular antiprism between its boundary triangles (circumradius R = l / (2 sin 60°) =
/// 43.3 mm, the polygon circumradius); its prismatoid volume is H·(2·A_n + 4·A_mid)/6 with the
/// mid-section a 2n-gon of circumradius R·cos(90°/n). For n = 3 that is √3·R² = 3248 mm².
/// By virtual work the axial force of a gauge pressure p is p·dV/dH = p·A.
pub fn piston_area_mm2(n: u32, edge_mm: f64) -> f64 {
    let nf = n as f64;
    let r = edge_mm / (2.0 * (core::f64::consts::PI / nf).sin());
    let a_n = 0.5 * nf * r * r * (2.0 * core::f64::consts::PI / nf).sin();
    let r_mid = r * (core::f64::consts::PI / (2.0 * nf)).cos();
    let a_mid = nf * r_mid * r_mid * (core::f64::consts::PI / nf).sin();
    (2.0 * a_n + 4.0 * a_mid) / 6.0
}

/// Every parameter of the trunk model.
#[derive(Debug, Clone, PartialEq)]
pub struct TrunkParams {
    /// Top module's force–extension law (wells: F, D).
    pub top: MultistableCurve,
    /// Bottom module's force–extension law (wells: P, half-packed, F, D).
    pub bottom: MultistableCurve,
    /// Effective piston area, mm².
    pub area_mm2: f64,
    /// Viscous damping of each module's axial motion, N·s/mm.
    pub damping_n_s_per_mm: f64,
    /// Bending stiffness of the top module in F and D, N·mm/rad.
    pub top_bending_n_mm_per_rad: [f64; 2],
    /// Bending stiffness of the bottom module in P, half-packed, F, D, N·mm/rad.
    pub bottom_bending_n_mm_per_rad: [f64; 4],
    /// Viscous damping of bending, N·mm·s/rad.
    pub bending_damping_n_mm_s_per_rad: f64,
    /// Dead load on the tip (cap, connector, tendon locator), N.
    pub tip_load_n: f64,
    /// Radius at which the tendons run, mm.
    pub tendon_radius_mm: f64,
    /// Axial stiffness of one tendon including its spool and horn, N/mm.
    pub tendon_stiffness_n_per_mm: f64,
    /// Tendon free length at zero spool pay-in: slack exactly at the unloaded D&D height, mm.
    pub tendon_slack_length_mm: f64,
    /// Air reservoir between the valves and the trunk (base plenum + buffer), m³.
    pub plenum_m3: f64,
    /// Regulated supply pressure, gauge Pa.
    pub supply_gauge_pa: f64,
    /// Orifice discharge coefficient of valves and leak.
    pub cd: f64,
    /// Inlet valve orifice diameter, mm.
    pub inlet_diameter_mm: f64,
    /// Exhaust valve orifice diameter, mm.
    pub exhaust_diameter_mm: f64,
    /// The trunk's normal leak, equivalent orifice diameter, mm.
    pub leak_diameter_mm: f64,
    /// The `leak` fault's equivalent orifice diameter, mm.
    pub fault_leak_diameter_mm: f64,
    /// The simulated pressure sensor's gain error: it reads `gain × p + offset` (1: none).
    pub sensor_gain: f64,
    /// The simulated pressure sensor's offset error, kPa.
    pub sensor_offset_kpa: f64,
}

impl TrunkParams {
    /// The calibrated PDF trunk (docs/simulator.md, "Calibration"), derived from the design;
    /// `trunks/pdf.toml` describes the same trunk (a test holds them equal) and is what the
    /// simulator runs by default ([`super::spec::TrunkSpec::pdf`]).
    pub fn pdf() -> Result<Self, CurveError> {
        let h = TrunkDesign::PDF.heights();
        let [top_f, top_d] = h.top;
        let bot_layer_f = h.bottom_layer_folded_mm;
        let bot_p = BOTTOM_LAYERS as f64 * PACKED_LAYER_MM;
        let bot_half = PACKED_LAYER_MM + bot_layer_f;
        let (bot_f, bot_d) = (h.bottom_folded_mm, h.bottom_deployed_mm);
        let well = |height_mm, stiffness_n_per_mm| Well {
            height_mm,
            stiffness_n_per_mm,
        };
        let barrier = |tension_n, compression_n| Barrier {
            tension_n,
            compression_n,
        };
        // Stiffness grows with β (§5.1): bottom (35°) wells are stiffer than the top's (31.72°)
        // in the same state. Forces: see docs/simulator.md, "Calibration".
        let top = MultistableCurve::new(
            vec![well(top_f, 1.4), well(top_d, 16.0)],
            // F→D pop-out at 62 N (19.1 kPa); D→F buckling at 75 N (> the 56 N of the paper's
            // 5.7 kg load held in D&D without pressure, §6.5).
            vec![barrier(62.0, 75.0)],
            TOP_LAYERS as f64 * PACKED_LAYER_MM,
            50.0,
        )?;
        let bottom = MultistableCurve::new(
            vec![
                well(bot_p, 25.0),
                well(bot_half, 12.0),
                well(bot_f, 16.0),
                well(bot_d, 20.0),
            ],
            vec![
                // P → half: unpacks at 42 N (12.9 kPa); half → P: the second packing snap, 130 N.
                barrier(42.0, 130.0),
                // half → F at 20 N (< 42 N, so unpacking cascades through both layers in one
                // snap, as in the tensile tests); F → half: the first packing snap, 110 N.
                barrier(20.0, 110.0),
                // F → D at 97 N (29.9 kPa); D → F buckling at 124 N.
                barrier(97.0, 124.0),
            ],
            0.8 * bot_p,
            200.0,
        )?;
        Ok(Self {
            top,
            bottom,
            area_mm2: h.area_mm2,
            damping_n_s_per_mm: 0.05,
            top_bending_n_mm_per_rad: [900.0, 60_000.0],
            bottom_bending_n_mm_per_rad: [120_000.0, 8_000.0, 1_500.0, 90_000.0],
            bending_damping_n_mm_s_per_rad: 30.0,
            tip_load_n: 0.5,
            tendon_radius_mm: 38.0,
            tendon_stiffness_n_per_mm: 50.0,
            tendon_slack_length_mm: h.tendon_slack_length_mm,
            plenum_m3: 1.5e-3,
            supply_gauge_pa: 80e3,
            cd: 0.7,
            inlet_diameter_mm: 1.2,
            exhaust_diameter_mm: 2.0,
            leak_diameter_mm: 0.04,
            fault_leak_diameter_mm: 2.5,
            sensor_gain: 1.0,
            sensor_offset_kpa: 0.0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folded_and_deployed_heights_follow_table_1() {
        // n = 3, β = 31.72°: w = 0.61809, d_F = √(0.38204 − 1/3) = 0.22069.
        assert!((deployed_d(31.72) - 0.61809).abs() < 1e-4);
        assert!((folded_d(31.72, 3) - 0.22069).abs() < 1e-4);
        assert!((folded_d(35.0, 3) - 0.39616).abs() < 1e-4);
        // β = 90°/n is flat-foldable: d = 0.
        assert!(folded_d(30.0, 3) < 1e-7);
        // The closed form of eqs 10–11.
        for beta in [31.72f64, 35.0, 40.0] {
            let w = beta.to_radians().tan();
            let t = 30f64.to_radians().tan();
            assert!((folded_d(beta, 3) - (w * w - t * t).sqrt()).abs() < 1e-12);
        }
    }

    #[test]
    fn piston_area_of_the_n3_antiprism_is_root3_r_squared() {
        let r = 75.0 / (2.0 * 60f64.to_radians().sin());
        assert!((piston_area_mm2(3, 75.0) - 3f64.sqrt() * r * r).abs() < 1e-6);
        // Between the inscribed triangle and the circumscribed circle.
        let a = piston_area_mm2(3, 75.0);
        assert!(a > 0.433 * 75.0 * 75.0 && a < core::f64::consts::PI * r * r);
    }

    #[test]
    fn pdf_parameters_are_valid_and_ordered_by_the_paper() {
        let p = TrunkParams::pdf().unwrap();
        let (t, b) = (p.top.barriers(), p.bottom.barriers());
        // Tension: bottom unpacks first, then the top pops, then the bottom deploys.
        assert!(b[0].tension_n < t[0].tension_n && t[0].tension_n < b[2].tension_n);
        // Unpacking cascades: the second layer's barrier is below the first's.
        assert!(b[1].tension_n < b[0].tension_n);
        // Compression: the smaller-β top buckles first; then bottom D→F; packing layer by layer.
        assert!(t[0].compression_n < b[2].compression_n);
        assert!(b[1].compression_n < b[0].compression_n);
        assert!(t[0].compression_n > 5.7 * 9.81);
        // Stiffness grows with β in the same state (F and D).
        assert!(p.bottom.wells()[2].stiffness_n_per_mm > p.top.wells()[0].stiffness_n_per_mm);
        assert!(p.bottom.wells()[3].stiffness_n_per_mm > p.top.wells()[1].stiffness_n_per_mm);
    }
}
