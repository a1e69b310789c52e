//! The transition planner: every pair has a plan, plans chain, costs add up, manual steps only
//! where the paper says no actuator can go.

use geometry::TrunkState;
use protocol::transitions::{TRANSITIONS, UNPACK_KPA};
use protocol::{StepKind, MAX_PLAN_STEPS};
use transition_graph::{CostModel, Graph, PlanError};

fn s(name: &str) -> TrunkState {
    name.parse().unwrap()
}

#[test]
fn every_pair_has_a_plan_that_chains_from_start_to_target() {
    let g = Graph::nominal();
    for from in TrunkState::ALL {
        for to in TrunkState::ALL {
            let plan = g
                .plan(from, to)
                .unwrap_or_else(|e| panic!("{from} → {to}: {e}"));
            assert_eq!((plan.from(), plan.target()), (from, to));
            let mut at = from;
            for step in plan.steps() {
                assert_eq!(step.edge.from(), at, "{from} → {to} does not chain");
                at = step.edge.to();
            }
            assert_eq!(at, to, "{from} → {to} ends in {at}");
            assert_eq!(plan.steps().is_empty(), from == to);
            let wire = plan.to_protocol(7).unwrap();
            assert_eq!(wire.plan_id, 7);
            assert_eq!(wire.steps.len(), plan.steps().len());
            assert!(wire.steps.len() <= MAX_PLAN_STEPS);
            for w in wire.steps.windows(2) {
                assert_eq!(w[0].to, w[1].from);
            }
        }
    }
}

#[test]
fn paths_into_d_and_p_contain_the_manual_step_and_no_others_do() {
    let g = Graph::nominal();
    for from in TrunkState::ALL {
        for to in TrunkState::ALL {
            let plan = g.plan(from, to).unwrap();
            let manual = plan
                .steps()
                .iter()
                .filter(|st| st.edge.kind() == StepKind::Manual)
                .count();
            if to == s("D&P") && from != to {
                assert_eq!(manual, 1, "{from} → {to}");
                let last = plan.steps().last().unwrap();
                assert_eq!((last.edge.from(), last.edge.to()), (s("D&F"), s("D&P")));
            } else {
                // D&P is the only state a person must help reach; leaving it is actuated.
                assert_eq!(manual, 0, "{from} → {to}");
            }
        }
    }
}

#[test]
fn the_papers_demo_paths_are_the_cheapest() {
    let g = Graph::nominal();
    let names = |from: &str, to: &str| -> Vec<TrunkState> {
        let plan = g.plan(s(from), s(to)).unwrap();
        let mut v = vec![plan.from()];
        v.extend(plan.steps().iter().map(|st| st.edge.to()));
        v
    };
    // Manipulation demo and load bearing (§6.2): pressure from as-manufactured.
    assert_eq!(names("F&P", "D&F"), [s("F&P"), s("F&F"), s("D&F")]);
    assert_eq!(
        names("F&P", "D&D"),
        [s("F&P"), s("F&F"), s("D&F"), s("D&D")]
    );
    // Solar demo: tendons fold the top first.
    assert_eq!(names("D&D", "F&D"), [s("D&D"), s("F&D")]);
    // Back to as-manufactured by tendons only.
    assert_eq!(
        names("D&D", "F&P"),
        [s("D&D"), s("F&D"), s("F&F"), s("F&P")]
    );
    // D&P: up by pressure, then pack the bottom by hand.
    assert_eq!(
        names("F&P", "D&P"),
        [s("F&P"), s("F&F"), s("D&F"), s("D&P")]
    );
}

