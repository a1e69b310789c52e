//! The trunk: two multistable modules in series, bent as one constant-curvature segment by
//! three tendons, inflated through an inlet valve and vented through an exhaust valve.
//!
//! Generalised coordinates: the two module heights and the bend vector `b = θ·(cos φ, sin φ)`
//! (tip-axis bend angle θ toward direction φ). The panels weigh grams, so inertia is neglected:
//! each coordinate moves against viscous damping (`c·ẋ = generalised force`), integrated by a
//! linearised backward-Euler step that is stable for the stiff tendons at any step size. The
//! negative stiffness of a snap-through branch is left explicit (it is what drives the snap).

use geometry::{BottomState, TopState, TrunkState};

use super::gas::{exchange_pv, orifice_area_m2, P_ATM_PA};
use super::params::TrunkParams;

/// Angular position of tendon `i` around the trunk (tendon 0 at 0°, 120° apart).
pub fn tendon_angle_rad(i: usize) -> f64 {
    (i as f64) * 2.0 * core::f64::consts::PI / 3.0
}

/// Unit vectors toward the tendons (cos, sin of [`tendon_angle_rad`]), precomputed: they are
/// used several times in every step.
const TENDON_DIR: [[f64; 2]; 3] = [
    [1.0, 0.0],
    [-0.5, 0.866_025_403_784_438_6],
    [-0.5, -0.866_025_403_784_438_6],
];

/// Which module.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Module {
    /// The β = 31.72° top module.
    Top,
    /// The β = 35° bottom module.
    Bottom,
}

/// A module leaving one stable branch for another.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Snap {
    /// Which module.
    pub module: Module,
    /// Well it left (index into its curve's wells).
    pub from_well: usize,
    /// Well it arrived in.
    pub to_well: usize,
}

/// What drives the trunk during one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Actuation {
    /// Tendon pay-in of each spool from the slack position (positive shortens the tendon), mm.
    pub pay_in_mm: [f64; 3],
    /// Inlet valve passes air (commanded open or stuck open, and not stuck closed).
    pub inlet_open: bool,
    /// Exhaust valve passes air.
    pub exhaust_open: bool,
    /// The `leak` fault is active.
    pub fault_leak: bool,
    /// Tendons that have broken carry no tension.
    pub tendon_broken: [bool; 3],
    /// Extra load on the tip (a held object), N.
    pub payload_n: f64,
}

/// The physical state of the trunk.
#[derive(Debug, Clone)]
pub struct Trunk {
    params: TrunkParams,
    /// Module heights, mm: `[top, bottom]`.
    heights_mm: [f64; 2],
    /// Bend vector, rad.
    bend: [f64; 2],
    /// Gas amount `p·V`, J.
    pv_j: f64,
    /// Stable well of each module at the end of the last step (None on a snap branch).
    wells: [Option<usize>; 2],
    /// Last well each module was settled in.
    last_well: [usize; 2],
    tensions_n: [f64; 3],
    /// A fold by hand under way.
    hand: Option<Hand>,
    /// What every step derives from the parameters alone, computed once.
    derived: Derived,
}

/// A person's hands moving one module into a well ([`Trunk::fold_by_hand`]): its height goes
/// from where it was to the well's, evenly over the fold's time, whatever the forces on it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Hand {
    module: Module,
    well: usize,
    from_mm: f64,
    to_mm: f64,
    over_s: f64,
    done_s: f64,
}

/// Values every step needs that depend on the parameters only (the same expressions, evaluated
/// once in [`Trunk::new`] instead of every millisecond).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Derived {
    /// Series bending stiffness for each (top basin, bottom basin), N·mm/rad.
    k_bend: [[f64; 4]; 2],
    /// Orifice areas, m²: inlet, normal leak, exhaust, the `leak` fault.
    inlet_m2: f64,
    leak_m2: f64,
    exhaust_m2: f64,
    fault_leak_m2: f64,
    /// The damping terms `c / dt` of the last step's `dt` (the bits of `dt`, then the terms).
    c_over_dt: (u64, [f64; 4]),
}

