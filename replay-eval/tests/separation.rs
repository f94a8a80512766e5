//! The replay library and the estimator never reach the truth simulator: the evidence crate is
//! the only one that sees both (checked on `cargo metadata`, every dependency kind).

use std::collections::{BTreeMap, BTreeSet};

fn workspace_deps() -> BTreeMap<String, Vec<String>> {
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
    v["packages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let deps = p["dependencies"].as_array().unwrap();
            (
                p["name"].as_str().unwrap().to_owned(),
                deps.iter()
                    .map(|d| d["name"].as_str().unwrap().to_owned())
                    .collect(),
            )
        })
        .collect()
}

fn reaches(deps: &BTreeMap<String, Vec<String>>, from: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut stack = deps[from].clone();
    while let Some(d) = stack.pop() {
        if seen.insert(d.clone()) {
            stack.extend(deps.get(&d).cloned().unwrap_or_default());
        }
    }
    seen
}

#[test]
fn replay_and_the_estimator_do_not_reach_the_truth_simulator() {
    let deps = workspace_deps();
    for lib in ["replay", "estimator", "gap"] {
        let r = reaches(&deps, lib);
        for bad in ["flight-sim", "replay-eval", "gap-eval"] {
            assert!(!r.contains(bad), "{lib} reaches {bad}");
        }
    }
    let r = reaches(&deps, "replay-eval");
    for needed in ["flight-sim", "replay", "gap", "estimator"] {
        assert!(r.contains(needed), "replay-eval needs {needed}");
    }
}
