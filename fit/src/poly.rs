//! The fitted polynomial, its statistics and warnings.

use std::fmt;

use crate::dd::Dd;

/// Condition number of the scaled design matrix above which
/// [`FitWarning::IllConditioned`] is raised. Beyond about `1/√ε ≈ 7e7` the
/// refinement can no longer recover full accuracy.
pub const ILL_CONDITIONED_THRESHOLD: f64 = 1e7;

/// Highest polynomial degree accepted by the fits.
///
/// Even on `[−1, 1]` the monomial basis becomes ill-conditioned quickly
/// (condition ≈ 2.4ᵈ); beyond degree 20 the coefficients carry little
/// information and a piecewise model is the right tool.
pub const MAX_DEGREE: usize = 20;

/// The degree used by the paper's thrust → power curves.
pub const DEFAULT_DEGREE: usize = 5;

/// Relative tolerance (against `Σ|aₖ|`, the size of the curve in the scaled
/// basis) below which a negative slope is treated as rounding noise by the
/// monotonicity check.
const MONOTONE_REL_TOL: f64 = 1e-9;

/// The largest residual of a fit and where it occurs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaxResidual {
    /// `|y − p(x)|` at that point.
    pub abs_value: f64,
    /// The signed residual `y − p(x)`.
    pub residual: f64,
    /// The abscissa of the point.
    pub x: f64,
    /// Its zero-based index in the input (for streams: the push order).
    pub index: usize,
}

/// Goodness-of-fit and uncertainty figures of a [`PolyFit`].
///
/// For weighted fits, `rss`, `r_squared`, `residual_std` and the standard
/// errors use the weights (`rss = Σ wᵢ rᵢ²`); `rmse` and `max_residual` are
/// always about the raw residuals `rᵢ = yᵢ − p(xᵢ)`.
#[derive(Debug, Clone, PartialEq)]
pub struct FitStats {
    /// Number of data points used.
    pub n_points: usize,
    /// Degrees of freedom `n_points − (degree + 1)`.
    pub dof: usize,
    /// Residual sum of squares (the minimised objective).
    pub rss: f64,
    /// Root-mean-square raw residual `√(Σ rᵢ² / n)`.
    pub rmse: f64,
    /// Coefficient of determination `1 − rss / Σ wᵢ (yᵢ − ȳ)²`; 1 when `y`
    /// is constant (the fit is then exact).
    pub r_squared: f64,
    /// Residual standard deviation `√(rss / dof)`; `None` when `dof == 0`
    /// (an interpolating fit has no residual information).
    pub residual_std: Option<f64>,
    /// The largest raw residual and its location. Always present for batch
    /// fits; `None` for streaming fits unless a
    /// [`ResidualScan`](crate::ResidualScan) second pass supplied it.
    pub max_residual: Option<MaxResidual>,
    /// Standard errors of the coefficients in the scaled basis (powers of
    /// `t = (x − center)/scale`); `None` when `dof == 0`.
    pub std_errors_scaled: Option<Vec<f64>>,
    /// Standard errors of the physical monomial coefficients `b₀ … b_d`
    /// (same order as [`PolyFit::monomial_coefficients`]); `None` when `dof == 0`.
    pub std_errors_monomial: Option<Vec<f64>>,
    /// 2-norm condition number of the (weighted) design matrix in the scaled
    /// basis: ratio of its extreme singular values (computed from the
    /// triangular factor `R`, which has the same singular values).
    pub condition_number: f64,
    /// Number of iterative-refinement steps applied (0 for streaming fits,
    /// which cannot revisit the data).
    pub refinement_iterations: usize,
}

