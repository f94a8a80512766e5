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
/// (`thrust_limit_end=1` turns the thrust-limit end on).
fn config_from_env() -> estimator::online::OnlineConfig {
    let mut c = estimator::online::OnlineConfig::default();
    let Ok(spec) = std::env::var("SWEEP_CFG") else {
        return c;
    };
    for kv in spec.split(',').filter(|s| !s.is_empty()) {
        let (k, v) = kv.split_once('=').expect("key=value");
        let v: f64 = v.parse().expect("a number");
        if k == "thrust_limit_end" {
            c.thrust_limit_end = v != 0.0;
            continue;
        }
        let slot = match k {
            "voltage_sigma_v" => &mut c.voltage_sigma_v,
            "current_sigma_a" => &mut c.current_sigma_a,
            "power_sigma_fraction" => &mut c.power_sigma_fraction,
            "initial_soc_sigma" => &mut c.initial_soc_sigma,
            "resistance_scale_sigma" => &mut c.resistance_scale_sigma,
            "capacity_scale_sigma" => &mut c.capacity_scale_sigma,
            "extra_power_sigma_fraction" => &mut c.extra_power_sigma_fraction,
            "resistance_drift_per_sqrt_s" => &mut c.resistance_drift_per_sqrt_s,
            "capacity_drift_per_sqrt_s" => &mut c.capacity_drift_per_sqrt_s,
            "extra_power_drift_fraction_per_sqrt_s" => &mut c.extra_power_drift_fraction_per_sqrt_s,
            "voltage_bias_sigma_cell_v" => &mut c.voltage_bias_sigma_cell_v,
            "voltage_bias_drift_cell_v_per_sqrt_s" => &mut c.voltage_bias_drift_cell_v_per_sqrt_s,
            "prediction_model_sigma_fraction" => &mut c.prediction_model_sigma_fraction,
            "end_soc_sigma" => &mut c.end_soc_sigma,
            "current_scale_sigma" => &mut c.current_scale_sigma,
            "current_offset_sigma_a" => &mut c.current_offset_sigma_a,
            "cutoff_curve_sigma_cell_v" => &mut c.cutoff_curve_sigma_cell_v,
            "voltage_scale_sigma" => &mut c.voltage_scale_sigma,
            "capacity_fade_sigma" => &mut c.capacity_fade_sigma,
            "extra_power_thrust_share" => &mut c.extra_power_thrust_share,
            "extra_power_thrust_share_sigma" => &mut c.extra_power_thrust_share_sigma,
            other => panic!("unknown key {other}"),
        };
        *slot = v;
    }
    c
}