#[test]
fn plan_cost_is_the_sum_of_its_edges_and_matches_the_cost_model() {
    let costs = CostModel::default();
    let g = Graph::with_costs(costs);
    // Every edge costs overhead + its primitives.
    for (e, t) in g.edges().iter().zip(TRANSITIONS.iter()) {
        let expected = costs.step_overhead_s
            + t.primitives
                .iter()
                .map(|p| costs.primitive_s(p))
                .sum::<f64>();
        assert!((e.cost_s - expected).abs() < 1e-12);
        assert!(e.cost_s > 0.0);
    }
    // F&P → F&F: inflate to UNPACK_KPA at 5 kPa/s + vent 1.5 s + overhead 0.5 s.
    let plan = g.plan(s("F&P"), s("F&F")).unwrap();
    let expected = f64::from(UNPACK_KPA) / 5.0 + 1.5 + 0.5;
    assert!(
        (plan.cost_s() - expected).abs() < 1e-6,
        "{} vs {expected}",
        plan.cost_s()
    );
    // A manual step dominates: F&P → D&P costs more than the manual time alone.
    let dp = g.plan(s("F&P"), s("D&P")).unwrap();
    assert!(dp.cost_s() > costs.manual_s);
    let sum: f64 = dp.steps().iter().map(|st| st.edge.cost_s).sum();
    assert!((dp.cost_s() - sum).abs() < 1e-12);
}

#[test]
fn costs_steer_the_search_and_every_pair_stays_reachable() {
    // With pressure made very slow, D&D → F&F still goes by tendons (two tendon steps), and
    // every plan is still found.
    let slow_air = CostModel {
        inflate_kpa_per_s: 0.01,
        ..CostModel::default()
    };
    let g = Graph::with_costs(slow_air);
    let plan = g.plan(s("D&D"), s("F&F")).unwrap();
    assert!(plan
        .steps()
        .iter()
        .all(|st| st.edge.kind() == StepKind::Tendon));
    for from in TrunkState::ALL {
        for to in TrunkState::ALL {
            assert!(g.plan(from, to).is_ok());
        }
    }
}

#[test]
fn replanning_starts_from_the_reported_state_and_avoids_failed_edges() {
    let g = Graph::nominal();
    // The step F&P → F&F overshot to D&F (a surprise): go on from D&F, not from F&F.
    let plan = g
        .replan(s("D&F"), s("D&D"), &[(s("F&P"), s("F&F"))])
        .unwrap();
    assert_eq!(plan.from(), s("D&F"));
    let path: Vec<_> = plan
        .steps()
        .iter()
        .map(|st| (st.edge.from(), st.edge.to()))
        .collect();
    assert_eq!(path, [(s("D&F"), s("D&D"))]);
    // A failed edge is not planned again: D&D → F&F avoiding D&D → F&D has no way.
    assert!(g
        .replan(s("D&D"), s("F&F"), &[(s("D&D"), s("F&D"))])
        .is_err());
    // D&F is entered only from F&F (pressure) and D&P (pressure), and D&P only from D&F: with
    // F&F → D&F failed there is no way, and the planner says so rather than loop.
    let err = g.replan(s("F&F"), s("D&F"), &[(s("F&F"), s("D&F"))]);
    // D&F is entered from F&F (pressure) and from D&P (pressure): D&P itself needs D&F first.
    assert_eq!(
        err.unwrap_err(),
        PlanError::Unreachable {
            from: s("F&F"),
            to: s("D&F")
        }
    );
}

#[test]
fn a_plan_explains_every_step() {
    let g = Graph::nominal();
    let plan = g.plan(s("F&P"), s("D&P")).unwrap();
    let text = plan.to_string();
    for needle in [
        "F&P → D&P",
        "pneumatic",
        "manual",
        format!("inflate toward {UNPACK_KPA:.1} kPa").as_str(),
        "vent to 0.0 kPa",
        "by hand",
        "why:",
        "self-packing",
    ] {
        assert!(text.contains(needle), "missing {needle:?} in\n{text}");
    }
    assert_eq!(text.matches("why:").count(), plan.steps().len());
    assert!(g
        .plan(s("D&D"), s("D&D"))
        .unwrap()
        .to_string()
        .contains("nothing to do"));
}
