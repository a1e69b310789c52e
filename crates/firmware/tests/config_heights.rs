//! The controller's `f32` state heights against the geometry crate's `f64` closed forms they
//! replace on the board (deployed d = tan β, folded d = √(tan²β − tan²(90°/n))).

use firmware::CraneConfig;
use geometry::{BottomState, ModuleDesign, TopState, TrunkState};

#[test]
fn f32_heights_match_the_geometry_crate_over_the_design_range() {
    let mut worst: f64 = 0.0;
    for n in 3u8..=12 {
        for tenth in 100..=800 {
            let beta = tenth as f32 / 10.0;
            let mut cfg = CraneConfig::default();
            cfg.geometry.top.n = n;
            cfg.geometry.top.beta_deg = beta;
            cfg.geometry.bottom.n = n;
            cfg.geometry.bottom.beta_deg = beta;
            let d = ModuleDesign::new(u32::from(n), f64::from(beta)).unwrap();
            let edge = f64::from(cfg.geometry.top.edge_mm);
            let layers = f64::from(cfg.geometry.top.layers);
            for (state, want) in [
                (
                    TrunkState::new(TopState::Deployed, BottomState::Deployed),
                    2.0 * layers * d.w() * edge,
                ),
                (
                    TrunkState::new(TopState::Folded, BottomState::Folded),
                    2.0 * layers * d.folded_d().unwrap_or(0.0) * edge,
                ),
            ] {
                let got = f64::from(cfg.trunk_height_mm(state).expect("a valid design"));
                let err = (got - want).abs() / want.max(1.0);
                worst = worst.max(err);
                assert!(err < 1e-4, "n {n} β {beta}: {got} vs {want} ({state})");
            }
        }
    }
    eprintln!("worst relative error {worst:.2e}");
}

#[test]
fn an_invalid_module_has_no_height() {
    let mut cfg = CraneConfig::default();
    cfg.geometry.top.beta_deg = 90.0;
    assert_eq!(
        cfg.trunk_height_mm(TrunkState::new(TopState::Deployed, BottomState::Deployed)),
        None
    );
    cfg.geometry.top.beta_deg = 30.0;
    cfg.geometry.top.n = 2;
    assert_eq!(
        cfg.trunk_height_mm(TrunkState::new(TopState::Folded, BottomState::Folded)),
        None
    );
}
