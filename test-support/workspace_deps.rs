//! The workspace's dependency graph, for the tests that prove a crate does not reach a truth
//! simulator (`gap-eval/tests/separation.rs`, `replay-eval/tests/separation.rs`).
//!
//! A plain file, not a crate: each test includes it with `#[path]`, so sharing it adds no
//! package and no edge to the graph it checks, and it lives in none of the crates under test
//! nor in a truth simulator.

use std::collections::{BTreeMap, BTreeSet};

/// Every workspace package a workspace package reaches through its dependencies of every kind
/// (normal, dev, build), from `cargo metadata --no-deps` (no network, no resolution: the
/// workspace's own crates are the only way to reach another workspace crate).
pub fn reach() -> BTreeMap<String, BTreeSet<String>> {
    let out = std::process::Command::new(env!("CARGO"))
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let direct: BTreeMap<String, Vec<String>> = v["packages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            (
                p["name"].as_str().unwrap().to_owned(),
                p["dependencies"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|d| d["name"].as_str().unwrap().to_owned())
                    .collect(),
            )
        })
        .collect();
    assert!(
        direct.len() > 10,
        "the workspace's packages: {:?}",
        direct.keys()
    );
    direct
        .keys()
        .map(|k| {
            let mut seen = BTreeSet::new();
            let mut stack = direct[k].clone();
            while let Some(d) = stack.pop() {
                if seen.insert(d.clone()) {
                    stack.extend(direct.get(&d).cloned().unwrap_or_default());
                }
            }
            (k.clone(), seen)
        })
        .collect()
}
