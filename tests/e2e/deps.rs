//! The workspace's dependency graph is the one ARCHITECTURE.md states, edge by edge, and its
//! licences and feature boundaries hold per binary (read from `cargo metadata` and `cargo tree`,
//! what cargo itself resolves).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

/// One edge between two workspace crates: from, to, kind (`normal`, `dev`, `build`), optional.
type Edge = (String, String, String, bool);

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn cargo(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "cargo {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("cargo prints UTF-8")
}

/// The edges between workspace members that the manifests declare.
fn declared_edges() -> BTreeSet<Edge> {
    let meta: serde_json::Value = serde_json::from_str(&cargo(&[
        "metadata",
        "--format-version",
        "1",
        "--no-deps",
        "--locked",
        "--offline",
    ]))
    .expect("cargo metadata is JSON");
    let packages = meta["packages"].as_array().expect("packages");
    let members: BTreeSet<&str> = packages
        .iter()
        .map(|p| p["name"].as_str().expect("a name"))
        .collect();
    let mut edges = BTreeSet::new();
    for p in packages {
        for d in p["dependencies"].as_array().expect("dependencies") {
            let to = d["name"].as_str().expect("a dependency name");
            if members.contains(to) {
                edges.insert((
                    p["name"].as_str().unwrap().to_owned(),
                    to.to_owned(),
                    d["kind"].as_str().unwrap_or("normal").to_owned(),
                    d["optional"].as_bool().unwrap_or(false),
                ));
            }
        }
    }
    edges
}

/// The edges ARCHITECTURE.md lists under "Dependency edges": lines of the form
/// ``- `from` → `a`, `b`; dev (…): `c`; optional (…): `d` ``.
fn documented_edges(text: &str) -> BTreeSet<Edge> {
    let section = text
        .split("### Dependency edges")
        .nth(1)
        .expect("ARCHITECTURE.md has a \"### Dependency edges\" section");
    let mut edges = BTreeSet::new();
    for line in section.lines().take_while(|l| !l.starts_with("###")) {
        let Some(rest) = line.strip_prefix("- `") else {
            continue;
        };
        let (from, rest) = rest.split_once("` → ").expect("- `from` → …");
        for group in rest.split(';') {
            let group = group.trim();
            let (kind, optional, names) = if let Some(g) = group.strip_prefix("dev") {
                ("dev", false, g)
            } else if let Some(g) = group.strip_prefix("optional") {
                ("normal", true, g)
            } else {
                ("normal", false, group)
            };
            // Skip a "(…):" qualifier after the kind.
            let names = names.split_once(':').map_or(names, |(_, n)| n);
            for name in names.split(',') {
                let name = name.trim().trim_matches('`').trim_end_matches('.');
                assert!(!name.is_empty(), "an empty name in {line:?}");
                edges.insert((from.to_owned(), name.to_owned(), kind.to_owned(), optional));
            }
        }
    }
    edges
}

#[test]
fn architecture_md_lists_every_dependency_edge_and_no_other() {
    let text = std::fs::read_to_string(root().join("ARCHITECTURE.md")).expect("ARCHITECTURE.md");
    let documented = documented_edges(&text);
    let declared = declared_edges();
    let missing: Vec<_> = declared.difference(&documented).collect();
    let stale: Vec<_> = documented.difference(&declared).collect();
    assert!(
        missing.is_empty() && stale.is_empty(),
        "ARCHITECTURE.md's dependency edges differ from the manifests: \
         not listed there {missing:?}; listed but not declared {stale:?}"
    );
}

#[test]
fn the_dependency_graph_has_no_cycle_even_through_dev_dependencies() {
    let edges = declared_edges();
    let mut out: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for (from, to, _, _) in &edges {
        out.entry(from).or_default().push(to);
    }
    // Depth-first search with the path on a stack: a back edge is a cycle.
    fn visit<'a>(
        n: &'a str,
        out: &BTreeMap<&'a str, Vec<&'a str>>,
        path: &mut Vec<&'a str>,
        done: &mut BTreeSet<&'a str>,
    ) {
        if done.contains(n) {
            return;
        }
        if let Some(i) = path.iter().position(|p| *p == n) {
            panic!("dependency cycle: {}", path[i..].join(" → ") + " → " + n);
        }
        path.push(n);
        for m in out.get(n).into_iter().flatten() {
            visit(m, out, path, done);
        }
        path.pop();
        done.insert(n);
    }
    let mut done = BTreeSet::new();
    for n in out.keys() {
        visit(n, &out, &mut Vec::new(), &mut done);
    }
    assert!(done.contains("host-tool") && done.contains("firmware"));
}

/// The crates (name, licence) a package's own build links, its features resolved as a user's
/// `cargo install` / `cargo build -p` resolves them.
fn linked(package: &str, extra: &[&str]) -> Vec<(String, String)> {
    let mut args = vec![
        "tree",
        "--locked",
        "--offline",
        "-p",
        package,
        "-e",
        "normal,build",
        "--prefix",
        "none",
        "--format",
        "{p}|{l}",
    ];
    args.extend_from_slice(extra);
    cargo(&args)
        .lines()
        .filter_map(|l| l.split_once('|'))
        .map(|(p, l)| {
            let name = p.split_whitespace().next().unwrap_or(p).to_owned();
            (name, l.trim().to_owned())
        })
        .collect()
}

#[test]
fn host_tool_links_no_emulator_and_no_gpl_code() {
    let crates = linked("host-tool", &[]);
    assert!(crates.iter().any(|(n, _)| n == "hil-sim"), "{crates:?}");
    for (name, licence) in &crates {
        assert!(
            !licence.contains("GPL") || licence.contains(" OR "),
            "host-tool links {name} ({licence})"
        );
        assert!(
            !["ra4m1-emu", "unicorn-engine", "unicorn-engine-sys"].contains(&name.as_str()),
            "host-tool links {name}"
        );
    }
}

#[test]
fn the_emulator_comes_with_hil_sims_feature_pil_and_not_without_it() {
    let with = linked("hil-sim", &[]);
    assert!(with.iter().any(|(n, _)| n == "unicorn-engine"), "{with:?}");
    // ra4m1-run's test-runner crates are not the library's.
    for runner_only in ["libtest-mimic", "defmt-decoder"] {
        assert!(
            !with.iter().any(|(n, _)| n == runner_only),
            "hil-sim links {runner_only}"
        );
    }
    let without = linked("hil-sim", &["--no-default-features"]);
    assert!(
        !without.iter().any(|(n, _)| n.starts_with("unicorn")),
        "{without:?}"
    );
}

#[test]
fn the_emulators_library_links_no_crane_and_its_runner_reads_the_pin_map() {
    let library = linked("ra4m1-emu", &["--no-default-features"]);
    assert!(
        !library.iter().any(|(n, _)| n == "firmware"),
        "ra4m1-emu's library links firmware: {library:?}"
    );
    let runner = linked("ra4m1-emu", &[]);
    assert!(runner.iter().any(|(n, _)| n == "firmware"), "{runner:?}");
}

#[test]
fn the_host_engine_builds_no_inverse_kinematics() {
    let crates = linked("host", &[]);
    for ik_only in ["planner", "rayon"] {
        assert!(
            !crates.iter().any(|(n, _)| n == ik_only),
            "host links {ik_only}"
        );
    }
    assert!(crates.iter().any(|(n, _)| n == "transition-graph"));
}
