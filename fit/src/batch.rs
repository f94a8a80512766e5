//! Batch least-squares polynomial fit with extended-precision refinement.

use crate::assemble::Solved;
use crate::dd::{Dd, DdSum};
use crate::error::{FitError, Input};
use crate::poly::{MAX_DEGREE, MaxResidual, PolyFit};
use crate::qr::{
    DEFAULT_BLOCK_ROWS, QrAccumulator, solve_upper, solve_upper_transposed, split_augmented,
};
use crate::scale::Pow2;

/// Maximum number of corrected-semi-normal-equation refinement steps.
const MAX_REFINEMENT_STEPS: usize = 8;

/// A refinement step must shrink the correction at least this much, or the
/// iteration is considered to have stopped contracting.
const MIN_CONTRACTION: f64 = 0.5;

/// Relative size of the last correction below which the refinement counts
/// as converged (four orders beyond double precision); if it stops above
/// this, [`FitWarning::RefinementStalled`](crate::FitWarning::RefinementStalled)
/// is reported.
const CONVERGED_REL: f64 = 1e-20;

/// Least-squares polynomial of the given degree through `(x, y)`.
///
/// See the [crate documentation](crate) for the method. Returns an error for
/// empty or mismatched input, non-finite values, too few distinct x values,
/// all-equal x, or a degree above [`MAX_DEGREE`]; never panics.
pub fn fit_polynomial(x: &[f64], y: &[f64], degree: usize) -> Result<PolyFit, FitError> {
    fit(x, y, None, degree)
}

/// Weighted least squares: minimises `Σ wᵢ (yᵢ − p(xᵢ))²`.
///
/// Weights must be finite and strictly positive (use `1/σᵢ²` for points
/// with known standard deviations). Otherwise as [`fit_polynomial`].
pub fn fit_polynomial_weighted(
    x: &[f64],
    y: &[f64],
    weights: &[f64],
    degree: usize,
) -> Result<PolyFit, FitError> {
    fit(x, y, Some(weights), degree)
}

/// Validated input: scaled ordinates and weights, and the x statistics.
struct Prepared {
    center: f64,
    scale: f64,
    min: f64,
    max: f64,
    distinct: usize,
    y: Vec<f64>,
    w: Option<Vec<f64>>,
    y_pow: Pow2,
    w_pow: Pow2,
}

fn prepare(x: &[f64], y: &[f64], w: Option<&[f64]>, degree: usize) -> Result<Prepared, FitError> {
    if degree > MAX_DEGREE {
        return Err(FitError::DegreeTooLarge {
            degree,
            max: MAX_DEGREE,
        });
    }
    let mismatch = |second: Input, second_len: usize| FitError::LengthMismatch {
        first: Input::X,
        first_len: x.len(),
        second,
        second_len,
    };
    if x.len() != y.len() {
        return Err(mismatch(Input::Y, y.len()));
    }
    if let Some(len) = w.map(<[f64]>::len).filter(|&len| len != x.len()) {
        return Err(mismatch(Input::Weight, len));
    }
    if x.is_empty() {
        return Err(FitError::Empty);
    }
    for (index, (&xi, &yi)) in x.iter().zip(y).enumerate() {
        for (input, value) in [(Input::X, xi), (Input::Y, yi)] {
            if !value.is_finite() {
                return Err(FitError::NonFinite {
                    input,
                    index,
                    value,
                });
            }
        }
        if let Some(w) = w {
            let value = w[index];
            if !value.is_finite() {
                return Err(FitError::NonFinite {
                    input: Input::Weight,
                    index,
                    value,
                });
            }
            if value <= 0.0 {
                return Err(FitError::NotPositive {
                    input: Input::Weight,
                    index,
                    value,
                });
            }
        }
    }
    let (min, max) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if min == max {
        return Err(FitError::AllXEqual {
            n: x.len(),
            value: min,
        });
    }
    let width = max - min;
    if !width.is_finite() {
        return Err(FitError::RangeTooWide { min, max });
    }
    let mut sorted = x.to_vec();
    sorted.sort_by(f64::total_cmp);
    // -0.0 and 0.0 are the same abscissa.
    let distinct = 1 + sorted.windows(2).filter(|p| p[0] != p[1]).count();
    if distinct <= degree {
        return Err(FitError::TooFewDistinctX { degree, distinct });
    }
    let (center, scale) = crate::scale::rounded_center_scale(min, max);

    let y_pow = Pow2::for_max_abs(y.iter().fold(0.0, |m, v| m.max(v.abs())));
    let w_pow = w.map_or(Pow2::IDENTITY, |w| {
        Pow2::for_max_abs(w.iter().fold(0.0, |m, v| m.max(*v)))
    });
    Ok(Prepared {
        center,
        scale,
        min,
        max,
        distinct,
        y: y.iter().map(|&v| y_pow.down(v)).collect(),
        w: w.map(|w| w.iter().map(|&v| w_pow.down(v)).collect()),
        y_pow,
        w_pow,
    })
}

