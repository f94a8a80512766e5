//! The motor map (power against the ESC's drive voltage `duty · V`): a physical motor of another
//! form than the map's polynomial, and the real stand logs that test the collapse across
//! supply voltages.

use std::path::{Path, PathBuf};

use fit::motor::{MotorMapOptions, MotorPoints, fit_motor_map};
use fit::sweeps::{LimitSweep, NominalSweep, SweepFitOptions, fit_sweeps};
use import::stand::{StandLog, StandOptions};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A brushless motor on a propeller behind an ideal PWM ESC: back-EMF `ω/Kv`, winding
/// resistance, no-load current, propeller torque `k·ω²`. Electrical power at `duty` on `volts`.
struct PhysicalMotor {
    kv_rad_per_v_s: f64,
    resistance_ohm: f64,
    no_load_current_a: f64,
    torque_per_rad2_nm: f64,
    esc_zero_us: f64,
    /// ESC conduction loss, Ω (carried by the motor current, so also a function of the drive).
    esc_resistance_ohm: f64,
}

impl PhysicalMotor {
    fn power_w(&self, us: f64, volts: f64) -> f64 {
        let duty = ((us - self.esc_zero_us) / (2000.0 - self.esc_zero_us)).clamp(0.0, 1.0);
        let x = duty * volts;
        let kt = 1.0 / self.kv_rad_per_v_s;
        let r = self.resistance_ohm + self.esc_resistance_ohm;
        // x = r·(I0 + k ω²/Kt) + ω/Kv: a quadratic in ω.
        let a = r * self.torque_per_rad2_nm / kt;
        let b = 1.0 / self.kv_rad_per_v_s;
        let c = r * self.no_load_current_a - x;
        let omega = (-b + (b * b - 4.0 * a * c).sqrt()) / (2.0 * a);
        let current = self.no_load_current_a + self.torque_per_rad2_nm * omega * omega / kt;
        x * current
    }

    /// Thrust ∝ ω² (only used to leave out the steps where the rotor barely turns).
    fn thrust_g(&self, us: f64, volts: f64) -> f64 {
        let p = self.power_w(us, volts);
        p.max(0.0).powf(2.0 / 3.0) * 10.0
    }
}

fn a_2212_class_motor() -> PhysicalMotor {
    PhysicalMotor {
        kv_rad_per_v_s: 920.0 * std::f64::consts::PI / 30.0,
        resistance_ohm: 0.12,
        no_load_current_a: 0.4,
        torque_per_rad2_nm: 1.6e-7,
        esc_zero_us: 1062.0,
        esc_resistance_ohm: 0.01,
    }
}

/// A sweep of the motor at `volts`, commands `from..=2000` every `step` µs, with relative noise
/// `noise` (seeded) on the power.
fn sweep(
    m: &PhysicalMotor,
    volts: f64,
    from: f64,
    step: f64,
    noise: f64,
    rng: &mut ChaCha8Rng,
) -> MotorPoints {
    let us: Vec<f64> = (0..)
        .map(|i| from + step * f64::from(i))
        .take_while(|u| *u <= 2000.0)
        .collect();
    let power_w = us
        .iter()
        .map(|&u| m.power_w(u, volts) * (1.0 + noise * (rng.random::<f64>() * 2.0 - 1.0)))
        .collect();
    MotorPoints {
        thrust_g: us.iter().map(|&u| m.thrust_g(u, volts)).collect(),
        voltage_v: vec![volts; us.len()],
        power_w,
        throttle_us: us,
        supply_voltage_v: volts,
        source_name: format!("{volts} V"),
        command_range_us: Some((1000.0, 2000.0)),
    }
}

