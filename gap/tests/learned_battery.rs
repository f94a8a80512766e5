//! The learned battery on flights of a pack the diagnosis was not written with: PyBaMM's
//! equivalent-circuit example cell (its measured open-circuit curve, `tests/data`), one RC pair,
//! simulated here by a small simulator of its own (constant-power hover, explicit RC state,
//! seeded sensor noise) and diagnosed blind.

use gap::diagnose::{BatterySet, DiagnoseOptions, Diagnosis, diagnose, diagnose_with};
use gap::flight::{FlightInfo, FlightRecord, Phase};
use gap::logs::ConstantPower;
use gap::model::{Effect, Model};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The cell's open-circuit curve: (state of charge, V).
fn ecm_curve() -> Vec<(f64, f64)> {
    include_str!("data/ecm_example_ocv.csv")
        .lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| {
            let mut it = l.split(',').map(|x| x.trim().parse::<f64>());
            match (it.next(), it.next()) {
                (Some(Ok(s)), Some(Ok(v))) => Some((s, v)),
                _ => None,
            }
        })
        .collect()
}

fn ocv(curve: &[(f64, f64)], s: f64) -> f64 {
    let i = curve.partition_point(|p| p.0 < s).clamp(1, curve.len() - 1);
    let ((s0, v0), (s1, v1)) = (curve[i - 1], curve[i]);
    v0 + (v1 - v0) * (s - s0) / (s1 - s0)
}

const CELLS: u8 = 3;
const ENERGY_WH: f64 = 40.0;
const HOVER_W: f64 = 180.0;
const MASS_KG: f64 = 1.2;
const IDLE_W: f64 = 3.0;
const CUTOFF_V: f64 = 3.3 * 3.0;

/// One flight: 20 s on the ground, then hover until the cut-off; 1 Hz log.
fn simulate(seed: u64, payload_kg: f64, fade: f64) -> FlightRecord {
    let curve = ecm_curve();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let cells = f64::from(CELLS);
    let mean_ocv: f64 = (0..1000)
        .map(|k| ocv(&curve, (f64::from(k) + 0.5) / 1000.0))
        .sum::<f64>()
        / 1000.0;
    let capacity_ah = ENERGY_WH / (cells * mean_ocv) * (1.0 - fade);
    let (r0, r1, tau) = (cells * 0.004, cells * 0.003, 40.0);
    let hover = HOVER_W * ((MASS_KG + payload_kg) / MASS_KG).powf(1.5);
    let (mut soc, mut v1, mut wobble) = (0.98, 0.0, 0.0);
    let (mut t, dt) = (0.0, 0.1);
    let mut rec = FlightRecord {
        name: format!("flight-{seed}"),
        time_s: vec![],
        voltage_v: vec![],
        current_a: Some(vec![]),
        phase: vec![],
        altitude_m: None,
        info: FlightInfo {
            structure_mass_kg: MASS_KG - 0.3,
            battery_mass_kg: 0.3,
            battery_energy_wh: ENERGY_WH,
            cells: CELLS,
            payload_mass_kg: payload_kg,
            payload_power_w: 0.0,
            avionics_power_w: IDLE_W,
            battery_id: None,
            battery_cycles: None,
            ambient_temperature_c: None,
            air_density_kg_m3: None,
            cutoff_voltage_v: CUTOFF_V,
            ended_at_cutoff: true,
            ceiling_height_m: None,
            measured_ocv: None,
        },
    };
    let mut step = 0u64;
    loop {
        let flying = t >= 20.0;
        // Control activity: a slowly wandering 2 % on the rotor power.
        wobble = 0.98 * wobble + 0.02 * rng.random_range(-1.0..1.0) * 2.0;
        let p = if flying {
            hover * (1.0 + 0.02 * wobble) + IDLE_W
        } else {
            IDLE_W
        };
        let e = cells * ocv(&curve, soc) - v1;
        let disc = e * e - 4.0 * r0 * p;
        if disc < 0.0 {
            break;
        }
        let i = (e - disc.sqrt()) / (2.0 * r0);
        let v = e - i * r0;
        if flying && v < CUTOFF_V {
            break;
        }
        if step % 10 == 0 {
            let cur = rec.current_a.as_mut().unwrap();
            rec.time_s.push(t);
            rec.voltage_v.push(v + rng.random_range(-0.01..0.01));
            cur.push(i + rng.random_range(-0.1..0.1));
            rec.phase
                .push(if flying { Phase::Hover } else { Phase::Ground });
        }
        soc -= i * dt / 3600.0 / capacity_ah;
        v1 += (i * r1 - v1) * (1.0 - (-dt / tau).exp());
        t += dt;
        step += 1;
    }
    rec
}

