//! A trunk described in a file: every parameter of the physics of one trunk, in TOML
//! (`trunks/pdf.toml` is the calibrated PDF trunk, [`TrunkParams::pdf`]), the shorthand that
//! scales its snap forces, and the swarm's random trunks around it (`docs/simulator.md`,
//! "Trunks that differ").
//!
//! A description the physics cannot represent is refused with the reason ([`TrunkError`]): a
//! curve whose barriers overlap, a value that is not positive, a well count other than the
//! modules' states, or snap forces whose order is not the one the crane's state graph is built
//! on (`protocol::transitions`: under pressure the bottom unpacks before the top pops out and
//! the top pops out before the bottom deploys; under the tendons the top buckles first).

use rand::Rng;
use serde::{Deserialize, Serialize};

use super::design::{DesignError, TrunkDesign, DESIGN_TOLERANCE};
use super::multistable::{Barrier, CurveError, MultistableCurve, Well};
use super::params::TrunkParams;

/// The calibrated PDF trunk's description (`trunks/pdf.toml`, compiled in).
pub const PDF_TOML: &str = include_str!("../../../../trunks/pdf.toml");

/// Radius at which the tendons run in the physics alone (the simulator puts them where the
/// controller's configuration says: that is the rig's, not the trunk's).
pub const TENDON_RADIUS_MM: f64 = 38.0;

/// The range of `--sim-trunk-scale`: a factor on every snap force.
pub const SCALE_RANGE: core::ops::RangeInclusive<f64> = 0.1..=10.0;

/// Half-width of the sensor offset's spread per unit of `--trunk-spread`, kPa: a spread `F`
/// draws the offset uniformly in `±F × 1 kPa` (the calibrated sensor reads true, offset 0).
pub const OFFSET_SPREAD_KPA: f64 = 1.0;

/// The sensor gain's spread per unit of `--trunk-spread`: a spread `F` draws the gain within
/// `1 ± F × GAIN_SPREAD`. A pressure sensor's gain is its datasheet's class (±2.5 % for an
/// MPX5100), not a print's variation; and a sensor that reads low by g lets the true pressure
/// reach the cap / (1 − g), which no firmware can see (the swarm's cap is on the true pressure).
pub const GAIN_SPREAD: f64 = 0.2;

/// How far apart (a factor) the snaps of one actuation must be for the crane to make one
/// without the next: the calibrated trunk's closest pair is 1.47 (the top's buckling at 75 N,
/// the bottom's first packing snap at 110 N).
pub const ORDER_RATIO: f64 = 1.2;

/// Smallest pressure step (kPa) of a snap under inflation that the crane can see, as
/// [`snap_step_kpa`] estimates it: the firmware's snap detector needs 1.5 kPa over the filling
/// ramp, and a snap that moves its module too little (a soft well that stretches almost to its
/// barrier, a well close to the next) drops the sealed pressure by less. Such a trunk's
/// inflation goes on to its next snap and takes it for the first: no firmware can tell from
/// the pressure alone. Measured: a drawn top estimated at 1.67 kPa went unseen, the calibrated
/// trunk's top (3.7 kPa) and its ×1.2 forces (2.2 kPa) are seen.
pub const MIN_SNAP_STEP_KPA: f64 = 2.0;

/// The pressure step (kPa) of a module snapping from well `from` under `force_n` by
/// inflation, with the rest of the trunk `other_mm` tall: the module jumps from its tension
/// peak to the next well's branch at the same force (through every well the force cannot
/// hold), and the sealed gas (the plenum and the trunk) expands isothermally.
fn snap_step_kpa(
    c: &MultistableCurve,
    from: usize,
    force_n: f64,
    other_mm: f64,
    area_mm2: f64,
    plenum_m3: f64,
) -> f64 {
    let w = c.wells();
    let b = c.barriers();
    let before = w[from].height_mm + force_n / w[from].stiffness_n_per_mm;
    let mut to = from + 1;
    while to < b.len() && b[to].tension_n < force_n {
        to += 1;
    }
    let after = w[to].height_mm + force_n / w[to].stiffness_n_per_mm;
    let p_abs_kpa = super::gas::P_ATM_PA / 1e3 + force_n / area_mm2 * 1e3;
    let v_mm3 = plenum_m3 * 1e9 + area_mm2 * (before + other_mm);
    let dv_mm3 = area_mm2 * (after - before).max(0.0);
    p_abs_kpa * dv_mm3 / (v_mm3 + dv_mm3)
}

