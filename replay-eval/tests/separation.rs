//! The replay library and the estimator never reach the truth simulator: the evidence crate is
//! the only one that sees both (checked on `cargo metadata`, every dependency kind).

#[path = "../../test-support/workspace_deps.rs"]
mod workspace_deps;

#[test]
fn replay_and_the_estimator_do_not_reach_the_truth_simulator() {
    let deps = workspace_deps::reach();
    for lib in ["replay", "estimator", "gap"] {
        let r = &deps[lib];
        for bad in ["flight-sim", "replay-eval", "gap-eval"] {
            assert!(!r.contains(bad), "{lib} reaches {bad}");
        }
    }
    let r = &deps["replay-eval"];
    for needed in ["flight-sim", "replay", "gap", "estimator"] {
        assert!(r.contains(needed), "replay-eval needs {needed}");
    }
}
