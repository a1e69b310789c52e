//! Pneumatics: ideal gas at constant temperature, flow through sharp-edged orifices.
//!
//! The gas in the trunk and its reservoir is tracked as the product `p·V` (joules, absolute
//! pressure times volume), which at constant temperature is proportional to the gas mass. The
//! temperature is held constant because the trunk's thin TPU walls and the reservoir exchange
//! heat far faster than the seconds a step takes, and pressure changes are small (tens of kPa on
//! 101 kPa): an adiabatic snap would read at most ~40 % more pressure change for a few hundred
//! ms (docs/simulator.md).

/// Standard atmospheric pressure, Pa.
pub const P_ATM_PA: f64 = 101_325.0;
/// Specific gas constant of air, J/(kg·K).
pub const R_AIR: f64 = 287.05;
/// Gas temperature, K (20 °C lab).
pub const T_K: f64 = 293.15;
/// Heat capacity ratio of air.
pub const GAMMA: f64 = 1.4;

/// Critical pressure ratio (2/(γ+1))^(γ/(γ−1)): below it the orifice flow is choked.
pub fn critical_ratio() -> f64 {
    (2.0 / (GAMMA + 1.0)).powf(GAMMA / (GAMMA - 1.0))
}

/// The flow function's square, ψ²(r) = 2γ/((γ−1)RT)·(r^(2/γ) − r^((γ+1)/γ)), for a pressure
/// ratio r at or above the critical ratio.
fn psi_squared_exact(r: f64) -> f64 {
    2.0 * GAMMA / ((GAMMA - 1.0) * R_AIR * T_K)
        * (r.powf(2.0 / GAMMA) - r.powf((GAMMA + 1.0) / GAMMA))
}

/// Entries of the ψ² table over r ∈ [critical ratio, 1].
const PSI_TABLE_LEN: usize = 1024;

/// ψ² is smooth in r (it is the square root that is stiff near r = 1), so a linearly
/// interpolated table of ψ² is within 1e-6 relative of the exact law and saves two `powf` per
/// orifice per step (the simulator evaluates three orifices every millisecond).
fn psi_table() -> &'static [f64; PSI_TABLE_LEN + 1] {
    static TABLE: std::sync::OnceLock<[f64; PSI_TABLE_LEN + 1]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let rc = critical_ratio();
        core::array::from_fn(|i| {
            psi_squared_exact(rc + (1.0 - rc) * i as f64 / PSI_TABLE_LEN as f64)
        })
    })
}

fn psi_squared(r: f64) -> f64 {
    let rc = critical_ratio_const();
    let x = ((r - rc) / (1.0 - rc)).clamp(0.0, 1.0) * PSI_TABLE_LEN as f64;
    let i = (x as usize).min(PSI_TABLE_LEN - 1);
    let f = x - i as f64;
    let t = psi_table();
    t[i] + (t[i + 1] - t[i]) * f
}

/// The critical ratio of air, as a constant (checked against [`critical_ratio`] in the tests).
const fn critical_ratio_const() -> f64 {
    0.528_281_787_717_174_4
}

/// Mass flow (kg/s) through an orifice of `area_m2` with discharge coefficient `cd` from the
/// absolute pressure `p_up_pa` to `p_down_pa` (zero if `p_down ≥ p_up`): the ideal
/// compressible-flow (Saint-Venant–Wantzel) law, choked below the critical ratio.
pub fn orifice_mass_flow(cd: f64, area_m2: f64, p_up_pa: f64, p_down_pa: f64) -> f64 {
    if p_down_pa >= p_up_pa || p_up_pa <= 0.0 {
        return 0.0;
    }
    let r = (p_down_pa / p_up_pa).max(critical_ratio_const());
    cd * area_m2 * p_up_pa * psi_squared(r).max(0.0).sqrt()
}

/// Flow of `p·V` (W = J/s) through the orifice: mass flow × R·T.
pub fn orifice_pv_flow(cd: f64, area_m2: f64, p_up_pa: f64, p_down_pa: f64) -> f64 {
    orifice_mass_flow(cd, area_m2, p_up_pa, p_down_pa) * R_AIR * T_K
}

