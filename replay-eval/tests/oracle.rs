//! The oracle ablation (`replay_eval::oracle`): inert when off, and with everything handed the
//! filter's own structure predicts a calm world's flights closely.

use estimator::online::OnlineConfig;
use flight_sim::SensorErrors;
use replay_eval::{Oracle, StudyOptions, select_families, study_oracles, study_with};

fn opts(families: &str, seeds: std::ops::Range<u64>) -> StudyOptions {
    StudyOptions {
        seeds,
        families: select_families(families).unwrap(),
        threads: 2,
        config: OnlineConfig::default(),
        pack_history: false,
        voltage_only: false,
        motor_power: false,
    }
}

fn err50(s: &replay_eval::Study) -> Vec<(u64, String, f64)> {
    s.scenarios
        .iter()
        .filter_map(|(seed, _, r)| r.as_ref().ok().map(|o| (*seed, o)))
        .flat_map(|(seed, o)| {
            o.flights.iter().map(move |f| {
                let c = &f.checkpoints[1];
                let p = c.predicted_remaining_s.unwrap_or(f64::NAN);
                (
                    seed,
                    f.name.clone(),
                    (p - c.true_remaining_s) / (f.end_s - f.takeoff_s) * 100.0,
                )
            })
        })
        .collect()
}

/// With every switch off the oracle's own estimator builder replays each flight exactly as the
/// study does (to the bit, every checkpoint and final state); `sensors` alone is the sensor
/// ablation; and each piece of the truth changes the estimates.
#[test]
fn the_oracle_switches_are_inert_when_off() {
    // A logged current (fc-10hz) and a voltage-only log (vonly-5hz).
    let o = opts("nmc/fc-10hz/paper,lipo/vonly-5hz/paper", 4..6);
    let set = [
        Oracle::NONE,
        Oracle::only("sensors").unwrap(),
        Oracle::only("curve").unwrap(),
        Oracle::only("capacity").unwrap(),
        Oracle::only("resistance").unwrap(),
        Oracle::only("power").unwrap(),
        Oracle::only("start").unwrap(),
    ];
    let studies = study_oracles(&o, &set, &|| {});
    let plain = study_with(&o, SensorErrors::Drawn, &|| {});
    assert!(plain.scenarios.iter().all(|s| s.2.is_ok()));
    // Debug text: equal to the bit, NaN placeholders included (NaN != NaN under PartialEq).
    assert_eq!(
        format!("{:?}", studies[0].scenarios),
        format!("{:?}", plain.scenarios)
    );
    assert_eq!(
        format!("{:?}", studies[0].groups),
        format!("{:?}", plain.groups)
    );
    let ideal = study_with(&o, SensorErrors::Ideal, &|| {});
    assert_eq!(
        format!("{:?}", studies[1].scenarios),
        format!("{:?}", ideal.scenarios)
    );
    let base = err50(&plain);
    assert!(base.len() >= 6, "{base:?}");
    for (k, s) in studies.iter().enumerate().skip(2) {
        let e = err50(s);
        assert_eq!(e.len(), base.len());
        assert_ne!(e, base, "{} changes nothing", set[k].name());
    }
}

/// The voltage-only ablation reaches the oracles too: with every switch off they replay the
/// flights without their current exactly as the study does.
#[test]
fn the_oracles_replay_without_the_current_when_asked() {
    let o = StudyOptions {
        voltage_only: true,
        motor_power: false,
        ..opts("nmc/fc-10hz/paper", 4..5)
    };
    let none = study_oracles(&o, &[Oracle::NONE], &|| {}).remove(0);
    let plain = study_with(&o, SensorErrors::Drawn, &|| {});
    assert!(plain.scenarios.iter().all(|s| s.2.is_ok()));
    assert_eq!(
        format!("{:?}", none.scenarios),
        format!("{:?}", plain.scenarios)
    );
    let with_current = study_with(
        &StudyOptions {
            voltage_only: false,
            motor_power: false,
            ..opts("nmc/fc-10hz/paper", 4..5)
        },
        SensorErrors::Drawn,
        &|| {},
    );
    assert_ne!(err50(&none), err50(&with_current));
}

/// Everything handed (the pack's curve, capacity, resistance and start, the power above the
/// model, calibrated sensors) on a calm world — a lab logger at 1 Hz, LiPo, nominal robot —
/// leaves only the filter's structure (one RC pair for two, no hysteresis or temperature, a
/// constant power): the remaining time at half the flight is then within 3 % of the flight on
/// every flight, whatever the condition, and much closer in the median.
#[test]
fn everything_handed_predicts_a_calm_worlds_flights_closely() {
    let o = opts("lipo/lab-1hz/paper", 0..6);
    let all = study_oracles(&o, &[Oracle::ALL], &|| {}).remove(0);
    let e = err50(&all);
    assert!(e.len() >= 12, "{e:?}");
    let mut abs: Vec<f64> = e.iter().map(|x| x.2.abs()).collect();
    assert!(abs.iter().all(|v| v.is_finite() && *v < 3.0), "{e:?}");
    abs.sort_by(f64::total_cmp);
    let median = abs[abs.len() / 2];
    assert!(median < 1.5, "median {median}: {e:?}");
}