impl Derived {
    fn new(p: &TrunkParams) -> Self {
        Self {
            k_bend: core::array::from_fn(|t| {
                core::array::from_fn(|b| {
                    let kt = p.top_bending_n_mm_per_rad[t];
                    let kb = p.bottom_bending_n_mm_per_rad[b];
                    1.0 / (1.0 / kt + 1.0 / kb)
                })
            }),
            inlet_m2: orifice_area_m2(p.inlet_diameter_mm),
            leak_m2: orifice_area_m2(p.leak_diameter_mm),
            exhaust_m2: orifice_area_m2(p.exhaust_diameter_mm),
            fault_leak_m2: orifice_area_m2(p.fault_leak_diameter_mm),
            c_over_dt: (f64::NAN.to_bits(), [f64::NAN; 4]),
        }
    }
}

fn top_well(s: TopState) -> usize {
    match s {
        TopState::Folded => 0,
        TopState::Deployed => 1,
    }
}

fn bottom_well(s: BottomState) -> usize {
    match s {
        BottomState::Packed => 0,
        BottomState::Folded => 2,
        BottomState::Deployed => 3,
    }
}

/// Name of a well for traces: `F`/`D` on the top, `P`/`P½`/`F`/`D` on the bottom.
pub fn well_name(module: Module, well: usize) -> &'static str {
    match (module, well) {
        (Module::Top, 0) => "F",
        (Module::Top, _) => "D",
        (Module::Bottom, 0) => "P",
        (Module::Bottom, 1) => "P½",
        (Module::Bottom, 2) => "F",
        (Module::Bottom, _) => "D",
    }
}

impl Trunk {
    /// A trunk at rest in `state`, straight, at atmospheric pressure.
    pub fn new(params: TrunkParams, state: TrunkState) -> Self {
        let mut t = Self {
            derived: Derived::new(&params),
            params,
            heights_mm: [0.0; 2],
            bend: [0.0; 2],
            pv_j: 0.0,
            wells: [None; 2],
            last_well: [0; 2],
            tensions_n: [0.0; 3],
            hand: None,
        };
        t.place(state);
        t.pv_j = P_ATM_PA * t.volume_m3();
        t
    }

    /// Moves both modules into the wells of `state` (what a person folding by hand does), at
    /// the same gas amount.
    pub fn place(&mut self, state: TrunkState) {
        self.hand = None;
        self.set_module_well(Module::Top, top_well(state.top));
        self.set_module_well(Module::Bottom, bottom_well(state.bottom));
    }

    /// A person begins to fold one module into `well`, done `over_s` from now: each step
    /// moves it evenly toward the well (the gas flows as the volume changes: through the
    /// exhaust when it is open), and the last one leaves it there. A fold in zero time is
    /// [`Trunk::set_module_well`]. A fold already under way is finished first.
    pub fn fold_by_hand(&mut self, module: Module, well: usize, over_s: f64) {
        if let Some(h) = self.hand.take() {
            self.set_module_well(h.module, h.well);
        }
        let (curve, i) = match module {
            Module::Top => (&self.params.top, 0),
            Module::Bottom => (&self.params.bottom, 1),
        };
        let well = well.min(curve.wells().len() - 1);
        if over_s.is_nan() || over_s <= 0.0 {
            self.set_module_well(module, well);
            return;
        }
        self.hand = Some(Hand {
            module,
            well,
            from_mm: self.heights_mm[i],
            to_mm: curve.wells()[well].height_mm,
            over_s,
            done_s: 0.0,
        });
    }

    /// Whether a fold by hand is under way.
    pub fn folding_by_hand(&self) -> bool {
        self.hand.is_some()
    }

    /// Moves one module into `well` by hand, at once.
    pub fn set_module_well(&mut self, module: Module, well: usize) {
        let (curve, i) = match module {
            Module::Top => (&self.params.top, 0),
            Module::Bottom => (&self.params.bottom, 1),
        };
        let well = well.min(curve.wells().len() - 1);
        self.heights_mm[i] = curve.wells()[well].height_mm;
        self.wells[i] = Some(well);
        self.last_well[i] = well;
    }

