//! `hoverbench simulate-flights`, `gap` and `gap-eval` end to end, and the gap on real
//! Crazyflie flights (read from `../shared/data/real/crazyflie`, which CI has beside the clone).

use serde_json::Value;

mod common;
use common::{data_path, json, ok, root, run, shared_path};

/// `hoverbench simulate-flights` into `DIR/set` with the options given (family, effect, seed):
/// the set's folder.
fn simulate(dir: &std::path::Path, options: &[&str]) -> std::path::PathBuf {
    simulate_into(dir, "set", options)
}

/// [`simulate`] into `DIR/NAME`.
fn simulate_into(dir: &std::path::Path, name: &str, options: &[&str]) -> std::path::PathBuf {
    let out = dir.join(name);
    ok(&[&["simulate-flights", "-o", out.to_str().unwrap()], options].concat());
    out
}

/// `hoverbench gap` on a simulated set's training flights against its held-out ones, with
/// `extra`: its standard output.
fn gap_on_set(set: &std::path::Path, extra: &[&str]) -> String {
    let (train, held) = (set.join("train"), set.join("heldout"));
    let args = [
        "gap",
        train.to_str().unwrap(),
        "--holdout",
        held.to_str().unwrap(),
    ];
    ok(&[&args[..], extra].concat())
}

/// The rig sweep of a simulated set fitted into `DIR/params.toml`, as a bench's would be.
fn fit_rig(dir: &std::path::Path, set: &std::path::Path) -> std::path::PathBuf {
    let params = dir.join("params.toml");
    ok(&[
        "fit",
        set.join("rig-sweep.csv").to_str().unwrap(),
        "--volts",
        "12.5",
        "-o",
        params.to_str().unwrap(),
    ]);
    params
}

#[test]
fn simulated_set_is_diagnosed_from_its_files_without_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let out = simulate(
        dir.path(),
        &[
            "--family",
            "nmc/fc-10hz/paper",
            "--effect",
            "capacity_fade=0.12",
            "--seed",
            "4",
        ],
    );
    // The truth lies beside the flights, in a file the reader does not take.
    let truth: Value =
        serde_json::from_slice(&std::fs::read(out.join("truth.json")).unwrap()).unwrap();
    assert_eq!(truth["effect"]["kind"], "capacity_fade");
    assert_eq!(truth["family"], "nmc/fc-10hz/paper");
    std::fs::rename(
        out.join("truth.json"),
        dir.path().join("truth-elsewhere.json"),
    )
    .unwrap();
    // The rig sweep fits into a parameter file as a bench's would.
    let params = fit_rig(dir.path(), &out);
    let train = out.join("train");
    let held = out.join("heldout");
    let v = json(&[
        "gap",
        train.to_str().unwrap(),
        "--holdout",
        held.to_str().unwrap(),
        "--params",
        params.to_str().unwrap(),
        "--json",
    ]);
    // Every flight read (8 training, 4 held out), none skipped; the faded pack opens a held-out
    // endurance gap of about its fade.
    assert_eq!(v["split"]["train"].as_array().unwrap().len(), 8);
    assert_eq!(v["split"]["heldout"].as_array().unwrap().len(), 4);
    assert_eq!(v["skipped"].as_array().unwrap().len(), 0);
    let before = v["baseline"]["heldout"]["endurance_pct"].as_f64().unwrap();
    assert!(before > 8.0, "held-out endurance gap {before} %");
    assert!(v["verdict"].is_array());
    assert!(v["where"]["by_phase"].is_array());
    // The plots, before and after.
    let plots = dir.path().join("plots");
    ok(&[
        "gap",
        train.to_str().unwrap(),
        "--holdout",
        held.to_str().unwrap(),
        "-o",
        plots.to_str().unwrap(),
    ]);
    for f in ["gap-voltage-over-time", "gap-residual-by-phase"] {
        for ext in ["svg", "png"] {
            assert!(plots.join(format!("{f}.{ext}")).exists(), "{f}.{ext}");
        }
    }
}

