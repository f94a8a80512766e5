//! The paper's Fig. 3 curve (as reconstructed in `../shared/reference/paper-targets.md`, sampled
//! in `data/paper-fig3.csv`) against the paper's rotor with physical coefficients
//! (`presets::paper`): the physical model misses the curve by far more than noise, and the
//! diagnosis names the effect behind it and how far it shrinks.

use std::path::Path;

use import::stand::{StandLog, StandOptions};
use rig_gap::diagnose::{Options, diagnose};
use rig_gap::{presets, runs_of_log, split_default};

#[test]
fn the_paper_curve_against_the_physical_paper_rotor() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/paper-fig3.csv");
    let log = StandLog::read(&path, &StandOptions::default()).expect("readable");
    let (train, held, _) = split_default(runs_of_log(&log).expect("runs"));
    let opts = Options {
        fixed: presets::paper().fixed,
        ..Options::default()
    };
    let d = diagnose(&train, &held, &opts).expect("diagnosis");
    let (before, after) = d.headline_pct().expect("power compared");
    // Momentum theory with a figure of merit of 0.5 and a motor matched to the published thrust
    // limits draws far less than the curve: the base model is well outside noise.
    assert!(before > 20.0, "{before}");
    // Power rising faster with speed than the propeller's torque allows: a no-load (iron and
    // friction) loss growing with speed is named first, and it at least halves the error.
    assert_eq!(d.effects[0].effect, "no_load_current", "{:?}", d.candidates);
    assert!(after < 0.5 * before, "{before} → {after}");
    assert!(d.after.heldout_chi2_per_obs < d.baseline.heldout_chi2_per_obs);
    // The preset's values were held, not fitted.
    for (p, _) in &opts.fixed {
        assert!(
            !d.after.parameters.contains_key(p.name()),
            "{} was fitted",
            p.name()
        );
    }
}

/// The curve's rows: (thrust g, power W).
fn fig3_rows() -> Vec<(f64, f64)> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/paper-fig3.csv");
    std::fs::read_to_string(path)
        .expect("readable")
        .lines()
        .skip(1)
        .map(|l| {
            let c: Vec<f64> = l.split(',').map(|x| x.parse().expect("number")).collect();
            (c[0], c[3])
        })
        .collect()
}

/// The physical preset's steady electrical power at 12.5 V, W.
fn preset_power_w(thrust_g: f64) -> f64 {
    let mut p = motor_model::Params::default();
    for (q, v) in presets::paper().fixed {
        p.set(q, v);
    }
    p.set(motor_model::Param::SupplyVoltageV, 12.5);
    let pt = motor_model::Point {
        thrust_g,
        time_frac: 0.0,
        time_s: 0.0,
        tare_time_s: 0.0,
        measured_current_a: None,
    };
    motor_model::predict_sweep(&p, &[pt])[0].power_w
}

/// Why the physical rotor cannot reach the curve, in two numbers the paper fixes:
/// 1. the level: the curve's overall figure of merit (momentum theory's ideal power over the
///    electrical power) peaks near 0.24, while a rotor made of typical parts has about 0.39 there;
/// 2. the top: the paper's ideal battery optimum (0.353 kg on a 0.431 kg structure) needs the
///    power to grow as thrust^2.25 at the hover thrust of that optimum (196 g per rotor), while a
///    rotor with constant coefficients grows at most as thrust² (copper loss) and this one as
///    thrust^1.3.
#[test]
fn the_curve_needs_more_than_a_physical_rotor_has() {
    let rows = fig3_rows();
    let d = presets::PAPER_DIAMETER_M;
    let fm_curve = rows
        .iter()
        .filter(|r| r.0 > 0.0)
        .map(|&(t, p)| presets::ideal_power_w(t, d) / p)
        .fold(0.0f64, f64::max);
    assert!((0.22..0.26).contains(&fm_curve), "{fm_curve}");
    let fm_preset = presets::ideal_power_w(150.0, d) / preset_power_w(150.0);
    assert!((0.35..0.45).contains(&fm_preset), "{fm_preset}");
    // Elasticity d ln P / d ln T at 190–200 g, from the curve's own rows.
    let at = |t: f64| rows.iter().find(|r| r.0 == t).expect("row").1;
    let e_curve = (at(200.0) / at(190.0)).ln() / (200.0f64 / 190.0).ln();
    assert!((2.1..2.4).contains(&e_curve), "{e_curve}");
    // The optimum condition: ε = m_total/m_battery (ideal battery, avionics power aside).
    let e_needed = (0.431 + 0.353) / 0.353;
    assert!((e_curve - e_needed).abs() < 0.1, "{e_curve} vs {e_needed}");
    let e_preset = (preset_power_w(200.0) / preset_power_w(190.0)).ln() / (200.0f64 / 190.0).ln();
    assert!(e_preset < 1.5 && e_preset < e_needed - 0.7, "{e_preset}");
}
