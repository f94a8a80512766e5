//! Thrust-limit extraction on synthetic sweeps at minimum battery voltage.

use fit::{FitError, Input, ThrustLimitKind, ThrustLimitOptions, thrust_limit};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Throttle 0, 5, …, 100 %.
fn throttle() -> Vec<f64> {
    (0..=20).map(|i| 5.0 * i as f64).collect()
}

/// Thrust (g) rising as throttle² and saturating at `limit` from `knee` %.
fn saturating(limit: f64, knee: f64) -> Vec<f64> {
    throttle()
        .iter()
        .map(|&u| limit * (u.min(knee) / knee).powi(2))
        .collect()
}

/// Zero-mean Gaussian noise by Box–Muller.
fn gaussian(rng: &mut ChaCha8Rng, sigma: f64) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random();
    sigma * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[test]
fn exact_plateau_is_found() {
    let thrust = saturating(620.0, 80.0);
    let r = thrust_limit(&throttle(), &thrust, &ThrustLimitOptions::default()).unwrap();
    assert_eq!(r.thrust_g, 620.0);
    assert_eq!(
        r.kind,
        ThrustLimitKind::Plateau {
            from_throttle: 80.0,
            to_throttle: 100.0,
            n_points: 5
        }
    );
    assert_eq!(r.uncertainty_g, 0.0);
    assert!(r.sag.is_none());
}

#[test]
fn rising_sweep_reports_top_of_range() {
    let thrust: Vec<f64> = throttle().iter().map(|&u| 0.07 * u * u).collect();
    let opts = ThrustLimitOptions {
        noise_std_g: Some(2.0),
        ..Default::default()
    };
    let r = thrust_limit(&throttle(), &thrust, &opts).unwrap();
    assert_eq!(r.kind, ThrustLimitKind::TopOfRange);
    assert!((r.thrust_g - 700.0).abs() < 1e-9);
    assert_eq!(r.uncertainty_g, 2.0);
}

#[test]
fn noisy_plateau_is_found_within_its_uncertainty() {
    let sigma = 3.0;
    for seed in 0..20 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let thrust: Vec<f64> = saturating(620.0, 70.0)
            .into_iter()
            .map(|t| t + gaussian(&mut rng, sigma))
            .collect();
        let std = vec![sigma; thrust.len()];
        let opts = ThrustLimitOptions {
            thrust_std_g: Some(&std),
            ..Default::default()
        };
        let r = thrust_limit(&throttle(), &thrust, &opts).unwrap();
        let ThrustLimitKind::Plateau {
            from_throttle,
            n_points,
            ..
        } = r.kind
        else {
            panic!("seed {seed}: expected a plateau, got {r:?}");
        };
        // The knee is at 70 %; noise may shift the detected start by a step or two.
        assert!((60.0..=80.0).contains(&from_throttle), "seed {seed}: {r:?}");
        assert!(n_points >= 5, "seed {seed}: {r:?}");
        assert!(r.uncertainty_g >= sigma / (n_points as f64).sqrt() * 0.999);
        assert!(
            (r.thrust_g - 620.0).abs() <= 4.0 * r.uncertainty_g,
            "seed {seed}: {r:?}"
        );
        assert_eq!(r.noise_std_g, sigma);
    }
}

#[test]
fn noise_is_estimated_when_not_given() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let thrust: Vec<f64> = saturating(500.0, 75.0)
        .into_iter()
        .map(|t| t + gaussian(&mut rng, 2.0))
        .collect();
    let r = thrust_limit(&throttle(), &thrust, &ThrustLimitOptions::default()).unwrap();
    assert!(r.noise_std_g > 0.5 && r.noise_std_g < 8.0, "{r:?}");
    assert!(matches!(r.kind, ThrustLimitKind::Plateau { .. }), "{r:?}");
    assert!((r.thrust_g - 500.0).abs() < 5.0, "{r:?}");
}

