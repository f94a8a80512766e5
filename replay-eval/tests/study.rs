//! A small study of the online estimator on simulated flights: what it must always do, and the
//! issue's targets (ignored while they are not met; the numbers are in the report and README).

use estimator::online::OnlineConfig;
use replay_eval::{Condition, StudyOptions, Targets, select_families, study};

fn small(families: &str, seeds: std::ops::Range<u64>) -> replay_eval::Study {
    study(
        &StudyOptions {
            seeds,
            families: select_families(families).unwrap(),
            threads: 2,
            config: OnlineConfig::default(),
            pack_history: false,
            voltage_only: false,
            motor_power: false,
        },
        &|| {},
    )
}

#[test]
fn conditions_are_drawn_evenly_from_the_seed() {
    let mut counts = [0usize; 7];
    for s in 0..700 {
        let c = Condition::draw(s);
        counts[Condition::NAMES
            .iter()
            .position(|n| *n == c.name())
            .unwrap()] += 1;
        assert_eq!(c, Condition::draw(s));
    }
    assert!(
        counts.iter().all(|&n| (70..=130).contains(&n)),
        "{counts:?}"
    );
}

#[test]
fn a_small_study_scores_every_held_out_flight_at_the_cut_off() {
    let s = small("lipo/lab-1hz/paper,nca/fc-10hz/varied", 0..4);
    for (seed, fam, r) in &s.scenarios {
        let o = r
            .as_ref()
            .unwrap_or_else(|e| panic!("seed {seed} {}: {e}", fam.name()));
        // Both pack types learned; every held-out flight flown to the cut-off and scored.
        assert_eq!(o.packs.len(), 2);
        assert!(o.skipped.is_empty(), "{:?}", o.skipped);
        assert_eq!(o.flights.len(), 4);
        for f in &o.flights {
            assert_eq!(f.checkpoints.len(), 4);
            for c in &f.checkpoints {
                let p = c.predicted_remaining_s.expect("online prediction");
                assert!(p.is_finite() && p >= 0.0);
                assert!(c.sigma_s.is_some_and(|s| s > 0.0));
            }
        }
    }
    let held = s
        .groups
        .iter()
        .find(|g| g.name == "all held-out families")
        .unwrap();
    assert_eq!(held.split, "held out");
    assert_eq!(held.replay.summary.scored_flights, 8);
}

/// The issue's targets on held-out families. Ignored: not met by the current online
/// estimator (see the replay report for the numbers).
#[test]
#[ignore = "issue 14 targets not met yet: see README (replay) for the measured numbers"]
fn heldout_families_meet_issue_14_targets() {
    let s = small("heldout", 0..40);
    let held = s
        .groups
        .iter()
        .find(|g| g.name == "all held-out families")
        .unwrap();
    let t = Targets::of(&held.replay.summary);
    assert!(t.all_met(), "{t:?}");
}

/// A pinned failure of the online estimator, traced on a tuning scenario (seed 5,
/// `lipo/fc-10hz/paper`, capacity fade 17 %; `cargo run --release -p replay-eval --example trace
/// -- lipo/fc-10hz/paper 5 0.1`). On pack A (learned section 2.03 Ah; the faded pack delivers
/// ≈ 1.57 Ah to the cut-off) the filter keeps the capacity at 2.03 Ah to the end and explains
/// the voltage falling faster than the counted charge says with the curve-offset state instead
/// (−0.15 V at 10 % of the flight, −0.48 V at 50 %), so it over-predicts the remaining time by
/// ≈ 30 % of the flight throughout (the logged power also sits ≈ 9 % below the model's on this
/// flight: a current sensor reading low, which the charge count cannot see either). The offset is needed: on nominal LiPo flights (tuning seeds
/// 12, 13) the learned curve sits −0.22…+0.36 V (pack) off before the knee, as much as this fade
/// moves it, so holding the offset tighter (drift 3e-3 or 1e-3 V/cell/√s, with the
/// capacity learned faster) made the tuning median worse (4.4 → 5.2…10.1 %). Ignored until the
/// fade is learned: the test states what "learned" means.
#[test]
#[ignore = "issue 14: a 17 % capacity fade is not learned (the curve offset absorbs it); see the doc comment"]
fn a_seventeen_percent_fade_is_learned_on_tuning_seed_5() {
    let fam = flight_sim::Family::parse("lipo/fc-10hz/paper").unwrap();
    let p = replay_eval::prepare_scenario(&fam, 5).unwrap();
    assert!(matches!(p.condition, Condition::CapacityFade { fraction } if fraction > 0.15));
    let o = replay_eval::replay_scenario(&p, &OnlineConfig::default());
    let f = o.flights.iter().find(|f| f.name == "9-hover-A").unwrap();
    let c = &f.checkpoints[1];
    let err = (c.predicted_remaining_s.unwrap() - c.true_remaining_s) / f.duration_s();
    assert!(
        err.abs() <= 0.03,
        "error at 50 %: {:+.1} % of the flight",
        err * 100.0
    );
}

