//! Shared back end of the batch and streaming fits: the assembly of a [`PolyFit`] (statistics and warnings) from a solved system.

use faer::Mat;

use crate::dd::Dd;
use crate::error::FitError;
use crate::poly::{
    FitStats, FitWarning, ILL_CONDITIONED_THRESHOLD, MaxResidual, PolyFit, monomial_map,
    monotonicity_warning,
};
use crate::qr::solve_upper;
use crate::scale::Pow2;

/// Ratio of extreme singular values of the triangle `R`.
fn condition_number(r: &[f64], p: usize) -> f64 {
    let m = Mat::from_fn(p, p, |i, j| r[i * p + j]);
    match m.singular_values() {
        Ok(sv) => {
            let max = sv.iter().copied().fold(0.0, f64::max);
            let min = sv.iter().copied().fold(f64::INFINITY, f64::min);
            if min > 0.0 { max / min } else { f64::INFINITY }
        }
        Err(_) => f64::INFINITY,
    }
}

/// Everything needed to assemble a [`PolyFit`].
pub(crate) struct Solved {
    pub degree: usize,
    pub center: f64,
    pub scale: f64,
    pub coeffs: Vec<Dd>,
    pub domain: (f64, f64),
    /// Triangle of the (normalised-weight) design matrix, row-major
    /// `(d+1) × (d+1)`.
    pub r: Vec<f64>,
    pub n_points: usize,
    /// Weighted residual sum of squares, in normalised units.
    pub rss: f64,
    /// Unweighted sum of squared residuals, in normalised units.
    pub raw_ss: f64,
    /// Weighted total sum of squares about the weighted mean, normalised units.
    pub sst: f64,
    /// Power-of-two unit of y (physical = normalised · unit).
    pub y_unit: Pow2,
    /// Power-of-two unit of the weights.
    pub w_unit: Pow2,
    pub max_residual: Option<MaxResidual>,
    /// `(duplicates, distinct)` when known.
    pub duplicates: Option<(usize, usize)>,
    pub refinement_iterations: usize,
    pub stalled_correction: Option<f64>,
    pub streaming: bool,
}

impl Solved {
    pub(crate) fn assemble(self) -> Result<PolyFit, FitError> {
        let p = self.degree + 1;
        let coeffs_hi: Vec<f64> = self.coeffs.iter().map(|c| c.hi).collect();
        let coeffs_lo: Vec<f64> = self.coeffs.iter().map(|c| c.lo).collect();
        if coeffs_hi.iter().any(|c| !c.is_finite()) {
            return Err(FitError::NumericalFailure {
                context: "coefficients overflowed (data values too extreme for f64)",
            });
        }
        let dof = self.n_points.saturating_sub(p);
        // Ratios and roots are formed in normalised units (no overflow), then
        // scaled back: rss = 2^(e_w + 2 e_y)·rss', σ = 2^e_y·√(2^e_w)·σ'.
        // A constant y is fitted exactly by any degree ≥ 0.
        let r_squared = if self.sst > 0.0 {
            1.0 - self.rss / self.sst
        } else {
            1.0
        };
        let (yu, wu) = (self.y_unit, self.w_unit);
        let sigma_norm = (dof > 0).then(|| (self.rss / dof as f64).sqrt());
        let residual_std = sigma_norm.map(|s| yu.up(wu.up_sqrt(s)));
        let rss = wu.up(yu.up(yu.up(self.rss)));
        let rmse = yu.up((self.raw_ss / self.n_points as f64).sqrt());

        // Unscaled covariance (RᵀR)⁻¹ = R⁻¹R⁻ᵀ, column by column of R⁻¹.
        let mut r_inv = vec![0.0; p * p]; // row-major
        for j in 0..p {
            let mut e = vec![0.0; p];
            e[j] = 1.0;
            for (i, v) in solve_upper(&self.r, p, &e).into_iter().enumerate() {
                r_inv[i * p + j] = v;
            }
        }
        let cov = |i: usize, j: usize| -> f64 {
            (0..p).map(|k| r_inv[i * p + k] * r_inv[j * p + k]).sum()
        };
        // σ·R⁻¹ is invariant under the weight normalisation, so the standard
        // errors only need the y unit.
        let (std_errors_scaled, std_errors_monomial) = match sigma_norm {
            Some(sigma_norm) => {
                let sigma = yu.up(sigma_norm);
                let scaled = (0..p).map(|i| sigma * cov(i, i).max(0.0).sqrt()).collect();
                // Cov_b = T Cov_a Tᵀ with b = T a; only the diagonal is needed:
                // diag = Σ_k ((T R⁻¹)_{ik})².
                let t = monomial_map(p, self.center, self.scale);
                let monomial = (0..p)
                    .map(|i| {
                        let ss: f64 = (0..p)
                            .map(|k| {
                                let v: f64 = (0..p).map(|j| t[i * p + j] * r_inv[j * p + k]).sum();
                                v * v
                            })
                            .sum();
                        sigma * ss.sqrt()
                    })
                    .collect();
                (Some(scaled), Some(monomial))
            }
            None => (None, None),
        };
        let condition_number = condition_number(&self.r, p);

        let mut warnings = Vec::new();
        let t_lo = (self.domain.0 - self.center) / self.scale;
        let t_hi = (self.domain.1 - self.center) / self.scale;
        if let Some(w) = monotonicity_warning(&coeffs_hi, self.center, self.scale, t_lo, t_hi) {
            warnings.push(w);
        }
        if self.n_points < 2 * p {
            warnings.push(FitWarning::FewPoints {
                n_points: self.n_points,
                degree: self.degree,
                recommended_min: 2 * p,
            });
        }
        if let Some((count @ 1.., distinct)) = self.duplicates {
            warnings.push(FitWarning::DuplicateX { count, distinct });
        }
        if condition_number.is_nan() || condition_number > ILL_CONDITIONED_THRESHOLD {
            warnings.push(FitWarning::IllConditioned {
                condition_number,
                threshold: ILL_CONDITIONED_THRESHOLD,
            });
        }
        if let Some(last_relative_correction) = self.stalled_correction {
            warnings.push(FitWarning::RefinementStalled {
                iterations: self.refinement_iterations,
                last_relative_correction,
            });
        }
        if self.streaming {
            warnings.push(FitWarning::StreamingChecksSkipped);
        }

        Ok(PolyFit {
            degree: self.degree,
            center: self.center,
            scale: self.scale,
            coeffs_hi,
            coeffs_lo,
            domain: self.domain,
            stats: FitStats {
                n_points: self.n_points,
                dof,
                rss,
                rmse,
                r_squared,
                residual_std,
                max_residual: self.max_residual,
                std_errors_scaled,
                std_errors_monomial,
                condition_number,
                refinement_iterations: self.refinement_iterations,
            },
            warnings,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn condition_number_of_a_diagonal_triangle() {
        assert!((condition_number(&[1.0, 0.0, 0.0, 0.25], 2) - 4.0).abs() < 1e-12);
    }
}