/// A non-fatal diagnostic attached to a fit.
#[derive(Debug, Clone, PartialEq)]
pub enum FitWarning {
    /// The fitted curve decreases somewhere in the data range (a thrust →
    /// power curve should be increasing).
    NotMonotoneIncreasing {
        /// Smallest x at which the fitted curve starts to decrease.
        first_decrease_x: f64,
        /// Most negative slope dy/dx over the data range.
        min_derivative: f64,
        /// Where that slope occurs.
        min_derivative_x: f64,
    },
    /// Few points for the number of coefficients (fewer than
    /// `2 × (degree + 1)`): the fit follows the noise.
    FewPoints {
        /// Points supplied.
        n_points: usize,
        /// Polynomial degree.
        degree: usize,
        /// Recommended minimum, `2 × (degree + 1)`.
        recommended_min: usize,
    },
    /// Some x values occur more than once (fine for repeated measurements,
    /// but often a sign of a logging error).
    DuplicateX {
        /// Number of points whose x equals that of an earlier point.
        count: usize,
        /// Number of distinct x values.
        distinct: usize,
    },
    /// The scaled design matrix is ill-conditioned; coefficients are less
    /// reliable than usual.
    IllConditioned {
        /// The condition number found.
        condition_number: f64,
        /// The threshold, [`ILL_CONDITIONED_THRESHOLD`].
        threshold: f64,
    },
    /// Iterative refinement stopped without converging to full extended
    /// precision (the result is the best iterate found, at least as good as
    /// the plain QR solution).
    RefinementStalled {
        /// Refinement steps taken.
        iterations: usize,
        /// Relative size of the last correction.
        last_relative_correction: f64,
    },
    /// Streaming fits only: checks that need the samples themselves
    /// (duplicated x, maximum residual) were not performed.
    StreamingChecksSkipped,
}

/// `v` to about four significant digits, for messages (`-0.2742`, not `-0.27415419267069424`).
fn four_digits(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let decimals = (3.0 - v.abs().log10().floor()).clamp(0.0, 15.0) as usize;
    format!("{v:.decimals$}")
}

impl fmt::Display for FitWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FitWarning::NotMonotoneIncreasing {
                first_decrease_x,
                min_derivative,
                min_derivative_x,
            } => write!(
                f,
                "fitted curve is not monotone increasing: it first decreases at x = {}; \
                 steepest descent {} at x = {}",
                four_digits(*first_decrease_x),
                four_digits(*min_derivative),
                four_digits(*min_derivative_x)
            ),
            FitWarning::FewPoints {
                n_points,
                degree,
                recommended_min,
            } => write!(
                f,
                "only {n_points} points for a degree-{degree} fit (at least {recommended_min} recommended)"
            ),
            FitWarning::DuplicateX { count, distinct } => write!(
                f,
                "{count} points repeat an earlier x value ({distinct} distinct x values)"
            ),
            FitWarning::IllConditioned {
                condition_number,
                threshold,
            } => write!(
                f,
                "design matrix is ill-conditioned (condition number {condition_number:.3e} > {threshold:.0e})"
            ),
            FitWarning::RefinementStalled {
                iterations,
                last_relative_correction,
            } => write!(
                f,
                "iterative refinement did not converge after {iterations} steps \
                 (last relative correction {last_relative_correction:.3e})"
            ),
            FitWarning::StreamingChecksSkipped => f.write_str(
                "streaming fit: duplicate-x and maximum-residual checks need the samples and were skipped",
            ),
        }
    }
}

/// A least-squares polynomial, stored in the scaled basis.
///
/// The curve is `p(x) = Σₖ aₖ tᵏ` with `t = (x − center) / scale`; the data
/// range maps onto `t ∈ [−1, 1]` for batch fits. Coefficients are held to
/// double-double precision internally so the conversion to physical monomial
/// coefficients ([`monomial_coefficients`](Self::monomial_coefficients))
/// does not lose the digits that the shift-and-scale cancels.
#[derive(Debug, Clone, PartialEq)]
pub struct PolyFit {
    pub(crate) degree: usize,
    pub(crate) center: f64,
    pub(crate) scale: f64,
    pub(crate) coeffs_hi: Vec<f64>,
    pub(crate) coeffs_lo: Vec<f64>,
    pub(crate) domain: (f64, f64),
    pub(crate) stats: FitStats,
    pub(crate) warnings: Vec<FitWarning>,
}

impl PolyFit {
    /// Polynomial degree.
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Centre `c` of the scaling `t = (x − c)/s`.
    pub fn center(&self) -> f64 {
        self.center
    }

