//! A small robust Levenberg–Marquardt solver: box bounds by projection, a Huber loss by
//! iteratively reweighted least squares, Marquardt's diagonal scaling, a forward-difference
//! Jacobian, and parameter standard errors from the Jacobian at the solution.

use nalgebra::{DMatrix, DVector};

/// How the solver runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmOptions {
    /// Residuals larger than this (in their own units, normally noise-normalised) count
    /// linearly, not quadratically (Huber). `f64::INFINITY` is plain least squares.
    pub huber_delta: f64,
    /// Most iterations.
    pub max_iterations: usize,
    /// Stop when the relative cost decrease of an accepted step is below this.
    pub tolerance: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        Self {
            huber_delta: 3.0,
            max_iterations: 200,
            tolerance: 1e-10,
        }
    }
}

/// What the solver found.
#[derive(Debug, Clone, PartialEq)]
pub struct LmSolution {
    /// Parameters at the solution.
    pub x: Vec<f64>,
    /// Standard errors (from `(JᵀWJ)⁻¹ · s²`, with `s²` the robust cost per degree of freedom,
    /// at least 1). Infinite for a parameter the data cannot determine; 0 for one held at a
    /// bound.
    pub std_errors: Vec<f64>,
    /// Robust cost `Σ ρ(r)` at the solution (ρ(r) = r²/2 inside the Huber band).
    pub cost: f64,
    /// Number of residuals.
    pub residuals: usize,
    /// Iterations taken.
    pub iterations: usize,
    /// Whether the solver stopped on its tolerance (not on the iteration limit).
    pub converged: bool,
}

fn huber(r: f64, delta: f64) -> (f64, f64) {
    // (cost, IRLS weight)
    let a = r.abs();
    if a <= delta {
        (0.5 * r * r, 1.0)
    } else {
        (delta * (a - 0.5 * delta), delta / a)
    }
}

fn robust_cost(r: &[f64], delta: f64) -> f64 {
    r.iter().map(|&v| huber(v, delta).0).sum()
}

fn project(x: &mut [f64], lower: &[f64], upper: &[f64]) {
    for ((v, lo), hi) in x.iter_mut().zip(lower).zip(upper) {
        *v = v.clamp(*lo, *hi);
    }
}

fn jacobian(
    f: &dyn Fn(&[f64], &mut Vec<f64>),
    x: &[f64],
    r0: &[f64],
    lower: &[f64],
    upper: &[f64],
) -> DMatrix<f64> {
    let n = r0.len();
    let m = x.len();
    let mut j = DMatrix::zeros(n, m);
    let mut xp = x.to_vec();
    let mut r = Vec::with_capacity(n);
    for k in 0..m {
        let h = 1e-6 * x[k].abs().max(1e-3);
        // Step away from the nearer bound so the probe stays feasible.
        let step = if x[k] + h > upper[k] { -h } else { h };
        xp[k] = x[k] + step;
        r.clear();
        f(&xp, &mut r);
        for i in 0..n {
            j[(i, k)] = (r[i] - r0[i]) / step;
        }
        xp[k] = x[k];
        let _ = lower;
    }
    j
}