#[test]
fn gap_eval_reports_per_family() {
    let v = json(&[
        "gap-eval",
        "--scenarios",
        "2",
        "--families",
        "lipo/lab-1hz/paper,lfp/lab-1hz/paper",
        "--json",
    ]);
    assert_eq!(v["scenarios"].as_array().unwrap().len(), 2);
    assert_eq!(
        v["tuning_families"],
        serde_json::json!(["lipo/lab-1hz/paper"])
    );
    assert_eq!(
        v["heldout_families"],
        serde_json::json!(["lfp/lab-1hz/paper"])
    );
    let groups = v["groups"].as_array().unwrap();
    assert!(groups.iter().any(|g| g["name"] == "lfp/lab-1hz/paper"));
    assert!(v["confusion"].is_array());
    // With the rig the diagnosis estimates no hover power.
    for sc in v["scenarios"].as_array().unwrap() {
        assert!(sc["estimated_hover_power_w"].is_null(), "{sc}");
    }
    // An unknown family is an error that says what families look like.
    let out = run(&["gap-eval", "--families", "lead-acid"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("chemistry/logging/robot"));
}

#[test]
fn crazyflie_with_the_learned_battery() {
    let cf = shared_path("crazyflie");
    let v = json(&["gap", cf.to_str().unwrap(), "--json"]);
    assert!(
        v["baseline_source"]
            .as_str()
            .unwrap()
            .contains("estimated from the training flights")
    );
    // 30 of the 90 flights are held out by the default rule.
    assert_eq!(v["split"]["heldout"].as_array().unwrap().len(), 30);
    // The battery is learned from the 60 training flights, through the power model (no
    // current is logged), and has its late-discharge knee.
    let b = &v["batteries"][0];
    assert_eq!(b["current"], "power_model");
    assert!(b["samples"].as_u64().unwrap() >= 200);
    let after = v["after"]["heldout"]["voltage_rmse_v"].as_f64().unwrap();
    let before = v["baseline"]["heldout"]["voltage_rmse_v"].as_f64().unwrap();
    // Measured when written: CRAZYFLIE_RMSE_V (0.111 V with the LiPo table before; the aim of
    // issue 9, below 0.08 V, is not reached).
    assert!(
        after < CRAZYFLIE_RMSE_V + 0.005,
        "held-out voltage RMSE {before} → {after} V"
    );
    assert!(after <= before + 1e-12);
    // A remaining gap is named, never a bare `unexplained`.
    if v["unexplained"] == true || v["verdict"].as_array().unwrap().is_empty() {
        assert!(
            !v["residual"]["description"]
                .as_str()
                .unwrap_or("")
                .is_empty()
        );
    }
}

/// How close issue 9's Crazyflie aim (held-out voltage RMSE below 0.08 V) is to what the data
/// allow a prediction made before take-off. The loaded voltage's drop below the resting start
/// voltage, in 3 s windows from 5 s into each flight, is fitted by least squares on the start
/// voltage, time, time² and climb rate over all 90 flights at once (the fit is tested on the
/// flights it was fitted to, so it flatters itself). What is left is almost all one constant per
/// flight: measured 0.073 V between flights against 0.020 V within one. A flight's constant is
/// its pack's sag under load (0.39–0.73 V 5 s in, the dataset names no pack), which nothing
/// logged before take-off reveals, so any prediction from the rest voltage carries it: with
/// 0.07 V of it, 0.08 V leaves about 0.04 V for every other error.
#[test]
fn crazyflie_flights_differ_by_a_sag_no_log_reveals_before_take_off() {
    let set = flightlog::FlightSet::read(&shared_path("crazyflie")).unwrap();
    assert_eq!(set.flights.len(), 90);
    // Rows: (flight, [1, v0, t, t², climb rate], drop).
    let mut rows: Vec<(usize, [f64; 5], f64)> = Vec::new();
    for (k, f) in set.flights.iter().enumerate() {
        let s = &f.samples;
        let (v, z, t) = (&s.voltage_v, s.altitude_m.as_ref().unwrap(), &s.time_s);
        let v0 = v[..20].iter().sum::<f64>() / 20.0;
        let win = 300; // 3 s at 100 Hz
        let mut a = 500; // 5 s in
        while a + win < v.len() {
            let vw = v[a..a + win].iter().sum::<f64>() / win as f64;
            let tw = t[a] - t[0];
            let climb = (z[a + win - 1] - z[a]) / (t[a + win - 1] - t[a]);
            rows.push((k, [1.0, v0, tw, tw * tw, climb], v0 - vw));
            a += win;
        }
    }
    let m = 5;
    let (mut ata, mut atb) = (vec![0.0; m * m], vec![0.0; m]);
    for (_, x, y) in &rows {
        for p in 0..m {
            atb[p] += x[p] * y;
            for q in 0..m {
                ata[p * m + q] += x[p] * x[q];
            }
        }
    }
    let c = gap::stats::solve(ata, atb).unwrap();
    let mut per_flight = vec![Vec::new(); set.flights.len()];
    for (k, x, y) in &rows {
        per_flight[*k].push(y - x.iter().zip(&c).map(|(a, b)| a * b).sum::<f64>());
    }
    let means: Vec<f64> = per_flight
        .iter()
        .filter(|r| !r.is_empty())
        .map(|r| gap::stats::mean(r).unwrap())
        .collect();
    let between = gap::stats::rms(&means).unwrap();
    let within: Vec<f64> = per_flight
        .iter()
        .zip(means.iter())
        .flat_map(|(r, m)| r.iter().map(move |e| e - m))
        .collect();
    let within = gap::stats::rms(&within).unwrap();
    assert!(
        between > 0.06 && within < 0.03,
        "between flights {between:.3} V, within {within:.3} V"
    );
}

/// The held-out voltage RMSE on the Crazyflie flights with the learned battery, V, as measured
/// when the learned battery landed (`hoverbench gap ../shared/data/real/crazyflie`).
const CRAZYFLIE_RMSE_V: f64 = 0.106;

#[test]
fn text_and_json_report_the_same_shares_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = simulate(
        dir.path(),
        &["--effect", "internal_resistance=0.06", "--seed", "5"],
    );
    let (train, held) = (out.join("train"), out.join("heldout"));
    let args = [
        "gap",
        train.to_str().unwrap(),
        "--holdout",
        held.to_str().unwrap(),
    ];
    let v = json(&[&args[..], &["--json"]].concat());
    let text = run(&args);
    assert!(text.status.success());
    let text = String::from_utf8(text.stdout).unwrap();
    let effects = v["effects"].as_array().unwrap();
    assert!(!effects.is_empty(), "{text}");
    for e in effects {
        let name = e["effect"].as_str().unwrap();
        let share = format!("{:.0} %", e["share_of_gap"].as_f64().unwrap() * 100.0);
        let row = text
            .lines()
            .find(|l| l.starts_with(name))
            .unwrap_or_else(|| panic!("no row for {name} in\n{text}"));
        assert!(row.trim_end().ends_with(&share), "{row} vs {share}");
    }
    let line = text
        .lines()
        .find(|l| l.starts_with("held-out endurance gap:"))
        .unwrap_or_else(|| panic!("{text}"));
    let before = format!(
        "{:.3} %",
        effects[0]["heldout_error_before_pct"].as_f64().unwrap()
    );
    let after = format!(
        "{:.3} %",
        effects[0]["heldout_error_after_pct"].as_f64().unwrap()
    );
    assert!(
        line.contains(&format!("{before} before")),
        "{line} vs {before}"
    );
    assert!(
        line.contains(&format!("{after} after")),
        "{line} vs {after}"
    );
    assert_eq!(
        v["headline"]["before"],
        effects[0]["heldout_error_before_pct"]
    );
    assert_eq!(
        v["headline"]["after"],
        effects[0]["heldout_error_after_pct"]
    );
}

