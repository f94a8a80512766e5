//! A held-out flight (or stand log) that is also a training one is refused, by name: the same
//! file, the same file by another path, or a copy of it in another folder.

mod common;
use common::{data_path, ok, refused, run};

/// A simulated set: `DIR/train` (8 flights) and `DIR/heldout` (4).
fn flight_set(dir: &std::path::Path) -> std::path::PathBuf {
    let out = dir.join("set");
    ok(&[
        "simulate-flights",
        "-o",
        out.to_str().unwrap(),
        "--family",
        "lipo/lab-1hz/paper",
        "--seed",
        "7",
    ]);
    out
}

/// The CSV flights of a folder, sorted.
fn csvs(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    v.sort();
    v
}

#[test]
fn gap_refuses_a_heldout_flight_that_is_also_trained_on() {
    let dir = tempfile::tempdir().unwrap();
    let set = flight_set(dir.path());
    let (train, held) = (set.join("train"), set.join("heldout"));
    let t = train.to_str().unwrap();

    // The training folder held out as well: every flight named.
    let err = refused(
        &run(&["gap", t, "--holdout", t, "--json"]),
        "8 held-out flight(s) also in the training set",
    );
    for f in csvs(&train) {
        assert!(err.contains(&f.display().to_string()), "{f:?} in {err}");
    }

    // One training flight, named by another path (`train/../train/NAME`).
    let first = csvs(&train).remove(0);
    let name = first.file_name().unwrap().to_str().unwrap();
    let other_path = train.join("..").join("train").join(name);
    let h = held.to_str().unwrap();
    let err = refused(
        &run(&["gap", t, "--holdout", h, other_path.to_str().unwrap()]),
        "1 held-out flight(s) also in the training set",
    );
    assert!(
        err.contains(&format!(
            "{} is the training flight {}",
            other_path.display(),
            first.display()
        )),
        "{err}"
    );

    // A copy of a training flight (with its sidecar) in another folder: the same bytes.
    let copy = dir.path().join("copy");
    std::fs::create_dir(&copy).unwrap();
    let copied = copy.join("renamed.csv");
    std::fs::copy(&first, &copied).unwrap();
    std::fs::copy(first.with_extension("toml"), copy.join("renamed.toml")).unwrap();
    let err = refused(
        &run(&["gap", t, "--holdout", h, copy.to_str().unwrap()]),
        "has the same bytes as the training flight",
    );
    assert!(err.contains(&copied.display().to_string()), "{err}");
    assert!(err.contains(&first.display().to_string()), "{err}");

    // Distinct sets still run.
    ok(&["gap", t, "--holdout", h, "--json"]);
}

#[test]
fn rig_gap_refuses_a_heldout_log_that_is_also_trained_on() {
    let sweep = data_path("paper-sweep.csv");
    let s = sweep.to_str().unwrap();
    refused(
        &run(&["rig-gap", s, "--holdout", s]),
        "1 held-out stand log(s) also in the training set",
    );
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("sweep-copy.csv");
    std::fs::copy(&sweep, &copy).unwrap();
    let err = refused(
        &run(&["rig-gap", s, "--holdout", copy.to_str().unwrap()]),
        "has the same bytes as the training stand log",
    );
    assert!(err.contains("sweep-copy.csv"), "{err}");
}
