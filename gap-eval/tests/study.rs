//! The blind study end to end on a few scenarios, and what the truth puts in front of the
//! diagnosis.

use flight_sim::{EffectKind, Family, Withheld, generate};
use gap_eval::{StudyOptions, adapter, read_back, rig_curve, select_families, study};

#[test]
fn reduced_study_runs_and_reports_per_family() {
    let families = select_families("lipo/lab-1hz/paper,lfp/lab-1hz/varied").unwrap();
    let rep = study(
        &StudyOptions {
            seeds: 0..4,
            families,
            threads: 2,
            ..StudyOptions::default()
        },
        &|_| {},
    )
    .unwrap();
    assert!(rep.failed.is_empty(), "{:?}", rep.failed);
    assert_eq!(rep.scenarios.len(), 4);
    assert_eq!(rep.tuning_families, ["lipo/lab-1hz/paper"]);
    assert_eq!(rep.heldout_families, ["lfp/lab-1hz/varied"]);
    for name in [
        "all held-out families",
        "all tuning families",
        "lfp/lab-1hz/varied",
    ] {
        let g = rep.groups.iter().find(|g| g.name == name).unwrap();
        assert_eq!(g.scenarios, 2, "{name}");
    }
    // Each scenario's truth is its own: the study never reads it from the flights.
    for s in &rep.scenarios {
        assert!(s.heldout_endurance_before_pct.is_some(), "seed {}", s.seed);
    }
}

/// A big withheld effect shows in the held-out endurance gap the diagnosis measures before any
/// effect is added: what the truth withholds reaches the diagnosis through the files. The gap
/// opens by at least half the effect's impact (the battery learned from the faded training
/// flights takes up the rest: on seed 21, 1.2 % → 10.5 % for an impact of −16.5 %).
#[test]
fn a_withheld_effect_opens_a_held_out_gap() {
    let fam = Family::parse("lipo/lab-1hz/paper").unwrap();
    let gap_of = |effect: Withheld| {
        let set = generate(&fam, &effect, 21);
        let o = adapter::diagnose_blind(
            &read_back(&set.train).unwrap(),
            &read_back(&set.heldout).unwrap(),
            &rig_curve(&set.rig).unwrap(),
            4,
        )
        .unwrap();
        (
            o.heldout_endurance_before_pct.unwrap(),
            set.truth.endurance_impact_pct(),
        )
    };
    let (clean, _) = gap_of(Withheld::NONE);
    let (faded, impact) = gap_of(Withheld {
        kind: EffectKind::CapacityFade,
        magnitude: 0.2,
    });
    assert!(impact < -15.0, "{impact} %");
    assert!(
        faded > clean + 0.5 * impact.abs(),
        "{clean} % → {faded} % (impact {impact} %)"
    );
}