/// Minimises `Σ ρ(rᵢ(x))` over `lower ≤ x ≤ upper`. `f` writes the residuals for `x` into its
/// vector (cleared by the caller); their number must not depend on `x`.
pub fn solve(
    f: &dyn Fn(&[f64], &mut Vec<f64>),
    x0: &[f64],
    lower: &[f64],
    upper: &[f64],
    options: &LmOptions,
) -> LmSolution {
    let m = x0.len();
    let mut x = x0.to_vec();
    project(&mut x, lower, upper);
    let mut r = Vec::new();
    f(&x, &mut r);
    let n = r.len();
    let delta = options.huber_delta;
    let mut cost = robust_cost(&r, delta);
    let mut lambda: f64 = 1e-3;
    let mut iterations = 0;
    let mut converged = false;
    let mut trial_r = Vec::with_capacity(n);
    while iterations < options.max_iterations {
        iterations += 1;
        let j = jacobian(f, &x, &r, lower, upper);
        let w: Vec<f64> = r.iter().map(|&v| huber(v, delta).1).collect();
        let mut jtj = DMatrix::<f64>::zeros(m, m);
        let mut g = DVector::<f64>::zeros(m);
        // JᵀWJ and JᵀWr column by column (J is column-major): every sum runs over the
        // residuals in order, as a row-by-row accumulation would, on contiguous memory.
        let js = j.as_slice();
        let mut wa = vec![0.0; n];
        for a in 0..m {
            let ca = &js[a * n..(a + 1) * n];
            for ((v, c), wi) in wa.iter_mut().zip(ca).zip(&w) {
                *v = c * wi;
            }
            g[a] = wa.iter().zip(&r).fold(0.0, |s, (v, ri)| s + v * ri);
            for b in a..m {
                let cb = &js[b * n..(b + 1) * n];
                jtj[(a, b)] = wa.iter().zip(cb).fold(0.0, |s, (v, c)| s + v * c);
            }
        }
        for a in 0..m {
            for b in 0..a {
                jtj[(a, b)] = jtj[(b, a)];
            }
        }
        let mut accepted = false;
        for _ in 0..30 {
            let mut a = jtj.clone();
            for k in 0..m {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let mut xt: Vec<f64> = x.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
            project(&mut xt, lower, upper);
            trial_r.clear();
            f(&xt, &mut trial_r);
            let c = robust_cost(&trial_r, delta);
            if c.is_finite() && c < cost {
                let rel = (cost - c) / cost.max(1e-300);
                x = xt;
                std::mem::swap(&mut r, &mut trial_r);
                cost = c;
                lambda = (lambda / 3.0).max(1e-12);
                accepted = true;
                if rel < options.tolerance {
                    converged = true;
                }
                break;
            }
            lambda *= 4.0;
            if lambda > 1e12 {
                break;
            }
        }
        if !accepted {
            converged = true;
            break;
        }
        if converged {
            break;
        }
    }
    let std_errors = std_errors(f, &x, &r, lower, upper, delta, cost);
    LmSolution {
        x,
        std_errors,
        cost,
        residuals: n,
        iterations,
        converged,
    }
}

fn std_errors(
    f: &dyn Fn(&[f64], &mut Vec<f64>),
    x: &[f64],
    r: &[f64],
    lower: &[f64],
    upper: &[f64],
    delta: f64,
    cost: f64,
) -> Vec<f64> {
    let m = x.len();
    let n = r.len();
    let at_bound: Vec<bool> = (0..m)
        .map(|k| {
            let span = (upper[k] - lower[k]).abs().max(1e-300);
            (x[k] - lower[k]).abs() < 1e-9 * span || (upper[k] - x[k]).abs() < 1e-9 * span
        })
        .collect();
    let free: Vec<usize> = (0..m).filter(|&k| !at_bound[k]).collect();
    let mut out = vec![0.0; m];
    if free.is_empty() {
        return out;
    }
    let j = jacobian(f, x, r, lower, upper);
    let w: Vec<f64> = r.iter().map(|&v| huber(v, delta).1).collect();
    let q = free.len();
    let mut jtj = DMatrix::<f64>::zeros(q, q);
    for i in 0..n {
        for (a, &ka) in free.iter().enumerate() {
            for (b, &kb) in free.iter().enumerate() {
                jtj[(a, b)] += w[i] * j[(i, ka)] * j[(i, kb)];
            }
        }
    }
    // Robust residual scale (MAD), never below the noise the residuals were normalised by.
    let _ = cost;
    let mut abs: Vec<f64> = r.iter().map(|v| v.abs()).collect();
    abs.sort_by(f64::total_cmp);
    let mad = if n > 0 { 1.4826 * abs[n / 2] } else { 1.0 };
    let s2 = (mad * mad * n as f64 / (n as f64 - q as f64).max(1.0)).max(1.0);
    match jtj.clone().try_inverse() {
        Some(inv) => {
            for (a, &k) in free.iter().enumerate() {
                let v = inv[(a, a)] * s2;
                out[k] = if v.is_finite() && v >= 0.0 {
                    v.sqrt()
                } else {
                    f64::INFINITY
                };
            }
        }
        None => {
            for &k in &free {
                out[k] = f64::INFINITY;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_an_exponential_and_its_uncertainty() {
        // y = 2 exp(-0.5 t) with a gross outlier that the Huber loss must shrug off.
        let t: Vec<f64> = (0..40).map(|i| i as f64 * 0.2).collect();
        let mut y: Vec<f64> = t.iter().map(|t| 2.0 * (-0.5 * t).exp()).collect();
        for (i, v) in y.iter_mut().enumerate() {
            *v += 0.001 * ((i * 7919 % 13) as f64 - 6.0);
        }
        y[10] += 5.0;
        let f = |x: &[f64], out: &mut Vec<f64>| {
            for (t, y) in t.iter().zip(&y) {
                out.push((x[0] * (-x[1] * t).exp() - y) / 0.004);
            }
        };
        let s = solve(
            &f,
            &[1.0, 1.0],
            &[0.0, 0.0],
            &[10.0, 10.0],
            &LmOptions::default(),
        );
        assert!((s.x[0] - 2.0).abs() < 0.01, "{:?}", s.x);
        assert!((s.x[1] - 0.5).abs() < 0.01, "{:?}", s.x);
        assert!(s.std_errors.iter().all(|e| e.is_finite() && *e > 0.0));
        assert!(s.std_errors[0] < 0.01);
    }

    #[test]
    fn respects_bounds() {
        let f = |x: &[f64], out: &mut Vec<f64>| out.push(x[0] - 5.0);
        let s = solve(&f, &[0.0], &[-1.0], &[1.0], &LmOptions::default());
        assert!((s.x[0] - 1.0).abs() < 1e-12);
        assert_eq!(s.std_errors[0], 0.0);
    }
}
