//! The online estimator against synthetic packs discharged by an integrator written here, in
//! another form than the filter: the open-circuit curve is a closed formula (not a knot table),
//! the discharge is a fixed-step Euler integration at 100 Hz of the pack's charge, its RC pair
//! and the power the robot draws, and the logged samples carry seeded noise.

use estimator::online::{
    BatteryModel, Chemistry, Estimate, FlightPhase, OCV_KNOTS, OnlineConfig, OnlineEstimator,
    Sample, Vehicle,
};
use estimator::{MissionOptions, Params, PolyCurve, Segment};

/// Open-circuit voltage of one cell of the synthetic pack: a sloped plateau, a knee below 15 %
/// and a shoulder near full.
fn truth_ocv_cell_v(soc: f64) -> f64 {
    let s = soc.clamp(0.0, 1.0);
    4.2 - 0.62 * (1.0 - s) - 0.28 * (-14.0 * s).exp() - 0.04 * (std::f64::consts::PI * s).sin()
}

/// The pack the truth flies.
#[derive(Clone, Copy)]
struct TruePack {
    cells: f64,
    capacity_ah: f64,
    r0_cell_ohm: f64,
    r1_cell_ohm: f64,
    tau_s: f64,
    cutoff_cell_v: f64,
}

const NOMINAL: TruePack = TruePack {
    cells: 3.0,
    capacity_ah: 2.1,
    r0_cell_ohm: 0.012,
    r1_cell_ohm: 0.006,
    tau_s: 20.0,
    cutoff_cell_v: 3.4,
};

fn params() -> Params {
    // p(T) = 0.12 T + 0.0004 T² per rotor, in the scaled basis t = (T − 130)/130.
    let curve = PolyCurve::new(
        &[22.36, 29.12, 6.76],
        130.0,
        130.0,
        (0.0, 260.0),
        Some(12.0),
    )
    .unwrap();
    Params {
        rotor_count: 4,
        curve,
        thrust_limit: None,
        battery: None,
        vehicle: Some(Vehicle {
            structure_mass_kg: 0.431,
            battery_mass_kg: 0.144,
            payload_mass_kg: 0.0,
            avionics_power_w: 2.44,
            payload_power_w: 0.0,
        }),
    }
}

/// The battery model the file holds: the nominal pack, its curve sampled at the knots (as the
/// gap diagnosis would learn it).
fn file_battery() -> BatteryModel {
    let mut ocv = [0.0; OCV_KNOTS];
    for (k, v) in ocv.iter_mut().enumerate() {
        *v = truth_ocv_cell_v(k as f64 / (OCV_KNOTS - 1) as f64);
    }
    BatteryModel {
        cells: 3,
        rated_capacity_ah: NOMINAL.capacity_ah,
        chemistry: Chemistry::Measured,
        ocv_cell_v: ocv,
        series_resistance_cell_ohm: NOMINAL.r0_cell_ohm,
        rc_resistance_cell_ohm: NOMINAL.r1_cell_ohm,
        rc_time_constant_s: NOMINAL.tau_s,
        cutoff_cell_v: NOMINAL.cutoff_cell_v,
    }
}

