//! A study on a seed range without the CLI, printing the group table (the flights are flown
//! once per seed): `cargo run -p replay-eval --example sweep -- FAMILIES FIRST_SEED COUNT`.
//! `SWEEP_FLIGHTS=1` also lists every flight: its error at 50 % and the filter's state of charge
//! and curve offset when the pack reached the cut-off (a state of charge well above 0 there is a
//! pack that ran out earlier than the learned section says: fade, cold, a knee the curve lacks).
//! `SWEEP_TRUTH=1` adds, under each flight, its pack's true capacity and mean airborne series
//! resistance (flight-sim's record, for the analysis only: no estimator sees it) beside the
//! filter's at the end, and the truth beside each pack-history reading.
//! `SWEEP_SENSORS=ideal` (or `ideal-voltage`, `ideal-current`) flies the same worlds with
//! calibrated sensors (no per-flight scale or offset error; noise kept): the sensor ablation.
//! `SWEEP_ORACLE=curve,power` (or `all`, `all-but-start`, …) hands the estimator those pieces
//! of each flight's truth (`replay_eval::oracle`); the `budget` example runs the whole budget.
//! `SWEEP_DROP_CURRENT=1` replays the held-out flights without their current column;
//! `SWEEP_MOTOR_POWER=1` gives the estimator the rotors' power read from their motor commands
//! (`--motor-power`).

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (families, seeds) = replay_eval::families_and_seeds(&args).expect("families");
    let opts = replay_eval::StudyOptions {
        seeds,
        families,
        threads: 2,
        config: config_from_env(),
        pack_history: std::env::var("SWEEP_HISTORY").is_ok_and(|v| v == "1"),
        voltage_only: std::env::var("SWEEP_DROP_CURRENT").is_ok_and(|v| v == "1"),
        motor_power: std::env::var("SWEEP_MOTOR_POWER").is_ok_and(|v| v == "1"),
    };
    let sensors = std::env::var("SWEEP_SENSORS").map_or(flight_sim::SensorErrors::Drawn, |s| {
        flight_sim::SensorErrors::parse(&s).expect("drawn, ideal-voltage, ideal-current or ideal")
    });
    let study = match std::env::var("SWEEP_ORACLE") {
        Ok(o) => {
            let mut oracle = replay_eval::Oracle::parse(&o).expect("SWEEP_ORACLE");
            oracle.sensors |= sensors == flight_sim::SensorErrors::Ideal;
            assert!(
                oracle.sensors || sensors == flight_sim::SensorErrors::Drawn,
                "SWEEP_ORACLE takes the sensors as `sensors` (ideal) only"
            );
            replay_eval::study_oracles(&opts, &[oracle], &|| {}).remove(0)
        }
        Err(_) => replay_eval::study_with(&opts, sensors, &|| {}),
    };
    print!("{}", replay_eval::table(&study));
    if std::env::var_os("SWEEP_FLIGHTS").is_some() {
        let truth = std::env::var("SWEEP_TRUTH").is_ok_and(|v| v == "1");
        print!("{}", replay_eval::flight_lines_with(&study, truth));
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
