//! Invariants of the simulated worlds.

use flight_sim::{Chemistry, EffectKind, Family, Logging, RobotVariant, Withheld, generate};

fn family(chemistry: Chemistry, logging: Logging) -> Family {
    Family {
        chemistry,
        logging,
        robot: RobotVariant::Paper,
    }
}

#[test]
fn lipo_hover_lasts_about_the_paper_endurance() {
    let set = generate(
        &family(Chemistry::LiPo, Logging::Lab1Hz),
        &Withheld::NONE,
        1,
    );
    // Flight 1: hover to cut-off on Battery-A without payload. The paper's eq. 1–5 give
    // 13.83 min; a real pack leaves some charge behind at the loaded cut-off.
    let f = &set.train[0];
    assert!(f.name.contains("hover") && f.ended_at_cutoff);
    let min = f.endurance_s / 60.0;
    assert!((11.0..14.5).contains(&min), "{min} min");
}

#[test]
fn every_chemistry_and_log_flies_to_its_cutoff() {
    let worlds = Chemistry::ALL
        .into_iter()
        .map(|c| (c, Logging::Lab1Hz))
        .chain(Logging::ALL.into_iter().map(|l| (Chemistry::LiPo, l)));
    for (chem, log) in worlds {
        {
            let set = generate(&family(chem, log), &Withheld::NONE, 3);
            for f in set.train.iter().chain(&set.heldout) {
                assert!(f.ended_at_cutoff, "{chem:?} {log:?} {}", f.name);
                assert!(
                    f.endurance_s > 240.0,
                    "{chem:?} {log:?} {} {}",
                    f.name,
                    f.endurance_s
                );
                let rows = f.csv.lines().count() - 1;
                assert_eq!(rows, f.samples);
                // Roughly the logging rate, less the dropped samples.
                let expected = f.endurance_s * [1.0, 10.0, 5.0, 50.0][log as usize];
                assert!(rows as f64 > 0.9 * expected && rows as f64 <= expected + 1.0);
            }
        }
    }
}

#[test]
fn effects_move_endurance_the_way_their_physics_says() {
    let fam = family(Chemistry::Nmc, Logging::Fc10Hz);
    let impact = |kind: EffectKind, magnitude: f64| {
        generate(&fam, &Withheld { kind, magnitude }, 5)
            .truth
            .endurance_impact_pct()
    };
    for (k, m) in [
        (EffectKind::InternalResistance, 0.08),
        (EffectKind::CapacityFade, 0.1),
        (EffectKind::Peukert, 0.05),
        (EffectKind::ControlOverhead, 0.08),
        (EffectKind::AttachedPower, 0.3),
        (EffectKind::AirDensity, 0.2),
        (EffectKind::MotorHeating, 80.0),
    ] {
        let i = impact(k, m);
        assert!(i < -0.3, "{k:?}: {i} %");
    }
    for (k, m) in [
        (EffectKind::CeilingEffect, 0.3),
        (EffectKind::DrainingPayload, 0.06),
    ] {
        let i = impact(k, m);
        assert!(i > 0.3, "{k:?}: {i} %");
    }
    // Climbs are a few percent of a flight: their cost is small but real.
    assert!(impact(EffectKind::ClimbPower, 10.0) < 0.0);
    assert_eq!(impact(EffectKind::None, 0.0), 0.0);
}

#[test]
fn voltage_only_logs_have_no_current_column() {
    let set = generate(
        &family(Chemistry::LiFePo4, Logging::VoltageOnly5Hz),
        &Withheld::NONE,
        2,
    );
    assert!(set.train[0].csv.starts_with(
        "time_s,voltage_v,phase,altitude_m,motor1_us,motor2_us,motor3_us,motor4_us\n"
    ));
    assert!(set.train[0].toml.contains("cells = 4"));
    assert!(set.train[0].toml.contains("ceiling_height_m = 2.5\n"));
}

#[test]
fn same_seed_same_files() {
    let fam = family(Chemistry::LiHv, Logging::Blackbox50Hz);
    let e = Withheld {
        kind: EffectKind::Peukert,
        magnitude: 0.03,
    };
    assert_eq!(generate(&fam, &e, 9), generate(&fam, &e, 9));
    assert_ne!(
        generate(&fam, &e, 9).train[0].csv,
        generate(&fam, &e, 10).train[0].csv
    );
}

