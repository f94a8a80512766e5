//! Property tests of the polynomial fits.

use fit::{
    FitError, MAX_DEGREE, StreamingPolyFit, ThrustLimitKind, ThrustLimitOptions, fit_polynomial,
    fit_polynomial_weighted, thrust_limit,
};
use proptest::prelude::*;

/// Any f64 at all: normal, subnormal, zero, infinite, NaN.
fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        proptest::num::f64::ANY,
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::MAX),
        Just(-f64::MAX),
        -10.0..10.0_f64,
    ]
}

/// Finite values of every magnitude.
fn finite_f64() -> impl Strategy<Value = f64> {
    use proptest::num::f64::{NEGATIVE, NORMAL, POSITIVE, SUBNORMAL, ZERO};
    (NORMAL | SUBNORMAL | ZERO | POSITIVE | NEGATIVE).prop_filter("finite", |v| v.is_finite())
}

/// `n` jittered-grid abscissae over `[lo, lo + width]`, shuffled by a stride.
fn spread_x(n: usize, lo: f64, width: f64, jitter: &[f64]) -> Vec<f64> {
    let mut x: Vec<f64> = (0..n)
        .map(|i| lo + width * (i as f64 + 0.4 * jitter[i % jitter.len()]) / (n - 1) as f64)
        .collect();
    // Input order must not matter: permute by a stride coprime with n.
    let gcd = |mut a: usize, mut b: usize| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    let stride = (7..).find(|&s| gcd(s, n) == 1).unwrap_or(1);
    x = (0..n).map(|i| x[(i * stride) % n]).collect();
    x
}

