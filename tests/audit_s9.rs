//! Session 9's pass as a new user: mistakes that used to move the rig, print a wrapped seed
//! range, lose the line of a bad row or pass silently now end with exit 2 and a message naming
//! the file, line or value.

mod common;

use common::{data, outcome};

/// `hoverbench ARGS` exits with 2; returns (stdout, stderr).
fn fails(args: &[&str]) -> (String, String) {
    let (code, out, err) = outcome(args);
    assert_eq!(code, 2, "{args:?}:\n{out}\n{err}");
    assert!(!err.contains("panicked"), "{args:?}:\n{err}");
    (out, err)
}

#[test]
fn characterise_refuses_a_session_folder_it_cannot_make_before_the_rig_starts() {
    let d = tempfile::tempdir().unwrap();
    let file = d.path().join("params.toml");
    std::fs::write(&file, "not a folder\n").unwrap();
    let under_file = file.join("session");
    for target in [&file, &under_file] {
        let t = target.to_str().unwrap();
        let (out, err) = fails(&["characterise", "-o", t]);
        assert!(
            err.contains(&format!("cannot use {t} as the session folder")),
            "{err}"
        );
        // Refused before the simulated bench was started: no rig line, no "steps are in".
        assert!(!out.contains("simulated bench"), "{out}");
        assert!(!err.contains("complete steps are in"), "{err}");
    }
    assert_eq!(
        std::fs::read_to_string(&file).unwrap(),
        "not a folder\n",
        "the file in the way is left as it was"
    );
}

#[test]
fn sweep_refuses_a_log_in_a_missing_folder_before_connecting() {
    let d = tempfile::tempdir().unwrap();
    let log = d.path().join("missing").join("sweep.csv");
    let log = log.to_str().unwrap();
    // The ports do not exist either: the folder is checked first, so no port is opened.
    let (_, err) = fails(&[
        "sweep",
        "--rig",
        "/dev/nonexistent-rig",
        "--supply",
        "/dev/nonexistent-supply",
        "-o",
        log,
    ]);
    assert!(err.contains(&format!("cannot write {log}")), "{err}");
    assert!(err.contains("does not exist"), "{err}");
    assert!(!err.contains("nonexistent-rig"), "{err}");
}

#[test]
fn studies_refuse_zero_scenarios_zero_threads_and_seeds_past_the_last() {
    for args in [
        vec!["rig-gap-eval", "--scenarios", "0"],
        vec!["gap-eval", "--scenarios", "0"],
        vec!["replay-eval", "--scenarios", "0"],
        vec!["gap-eval", "--threads", "0", "--scenarios", "1"],
        vec!["replay-eval", "--threads", "0", "--scenarios", "1"],
    ] {
        let (_, err) = fails(&args);
        assert!(err.contains("\"0\" must be at least 1"), "{args:?}:\n{err}");
    }
    // rig-gap-eval --scenarios 0 used to print "seeds 0–18446744073709551615".
    let last = u64::MAX.to_string();
    for args in [
        vec!["rig-gap-eval", "--seed", &last, "--scenarios", "2"],
        vec!["gap-eval", "--seed-start", &last, "--scenarios", "2"],
        vec!["replay-eval", "--seed", &last, "--scenarios", "2"],
    ] {
        let (out, err) = fails(&args);
        assert!(
            err.contains("run past the largest seed"),
            "{args:?}:\n{err}"
        );
        assert!(out.is_empty(), "{args:?}:\n{out}");
    }
}