/// One module: its wells (shortest first), the barriers between them, the panels' contact and
/// the bending stiffness in each well.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModuleSpec {
    /// Stable states, shortest first: top F, D; bottom P, P½, F, D.
    pub wells: Vec<Well>,
    /// Between neighbouring wells: the tension that snaps it longer, the compression that
    /// snaps it back, N.
    pub barriers: Vec<Barrier>,
    /// Height below which panels touch, mm.
    pub contact_mm: f64,
    /// Stiffness of that contact, N/mm.
    pub contact_stiffness_n_per_mm: f64,
    /// Bending stiffness in each well, N·mm/rad.
    pub bending_n_mm_per_rad: Vec<f64>,
}

/// The pneumatics: the trunk's piston area and leak, the reservoir and the valves.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PneumaticSpec {
    /// Effective piston area (dV/dH), mm².
    pub area_mm2: f64,
    /// Reservoir between the valves and the trunk, m³.
    pub plenum_m3: f64,
    /// Regulated supply, gauge Pa.
    pub supply_gauge_pa: f64,
    /// Orifice discharge coefficient.
    pub cd: f64,
    /// Inlet orifice diameter, mm.
    pub inlet_diameter_mm: f64,
    /// Exhaust orifice diameter, mm.
    pub exhaust_diameter_mm: f64,
    /// The trunk's normal leak, equivalent orifice diameter, mm.
    pub leak_diameter_mm: f64,
    /// The `leak` fault's equivalent orifice diameter, mm.
    pub fault_leak_diameter_mm: f64,
}

/// Damping, the tip's dead load and the tendons.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MechanicsSpec {
    /// Viscous damping of each module's axial motion, N·s/mm.
    pub damping_n_s_per_mm: f64,
    /// Viscous damping of bending, N·mm·s/rad.
    pub bending_damping_n_mm_s_per_rad: f64,
    /// Dead load on the tip, N.
    pub tip_load_n: f64,
    /// Axial stiffness of one tendon with its spool and horn, N/mm.
    pub tendon_stiffness_n_per_mm: f64,
    /// Tendon free length at zero pay-in, mm (the winches are set up slack at the unloaded
    /// D&D height).
    pub tendon_slack_length_mm: f64,
}

/// The simulated pressure sensor's error: it reads `gain × p + offset` (plus its noise); the
/// controller's own calibration of the sensor is its configuration, not this.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSpec {
    /// Gain error (1: none).
    pub gain: f64,
    /// Offset error, kPa.
    pub offset_kpa: f64,
}

/// A trunk's description, as in `trunks/*.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrunkSpec {
    /// The trunk's name.
    pub name: String,
    /// The design it is printed from (n, edge, β and layers per module): `pattern`/`model`
    /// make its files, and its heights and piston area must be the design's
    /// ([`TrunkSpec::check_design`]). A description without it is physics only (the simulator
    /// runs it as before; `pattern`/`model` refuse it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub design: Option<TrunkDesign>,
    /// The top module (wells F, D).
    pub top: ModuleSpec,
    /// The bottom module (wells P, P½, F, D).
    pub bottom: ModuleSpec,
    /// Piston area, reservoir, valves, leak.
    pub pneumatics: PneumaticSpec,
    /// Damping, tip load, tendons.
    pub mechanics: MechanicsSpec,
    /// The pressure sensor's error.
    pub sensor: SensorSpec,
}

/// Why a trunk description was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrunkError {
    /// The file could not be read.
    #[error("cannot read the trunk file {path}: {reason}")]
    Read {
        /// The file.
        path: String,
        /// The system's reason.
        reason: String,
    },
    /// Not TOML of the expected shape.
    #[error("the trunk description is not valid: {0}")]
    Parse(String),
    /// A module with another number of wells or bending stiffnesses than its states.
    #[error(
        "the {module} module needs {want} wells, {want_barriers} barriers and {want} bending \
         stiffnesses (got {wells}, {barriers}, {bending})"
    )]
    Shape {
        /// Which module.
        module: &'static str,
        /// Wells it needs.
        want: usize,
        /// Barriers it needs.
        want_barriers: usize,
        /// Wells given.
        wells: usize,
        /// Barriers given.
        barriers: usize,
        /// Bending stiffnesses given.
        bending: usize,
    },
    /// A module's force law cannot be built.
    #[error("the {module} module cannot be represented: {source}")]
    Curve {
        /// Which module.
        module: &'static str,
        /// Why.
        source: CurveError,
    },
    /// A value that must be finite and positive is not.
    #[error("{field} must be finite and positive (got {value})")]
    NotPositive {
        /// The parameter.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// A value that must be finite is not.
    #[error("{field} must be finite (got {value})")]
    NotFinite {
        /// The parameter.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// The snap forces' order is not the one the crane's transitions are built on.
    #[error(
        "the snap order is not the crane's: {0}, by a factor {ORDER_RATIO} at least (the state \
         graph of protocol::transitions needs it; docs/simulator.md, \"Trunks that differ\")"
    )]
    Order(&'static str),
    /// A snap under inflation that moves the pressure too little for the crane to see.
    #[error(
        "{what} drops the sealed pressure by {step_kpa:.2} kPa, under the {MIN_SNAP_STEP_KPA} \
         kPa the crane's snap detector needs (its module moves too little): the crane cannot \
         drive this trunk"
    )]
    Unseen {
        /// Which snap.
        what: &'static str,
        /// Its pressure step, kPa.
        step_kpa: f64,
    },
    /// The `[design]` table is infeasible or outside the crane's topology.
    #[error("{0}")]
    Design(#[from] DesignError),
    /// A height or the piston area that is not the one the `[design]` table gives.
    #[error(
        "{field} = {value} but the design gives {design} (the heights, the piston area and the \
         tendons' slack length follow from [design]; docs/simulator.md, \"Your own trunk\")"
    )]
    Disagrees {
        /// The parameter.
        field: &'static str,
        /// Its value in the description.
        value: f64,
        /// What the design gives.
        design: f64,
    },
    /// `--sim-trunk-scale` outside its range.
    #[error("a snap-force scale must be a number from 0.1 to 10 (got {0})")]
    Scale(f64),
    /// `--trunk-spread` outside its range.
    #[error(
        "a trunk spread must be at least 0 and below 1 (a fraction of each parameter; got {0})"
    )]
    Spread(f64),
}

