//! The oracle-battery switch of the study ([`gap_eval::oracle`]): inert when off, and the curve
//! it hands over is the truth's, read through the diagnosis's measured-curve door.

use std::fmt::Write as _;

use flight_sim::ocv::{OcvCurve, OcvScatter};
use flight_sim::{Chemistry, Family, SimFlight, draw_effect, generate};
use gap_eval::oracle::{BatteryOracle, apply, nominal_ocv_csv};
use gap_eval::{UnexplainedRule, adapter, read_back, rig_curve, run_scenario, run_scenario_oracle};

fn scratch(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!(
        "gap-eval-oracle-test-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Off, the switch changes no byte of the flights, writes no file, and the study's own path
/// (`run_scenario`, which `study` and `hoverbench gap-eval` use) is the off run — which differs
/// from a run given the curve, so a curve leaking into the default path would fail here.
#[test]
fn the_switch_leaks_nothing_when_off() {
    let families = vec![Family::parse("nmc/fc-10hz/paper").unwrap()];
    let seed = 6;
    let fam = families[0];
    let set = generate(&fam, &draw_effect(seed), seed);
    let dir = scratch("off");
    let mut off = set.clone();
    let f = apply(BatteryOracle::Off, &fam, seed, &mut off, &dir).unwrap();
    assert_eq!(off, set);
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
    drop(f);
    for fl in read_back(&off.train).unwrap() {
        assert!(fl.meta.battery_ocv_csv.is_none());
    }

    let mut on = set.clone();
    let file = apply(BatteryOracle::Ocv, &fam, seed, &mut on, &dir).unwrap();
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    for fl in read_back(&on.train).unwrap() {
        assert!(fl.meta.battery_ocv_csv.is_some(), "{}", fl.name);
    }
    // Only the training flights name the curve; `ocv` leaves the rated energies alone.
    assert_eq!(on.heldout, set.heldout);
    drop(file);
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        0,
        "the curve's file is removed"
    );
    let mut all = set.clone();
    let _file = apply(BatteryOracle::OcvAll, &fam, seed, &mut all, &dir).unwrap();
    assert_ne!(
        all.heldout, set.heldout,
        "ocv+all gives every flight its capacity"
    );

    let default = run_scenario(seed, &families).unwrap();
    let explicit_off = run_scenario_oracle(
        seed,
        &families,
        UnexplainedRule::default(),
        BatteryOracle::Off,
    )
    .unwrap();
    let with_curve = run_scenario_oracle(
        seed,
        &families,
        UnexplainedRule::default(),
        BatteryOracle::Ocv,
    )
    .unwrap();
    assert_eq!(default, explicit_off);
    assert_ne!(
        default.heldout_endurance_before_pct, with_curve.heldout_endurance_before_pct,
        "the oracle curve changes the baseline, so a leak would show"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A noiseless world of the truth's nominal pack (its open-circuit curve, a series
/// resistance, charge counted exactly): given the oracle curve through the flights' metadata,
/// the diagnosis's battery fit leaves almost no residual, and its curve is the truth's.
#[test]
fn with_the_oracle_curve_a_noiseless_world_fits_to_near_zero() {
    let dir = scratch("noiseless");
    for chem in [Chemistry::LiPo, Chemistry::Nmc, Chemistry::LiFePo4] {
        let truth = OcvCurve::new(chem, OcvScatter::NONE);
        let cells = chem.cells();
        let csv_path = dir.join(format!("{}.csv", chem.name()));
        std::fs::write(&csv_path, nominal_ocv_csv(chem)).unwrap();
        let capacity_ah = 2.0;
        let r0_cell_ohm = 0.004;
        // The rated energy whose capacity, over the curve's mean, is the pack's.
        let energy_wh = capacity_ah * f64::from(cells) * truth.mean_v();
        let flights: Vec<SimFlight> = [8.0, 11.0, 14.0]
            .iter()
            .enumerate()
            .map(|(k, amps)| {
                let mut csv = String::from("time_s,voltage_v,current_a,phase,altitude_m\n");
                let (mut soc, mut n) = (1.0_f64, 0usize);
                for t in 0..4000 {
                    let (i, phase, alt) = if t < 5 {
                        (0.0, "ground", 0.0)
                    } else {
                        (*amps, "hover", 1.0)
                    };
                    let v = f64::from(cells) * (truth.at(soc) - i * r0_cell_ohm);
                    let _ = writeln!(csv, "{t},{v:.5},{i:.4},{phase},{alt}");
                    n += 1;
                    soc -= i / 3600.0 / capacity_ah;
                    if soc < 0.08 {
                        break;
                    }
                }
                let mut toml = String::new();
                let _ = writeln!(toml, "cells = {cells}");
                let _ = writeln!(toml, "battery_energy_wh = {energy_wh}");
                let _ = writeln!(toml, "battery_mass_kg = 0.15");
                let _ = writeln!(toml, "structure_mass_kg = 0.5");
                let _ = writeln!(toml, "battery_id = \"pack\"");
                let _ = writeln!(toml, "ambient_temperature_c = 25.0");
                let _ = writeln!(toml, "end = \"landed\"");
                let _ = writeln!(
                    toml,
                    "battery_ocv_csv = {:?}",
                    csv_path.display().to_string()
                );
                SimFlight {
                    name: format!("flight-{k}"),
                    csv,
                    toml,
                    endurance_s: 0.0,
                    ended_at_cutoff: false,
                    samples: n,
                }
            })
            .collect();
        let rig = generate(
            &Family::parse("lipo/lab-1hz/paper").unwrap(),
            &draw_effect(0),
            0,
        )
        .rig;
        let learned = adapter::learned_batteries(
            &read_back(&flights).unwrap(),
            &rig_curve(&rig).unwrap(),
            rig.rotor_count,
        )
        .unwrap();
        assert_eq!(learned.len(), 1);
        let l = &learned[0];
        assert!(
            l.rmse_cell_v < 0.004,
            "{chem:?}: the fit's residual {:.4} V per cell with the true curve",
            l.rmse_cell_v
        );
        for k in 3..=18 {
            let s = f64::from(k) / 20.0;
            assert!(
                (l.ocv_cell_v(s) - truth.at(s)).abs() < 0.01,
                "{chem:?} at {s}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
