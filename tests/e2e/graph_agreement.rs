//! The planner's graph is the graph the simulator's physics discovers: every transition the
//! planner may plan happens in the simulated trunk under its actuation, and no other does.

use std::time::Instant;

use hil_sim::discovery::{discover, RigConfig};
use planner::graph::{kind_name, Graph};

#[test]
fn the_planners_graph_equals_the_simulators_discovered_graph() {
    let start = Instant::now();
    let discovered = discover(RigConfig::default());
    let mut found: Vec<(&str, &str, &str)> = discovered
        .edges
        .iter()
        .map(|e| (e.from.name(), e.to.name(), e.kind.name()))
        .collect();
    found.sort();
    let mut planned: Vec<(&str, &str, &str)> = Graph::nominal()
        .edges()
        .iter()
        .map(|e| (e.from().name(), e.to().name(), kind_name(e.kind())))
        .collect();
    planned.sort();
    assert_eq!(
        planned, found,
        "planner (left) vs discovered by the simulator (right)"
    );
    // Every state has its two explorations (pressure and tendons), so absent edges were tried.
    assert_eq!(discovered.outcomes.len(), 12);
    eprintln!("discovery took {:.2?}", start.elapsed());
}