fn positive(field: &'static str, value: f64) -> Result<f64, TrunkError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(TrunkError::NotPositive { field, value })
    }
}

fn finite(field: &'static str, value: f64) -> Result<f64, TrunkError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(TrunkError::NotFinite { field, value })
    }
}

/// Checks a `--sim-trunk-scale` value.
pub fn check_scale(k: f64) -> Result<f64, TrunkError> {
    if SCALE_RANGE.contains(&k) {
        Ok(k)
    } else {
        Err(TrunkError::Scale(k))
    }
}

/// Checks a `--trunk-spread` value.
pub fn check_spread(f: f64) -> Result<f64, TrunkError> {
    if f.is_finite() && (0.0..1.0).contains(&f) {
        Ok(f)
    } else {
        Err(TrunkError::Spread(f))
    }
}

impl ModuleSpec {
    fn of(curve: &MultistableCurve, bending: &[f64]) -> Self {
        let (contact_mm, contact_stiffness_n_per_mm) = curve.contact();
        Self {
            wells: curve.wells().to_vec(),
            barriers: curve.barriers().to_vec(),
            contact_mm,
            contact_stiffness_n_per_mm,
            bending_n_mm_per_rad: bending.to_vec(),
        }
    }

    fn curve(&self, module: &'static str, wells: usize) -> Result<MultistableCurve, TrunkError> {
        if self.wells.len() != wells
            || self.barriers.len() + 1 != wells
            || self.bending_n_mm_per_rad.len() != wells
        {
            return Err(TrunkError::Shape {
                module,
                want: wells,
                want_barriers: wells - 1,
                wells: self.wells.len(),
                barriers: self.barriers.len(),
                bending: self.bending_n_mm_per_rad.len(),
            });
        }
        for &k in &self.bending_n_mm_per_rad {
            positive("a bending stiffness", k)?;
        }
        MultistableCurve::new(
            self.wells.clone(),
            self.barriers.clone(),
            self.contact_mm,
            self.contact_stiffness_n_per_mm,
        )
        .map_err(|source| TrunkError::Curve { module, source })
    }
}

impl TrunkSpec {
    /// The calibrated PDF trunk's description (`trunks/pdf.toml`).
    pub fn pdf() -> Self {
        Self::from_toml(PDF_TOML)
            .unwrap_or_else(|e| unreachable!("trunks/pdf.toml (a test parses it): {e}"))
    }

    /// A description from TOML text; checked by [`TrunkSpec::params`], not here.
    pub fn from_toml(text: &str) -> Result<Self, TrunkError> {
        toml::from_str(text).map_err(|e| TrunkError::Parse(e.to_string().trim().to_string()))
    }

    /// A description from a file, checked: the physics can represent it.
    pub fn load(path: &std::path::Path) -> Result<Self, TrunkError> {
        let text = std::fs::read_to_string(path).map_err(|e| TrunkError::Read {
            path: path.display().to_string(),
            reason: e.to_string(),
        })?;
        let spec = Self::from_toml(&text)?;
        // The physics first: a value that is not a number at all is named as such, not as a
        // disagreement with the design.
        spec.params()?;
        spec.check_design()?;
        Ok(spec)
    }

