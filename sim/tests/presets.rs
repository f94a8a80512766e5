//! The presets against their targets, from the physics' steady state (the end-to-end checks
//! through firmware and protocol are in `paper_preset.rs`).

use sim::physics::{Propulsion, Supply};
use sim::presets;

fn target_w(t: f64) -> f64 {
    0.157434234 * t + 0.341190317 * (t / 100.0).powf(5.34865728)
}

fn unit(p: &sim::Preset) -> Propulsion {
    Propulsion::new(p.motor, p.prop, p.esc)
}

/// Steady state at a given thrust (bisection on throttle).
fn at_thrust(u: &Propulsion, supply: Supply, thrust_g: f64) -> sim::physics::SteadyState {
    let (mut lo, mut hi) = (1000.0, 2000.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if u.steady_state(mid, supply).thrust_g < thrust_g {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    u.steady_state(hi, supply)
}

#[test]
fn paper_power_curve_follows_the_reconstruction() {
    let p = presets::paper();
    let u = unit(&p);
    let supply = Supply {
        voltage_v: 12.5,
        ..p.supply
    };
    let mut worst: f64 = 0.0;
    for t in (10..=260).step_by(5) {
        let s = at_thrust(&u, supply, f64::from(t));
        assert!(
            (s.thrust_g - f64::from(t)).abs() < 0.01,
            "{t} g not reachable at 12.5 V"
        );
        let rel = s.power_w() / target_w(f64::from(t)) - 1.0;
        worst = worst.max(rel.abs());
    }
    assert!(worst < 0.005, "worst relative power error {worst}");
    println!(
        "paper preset: worst |P/P_target - 1| over 10..260 g = {:.3} %",
        worst * 100.0
    );
}

#[test]
fn paper_thrust_limits_follow_the_supply_voltage() {
    let p = presets::paper();
    let u = unit(&p);
    let max = |v: f64| {
        u.steady_state(
            2000.0,
            Supply {
                voltage_v: v,
                ..p.supply
            },
        )
        .thrust_g
    };
    let (t9, t125, t126) = (max(9.0), max(12.5), max(12.6));
    println!(
        "paper preset: max thrust {t9:.2} g at 9.0 V, {t125:.2} g at 12.5 V, {t126:.2} g at 12.6 V"
    );
    assert!((t9 - 150.0).abs() < 0.5, "{t9}");
    assert!((258.0..=266.0).contains(&t126), "{t126}");
    assert!(t125 >= 260.0, "{t125}");
}

#[test]
fn paper_motor_has_a_realistic_time_constant() {
    let p = presets::paper();
    let u = unit(&p);
    let s = at_thrust(&u, p.supply, 150.0);
    let tau = u.time_constant_s(s.omega_rad_s);
    assert!((0.01..0.2).contains(&tau), "{tau}");
}

#[test]
fn step_response_settles_on_the_steady_state_and_regenerates_on_a_cut() {
    let p = presets::paper();
    let mut u = unit(&p);
    let target = u.steady_state(1600.0, p.supply);
    for _ in 0..2000 {
        u.step(1e-3, 1600.0, p.supply);
    }
    assert!((u.omega_rad_s / target.omega_rad_s - 1.0).abs() < 1e-3);
    let e = u.step(1e-3, 1000.0, p.supply);
    // duty 0 after a cut: no supply current through the ESC in this model, the rotor coasts
    assert!(e.bus_current_a.abs() < 1e-9);
    let e = u.step(1e-3, 1300.0, p.supply);
    assert!(
        e.bus_current_a < 0.0,
        "partial duty below back-EMF regenerates: {e:?}"
    );
}

#[test]
fn ctu_preset_reproduces_the_published_table_within_5_percent() {
    let p = presets::ctu_2312_9450();
    let u = unit(&p);
    let csv = include_str!("data/ctu_mrs_motor_tests.csv");
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[1] == "DJI plastic 9450")
        .collect();
    assert_eq!(rows.len(), 6);
    for (i, r) in rows.iter().enumerate() {
        let throttle_us = 1500.0 + 100.0 * i as f64; // 50..100 %
        let s = u.steady_state(throttle_us, p.supply);
        let (t, a, w): (f64, f64, f64) = (
            r[2].parse().unwrap(),
            r[5].parse().unwrap(),
            r[6].parse().unwrap(),
        );
        let et = s.thrust_g / t - 1.0;
        let ea = s.electrical.bus_current_a / a - 1.0;
        let ew = s.power_w() / w - 1.0;
        println!(
            "ctu {:>3} %: thrust {:7.1} g ({t}) {:+.2} %, current {:6.2} A ({a}) {:+.2} %, power {:7.2} W ({w}) {:+.2} %",
            50 + 10 * i,
            s.thrust_g,
            et * 100.0,
            s.electrical.bus_current_a,
            ea * 100.0,
            s.power_w(),
            ew * 100.0
        );
        for e in [et, ea, ew] {
            assert!(e.abs() < 0.05, "row {i}: {e}");
        }
    }
}
