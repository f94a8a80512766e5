//! How far `sim`'s `paper` preset gets with physical constants instead of its fitted ones
//! (issue 11): the rotor's steady state on a 12.5 V supply at 10 g steps, against the
//! reconstructed Fig. 3 curve, then the paper's pipeline (fifth-order polynomial, thrust limit at
//! 9.0 V, eq. 4–5) on that sweep.
//!
//! ```text
//! cargo run -p sim --example physical_paper
//! ```
//!
//! The physical rotor is `sim`'s `paper-physical` preset ([`sim::presets::paper_physical`]), the
//! one `rig-gap --preset paper` holds fixed: static `C_T` 0.10 and `C_P` 0.045 at 200 mm (figure
//! of merit 0.56), winding plus ESC 0.2 Ω, no-load current 0.4 A, ESC 95 % (typical values),
//! `K_v` 566 rpm/V (the published 260 g at 12.6 V), no drag rise. It is run twice: as is, and
//! with the no-load current rising 0.2287 A per 1000 rpm (the effect `rig-gap --preset paper`
//! names on the Fig. 3 curve), as `sim`'s iron drag.
//!
//! This is the noise-free steady state, not the firmware-and-protocol path of
//! `tests/paper_preset.rs`; for the preset as it is the two agree within that test's tolerance.

use sim::physics::{Motor, Propulsion, Supply};
use sim::presets;

#[path = "../tests/support/poly.rs"]
mod support_poly;
use support_poly::{poly, polyfit};

const M_S_KG: f64 = 0.431;
const P_A_W: f64 = 2.44;
const E_D_WH_PER_KG: f64 = 164.0;

fn fig3_w(t_g: f64) -> f64 {
    0.157_434_234 * t_g + 0.341_190_317 * (t_g / 100.0).powf(5.348_657_28)
}

fn run(name: &str, unit: &Propulsion) {
    let supply = |v| Supply {
        voltage_v: v,
        resistance_ohm: 0.01,
    };
    // Throttle sweep at 0.5 µs, then the 10 g points by linear interpolation.
    let pts: Vec<(f64, f64)> = (0..=2000)
        .map(|k| {
            let s = unit.steady_state(1000.0 + 0.5 * f64::from(k), supply(12.5));
            (s.thrust_g, s.power_w())
        })
        .collect();
    let (mut ts, mut ps) = (Vec::new(), Vec::new());
    for t in (10..=260).step_by(10).map(f64::from) {
        if let Some(w) = pts.windows(2).find(|w| w[0].0 <= t && w[1].0 >= t) {
            let f = (t - w[0].0) / (w[1].0 - w[0].0);
            ts.push(t);
            ps.push(w[0].1 + f * (w[1].1 - w[0].1));
        }
    }
    let errs: Vec<f64> = ts
        .iter()
        .zip(&ps)
        .map(|(t, p)| p / fig3_w(*t) - 1.0)
        .collect();
    let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
    let worst = errs.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    let c = polyfit(&ts, &ps, 5);
    let limit_9 = unit.steady_state(2000.0, supply(9.0)).thrust_g;
    let limit_126 = unit.steady_state(2000.0, supply(12.6)).thrust_g;
    let t_e =
        |m_b: f64| 60.0 * E_D_WH_PER_KG * m_b / (4.0 * poly(&c, (M_S_KG + m_b) * 250.0) + P_A_W);
    // Ideal optimum, searched while the hover thrust stays on the measured curve (≤ 260 g).
    let (mut best_m, mut best_t) = (0.0, 0.0);
    let mut m_b = 0.001;
    while (M_S_KG + m_b) * 250.0 <= 260.0 {
        if t_e(m_b) > best_t {
            (best_m, best_t) = (m_b, t_e(m_b));
        }
        m_b += 0.0005;
    }
    let m_real = limit_9 * 4.0 / 1000.0 - M_S_KG;
    println!("{name}");
    println!(
        "  Fig. 3 power: {} points, RMS {:.1} %, worst {:.1} %",
        ts.len(),
        100.0 * rms,
        100.0 * worst
    );
    println!(
        "  thrust limit: {limit_126:.0} g at 12.6 V, {limit_9:.0} g at 9.0 V (paper ~260, 150)"
    );
    println!(
        "  ideal optimum: m_B {best_m:.3} kg, t_E {best_t:.2} min (paper 0.353 kg, 19.76 min){}",
        if (M_S_KG + best_m + 0.0005) * 250.0 > 260.0 {
            "; at the search's end (260 g per rotor)"
        } else {
            ""
        }
    );
    println!(
        "  realistic optimum: m_B {m_real:.3} kg, t_E {:.2} min (paper 0.169 kg, 15.28 min)",
        t_e(m_real)
    );
}

fn main() {
    let p = presets::paper();
    run(
        "sim `paper` preset as it is (calibrated: k_Q 0.1 x momentum theory, drag rise ~ w^9.6)",
        &Propulsion::new(p.motor, p.prop, p.esc),
    );
    let q = presets::paper_physical();
    run(
        "sim `paper-physical` preset (physical rotor)",
        &Propulsion::new(q.motor, q.prop, q.esc),
    );
    let slope_a_per_krpm = 0.2287;
    let motor = Motor {
        iron_drag_nm_s: q.motor.ke() * slope_a_per_krpm / (1000.0 * std::f64::consts::PI / 30.0),
        ..q.motor
    };
    run(
        &format!("`paper-physical` + no-load slope {slope_a_per_krpm} A per 1000 rpm"),
        &Propulsion::new(motor, q.prop, q.esc),
    );
}