#[test]
fn gap_summary_names_the_line_of_a_mission_the_model_cannot_fly() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(data("table-i.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    // A second mission with a 5 kg pack: far beyond the curve's thrust range.
    let heavy = lines[1]
        .replace("Table I (Battery-A)", "too heavy")
        .replace(",0.144,", ",5,");
    assert_ne!(heavy, lines[1]);
    lines.push(heavy);
    let file = d.path().join("missions.csv");
    std::fs::write(&file, lines.join("\n") + "\n").unwrap();
    let f = file.to_str().unwrap();
    let (_, err) = fails(&["gap-summary", f, "--paper"]);
    assert!(
        err.contains(&format!("error: {f}, line 3 (too heavy)")),
        "{err}"
    );
    assert!(err.contains("outside the measured thrust curve"), "{err}");
}

#[test]
fn a_params_file_names_the_key_it_lacks_or_cannot_use() {
    let d = tempfile::tempdir().unwrap();
    let params = d.path().join("params.toml");
    let p = params.to_str().unwrap();
    common::ok(&["fit", &data("paper-sweep.csv"), "-o", p]);
    let text = std::fs::read_to_string(&params).unwrap();
    let estimate = [&["estimate", "--params", p][..], &common::BATTERY_A_MISSION].concat();
    // A section left out: said in the file's words, not serde's "missing field".
    let start = text.find("[fit]").unwrap();
    let end = text.find("[provenance]").unwrap();
    std::fs::write(&params, format!("{}{}", &text[..start], &text[end..])).unwrap();
    let (_, err) = fails(&estimate);
    assert!(
        err.contains("`fit` is missing: every hoverbench parameter file has it"),
        "{err}"
    );
    assert!(!err.contains("missing field"), "{err}");
    // A value the curve cannot use: its key and line, as the file names it (`scale`, not the
    // estimator's `scale_g`).
    let line = text.lines().position(|l| l.starts_with("scale =")).unwrap() + 1;
    std::fs::write(
        &params,
        text.replace("\nscale = 130.0\n", "\nscale = 0.0\n"),
    )
    .unwrap();
    let (_, err) = fails(&estimate);
    assert!(
        err.contains(&format!(
            "line {line}, column 9, curve.scale: values the estimator cannot use"
        )),
        "{err}"
    );
}

#[test]
fn fit_says_a_tare_offset_once_and_a_descent_in_four_digits() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(data("paper-sweep.csv")).unwrap();
    // The first step reads −20 g instead of its thrust.
    let (text, _) = common::with_cell(&text, 0, "thrust_g", "-20");
    let file = d.path().join("sweep.csv");
    std::fs::write(&file, text).unwrap();
    let (code, _, err) = outcome(&["fit", file.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(err.matches("tare offset at idle").count(), 1, "{err}");
    if let Some(w) = err.lines().find(|l| l.contains("steepest descent")) {
        // no 17-digit floats
        assert!(
            w.split(|c: char| !(c.is_ascii_digit() || c == '.'))
                .all(|n| n.len() < 10),
            "{w}"
        );
    }
}

#[test]
fn help_says_what_the_summaries_file_holds_and_the_clock_rate_unit() {
    let help = common::ok(&["gap-summary", "--help"]);
    assert!(help.contains("measured_mean_min"), "{help}");
    let help = common::ok(&["characterise", "--help"]);
    assert!(help.contains("× real time"), "{help}");
}

#[test]
fn gap_summary_says_its_spread_is_the_standard_error() {
    // Table I: 102.3 ± 0.2 min (standard deviation) over 2 flights, a standard error of 0.14.
    let out = common::ok(&["gap-summary", &data("table-i.csv"), "--paper"]);
    assert!(out.contains("measured (± s.e.)"), "{out}");
    assert!(out.contains("102.3 ± 0.14 min"), "{out}");
}

#[test]
fn export_never_writes_over_its_own_input() {
    let d = tempfile::tempdir().unwrap();
    let params = d.path().join("params.toml");
    let p = params.to_str().unwrap();
    common::ok(&["fit", &data("paper-sweep.csv"), "-o", p]);
    let before = std::fs::read(&params).unwrap();
    let sweep = d.path().join("sweep.csv");
    std::fs::copy(data("paper-sweep.csv"), &sweep).unwrap();
    let s = sweep.to_str().unwrap();
    let sweep_before = std::fs::read(&sweep).unwrap();
    // `export c-header params.toml -o params.toml` used to replace the parameters with C.
    for args in [
        vec!["export", "c-header", p, "-o", p],
        vec!["export", "px4", "--sweep", s, "-o", s],
        vec!["export", "ardupilot", "--sweep", s, "-o", s],
    ] {
        let (_, err) = fails(&args);
        assert!(err.contains("is also an input"), "{args:?}:\n{err}");
    }
    assert_eq!(std::fs::read(&params).unwrap(), before);
    assert_eq!(std::fs::read(&sweep).unwrap(), sweep_before);
}

#[test]
fn a_sweep_given_for_the_parameters_is_named_as_such() {
    let sweep = data("paper-sweep.csv");
    for args in [
        vec!["report", &sweep, "-o", "never-written"],
        vec!["export", "c-header", &sweep],
    ] {
        let (_, err) = fails(&args);
        assert!(
            err.contains("a table of comma-separated values, not a TOML parameter file"),
            "{args:?}:\n{err}"
        );
        assert!(err.contains("hoverbench fit"), "{err}");
    }
    assert!(!std::path::Path::new("never-written").exists());
}

#[test]
fn a_folder_of_log_folders_says_its_subfolders_are_not_searched() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir(d.path().join("ulog")).unwrap();
    std::fs::create_dir(d.path().join("dataflash")).unwrap();
    let (_, err) = fails(&["flights", d.path().to_str().unwrap()]);
    assert!(
        err.contains("subfolders are not searched: give them (dataflash/, ulog/)"),
        "{err}"
    );
}

#[test]
fn a_supply_that_cannot_be_opened_is_named_with_its_port() {
    use std::io::BufRead;
    let d = tempfile::tempdir().unwrap();
    let mut rig = common::bin()
        .args(["sim-rig", "--json", "--speed", "10"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut first = String::new();
    std::io::BufReader::new(rig.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    let port: serde_json::Value = serde_json::from_str(&first).unwrap();
    let port = port["port"].as_str().unwrap().to_owned();
    let log = d.path().join("sweep.csv");
    let out = outcome(&[
        "sweep",
        "--rig",
        &port,
        "--supply",
        "/dev/nonexistent-supply",
        "-o",
        log.to_str().unwrap(),
    ]);
    let _ = rig.kill();
    let _ = rig.wait();
    let (code, _, err) = out;
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("error: connecting to the scpi supply on /dev/nonexistent-supply"),
        "{err}"
    );
    // was "caused by: bench supply open"
    assert!(err.contains("the bench supply failed to open"), "{err}");
}

#[test]
fn a_fractional_throttle_just_past_one_is_not_read_as_percent() {
    // paper-sweep.csv's throttle runs 0.100 … 1.010: read as a percentage, ArduPilot found no
    // command above MOT_SPIN_MIN ("0 usable sweep points") and PX4 fitted commands of 0.001 ….
    let out = common::ok(&["export", "ardupilot", "--sweep", &data("paper-sweep.csv")]);
    assert!(out.contains("MOT_THST_EXPO,"), "{out}");
    let px4 = common::ok(&["export", "px4", "--sweep", &data("paper-sweep.csv")]);
    let fac: f64 = px4
        .lines()
        .find_map(|l| {
            l.split('\t')
                .collect::<Vec<_>>()
                .get(2..4)
                .and_then(|f| (f[0] == "THR_MDL_FAC").then(|| f[1].parse().ok()).flatten())
        })
        .unwrap_or_else(|| panic!("{px4}"));
    assert!((0.0..=1.0).contains(&fac), "{px4}");
}

#[test]
fn optimise_refuses_an_energy_density_beside_a_catalogue() {
    // The catalogue's packs carry their own energy; --energy-density was silently ignored.
    let (_, err) = fails(&[
        "optimise",
        "--paper",
        "--energy-density",
        "164",
        "--catalogue",
        &common::root()
            .join("data/batteries/paper.csv")
            .to_string_lossy(),
    ]);
    assert!(err.contains("cannot be used with"), "{err}");
}
