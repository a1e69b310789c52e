//! Processor in the loop for the tasks: the first part of the manipulation demonstration
//! (§6.3: grasp in F&P, carry to F&F, place bent the other way, straighten) with the board's
//! own `uno-r4` ELF in the RA4M1 emulator driving the simulated crane and its world.

use geometry::TrunkState;
use hil_sim::host::SimHost;
use hil_sim::world::{Object, World};
use hil_sim::{Sim, SimOptions};
use planner::task::{bend_primitive, step_within, Workspace};
use protocol::{Primitive, Step, StepKind};

fn run(host: &mut SimHost, sim: &mut Sim, id: u16, steps: &[Step]) {
    let (ok, _) = host
        .run_plan(sim, id, steps, 60_000)
        .expect("the plan ends");
    assert!(ok, "plan {id}: {:?}", sim.ground_truth());
    assert!(sim.board_error().is_none(), "{:?}", sim.board_error());
}

#[test]
fn the_elf_grasps_carries_and_places_an_object() {
    let elf = hil_sim::elf_board::built_elf_path();
    assert!(
        elf.is_file(),
        "{} is missing: build it with `cargo firmware`",
        elf.display()
    );
    let fp: TrunkState = "F&P".parse().unwrap();
    let ff: TrunkState = "F&F".parse().unwrap();
    let mut sim = Sim::try_new(SimOptions {
        initial: fp,
        firmware_elf: Some(elf),
        ..SimOptions::default()
    })
    .expect("the ELF loads");
    sim.run_for(50);
    // The workspace the host plans with on the simulator (calibrated against it).
    let cfg = *sim.crane_config();
    let limits = Workspace::held_limits(
        TrunkState::ALL.map(|s| cfg.geometry.bend_limit_deg(s).map(f64::from)),
        f64::from(cfg.geometry.take_up_margin_mm),
        f64::from(cfg.geometry.tendon_radius_mm),
    );
    let ws = Workspace::of_crane(&cfg.geometry, limits).unwrap();
    let ws = hil_sim::world::calibrate(ws, &cfg.geometry).unwrap();
    let at = ws.tip(fp, 0.0, 0.0).unwrap().position_mm;
    let place = ws.tip(ff, 15.0, 180.0).unwrap().position_mm;
    let object = Object::parse(&format!("low:{},{},{},0.05", at[0], at[1], at[2])).unwrap();
    let closed = sim.ground_truth().gripper_closed;
    *sim.world_mut() = World::with(vec![object], 0.0).unwrap();
    sim.world_mut().set_gripper(closed);
    let mut host = SimHost::new();
    host.hello(&mut sim).expect("the ELF answers the handshake");

    let grip = |s, close| step_within(s, StepKind::Tendon, &[Primitive::Gripper { close }]);
    run(&mut host, &mut sim, 1, &[grip(fp, false)]);
    run(&mut host, &mut sim, 2, &[grip(fp, true)]);
    assert!(sim.world().objects()[0].held, "{:?}", sim.world());
    let carry: Vec<Step> = planner::graph::Graph::nominal()
        .plan(fp, ff)
        .unwrap()
        .steps()
        .iter()
        .map(|s| s.to_protocol())
        .collect();
    run(&mut host, &mut sim, 3, &carry);
    let n = ws.nearest_in(ff, place).unwrap();
    assert!(n.distance_mm < 1e-6);
    let tg =
        geometry::tendon::TendonGeometry::new(f64::from(cfg.geometry.tendon_radius_mm)).unwrap();
    let cmd = tg.command_for(n.bend, f64::from(cfg.geometry.take_up_margin_mm));
    run(
        &mut host,
        &mut sim,
        4,
        &[step_within(ff, StepKind::Tendon, &[bend_primitive(cmd)])],
    );
    run(&mut host, &mut sim, 5, &[grip(ff, false)]);
    let straight = tg.command_for(geometry::tendon::Bend::STRAIGHT, 0.0);
    run(
        &mut host,
        &mut sim,
        6,
        &[step_within(
            ff,
            StepKind::Tendon,
            &[bend_primitive(straight)],
        )],
    );
    // The verdict against the truth: on the table, below the place point within 5 mm.
    let o = &sim.world().objects()[0];
    let d = (o.position_mm[0] - place[0]).hypot(o.position_mm[1] - place[1]);
    assert!(!o.held && o.position_mm[2] == 0.0, "{o:?}");
    assert!(d <= 5.0, "{d:.2} mm from below the place point: {o:?}");
    assert_eq!(sim.ground_truth().true_state, Some(ff));
    eprintln!(
        "ELF: the object placed {d:.2} mm from below its place point at {} ms virtual",
        sim.now_ms()
    );
}