    /// The `[design]` table (if any) is feasible and of the crane's topology
    /// ([`TrunkDesign::check`]), and the description's heights, piston area and tendon slack
    /// are what it gives, within [`DESIGN_TOLERANCE`]: top F and D, bottom F and D, the
    /// half-packed well P½ = P / 2 + F / 2 (one layer packed over one folded; the packed
    /// layer's height is the printed panels' stack, not the pattern's, so P is the file's),
    /// the piston area (dV/dH of a deployed layer) and the slack length (the D&D height).
    /// Derived numbers are refused when they disagree rather than silently replaced: the file
    /// says every number the physics runs, and a disagreement is a mistake in one or the other.
    /// The swarm's spread trunks vary the heights on purpose and are not checked against it.
    pub fn check_design(&self) -> Result<(), TrunkError> {
        let Some(design) = &self.design else {
            return Ok(());
        };
        design.check()?;
        if self.top.wells.len() != 2 || self.bottom.wells.len() != 4 {
            // The shape is refused with its reason by `params`.
            return Ok(());
        }
        let h = design.heights();
        let (t, b) = (&self.top.wells, &self.bottom.wells);
        let half = 0.5 * b[0].height_mm + 0.5 * h.bottom_folded_mm;
        for (field, value, want) in [
            ("top.wells[0].height_mm (F)", t[0].height_mm, h.top[0]),
            ("top.wells[1].height_mm (D)", t[1].height_mm, h.top[1]),
            ("bottom.wells[1].height_mm (P½)", b[1].height_mm, half),
            (
                "bottom.wells[2].height_mm (F)",
                b[2].height_mm,
                h.bottom_folded_mm,
            ),
            (
                "bottom.wells[3].height_mm (D)",
                b[3].height_mm,
                h.bottom_deployed_mm,
            ),
            ("pneumatics.area_mm2", self.pneumatics.area_mm2, h.area_mm2),
            (
                "mechanics.tendon_slack_length_mm",
                self.mechanics.tendon_slack_length_mm,
                h.tendon_slack_length_mm,
            ),
        ] {
            // A NaN agrees with nothing.
            let agrees = (value - want).abs() <= DESIGN_TOLERANCE * want;
            if !agrees {
                return Err(TrunkError::Disagrees {
                    field,
                    value,
                    design: (want * 1e4).round() / 1e4,
                });
            }
        }
        Ok(())
    }