#[test]
fn dropped_samples_never_leave_a_hole_a_reader_rejects() {
    // Seed 50 of the study once chained two bursts into a 5.6 s hole.
    for seed in [50, 118, 180, 181] {
        let fam = Family::all()[(seed % 40) as usize];
        let set = generate(&fam, &flight_sim::draw_effect(seed), seed);
        for f in set.train.iter().chain(&set.heldout) {
            let t: Vec<f64> = f
                .csv
                .lines()
                .skip(1)
                .map(|l| l.split(',').next().unwrap().parse().unwrap())
                .collect();
            let worst = t.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
            assert!(
                worst < 4.5,
                "{} seed {seed} {}: {worst} s",
                fam.name(),
                f.name
            );
        }
    }
}

#[test]
fn families_are_selected_by_patterns_and_the_study_s_tuning_choice() {
    let lfp_tuned = |f: &Family| f.chemistry == Chemistry::LiFePo4;
    assert_eq!(Family::select("all", lfp_tuned).unwrap().len(), 40);
    let t = Family::select("tuning", lfp_tuned).unwrap();
    assert_eq!(t.len(), 8);
    assert!(t.iter().all(lfp_tuned));
    assert_eq!(Family::select("held-out", lfp_tuned).unwrap().len(), 32);
    // In order, without repeats.
    let s = Family::select(" */vonly-5hz/paper , lfp/*/paper,lfp", |_| false).unwrap();
    assert_eq!(s.len(), 5 + 3 + 4);
    assert_eq!(s[0].name(), "lipo/vonly-5hz/paper");
    let e = Family::select("lfp,lead-acid", lfp_tuned).unwrap_err();
    assert_eq!(e.0, "lead-acid");
    assert!(e.to_string().contains("lead-acid"), "{e}");
    assert!(Family::select(" , ", lfp_tuned).is_err());
    assert!(Family::select("tuning", |_| false).is_err());
}

/// The sensor ablation's switch: `SensorErrors::Drawn` is the default flight byte for byte; a
/// calibrated current sensor changes the logged current only (the autopilot lands on the
/// voltage, so the flight and its voltage column stay); a calibrated voltage sensor changes the
/// logged voltage (and may move the landing: the autopilot's reading is what reaches the
/// cut-off).
#[test]
fn ideal_sensors_change_only_what_they_measure() {
    use flight_sim::{SensorErrors, simulate, simulate_with};
    let fam = family(Chemistry::LiPo, Logging::Fc10Hz);
    let robot = flight_sim::Robot::of(fam.robot, 4);
    let (train, _) = flight_sim::plans(&fam, 4);
    let plan = &train[0];
    let effect = Withheld::NONE;
    let drawn = simulate(&fam, &robot, plan, &effect, 11);
    assert_eq!(
        simulate_with(&fam, &robot, plan, &effect, 11, SensorErrors::Drawn),
        drawn
    );
    let column = |f: &flight_sim::SimFlight, k: usize| -> Vec<String> {
        f.csv
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(k).unwrap().to_owned())
            .collect()
    };
    let ic = simulate_with(&fam, &robot, plan, &effect, 11, SensorErrors::IdealCurrent);
    assert_eq!(ic.endurance_s, drawn.endurance_s);
    assert_eq!(column(&ic, 1), column(&drawn, 1), "voltage column");
    assert_ne!(column(&ic, 2), column(&drawn, 2), "current column");
    let iv = simulate_with(&fam, &robot, plan, &effect, 11, SensorErrors::IdealVoltage);
    assert_ne!(column(&iv, 1), column(&drawn, 1), "voltage column");
    assert!((iv.endurance_s / drawn.endurance_s - 1.0).abs() < 0.1);
    // Both ideal: the voltage log of the ideal voltage sensor.
    let both = simulate_with(&fam, &robot, plan, &effect, 11, SensorErrors::Ideal);
    assert_eq!(both.endurance_s, iv.endurance_s);
    assert_eq!(column(&both, 1), column(&iv, 1));
    for e in SensorErrors::ALL {
        assert_eq!(SensorErrors::parse(e.name()), Some(e));
    }
    assert_eq!(SensorErrors::parse("calibrated"), None);
}

