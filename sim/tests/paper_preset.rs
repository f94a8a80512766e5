//! The `paper` preset end to end, the way the paper's rig was used: through the firmware and
//! the protocol (in process, on the simulated clock), tare and calibrate with known masses,
//! sweep thrust in 10 g steps at 12.5 V reading current and voltage, fit a fifth-order
//! polynomial, measure the thrust limit at 9.0 V, and run the paper's equations 1–5.

use rig_protocol::{Client, ClientConfig, Rig, Sample};
use sim::peripherals::SimClock;
use sim::{ClientClockExt, SimLink, SimRig, presets};

#[path = "support/poly.rs"]
mod support_poly;
use support_poly::{poly, polyfit};

type Host = Client<SimLink, SimClock>;

const M_S_KG: f64 = 0.431;
const P_A_W: f64 = 2.44;
const E_D_WH_PER_KG: f64 = 164.0;

fn collect(host: &mut Host, duration_us: u64) -> Vec<Sample> {
    let end = host.clock_now_us() + duration_us;
    let mut v = Vec::new();
    while host.clock_now_us() < end {
        if let Some(s) = host.next_sample().unwrap() {
            v.push(s);
        }
    }
    v
}

fn mean(xs: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0.0);
    for x in xs {
        s += x;
        n += 1.0;
    }
    s / n
}

/// Sets the throttle so that the measured thrust is near `target_g`; returns (thrust g, power W).
fn point(
    host: &mut Host,
    throttle: &mut f64,
    slope_g_per_us: &mut f64,
    target_g: f64,
) -> (f64, f64) {
    for _ in 0..12 {
        host.set_throttle(throttle.round() as u16).unwrap();
        collect(host, 400_000);
        let t = mean(collect(host, 300_000).iter().map(|s| f64::from(s.thrust_g)));
        let err = target_g - t;
        if err.abs() < 1.0 || (*throttle >= 2000.0 && err > 0.0) {
            break;
        }
        let step = (err / *slope_g_per_us).clamp(-150.0, 150.0);
        let new = (*throttle + step).clamp(1000.0, 2000.0);
        if (new - *throttle).abs() < 0.5 {
            break;
        }
        *throttle = new;
    }
    let s = collect(host, 1_000_000);
    let thrust = mean(s.iter().map(|s| f64::from(s.thrust_g)));
    let power = mean(
        s.iter()
            .map(|s| f64::from(s.current_a) * f64::from(s.voltage_v)),
    );
    (thrust, power)
}

fn endurance_min(c: &[f64], m_b: f64) -> f64 {
    let m_t = M_S_KG + m_b;
    let p_m = 4.0 * poly(c, m_t * 1000.0 / 4.0);
    60.0 * E_D_WH_PER_KG * m_b / (p_m + P_A_W)
}

#[test]
fn paper_preset_lands_on_the_paper_through_firmware_and_protocol() {
    let mut rig = SimRig::new(&presets::paper(), 2024).unwrap();
    rig.advance(200_000);
    let mut host = rig.into_client(ClientConfig::default());
    host.handshake().unwrap();
    let id = host.identify().unwrap();
    assert_eq!(id.board, 0);

    // Tare with the motor mount on the cell, then three known masses.
    host.tare(40).unwrap();
    for m in [100.0, 200.0, 500.0] {
        host.transport_mut().rig_mut().place_mass_g(m);
        host.transport_mut().rig_mut().advance(500_000);
        let cal = host.calibrate(m as f32).unwrap();
        assert!(
            (f64::from(cal.scale_g_per_count) / 0.0025 - 1.0).abs() < 2e-3,
            "{cal:?}"
        );
    }
    host.transport_mut().rig_mut().place_mass_g(0.0);

    host.start_stream(100).unwrap();
    host.arm().unwrap();
    let (mut thr, mut slope) = (1100.0, 0.3);
    let (mut ts, mut ps) = (Vec::new(), Vec::new());
    for target in (10..=260).step_by(10) {
        let (t, p) = point(&mut host, &mut thr, &mut slope, f64::from(target));
        slope = slope.max(0.05);
        ts.push(t);
        ps.push(p);
        let reference = 0.157434234 * t + 0.341190317 * (t / 100.0).powf(5.34865728);
        // Sensor offsets (0.5 mA, 4 mV) weigh most at the lightest points.
        let tolerance = if t < 45.0 { 0.025 } else { 0.01 };
        assert!(
            (p / reference - 1.0).abs() < tolerance,
            "{target} g: measured {t:.2} g, {p:.3} W vs {reference:.3} W"
        );
    }
    assert!(
        (ts.last().unwrap() - 260.0).abs() < 1.5,
        "260 g reached at 12.5 V: {ts:?}"
    );

    // Thrust limit at the minimum battery voltage.
    host.transport_mut().rig_mut().set_supply_voltage(9.0);
    host.set_throttle(2000).unwrap();
    collect(&mut host, 1_500_000);
    let s = collect(&mut host, 1_000_000);
    let t9 = mean(s.iter().map(|s| f64::from(s.thrust_g)));
    let v9 = mean(s.iter().map(|s| f64::from(s.voltage_v)));
    host.set_throttle(1000).unwrap();
    collect(&mut host, 1_000_000);
    host.disarm().unwrap();
    let m_l = 4.0 * t9 / 1000.0;

    let c = polyfit(&ts, &ps, 5);
    let (mut best_m, mut best_t) = (0.0, 0.0);
    let mut m = 0.05;
    while (M_S_KG + m) * 1000.0 / 4.0 <= 260.0 {
        let t = endurance_min(&c, m);
        if t > best_t {
            (best_m, best_t) = (m, t);
        }
        m += 1e-4;
    }
    let real_m = (m_l - M_S_KG).min(best_m);
    let real_t = endurance_min(&c, real_m);
    println!(
        "paper preset through the rig: thrust limit {t9:.2} g at {v9:.3} V (m_L = {m_l:.4} kg)"
    );
    println!(
        "  ideal optimum     m_B = {best_m:.4} kg, t_E = {best_t:.3} min   (paper 0.353 kg, 19.76 min)"
    );
    println!(
        "  realistic optimum m_B = {real_m:.4} kg, t_E = {real_t:.3} min   (paper 0.169 kg, 15.28 min)"
    );
    assert!((best_m - 0.353).abs() <= 0.005, "{best_m}");
    assert!((best_t / 19.76 - 1.0).abs() <= 0.01, "{best_t}");
    assert!((m_l - 0.600).abs() <= 0.005, "{m_l}");
    assert!((real_m - 0.169).abs() <= 0.005, "{real_m}");
    assert!((real_t / 15.28 - 1.0).abs() <= 0.01, "{real_t}");
}
