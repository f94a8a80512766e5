//! Non-fatal diagnostics of the batch fit.

use fit::{FitWarning, fit_polynomial, fit_polynomial_weighted};

fn grid(n: usize, lo: f64, hi: f64) -> Vec<f64> {
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}

#[test]
fn clean_thrust_curve_has_no_warnings() {
    let x = grid(27, 0.0, 260.0);
    let y: Vec<f64> = x
        .iter()
        .map(|&t| 0.157434234 * t + 0.341190317 * (t / 100.0).powf(5.34865728))
        .collect();
    let f = fit_polynomial(&x, &y, 5).unwrap();
    assert!(f.warnings().is_empty(), "{:?}", f.warnings());
    let s = f.stats();
    assert_eq!((s.n_points, s.dof), (27, 21));
    assert!(s.condition_number > 1.0 && s.condition_number < 1e3);
    assert!(s.refinement_iterations >= 1);
    let m = s.max_residual.unwrap();
    assert_eq!(x[m.index], m.x);
    assert!((m.residual.abs() - m.abs_value).abs() == 0.0);
    assert!(s.rmse <= m.abs_value && s.rmse > 0.0);
}

#[test]
fn dip_in_the_curve_is_located() {
    // y = (x − 5)³ − 3(x − 5) decreases on (4, 6) within [0, 10].
    let x = grid(41, 0.0, 10.0);
    let y: Vec<f64> = x
        .iter()
        .map(|&v| (v - 5.0).powi(3) - 3.0 * (v - 5.0))
        .collect();
    let f = fit_polynomial(&x, &y, 3).unwrap();
    let w = f
        .warnings()
        .iter()
        .find_map(|w| match *w {
            FitWarning::NotMonotoneIncreasing {
                first_decrease_x,
                min_derivative,
                min_derivative_x,
            } => Some((first_decrease_x, min_derivative, min_derivative_x)),
            _ => None,
        })
        .expect("monotonicity warning");
    assert!((w.0 - 4.0).abs() < 1e-9, "{w:?}");
    assert!((w.1 + 3.0).abs() < 1e-9, "{w:?}");
    assert!((w.2 - 5.0).abs() < 1e-9, "{w:?}");
    assert!(
        f.warnings()[0]
            .to_string()
            .contains("first decreases at x = 4")
    );
}

#[test]
fn few_points_and_duplicates_are_reported() {
    let x = [0.0, 1.0, 1.0, 2.0, 3.0, 3.0, 3.0];
    let y = [0.0, 1.0, 1.1, 4.0, 9.0, 9.2, 8.9];
    let f = fit_polynomial(&x, &y, 3).unwrap();
    assert!(f.warnings().contains(&FitWarning::FewPoints {
        n_points: 7,
        degree: 3,
        recommended_min: 8
    }));
    assert!(f.warnings().contains(&FitWarning::DuplicateX {
        count: 3,
        distinct: 4
    }));
}

#[test]
fn ill_conditioning_is_reported() {
    // Degree 20 on points crowded around the centre: the high powers of t
    // are nearly indistinguishable there.
    let x: Vec<f64> = (0..60)
        .map(|i| (2.0 * i as f64 / 59.0 - 1.0).powi(3))
        .collect();
    let y: Vec<f64> = x.iter().map(|v| v.sin()).collect();
    let f = fit_polynomial(&x, &y, 20).unwrap();
    let cond = f.stats().condition_number;
    assert!(cond > fit::ILL_CONDITIONED_THRESHOLD, "cond {cond:e}");
    assert!(f.warnings().iter().any(|w| matches!(
        w,
        FitWarning::IllConditioned { condition_number, .. } if *condition_number == cond
    )));
    // Still a usable interpolant of a smooth function.
    for &v in &x {
        assert!((f.eval(v) - v.sin()).abs() < 1e-6);
    }
}

#[test]
fn weighted_fit_statistics_use_the_weights() {
    let x = grid(30, 0.0, 3.0);
    let y: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, &v)| 1.0 + 2.0 * v + if i % 2 == 0 { 0.1 } else { -0.1 })
        .collect();
    let unit = fit_polynomial(&x, &y, 1).unwrap();
    let w = vec![4.0; x.len()];
    let weighted = fit_polynomial_weighted(&x, &y, &w, 1).unwrap();
    // Uniform weights: same curve, rss scaled by the weight, same R² and
    // standard errors (σ² (AᵀWA)⁻¹ is invariant to a common weight factor).
    for (a, b) in unit.coeffs_scaled().iter().zip(weighted.coeffs_scaled()) {
        assert!((a - b).abs() < 1e-14);
    }
    let (su, sw) = (unit.stats(), weighted.stats());
    assert!((sw.rss / su.rss - 4.0).abs() < 1e-12);
    assert!((sw.r_squared - su.r_squared).abs() < 1e-14);
    assert!((sw.rmse - su.rmse).abs() < 1e-14);
    let (eu, ew) = (
        su.std_errors_monomial.as_ref().unwrap(),
        sw.std_errors_monomial.as_ref().unwrap(),
    );
    for (a, b) in eu.iter().zip(ew) {
        assert!((a / b - 1.0).abs() < 1e-12);
    }
}
