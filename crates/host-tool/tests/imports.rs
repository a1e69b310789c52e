//! The modules of host-tool import each other without a circle: commands share what they
//! share through modules of their own (`shell`, `device`, …), never by importing a command
//! that imports them back. Read from the source: every `crate::…` path names the module it
//! reaches (comments aside); a command is `cmd::NAME` (its submodules included), any other
//! module its top name.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).expect("src is readable") {
        let p = e.expect("an entry").path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The node of a source file: `cmd::NAME` for a command's files, else the top module.
fn node_of(src: &Path, file: &Path) -> String {
    let rel: Vec<String> = file
        .strip_prefix(src)
        .expect("under src")
        .with_extension("")
        .iter()
        .map(|c| c.to_string_lossy().into_owned())
        .collect();
    match rel.as_slice() {
        [cmd, name, ..] if cmd == "cmd" => format!("cmd::{name}"),
        [top, ..] if top == "main" => "crate".into(),
        [top, ..] => top.clone(),
        [] => "crate".into(),
    }
}

/// The nodes a `crate::…` path names: `crate::cmd::a::x` → `cmd::a`, `crate::cmd::{a, b}` →
/// both, `crate::shell::x` → `shell`, `crate::{a, b::c}` → both.
fn targets(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect()
    };
    let group = |s: &str| -> Vec<String> {
        let inner = s.split('}').next().unwrap_or("");
        inner
            .split(',')
            .map(|p| ident(p.trim()))
            .filter(|p| !p.is_empty() && p != "self")
            .collect()
    };
    for (i, _) in text.match_indices("crate::") {
        let rest = &text[i + "crate::".len()..];
        if let Some(cmd) = rest.strip_prefix("cmd::") {
            if let Some(g) = cmd.strip_prefix('{') {
                out.extend(group(g).into_iter().map(|n| format!("cmd::{n}")));
            } else {
                out.insert(format!("cmd::{}", ident(cmd)));
            }
        } else if let Some(g) = rest.strip_prefix('{') {
            out.extend(group(g).into_iter().filter(|n| n != "cmd"));
        } else {
            let name = ident(rest);
            // `crate::say!` and the like are macros at the crate's root.
            if !name.is_empty() && !rest[name.len()..].starts_with('!') {
                out.insert(name);
            }
        }
    }
    out
}

#[test]
fn host_tools_modules_import_each_other_without_a_circle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in &files {
        let from = node_of(&src, f);
        let text = std::fs::read_to_string(f).expect("a source file");
        // Code only: a doc link names a module without importing it.
        let code: String = text
            .lines()
            .filter(|l| !l.trim_start().starts_with("//"))
            .map(|l| format!("{l}\n"))
            .collect();
        for to in targets(&code) {
            if to != from && to != "cmd" {
                edges.entry(from.clone()).or_default().insert(to);
            }
        }
    }
    assert!(
        edges
            .get("cmd::plan")
            .is_some_and(|t| t.contains("cmd::calibrate")),
        "the scan sees plan's use of calibrate's profile: {edges:?}"
    );
    fn visit(
        n: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
        circles: &mut Vec<String>,
    ) {
        if done.contains(n) {
            return;
        }
        if let Some(i) = path.iter().position(|p| p == n) {
            circles.push(format!("{} → {n}", path[i..].join(" → ")));
            return;
        }
        path.push(n.to_owned());
        for m in edges.get(n).into_iter().flatten() {
            visit(m, edges, path, done, circles);
        }
        path.pop();
        done.insert(n.to_owned());
    }
    let (mut done, mut circles) = (BTreeSet::new(), Vec::new());
    for n in edges.keys() {
        visit(n, &edges, &mut Vec::new(), &mut done, &mut circles);
    }
    assert!(
        circles.is_empty(),
        "import circles in host-tool: {circles:#?}"
    );
}

#[test]
fn the_scan_reads_every_form_of_path() {
    let t = targets(
        "use crate::cmd::plan::CliShell;\nuse crate::cmd::{aim, pose::Pose};\n\
         use crate::{device::X, shell};\nlet f = crate::shell::interrupt_flag();\ncrate::say!(\"x\");",
    );
    let want: BTreeSet<String> = ["cmd::plan", "cmd::aim", "cmd::pose", "device", "shell"]
        .into_iter()
        .map(String::from)
        .collect();
    assert_eq!(t, want);
}