#[test]
fn a_physical_motor_at_two_voltages_predicts_a_third() {
    let m = a_2212_class_motor();
    let mut rng = ChaCha8Rng::seed_from_u64(19);
    // The rig: a nominal sweep at 12.5 V and a limit sweep at 9.0 V, 0.3 % power noise.
    let sweeps = [
        sweep(&m, 12.5, 1100.0, 25.0, 0.003, &mut rng),
        sweep(&m, 9.0, 1100.0, 50.0, 0.003, &mut rng),
    ];
    let done = fit_motor_map(&sweeps, &MotorMapOptions::new(1000.0, 2000.0)).unwrap();
    let map = done.map;
    // The search finds the ESC's deadband.
    assert!(
        (map.zero_us() - m.esc_zero_us).abs() < 5.0,
        "zero_us {} vs {}",
        map.zero_us(),
        m.esc_zero_us
    );
    assert!(
        map.fit_rmse_fraction() < 0.01,
        "{}",
        map.fit_rmse_fraction()
    );
    assert_eq!(done.per_sweep.len(), 2);
    // A 3S pack at 11.1 V: every command whose drive both sweeps covered, within 1 %.
    let mut worst: f64 = 0.0;
    let mut checked = 0;
    for us in (1200..=2000).step_by(10).map(f64::from) {
        match map.power_w(us, 11.1) {
            Ok(p) => {
                let truth = m.power_w(us, 11.1);
                worst = worst.max(((p - truth) / truth).abs());
                checked += 1;
            }
            Err(e) => assert!(
                matches!(e, estimator::EstimateError::DriveAboveRange { .. }) || us < 1300.0,
                "{us} µs: {e}"
            ),
        }
    }
    eprintln!(
        "physical motor: zero_us {:.1} (truth {}), pooled RMSE {:.3} %, worst error at 11.1 V {:.3} % over {checked} commands",
        map.zero_us(),
        m.esc_zero_us,
        100.0 * map.fit_rmse_fraction(),
        100.0 * worst
    );
    assert!(checked > 60, "{checked} commands in range");
    assert!(worst < 0.01, "worst relative error at 11.1 V {worst}");
    // Ignoring the voltage (the 12.5 V sweep's power at the same command) misses by far more:
    // the test can tell the collapse from no model.
    let p_12 = m.power_w(1600.0, 12.5);
    let p_11 = m.power_w(1600.0, 11.1);
    assert!((p_12 - p_11) / p_11 > 0.1);
}

#[test]
fn fewer_than_two_sweeps_need_a_given_zero() {
    let m = a_2212_class_motor();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let one = [sweep(&m, 12.5, 1100.0, 25.0, 0.0, &mut rng)];
    let opts = MotorMapOptions::new(1000.0, 2000.0);
    assert!(matches!(
        fit_motor_map(&one, &opts),
        Err(fit::FitError::TooFewPoints {
            needed: 2,
            got: 1,
            ..
        })
    ));
    let fixed = MotorMapOptions {
        zero_us: Some(m.esc_zero_us),
        ..opts
    };
    let done = fit_motor_map(&one, &fixed).unwrap();
    assert_eq!(done.map.zero_us(), m.esc_zero_us);
    // A zero above the first command is refused.
    let bad = MotorMapOptions {
        zero_us: Some(1150.0),
        ..opts
    };
    assert!(fit_motor_map(&one, &bad).is_err());
}

fn shared(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/real")
        .join(rel)
}

fn points(rel: &str) -> MotorPoints {
    let log = StandLog::read(&shared(rel), &StandOptions::default()).expect(rel);
    let limit = LimitSweep::from_stand(&log, None).expect(rel);
    limit.motor_points.expect("throttle, voltage and power")
}

/// Relative RMS error of `predict` on the steps of `b` it covers, and how many it covers.
fn rms_on(b: &MotorPoints, predict: impl Fn(f64, f64) -> Option<f64>) -> (f64, usize) {
    let (mut ss, mut n) = (0.0, 0);
    for i in 0..b.throttle_us.len() {
        if let Some(p) = predict(b.throttle_us[i], b.voltage_v[i]) {
            ss += ((p - b.power_w[i]) / b.power_w[i]).powi(2);
            n += 1;
        }
    }
    ((ss / n.max(1) as f64).sqrt(), n)
}