    /// The model's parameters.
    pub fn params(&self) -> &TrunkParams {
        &self.params
    }

    /// Module heights `[top, bottom]`, mm.
    pub fn heights_mm(&self) -> [f64; 2] {
        self.heights_mm
    }

    /// Total height along the axis, mm.
    pub fn height_mm(&self) -> f64 {
        self.heights_mm[0] + self.heights_mm[1]
    }

    /// Bend angle of the tip axis, degrees, and its direction, degrees (0° toward tendon 0).
    pub fn bend_deg(&self) -> (f64, f64) {
        let theta = (self.bend[0] * self.bend[0] + self.bend[1] * self.bend[1]).sqrt();
        (
            theta.to_degrees(),
            self.bend[1].atan2(self.bend[0]).to_degrees(),
        )
    }

    /// Stable well of each module (`None` while snapping).
    pub fn wells(&self) -> [Option<usize>; 2] {
        self.wells
    }

    /// Gas volume (trunk + reservoir), m³.
    pub fn volume_m3(&self) -> f64 {
        self.params.plenum_m3 + self.params.area_mm2 * self.height_mm() * 1e-9
    }

    /// Absolute pressure, Pa.
    pub fn pressure_abs_pa(&self) -> f64 {
        self.pv_j / self.volume_m3()
    }

    /// Gauge pressure, kPa.
    pub fn pressure_kpa(&self) -> f64 {
        (self.pressure_abs_pa() - P_ATM_PA) * 1e-3
    }

    /// Sets the gas amount so that the gauge pressure is `kpa` at the present volume.
    pub fn set_gas_gauge_kpa(&mut self, kpa: f64) {
        self.pv_j = (P_ATM_PA + kpa * 1e3) * self.volume_m3();
    }

    /// Tendon tensions of the last step, N.
    pub fn tensions_n(&self) -> [f64; 3] {
        self.tensions_n
    }

    /// The trunk state, if both modules sit on the stable branch of a named state (`None`
    /// while snapping or with the bottom half-packed).
    pub fn state(&self) -> Option<TrunkState> {
        let top = match self.wells[0]? {
            0 => TopState::Folded,
            _ => TopState::Deployed,
        };
        let bottom = match self.wells[1]? {
            0 => BottomState::Packed,
            1 => return None,
            2 => BottomState::Folded,
            _ => BottomState::Deployed,
        };
        Some(TrunkState::new(top, bottom))
    }

    /// The trunk state the modules would relax to if every load were removed now.
    pub fn relaxed_state(&self) -> Option<TrunkState> {
        let top = match self.params.top.basin(self.heights_mm[0]) {
            0 => TopState::Folded,
            _ => TopState::Deployed,
        };
        let bottom = match self.params.bottom.basin(self.heights_mm[1]) {
            0 => BottomState::Packed,
            1 => return None,
            2 => BottomState::Folded,
            _ => BottomState::Deployed,
        };
        Some(TrunkState::new(top, bottom))
    }

    fn tendon_lengths(&self) -> [f64; 3] {
        let h = self.height_mm();
        let r = self.params.tendon_radius_mm;
        core::array::from_fn(|i| {
            let u = TENDON_DIR[i];
            h - r * (u[0] * self.bend[0] + u[1] * self.bend[1])
        })
    }

    /// The two modules' bending stiffnesses in series, for the basins they are in.
    fn bending_stiffness(&self) -> f64 {
        let p = &self.params;
        let t = p.top.basin(self.heights_mm[0]).min(1);
        let b = p.bottom.basin(self.heights_mm[1]).min(3);
        self.derived.k_bend[t][b]
    }