/// Residual `y − p(t)` evaluated entirely in double-double.
#[inline]
fn residual_dd(a: &[Dd], t: Dd, y: f64) -> Dd {
    let mut v = Dd::ZERO;
    for &ak in a.iter().rev() {
        v = v * t + ak;
    }
    Dd::from_f64(y) - v
}

/// `g = Aᵀ W r` with `r = y − A a`, and the objective `Σ wᵢ rᵢ²`, all in
/// double-double.
fn gradient(a: &[Dd], t: &[Dd], y: &[f64], w: Option<&[f64]>) -> (Vec<f64>, Dd) {
    let p = a.len();
    let mut g = vec![DdSum::default(); p];
    let mut rss = DdSum::default();
    for (i, (&ti, &yi)) in t.iter().zip(y).enumerate() {
        let r = residual_dd(a, ti, yi);
        let wr = w.map_or(r, |w| r.mul_f64(w[i]));
        rss.add(wr * r);
        let mut pw = wr;
        for gk in g.iter_mut() {
            gk.add(pw);
            pw = pw * ti;
        }
    }
    (g.into_iter().map(|s| s.0.to_f64()).collect(), rss.0)
}

fn fit(x: &[f64], y: &[f64], w: Option<&[f64]>, degree: usize) -> Result<PolyFit, FitError> {
    let prep = prepare(x, y, w, degree)?;
    let p = degree + 1;
    let n = x.len();
    let (c, s) = (prep.center, prep.scale);
    let y = &prep.y[..];
    let w = prep.w.as_deref();

    // The scaled abscissa in double-double: x − c is exact, the division
    // by s is accurate to ~1e-32, so the refinement sees the true problem.
    let t: Vec<Dd> = x.iter().map(|&xi| Dd::diff(xi, c).div_f64(s)).collect();

    // Householder QR of [√W·A | √W·y], A the Vandermonde matrix in t.
    let mut acc = QrAccumulator::new(p + 1, n.min(DEFAULT_BLOCK_ROWS));
    let mut next = 0;
    while next < n {
        let m = acc.free_rows().min(n - next);
        acc.fill_rows(m, |cols| {
            for i in 0..m {
                let k = next + i;
                let sw = w.map_or(1.0, |w| w[k].sqrt());
                let ti = t[k].hi;
                let mut pw = sw;
                for col in cols[..p].iter_mut() {
                    col[i] = pw;
                    pw *= ti;
                }
                cols[p][i] = sw * y[k];
            }
        });
        next += m;
    }
    let (r, qty, _) = split_augmented(&acc.triangle(), p);
    let a0 = solve_upper(&r, p, &qty);
    if a0.iter().any(|v| !v.is_finite()) {
        return Err(FitError::NumericalFailure {
            context: "QR solve produced non-finite coefficients",
        });
    }

    // Corrected semi-normal equations: a ← a + (RᵀR)⁻¹ Aᵀ W (y − A a), with
    // the residual and Aᵀ W r in double-double. The fixed point satisfies the
    // exact normal equations, and each step contracts the error by about
    // ε·κ², so a few steps reach double-double accuracy.
    //
    // Safeguard for very ill-conditioned problems (ε·κ² ≳ 1), where the
    // iteration need not contract: a step is kept only while the corrections
    // shrink and the objective does not grow; otherwise the best iterate so
    // far (at worst the QR solution) is returned.
    let mut a: Vec<Dd> = a0.into_iter().map(Dd::from_f64).collect();
    let mut best: Option<(Vec<Dd>, Dd)> = None;
    let mut iterations = 0;
    let mut last_rel = f64::INFINITY;
    for step in 0..=MAX_REFINEMENT_STEPS {
        let (g, objective) = gradient(&a, &t, y, w);
        let worse = best
            .as_ref()
            .is_some_and(|(_, best_obj)| (objective - *best_obj).hi > 0.0);
        if worse {
            // Undo the last step (one was taken, or `best` would be empty).
            if let Some((best_a, _)) = best {
                a = best_a;
            }
            iterations -= 1;
            break;
        }
        best = Some((a.clone(), objective));
        if step == MAX_REFINEMENT_STEPS {
            break;
        }
        let delta = solve_upper(&r, p, &solve_upper_transposed(&r, p, &g));
        let a_norm = a.iter().fold(0.0_f64, |m, v| m.max(v.hi.abs()));
        let d_norm = delta.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        if d_norm == 0.0 {
            last_rel = 0.0;
            break;
        }
        let rel = d_norm / a_norm.max(f64::MIN_POSITIVE);
        if !rel.is_finite() || (iterations > 0 && rel > MIN_CONTRACTION * last_rel) {
            break;
        }
        for (ak, dk) in a.iter_mut().zip(delta) {
            *ak = ak.add_f64(dk);
        }
        iterations += 1;
        last_rel = rel;
        if rel < CONVERGED_REL {
            break;
        }
    }
    let stalled_correction = (last_rel >= CONVERGED_REL).then_some(last_rel);

    // Final residuals (double-double) and sums of squares.
    let mut rss = DdSum::default();
    let mut raw_ss = DdSum::default();
    let mut max_residual: Option<MaxResidual> = None;
    for (i, (&ti, &yi)) in t.iter().zip(y).enumerate() {
        let r = residual_dd(&a, ti, yi);
        let sq = r * r;
        raw_ss.add(sq);
        rss.add(w.map_or(sq, |w| sq.mul_f64(w[i])));
        let rf = prep.y_pow.up(r.to_f64());
        if max_residual.is_none_or(|m| rf.abs() > m.abs_value) {
            max_residual = Some(MaxResidual {
                abs_value: rf.abs(),
                residual: rf,
                x: x[i],
                index: i,
            });
        }
    }
    let sst = total_sum_of_squares(y, w);
    let y_pow = prep.y_pow;
    let coeffs = a
        .iter()
        .map(|v| Dd {
            hi: y_pow.up(v.hi),
            lo: y_pow.up(v.lo),
        })
        .collect();

    Solved {
        degree,
        center: c,
        scale: s,
        coeffs,
        domain: (prep.min, prep.max),
        r,
        n_points: n,
        rss: rss.0.to_f64(),
        raw_ss: raw_ss.0.to_f64(),
        sst,
        y_unit: y_pow,
        w_unit: prep.w_pow,
        max_residual,
        duplicates: Some((n - prep.distinct, prep.distinct)),
        refinement_iterations: iterations,
        stalled_correction,
        streaming: false,
    }
    .assemble()
}

