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

/// The thrust at full throttle on a supply of `voltage_v` (the preset's supply otherwise).
fn max_thrust_g(p: &sim::Preset, voltage_v: f64) -> f64 {
    unit(p)
        .steady_state(
            2000.0,
            Supply {
                voltage_v,
                ..p.supply
            },
        )
        .thrust_g
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
    let max = |v: f64| max_thrust_g(&p, v);
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

/// The CTU table's DJI 9450 rows: (thrust g, rpm, voltage V, current A, power W).
fn ctu_rows() -> Vec<[f64; 5]> {
    include_str!("data/ctu_mrs_motor_tests.csv")
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[1] == "DJI plastic 9450")
        .map(|c| [2, 3, 4, 5, 6].map(|k| c[k].parse::<f64>().unwrap()))
        .collect()
}

fn rms(e: &[f64]) -> f64 {
    (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt()
}

/// The physical `ctu-2312-9450` against the published table, by throttle (50..100 %). Thrust
/// within 2 % on every row; current and power within 3 % at 60–100 % and 7.5 % at 50 %, RMS
/// under 4 %. (The fitted preset this replaced, seven values fitted to these rows, was within
/// 5 % everywhere and in fact within 1.9 %; the physical one misses the 50 % row by +6.8 %, its
/// power rising more slowly with thrust than the table's. That row's bound is the one wider
/// than before, by 2.5 points, and says so.)
#[test]
fn ctu_preset_reproduces_the_published_table() {
    let p = presets::ctu_2312_9450();
    let u = unit(&p);
    let rows = ctu_rows();
    assert_eq!(rows.len(), 6);
    let (mut et, mut ea, mut ew) = (Vec::new(), Vec::new(), Vec::new());
    for (i, [t, _, _, a, w]) in rows.iter().copied().enumerate() {
        let throttle_us = 1500.0 + 100.0 * i as f64; // 50..100 %
        let s = u.steady_state(throttle_us, p.supply);
        et.push(s.thrust_g / t - 1.0);
        ea.push(s.electrical.bus_current_a / a - 1.0);
        ew.push(s.power_w() / w - 1.0);
        println!(
            "ctu {:>3} %: thrust {:7.1} g ({t}) {:+.2} %, current {:6.2} A ({a}) {:+.2} %, power {:7.2} W ({w}) {:+.2} %",
            50 + 10 * i,
            s.thrust_g,
            et[i] * 100.0,
            s.electrical.bus_current_a,
            ea[i] * 100.0,
            s.power_w(),
            ew[i] * 100.0
        );
        assert!(et[i].abs() < 0.02, "row {i} thrust: {}", et[i]);
        let bound = if i == 0 { 0.075 } else { 0.03 };
        assert!(ea[i].abs() < bound, "row {i} current: {}", ea[i]);
        assert!(ew[i].abs() < bound, "row {i} power: {}", ew[i]);
    }
    println!(
        "ctu RMS: thrust {:.2} %, current {:.2} %, power {:.2} %",
        100.0 * rms(&et),
        100.0 * rms(&ea),
        100.0 * rms(&ew)
    );
    assert!(rms(&et) < 0.015 && rms(&ea) < 0.04 && rms(&ew) < 0.04);
}

/// Power at the table's own thrust (bisection on throttle), so the throttle axis plays no
/// part: what the physical motor, ESC and propeller alone give.
#[test]
fn ctu_preset_power_at_the_tables_thrust() {
    let p = presets::ctu_2312_9450();
    let u = unit(&p);
    let mut e = Vec::new();
    for [t, rpm, _, _, w] in ctu_rows() {
        let s = at_thrust(&u, p.supply, t);
        assert!((s.thrust_g / t - 1.0).abs() < 1e-3, "{t} g not reached");
        let rpm_model = s.omega_rad_s * 30.0 / std::f64::consts::PI;
        e.push(s.power_w() / w - 1.0);
        println!(
            "ctu at {t} g: power {:.2} W ({w}) {:+.2} %, {rpm_model:.0} rpm ({rpm})",
            s.power_w(),
            100.0 * e.last().unwrap()
        );
        assert!((rpm_model / rpm - 1.0).abs() < 0.02, "{rpm_model} vs {rpm}");
    }
    println!(
        "ctu power at the table's thrust: RMS {:.2} %",
        100.0 * rms(&e)
    );
    assert!(rms(&e) < 0.04, "{e:?}");
    assert!(e.iter().all(|x| x.abs() < 0.075), "{e:?}");
}

/// What makes the `ctu-2312-9450` preset physical, checked on its values: the motor's sold
/// `K_v`, a winding resistance and no-load current of the class, a propeller figure of merit of
/// real propellers, no fitted loss terms, an ESC that loses a few per cent.
#[test]
fn ctu_preset_is_physical() {
    let p = presets::ctu_2312_9450();
    assert_eq!(p.motor.kv_rpm_per_v, 920.0);
    assert!((0.05..=0.2).contains(&p.motor.resistance_ohm));
    assert!((0.2..=0.8).contains(&p.motor.no_load_current_a));
    assert_eq!(p.motor.iron_drag_nm_s, 0.0);
    assert_eq!(p.prop.drag_rise_torque_nm, 0.0);
    let fm = presets::figure_of_merit(&p.prop, presets::DJI_9450_DIAMETER_M);
    assert!((0.4..=0.7).contains(&fm), "figure of merit {fm}");
    assert!((0.9..=0.98).contains(&p.esc.efficiency));
    // The pack: 4.1–4.2 V per cell when full, 5–8 mΩ per cell.
    assert!((16.4..=16.8).contains(&p.supply.voltage_v));
    assert!((0.02..=0.032).contains(&p.supply.resistance_ohm));
}

/// The physical `paper-physical` preset: what must hold for it (not the paper's optima, which
/// no physical rotor reaches; see the module docs of `sim::presets`).
#[test]
fn paper_physical_preset_is_physical_and_meets_the_stated_limit() {
    let p = presets::by_name("paper-physical").unwrap();
    assert_eq!(p.name, "paper-physical");
    let fm = presets::figure_of_merit(&p.prop, presets::PAPER_DIAMETER_M);
    assert!((fm - 0.56).abs() < 0.005, "figure of merit {fm}");
    assert_eq!(p.prop.drag_rise_torque_nm, 0.0);
    assert_eq!(p.motor.iron_drag_nm_s, 0.0);
    assert_eq!((p.esc.efficiency, p.esc.max_duty), (0.95, 1.0));
    let u = unit(&p);
    let max = |v: f64| max_thrust_g(&p, v);
    let (t9, t126) = (max(9.0), max(12.6));
    println!("paper-physical: max thrust {t9:.1} g at 9.0 V, {t126:.1} g at 12.6 V");
    // The paper's ~260 g at 12.6 V (the 0.01 Ω leads take 0.03 V).
    assert!((257.0..=261.0).contains(&t126), "{t126}");
    // A low-resistance motor gives thrust ∝ V² nearly: 260·(9/12.6)² = 133 g, not the 150 g
    // paper-targets.md derives from the optimum.
    assert!((130.0..=140.0).contains(&t9), "{t9}");
    // Electrical power at 150 g against momentum theory's ideal: the overall figure of merit
    // of typical parts, 0.35–0.55 (Fig. 3's reconstruction has 0.24 there).
    let s = at_thrust(&u, p.supply, 150.0);
    let t_n = 0.150 * sim::physics::G;
    let area = std::f64::consts::PI * 0.01;
    let ideal_w = t_n.powf(1.5) / (2.0 * 1.225 * area).sqrt();
    let overall = ideal_w / s.power_w();
    println!("paper-physical: overall figure of merit at 150 g {overall:.3}");
    assert!((0.35..=0.55).contains(&overall), "{overall}");
    // Power–thrust elasticity at 196 g: under 2 (constant coefficients), far from the 2.22
    // the paper's optimum needs.
    let (a, b) = (
        at_thrust(&u, p.supply, 190.0),
        at_thrust(&u, p.supply, 200.0),
    );
    let el = (b.power_w() / a.power_w()).ln() / (200.0f64 / 190.0).ln();
    println!("paper-physical: d ln P / d ln T at 195 g = {el:.3}");
    assert!((1.0..2.0).contains(&el), "{el}");
}

/// The ESC's efficiency: the bus power is the motor's input over `η` while driving, and the
/// same throttle map and speed give the same motor current.
#[test]
fn esc_efficiency_scales_the_bus_power() {
    let mut p = presets::paper_physical();
    let u95 = unit(&p);
    p.esc.efficiency = 1.0;
    let u100 = unit(&p);
    let supply = Supply {
        voltage_v: 12.5,
        resistance_ohm: 0.0,
    };
    let (d, w) = (0.6, 300.0); // d·V 7.5 V above the back-EMF 5.1 V: driving
    let (e95, e100) = (u95.electrical(d, w, supply), u100.electrical(d, w, supply));
    assert!((e95.motor_current_a - e100.motor_current_a).abs() < 1e-12);
    let motor_in_w = d * supply.voltage_v * e95.motor_current_a;
    assert!((e95.bus_current_a * supply.voltage_v * 0.95 / motor_in_w - 1.0).abs() < 1e-12);
    // Regenerating (back-EMF above d·V): the bus gets η of what the motor returns.
    let r95 = u95.electrical(0.3, 600.0, supply);
    let r100 = u100.electrical(0.3, 600.0, supply);
    assert!(r95.bus_current_a < 0.0);
    assert!((r95.bus_current_a / r100.bus_current_a - 0.95).abs() < 1e-12);
    // The bus load the external supply sees agrees with the physics.
    let mut q = unit(&presets::paper_physical());
    q.omega_rad_s = w;
    let load = q.bus_load(1600.0);
    let e = q.electrical(load.duty, w, supply);
    assert!((load.current_a(12.5) - e.bus_current_a).abs() < 1e-9);
}