/// A small deterministic generator (xorshift) for sensor noise.
struct Noise(u64);
impl Noise {
    fn gauss(&mut self) -> f64 {
        let mut u = || {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        };
        let (a, b) = (u().max(1e-12), u());
        (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
    }
}

struct Flight {
    samples: Vec<Sample>,
    soc: Vec<f64>,
    /// Time of the cut-off (end of the flight), s.
    end_s: f64,
}

/// Ground for 5 s at idle, then hover at `hover_w` until the terminal voltage reaches the
/// cut-off; samples at `rate_hz` with noise.
fn fly(
    pack: TruePack,
    idle_w: f64,
    hover_w: f64,
    rate_hz: f64,
    with_current: bool,
    seed: u64,
) -> Flight {
    let dt = 0.01;
    let every = (1.0 / rate_hz / dt).round() as usize;
    let mut noise = Noise(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let (mut soc, mut v1, mut t) = (1.0, 0.0, 0.0);
    let (mut samples, mut socs) = (Vec::new(), Vec::new());
    let r0 = pack.cells * pack.r0_cell_ohm;
    let r1 = pack.cells * pack.r1_cell_ohm;
    for k in 0.. {
        let flying = t >= 5.0;
        let p = if flying { hover_w } else { idle_w };
        let e = pack.cells * truth_ocv_cell_v(soc) - v1;
        let disc = e * e - 4.0 * r0 * p;
        if disc < 0.0 {
            break;
        }
        let i = (e - disc.sqrt()) / (2.0 * r0);
        let v = e - i * r0;
        if flying && v <= pack.cells * pack.cutoff_cell_v {
            break;
        }
        if k % every == 0 {
            samples.push(Sample {
                time_s: t,
                voltage_v: v + 0.01 * noise.gauss(),
                current_a: with_current.then(|| i * 1.0 + 0.05 * noise.gauss()),
                phase: Some(if flying {
                    FlightPhase::Hover
                } else {
                    FlightPhase::Ground
                }),
            });
            socs.push(soc);
        }
        soc -= i * dt / (3600.0 * pack.capacity_ah);
        v1 += (i * r1 - v1) * dt / pack.tau_s;
        t += dt;
    }
    Flight {
        samples,
        soc: socs,
        end_s: t,
    }
}

fn run(f: &Flight, est: &mut OnlineEstimator) -> Vec<Estimate> {
    f.samples.iter().map(|s| est.update(s)).collect()
}

/// Index of the sample at `frac` of the hover and the true remaining time there, s.
fn at_fraction(f: &Flight, frac: f64) -> (usize, f64) {
    let t = 5.0 + frac * (f.end_s - 5.0);
    let k = f.samples.iter().position(|s| s.time_s >= t).unwrap();
    (k, f.end_s - f.samples[k].time_s)
}

fn base_estimator() -> OnlineEstimator {
    OnlineEstimator::new(&params(), &file_battery(), &OnlineConfig::default()).unwrap()
}

#[test]
fn diagnostic_print() {
    let est = base_estimator();
    let hover = est.model_hover_power_w();
    let idle = est.idle_power_w();
    for (name, pack, extra) in [
        ("nominal", NOMINAL, 1.0),
        (
            "fade20",
            TruePack {
                capacity_ah: NOMINAL.capacity_ah * 0.8,
                ..NOMINAL
            },
            1.0,
        ),
        (
            "res150",
            TruePack {
                r0_cell_ohm: NOMINAL.r0_cell_ohm * 1.5,
                ..NOMINAL
            },
            1.0,
        ),
        ("power115", NOMINAL, 1.15),
    ] {
        for cur in [true, false] {
            let f = fly(pack, idle, hover * extra, 10.0, cur, 7);
            let mut e = base_estimator();
            let out = run(&f, &mut e);
            for frac in [0.1, 0.25, 0.5, 0.75, 0.9] {
                let (k, truth) = at_fraction(&f, frac);
                let o = out[k];
                eprintln!(
                    "{name} cur={cur} {frac}: rem {:.0}±{:.0} true {:.0} ({:+.1}%) soc {:.3}±{:.3} true {:.3} cap {:.3} R {:.4} pe {:.1} flags {}",
                    o.remaining_phase_s,
                    o.remaining_phase_sigma_s,
                    truth,
                    100.0 * (o.remaining_phase_s - truth) / (f.end_s - 5.0),
                    o.soc,
                    o.soc_sigma,
                    f.soc[k],
                    o.usable_capacity_ah,
                    o.series_resistance_ohm,
                    o.extra_power_w,
                    o.flags
                );
            }
        }
    }
    let _ = (Segment::HoverUntilEmpty, MissionOptions::default());
}