/// The packs `pack_truths` reports are the ones the flights fly: one per flight, in order, and
/// each flight's first logged voltage (on the ground, sensor errors and all) reads near its own
/// pack's full curve, not the nominal one's.
#[test]
fn pack_truths_are_the_packs_the_flights_fly() {
    let fam = Family::parse("nmc/lab-1hz/paper").unwrap();
    for seed in [3, 8] {
        let set = generate(&fam, &Withheld::NONE, seed);
        let (tp, hp) = flight_sim::pack_truths(&fam, seed);
        assert_eq!((tp.len(), hp.len()), (set.train.len(), set.heldout.len()));
        for (f, p) in set.train.iter().zip(&tp) {
            let first_v: f64 = f
                .csv
                .lines()
                .nth(1)
                .unwrap()
                .split(',')
                .nth(1)
                .unwrap()
                .parse()
                .unwrap();
            let full_v = f64::from(p.cells) * p.ocv.at(0.994);
            assert!(
                (first_v - full_v).abs() < 0.12,
                "seed {seed} {}: first {first_v} V, pack full {full_v} V",
                f.name
            );
            assert!(p.capacity_ah > 0.5 && p.series_resistance_ohm > 0.0);
        }
    }
}

/// A LiPo or LiHV pack's rated empty (3.30 V open circuit) lies above its autopilot's loaded
/// cut-off (3.0 V a cell): the flight must go on past it to the cut-off (or the thrust limit),
/// not stop at the edge of the curve's table with the last logged voltage 0.2 V a cell above
/// the cut-off its metadata names.
#[test]
fn packs_discharge_past_their_rated_empty_to_the_cutoff() {
    use flight_sim::{FlightEnd, clean_flights};
    for chem in [Chemistry::LiPo, Chemistry::LiHv] {
        let fam = family(chem, Logging::Lab1Hz);
        let mut above_mv = Vec::new();
        for (f, t) in clean_flights(&fam, 0..2) {
            assert!(
                matches!(t.end, FlightEnd::Cutoff | FlightEnd::ThrustLimit),
                "{chem:?} {}: {:?} at state of charge {}",
                f.name,
                t.end,
                t.end_soc
            );
            let last_v = f.last_voltage_v().unwrap();
            above_mv.push(1e3 * (last_v / f64::from(chem.cells()) - chem.cutoff_cell_v()));
        }
        above_mv.sort_by(f64::total_cmp);
        let median = above_mv[above_mv.len() / 2];
        assert!(
            median < 60.0,
            "{chem:?}: median last voltage {median:.0} mV a cell above the cut-off"
        );
    }
}

/// A withheld capacity fade takes charge away and nothing else: the flown pack's impedance is
/// the same with and without it, and the one `pack_truths` reports for the oracle studies.
#[test]
fn capacity_fade_changes_the_capacity_not_the_impedance() {
    use flight_sim::{Robot, SensorErrors, pack_truth, plans, simulate_with_truth};
    let fam = family(Chemistry::Nmc, Logging::Fc10Hz);
    let robot = Robot::of(fam.robot, 4);
    let (tp, _) = plans(&fam, 4);
    let fade = Withheld {
        kind: EffectKind::CapacityFade,
        magnitude: 0.2,
    };
    let fly =
        |e: &Withheld| simulate_with_truth(&fam, &robot, &tp[0], e, 77, SensorErrors::Drawn).1;
    let (faded, fresh) = (fly(&fade), fly(&Withheld::NONE));
    assert!((faded.capacity_ah / fresh.capacity_ah - 0.8).abs() < 1e-12);
    assert_eq!(faded.r0_cell_ohm_25c, fresh.r0_cell_ohm_25c);
    assert_eq!(faded.rc_cell_25c, fresh.rc_cell_25c);
    let told = pack_truth(&fam, &tp[0], 77);
    let cells = f64::from(told.cells);
    assert!((told.series_resistance_ohm - cells * faded.r0_cell_ohm_25c).abs() < 1e-15);
}