/// The battery fit runs twice, the second round counting the state of charge on the first
/// round's curve. On tuning seed 39 (nmc/fc-10hz, Peukert withheld) the first round's curve of
/// pack nmc-B is flat from 0.45 of the charge up; three of its flights, resting at 4.15–4.16 V
/// per cell, read a start near 0.35 on it, the count then runs them 0.4–0.5 of the charge past
/// empty, the second round's curve collapses (flat knots, the discharge taken by a slow RC
/// pair), and the held-out endurance error after the diagnosis is 23.1 %.
///
/// Tried and reverted (issue 9, each made some held-out predictions worse by more than 0.25 pp):
/// keeping the first round when the second counts 8 % more samples past empty (17.8 %; commit
/// 17badd5); taking a start the count runs more than 30 % past empty from the count, and keeping
/// the first round when the second round's own curve still reads such starts (17.8 %; commit
/// d5fff1d on branch `wt-s7-gapsoc`, 2 of 100 worse on held-out seeds 5000-5099, 1 of 40 on
/// 9500-9539, 1 of 60 on 9700-9759). Also tried (commit 980f134 on branch `wt-s7-gapsoc`,
/// session 7 helper gapsoc2): when the first round's count runs a flight more than 30 % past
/// empty, refit with one additive voltage-sensor offset per flight (zero-mean prior σ 0.04 V per
/// cell, the offsets summing to zero) and a prior on R₀ from the take-off step, each training
/// flight's start read through its round-1 offset: seed 39 8.0 %, tuning seeds 8/26/30/32 from
/// ~50 % to 9-14 %, 0 worse on tuning 0-39, all 0-39, 9500-9539 and fresh 10300-10359, but 1 of
/// 100 worse on 5000-5099 (5039 lfp/bb-50hz 0.73 → 1.53 %). The learned offsets reach
/// 0.2-0.4 V per cell (5-10 σ) on lab-1hz logs, so they absorb model misfit, not only sensor
/// error: their prior is swamped by hundreds of rows per flight. The same with the count capped
/// at a full pack in the trigger (commit dd0662c, helper gapsoc3: 5039's trigger was a count
/// beyond the rated charge from a start read full, the count's error) is 0 worse on all six
/// gap-eval sets (tuning 0-39, all 0-39, 5000-5099, 9500-9539, 10300-10359, fresh
/// 10500-10559), but flown by the in-flight estimator (issue 14, `replay-eval`'s sweep, flight
/// by flight at half the flight against main) it makes 6 held-out flights worse by more than
/// 0.25 pp and 5 better: tuning 0-23 1/1, 9100-9135 0/2, 9800-9835 1/0, 9900-9935 1/1 (9908
/// lihv-A, cold: −13.6 → −23.8 %), fresh 10700-10735 3/1 (10732 lipo-B, 22 % fade: 4.9 → 16.8
/// and 6.0 → 10.4 %). Where it fires there, main's curve had collapsed and `replay` flew the
/// built-in LiPo table instead; the refit's curve is real but its R₀ came out 0 (9908) or the
/// section's capacity grew by 10 % (10732, the collapsed curve's high mean voltage had shrunk it,
/// which offset part of the fade the filter does not learn). Ignored until a fix passes that rule
/// for both the diagnosis and the estimator.
///
/// Candidate C (commit 37c9755, session 7 helper gapsoc4; measured again in session 8 by helper
/// gapc against main 8d21bb0): dd0662c plus R₀ held at the take-off step's mean − 2σ at least
/// and the per-flight offsets bounded at ±2σ (0.08 V per cell). Replay against main, flights
/// worse/better by > 0.25 pp at half the flight: tuning 0-23 0/2, 9100 0/2, 9800 2/0, 9900 0/2,
/// fresh 10700 0/3. Both worse flights are 9805 lihv-B (bb-50hz, a 16 % fade on the held-out
/// flights): 10-attach-B 0.3 → 5.6 %, 12-climbs-B −21.1 → +23.8 %. There main's second round
/// had collapsed (knots 4.32-4.42 V), `replay` flew the LiPo table, and the collapsed curve's
/// high mean voltage shrank the section's capacity to 1.23 Ah, which happened to offset the
/// fade; C's curve is real (3.53-4.42 V, 1.33 Ah; the training flights measured 1.41 Ah usable)
/// and its errors are those of a nominal model that does not see the fade (the static model:
/// +5.9 and +28.2 %). In the diagnosis C is NOT 0 worse (session 7's gap-eval JSONs of A-F
/// came from a stale `hoverbench` binary, byte-identical for every variant, i.e. dd0662c's):
/// runs worse/better by > 0.25 pp against main: tuning 0-39 0/3, all 0-39 1/1 (26 nca 98.5 →
/// 100.0 %), 5000-5099 2/6 (5023 nmc/bb-50hz 18.7 → 28.9 %, 5084 lihv/fc-10hz 21.2 → 49.6 %),
/// 9500-9539 1/1 (9516 lihv/bb-50hz 39.8 → 52.0 %), 10300-10359 1/1 (10341 lihv/fc-10hz 49.4 →
/// 50.7 %), 10500-10559 0/3. On tuning seed 8 the R₀ floor (2.6 mΩ) leaves pack lipo-A's
/// refit collapsing again (knots flat at 4.20 V): 50.7 % as on main, where dd0662c had 9.6 %.
#[ignore = "fails until the battery fit stops a diverging second round without making a held-out prediction worse (issue 9)"]
#[test]
fn a_diverging_second_round_of_the_battery_fit_is_not_kept() {
    let families = select_families("tuning").unwrap();
    let s = gap_eval::run_scenario(39, &families).unwrap();
    assert_eq!(s.family, "nmc/fc-10hz/paper");
    let after = s.heldout_endurance_after_pct.unwrap();
    assert!(after < 20.0, "held-out endurance error after {after} %");
}

/// The battery fit says when its state of charge is inconsistent: on tuning seed 2
/// (nmc/lab-1hz) no fit carries the mark; the same flights with one training flight's current
/// logged at twice its value (a power module set up with the wrong amps-per-volt, so the count
/// runs far past empty) mark that flight's pack UNRELIABLE, and only that pack. (Until session
/// 11 a seed whose fit collapsed on its own served; on the corrected worlds no tuning seed of
/// 0–199 does.)
#[test]
fn a_count_run_far_past_empty_marks_the_learned_battery_unreliable() {
    let families = select_families("tuning").unwrap();
    let seed = 2;
    let family = gap_eval::family_of(seed, &families);
    let set = generate(&family, &flight_sim::draw_effect(seed), seed);
    let notes = |gain: f64| -> (String, Vec<(String, String)>) {
        let mut train = read_back(&set.train).unwrap();
        let bad = &mut train[0];
        if let Some(c) = bad.samples.current_a.as_mut() {
            c.iter_mut().for_each(|a| *a *= gain);
        }
        let bad_type = gap::battery::battery_type(&gap::logs::record_from_log(bad).unwrap());
        let records = |fs: &[flightlog::Flight]| -> Vec<gap::flight::FlightRecord> {
            fs.iter()
                .map(|f| gap::logs::record_from_log(f).unwrap())
                .collect()
        };
        let (train, heldout) = (records(&train), records(&read_back(&set.heldout).unwrap()));
        let curve = rig_curve(&set.rig).unwrap();
        let d = gap::diagnose::diagnose(
            gap::model::Model {
                curve: &curve,
                rotor_count: set.rig.rotor_count,
            },
            &train.iter().collect::<Vec<_>>(),
            &heldout.iter().collect::<Vec<_>>(),
            &gap::diagnose::DiagnoseOptions::default(),
        )
        .unwrap();
        let notes = d
            .batteries
            .iter()
            .map(|b| (b.battery_type.clone(), b.note.clone()))
            .collect();
        (bad_type, notes)
    };
    let (_, clean) = notes(1.0);
    assert!(
        clean.iter().all(|(_, n)| !n.contains("UNRELIABLE")),
        "{clean:?}"
    );
    let (bad_type, flagged) = notes(2.0);
    for (t, n) in &flagged {
        assert_eq!(
            n.contains("UNRELIABLE"),
            *t == bad_type,
            "{bad_type}: {flagged:?}"
        );
    }
}