    /// Advances the trunk by `dt_s` under `act`; returns the snaps that completed in the step.
    // Index loops: this is 4×4 matrix assembly, clearer with indices.
    #[allow(clippy::needless_range_loop)]
    pub fn step(&mut self, dt_s: f64, act: &Actuation) -> heapless_snaps::Snaps {
        if self.derived.c_over_dt.0 != dt_s.to_bits() {
            let p = &self.params;
            let c = [
                p.damping_n_s_per_mm,
                p.damping_n_s_per_mm,
                p.bending_damping_n_mm_s_per_rad,
                p.bending_damping_n_mm_s_per_rad,
            ];
            self.derived.c_over_dt = (dt_s.to_bits(), c.map(|c| c / dt_s));
        }
        let c_over_dt = self.derived.c_over_dt.1;
        let p = &self.params;
        let area_m2 = p.area_mm2 * 1e-6;
        let r_t = p.tendon_radius_mm;
        let k_t = p.tendon_stiffness_n_per_mm;

        // Tendons: tension and which are taut.
        let lengths = self.tendon_lengths();
        let mut tension = [0.0; 3];
        let mut k_taut = [0.0; 3];
        for i in 0..3 {
            let free = p.tendon_slack_length_mm - act.pay_in_mm[i];
            if !act.tendon_broken[i] && lengths[i] > free {
                tension[i] = k_t * (lengths[i] - free);
                k_taut[i] = k_t;
            }
        }
        self.tensions_n = tension;

        // Axial load on the tip (tension positive) and its stiffness against height.
        let volume = self.volume_m3();
        let p_abs = self.pv_j / volume;
        let gas_force = (p_abs - P_ATM_PA) * area_m2;
        // dF/dH of the gas at constant amount: −p·A²/V (per mm of height).
        let gas_k = p_abs * area_m2 * area_m2 / volume * 1e-3;
        let sum_t: f64 = tension.iter().sum();
        let f_tip = gas_force - sum_t - p.tip_load_n - act.payload_n;
        let k_ax = gas_k + k_taut.iter().sum::<f64>();

        // Bending moment vector and its couplings.
        let (mut m, mut v) = ([0.0; 2], [0.0; 2]);
        let mut kbb = [[0.0; 2]; 2];
        for i in 0..3 {
            if k_taut[i] == 0.0 {
                // A slack tendon adds only zeros (its tension is 0 too).
                continue;
            }
            let u = TENDON_DIR[i];
            for a in 0..2 {
                m[a] += tension[i] * r_t * u[a];
                v[a] += k_taut[i] * r_t * u[a];
                for b in 0..2 {
                    kbb[a][b] += k_taut[i] * r_t * r_t * u[a] * u[b];
                }
            }
        }
        let k_bend = self.bending_stiffness();
        let curves = [&p.top, &p.bottom];
        let mut g = [0.0; 4];
        let mut jac = [[0.0; 4]; 4];
        for mi in 0..2 {
            let (f, k) = curves[mi].force_and_stiffness(self.heights_mm[mi]);
            g[mi] = f_tip - f;
            for mj in 0..2 {
                jac[mi][mj] = -k_ax;
            }
            // The snap branch's negative stiffness stays explicit (it drives the snap).
            jac[mi][mi] -= k.max(0.0);
            jac[mi][2] = v[0];
            jac[mi][3] = v[1];
            jac[2][mi] = v[0];
            jac[3][mi] = v[1];
        }
        for a in 0..2 {
            g[2 + a] = m[a] - k_bend * self.bend[a];
            for b in 0..2 {
                jac[2 + a][2 + b] = -kbb[a][b];
            }
            jac[2 + a][2 + a] -= k_bend;
        }
        // (C/dt − J)·Δx = G
        let mut a = [[0.0; 4]; 4];
        for r in 0..4 {
            for col in 0..4 {
                a[r][col] = -jac[r][col];
            }
            a[r][r] += c_over_dt[r];
        }
        let dx = solve4(a, g);
        self.heights_mm[0] += dx[0];
        self.heights_mm[1] += dx[1];
        self.bend[0] += dx[2];
        self.bend[1] += dx[3];
        let mut hand_done = None;
        if let Some(h) = self.hand.as_mut() {
            // The hands set the module's height, whatever the forces.
            h.done_s += dt_s;
            let i = match h.module {
                Module::Top => 0,
                Module::Bottom => 1,
            };
            // (1e-9: the sum of a thousand 1 ms steps is not exactly 1 s.)
            let f = (h.done_s / h.over_s + 1e-9).min(1.0);
            self.heights_mm[i] = h.from_mm + (h.to_mm - h.from_mm) * f;
            if f >= 1.0 {
                hand_done = Some((h.module, h.well));
            }
        }

        // Gas: flows at the new volume.
        let volume = self.volume_m3();
        let p_abs = self.pv_j / volume;
        let d = &self.derived;
        let mut flow = 0.0;
        if act.inlet_open {
            let a = d.inlet_m2;
            flow += exchange_pv(p.cd, a, p_abs, P_ATM_PA + p.supply_gauge_pa, volume, dt_s);
        }
        let mut vent_area = d.leak_m2;
        if act.exhaust_open {
            vent_area += d.exhaust_m2;
        }
        if act.fault_leak {
            vent_area += d.fault_leak_m2;
        }
        flow += exchange_pv(p.cd, vent_area, p_abs, P_ATM_PA, volume, dt_s);
        self.pv_j = (self.pv_j + flow * dt_s).max(1.0);

        // Snaps: a module arriving on a stable branch other than the one it left.
        let mut snaps = heapless_snaps::Snaps::new();
        for (mi, module) in [Module::Top, Module::Bottom].into_iter().enumerate() {
            let now = curves[mi].stable_well(self.heights_mm[mi]);
            if let Some(w) = now {
                if w != self.last_well[mi] {
                    snaps.push(Snap {
                        module,
                        from_well: self.last_well[mi],
                        to_well: w,
                    });
                    self.last_well[mi] = w;
                }
            }
            self.wells[mi] = now;
        }
        if let Some((module, well)) = hand_done {
            self.hand = None;
            self.set_module_well(module, well);
        }
        snaps
    }
}

