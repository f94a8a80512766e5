//! The blind study's truth simulator (`stand-sim`) lives apart from the diagnosis: neither the
//! diagnosis nor the model it fits may depend on it (nor it on them).

use std::path::Path;

fn deps(manifest: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(manifest);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn diagnosis_and_model_do_not_depend_on_the_truth_simulator() {
    for m in ["Cargo.toml", "../motor-model/Cargo.toml"] {
        let text = deps(m);
        assert!(!text.contains("stand-sim"), "{m} names stand-sim");
        assert!(!text.contains("stand_sim"), "{m} names stand_sim");
    }
}

#[test]
fn truth_simulator_does_not_depend_on_the_diagnosis_or_the_model() {
    let text = deps("../stand-sim/Cargo.toml");
    for name in ["rig-gap", "motor-model", "sim", "gap"] {
        assert!(
            !text
                .lines()
                .any(|l| l.trim_start().starts_with(&format!("{name} "))
                    || l.trim_start().starts_with(&format!("{name}."))),
            "stand-sim depends on {name}"
        );
    }
}
