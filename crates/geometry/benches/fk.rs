//! Forward kinematics throughput: module transforms per second.
//!
//! `cargo bench -p geometry --bench fk`

// `criterion_group!` generates an undocumented `pub fn benches`.
#![allow(missing_docs)]

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use geometry::{fk, ModuleDesign, Pose, ShapeState};
use nalgebra::Point3;

const MODULES: usize = 64;

fn stack() -> Vec<(ModuleDesign, ShapeState)> {
    let golden = ModuleDesign::new(3, 31.717_474_411_461_005).unwrap();
    let packed = ModuleDesign::new(3, 35.0).unwrap();
    (0..MODULES)
        .map(|k| {
            let d = if k % 2 == 0 { golden } else { packed };
            let s = d.shape_states().nth(k % 8).unwrap();
            (d, s)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let modules = stack();
    let poses: Vec<Pose> = modules.iter().map(|(d, s)| d.pose(*s)).collect();
    let mut out = vec![Point3::origin(); MODULES];

    let mut g = c.benchmark_group("fk");
    g.throughput(Throughput::Elements(MODULES as u64));
    g.bench_function("tips_from_poses_64", |b| {
        b.iter(|| fk::fill_tips(black_box(&poses).iter().copied(), &mut out).unwrap())
    });
    g.bench_function("tips_from_states_64", |b| {
        b.iter(|| fk::fill_tips_of_states(black_box(&modules).iter().copied(), &mut out).unwrap())
    });
    g.finish();

    let mut g = c.benchmark_group("module");
    g.throughput(Throughput::Elements(1));
    let m = modules[5];
    g.bench_function("state_info_3d_verification", |b| {
        b.iter(|| black_box(m.0).state_info(black_box(m.1)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
