//! The truth and the diagnosis stay apart: the dependency graph, and what crosses between them
//! (flight-log files only).

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

use flight_sim::{Family, Logging, Withheld, generate};
use serde_json::Value;

/// Every workspace package a workspace package reaches through its dependencies of every kind
/// (normal, dev, build), from `cargo metadata --no-deps` (no network, no resolution: the
/// workspace's own crates are the only way to reach another workspace crate).
fn reach() -> BTreeMap<String, BTreeSet<String>> {
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
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
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

#[test]
fn truth_and_diagnosis_do_not_depend_on_each_other() {
    let r = reach();
    for bad in ["flight-sim", "gap-eval"] {
        assert!(!r["gap"].contains(bad), "gap reaches {bad}");
    }
    for bad in ["gap", "sim", "gap-eval"] {
        assert!(!r["flight-sim"].contains(bad), "flight-sim reaches {bad}");
    }
    for needed in ["flight-sim", "gap", "flightlog"] {
        assert!(r["gap-eval"].contains(needed), "gap-eval needs {needed}");
    }
}

#[test]
fn every_family_reads_back_through_the_flight_log_reader() {
    for fam in Family::all()
        .into_iter()
        .filter(|f| f.logging != Logging::Blackbox50Hz)
    {
        let set = generate(&fam, &Withheld::NONE, 11);
        let flights = gap_eval::read_back(&set.train).unwrap();
        for (f, s) in flights.iter().zip(&set.train) {
            assert_eq!(f.samples.len(), s.samples, "{}", fam.name());
            assert_eq!(
                f.samples.current_a.is_some(),
                fam.logging != Logging::VoltageOnly5Hz
            );
            assert!(f.samples.phase.is_some());
            assert_eq!(f.meta.cells, Some(u32::from(fam.chemistry.cells())));
            assert_eq!(f.meta.end, Some(flightlog::End::Cutoff));
            assert!(f.meta.take_off_mass_kg().unwrap() > 0.4);
        }
        gap_eval::rig_curve(&set.rig).unwrap();
    }
}
