//! Streaming least-squares polynomial fit with memory independent of N.

use crate::assemble::Solved;
use crate::dd::Dd;
use crate::error::{FitError, Input};
use crate::poly::{MAX_DEGREE, PolyFit};
use crate::qr::{DEFAULT_BLOCK_ROWS, QrAccumulator, solve_upper, split_augmented};
use crate::scale::Pow2;

/// Cheap first pass over the abscissae to fix the domain of a
/// [`StreamingPolyFit`].
///
/// Non-finite values are ignored here (the fit itself rejects them with
/// their index).
#[derive(Debug, Clone, Copy, Default)]
pub struct RangeScan {
    min: f64,
    max: f64,
    n: usize,
}

impl RangeScan {
    /// An empty scan.
    pub fn new() -> Self {
        RangeScan {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            n: 0,
        }
    }

    /// Records one abscissa.
    pub fn push(&mut self, x: f64) {
        if x.is_finite() {
            self.min = self.min.min(x);
            self.max = self.max.max(x);
            self.n += 1;
        }
    }

    /// Records a chunk of abscissae.
    pub fn push_chunk(&mut self, x: &[f64]) {
        let (lo, hi, n) = finite_min_max(x);
        self.min = self.min.min(lo);
        self.max = self.max.max(hi);
        self.n += n;
    }

    /// `(min, max)` of the finite values seen, or `None` if there were none.
    pub fn range(&self) -> Option<(f64, f64)> {
        (self.n > 0).then_some((self.min, self.max))
    }
}

/// Least-squares polynomial fit over a stream of points, keeping no samples.
///
/// # Fixed scaling
/// The scaled abscissa `t = (x − c)/s` must be known before the first point
/// arrives, so the domain `[lo, hi]` is given to [`new`](Self::new) and
/// fixes `c = (lo + hi)/2`, `s = (hi − lo)/2`. Points outside the domain are
/// rejected ([`FitError::OutsideDomain`]). When the range is not known in
/// advance, run a [`RangeScan`] over the x values first (one cheap pass);
/// passing the exact data range makes the basis identical to the one
/// [`fit_polynomial`](crate::fit_polynomial) would choose.
///
/// # Method and memory
/// Rows `[1, t, …, tᵈ, y]` are buffered in a block of a few thousand rows;
/// when it fills, faer's Householder QR factorises the stacked
/// `[R; block]` and keeps only the new `(d+2) × (d+2)` triangle `R`. The
/// last diagonal entry of `R` is the root of the residual sum of squares.
/// Memory is `O((d + block) · d)` regardless of the number of points.
///
/// # What the result contains
/// [`finish`](Self::finish) returns a [`PolyFit`] with coefficients, domain
/// (the actual min/max x seen), `n_points`, `dof`, `rss`, `rmse`,
/// `r_squared`, `residual_std`, standard errors, condition number and the
/// monotonicity / few-points / ill-conditioning warnings. Without the
/// samples it cannot refine in extended precision (the solution is the plain
/// QR one, accurate to about `ε·κ` relative), cannot count duplicate x, and
/// `max_residual` is `None`; a [`FitWarning::StreamingChecksSkipped`](crate::FitWarning::StreamingChecksSkipped)
/// says so. A second pass with [`PolyFit::into_residual_scan`] fills
/// `max_residual` in.
#[derive(Debug, Clone)]
pub struct StreamingPolyFit {
    degree: usize,
    lo: f64,
    hi: f64,
    center: f64,
    scale: f64,
    acc: QrAccumulator,
    n: usize,
    min_x: f64,
    max_x: f64,
    mean_y: f64,
    m2_y: f64,
    /// Up to `degree + 1` distinct x values (enough to prove full rank).
    distinct: Vec<f64>,
}

impl StreamingPolyFit {
    /// A streaming fit of the given degree over the fixed domain `[lo, hi]`.
    pub fn new(degree: usize, lo: f64, hi: f64) -> Result<Self, FitError> {
        Self::with_block_rows(degree, lo, hi, DEFAULT_BLOCK_ROWS)
    }