    /// Scale `s` of the scaling `t = (x − c)/s`.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Coefficients `a₀ … a_d` in the scaled basis (ascending powers of `t`),
    /// rounded to `f64`.
    pub fn coeffs_scaled(&self) -> &[f64] {
        &self.coeffs_hi
    }

    /// Validity range: the smallest and largest x of the data. Evaluating
    /// outside it is extrapolation.
    pub fn domain(&self) -> (f64, f64) {
        self.domain
    }

    /// Fit statistics.
    pub fn stats(&self) -> &FitStats {
        &self.stats
    }

    /// Non-fatal diagnostics (empty for a clean fit).
    pub fn warnings(&self) -> &[FitWarning] {
        &self.warnings
    }

    /// The scaled abscissa `t = (x − center)/scale`.
    #[inline]
    pub fn to_scaled(&self, x: f64) -> f64 {
        (x - self.center) / self.scale
    }

    /// Evaluates the fitted curve at `x` (Horner's scheme in `t`).
    #[inline]
    pub fn eval(&self, x: f64) -> f64 {
        horner(&self.coeffs_hi, self.to_scaled(x))
    }

    /// The slope `dp/dx` at `x`.
    pub fn derivative(&self, x: f64) -> f64 {
        let t = self.to_scaled(x);
        let mut acc = 0.0;
        for (k, &a) in self.coeffs_hi.iter().enumerate().skip(1).rev() {
            acc = acc * t + k as f64 * a;
        }
        acc / self.scale
    }

    /// Coefficients `b₀ … b_d` in the physical monomial basis (ascending
    /// powers of the original x, e.g. W per gᵏ): `p(x) = Σₖ bₖ xᵏ`.
    ///
    /// The change of basis runs in double-double arithmetic from the
    /// double-double scaled coefficients, so each `bₖ` is correctly rounded
    /// up to a few units even when the shift cancels many digits. Evaluating
    /// these coefficients directly is ill-conditioned for data far from
    /// `x = 0`; prefer [`eval`](Self::eval).
    pub fn monomial_coefficients(&self) -> Vec<f64> {
        let a: Vec<Dd> = self
            .coeffs_hi
            .iter()
            .zip(&self.coeffs_lo)
            .map(|(&hi, &lo)| Dd { hi, lo })
            .collect();
        to_monomial(&a, self.center, self.scale)
            .into_iter()
            .map(Dd::to_f64)
            .collect()
    }

    /// Consumes the fit and starts a second pass over the data to find the
    /// largest residual (useful after a streaming fit, which keeps no samples).
    pub fn into_residual_scan(self) -> ResidualScan {
        ResidualScan {
            fit: self,
            seen: 0,
            best: None,
        }
    }
}

/// Second pass over the data of a fit, recording the largest residual.
///
/// Obtained from [`PolyFit::into_residual_scan`]; feed it the same points in
/// the same order as the fit (indices are counted from 0 in push order), then
/// [`finish`](Self::finish) returns the fit with
/// [`FitStats::max_residual`] filled in. Non-finite points are skipped.
#[derive(Debug, Clone)]
pub struct ResidualScan {
    fit: PolyFit,
    seen: usize,
    best: Option<MaxResidual>,
}

impl ResidualScan {
    /// Feeds one point.
    pub fn push(&mut self, x: f64, y: f64) {
        let index = self.seen;
        self.seen += 1;
        let residual = y - self.fit.eval(x);
        if !residual.is_finite() {
            return;
        }
        let abs_value = residual.abs();
        if self.best.is_none_or(|b| abs_value > b.abs_value) {
            self.best = Some(MaxResidual {
                abs_value,
                residual,
                x,
                index,
            });
        }
    }

    /// Feeds a chunk of points; only the common prefix is used if the
    /// lengths differ.
    pub fn push_chunk(&mut self, x: &[f64], y: &[f64]) {
        for (&xi, &yi) in x.iter().zip(y) {
            self.push(xi, yi);
        }
    }