#[test]
fn sag_at_the_top_returns_the_maximum_sustained_thrust() {
    // Rises to 600 g at 70–80 %, then the supply sags and thrust falls.
    let thrust: Vec<f64> = throttle()
        .iter()
        .map(|&u| {
            if u <= 70.0 {
                600.0 * (u / 70.0).powi(2)
            } else if u <= 80.0 {
                600.0
            } else {
                600.0 - 4.0 * (u - 80.0)
            }
        })
        .collect();
    let opts = ThrustLimitOptions {
        noise_std_g: Some(1.5),
        ..Default::default()
    };
    let r = thrust_limit(&throttle(), &thrust, &opts).unwrap();
    assert_eq!(
        r.kind,
        ThrustLimitKind::Plateau {
            from_throttle: 70.0,
            to_throttle: 80.0,
            n_points: 3
        }
    );
    assert_eq!(r.thrust_g, 600.0);
    let sag = r.sag.expect("sag reported");
    assert_eq!(sag.from_throttle, 85.0);
    assert_eq!(sag.final_thrust_g, 520.0);
    assert_eq!(sag.drop_g, 80.0);
}

#[test]
fn sharp_peak_followed_by_sag_is_still_the_limit() {
    let throttle = [0.0, 25.0, 50.0, 75.0, 100.0];
    let thrust = [0.0, 150.0, 400.0, 560.0, 500.0];
    let opts = ThrustLimitOptions {
        noise_std_g: Some(1.0),
        ..Default::default()
    };
    let r = thrust_limit(&throttle, &thrust, &opts).unwrap();
    assert_eq!(r.thrust_g, 560.0);
    assert!(matches!(
        r.kind,
        ThrustLimitKind::Plateau { n_points: 1, .. }
    ));
    assert_eq!(r.sag.map(|s| s.drop_g), Some(60.0));
    assert_eq!(r.uncertainty_g, 1.0);
}

#[test]
fn invalid_sweeps_are_rejected_with_context() {
    let opts = ThrustLimitOptions::default();
    assert_eq!(
        thrust_limit(&[0.0, 50.0, 50.0], &[0.0, 1.0, 2.0], &opts),
        Err(FitError::ThrottleNotIncreasing {
            index: 2,
            previous: 50.0,
            value: 50.0
        })
    );
    assert!(matches!(
        thrust_limit(&[0.0, 50.0], &[0.0, f64::NAN], &opts),
        Err(FitError::NonFinite {
            input: Input::Thrust,
            index: 1,
            ..
        })
    ));
    assert!(matches!(
        thrust_limit(&[0.0], &[0.0], &opts),
        Err(FitError::TooFewPoints { got: 1, .. })
    ));
    assert!(matches!(
        thrust_limit(&[0.0, 1.0], &[0.0], &opts),
        Err(FitError::LengthMismatch { .. })
    ));
    let std = [1.0, -1.0];
    let with_std = ThrustLimitOptions {
        thrust_std_g: Some(&std),
        ..Default::default()
    };
    assert!(matches!(
        thrust_limit(&[0.0, 1.0], &[0.0, 1.0], &with_std),
        Err(FitError::Negative {
            input: Input::ThrustStd,
            index: 1,
            ..
        })
    ));
    let bad_k = ThrustLimitOptions {
        k_sigma: 0.0,
        ..Default::default()
    };
    assert!(matches!(
        thrust_limit(&[0.0, 1.0], &[0.0, 1.0], &bad_k),
        Err(FitError::InvalidOption {
            name: "k_sigma",
            ..
        })
    ));
}

#[test]
fn isolated_low_reading_inside_the_plateau_is_an_outlier_not_a_sag() {
    let throttle = [0.0, 20.0, 40.0, 60.0, 70.0, 80.0, 90.0, 100.0];
    let thrust = [0.0, 120.0, 380.0, 600.0, 601.0, 585.0, 599.0, 600.5];
    let opts = ThrustLimitOptions {
        noise_std_g: Some(2.0),
        ..Default::default()
    };
    let r = thrust_limit(&throttle, &thrust, &opts).unwrap();
    assert_eq!(
        r.kind,
        ThrustLimitKind::Plateau {
            from_throttle: 60.0,
            to_throttle: 100.0,
            n_points: 4
        }
    );
    assert!(r.sag.is_none());
    assert!((r.thrust_g - 600.125).abs() < 1e-12);
}

#[test]
fn extreme_readings_do_not_overflow_the_mean() {
    let r = thrust_limit(
        &[0.0, 1.0, 2.0],
        &[f64::MAX, f64::MAX, f64::MAX],
        &ThrustLimitOptions::default(),
    )
    .unwrap();
    assert_eq!(r.thrust_g, f64::MAX);
}