/// Gaussian elimination with partial pivoting for the 4×4 step system (diagonally dominant
/// through the damping term, so never singular for dt > 0).
#[allow(clippy::needless_range_loop)]
fn solve4(mut a: [[f64; 4]; 4], mut b: [f64; 4]) -> [f64; 4] {
    for col in 0..4 {
        let mut piv = col;
        for r in col + 1..4 {
            if a[r][col].abs() > a[piv][col].abs() {
                piv = r;
            }
        }
        a.swap(col, piv);
        b.swap(col, piv);
        let d = a[col][col];
        if d.abs() < 1e-300 {
            continue;
        }
        for r in col + 1..4 {
            let f = a[r][col] / d;
            for k in col..4 {
                a[r][k] -= f * a[col][k];
            }
            b[r] -= f * b[col];
        }
    }
    let mut x = [0.0; 4];
    for r in (0..4).rev() {
        let mut s = b[r];
        for k in r + 1..4 {
            s -= a[r][k] * x[k];
        }
        x[r] = if a[r][r].abs() < 1e-300 {
            0.0
        } else {
            s / a[r][r]
        };
    }
    x
}

/// At most two snaps per step (one per module), without allocation.
pub mod heapless_snaps {
    use super::Snap;

    /// The snaps of one step.
    #[derive(Debug, Clone, Copy, Default)]
    pub struct Snaps {
        items: [Option<Snap>; 2],
    }

