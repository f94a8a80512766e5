//! Issue 12, last items: staged report folders, strict gap-summary counts, short fit numbers
//! and grammar, notes on stderr, no negative zero, resumed and finished sessions.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{bin, data, ok, run};

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Hidden leftovers (temporary files, staging or aside folders) in `dir`.
fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp") || n.contains(".staging-") || n.contains(".old"))
        .collect()
}

/// A finished simulated session in `dir` (the paper rig; figures left out unless `figures`).
fn session(dir: &Path, figures: bool) {
    let mut args = vec!["characterise", "-o", dir.to_str().unwrap(), "--speed", "20"];
    if !figures {
        args.push("--no-figures");
    }
    // the host may be late under load; a session stopped by a latched timeout is resumed
    let mut out = run(&args);
    let mut tries = 0;
    while !out.status.success() && tries < 4 {
        assert!(
            stderr(&out).contains("--resume"),
            "characterise failed: {}",
            stderr(&out)
        );
        let mut resume = args.clone();
        resume.push("--resume");
        out = run(&resume);
        tries += 1;
    }
    assert!(out.status.success(), "{}", stderr(&out));
}

// --- item 1: a report folder appears whole or not at all ----------------------------------

#[test]
fn a_report_killed_while_writing_leaves_no_partial_folder() {
    let d = tempfile::tempdir().unwrap();
    let s = d.path().join("s");
    session(&s, false);
    let out_dir = d.path().join("figs");
    let mut killed_while_writing = 0;
    for attempt in 0..3 {
        let mut child = bin()
            .args([
                "report",
                s.to_str().unwrap(),
                "-o",
                out_dir.to_str().unwrap(),
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // kill -9 once the output shows (the folder, or its staging folder) holding `files`
        // files: as it starts, and part-way through writing
        let files = [0, 1, 5][attempt];
        let start = Instant::now();
        let shows = || {
            let count = |p: &Path| std::fs::read_dir(p).map_or(0, |r| r.count());
            std::fs::read_dir(d.path()).unwrap().any(|e| {
                let e = e.unwrap();
                let name = e.file_name().to_string_lossy().into_owned();
                (name == "figs" || name.starts_with(".figs.")) && count(&e.path()) >= files
            })
        };
        while !shows() && start.elapsed() < Duration::from_secs(120) {
            if child.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        if child.try_wait().unwrap().is_none() {
            killed_while_writing += 1;
        }
        let _ = child.kill();
        child.wait().unwrap();
        // the folder is either absent or complete
        if out_dir.exists() {
            assert!(
                out_dir.join("report.html").is_file(),
                "a partial report folder: {:?}",
                std::fs::read_dir(&out_dir)
                    .unwrap()
                    .map(|e| e.unwrap().file_name())
                    .collect::<Vec<_>>()
            );
            std::fs::remove_dir_all(&out_dir).unwrap();
        }
        // no temporary file sits where the folder should be
        assert!(!d.path().join("figs.tmp").exists());
    }
    assert!(
        killed_while_writing > 0,
        "the report never got killed mid-way"
    );
    // the next run writes the whole folder and removes what the killed ones left
    ok(&[
        "report",
        s.to_str().unwrap(),
        "-o",
        out_dir.to_str().unwrap(),
    ]);
    assert!(out_dir.join("report.html").is_file());
    assert!(out_dir.join("fig3-thrust-curve.png").is_file());
    assert_eq!(leftovers(d.path()), Vec::<String>::new());
    assert_eq!(leftovers(&out_dir), Vec::<String>::new());
}

#[test]
fn a_report_never_replaces_a_folder_of_other_files() {
    let d = tempfile::tempdir().unwrap();
    let params = d.path().join("p.toml");
    ok(&[
        "fit",
        &data("paper-sweep.csv"),
        "-o",
        params.to_str().unwrap(),
    ]);
    let out_dir = d.path().join("mine");
    std::fs::create_dir(&out_dir).unwrap();
    std::fs::write(out_dir.join("notes.txt"), "keep me").unwrap();
    let o = run(&[
        "report",
        params.to_str().unwrap(),
        "-o",
        out_dir.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(stderr(&o).contains("notes.txt"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(out_dir.join("notes.txt")).unwrap(),
        "keep me"
    );
    // an earlier report in the folder is replaced
    let again = d.path().join("again");
    ok(&[
        "report",
        params.to_str().unwrap(),
        "-o",
        again.to_str().unwrap(),
    ]);
    ok(&[
        "report",
        params.to_str().unwrap(),
        "-o",
        again.to_str().unwrap(),
    ]);
    assert!(again.join("report.html").is_file());
    assert_eq!(leftovers(d.path()), Vec::<String>::new());
    // files people can read, as any file they create (not tempfile's private 0600)
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let plain = d.path().join("plain");
        std::fs::write(&plain, "x").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&again.join("report.html")), mode(&plain));
        assert_eq!(mode(&params), mode(&plain));
    }
}

// --- item 2: gap-summary counts and spreads -------------------------------------------------

#[test]
fn gap_summary_refuses_bad_counts_and_spreads_with_line_and_column() {
    let d = tempfile::tempdir().unwrap();
    let good = std::fs::read_to_string(data("table-i.csv")).unwrap();
    // the header and the first mission
    let good: String = good.lines().take(2).map(|l| format!("{l}\n")).collect();
    for (column, value) in [
        ("samples", "-3"),
        ("samples", "2.5"),
        ("samples", "0"),
        ("measured_std_min", "-0.2"),
        ("measured_std_min", "NaN"),
        ("payload_mass_kg", "-1"),
    ] {
        let (text, _) = common::with_cell(&good, 0, column, value);
        let path = d.path().join("summary.csv");
        std::fs::write(&path, text).unwrap();
        let o = run(&["gap-summary", path.to_str().unwrap(), "--paper"]);
        assert_eq!(o.status.code(), Some(2), "{column}={value}: {}", stdout(&o));
        let e = stderr(&o);
        assert!(
            e.contains("summary.csv, line 2") && e.contains(&format!("{column:?}")),
            "{column}={value}: {e}"
        );
    }
}

// --- item 3: short centre and scale, grammar --------------------------------------------------

#[test]
fn fit_stores_a_short_centre_and_scale_and_counts_in_words() {
    let d = tempfile::tempdir().unwrap();
    // the paper sweep from 9.77 g (no zero row), one row marked invalid
    let text = std::fs::read_to_string(data("paper-sweep.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    lines.retain(|l| !l.starts_with("0,"));
    let first = lines
        .iter()
        .position(|l| l.starts_with("10,"))
        .expect("a 10 g row");
    lines[first] = lines[first].replacen("10,10.0,", "10,9.7731,", 1);
    let last = lines.len() - 1;
    lines[last] = lines[last].replace(",true", ",false");
    let sweep = d.path().join("sweep.csv");
    std::fs::write(&sweep, lines.join("\n") + "\n").unwrap();
    let params = d.path().join("p.toml");
    let out = ok(&[
        "fit",
        sweep.to_str().unwrap(),
        "-o",
        params.to_str().unwrap(),
    ]);
    assert!(out.contains("(1 row marked invalid was skipped)"), "{out}");
    assert!(!out.contains("1 rows"), "{out}");
    let toml = std::fs::read_to_string(&params).unwrap();
    for key in ["center", "scale"] {
        let line = toml
            .lines()
            .find(|l| l.starts_with(&format!("{key} =")))
            .unwrap();
        let value = line.split('=').nth(1).unwrap().trim();
        let digits = value.chars().filter(char::is_ascii_digit).count();
        assert!(digits <= 5, "{line}");
    }
    // the valid range is printed to the data's precision, not 9.773100000000001
    let range = out.lines().find(|l| l.starts_with("valid over")).unwrap();
    assert!(range.len() < 40, "{range}");
    // and the curve still evaluates as before: estimate reads it
    ok(&[
        &["estimate", "--params", params.to_str().unwrap()][..],
        &common::BATTERY_A_MISSION,
    ]
    .concat());
}

// --- item 7: notes go to stderr ----------------------------------------------------------------

#[test]
fn fit_prints_its_notes_on_stderr_and_the_result_on_stdout() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(data("paper-sweep.csv")).unwrap();
    // a thrust column without a unit: read as grams, with a note
    let unitless = text.replace("target_g,thrust_g,", "target_g,thrust,");
    let path = d.path().join("unitless.csv");
    std::fs::write(&path, unitless).unwrap();
    let o = run(&["fit", path.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("note: column \"thrust\" names no unit"),
        "{}",
        stderr(&o)
    );
    assert!(!stdout(&o).contains("note:"), "{}", stdout(&o));
    assert!(stdout(&o).contains("degree 5"), "{}", stdout(&o));
}

// --- item 8: no negative zero -----------------------------------------------------------------

#[test]
fn gap_on_a_log_without_flying_never_says_minus_zero() {
    let d = tempfile::tempdir().unwrap();
    let mut csv = String::from("time_s,voltage_v,current_a,phase,altitude_m\n");
    for i in 0..40 {
        csv.push_str(&format!("{i}.000,12.59,0.20,ground,0.01\n"));
    }
    std::fs::write(d.path().join("ground.csv"), csv).unwrap();
    std::fs::write(
        d.path().join("ground.toml"),
        "structure_mass_kg = 0.431\nbattery_mass_kg = 0.144\nbattery_energy_wh = 23.616\ncells = 3\npayload_mass_kg = 0\npayload_power_w = 0\navionics_power_w = 2.44\n",
    )
    .unwrap();
    let o = run(&["gap", d.path().join("ground.csv").to_str().unwrap()]);
    let all = format!("{}{}", stdout(&o), stderr(&o));
    assert!(all.contains("0.0 s"), "{all}");
    assert!(!all.contains("-0.0"), "{all}");
}

// --- items 5 and 6: resumed and finished sessions ------------------------------------------------

/// The `time_s` column of a session's step log.
fn step_times(csv: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let i = head.iter().position(|c| *c == "time_s").unwrap();
    lines
        .map(|l| l.split(',').nth(i).unwrap().parse().unwrap())
        .collect()
}

fn summary_json(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn an_interrupted_session_counts_the_rig_time_of_every_run() {
    let d = tempfile::tempdir().unwrap();
    let s = d.path().join("s");
    // kill -9 once the nominal sweep has logged 12 steps
    let mut child: std::process::Child = Command::new(env!("CARGO_BIN_EXE_hoverbench"))
        .args(["characterise", "-o", s.to_str().unwrap(), "--no-figures"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let rows = |p: &Path| {
        std::fs::read_to_string(p)
            .map(|t| {
                t.lines()
                    .filter(|l| l.starts_with(|c: char| c.is_ascii_digit()))
                    .count()
            })
            .unwrap_or(0)
    };
    while rows(&s.join("sweep.csv")) < 12 && start.elapsed() < Duration::from_secs(300) {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = child.kill();
    child.wait().unwrap();
    let first_run = rows(&s.join("sweep.csv"));
    assert!(first_run >= 12, "only {first_run} steps before the kill");
    let resume = |extra: &[&str]| {
        let mut a = vec![
            "characterise",
            "-o",
            s.to_str().unwrap(),
            "--resume",
            "--no-figures",
        ];
        a.extend_from_slice(extra);
        run(&a)
    };
    let mut o = resume(&[]);
    // a late host (a loaded machine) stops the sweep; resume again
    for _ in 0..4 {
        if o.status.success() {
            break;
        }
        o = resume(&[]);
    }
    assert!(o.status.success(), "{}", stderr(&o));
    let times = step_times(&s.join("sweep.csv"));
    // the rig time of the steps each run logged, from the step log's own clock readings
    let (k, n) = (first_run, times.len());
    let earlier_span = times[k - 1] - times[0];
    assert!(earlier_span > 1.0, "{times:?}");
    let v = summary_json(&s);
    let total = v["nominal"]["rig_time_s"].as_f64().unwrap();
    assert!(
        total >= earlier_span + (times[n - 1] - times[k]),
        "rig time {total} s counts only the resumed run ({times:?}, {k} steps before the kill)"
    );

    // --- a finished session resumed: said to be complete, nothing measured or calibrated,
    // no rig needed (these ports do not exist), outputs regenerated
    std::fs::remove_file(s.join("params.toml")).unwrap();
    let o = resume(&[
        "--rig",
        "/nonexistent/rig",
        "--supply",
        "/nonexistent/supply",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("is complete"), "{}", stderr(&o));
    assert!(!stdout(&o).contains("calibrating"), "{}", stdout(&o));
    assert!(s.join("params.toml").is_file());
    let again = summary_json(&s);
    assert_eq!(again["nominal"]["rig_time_s"], v["nominal"]["rig_time_s"]);
    assert_eq!(again["limit"]["rig_time_s"], v["limit"]["rig_time_s"]);
    assert_eq!(again["calibration"], v["calibration"]);

    // --- item 6: an empty spread in limit.csv (a step without one) reads as missing, as the
    // importer reads it, when the session is read back
    let limit = std::fs::read_to_string(s.join("limit.csv")).unwrap();
    let (limit, _) = common::with_cell(&limit, 0, "thrust_std_g", "");
    std::fs::write(s.join("limit.csv"), limit).unwrap();
    let o = resume(&[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = d.path().join("r");
    ok(&[
        "report",
        s.to_str().unwrap(),
        "-o",
        report.to_str().unwrap(),
    ]);
}

/// The README's list of a session's figures is what a session writes.
#[test]
fn the_readme_lists_the_figures_a_session_writes() {
    let d = tempfile::tempdir().unwrap();
    let s = d.path().join("session");
    session(&s, true);
    let mut written: Vec<String> = std::fs::read_dir(s.join("report"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter_map(|n| {
            let n = n.strip_suffix(".svg")?.strip_prefix("fig")?.to_owned();
            Some(format!("Fig. {}", n.split('-').next()?))
        })
        .collect();
    written.sort();
    let readme =
        std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("README.md"))
            .unwrap();
    // "on the simulated `paper` rig Fig. 3, Fig. 4, …; with `--structure-mass` …"
    let section = &readme[readme.find("## A session").unwrap()..];
    let listed = &section[section.find("on the simulated `paper` rig").unwrap()..];
    let listed = &listed[..listed.find("with `--structure-mass`").unwrap()];
    let mut named: Vec<String> = (1..=9)
        .map(|n| format!("Fig. {n}"))
        .filter(|f| listed.contains(f.as_str()))
        .collect();
    named.sort();
    assert_eq!(named, written, "README: {listed}");
}

#[test]
fn rig_gap_writes_its_folder_whole_and_never_over_other_files() {
    let d = tempfile::tempdir().unwrap();
    let sweep = data("paper-sweep.csv");
    let out_dir = d.path().join("rg");
    std::fs::create_dir(&out_dir).unwrap();
    std::fs::write(out_dir.join("thesis.tex"), "mine").unwrap();
    let o = run(&["rig-gap", &sweep, &sweep, "-o", out_dir.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(stderr(&o).contains("thesis.tex"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_dir(&out_dir).unwrap().count(),
        1,
        "nothing written beside the user's file"
    );
    std::fs::remove_file(out_dir.join("thesis.tex")).unwrap();
    // twice into the same folder: the second run replaces the first
    for _ in 0..2 {
        ok(&["rig-gap", &sweep, &sweep, "-o", out_dir.to_str().unwrap()]);
    }
    let mut names: Vec<String> = std::fs::read_dir(&out_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "rig-gap-residuals.csv",
            "rig-gap.json",
            "rig-gap.png",
            "rig-gap.svg"
        ]
    );
    assert_eq!(leftovers(d.path()), Vec::<String>::new());
}

#[test]
fn simulate_flights_writes_its_set_whole_and_never_over_other_files() {
    let d = tempfile::tempdir().unwrap();
    let out_dir = d.path().join("set");
    std::fs::create_dir(&out_dir).unwrap();
    std::fs::write(out_dir.join("thesis.tex"), "mine").unwrap();
    let dir = out_dir.to_str().unwrap();
    let o = run(&["simulate-flights", "-o", dir, "--seed", "3"]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(stderr(&o).contains("thesis.tex"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_dir(&out_dir).unwrap().count(),
        1,
        "nothing written beside the user's file"
    );
    std::fs::remove_file(out_dir.join("thesis.tex")).unwrap();
    // twice into the same folder: the second run replaces the first
    for seed in ["3", "4"] {
        ok(&["simulate-flights", "-o", dir, "--seed", seed]);
    }
    let mut names: Vec<String> = std::fs::read_dir(&out_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["heldout", "rig-sweep.csv", "train", "truth.json"]);
    assert_eq!(leftovers(d.path()), Vec::<String>::new());
}
