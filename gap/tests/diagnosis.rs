//! The diagnosis on simulated flight sets with a known truth, and a reduced blind study.

use gap::diagnose::{DiagnoseOptions, diagnose};
use gap::eval::{generate, rig_curve, study};
use gap::flight::FlightRecord;
use gap::model::{Effect, Model};
use gap::truth::{OutOfLibrary, Robot, TruthEffect};

fn diagnose_truth(effect: TruthEffect, seed: u64) -> gap::diagnose::Diagnosis {
    let robot = Robot::paper();
    let curve = rig_curve(&robot).unwrap();
    let set = generate(&robot, seed, effect);
    let train: Vec<&FlightRecord> = set.train.iter().collect();
    let held: Vec<&FlightRecord> = set.heldout.iter().collect();
    diagnose(
        Model {
            curve: &curve,
            rotor_count: 4,
        },
        &train,
        &held,
        // The pilot knows the packs are LiPo (the truth's table is not given: only the
        // chemistry, whose prior comes from measured PyBaMM curves).
        &DiagnoseOptions {
            chemistry: Some(gap::battery::Chemistry::Lipo),
            ..DiagnoseOptions::default()
        },
    )
    .unwrap()
}

#[test]
fn a_clean_robot_is_within_noise() {
    let d = diagnose_truth(TruthEffect::None, 7);
    assert!(d.within_noise, "{:?}", d.baseline);
    assert!(d.verdict.is_empty());
    assert!(!d.unexplained);
}

#[test]
fn extra_pack_resistance_is_found_and_measured() {
    let d = diagnose_truth(TruthEffect::Library(Effect::InternalResistance, 0.05), 11);
    assert_eq!(d.verdict, [Effect::InternalResistance]);
    // The parameter is the resistance above the nominal 5 mΩ per cell. This truth's healthy
    // pack has 0.6 × nominal in series (and 0.4 × nominal in an RC pair, which the learned
    // battery takes), so 0.05 Ω more is 0.05 − 3 × 2 mΩ = 0.044 Ω above the nominal.
    let r = d.effects[0].parameter.value;
    assert!(
        (r - 0.044).abs() < 0.005,
        "fitted {r} Ω for 0.044 Ω above nominal"
    );
    assert!(!d.unexplained);
    // The held-out endurance gap shrinks by most of itself.
    let (before, after) = (
        d.baseline.heldout.endurance_pct.unwrap(),
        d.after.heldout.endurance_pct.unwrap(),
    );
    assert!(after < 0.3 * before, "{before} % → {after} %");
    assert!(d.effects[0].share_of_gap > 0.6);
}

#[test]
#[ignore = "open regression (issue 9 item 1): the learned open-circuit curve and RC pair absorb \
            most of a 12 % capacity fade in this truth's world even with the chemistry given"]
fn capacity_fade_is_told_from_resistance() {
    let d = diagnose_truth(TruthEffect::Library(Effect::CapacityFade, 0.12), 12);
    assert_eq!(d.verdict, [Effect::CapacityFade]);
    let v = d.effects[0].parameter.value;
    assert!((v - 0.12).abs() < 0.02, "fitted fade {v}");
}

#[test]
fn an_effect_outside_the_library_is_not_forced_onto_one() {
    let d = diagnose_truth(
        TruthEffect::OutOfLibrary(OutOfLibrary::MotorHeating, 0.15),
        13,
    );
    assert!(
        d.unexplained,
        "verdict {:?} without 'unexplained'",
        d.verdict
    );
}

/// A reduced blind study (the full one is `hoverbench gap-eval --scenarios 200`).
#[test]
fn reduced_blind_study_scores() {
    let robot = Robot::paper();
    let curve = rig_curve(&robot).unwrap();
    let rep = study(
        &robot,
        &curve,
        4,
        0..16,
        &DiagnoseOptions::default(),
        2,
        &|_| {},
    );
    assert_eq!(rep.scenarios.len(), 16);
    assert_eq!(rep.false_positive_rate_none.unwrap_or(0.0), 0.0);
    // Every single library effect with at least 2 % endurance impact in this range is named.
    for s in &rep.scenarios {
        if s.truth != "none" && s.truth != "out_of_library" && s.impact_pct.abs() >= 2.0 {
            assert!(
                s.correct,
                "seed {}: {} ({:.1} %) diagnosed as {}",
                s.seed, s.truth, s.impact_pct, s.verdict
            );
        }
    }
}