/// RCbenchmark 1580, 2020-06-16, two 3S step tests minutes apart of the same motor and
/// propeller (their power against thrust agrees within 3 %), the pack 0.3 V lower in the
/// second (11.7 V vs 11.4 V mean): the map fitted to one, with the ESC's zero at the rig's
/// 1000 µs, predicts the other's power at each step's command and voltage, and beats the same
/// fit that ignores the voltage (power against command alone).
#[test]
fn the_collapse_holds_across_two_real_3s_runs() {
    let a = points("rcbenchmark/StepsTest_2020-06-16_220340.csv");
    let b = points("rcbenchmark/StepsTest_2020-06-16_220513.csv");
    assert!(
        a.supply_voltage_v - b.supply_voltage_v > 0.2,
        "{} V vs {} V",
        a.supply_voltage_v,
        b.supply_voltage_v
    );
    for (from, to) in [(&a, &b), (&b, &a)] {
        let opts = MotorMapOptions {
            degree: 3,
            zero_us: Some(1000.0),
            ..MotorMapOptions::new(1000.0, 2000.0)
        };
        let map = fit_motor_map(std::slice::from_ref(from), &opts)
            .unwrap()
            .map;
        let (map_rms, n) = rms_on(to, |us, v| map.power_w(us, v).ok());
        // The same polynomial in the command alone (the voltage ignored): the duty times a
        // constant voltage is an affine map of the command.
        let v0 = from.supply_voltage_v;
        let (cmd_rms, m) = rms_on(to, |us, _| map.power_w(us, v0).ok());
        assert!(n >= 15 && m >= 15, "{n} / {m} steps covered");
        assert!(map_rms < 0.03, "map {map_rms}");
        assert!(
            map_rms < 0.6 * cmd_rms,
            "map {map_rms} vs command alone {cmd_rms}"
        );
        eprintln!(
            "{} → {}: map {:.2} % over {n} steps, command alone {:.2} %",
            from.source_name,
            to.source_name,
            100.0 * map_rms,
            100.0 * cmd_rms
        );
    }
    // Both pooled, with the zero searched: one curve within 1.5 % RMS.
    let both = fit_motor_map(&[a, b], &MotorMapOptions::new(1000.0, 2000.0)).unwrap();
    eprintln!(
        "both pooled: zero_us {:.1}, RMSE {:.2} %, per sweep {:?}",
        both.map.zero_us(),
        100.0 * both.map.fit_rmse_fraction(),
        both.per_sweep
    );
    assert!(both.map.fit_rmse_fraction() < 0.015, "{:?}", both.per_sweep);
}

/// The characterisation seam on the two real 3S runs: a `[motor]` section that reads back.
#[test]
fn the_seam_writes_a_motor_section_for_real_logs() {
    let read = |rel: &str| StandLog::read(&shared(rel), &StandOptions::default()).expect(rel);
    let nominal =
        NominalSweep::from_stand(&read("rcbenchmark/StepsTest_2020-06-16_220340.csv"), None)
            .unwrap();
    let limit =
        LimitSweep::from_stand(&read("rcbenchmark/StepsTest_2020-06-16_220513.csv"), None).unwrap();
    let done = fit_sweeps(&nominal, Some(&limit), &SweepFitOptions::new(4, "test")).unwrap();
    let m = done.summary.motor_map.as_ref().expect("a motor map");
    assert_eq!(m.sweeps.len(), 2);
    assert_eq!(m.full_us, 2000.0);
    // The logs do not state the range: said once.
    assert!(
        done.notes.iter().any(|n| n.contains("standard RC")),
        "{:?}",
        done.notes
    );
    let text = done.params.to_toml_string();
    let back = estimator::file::ParamsFile::from_toml_str(&text).unwrap();
    let map = back.to_params().unwrap().motor.unwrap();
    assert_eq!(map.zero_us(), m.zero_us);
    // Without a limit sweep: no map, one note saying why, no error.
    let done = fit_sweeps(&nominal, None, &SweepFitOptions::new(4, "test")).unwrap();
    assert!(done.params.motor.is_none());
    let why: Vec<_> = done
        .notes
        .iter()
        .filter(|n| n.starts_with("no motor map: "))
        .collect();
    assert_eq!(why.len(), 1, "{:?}", done.notes);
    assert!(done.summary.motor_map_skipped.is_some());
}

/// CTU-MRS's table has no throttle column (and each motor ran on one pack voltage): the seam
/// says so and fits no map.
#[test]
fn a_log_without_a_throttle_column_gives_no_map_and_says_why() {
    let log = StandLog::read(
        &shared("ctu-mrs/motor_tests.csv"),
        &StandOptions {
            filters: vec!["motor=Tarot 4114 320KV".parse().unwrap()],
            ..StandOptions::default()
        },
    )
    .unwrap();
    let n = NominalSweep::from_stand(&log, None).unwrap();
    let why = n.motor_points.clone().unwrap_err();
    assert!(why.contains("no throttle"), "{why}");
    let done = fit_sweeps(&n, None, &SweepFitOptions::new(4, "test")).unwrap();
    assert!(done.params.motor.is_none());
}