    /// As [`new`](Self::new), choosing how many rows are buffered between
    /// QR updates (memory `≈ 8 · (d + 2) · block_rows` bytes; at least 1).
    pub fn with_block_rows(
        degree: usize,
        lo: f64,
        hi: f64,
        block_rows: usize,
    ) -> Result<Self, FitError> {
        if degree > MAX_DEGREE {
            return Err(FitError::DegreeTooLarge {
                degree,
                max: MAX_DEGREE,
            });
        }
        let width = hi - lo;
        if !(lo.is_finite() && hi.is_finite() && lo < hi && width.is_finite()) {
            return Err(FitError::InvalidDomain { lo, hi });
        }
        let (center, scale) = crate::scale::rounded_center_scale(lo, hi);
        Ok(StreamingPolyFit {
            degree,
            lo,
            hi,
            center,
            scale,
            acc: QrAccumulator::new(degree + 2, block_rows),
            n: 0,
            min_x: f64::INFINITY,
            max_x: f64::NEG_INFINITY,
            mean_y: 0.0,
            m2_y: 0.0,
            distinct: Vec::with_capacity(degree + 1),
        })
    }

    /// Number of points accepted so far.
    pub fn n_points(&self) -> usize {
        self.n
    }

    /// The fixed domain `[lo, hi]`.
    pub fn domain(&self) -> (f64, f64) {
        (self.lo, self.hi)
    }

    fn check(&self, offset: usize, x: f64, y: f64) -> Result<(), FitError> {
        let index = self.n + offset;
        for (input, value) in [(Input::X, x), (Input::Y, y)] {
            if !value.is_finite() {
                return Err(FitError::NonFinite {
                    input,
                    index,
                    value,
                });
            }
        }
        if !(self.lo..=self.hi).contains(&x) {
            return Err(FitError::OutsideDomain {
                index,
                x,
                lo: self.lo,
                hi: self.hi,
            });
        }
        Ok(())
    }

    /// Adds one point. On error nothing is added.
    pub fn push(&mut self, x: f64, y: f64) -> Result<(), FitError> {
        self.push_chunk(&[x], &[y])
    }

    /// Adds a chunk of points. The chunk is validated first: on error
    /// (length mismatch, non-finite value, x outside the domain; indices
    /// count from the first point ever pushed) none of it is added.
    pub fn push_chunk(&mut self, x: &[f64], y: &[f64]) -> Result<(), FitError> {
        if x.len() != y.len() {
            return Err(FitError::LengthMismatch {
                first: Input::X,
                first_len: x.len(),
                second: Input::Y,
                second_len: y.len(),
            });
        }
        // Fast vectorisable screen, then locate the culprit only if needed.
        let ok = x.iter().zip(y).fold(true, |ok, (&xi, &yi)| {
            ok & (xi >= self.lo) & (xi <= self.hi) & yi.is_finite()
        });
        if !ok {
            for (i, (&xi, &yi)) in x.iter().zip(y).enumerate() {
                self.check(i, xi, yi)?;
            }
        }
        if x.is_empty() {
            return Ok(());
        }
        self.update_summaries(x, y);

        let p = self.degree + 1;
        let (c, s) = (self.center, self.scale);
        let mut next = 0;
        while next < x.len() {
            let m = self.acc.free_rows().min(x.len() - next);
            let (xs, ys) = (&x[next..next + m], &y[next..next + m]);
            self.acc.fill_rows(m, |cols| {
                let (basis, ycol) = cols.split_at_mut(p);
                ycol[0].copy_from_slice(ys);
                basis[0].fill(1.0);
                if p > 1 {
                    for (t, &xi) in basis[1].iter_mut().zip(xs) {
                        *t = (xi - c) / s;
                    }
                    for k in 2..p {
                        let (done, rest) = basis.split_at_mut(k);
                        for ((out, &prev), &t) in
                            rest[0].iter_mut().zip(&*done[k - 1]).zip(&*done[1])
                        {
                            *out = prev * t;
                        }
                    }
                }
            });
            next += m;
        }
        Ok(())
    }

    /// Count, x range, y mean / M2 (Chan et al. merge), distinct-x witness.
    fn update_summaries(&mut self, x: &[f64], y: &[f64]) {
        let m = x.len() as f64;
        let (lo, hi, _) = finite_min_max(x);
        self.min_x = self.min_x.min(lo);
        self.max_x = self.max_x.max(hi);
        let mean_b = lane_sum(y, |v| v) / m;
        let m2_b = lane_sum(y, |v| (v - mean_b) * (v - mean_b));
        let n_a = self.n as f64;
        let n = n_a + m;
        let delta = mean_b - self.mean_y;
        self.mean_y += delta * (m / n);
        self.m2_y += m2_b + delta * delta * (n_a * m / n);
        self.n += x.len();
        if self.distinct.len() <= self.degree {
            for &v in x {
                if !self.distinct.contains(&v) {
                    self.distinct.push(v);
                    if self.distinct.len() > self.degree {
                        break;
                    }
                }
            }
        }
    }

