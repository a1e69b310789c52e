//! Every (initial, target) pair through the real `host-tool` binary against the simulator on a
//! pty: the device reports the target, and the simulator's physics agrees. That includes the
//! tendon edges `F&D → F&F` and `F&F → F&P`, whose snaps make no pressure spike under the
//! pinning tendons: the controller cannot confirm them without a calibration profile, and the
//! simulated operator identifies the state (docs/firmware.md).

use std::time::{Duration, Instant};

use e2e::{host_tool, parallel, STATES};

/// Concurrent plans (each a host-tool process with the simulator in-process, unpaced).
const THREADS: usize = 2;
const LIMIT: Duration = Duration::from_secs(60);

#[test]
fn all_36_plans_reach_their_target() {
    let pairs: Vec<(&str, &str)> = STATES
        .iter()
        .flat_map(|a| STATES.iter().map(move |b| (*a, *b)))
        .collect();
    let start = Instant::now();
    let results = parallel(pairs.clone(), THREADS, |(from, to)| {
        let out = host_tool(
            &[
                "plan",
                "--target",
                to,
                "--sim",
                "--sim-initial",
                from,
                "--json",
            ],
            LIMIT,
        );
        (from, to, out)
    });
    let wall = start.elapsed();
    eprintln!("36 plans against the simulator (in-process, {THREADS} at a time): {wall:.2?}");
    let mut failures = Vec::new();
    let mut reached = 0;
    for (from, to, out) in &results {
        let v = out.json();
        let plan = planner::graph::Graph::nominal()
            .plan(from.parse().unwrap(), to.parse().unwrap())
            .unwrap();
        let ok = out.code() == 0
            && v["ok"] == true
            && v["from"] == *from
            && v["target"] == *to
            && v["final_state"] == *to
            && v["error"].is_null()
            && v["sim"]["true_state"] == *to
            && v["sim"]["actuators_safe"] == true;
        if !ok {
            failures.push(format!("{from} → {to}: exit {} {v}", out.code()));
            continue;
        }
        reached += 1;
        let steps = v["steps"].as_array().expect("steps is an array");
        let expected = plan;
        assert_eq!(steps.len(), expected.steps().len(), "{from} → {to}: {v}");
        let mut at = *from;
        for (s, e) in steps.iter().zip(expected.steps()) {
            assert_eq!(s["from"], at, "{from} → {to}: steps chain");
            assert_eq!(s["to"], e.edge.to().name());
            assert_eq!(s["kind"], planner::graph::kind_name(e.edge.kind()));
            assert!(e2e::step_ended_honestly(s, &v), "{from} → {to}: {v}");
            let ms = s["duration_ms"].as_u64().expect("a duration");
            assert!(
                ms > 0 && u64::from(e.edge.transition.timeout_ms) >= ms,
                "{s}"
            );
            at = s["to"].as_str().unwrap();
        }
        let max = v["sim"]["max_pressure_kpa"].as_f64().unwrap();
        let limit = v["sim"]["pressure_limit_kpa"].as_f64().unwrap();
        assert!(max <= limit, "{from} → {to}: {max} kPa > {limit} kPa");
    }
    assert!(
        failures.is_empty(),
        "{} of 36 failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
    assert_eq!(reached, 36);
}
