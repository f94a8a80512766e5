//! End-to-end: a failing command prints each reason once. The first line says what failed
//! (`error: …`, with the file, line and value), each `caused by: …` line says why, and no cause
//! repeats text printed above it; bad input exits with 2.

mod common;

use std::path::Path;

use common::{bin, data, replace_line};

/// `error:` and `caused by:` lines of a run's stderr, without their prefixes.
fn chain(stderr: &str) -> Vec<&str> {
    let mut lines = Vec::new();
    for l in stderr.lines() {
        if let Some(t) = l.strip_prefix("error: ") {
            lines.push(t);
        } else if let Some(t) = l.strip_prefix("  caused by: ") {
            assert!(!lines.is_empty(), "a cause before the error:\n{stderr}");
            lines.push(t);
        }
    }
    lines
}

/// Runs `hoverbench ARGS` in `dir`, asserts exit code 2, an `error:` line, at least `causes`
/// `caused by:` lines, and that no line of the chain holds another's text. Returns stderr.
fn fails_once(dir: &Path, args: &[&str], causes: usize) -> String {
    let out = bin().current_dir(dir).args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{args:?}:\n{err}");
    let lines = chain(&err);
    assert!(
        lines.len() > causes,
        "{args:?}: expected an error and {causes} cause(s):\n{err}"
    );
    for (i, later) in lines.iter().enumerate().skip(1) {
        for earlier in &lines[..i] {
            assert!(
                !earlier.contains(later) && !later.contains(earlier),
                "{args:?}: {later:?} repeats {earlier:?}:\n{err}"
            );
        }
    }
    err
}

#[test]
fn each_reason_is_printed_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let missing = d.join("missing.csv");
    let missing = missing.to_str().unwrap();

    // A file that is not there: what (the file) on the first line, why (the OS) once below.
    for args in [
        vec!["fit", missing],
        vec!["import", missing],
        vec!["rig-gap", missing],
        vec!["export", "px4", "--sweep", missing],
        vec!["flights", missing],
    ] {
        let err = fails_once(d, &args, 1);
        assert!(
            err.contains(&format!("error: cannot read {missing}")),
            "{err}"
        );
        let os = if args[0] == "flights" {
            "no such file or folder"
        } else {
            "No such file or directory"
        };
        assert_eq!(err.matches(os).count(), 1, "{args:?}:\n{err}");
    }

    // Malformed CSV: the file, line and column in one line.
    std::fs::write(d.join("quote.csv"), "thrust_g,power_w\n1,2\n\"3,4\n").unwrap();
    let err = fails_once(d, &["fit", "quote.csv"], 0);
    assert!(err.contains("quote.csv, line 3, column 1"), "{err}");

    // Parameter files: missing, malformed, and values the estimator refuses.
    let estimate = |params: &str| {
        vec![
            "estimate",
            "--params",
            params,
            "--battery-mass",
            "0.1",
            "--battery-energy",
            "10",
            "--structure-mass",
            "0.2",
            "--avionics-power",
            "1",
        ]
        .into_iter()
        .map(str::to_owned)
        .collect::<Vec<_>>()
    };
    let run = |args: Vec<String>, causes| {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        fails_once(d, &args, causes)
    };
    let err = run(estimate("missing.toml"), 1);
    assert!(err.contains("error: cannot read missing.toml"), "{err}");
    std::fs::write(d.join("bad.toml"), "nonsense = [\n").unwrap();
    let err = run(estimate("bad.toml"), 0);
    assert!(err.contains("bad.toml: line 1, column"), "{err}");
    let params = d.join("params.toml");
    let fit = bin()
        .current_dir(d)
        .args(["fit", &data("paper-sweep.csv"), "-o", "params.toml"])
        .output()
        .unwrap();
    assert!(fit.status.success(), "{fit:?}");
    let generic = d.join("generic.toml");
    std::fs::copy(&params, &generic).unwrap();
    replace_line(&params, "rotor_count", "rotor_count = 0");
    let err = run(estimate("params.toml"), 1);
    assert!(
        err.contains("params.toml: values the estimator cannot use"),
        "{err}"
    );
    assert!(
        err.contains("caused by: rotor count must be at least 1"),
        "{err}"
    );
    replace_line(&generic, "x =", "x = \"current_a\"");
    let err = run(
        ["replay", "--params", "generic.toml", "missing.csv"]
            .map(str::to_owned)
            .to_vec(),
        1,
    );
    assert!(
        err.contains("generic.toml cannot drive the estimator"),
        "{err}"
    );
    assert!(
        err.contains("caused by: the curve is power_w vs current_a"),
        "{err}"
    );

    // A flight set with no flight in it.
    std::fs::create_dir(d.join("empty")).unwrap();
    let err = fails_once(d, &["flights", "empty"], 0);
    assert!(err.contains("no flight logs"), "{err}");

    // A serial port that does not exist: what the command did, which port, why.
    let err = fails_once(
        d,
        &[
            "sweep",
            "--rig",
            "/dev/hoverbench-no-such-port",
            "--supply",
            "/dev/hoverbench-no-such-supply",
            "-o",
            "sweep.csv",
        ],
        2,
    );
    assert!(
        err.contains("serial port /dev/hoverbench-no-such-port"),
        "{err}"
    );
}

#[test]
fn every_chemistry_prior_is_accepted_and_listed() {
    let names: Vec<&str> = gap::battery::Chemistry::PRIORS
        .iter()
        .map(|c| c.name())
        .collect();
    assert!(names.contains(&"lifepo4"), "{names:?}");
    let help = bin().args(["battery", "learn", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    for args in [vec!["battery", "learn", "--params", "p.toml"], vec!["gap"]] {
        let with = |chemistry: &str| {
            let out = bin()
                .args(&args)
                .args(["--chemistry", chemistry, "missing-flights"])
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&out.stderr).into_owned();
            (out.status.code(), err)
        };
        let (code, err) = with("lead_acid");
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains("invalid value 'lead_acid'"), "{args:?}: {err}");
        for n in &names {
            assert!(err.contains(n), "{args:?}: {n} not listed in {err}");
            assert!(help.contains(n), "battery learn --help lacks {n}:\n{help}");
        }
        // Every listed name gets past the argument parser (to the missing files).
        for n in &names {
            let (_, err) = with(n);
            assert!(!err.contains("invalid value"), "{args:?} {n}: {err}");
        }
    }
}
