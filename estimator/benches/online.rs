//! Cost of one `OnlineEstimator::update` on the host: the filter step alone, and with the
//! prediction (the forward integrations at the sigma points) recomputed at every sample, with
//! and without a mission plan. `cargo bench -p estimator --bench online`.

use std::hint::black_box;
use std::time::{Duration, Instant};

use estimator::online::{BatteryModel, FlightPhase, OnlineConfig, OnlineEstimator, Sample};
use estimator::{MissionOptions, Segment};

#[path = "../tests/support/fixture.rs"]
mod fixture;

fn estimator(config: &OnlineConfig, plan: bool) -> OnlineEstimator {
    let params = fixture::params();
    let battery = BatteryModel::lipo(3, 2.1).expect("a valid pack");
    let mut e = OnlineEstimator::new(&params, &battery, config).expect("a valid estimator");
    if plan {
        e.set_plan(
            &[
                Segment::Hover { duration_min: 2.0 },
                Segment::Attached { duration_min: 30.0 },
                Segment::Hover { duration_min: 2.0 },
                Segment::HoverUntilEmpty,
            ],
            &MissionOptions::default(),
        )
        .expect("a valid plan");
    }
    e
}

/// 10 Hz samples of a 10-minute hover, voltage falling from 12.4 V to 11.1 V.
fn samples(current: bool) -> Vec<Sample> {
    (0..6000)
        .map(|k| {
            let t = f64::from(k) * 0.1;
            Sample {
                time_s: t,
                voltage_v: 12.4 - 1.3 * t / 600.0 + 0.01 * (t * 7.0).sin(),
                current_a: current.then_some(9.0 + 0.3 * (t * 3.0).sin()),
                phase: Some(FlightPhase::Hover),
                motor_power_w: None,
            }
        })
        .collect()
}

fn bench(name: &str, config: &OnlineConfig, plan: bool, current: bool) {
    let samples = samples(current);
    let mut updates = 0u64;
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(2) {
        let mut e = estimator(config, plan);
        for s in &samples {
            black_box(e.update(black_box(s)));
        }
        updates += samples.len() as u64;
    }
    let ns = start.elapsed().as_nanos() as f64 / updates as f64;
    println!("{name:<58} {ns:>10.0} ns/update ({updates} updates)");
}

fn main() {
    println!(
        "OnlineEstimator state: {} bytes",
        OnlineEstimator::state_size_bytes()
    );
    let filter_only = OnlineConfig {
        prediction_interval_s: 1e9,
        ..OnlineConfig::default()
    };
    let every = OnlineConfig {
        prediction_interval_s: 0.0,
        ..OnlineConfig::default()
    };
    bench("filter step, current logged", &filter_only, false, true);
    bench(
        "filter step, no current (power model)",
        &filter_only,
        false,
        false,
    );
    bench(
        "filter + prediction every sample, current logged",
        &every,
        false,
        true,
    );
    bench(
        "filter + prediction every sample, no current",
        &every,
        false,
        false,
    );
    bench(
        "filter + prediction + 4-segment plan every sample",
        &every,
        true,
        true,
    );
    bench(
        "default (prediction at most once a second, 10 Hz)",
        &OnlineConfig::default(),
        false,
        true,
    );
}
