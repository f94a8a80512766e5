//! A study on a seed range without the CLI, printing the group table (the flights are flown
//! once per seed): `cargo run -p replay-eval --example sweep -- FAMILIES FIRST_SEED COUNT`.
//! `SWEEP_FLIGHTS=1` also lists every flight: its error at 50 % and the filter's state of charge
//! and curve offset when the pack reached the cut-off (a state of charge well above 0 there is a
//! pack that ran out earlier than the learned section says: fade, cold, a knee the curve lacks).
//! `SWEEP_SENSORS=ideal` (or `ideal-voltage`, `ideal-current`) flies the same worlds with
//! calibrated sensors (no per-flight scale or offset error; noise kept): the sensor ablation.

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let families = replay_eval::select_families(args.get(1).map_or("tuning", String::as_str))
        .expect("families");
    let first: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0);
    let count: u64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(12);
    let opts = replay_eval::StudyOptions {
        seeds: first..first + count,
        families,
        threads: 2,
        config: config_from_env(),
    };
    let sensors = std::env::var("SWEEP_SENSORS").map_or(flight_sim::SensorErrors::Drawn, |s| {
        flight_sim::SensorErrors::parse(&s).expect("drawn, ideal-voltage, ideal-current or ideal")
    });
    let study = replay_eval::study_with(&opts, sensors, &|| {});
    print!("{}", replay_eval::table(&study));
    if std::env::var_os("SWEEP_FLIGHTS").is_some() {
        for (seed, fam, r) in &study.scenarios {
            let Ok(o) = r else { continue };
            for f in &o.flights {
                let c = &f.checkpoints[1];
                let d = f.end_s - f.takeoff_s;
                let state = |n: &str| {
                    f.final_state
                        .iter()
                        .find(|x| x.0 == n)
                        .map_or(f64::NAN, |x| x.1)
                };
                println!(
                    "{seed:4} {:24} {:18} {:16} err50 {:+6.1} % sigma {:5.1} % static {:+6.1} % | at the cut-off: soc {:.3} offset {:+.3} V",
                    fam.name(),
                    o.condition.name(),
                    f.name,
                    c.predicted_remaining_s
                        .map_or(f64::NAN, |p| (p - c.true_remaining_s) / d * 100.0),
                    c.sigma_s.map_or(f64::NAN, |s| s / d * 100.0),
                    c.baselines[2].map_or(f64::NAN, |p| (p - c.true_remaining_s) / d * 100.0),
                    state("soc"),
                    state("curve_offset_v"),
                );
            }
        }
    }
}

/// `SWEEP_CFG="capacity_scale_sigma=0.1,voltage_sigma_v=0.05"` overrides the defaults
/// ([`replay_eval::config_from_spec`]).
fn config_from_env() -> estimator::online::OnlineConfig {
    std::env::var("SWEEP_CFG").map_or_else(
        |_| estimator::online::OnlineConfig::default(),
        |s| replay_eval::config_from_spec(&s).expect("SWEEP_CFG"),
    )
}