/// The rig's limit sweep at the minimum battery voltage reproduces the paper's thrust limit on
/// its own platform: 150 g per rotor at 9.0 V (`paper-targets.md`, m_L = 0.600 kg), within the
/// sweep's 10 g step; and a lower voltage gives a lower limit.
#[test]
fn the_limit_sweep_finds_the_papers_thrust_limit_at_nine_volts() {
    let robot = flight_sim::Robot::of(flight_sim::RobotVariant::Paper, 0);
    let l = replay_eval::limit_sweep(&robot, 9.0, 10.0);
    assert!((l.per_rotor_g - 150.0).abs() <= 10.0, "{l:?}");
    assert!((l.uncertainty_g - 10.0 / 12f64.sqrt()).abs() < 1e-12);
    assert_eq!(l.supply_voltage_v, 9.0);
    assert!(replay_eval::limit_sweep(&robot, 8.0, 10.0).per_rotor_g < l.per_rotor_g);
}

/// Each held-out flight carries the curve-shape uncertainty of its pack's learned section:
/// `√2 × max(prior σ, fit RMSE)`, at least the 0.042 V per cell of a known chemistry, and the
/// unknown chemistry's 0.3 V prior (LiFePO₄ is not labelled) in full.
#[test]
fn prepared_flights_carry_the_learned_curve_sigma() {
    for (family, least) in [
        ("lipo/fc-10hz/paper", 0.03 * std::f64::consts::SQRT_2),
        ("lfp/fc-10hz/paper", 0.3 * std::f64::consts::SQRT_2),
    ] {
        let fam = flight_sim::Family::parse(family).unwrap();
        let p = replay_eval::prepare_scenario(&fam, 1).unwrap();
        assert!(!p.flights.is_empty());
        assert_eq!(p.curve_sigma_cell_v.len(), p.flights.len());
        for s in &p.curve_sigma_cell_v {
            let s = s.expect("a learned section says how its curve was fitted");
            assert!(s >= least - 1e-12 && s < 1.0, "{family}: {s}");
        }
    }
}