    impl Snaps {
        /// No snaps.
        pub fn new() -> Self {
            Self::default()
        }
        pub(crate) fn push(&mut self, s: Snap) {
            if let Some(slot) = self.items.iter_mut().find(|x| x.is_none()) {
                *slot = Some(s);
            }
        }
        /// Iterates the snaps.
        pub fn iter(&self) -> impl Iterator<Item = Snap> + '_ {
            self.items.iter().flatten().copied()
        }
        /// Whether there were none.
        pub fn is_empty(&self) -> bool {
            self.items[0].is_none()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn st(s: &str) -> TrunkState {
        s.parse().unwrap()
    }

    fn trunk(s: &str) -> Trunk {
        Trunk::new(TrunkParams::pdf().unwrap(), st(s))
    }

    #[test]
    fn tendon_directions_are_120_degrees_apart() {
        for (i, u) in TENDON_DIR.iter().enumerate() {
            let a = tendon_angle_rad(i);
            assert!((u[0] - a.cos()).abs() < 1e-15 && (u[1] - a.sin()).abs() < 1e-15);
        }
    }

    #[test]
    fn solve4_solves() {
        let a = [
            [4.0, 1.0, 0.0, 0.5],
            [1.0, 3.0, 0.2, 0.0],
            [0.0, 0.2, 5.0, 1.0],
            [0.5, 0.0, 1.0, 2.0],
        ];
        let x = [1.0, -2.0, 0.5, 3.0];
        let b: [f64; 4] = core::array::from_fn(|r| (0..4).map(|k| a[r][k] * x[k]).sum());
        let y = solve4(a, b);
        for i in 0..4 {
            assert!((x[i] - y[i]).abs() < 1e-12);
        }
    }

    #[test]
    fn every_state_is_at_rest_when_unloaded() {
        for s in TrunkState::ALL {
            let mut t = trunk(s.name());
            let h0 = t.height_mm();
            for _ in 0..2000 {
                assert!(t.step(1e-3, &Actuation::default()).is_empty(), "{s}");
            }
            assert_eq!(t.state(), Some(s));
            // Only the 0.5 N tip load sags it (top F well: 1.4 N/mm).
            assert!(
                (t.height_mm() - h0).abs() < 0.5,
                "{s}: {h0} -> {}",
                t.height_mm()
            );
            assert!(
                t.pressure_kpa().abs() < 0.1,
                "{s}: {} kPa",
                t.pressure_kpa()
            );
        }
    }

    #[test]
    fn a_fold_by_hand_moves_evenly_and_the_open_exhaust_lets_its_air_out() {
        // Packing the bottom under a deployed top (D&F → D&P) over 3 s: sealed, the gas is
        // squeezed as at once (Boyle); with the exhaust open it stays near ambient.
        let peak = |exhaust_open: bool| {
            let mut t = trunk("D&F");
            let h0 = t.heights_mm()[1];
            let p_at_once = {
                let mut u = t.clone();
                u.set_module_well(Module::Bottom, 0);
                u.pressure_kpa()
            };
            t.fold_by_hand(Module::Bottom, 0, 3.0);
            let act = Actuation {
                exhaust_open,
                ..Actuation::default()
            };
            let mut peak = 0.0_f64;
            for ms in 1..=3_000 {
                t.step(1e-3, &act);
                peak = peak.max(t.pressure_kpa());
                if ms == 1_500 {
                    // Half-way in time, half-way in height.
                    let h = t.heights_mm()[1];
                    let half = (h0 + t.params().bottom.wells()[0].height_mm) / 2.0;
                    assert!((h - half).abs() < 0.1, "{h} vs {half} mm");
                    assert!(t.folding_by_hand());
                }
            }
            assert!(!t.folding_by_hand());
            assert_eq!(t.state(), Some(st("D&P")));
            (peak, p_at_once)
        };
        let (sealed, at_once) = peak(false);
        assert!(
            (sealed - at_once).abs() < 0.05 * at_once,
            "{sealed} vs {at_once} kPa"
        );
        assert!(at_once > 5.0, "{at_once} kPa");
        let (open, _) = peak(true);
        assert!(open < 1.0, "{open} kPa with the exhaust open");
    }

    #[test]
    fn isothermal_compression_obeys_boyle() {
        // Valves closed: shortening the trunk raises p·V = const.
        let mut t = trunk("D&D");
        let pv0 = t.pressure_abs_pa() * t.volume_m3();
        t.heights_mm[0] -= 30.0;
        let pv1 = t.pressure_abs_pa() * t.volume_m3();
        assert!((pv0 - pv1).abs() < 1e-9 * pv0);
        let expected = P_ATM_PA * (t.volume_m3() + 30.0 * t.params.area_mm2 * 1e-9) / t.volume_m3();
        assert!((t.pressure_abs_pa() - expected).abs() < 1e-6);
    }

    /// Takes up the slack of `state`, then applies the geometry crate's constant-curvature
    /// length changes for a `deg` bend toward tendon 0; returns the bend the physics settles at.
    fn bend_under_geometry_lengths(state: &str, deg: f64) -> (f64, f64) {
        let mut t = trunk(state);
        t.params.tendon_radius_mm = 60.0;
        let slack = t.params.tendon_slack_length_mm - t.height_mm();
        let geo = geometry::tendon::TendonGeometry::new(60.0).unwrap();
        let dl = geo.length_changes(geometry::tendon::Bend::new(0.0, deg.to_radians()));
        let act = Actuation {
            pay_in_mm: dl.map(|d| slack - d),
            exhaust_open: true,
            ..Default::default()
        };
        for _ in 0..3000 {
            t.step(1e-3, &act);
        }
        assert_eq!(t.state(), Some(st(state)));
        t.bend_deg()
    }

    #[test]
    fn differential_pull_bends_a_flexible_trunk_as_constant_curvature_predicts() {
        // F&F is soft in bending: the bend comes close to the 20° the inextensible-tendon
        // kinematics predicts (less a little axial shortening under the tendon's pull).
        let (theta, phi) = bend_under_geometry_lengths("F&F", 20.0);
        assert!((15.0..=20.5).contains(&theta), "bend {theta}°");
        assert!(phi.abs() < 1.0, "direction {phi}°");
        // D&D is stiff: a 5° pull bends it about half as much as F&F (the stiff tendon
        // compresses the trunk instead; a 20° pull would buckle its top).
        let (theta_ff, _) = bend_under_geometry_lengths("F&F", 5.0);
        let (theta_dd, _) = bend_under_geometry_lengths("D&D", 5.0);
        assert!(
            theta_dd < 0.6 * theta_ff,
            "D&D bend {theta_dd}° vs F&F {theta_ff}°"
        );
    }

    #[test]
    fn d_and_d_holds_the_papers_5_7_kg_without_pressure_and_buckles_under_8_kg() {
        // §6.5: 5.7 kg on the tip of D&D, no air added. The smaller-β top buckles first.
        for (kg, expected) in [(5.7, "D&D"), (8.0, "F&D")] {
            let mut t = trunk("D&D");
            let act = Actuation {
                exhaust_open: true,
                payload_n: kg * 9.81,
                ..Default::default()
            };
            for _ in 0..3000 {
                t.step(1e-3, &act);
            }
            assert_eq!(t.relaxed_state(), Some(st(expected)), "{kg} kg");
        }
    }

    #[test]
    fn a_sealed_snap_changes_the_pressure_as_boyle_says() {
        // F&F sealed at 19 kPa plus a slow pull-up on the tip until the top pops: the volume
        // jump at constant gas amount must drop the pressure by p·ΔV/V.
        let mut t = trunk("F&F");
        t.set_gas_gauge_kpa(19.0);
        let mut pull = 0.0;
        let (p0, v0) = loop {
            pull += 0.01;
            let act = Actuation {
                payload_n: -pull,
                ..Default::default()
            };
            let before = (t.pressure_abs_pa(), t.volume_m3());
            let snaps = t.step(1e-3, &act);
            if t.wells()[0].is_none() || !snaps.is_empty() {
                break before;
            }
            assert!(pull < 50.0, "no snap");
        };
        let act = Actuation {
            payload_n: -pull,
            ..Default::default()
        };
        for _ in 0..500 {
            t.step(1e-3, &act);
        }
        assert_eq!(t.state(), Some(st("D&F")));
        let (p1, v1) = (t.pressure_abs_pa(), t.volume_m3());
        // The normal leak over 0.5 s is negligible: p·V is conserved within 0.1 %.
        assert!((p1 * v1 / (p0 * v0) - 1.0).abs() < 1e-3);
        let drop_kpa = (p0 - p1) * 1e-3;
        assert!(drop_kpa > 3.0, "{drop_kpa} kPa");
    }
}