    /// Returns the fit with [`FitStats::max_residual`] set from this pass.
    pub fn finish(mut self) -> PolyFit {
        self.fit.stats.max_residual = self.best;
        self.fit
            .warnings
            .retain(|w| *w != FitWarning::StreamingChecksSkipped);
        self.fit
    }
}

/// Horner evaluation of `Σ cₖ tᵏ`.
#[inline]
pub(crate) fn horner(c: &[f64], t: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &a| acc * t + a)
}

/// Converts scaled-basis coefficients (powers of `(x − c)/s`) to monomial
/// coefficients (powers of `x`) in double-double arithmetic.
pub(crate) fn to_monomial(a: &[Dd], c: f64, s: f64) -> Vec<Dd> {
    let p = a.len();
    // a'_j = a_j / s^j
    let scaled: Vec<Dd> = a
        .iter()
        .enumerate()
        .map(|(j, &aj)| (0..j).fold(aj, |acc, _| acc.div_f64(s)))
        .collect();
    // Horner-style Taylor shift: b(x) = Σ a'_j (x − c)^j.
    let mut b = vec![Dd::ZERO; p];
    for &aj in scaled.iter().rev() {
        for k in (1..p).rev() {
            b[k] = b[k - 1] - b[k].mul_f64(c);
        }
        b[0] = aj - b[0].mul_f64(c);
    }
    b
}

/// The linear map `T` with `b = T a` (scaled → monomial), row-major `p × p`.
pub(crate) fn monomial_map(p: usize, c: f64, s: f64) -> Vec<f64> {
    let mut t = vec![0.0; p * p];
    for j in 0..p {
        let mut e = vec![Dd::ZERO; p];
        e[j] = Dd::ONE;
        for (k, v) in to_monomial(&e, c, s).into_iter().enumerate() {
            t[k * p + j] = v.to_f64();
        }
    }
    t
}

/// Coefficients of the derivative of `Σ cₖ tᵏ`.
fn derivative_coeffs(c: &[f64]) -> Vec<f64> {
    c.iter()
        .enumerate()
        .skip(1)
        .map(|(k, &a)| k as f64 * a)
        .collect()
}

/// All real roots of `Σ cₖ tᵏ` in `[lo, hi]`, ascending.
///
/// Recursive isolation: between consecutive roots of the derivative the
/// polynomial is monotone, so each such interval holds at most one root,
/// found by bisection to full precision.
pub(crate) fn real_roots(c: &[f64], lo: f64, hi: f64) -> Vec<f64> {
    let mut c = c;
    while let Some((&0.0, rest)) = c.split_last() {
        c = rest;
    }
    match c.len() {
        0 | 1 => return Vec::new(),
        2 => {
            let r = -c[0] / c[1];
            return if (lo..=hi).contains(&r) {
                vec![r]
            } else {
                Vec::new()
            };
        }
        _ => {}
    }
    let mut breaks = vec![lo];
    breaks.extend(real_roots(&derivative_coeffs(c), lo, hi));
    breaks.push(hi);
    let mut roots: Vec<f64> = Vec::new();
    for w in breaks.windows(2) {
        let (mut u, mut v) = (w[0], w[1]);
        let (fu, fv) = (horner(c, u), horner(c, v));
        let root = if fu == 0.0 {
            Some(u)
        } else if fv == 0.0 {
            Some(v)
        } else if (fu < 0.0) != (fv < 0.0) {
            let neg_at_u = fu < 0.0;
            for _ in 0..200 {
                let m = 0.5 * (u + v);
                if m <= u || m >= v {
                    break;
                }
                if (horner(c, m) < 0.0) == neg_at_u {
                    u = m;
                } else {
                    v = m;
                }
            }
            Some(0.5 * (u + v))
        } else {
            None
        };
        if let Some(r) = root.filter(|&r| roots.last().is_none_or(|&last| r > last)) {
            roots.push(r);
        }
    }
    roots
}