/// The sensor ablation flies the same worlds: a voltage-only log has no current sensor, so
/// calibrating the current sensor changes nothing there; calibrating the voltage sensor (and
/// both) changes the logs, and with them the estimates, of the same flights.
#[test]
fn the_sensor_ablation_flies_the_same_worlds() {
    use flight_sim::SensorErrors;
    let opts = StudyOptions {
        seeds: 2..3,
        families: select_families("lipo/vonly-5hz/paper").unwrap(),
        threads: 1,
        config: OnlineConfig::default(),
        pack_history: false,
        voltage_only: false,
        motor_power: false,
    };
    let errors = |sensors| {
        let s = replay_eval::study_with(&opts, sensors, &|| {});
        let o = s.scenarios[0].2.as_ref().unwrap().clone();
        o.flights
            .iter()
            .map(|f| (f.name.clone(), f.checkpoints[1].predicted_remaining_s))
            .collect::<Vec<_>>()
    };
    let drawn = errors(SensorErrors::Drawn);
    assert!(!drawn.is_empty());
    let plain = small("lipo/vonly-5hz/paper", 2..3);
    let o = plain.scenarios[0].2.as_ref().unwrap();
    assert_eq!(
        o.flights
            .iter()
            .map(|f| (f.name.clone(), f.checkpoints[1].predicted_remaining_s))
            .collect::<Vec<_>>(),
        drawn
    );
    assert_eq!(errors(SensorErrors::IdealCurrent), drawn);
    let ideal = errors(SensorErrors::Ideal);
    assert_eq!(
        ideal.iter().map(|f| &f.0).collect::<Vec<_>>(),
        drawn.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    assert_ne!(ideal, drawn);
}

/// `SWEEP_CFG`'s parser: overrides by field name, the thrust-limit switch, and errors that
/// name what is wrong.
#[test]
fn config_specs_override_the_defaults_by_name() {
    let c = replay_eval::config_from_spec(
        " charged_start_soc_sigma=0.02, voltage_bias_sigma_cell_v = 0.1,thrust_limit_end=0,thrust_headroom_fraction=0.05",
    )
    .unwrap();
    assert_eq!(c.charged_start_soc_sigma, 0.02);
    assert_eq!(c.voltage_bias_sigma_cell_v, 0.1);
    assert!(!c.thrust_limit_end);
    assert_eq!(c.thrust_headroom_fraction, 0.05);
    assert!(
        replay_eval::config_from_spec("thrust_limit_end=1")
            .unwrap()
            .thrust_limit_end
    );
    assert_eq!(
        OnlineConfig {
            charged_start_soc_sigma: 0.0,
            voltage_bias_sigma_cell_v: OnlineConfig::default().voltage_bias_sigma_cell_v,
            thrust_limit_end: OnlineConfig::default().thrust_limit_end,
            thrust_headroom_fraction: OnlineConfig::default().thrust_headroom_fraction,
            ..c
        },
        OnlineConfig::default()
    );
    assert_eq!(
        replay_eval::config_from_spec("").unwrap(),
        OnlineConfig::default()
    );
    for (bad, says) in [
        ("end_soc_sigma", "key=value"),
        ("end_soc_sigma=x", "not a number"),
        ("no_such_key=1", "unknown key"),
    ] {
        let e = replay_eval::config_from_spec(bad).unwrap_err();
        assert!(e.contains(says), "{bad}: {e}");
    }
}

/// A tuning scenario of `family` and `seed` whose packs have faded by more than `fade`, replayed
/// with the defaults without and with the packs' history.
fn faded_with_and_without_history(
    family: &str,
    seed: u64,
    fade: f64,
) -> (replay_eval::ScenarioOutcome, replay_eval::ScenarioOutcome) {
    let fam = flight_sim::Family::parse(family).unwrap();
    let p = replay_eval::prepare_scenario(&fam, seed).unwrap();
    assert!(matches!(p.condition, Condition::CapacityFade { fraction } if fraction > fade));
    (
        replay_eval::replay_scenario(&p, &OnlineConfig::default()),
        replay_eval::replay_scenario_with_history(&p, &OnlineConfig::default(), true),
    )
}

/// The packs' history (`replay --pack-history`) on a faded pack (tuning seed 26, an NMC pack
/// logged at 1 Hz): each pack's first flight is flown exactly as without it and measures a
/// capacity well below the model's, and its second flight starts from that reading and misses
/// less at half the flight.
#[test]
fn a_packs_history_carries_a_fade_to_its_next_flight() {
    let (without, with) = faded_with_and_without_history("nmc/lab-1hz/paper", 26, 0.15);
    let err50 = |f: &replay::FlightReplay| {
        let c = &f.checkpoints[1];
        ((c.predicted_remaining_s.unwrap() - c.true_remaining_s) / f.duration_s()).abs()
    };
    for (first, second) in [
        ("9-hover-A", "11-ceiling-A"),
        ("10-attach-B", "12-climbs-B"),
    ] {
        let get = |o: &replay_eval::ScenarioOutcome, n: &str| {
            o.flights.iter().find(|f| f.name == n).unwrap().clone()
        };
        let (a0, a1) = (get(&without, first), get(&with, first));
        assert_eq!(
            a0.checkpoints, a1.checkpoints,
            "{first} flies as without history"
        );
        assert!(a1.capacity_carried.is_none());
        let reading = a1.capacity_reading.clone().unwrap().unwrap();
        assert!(reading.carries(), "{first}: {reading:?}");
        let (b0, b1) = (get(&without, second), get(&with, second));
        let (from, factor) = b1.capacity_carried.clone().unwrap();
        assert_eq!(from, first);
        assert!((factor - reading.factor()).abs() < 1e-12);
        assert!(
            err50(&b1) < err50(&b0) - 0.01,
            "{second}: {:.1} % with history, {:.1} % without",
            100.0 * err50(&b1),
            100.0 * err50(&b0)
        );
    }
}

/// A pack that reads within `history::MIN_SHORTFALL` of its model (tuning seed 0, a LiPo pack
/// with a fade under 15 % logged at 1 Hz) is read, but its next flight flies with the model's
/// capacity, exactly as without the history.
#[test]
fn a_packs_history_keeps_the_models_capacity_for_a_pack_that_reads_close_to_it() {
    let (without, with) = faded_with_and_without_history("lipo/lab-1hz/paper", 0, 0.05);
    for (a, b) in without.flights.iter().zip(&with.flights) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.checkpoints, b.checkpoints, "{}", a.name);
        assert!(b.capacity_carried.is_none(), "{}", b.name);
        let reading = b.capacity_reading.clone().unwrap().unwrap();
        assert!(!reading.carries() && reading.factor() < 0.98, "{reading:?}");
    }
}