/// The motor commands a flight controller logs follow the thrust the rotors carry: stopped on
/// the ground, inside the ESC's range in the air, higher with an airframe download (control
/// overhead), and driving the motors at about the voltage (duty times supply) at which the rig's
/// sweep held the same thrust.
#[test]
fn motor_commands_follow_the_rotors_thrust() {
    use flight_sim::{Robot, plans, simulate};
    let fam = family(Chemistry::LiPo, Logging::Fc10Hz);
    let robot = Robot::of(fam.robot, 7);
    let prop = robot.propulsion;
    let plan = &plans(&fam, 7).0[0];
    // Mean over hover samples of the command and of the drive voltage (duty × logged voltage).
    let hover = |effect: &Withheld| {
        let f = simulate(&fam, &robot, plan, effect, 7);
        let mut lines = f.csv.lines();
        let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
        let col = |n: &str| header.iter().position(|h| *h == n).expect(n);
        let (phase, volts, first) = (col("phase"), col("voltage_v"), col("motor1_us"));
        assert_eq!(header.len() - first, usize::from(robot.rotor_count));
        let (mut us_sum, mut drive_sum, mut n, mut ground) = (0.0, 0.0, 0.0, Vec::new());
        for l in lines {
            let c: Vec<&str> = l.split(',').collect();
            let us: Vec<f64> = c[first..].iter().map(|v| v.parse().expect("µs")).collect();
            let v: f64 = c[volts].parse().expect("V");
            match c[phase] {
                "hover" => {
                    us_sum += us.iter().sum::<f64>() / us.len() as f64;
                    drive_sum +=
                        us.iter().map(|u| prop.duty_of_us(*u) * v).sum::<f64>() / us.len() as f64;
                    n += 1.0;
                }
                "ground" => ground.extend(us),
                _ => {}
            }
        }
        assert!(n > 100.0 && ground.iter().all(|u| *u == 1000.0));
        let mass_kg: f64 = f
            .toml
            .lines()
            .filter(|l| {
                ["structure_mass_kg", "battery_mass_kg", "payload_mass_kg"]
                    .iter()
                    .any(|k| l.starts_with(k))
            })
            .filter_map(|l| l.split('=').nth(1)?.trim().parse::<f64>().ok())
            .sum();
        (us_sum / n, drive_sum / n, mass_kg)
    };
    let (nominal_us, nominal_drive_v, mass_kg) = hover(&Withheld::NONE);
    let (zero, full) = prop.esc_range_us;
    assert!(
        nominal_us > zero + 0.3 * (full - zero) && nominal_us < full,
        "{nominal_us}"
    );
    let (payload_us, ..) = hover(&Withheld {
        kind: EffectKind::ControlOverhead,
        magnitude: 0.1,
    });
    assert!(
        payload_us > nominal_us + 10.0,
        "{payload_us} vs {nominal_us}"
    );
    // The rig's nominal sweep: the drive at the step nearest a hovering rotor's thrust.
    let sweeps = robot.rig_sweeps(10.0, 7);
    assert!(sweeps.limit.len() > 15 && sweeps.nominal.len() > 20);
    let hover_g = 1000.0 * mass_kg / f64::from(robot.rotor_count);
    let at = sweeps
        .nominal
        .iter()
        .min_by(|a, b| {
            (a.thrust_g - hover_g)
                .abs()
                .total_cmp(&(b.thrust_g - hover_g).abs())
        })
        .expect("steps");
    assert!((at.thrust_g - hover_g).abs() <= 5.0);
    let rig_drive_v = prop.duty_of_us(at.throttle_us) * at.voltage_v;
    // Trims, propellers, warm windings, the air and a 5 g step apart: within 6 %.
    assert!(
        (nominal_drive_v / rig_drive_v - 1.0).abs() < 0.06,
        "flight {nominal_drive_v} V, rig {rig_drive_v} V"
    );
    // The limit sweep's thrust climbs with the command and tops out near the highest thrust
    // at 9 V.
    let last = sweeps.limit.last().expect("steps");
    let top = prop.max_thrust_g(9.0, flight_sim::robot::RIG_AIR_DENSITY_KG_M3);
    assert!(
        (last.thrust_g / top - 1.0).abs() < 0.05,
        "{} vs {top}",
        last.thrust_g
    );
}
