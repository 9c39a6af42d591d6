//! The crate graph is what `crate-graph.txt` (beside ARCHITECTURE.md) says it is: every workspace crate's
//! normal dependencies on other workspace crates, read from `cargo metadata`, equal the list's, both
//! ways. A new arrow (a stage importing another, the CLI reaching past the face) fails here until the
//! list, and with it the architecture, says so. ARCHITECTURE.md's table has one row per crate of the list.

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

const LIST: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../crate-graph.txt");
const ARCHITECTURE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../ARCHITECTURE.md");

/// Crate → the workspace crates it depends on.
type Graph = BTreeMap<String, BTreeSet<String>>;

/// The graph `crate-graph.txt` allows: `crate: dep dep …` per line, `#` comments.
fn listed() -> Graph {
    let text = std::fs::read_to_string(LIST).unwrap_or_else(|e| panic!("cannot read {LIST}: {e}"));
    let mut graph = Graph::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (name, deps) = line
            .split_once(':')
            .unwrap_or_else(|| panic!("{LIST}:{}: expected `crate: deps…`", n + 1));
        let deps = deps.split_whitespace().map(str::to_string).collect();
        let previous = graph.insert(name.trim().to_string(), deps);
        assert!(
            previous.is_none(),
            "{LIST}:{}: `{name}` listed twice",
            n + 1
        );
    }
    graph
}

/// The graph the manifests declare, from `cargo metadata` (normal dependencies only).
fn declared() -> Graph {
    let out = Command::new(env!("CARGO"))
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cannot run `cargo metadata`");
    assert!(
        out.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let metadata: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let packages = metadata["packages"].as_array().unwrap();
    let members: BTreeSet<String> = packages
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    packages
        .iter()
        .map(|p| {
            let deps = p["dependencies"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|d| d["kind"].is_null())
                .map(|d| d["name"].as_str().unwrap().to_string())
                .filter(|d| members.contains(d))
                .collect();
            (p["name"].as_str().unwrap().to_string(), deps)
        })
        .collect()
}

#[test]
fn the_crate_graph_is_the_one_the_architecture_lists() {
    let (listed, declared) = (listed(), declared());
    let mut wrong = Vec::new();
    for name in listed
        .keys()
        .chain(declared.keys())
        .collect::<BTreeSet<_>>()
    {
        match (listed.get(name), declared.get(name)) {
            (Some(l), Some(d)) if l == d => {}
            (Some(l), Some(d)) => wrong.push(format!(
                "{name}: Cargo.toml adds {:?}, drops {:?}",
                d.difference(l).collect::<Vec<_>>(),
                l.difference(d).collect::<Vec<_>>()
            )),
            (None, Some(_)) => wrong.push(format!("{name}: a workspace crate the list lacks")),
            (Some(_), None) => wrong.push(format!("{name}: listed but not in the workspace")),
            (None, None) => unreachable!(),
        }
    }
    assert!(
        wrong.is_empty(),
        "the crate graph differs from crate-graph.txt:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn the_listed_graph_parses_and_has_no_cycle() {
    let graph = listed();
    // Kahn's algorithm: a crate is settled once everything it depends on is.
    let mut settled = BTreeSet::new();
    while settled.len() < graph.len() {
        let next: Vec<&String> = graph
            .iter()
            .filter(|(name, deps)| {
                !settled.contains(*name) && deps.iter().all(|d| settled.contains(d))
            })
            .map(|(name, _)| name)
            .collect();
        assert!(
            !next.is_empty(),
            "crate-graph.txt has a cycle or names an unlisted crate among: {:?}",
            graph
                .keys()
                .filter(|n| !settled.contains(*n))
                .collect::<Vec<_>>()
        );
        settled.extend(next.into_iter().cloned());
    }
}

#[test]
fn architecture_md_has_one_row_per_crate() {
    let text = std::fs::read_to_string(ARCHITECTURE)
        .unwrap_or_else(|e| panic!("cannot read {ARCHITECTURE}: {e}"));
    // Rows of the crates table start with the crate's name in backticks: "| `neuroom-core` | …".
    let mut rows: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split_once("` |").map(|(name, _)| name))
        .filter(|name| name.starts_with("neuroom"))
        .collect();
    rows.sort_unstable();
    let crates: Vec<String> = listed().into_keys().collect();
    assert_eq!(
        rows, crates,
        "ARCHITECTURE.md's table rows and the crates of crate-graph.txt differ"
    );
}