/// Area of a circular orifice of `diameter_mm`, m².
pub fn orifice_area_m2(diameter_mm: f64) -> f64 {
    let r = diameter_mm * 0.5e-3;
    core::f64::consts::PI * r * r
}

/// Signed `p·V` flow (W) between a volume at `p_pa` and a reservoir at `p_res_pa` (positive
/// into the volume), limited so that one step of `dt_s` cannot carry the volume past the
/// reservoir's pressure: the orifice law is stiff near equal pressures (√Δp), and an explicit
/// step would otherwise overshoot and chatter.
pub fn exchange_pv(
    cd: f64,
    area_m2: f64,
    p_pa: f64,
    p_res_pa: f64,
    volume_m3: f64,
    dt_s: f64,
) -> f64 {
    let flow = if p_res_pa > p_pa {
        orifice_pv_flow(cd, area_m2, p_res_pa, p_pa)
    } else {
        -orifice_pv_flow(cd, area_m2, p_pa, p_res_pa)
    };
    let max_pv = (p_res_pa - p_pa) * volume_m3 / dt_s;
    if flow >= 0.0 {
        flow.min(max_pv.max(0.0))
    } else {
        flow.max(max_pv.min(0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn critical_ratio_of_air_is_0_528() {
        assert!((critical_ratio() - 0.5283).abs() < 1e-4);
        assert!((critical_ratio() - critical_ratio_const()).abs() < 1e-15);
    }

    #[test]
    fn the_flow_table_matches_the_exact_law() {
        let rc = critical_ratio();
        for i in 0..=10_000 {
            let r = rc + (1.0 - rc) * i as f64 / 10_000.0;
            let exact = psi_squared_exact(r);
            let scale = psi_squared_exact(rc);
            assert!((psi_squared(r) - exact).abs() <= 1e-6 * scale, "r = {r}");
        }
    }

    #[test]
    fn choked_flow_matches_the_textbook_constant() {
        // Choked: m = Cd A p0 sqrt(γ/(R T)) (2/(γ+1))^((γ+1)/(2(γ−1))) = 0.0404 A p0 / sqrt(T).
        let a = orifice_area_m2(1.0);
        let m = orifice_mass_flow(1.0, a, 500e3, 101e3);
        let textbook = 0.040418 * a * 500e3 / T_K.sqrt();
        assert!((m / textbook - 1.0).abs() < 1e-3, "{m} vs {textbook}");
        // Below the critical ratio, the flow does not depend on the downstream pressure.
        assert_eq!(m, orifice_mass_flow(1.0, a, 500e3, 50e3));
    }

    #[test]
    fn subsonic_flow_approaches_bernoulli_for_small_drops() {
        // For Δp ≪ p: m ≈ Cd A sqrt(2 ρ Δp).
        let a = orifice_area_m2(2.0);
        let (p_up, p_dn) = (102_325.0, P_ATM_PA);
        let rho = p_up / (R_AIR * T_K);
        let bernoulli = a * (2.0 * rho * (p_up - p_dn)).sqrt();
        let m = orifice_mass_flow(1.0, a, p_up, p_dn);
        assert!((m / bernoulli - 1.0).abs() < 0.01, "{m} vs {bernoulli}");
        assert_eq!(orifice_mass_flow(1.0, a, p_dn, p_up), 0.0);
    }

    #[test]
    fn one_step_never_overshoots_the_reservoir_pressure() {
        let a = orifice_area_m2(5.0);
        let v = 1e-6; // a tiny volume: an unlimited explicit step would overshoot wildly
        let p = 150e3;
        let pv = exchange_pv(0.8, a, p, P_ATM_PA, v, 1e-3);
        let p_after = p + pv * 1e-3 / v;
        assert!(p_after >= P_ATM_PA - 1e-6, "{p_after}");
        assert!(pv < 0.0);
    }
}