    /// Solves the accumulated system. See the type documentation for what
    /// the result contains.
    pub fn finish(mut self) -> Result<PolyFit, FitError> {
        if self.n == 0 {
            return Err(FitError::Empty);
        }
        if self.min_x == self.max_x {
            return Err(FitError::AllXEqual {
                n: self.n,
                value: self.min_x,
            });
        }
        if self.distinct.len() <= self.degree {
            return Err(FitError::TooFewDistinctX {
                degree: self.degree,
                distinct: self.distinct.len(),
            });
        }
        let p = self.degree + 1;
        let (r, qty, rnorm) = split_augmented(&self.acc.triangle(), p);
        let a = solve_upper(&r, p, &qty);
        let rss = rnorm * rnorm;
        Solved {
            degree: self.degree,
            center: self.center,
            scale: self.scale,
            coeffs: a.into_iter().map(Dd::from_f64).collect(),
            domain: (self.min_x, self.max_x),
            r,
            n_points: self.n,
            rss,
            raw_ss: rss,
            sst: self.m2_y,
            y_unit: Pow2::IDENTITY,
            w_unit: Pow2::IDENTITY,
            max_residual: None,
            duplicates: None,
            refinement_iterations: 0,
            stalled_correction: None,
            streaming: true,
        }
        .assemble()
    }
}

/// Number of independent accumulators in the reductions below: breaking the
/// serial dependency lets the compiler vectorise them.
const LANES: usize = 4;

/// Minimum, maximum and number of the finite values of `x`
/// (`(+∞, −∞, 0)` when there are none). Branch-free so that it vectorises.
fn finite_min_max(x: &[f64]) -> (f64, f64, usize) {
    let mut lo = [f64::INFINITY; LANES];
    let mut hi = [f64::NEG_INFINITY; LANES];
    let mut n = [0usize; LANES];
    let mut step = |k: usize, v: f64| {
        let finite = v.is_finite();
        let (vl, vh) = if finite {
            (v, v)
        } else {
            (f64::INFINITY, f64::NEG_INFINITY)
        };
        lo[k] = if vl < lo[k] { vl } else { lo[k] };
        hi[k] = if vh > hi[k] { vh } else { hi[k] };
        n[k] += usize::from(finite);
    };
    let chunks = x.chunks_exact(LANES);
    let tail = chunks.remainder();
    for c in chunks {
        for (k, &v) in c.iter().enumerate() {
            step(k, v);
        }
    }
    for &v in tail {
        step(0, v);
    }
    (
        lo.iter().copied().fold(f64::INFINITY, f64::min),
        hi.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        n.iter().sum(),
    )
}

/// `Σ f(vᵢ)` with [`LANES`] partial sums.
fn lane_sum(v: &[f64], f: impl Fn(f64) -> f64) -> f64 {
    let mut acc = [0.0; LANES];
    let chunks = v.chunks_exact(LANES);
    let tail = chunks.remainder();
    for c in chunks {
        for (a, &x) in acc.iter_mut().zip(c) {
            *a += f(x);
        }
    }
    acc.iter().sum::<f64>() + tail.iter().map(|&x| f(x)).sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reductions_match_naive_loops() {
        let x: Vec<f64> = (0..23).map(|i| ((i * 37) % 23) as f64 - 7.5).collect();
        let mut with_junk = x.clone();
        with_junk.insert(5, f64::NAN);
        with_junk.push(f64::INFINITY);
        assert_eq!(finite_min_max(&with_junk), (-7.5, 14.5, 23));
        assert_eq!(
            finite_min_max(&[f64::NAN]),
            (f64::INFINITY, f64::NEG_INFINITY, 0)
        );
        let naive: f64 = x.iter().map(|v| v * v).sum();
        assert!((lane_sum(&x, |v| v * v) - naive).abs() < 1e-12 * naive);
    }
}