/// `Σ wᵢ (yᵢ − ȳ)²` about the weighted mean, in compensated arithmetic.
fn total_sum_of_squares(y: &[f64], w: Option<&[f64]>) -> f64 {
    let mut sw = DdSum::default();
    let mut swy = DdSum::default();
    for (i, &yi) in y.iter().enumerate() {
        let wi = w.map_or(1.0, |w| w[i]);
        sw.add_f64(wi);
        swy.add(Dd::from_f64(yi).mul_f64(wi));
    }
    let mean = swy.0.to_f64() / sw.0.to_f64();
    let mut sst = DdSum::default();
    for (i, &yi) in y.iter().enumerate() {
        let d = Dd::diff(yi, mean);
        let sq = d * d;
        sst.add(w.map_or(sq, |w| sq.mul_f64(w[i])));
    }
    sst.0.to_f64()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pow2_normalises_into_half_open_unit_interval() {
        for m in [1.0, 0.75, 3.0, 1e300, 1.7e308, 1e-310, 5e-324, 12345.678] {
            let p = Pow2::for_max_abs(m);
            let d = p.down(m);
            assert!((0.5..1.0).contains(&d), "{m} -> {d}");
            assert_eq!(p.up(d), m);
        }
    }

    #[test]
    fn straight_line_is_exact() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let y = [1.0, 3.0, 5.0, 7.0];
        let f = fit_polynomial(&x, &y, 1).unwrap();
        assert_eq!(f.monomial_coefficients(), vec![1.0, 2.0]);
        assert!(f.stats().rss < 1e-28);
        assert_eq!(f.stats().r_squared, 1.0);
        assert_eq!(f.eval(1.5), 4.0);
        assert_eq!(f.derivative(0.3), 2.0);
    }

    #[test]
    fn constant_data_has_unit_r_squared() {
        let f = fit_polynomial(&[0.0, 1.0, 2.0, 3.0], &[0.1; 4], 2).unwrap();
        assert_eq!(f.stats().r_squared, 1.0);
        assert!((f.eval(1.5) - 0.1).abs() < 1e-16);
        assert!(
            f.warnings()
                .iter()
                .all(|w| !matches!(w, crate::FitWarning::NotMonotoneIncreasing { .. }))
        );
    }

    #[test]
    fn weights_pull_the_fit() {
        let x = [0.0, 1.0, 2.0];
        let y = [0.0, 1.0, 0.0];
        // A constant fit is the weighted mean.
        let f = fit_polynomial_weighted(&x, &y, &[1.0, 3.0, 1.0], 0).unwrap();
        assert!((f.eval(0.0) - 0.6).abs() < 1e-15);
        let g = fit_polynomial(&x, &y, 0).unwrap();
        assert!((g.eval(0.0) - 1.0 / 3.0).abs() < 1e-15);
    }

    #[test]
    fn errors_carry_context() {
        assert_eq!(fit_polynomial(&[], &[], 1), Err(FitError::Empty));
        assert!(matches!(
            fit_polynomial(&[1.0, 2.0], &[1.0], 1),
            Err(FitError::LengthMismatch {
                first_len: 2,
                second_len: 1,
                ..
            })
        ));
        assert!(matches!(
            fit_polynomial(&[1.0, 2.0, 3.0], &[1.0, f64::NAN, 2.0], 1),
            Err(FitError::NonFinite {
                input: Input::Y,
                index: 1,
                ..
            })
        ));
        assert!(matches!(
            fit_polynomial(&[1.0, f64::INFINITY], &[1.0, 2.0], 1),
            Err(FitError::NonFinite {
                input: Input::X,
                index: 1,
                ..
            })
        ));
        assert_eq!(
            fit_polynomial(&[1.0, 1.0, 2.0, 2.0], &[1.0, 2.0, 3.0, 4.0], 2),
            Err(FitError::TooFewDistinctX {
                degree: 2,
                distinct: 2
            })
        );
        assert_eq!(
            fit_polynomial(&[3.0, 3.0], &[1.0, 2.0], 0),
            Err(FitError::AllXEqual { n: 2, value: 3.0 })
        );
        assert_eq!(
            fit_polynomial(&[1.0, 2.0], &[1.0, 2.0], 21),
            Err(FitError::DegreeTooLarge {
                degree: 21,
                max: MAX_DEGREE
            })
        );
        assert_eq!(
            fit_polynomial(&[-1e308, 1e308], &[1.0, 2.0], 1),
            Err(FitError::RangeTooWide {
                min: -1e308,
                max: 1e308
            })
        );
        assert!(matches!(
            fit_polynomial_weighted(&[1.0, 2.0], &[1.0, 2.0], &[1.0, 0.0], 1),
            Err(FitError::NotPositive {
                input: Input::Weight,
                index: 1,
                ..
            })
        ));
        let msg = FitError::TooFewDistinctX {
            degree: 5,
            distinct: 3,
        }
        .to_string();
        assert!(
            msg.contains("6 distinct") && msg.contains("only 3"),
            "{msg}"
        );
    }
}