#[test]
fn table_i_summary_says_how_much_the_printed_eq8_accounts_for() {
    let file = data_path("table-i.csv");
    let v = json(&["gap-summary", file.to_str().unwrap(), "--paper", "--json"]);
    let g = &v[0];
    assert!((g["printed_min"].as_f64().unwrap() - 103.33).abs() < 0.01);
    assert!((g["consistent_min"].as_f64().unwrap() - 101.68).abs() < 0.01);
    assert!((g["eq8_accounts_for_min"].as_f64().unwrap() - 1.65).abs() < 0.02);
}

#[test]
fn one_flight_is_localised_and_says_how_many_more_the_attribution_needs() {
    let dir = tempfile::tempdir().unwrap();
    let out = simulate(dir.path(), &["--seed", "6"]);
    let one = std::fs::read_dir(out.join("train"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|x| x == "csv"))
        .unwrap();
    // A file nobody can read sits beside it: its reason prints first.
    let bad = out.join("train").join("broken.csv");
    std::fs::write(&bad, "not,a\nflight\n").unwrap();
    let o = run(&["gap", one.to_str().unwrap(), bad.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{text}\n{err}");
    assert!(
        err.contains("skipped") && err.contains("broken.csv"),
        "{err}"
    );
    assert!(text.contains("where:"), "{text}");
    assert!(
        text.contains("attribution needs at least 3 flights") && text.contains("2 more needed"),
        "{text}"
    );
}

/// Runs `hoverbench gap` on a shared folder of real logs: (exit code, stdout, stderr).
fn gap_on_shared(folder: &str) -> (Option<i32>, String, String) {
    let dir = root().join(folder);
    let o = run(&["gap", dir.to_str().unwrap()]);
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// One usable PX4 log with 1.2 s in the air (of 6 s), at most 23 W drawn: no hover power can
/// be estimated from it, so none is printed (it used to print 1658 W and a 4952 % gap).
#[test]
fn ulog_folder_refuses_a_hover_power_from_one_second_of_flying() {
    let (code, out, err) = gap_on_shared("../shared/data/real/flightlogs/ulog");
    assert_eq!(code, Some(2), "{out}\n{err}");
    assert!(!out.contains("estimated hover power"), "{out}");
    assert!(!out.contains("energy per phase"), "{out}");
    // The skipped files' reasons come first, then the refusal naming the flight and its time.
    let skipped = err.find("skipped").expect(&err);
    let refusal = err.find("too little flying").expect(&err);
    assert!(skipped < refusal, "{err}");
    assert!(
        err.contains("pyulog_sample_log_small: 1.2 s of 6.0 s") && err.contains("10 s"),
        "{err}"
    );
}

/// The 0.8 s ArduPlane log is left out with its reason: a fixed-wing aircraft does not hover
/// (it used to be held out by the default split and score a 100 % energy error, then, from
/// session 16, to be held out but not scored for its 0.8 s). The two copter logs left are too
/// few to attribute the gap, which the output says after the gap against the baseline.
#[test]
fn dataflash_folder_leaves_out_a_fixed_wing_log() {
    let (code, out, err) = gap_on_shared("../shared/data/real/flightlogs/dataflash");
    assert_eq!(code, Some(0), "{out}\n{err}");
    assert!(!out.contains("100.00 %"), "{out}");
    assert!(
        err.contains("skipped")
            && err.contains("pymavlink_test_arduplane_first64k")
            && err.contains("the vehicle is a fixed-wing aircraft according to the log (ArduPlane"),
        "{err}"
    );
    assert!(
        out.contains("attribution needs at least 3 flights") && out.contains("2 read"),
        "{out}"
    );
}

/// Why a gap is `unexplained` is printed in words with its numbers, and `--json` carries the
/// same sentences; both rules are computed whichever sets the flag. A payload that drains in
/// flight (outside the library) leaves every flight's power drifting down from the first to
/// the second half, beyond the flights' own scatter.
#[test]
fn unexplained_says_why_in_text_and_json_alike() {
    let dir = tempfile::tempdir().unwrap();
    let out = simulate(
        dir.path(),
        &[
            "--family",
            "nmc/lab-1hz/paper",
            "--effect",
            "draining_payload=0.05",
            "--seed",
            "2",
        ],
    );
    let (train, held) = (out.join("train"), out.join("heldout"));
    // `None`: the default rule, which is the systematic one.
    for given in [Some("chi2"), Some("systematic"), None] {
        let rule = given.unwrap_or("systematic");
        let mut args = vec![
            "gap",
            train.to_str().unwrap(),
            "--holdout",
            held.to_str().unwrap(),
        ];
        if let Some(r) = given {
            args.extend(["--unexplained-rule", r]);
        }
        let v = json(&[&args[..], &["--json"]].concat());
        let text = run(&args);
        assert!(text.status.success());
        let text = String::from_utf8(text.stdout).unwrap();
        assert_eq!(v["unexplained_rule"], rule);
        assert_eq!(v["unexplained"], true, "{text}");
        assert_eq!(v["unexplained_by_systematic"], true);
        let reasons = v["unexplained_reasons"].as_array().unwrap();
        assert!(!reasons.is_empty());
        for r in reasons {
            let line = format!("unexplained ({rule} rule): {}", r.as_str().unwrap());
            assert!(text.lines().any(|l| l == line), "{line}\nnot in\n{text}");
        }
        // The systematic check's numbers: the drift shared by all 12 flights.
        let drift = v["systematic"]["patterns"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["quantity"] == "power_drift")
            .unwrap();
        assert_eq!(drift["set"], "all");
        assert_eq!(drift["flights"], 12);
        assert!(drift["systematic"] == true && drift["mean"].as_f64().unwrap() < -1.5);
        let mean = format!("{:+.2} %", drift["mean"].as_f64().unwrap());
        assert!(text.contains(&mean), "{mean} not in\n{text}");
    }
}

/// `battery learn` from one LiFePO₄ hover flight says what that flight could not teach: one
/// flight, the charge below the lowest it reached (10 % here, next to the cut-off's 5 %: the
/// curve there is the prior's, charge the autopilot never uses), no RC pair from a steady load;
/// the same words in `--json`. From the pack's four flights those warnings are gone. (Seed 20
/// since session 11: on the corrected simulated packs seed 3's hover flight runs to the cut-off
/// and finds an RC pair. Since session 12, whose flights hold the thrust limit over two seconds
/// and step their physics at 0.1 s whatever the log rate, its hover flight ends next to the
/// cut-off; none of seeds 21–50 of this family, nor 0–25 of `lfp/fc-10hz/paper` and
/// `lfp/bb-50hz/varied`, leaves both the charge above the cut-off's unreached and no RC pair.)
#[test]
fn battery_learn_from_one_flight_says_what_it_could_not_teach() {
    let dir = tempfile::tempdir().unwrap();
    let set = simulate(
        dir.path(),
        &["--family", "lfp/fc-10hz/varied", "--seed", "20"],
    );
    let params = dir.path().join("params.toml");
    let p = params.to_str().unwrap();
    ok(&["fit", set.join("rig-sweep.csv").to_str().unwrap(), "-o", p]);
    let fitted = std::fs::read(&params).unwrap();
    let one = dir.path().join("one");
    std::fs::create_dir(&one).unwrap();
    for ext in ["csv", "toml"] {
        let name = format!("1-hover-A.{ext}");
        std::fs::copy(set.join("train").join(&name), one.join(&name)).unwrap();
    }
    let out = run(&["battery", "learn", "--params", p, one.to_str().unwrap()]);
    assert!(out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    let warnings: Vec<&str> = err
        .lines()
        .filter_map(|l| l.strip_prefix("warning: "))
        .collect();
    assert_eq!(warnings.len(), 3, "{err}");
    assert!(warnings[0].starts_with("learned from one flight"), "{err}");
    assert!(
        warnings[1].starts_with("no flight reached below")
            && warnings[1].contains("lifepo4 prior's shape")
            && warnings[1].contains("next to the flights' cut-off")
            && warnings[1].contains("charge the autopilot never uses"),
        "{err}"
    );
    assert!(warnings[2].starts_with("no RC pair identified"), "{err}");
    std::fs::write(&params, &fitted).unwrap();
    let v = json(&[
        "battery",
        "learn",
        "--params",
        p,
        one.to_str().unwrap(),
        "--json",
    ]);
    let in_json: Vec<&str> = v["fit"]["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    assert_eq!(in_json, warnings);
    // The pack's four training flights (climbs, attachment): learned over the whole charge.
    std::fs::write(&params, &fitted).unwrap();
    let v = json(&[
        "battery",
        "learn",
        "--params",
        p,
        set.join("train").to_str().unwrap(),
        "--battery-type",
        "lfp-A",
        "--json",
    ]);
    assert_eq!(v["fit"]["flights"], 4);
    assert!(
        v["fit"]["warnings"].as_array().unwrap().is_empty(),
        "{}",
        v["fit"]["warnings"]
    );
}

/// Effects the flights cannot tell from the verdict are listed, with the same numbers in the
/// text and the JSON: an NMC pack with a Peukert loss, whose healthy series resistance alone
/// fits the training flights best and is kept unnamed, leaves the Peukert loss among them.
#[test]
fn effects_the_flights_cannot_tell_apart_are_listed() {
    let dir = tempfile::tempdir().unwrap();
    let out = simulate(
        dir.path(),
        &[
            "--family",
            "nmc/lab-1hz/paper",
            "--effect",
            "peukert=0.034",
            "--seed",
            "6",
        ],
    );
    let params = fit_rig(dir.path(), &out);
    let args = |json: bool| {
        let mut a = vec![
            "gap".to_owned(),
            out.join("train").to_str().unwrap().to_owned(),
            "--holdout".to_owned(),
            out.join("heldout").to_str().unwrap().to_owned(),
            "--params".to_owned(),
            params.to_str().unwrap().to_owned(),
        ];
        if json {
            a.push("--json".to_owned());
        }
        a
    };
    let a: Vec<String> = args(true);
    let v = json(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let looks = v["look_alikes"].as_array().unwrap();
    assert!(looks.iter().any(|l| l["effect"] == "peukert"), "{looks:?}");
    let a: Vec<String> = args(false);
    let text = ok(&a.iter().map(String::as_str).collect::<Vec<_>>());
    for l in looks {
        let drop = l["training_chi2_drop"].as_f64().unwrap();
        let alone = l["heldout_alone"].as_f64().unwrap();
        let line = format!(
            "also fits these flights: {} — alone it lowers the training χ² by {drop:.0}",
            l["effect"].as_str().unwrap()
        );
        assert!(text.contains(&line), "{line}\n{text}");
        assert!(text.contains(&format!("to {alone:.3} %")), "{text}");
    }
    assert!(text.contains("these flights cannot tell it from the verdict"));
}

#[test]
fn the_current_steps_read_a_connectors_resistance_that_the_effect_adds() {
    // The same packs and missions (seed 3) with and without a 50 mΩ connector: each pack's
    // steps read 50 mΩ more, within a few standard errors, and the text says what the JSON says.
    let dir = tempfile::tempdir().unwrap();
    let read = |effect: &str| {
        let set = simulate_into(
            dir.path(),
            &effect.replace('=', "-"),
            &[
                "--family",
                "nmc/fc-10hz/paper",
                "--effect",
                effect,
                "--seed",
                "3",
            ],
        );
        let v: Value = serde_json::from_str(&gap_on_set(&set, &["--json"])).unwrap();
        (v, gap_on_set(&set, &[]))
    };
    let (clean, clean_text) = read("none");
    let (worn, _) = read("internal_resistance=0.05");
    let steps = |v: &Value| -> Vec<(String, f64, f64, u64)> {
        v["step_resistances"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| {
                (
                    s["battery_type"].as_str().unwrap().to_owned(),
                    s["pack_ohm"].as_f64().unwrap(),
                    s["sigma_ohm"].as_f64().unwrap(),
                    s["steps"].as_u64().unwrap(),
                )
            })
            .collect()
    };
    let (a, b) = (steps(&clean), steps(&worn));
    assert_eq!(a.len(), 2, "{a:?}");
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.0, y.0);
        assert!(x.3 >= 3 && y.3 >= 3, "{x:?} {y:?}");
        let extra = y.1 - x.1;
        let sigma = x.2.hypot(y.2);
        assert!((extra - 0.05).abs() < 3.0 * sigma + 0.002, "{x:?} {y:?}");
    }
    // The text line per pack carries the same number, per cell.
    let per_cell_mohm = a[0].1 / 3.0 * 1000.0;
    let want = format!("series resistance of {per_cell_mohm:.1} ±");
    assert!(clean_text.contains(&want), "{want} in {clean_text}");
}

#[test]
fn a_voltage_only_set_without_a_rig_estimates_the_hover_power_its_current_would_show() {
    // The same seed flown with a 10 Hz current log and as a 5 Hz voltage-only log, diagnosed
    // without a rig: the voltage-only estimate (from the voltage's fall) lies within a fifth of
    // the current's mean hover power. Before session 25 every voltage-only set that flew to its
    // cut-off estimated 3.6 kW for a 0.5 kg robot (a model that empties the pack at once scored
    // as a near-perfect fit), and a LiFePO4 set was read on the LiPo curve and refused.
    let dir = tempfile::tempdir().unwrap();
    let hover_w = |family: &str| {
        let set = simulate_into(
            dir.path(),
            &family.replace('/', "-"),
            &["--family", family, "--effect", "none", "--seed", "3"],
        );
        let v: Value = serde_json::from_str(&gap_on_set(&set, &["--json"])).unwrap();
        v["estimated_hover_power_w"].as_f64().unwrap()
    };
    for (chemistry, robot) in [("lipo", "paper"), ("lfp", "varied")] {
        let logged = hover_w(&format!("{chemistry}/fc-10hz/{robot}"));
        let voltage_only = hover_w(&format!("{chemistry}/vonly-5hz/{robot}"));
        assert!(
            (voltage_only / logged - 1.0).abs() < 0.2,
            "{chemistry}: {voltage_only} W from the voltage, {logged} W from the current"
        );
    }
}

#[test]
fn gap_eval_without_the_rig_estimates_the_hover_power_from_current_or_voltage_alike() {
    // The paper's robot flown with a current log and as a voltage-only log, diagnosed without
    // its rig: every scenario runs, and the voltage-only estimates of the hover power lie within
    // a fifth of the current's (seeds 0–3, the families taken in turn).
    let v = json(&[
        "gap-eval",
        "--scenarios",
        "4",
        "--families",
        "lipo/fc-10hz/paper,lipo/vonly-5hz/paper",
        "--no-rig",
        "--json",
    ]);
    assert_eq!(v["failed"].as_array().unwrap().len(), 0, "{}", v["failed"]);
    let scenarios = v["scenarios"].as_array().unwrap();
    assert_eq!(scenarios.len(), 4);
    let hover = |logging: &str| -> Vec<f64> {
        scenarios
            .iter()
            .filter(|s| s["family"].as_str().unwrap().contains(logging))
            .map(|s| s["estimated_hover_power_w"].as_f64().unwrap())
            .collect()
    };
    let (logged, voltage_only) = (hover("fc-10hz"), hover("vonly-5hz"));
    let mean = logged.iter().sum::<f64>() / logged.len() as f64;
    for w in &voltage_only {
        assert!(
            (w / mean - 1.0).abs() < 0.2,
            "{voltage_only:?} against {logged:?}"
        );
    }
}