/// The voltage-only ablation: the same held-out flights without their current column. The
/// baselines that need a current say so, the online estimator still predicts, and the flights,
/// their ends and their truths are the same.
#[test]
fn without_current_the_same_flights_are_replayed_from_their_voltage() {
    let fam = flight_sim::Family::parse("lipo/lab-1hz/paper").unwrap();
    let p = replay_eval::prepare_scenario(&fam, 0).unwrap();
    let names: Vec<String> = p.flights.iter().map(|(f, _)| f.name.clone()).collect();
    let v = p.clone().without_current();
    assert!(v.flights.iter().all(|(f, _)| f.samples.current_a.is_none()));
    assert!(p.flights.iter().all(|(f, _)| f.samples.current_a.is_some()));
    let o = replay_eval::replay_scenario(&v, &OnlineConfig::default());
    let got: Vec<String> = o.flights.iter().map(|f| f.name.clone()).collect();
    assert_eq!(got, names);
    for f in &o.flights {
        assert!(
            f.checkpoints
                .iter()
                .all(|c| c.predicted_remaining_s.is_some())
        );
        assert!(
            f.unavailable
                .iter()
                .any(|(m, r)| *m == replay::methods::PX4 && r.contains("no current"))
        );
    }
}

/// The motor commands' power: a family whose flight controller logs its motor commands gets
/// the rotors' power read from them (through the motor map fitted on the world's rig sweeps),
/// beside the current or without it; without the commands (`StudyOptions::motor_power` off),
/// none. The replays differ each time.
#[test]
fn the_motor_commands_power_is_read_only_when_the_commands_are_kept() {
    use replay::{Commands, PowerSource};
    let fam = flight_sim::Family::parse("lipo/fc-10hz/paper").unwrap();
    let p = replay_eval::prepare_scenario(&fam, 1).unwrap();
    assert!(
        p.params.motor.is_some(),
        "the world's rig gives a motor map"
    );
    assert!(p.flights.iter().all(|(f, _)| f.samples.motor_us.is_some()));
    let config = OnlineConfig::default();
    let run = |p: &replay_eval::PreparedScenario, current: bool, commands: Commands| {
        let o = replay_eval::replay_scenario(p, &config);
        let want = PowerSource { current, commands };
        assert!(o.flights.iter().all(|f| f.power_source == want), "{want:?}");
        o.flights
            .iter()
            .flat_map(|f| f.checkpoints.iter().map(|c| c.predicted_remaining_s))
            .collect::<Vec<Option<f64>>>()
    };
    let both = run(&p, true, Commands::Used);
    let current = run(&p.clone().without_motors(), true, Commands::NotLogged);
    assert_ne!(both, current);
    let motors = run(&p.clone().without_current(), false, Commands::Used);
    let model = run(
        &p.without_current().without_motors(),
        false,
        Commands::NotLogged,
    );
    assert_ne!(motors, model);
}

/// The analysis lines (`sweep` with `SWEEP_TRUTH=1`) give each flight's pack as flight-sim flew
/// it only when asked. On the faded pack of tuning seed 0 the true capacity lies below the
/// capacity the filter ended every flight with (the filter sees a fade only in part).
#[test]
fn the_truth_lines_appear_only_when_asked_and_show_the_fade() {
    let s = small("lipo/lab-1hz/paper", 0..1);
    let plain = replay_eval::flight_lines(&s);
    let with = replay_eval::flight_lines_with(&s, true);
    let Ok(o) = &s.scenarios[0].2 else {
        panic!("seed 0 failed")
    };
    assert!(matches!(o.condition, Condition::CapacityFade { .. }));
    assert!(!plain.contains("truth:"));
    let truths: Vec<&str> = with.lines().filter(|l| l.contains("truth: R")).collect();
    assert_eq!(truths.len(), o.flights.len(), "{with}");
    for f in &o.flights {
        let t = o.truth_pack.iter().find(|t| t.0 == f.name).unwrap();
        let filter_ah = f
            .final_state
            .iter()
            .find(|x| x.0 == "usable_capacity_ah")
            .unwrap()
            .1;
        assert!(t.2 > 0.0, "{t:?}");
        assert!(
            t.1 < filter_ah,
            "{}: truth {t:?}, filter {filter_ah}",
            f.name
        );
    }
}