/// Checks `dp/dt ≥ 0` over `t ∈ [t_lo, t_hi]`; returns the warning (in
/// physical units) when the curve decreases beyond rounding noise.
pub(crate) fn monotonicity_warning(
    a: &[f64],
    center: f64,
    scale: f64,
    t_lo: f64,
    t_hi: f64,
) -> Option<FitWarning> {
    let d = derivative_coeffs(a);
    if d.is_empty() || t_lo.partial_cmp(&t_hi) != Some(std::cmp::Ordering::Less) {
        return None;
    }
    let size: f64 = a.iter().map(|v| v.abs()).sum();
    let tol = MONOTONE_REL_TOL * size;
    let d_roots = real_roots(&d, t_lo, t_hi);
    // The minimum slope is at an end point or a critical point of the slope.
    let mut candidates = vec![t_lo, t_hi];
    candidates.extend(real_roots(&derivative_coeffs(&d), t_lo, t_hi));
    let (min_t, min_d) =
        candidates
            .iter()
            .map(|&t| (t, horner(&d, t)))
            .fold((t_lo, f64::INFINITY), |best, cur| {
                if cur.1 < best.1 { cur } else { best }
            });
    if min_d.partial_cmp(&-tol) != Some(std::cmp::Ordering::Less) {
        return None;
    }
    // First sign segment of the slope that dips below the tolerance.
    let mut bounds = vec![t_lo];
    bounds.extend(d_roots.iter().copied());
    bounds.push(t_hi);
    let first_t = bounds
        .windows(2)
        .find(|w| {
            let (u, v) = (w[0], w[1]);
            horner(&d, 0.5 * (u + v)) < 0.0
                && candidates
                    .iter()
                    .chain(&[0.5 * (u + v)])
                    .filter(|&&t| t >= u && t <= v)
                    .any(|&t| horner(&d, t) < -tol)
        })
        .map_or(min_t, |w| w[0]);
    Some(FitWarning::NotMonotoneIncreasing {
        first_decrease_x: center + scale * first_t,
        min_derivative: min_d / scale,
        min_derivative_x: center + scale * min_t,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roots_of_cubic_are_found() {
        // (t + 0.5)(t − 0.1)(t − 0.9) = t³ − 0.5t² − 0.41t + 0.045
        let c = [0.045, -0.41, -0.5, 1.0];
        let r = real_roots(&c, -1.0, 1.0);
        assert_eq!(r.len(), 3);
        for (got, want) in r.iter().zip([-0.5, 0.1, 0.9]) {
            assert!((got - want).abs() < 1e-14, "{got} vs {want}");
        }
        assert_eq!(real_roots(&c, 0.2, 0.8), Vec::<f64>::new());
    }

    #[test]
    fn monomial_conversion_matches_expansion() {
        // p(t) = 1 + 2t + 3t², t = (x − 4)/2  ⇒  p = 1 + (x−4) + 0.75(x−4)²
        //       = 9 − 5x + 0.75x²
        let a = [Dd::from_f64(1.0), Dd::from_f64(2.0), Dd::from_f64(3.0)];
        let b: Vec<f64> = to_monomial(&a, 4.0, 2.0)
            .into_iter()
            .map(Dd::to_f64)
            .collect();
        assert_eq!(b, vec![9.0, -5.0, 0.75]);
    }

    #[test]
    fn monotonicity_detects_dip_and_its_start() {
        // p(t) = t³ − 0.75t has p' = 3t² − 0.75 < 0 on (−0.5, 0.5).
        let a = [0.0, -0.75, 0.0, 1.0];
        let w = monotonicity_warning(&a, 10.0, 2.0, -1.0, 1.0).expect("dip");
        let FitWarning::NotMonotoneIncreasing {
            first_decrease_x,
            min_derivative,
            min_derivative_x,
        } = w
        else {
            panic!("wrong warning {w:?}");
        };
        assert!((first_decrease_x - 9.0).abs() < 1e-12);
        assert!((min_derivative + 0.375).abs() < 1e-12);
        assert!((min_derivative_x - 10.0).abs() < 1e-12);
        // An increasing cubic raises nothing.
        assert!(monotonicity_warning(&[0.0, 1.0, 0.0, 1.0], 0.0, 1.0, -1.0, 1.0).is_none());
    }
}