/// Issue 9's targets on the held-out families (run with `--ignored`; expensive). With the
/// diagnosis of this commit it FAILS: see `hoverbench gap-eval` for the per-family numbers.
#[test]
#[ignore = "expensive; fails until the diagnosis learns the battery (issue 9)"]
fn heldout_families_meet_issue_9_targets() {
    let rep = study(
        &StudyOptions {
            seeds: 0..80,
            families: select_families("heldout").unwrap(),
            threads: 2,
            ..StudyOptions::default()
        },
        &|_| {},
    )
    .unwrap();
    let g = &rep.groups[0];
    assert_eq!(g.name, "all held-out families");
    assert!(g.library_rate().unwrap_or(1.0) >= 0.9, "{g:?}");
    assert!(g.none_rate().unwrap_or(1.0) >= 0.95, "{g:?}");
    assert!(g.outside_rate().unwrap_or(1.0) >= 0.8, "{g:?}");
    assert_eq!(g.worse.1, 0, "{g:?}");
    assert!(g.median_shrinkage.unwrap_or(1.0) >= 0.8, "{g:?}");
}

/// The systematic rule for `unexplained` (the default since session 10): a payload that drains in flight,
/// which no library effect represents, leaves a power drift shared by every flight; the same
/// world without it leaves only the flights' own scatter.
#[test]
fn the_systematic_rule_flags_a_draining_payload_and_not_its_clean_world() {
    let fam = Family::parse("lipo/lab-1hz/paper").unwrap();
    let outcome = |effect: Withheld| {
        let set = generate(&fam, &effect, 44);
        adapter::diagnose_blind_with(
            &read_back(&set.train).unwrap(),
            &read_back(&set.heldout).unwrap(),
            &rig_curve(&set.rig).unwrap(),
            set.rig.rotor_count,
            gap_eval::UnexplainedRule::Systematic,
        )
        .unwrap()
    };
    let clean = outcome(Withheld::NONE);
    assert!(!clean.unexplained, "{:?}", clean.unexplained_reasons);
    assert!(clean.unexplained_reasons.is_empty());
    // The χ² rule flags the clean world all the same (fixed floors below the scatter).
    assert!(clean.unexplained_by_chi2);
    let drained = outcome(Withheld {
        kind: EffectKind::DrainingPayload,
        magnitude: 0.05,
    });
    assert!(drained.unexplained && drained.unexplained_by_systematic);
    assert!(
        drained
            .unexplained_reasons
            .iter()
            .any(|r| r.contains("late half of the flight minus early half")),
        "{:?}",
        drained.unexplained_reasons
    );
}

/// The study's account of a miss reads the search's own evidence: on tuning seed 6 (an NMC
/// pack with a Peukert loss of 4 % endurance impact) the extra series resistance alone fits the
/// training flights better than the Peukert loss alone, and the verdict is empty.
#[test]
fn a_miss_is_put_on_the_step_that_lost_it() {
    let families = select_families("tuning").unwrap();
    let s = gap_eval::run_scenario(6, &families).unwrap();
    assert_eq!(s.truth, "peukert");
    assert!(s.strict_scored && !s.strict_correct, "{}", s.verdict);
    let m = s
        .miss
        .as_ref()
        .expect("a missed library effect has a cause");
    assert_eq!(m.cause, gap_eval::MissCause::Outranked, "{}", m.detail);
    assert!(m.detail.starts_with("internal_resistance"), "{}", m.detail);
    // The evidence is the search's: every single is fitted from the baseline, so none has a
    // larger χ², and they come best first.
    let ev = &s.search;
    assert!(ev.singles.len() >= 2);
    assert!(ev.singles.windows(2).all(|w| w[0].chi2 <= w[1].chi2));
    assert!(ev.singles.iter().all(|x| x.chi2 <= ev.baseline_chi2));
    assert_eq!(ev.singles[0].effect, "internal_resistance");
    let peukert = ev.singles.iter().find(|x| x.effect == "peukert").unwrap();
    assert!(ev.baseline_chi2 - peukert.chi2 > ev.min_delta_chi2);
}