    /// The description as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_else(|e| unreachable!("plain tables and numbers: {e}"))
    }

    /// The description of `p` (what [`TrunkSpec::params`] turns back into `p`, the tendon
    /// radius aside: [`TENDON_RADIUS_MM`]).
    pub fn of(name: &str, p: &TrunkParams) -> Self {
        Self {
            name: name.to_string(),
            design: None,
            top: ModuleSpec::of(&p.top, &p.top_bending_n_mm_per_rad),
            bottom: ModuleSpec::of(&p.bottom, &p.bottom_bending_n_mm_per_rad),
            pneumatics: PneumaticSpec {
                area_mm2: p.area_mm2,
                plenum_m3: p.plenum_m3,
                supply_gauge_pa: p.supply_gauge_pa,
                cd: p.cd,
                inlet_diameter_mm: p.inlet_diameter_mm,
                exhaust_diameter_mm: p.exhaust_diameter_mm,
                leak_diameter_mm: p.leak_diameter_mm,
                fault_leak_diameter_mm: p.fault_leak_diameter_mm,
            },
            mechanics: MechanicsSpec {
                damping_n_s_per_mm: p.damping_n_s_per_mm,
                bending_damping_n_mm_s_per_rad: p.bending_damping_n_mm_s_per_rad,
                tip_load_n: p.tip_load_n,
                tendon_stiffness_n_per_mm: p.tendon_stiffness_n_per_mm,
                tendon_slack_length_mm: p.tendon_slack_length_mm,
            },
            sensor: SensorSpec {
                gain: p.sensor_gain,
                offset_kpa: p.sensor_offset_kpa,
            },
        }
    }

    /// The physics' parameters, or why the physics cannot represent this trunk.
    pub fn params(&self) -> Result<TrunkParams, TrunkError> {
        let top = self.top.curve("top", 2)?;
        let bottom = self.bottom.curve("bottom", 4)?;
        let (t, b) = (top.barriers(), bottom.barriers());
        // Each snap of one actuation at least ORDER_RATIO above the one it must follow: the
        // inlet closes (the pull stops) only once a drop (a spike) is seen, and closer
        // barriers snap together.
        let above = |hi: f64, lo: f64| hi >= ORDER_RATIO * lo;
        if !above(b[0].tension_n, b[1].tension_n) {
            return Err(TrunkError::Order(
                "the bottom's second layer must unpack at a force well under its first's \
                 (one snap through both layers; a trunk resting half-packed has no state)",
            ));
        }
        if !above(t[0].tension_n, b[0].tension_n) {
            return Err(TrunkError::Order(
                "under pressure the bottom must unpack well before the top pops out",
            ));
        }
        if !above(b[2].tension_n, t[0].tension_n) {
            return Err(TrunkError::Order(
                "under pressure the top must pop out well before the bottom deploys",
            ));
        }
        if !above(b[2].compression_n, t[0].compression_n)
            || !above(b[1].compression_n, t[0].compression_n)
        {
            return Err(TrunkError::Order(
                "under the tendons the top must buckle well before the bottom folds or packs",
            ));
        }
        let pn = &self.pneumatics;
        let me = &self.mechanics;
        let (area, plenum) = (
            positive("pneumatics.area_mm2", pn.area_mm2)?,
            positive("pneumatics.plenum_m3", pn.plenum_m3)?,
        );
        // The three snaps of inflation, each from the state it is made from: unpacking under
        // the folded top (F&P), the top's pop-out over the folded bottom (F&F), the bottom's
        // deployment under the deployed top (D&F).
        let (tw, bw) = (top.wells(), bottom.wells());
        let f = t[0].tension_n;
        let folded_top = tw[0].height_mm + b[0].tension_n / tw[0].stiffness_n_per_mm;
        let folded_bottom = bw[2].height_mm + f / bw[2].stiffness_n_per_mm;
        let deployed_top = tw[1].height_mm + b[2].tension_n / tw[1].stiffness_n_per_mm;
        for (what, step) in [
            (
                "the bottom's unpacking",
                snap_step_kpa(&bottom, 0, b[0].tension_n, folded_top, area, plenum),
            ),
            (
                "the top's pop-out",
                snap_step_kpa(&top, 0, f, folded_bottom, area, plenum),
            ),
            (
                "the bottom's deployment",
                snap_step_kpa(&bottom, 2, b[2].tension_n, deployed_top, area, plenum),
            ),
        ] {
            if step < MIN_SNAP_STEP_KPA {
                return Err(TrunkError::Unseen {
                    what,
                    step_kpa: step,
                });
            }
        }
        Ok(TrunkParams {
            area_mm2: area,
            damping_n_s_per_mm: positive("mechanics.damping_n_s_per_mm", me.damping_n_s_per_mm)?,
            top_bending_n_mm_per_rad: [
                self.top.bending_n_mm_per_rad[0],
                self.top.bending_n_mm_per_rad[1],
            ],
            bottom_bending_n_mm_per_rad: core::array::from_fn(|i| {
                self.bottom.bending_n_mm_per_rad[i]
            }),
            bending_damping_n_mm_s_per_rad: positive(
                "mechanics.bending_damping_n_mm_s_per_rad",
                me.bending_damping_n_mm_s_per_rad,
            )?,
            tip_load_n: finite("mechanics.tip_load_n", me.tip_load_n)?,
            tendon_radius_mm: TENDON_RADIUS_MM,
            tendon_stiffness_n_per_mm: positive(
                "mechanics.tendon_stiffness_n_per_mm",
                me.tendon_stiffness_n_per_mm,
            )?,
            tendon_slack_length_mm: positive(
                "mechanics.tendon_slack_length_mm",
                me.tendon_slack_length_mm,
            )?,
            plenum_m3: plenum,
            supply_gauge_pa: positive("pneumatics.supply_gauge_pa", pn.supply_gauge_pa)?,
            cd: positive("pneumatics.cd", pn.cd)?,
            inlet_diameter_mm: positive("pneumatics.inlet_diameter_mm", pn.inlet_diameter_mm)?,
            exhaust_diameter_mm: positive(
                "pneumatics.exhaust_diameter_mm",
                pn.exhaust_diameter_mm,
            )?,
            leak_diameter_mm: positive("pneumatics.leak_diameter_mm", pn.leak_diameter_mm)?,
            fault_leak_diameter_mm: positive(
                "pneumatics.fault_leak_diameter_mm",
                pn.fault_leak_diameter_mm,
            )?,
            sensor_gain: positive("sensor.gain", self.sensor.gain)?,
            sensor_offset_kpa: finite("sensor.offset_kpa", self.sensor.offset_kpa)?,
            top,
            bottom,
        })
    }

    /// This trunk's physics printed to another design: the heights, the piston area and the
    /// tendons' slack length derived from `design` (the packed well P and everything else
    /// kept; the contact heights keep their ratio to each module's first well), named `name`.
    /// The design is checked; the physics is checked by [`TrunkSpec::params`], not here (a
    /// design's heights with this trunk's forces may be a trunk the crane cannot drive).
    pub fn with_design(&self, name: &str, design: TrunkDesign) -> Result<Self, TrunkError> {
        design.check()?;
        let h = design.heights();
        let mut s = self.clone();
        s.name = name.to_string();
        s.design = Some(design);
        if s.top.wells.len() == 2 {
            let first = s.top.wells[0].height_mm;
            s.top.wells[0].height_mm = h.top[0];
            s.top.wells[1].height_mm = h.top[1];
            s.top.contact_mm *= h.top[0] / first;
        }
        if s.bottom.wells.len() == 4 {
            let p = s.bottom.wells[0].height_mm;
            s.bottom.wells[1].height_mm = 0.5 * p + 0.5 * h.bottom_folded_mm;
            s.bottom.wells[2].height_mm = h.bottom_folded_mm;
            s.bottom.wells[3].height_mm = h.bottom_deployed_mm;
        }
        s.pneumatics.area_mm2 = h.area_mm2;
        s.mechanics.tendon_slack_length_mm = h.tendon_slack_length_mm;
        Ok(s)
    }

    /// Every snap force (each barrier's tension and compression) times `k` (checked against
    /// [`SCALE_RANGE`]; the result is checked by [`TrunkSpec::params`]).
    pub fn scaled(&self, k: f64) -> Result<Self, TrunkError> {
        check_scale(k)?;
        let mut s = self.clone();
        for b in s
            .top
            .barriers
            .iter_mut()
            .chain(s.bottom.barriers.iter_mut())
        {
            b.tension_n *= k;
            b.compression_n *= k;
        }
        if k != 1.0 {
            s.name = format!("{} (snap forces ×{k})", self.name);
        }
        Ok(s)
    }

    /// A trunk around this one: every varied parameter times its own factor, drawn uniformly
    /// in `[1 − f, 1 + f]` (the sensor offset: `offset + u × f × OFFSET_SPREAD_KPA`, u uniform
    /// in [−1, 1]), independently; a draw the physics cannot represent is drawn again from the
    /// same stream. Returns the trunk and how many draws were refused before it.
    ///
    /// Varied: each barrier's tension and compression, each well's height and stiffness, the
    /// bending stiffness in each well, the piston area, the plenum, the leak's diameter, the
    /// tendons' stiffness, the sensor's gain and offset. Following them: each module's
    /// contact height keeps its ratio to the module's first well, and the tendons' slack
    /// length is the drawn D&D height (the winches are set up on the trunk they pull). The
    /// rest (damping, tip load, supply, valves) is the rig's and stays.
    pub fn spread<R: Rng>(&self, f: f64, rng: &mut R) -> Result<(Self, u32), TrunkError> {
        check_spread(f)?;
        self.params()?;
        if f == 0.0 {
            return Ok((self.clone(), 0));
        }
        for redraws in 0..10_000u32 {
            let mut s = self.clone();
            let mut k = |x: &mut f64| *x *= 1.0 + f * rng.gen_range(-1.0..=1.0);
            for m in [&mut s.top, &mut s.bottom] {
                let first = m.wells[0].height_mm;
                for w in &mut m.wells {
                    k(&mut w.height_mm);
                    k(&mut w.stiffness_n_per_mm);
                }
                for b in &mut m.barriers {
                    k(&mut b.tension_n);
                    k(&mut b.compression_n);
                }
                for x in &mut m.bending_n_mm_per_rad {
                    k(x);
                }
                m.contact_mm *= m.wells[0].height_mm / first;
            }
            k(&mut s.pneumatics.area_mm2);
            k(&mut s.pneumatics.plenum_m3);
            k(&mut s.pneumatics.leak_diameter_mm);
            k(&mut s.mechanics.tendon_stiffness_n_per_mm);
            s.sensor.gain *= 1.0 + f * GAIN_SPREAD * rng.gen_range(-1.0..=1.0);
            s.sensor.offset_kpa += f * OFFSET_SPREAD_KPA * rng.gen_range(-1.0..=1.0);
            s.mechanics.tendon_slack_length_mm = s.top.wells[1].height_mm
                + s.bottom.wells[3].height_mm
                + (self.mechanics.tendon_slack_length_mm
                    - self.top.wells[1].height_mm
                    - self.bottom.wells[3].height_mm);
            if s.params().is_ok() {
                s.name = format!("{} ±{f}", self.name);
                return Ok((s, redraws));
            }
        }
        Err(TrunkError::Spread(f))
    }

    /// Each varied parameter's factor against `base` (for people: a drawn trunk in one line).
    pub fn describe_against(&self, base: &TrunkSpec) -> String {
        let mut out = Vec::new();
        let r = |a: f64, b: f64| if b == 0.0 { 1.0 } else { a / b };
        for (name, m, b) in [
            ("top", &self.top, &base.top),
            ("bottom", &self.bottom, &base.bottom),
        ] {
            let forces: Vec<String> = m
                .barriers
                .iter()
                .zip(&b.barriers)
                .map(|(x, y)| {
                    format!(
                        "{:.3}/{:.3}",
                        r(x.tension_n, y.tension_n),
                        r(x.compression_n, y.compression_n)
                    )
                })
                .collect();
            let wells: Vec<String> = m
                .wells
                .iter()
                .zip(&b.wells)
                .map(|(x, y)| {
                    format!(
                        "{:.3}/{:.3}",
                        r(x.height_mm, y.height_mm),
                        r(x.stiffness_n_per_mm, y.stiffness_n_per_mm)
                    )
                })
                .collect();
            let bend: Vec<String> = m
                .bending_n_mm_per_rad
                .iter()
                .zip(&b.bending_n_mm_per_rad)
                .map(|(x, y)| format!("{:.3}", r(*x, *y)))
                .collect();
            out.push(format!(
                "{name} barriers ×[{}] wells h/k ×[{}] bending ×[{}]",
                forces.join(" "),
                wells.join(" "),
                bend.join(" ")
            ));
        }
        out.push(format!(
            "area ×{:.3} plenum ×{:.3} leak ×{:.3} tendon k ×{:.3} sensor gain ×{:.3} offset {:+.3} kPa",
            r(self.pneumatics.area_mm2, base.pneumatics.area_mm2),
            r(self.pneumatics.plenum_m3, base.pneumatics.plenum_m3),
            r(
                self.pneumatics.leak_diameter_mm,
                base.pneumatics.leak_diameter_mm
            ),
            r(
                self.mechanics.tendon_stiffness_n_per_mm,
                base.mechanics.tendon_stiffness_n_per_mm
            ),
            r(self.sensor.gain, base.sensor.gain),
            self.sensor.offset_kpa
        ));
        out.join("; ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn the_pdf_file_is_the_calibrated_trunk() {
        let mut want = TrunkParams::pdf().unwrap();
        want.tendon_radius_mm = TENDON_RADIUS_MM;
        assert_eq!(TrunkSpec::pdf().params().unwrap(), want);
        assert_eq!(TrunkSpec::pdf().name, "pdf");
        // The file is what `of` writes (a changed pdf() must be written to the file).
        let mut of = TrunkSpec::of("pdf", &want);
        of.design = Some(TrunkDesign::PDF);
        assert_eq!(
            TrunkSpec::from_toml(&of.to_toml()).unwrap(),
            TrunkSpec::pdf()
        );
        TrunkSpec::pdf().check_design().unwrap();
    }

    #[test]
    fn scaling_scales_every_snap_force_and_refuses_what_cannot_be() {
        let pdf = TrunkSpec::pdf();
        let s = pdf.scaled(1.2).unwrap().params().unwrap();
        let p = pdf.params().unwrap();
        for (a, b) in s.bottom.barriers().iter().zip(p.bottom.barriers()) {
            assert!((a.tension_n - 1.2 * b.tension_n).abs() < 1e-9);
            assert!((a.compression_n - 1.2 * b.compression_n).abs() < 1e-9);
        }
        assert_eq!(s.top.wells(), p.top.wells());
        // × 1.35: the top's barriers overlap (the pop-out's peak passes the buckling valley).
        let e = pdf.scaled(1.35).unwrap().params().unwrap_err();
        assert!(
            matches!(
                e,
                TrunkError::Curve {
                    source: CurveError::Overlap { .. },
                    ..
                }
            ),
            "{e}"
        );
        for k in [0.0, -1.0, f64::NAN, 11.0] {
            assert!(matches!(pdf.scaled(k), Err(TrunkError::Scale(_))), "{k}");
        }
    }

    #[test]
    fn spread_draws_representable_trunks_within_the_band_deterministically() {
        let pdf = TrunkSpec::pdf();
        let draw = |seed| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            pdf.spread(0.25, &mut rng).unwrap()
        };
        assert_eq!(draw(7), draw(7));
        assert_ne!(draw(7), draw(8));
        let mut redrawn = 0;
        for seed in 0..200 {
            let (s, r) = draw(seed);
            redrawn += r;
            s.params().unwrap();
            for (a, b) in s.bottom.barriers.iter().zip(&pdf.bottom.barriers) {
                let k = a.tension_n / b.tension_n;
                assert!((0.75..=1.25).contains(&k), "{k}");
            }
            assert!(s.sensor.offset_kpa.abs() <= 0.25);
        }
        // Some draws invert the snap order and are drawn again.
        assert!(redrawn > 0);
        assert_eq!(
            pdf.spread(1.0, &mut rand_chacha::ChaCha8Rng::seed_from_u64(1))
                .unwrap_err(),
            TrunkError::Spread(1.0)
        );
    }

    #[test]
    fn the_calibrated_snaps_are_seen_and_a_soft_top_is_refused() {
        let pdf = TrunkSpec::pdf();
        let p = pdf.params().unwrap();
        let top = snap_step_kpa(
            &p.top,
            0,
            62.0,
            59.43 + 97.0 / 16.0,
            p.area_mm2,
            p.plenum_m3,
        );
        assert!((3.0..5.0).contains(&top), "{top}");
        // Every scale the issue measures is a trunk the crane can drive.
        for k in [0.75, 0.8, 0.9, 1.1, 1.2] {
            pdf.scaled(k).unwrap().params().unwrap();
        }
        // The top of swarm seed 5066 at ±0.25 (its snap went unseen, the bottom's deployment
        // was taken for it): a soft F well stretched to 76 mm, a D well at 83 mm.
        let mut s = pdf.clone();
        s.top.wells[0].height_mm *= 1.240;
        s.top.wells[0].stiffness_n_per_mm *= 1.049;
        s.top.wells[1].height_mm *= 0.891;
        s.top.wells[1].stiffness_n_per_mm *= 1.157;
        s.top.barriers[0].tension_n *= 0.839;
        s.top.barriers[0].compression_n *= 0.834;
        s.pneumatics.area_mm2 *= 1.232;
        s.pneumatics.plenum_m3 *= 1.203;
        assert!(matches!(
            s.params().unwrap_err(),
            TrunkError::Unseen {
                what: "the top's pop-out",
                ..
            }
        ));
    }

    /// `trunks/n4.toml`'s design: n = 4, 75 mm edges, a 23° top over a 30° bottom.
    fn n4() -> TrunkDesign {
        use super::super::design::ModuleDesignSpec;
        TrunkDesign {
            n: 4,
            edge_mm: 75.0,
            top: ModuleDesignSpec {
                beta_deg: 23.0,
                layers: 2,
            },
            bottom: ModuleDesignSpec {
                beta_deg: 30.0,
                layers: 2,
            },
        }
    }

    #[test]
    fn the_n4_example_is_the_pdf_physics_printed_to_its_design() {
        let file = TrunkSpec::from_toml(include_str!("../../../../trunks/n4.toml")).unwrap();
        let want = TrunkSpec::pdf().with_design("n4", n4()).unwrap();
        assert_eq!(file, want);
        file.check_design().unwrap();
        file.params().unwrap();
        // The same physics at the PDF's heights: the heights disagree with the design.
        let mut wrong = file.clone();
        wrong.top.wells = TrunkSpec::pdf().top.wells;
        match wrong.check_design().unwrap_err() {
            TrunkError::Disagrees { field, design, .. } => {
                assert_eq!(field, "top.wells[0].height_mm (F)");
                assert!((design - file.top.wells[0].height_mm).abs() < 1e-4);
            }
            e => panic!("{e}"),
        }
        // Within the tolerance (0.1 %) a rounded height is accepted, beyond it refused.
        let mut rounded = file.clone();
        rounded.pneumatics.area_mm2 *= 1.0 + 0.9 * DESIGN_TOLERANCE;
        rounded.check_design().unwrap();
        rounded.pneumatics.area_mm2 = file.pneumatics.area_mm2 * (1.0 + 1.1 * DESIGN_TOLERANCE);
        assert!(matches!(
            rounded.check_design().unwrap_err(),
            TrunkError::Disagrees {
                field: "pneumatics.area_mm2",
                ..
            }
        ));
        // A file without [design] is physics only: nothing to check.
        let mut old = file;
        old.design = None;
        old.check_design().unwrap();
    }

    #[test]
    fn refusals_name_the_reason() {
        let mut s = TrunkSpec::pdf();
        s.pneumatics.area_mm2 = 0.0;
        assert!(s.params().unwrap_err().to_string().contains("area_mm2"));
        let mut s = TrunkSpec::pdf();
        s.top.wells.pop();
        assert!(matches!(
            s.params().unwrap_err(),
            TrunkError::Shape { module: "top", .. }
        ));
        let mut s = TrunkSpec::pdf();
        s.top.barriers[0].tension_n = 30.0;
        assert!(matches!(s.params().unwrap_err(), TrunkError::Order(_)));
        assert!(matches!(
            TrunkSpec::from_toml("name = 1").unwrap_err(),
            TrunkError::Parse(_)
        ));
    }
}
