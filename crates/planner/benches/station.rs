//! Station planner benchmark: the paper's solar station (four n = 3, β = 31.72° modules, the
//! top two adjustable: 64 configurations) at the Virginia Tech bus stop on the June solstice,
//! a whole day at 1-minute steps (1440 samples). Prints the median wall time of each stage
//! over repeated runs (a plain bench binary, like `ik`).
//!
//! `cargo bench -p planner --bench station`. Recorded figures: BENCHMARKS.md (## station).

use std::time::{Duration, Instant};

use geometry::orient::Heading;
use geometry::ModuleDesign;
use planner::station::{Station, SunDirection};
use planner::sun::{self, Atmosphere, DayGrid, DeltaT, Site};

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn time<T>(runs: usize, mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut out = None;
    let times = (0..runs)
        .map(|_| {
            let t = Instant::now();
            out = Some(std::hint::black_box(f()));
            t.elapsed()
        })
        .collect();
    (median(times), out.expect("at least one run"))
}

fn main() {
    let site = Site::new(37.2296, -80.4139, 634.0).expect("site");
    let grid = DayGrid::new(
        sun::parse_date("2025-06-21").expect("date"),
        sun::parse_offset("-04:00").expect("tz"),
        sun::parse_clock("00:00").expect("from"),
        sun::parse_clock("23:59").expect("to"),
        sun::parse_duration("1m").expect("every"),
    )
    .expect("grid");
    let air = Atmosphere::default();
    let dt = Some(DeltaT::seconds(69.2).expect("ΔT"));
    let runs = 21;
    let (t_sun, (_, samples)) = time(runs, || sun::day(&site, &grid, dt, &air).expect("sun"));
    let suns: Vec<SunDirection> = samples
        .iter()
        .map(|s| SunDirection::from_compass(s.sun.azimuth_deg, s.sun.elevation_deg, s.sun.up))
        .collect();
    let d = ModuleDesign::new(3, 31.72).expect("design");
    let (t_build, station) = time(runs, || {
        Station::new(vec![d; 4], 2, None, Heading::default(), false).expect("station")
    });
    let (t_scores, scores) = time(runs, || station.scores(&suns));
    let (t_free, free) = time(runs, || station.best_each(&scores));
    println!(
        "station: {} samples (1-minute steps, 24 h), {} configurations",
        suns.len(),
        station.configurations().len()
    );
    println!("  sun positions (SPA, 2 per sample)  {:>10.3?}", t_sun);
    println!("  configurations (fk of 64 stacks)   {:>10.3?}", t_build);
    println!("  scores (T x C)                      {:>10.3?}", t_scores);
    println!(
        "  best each sample ({} refolds)       {:>10.3?}",
        free.changes, t_free
    );
    for k in [2usize, 4, 6] {
        let (t_k, plan) = time(runs, || station.best_with_changes(&scores, k).expect("dp"));
        println!(
            "  best with <= {k} refolds (DP)        {:>10.3?}   total {:.3}",
            t_k, plan.total
        );
    }
    let (t_all, _) = time(runs, || {
        let (_, samples) = sun::day(&site, &grid, dt, &air).expect("sun");
        let suns: Vec<SunDirection> = samples
            .iter()
            .map(|s| SunDirection::from_compass(s.sun.azimuth_deg, s.sun.elevation_deg, s.sun.up))
            .collect();
        let scores = station.scores(&suns);
        station.best_with_changes(&scores, 4).expect("dp")
    });
    println!("  whole plan, sun + DP (K = 4)        {:>10.3?}", t_all);
}