struct World {
    train: Vec<FlightRecord>,
    held: Vec<FlightRecord>,
}

fn world(fade: f64) -> World {
    let payloads = [0.0, 0.1, 0.2, 0.3, 0.15, 0.05, 0.25, 0.12, 0.22];
    let all: Vec<FlightRecord> = payloads
        .iter()
        .enumerate()
        .map(|(k, p)| simulate(100 + k as u64, *p, fade))
        .collect();
    let (held, train): (Vec<_>, Vec<_>) =
        all.into_iter().enumerate().partition(|(k, _)| k % 3 == 2);
    World {
        train: train.into_iter().map(|x| x.1).collect(),
        held: held.into_iter().map(|x| x.1).collect(),
    }
}

fn run(w: &World, fixed: Option<BatterySet>) -> Diagnosis {
    run_with(w, fixed, &DiagnoseOptions::default()).unwrap()
}

/// Diagnoses the world's flights with a constant-power model of the simulated rotor, with
/// `fixed` batteries (else learned from the training flights).
fn run_with(
    w: &World,
    fixed: Option<BatterySet>,
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, gap::GapError> {
    let curve = ConstantPower {
        hover_power_w: HOVER_W,
        reference_mass_kg: MASS_KG,
    };
    let model = Model {
        curve: &curve,
        rotor_count: 1,
    };
    let train: Vec<&FlightRecord> = w.train.iter().collect();
    let held: Vec<&FlightRecord> = w.held.iter().collect();
    match fixed {
        Some(b) => diagnose_with(model, &b, &train, &held, opts),
        None => diagnose(model, &train, &held, opts),
    }
}

#[test]
fn a_pack_of_another_shape_with_an_rc_pair_and_no_effect_is_none() {
    let w = world(0.0);
    let d = run(&w, None);
    let fit = &d.batteries[0];
    let (before, after) = (
        d.baseline.heldout.endurance_pct.unwrap(),
        d.after.heldout.endurance_pct.unwrap(),
    );
    eprintln!(
        "learned: prior {:?}, series {:.4} Ω, RC {:.4} Ω × {} s per cell, fit RMSE {:.4} V; \
         verdict {:?} (unexplained {}), held-out endurance {before:.3} % → {after:.3} %, voltage RMSE {:?} V",
        fit.prior,
        fit.battery.series_resistance_cell_ohm,
        fit.battery.rc_resistance_cell_ohm,
        fit.battery.rc_time_constant_s,
        fit.rmse_cell_v,
        d.verdict,
        d.unexplained,
        d.baseline.heldout.voltage_rmse_v
    );
    for r in &d.heldout_baseline {
        eprintln!("  {}: endurance {:?}", r.name, r.endurance);
    }
    eprintln!("  learned knots {:?}", fit.battery.ocv_cell_v);
    eprintln!("  baseline {:?}", d.baseline);
    for r in &d.heldout_baseline {
        eprintln!(
            "  {} chi2 {} n {} {:?}",
            r.name, r.chi2, r.n_obs, r.phase_power
        );
    }
    eprintln!("  soc covered {:?}, note {}", fit.soc_covered, fit.note);
    assert!(d.verdict.is_empty(), "verdict {:?}", d.verdict);
    assert!(!d.unexplained, "{:?}", d.residual);
    assert!(after <= before + 1e-9, "{before} % → {after} %");
    // The learned curve follows the cell's own, not the LiPo table, over the flown charge.
    let curve = ecm_curve();
    for k in 3..=9 {
        let s = f64::from(k) / 10.0;
        let err = (fit.battery.ocv_cell_v(s) - ocv(&curve, s)).abs();
        assert!(
            err < 0.05,
            "at {s}: learned {} V, cell {} V",
            fit.battery.ocv_cell_v(s),
            ocv(&curve, s)
        );
    }
    // The learned RC pair is there and resistances are physical.
    assert!(fit.battery.series_resistance_cell_ohm >= 0.0);
    assert!(fit.battery.rc_resistance_cell_ohm >= 0.0);
}

#[test]
fn the_lipo_table_alone_would_have_blamed_an_effect_on_the_same_flights() {
    let w = world(0.0);
    let fixed = run(
        &w,
        Some(BatterySet::fixed(gap::battery::LearnedBattery::lipo())),
    );
    let learned = run(&w, None);
    eprintln!(
        "LiPo prior fixed: verdict {:?} (unexplained {}), held-out endurance {:?} → {:?} %, χ²/obs {:.2}; learned: χ²/obs {:.2}",
        fixed.verdict,
        fixed.unexplained,
        fixed.baseline.heldout.endurance_pct,
        fixed.after.heldout.endurance_pct,
        fixed.baseline.training.chi2_per_obs,
        learned.baseline.training.chi2_per_obs,
    );
    assert!(learned.baseline.training.chi2_per_obs < fixed.baseline.training.chi2_per_obs);
}

/// Without the chemistry a lost capacity is indistinguishable from a curve whose knee comes
/// earlier (the rated energy is the only anchor): with the pack's measured curve given, as a
/// user gives it with `--battery-ocv-csv`, the fade is found and measured.
#[test]
fn capacity_fade_is_found_when_the_curve_is_given() {
    let w = world(0.12);
    let text: String = ecm_curve()
        .iter()
        .filter(|(s, _)| (0.0..=1.0).contains(s))
        .map(|(s, v)| format!("{s},{v}\n"))
        .collect();
    let measured = gap::battery::LearnedBattery::from_ocv_csv(&text).unwrap();
    let opts = DiagnoseOptions {
        measured_ocv: Some(measured),
        ..DiagnoseOptions::default()
    };
    let d = run_with(&w, None, &opts).unwrap();
    eprintln!(
        "fade 0.12, curve given: verdict {:?} {:?}, held-out endurance {:?} → {:?} %",
        d.verdict,
        d.effects
            .iter()
            .map(|e| e.parameter.value)
            .collect::<Vec<_>>(),
        d.baseline.heldout.endurance_pct,
        d.after.heldout.endurance_pct
    );
    assert_eq!(d.verdict, [Effect::CapacityFade]);
    // The fade is named but under-measured: the learned resistances take part of it (0.06 of
    // 0.12 measured when this test was written; issue 9 item 1 open).
    let v = d.effects[0].parameter.value;
    assert!(v > 0.03 && v < 0.15, "fitted fade {v}");
    assert!(d.after.heldout.endurance_pct < d.baseline.heldout.endurance_pct);
    // The same curve named by each flight's metadata (`battery_ocv_csv`) instead of the
    // option: the same battery, the same diagnosis.
    let mut named = World {
        train: w.train.clone(),
        held: w.held.clone(),
    };
    for f in named.train.iter_mut().chain(named.held.iter_mut()) {
        f.info.measured_ocv = Some(measured);
    }
    let by_meta = run(&named, None);
    assert_eq!(
        by_meta.batteries[0].prior,
        gap::battery::Chemistry::Measured
    );
    assert_eq!(by_meta.verdict, d.verdict);
    assert_eq!(
        by_meta.effects[0].parameter.value,
        d.effects[0].parameter.value
    );
    // And without it, the same flights are at least never made worse.
    let blind = run(&w, None);
    assert!(blind.after.heldout.endurance_pct <= blind.baseline.heldout.endurance_pct);
}

#[test]
fn more_effects_than_the_library_holds_is_an_error() {
    let w = world(0.0);
    let opts = DiagnoseOptions {
        max_effects: 9,
        ..DiagnoseOptions::default()
    };
    let e = run_with(&w, None, &opts).unwrap_err();
    assert!(e.to_string().contains("max_effects 9"), "{e}");
}

#[test]
fn a_hover_power_below_the_avionics_stops_with_a_reason() {
    let w = world(0.0);
    let mut flights: Vec<FlightRecord> = w.train.clone();
    // A disconnected battery: the logged current is next to nothing.
    for f in &mut flights {
        for c in f.current_a.as_mut().unwrap() {
            *c *= 1e-4;
        }
    }
    let train: Vec<&FlightRecord> = flights.iter().collect();
    let held: Vec<&FlightRecord> = flights.iter().take(1).collect();
    let e = gap::logs::run::<ConstantPower>(
        gap::logs::Baseline::FromTraining,
        &train,
        &held,
        &DiagnoseOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, gap::GapError::Implausible(_)), "{e}");
    assert!(e.to_string().contains("avionics power"), "{e}");
}