fn horner(c: &[f64], u: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &a| acc * u + a)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// Arbitrary input never panics: the fits return `Ok` or a clear `Err`,
    /// and an `Ok` fit has finite coefficients.
    #[test]
    fn never_panics(
        x in prop::collection::vec(any_f64(), 0..24),
        y in prop::collection::vec(any_f64(), 0..24),
        w in prop::collection::vec(any_f64(), 0..24),
        degree in 0usize..=MAX_DEGREE + 2,
        lo in any_f64(),
        hi in any_f64(),
    ) {
        match fit_polynomial(&x, &y, degree) {
            Ok(f) => {
                prop_assert!(f.coeffs_scaled().iter().all(|c| c.is_finite()));
                prop_assert_eq!(f.coeffs_scaled().len(), degree + 1);
                let _ = f.monomial_coefficients();
                let _ = f.eval(x[0]);
                let _ = f.derivative(x[0]);
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
        let _ = fit_polynomial_weighted(&x, &y, &w, degree);
        if let Ok(mut s) = StreamingPolyFit::with_block_rows(degree, lo, hi, 4) {
            let _ = s.push_chunk(&x, &y);
            for (&xi, &yi) in x.iter().zip(&y) {
                let _ = s.push(xi, yi);
            }
            if let Ok(f) = s.finish() {
                prop_assert!(f.coeffs_scaled().iter().all(|c| c.is_finite()));
            }
        }
    }

    /// Extreme but finite magnitudes (up to ±f64::MAX, subnormals) either
    /// fit with finite results or fail with an error — no NaN leaks out.
    #[test]
    fn extreme_finite_values_fit_or_fail_cleanly(
        pts in prop::collection::vec((finite_f64(), finite_f64()), 1..16),
        degree in 0usize..4,
    ) {
        let (x, y): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
        if let Ok(f) = fit_polynomial(&x, &y, degree) {
            prop_assert!(f.coeffs_scaled().iter().all(|c| c.is_finite()));
            let s = f.stats();
            prop_assert!(!s.rss.is_nan() && !s.rmse.is_nan() && !s.r_squared.is_nan());
            prop_assert!(!s.condition_number.is_nan());
            prop_assert!(s.max_residual.is_some());
        }
    }

    /// Finite data of moderate size always fits when there are enough
    /// distinct abscissae.
    #[test]
    fn finite_data_with_enough_distinct_x_fits(
        pts in prop::collection::vec((-1e6..1e6_f64, -1e6..1e6_f64), 1..40),
        degree in 0usize..6,
    ) {
        let (x, y): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
        let mut d = x.clone();
        d.sort_by(f64::total_cmp);
        d.dedup();
        match fit_polynomial(&x, &y, degree) {
            Ok(_) => prop_assert!(d.len() > degree && d.len() > 1),
            Err(FitError::TooFewDistinctX { distinct, .. }) => prop_assert!(distinct == d.len() && distinct <= degree),
            Err(FitError::AllXEqual { .. }) => prop_assert_eq!(d.len(), 1),
            Err(e) => prop_assert!(false, "unexpected error {}", e),
        }
    }

    /// A polynomial of degree ≤ d sampled at well-spread points is recovered:
    /// the fit reproduces it everywhere on the data range.
    #[test]
    fn exact_polynomials_are_recovered(
        coeffs in prop::collection::vec(-100.0..100.0_f64, 1..7),
        extra in 0usize..3,
        n_extra in 0usize..30,
        lo in -1e4..1e4_f64,
        width in 1e-3..1e4_f64,
        shift in -0.5..0.5_f64,
        stretch in 0.5..2.0_f64,
        jitter in prop::collection::vec(-1.0..1.0_f64, 1..8),
    ) {
        let true_degree = coeffs.len() - 1;
        let degree = (true_degree + extra).min(8);
        let n = (degree + 1 + n_extra).max(2);
        let x = spread_x(n, lo, width, &jitter);
        // The polynomial lives in its own scaled variable u (not the fit's t).
        let (m, h) = (lo + width * (0.5 + shift), 0.5 * width * stretch);
        let u = |x: f64| (x - m) / h;
        let y: Vec<f64> = x.iter().map(|&xi| horner(&coeffs, u(xi))).collect();
        let f = fit_polynomial(&x, &y, degree).unwrap();
        let size: f64 = coeffs.iter().map(|c| c.abs()).sum::<f64>() * 4f64.powi(true_degree as i32);
        for k in 0..=200 {
            let xk = lo + width * k as f64 / 200.0;
            let err = (f.eval(xk) - horner(&coeffs, u(xk))).abs();
            prop_assert!(err <= 1e-9 * size, "x = {}: error {:e} (size {})", xk, err, size);
        }
        prop_assert!(f.stats().rss <= 1e-20 * size * size * n as f64);
    }

    /// Evaluating at the data points gives the least-squares fitted values:
    /// the residuals `y − eval(x)` are orthogonal to every basis function,
    /// their largest magnitude is the reported one, and an interpolating fit
    /// passes through the data.
    #[test]
    fn eval_at_data_gives_fitted_values(
        pts in prop::collection::vec((0.0..300.0_f64, -50.0..50.0_f64), 2..40),
        degree in 0usize..6,
    ) {
        let (x, y): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
        let Ok(f) = fit_polynomial(&x, &y, degree) else {
            return Ok(());
        };
        let r: Vec<f64> = x.iter().zip(&y).map(|(&xi, &yi)| yi - f.eval(xi)).collect();
        let y_scale = y.iter().fold(1.0_f64, |m, v| m.max(v.abs()));
        let tol = 1e-11 * y_scale * x.len() as f64;
        for k in 0..=degree {
            let dot: f64 = x.iter().zip(&r).map(|(&xi, &ri)| ri * f.to_scaled(xi).powi(k as i32)).sum();
            prop_assert!(dot.abs() <= tol, "basis {} · residual = {:e}", k, dot);
        }
        let max = f.stats().max_residual.unwrap();
        prop_assert!((r[max.index].abs() - max.abs_value).abs() <= 1e-12 * y_scale);
        prop_assert!(r.iter().all(|ri| ri.abs() <= max.abs_value + 1e-12 * y_scale));
        if f.stats().dof == 0 {
            prop_assert!(r.iter().all(|ri| ri.abs() <= 1e-9 * y_scale));
        }
    }

    /// The fitted curve does not depend on the units of x: fitting against
    /// `α x + β` gives the same curve.
    #[test]
    fn affine_rescaling_of_x_leaves_the_curve_unchanged(
        pts in prop::collection::vec((0.0..260.0_f64, 0.0..60.0_f64), 12..40),
        degree in 1usize..6,
        log_alpha in -3.0..3.0_f64,
        negative in any::<bool>(),
        beta in -1e3..1e3_f64,
    ) {
        let (x, y): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
        let alpha = if negative { -10f64.powf(log_alpha) } else { 10f64.powf(log_alpha) };
        let x2: Vec<f64> = x.iter().map(|&v| alpha * v + beta).collect();
        let (Ok(f), Ok(g)) = (fit_polynomial(&x, &y, degree), fit_polynomial(&x2, &y, degree)) else {
            return Ok(());
        };
        // Skip nearly rank-deficient samples (a few tight clusters).
        prop_assume!(f.stats().condition_number < 1e6);
        let scale = f.coeffs_scaled().iter().fold(1.0_f64, |m, v| m.max(v.abs()));
        let tol = 1e-8 * scale * f.stats().condition_number;
        for (&xi, &x2i) in x.iter().zip(&x2) {
            prop_assert!((f.eval(xi) - g.eval(x2i)).abs() <= tol);
        }
        // between the data too (the stored centre and scale are rounded numbers of each
        // abscissa, so the scaled coefficients themselves differ slightly)
        let (lo, hi) = f.domain();
        for i in 0..=50 {
            let xi = lo + (hi - lo) * f64::from(i) / 50.0;
            let (a, b) = (f.eval(xi), g.eval(alpha * xi + beta));
            prop_assert!((a - b).abs() <= tol, "at x = {}: {} vs {}", xi, a, b);
        }
        let (sf, sg) = (f.stats(), g.stats());
        prop_assert!((sf.r_squared - sg.r_squared).abs() <= 1e-9);
    }

    /// Thrust-limit extraction never panics, and a result lies within the
    /// range of the readings with a non-negative uncertainty.
    #[test]
    fn thrust_limit_never_panics(
        throttle in prop::collection::vec(any_f64(), 0..16),
        thrust in prop::collection::vec(any_f64(), 0..16),
        std in prop::option::of(prop::collection::vec(any_f64(), 0..16)),
        noise in prop::option::of(any_f64()),
        k_sigma in any_f64(),
        min_plateau_points in 0usize..6,
    ) {
        let opts = ThrustLimitOptions {
            thrust_std_g: std.as_deref(),
            noise_std_g: noise,
            k_sigma,
            min_plateau_points,
        };
        if let Ok(r) = thrust_limit(&throttle, &thrust, &opts) {
            let lo = thrust.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = thrust.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            prop_assert!(r.thrust_g >= lo && r.thrust_g <= hi, "{:?}", r);
            prop_assert!(r.uncertainty_g >= 0.0);
            if let ThrustLimitKind::Plateau { n_points, .. } = r.kind {
                prop_assert!(n_points >= 1 && n_points <= thrust.len());
            }
        }
    }

    /// Increasing sweeps of finite readings always yield a limit.
    #[test]
    fn thrust_limit_of_valid_sweeps_is_ok(
        thrust in prop::collection::vec(0.0..1000.0_f64, 2..30),
        sigma in 0.0..20.0_f64,
    ) {
        let throttle: Vec<f64> = (0..thrust.len()).map(|i| i as f64).collect();
        let opts = ThrustLimitOptions { noise_std_g: Some(sigma), ..Default::default() };
        let r = thrust_limit(&throttle, &thrust, &opts).unwrap();
        // The limit never exceeds the best reading, and the best reading
        // (first occurrence) lies within the reported plateau.
        let (best, max) = thrust
            .iter()
            .copied()
            .enumerate()
            .fold((0, f64::NEG_INFINITY), |b, (i, v)| if v > b.1 { (i, v) } else { b });
        prop_assert!(r.thrust_g <= max);
        match r.kind {
            ThrustLimitKind::Plateau { from_throttle, to_throttle, .. } => {
                prop_assert!(from_throttle <= throttle[best] && throttle[best] <= to_throttle, "{:?}", r);
            }
            ThrustLimitKind::TopOfRange => prop_assert_eq!(r.thrust_g, thrust[thrust.len() - 1]),
        }
    }
}
