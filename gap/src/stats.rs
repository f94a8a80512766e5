//! The small numerical helpers of the diagnosis, in one place: means, correlation, a
//! golden-section search, a dense symmetric solve and isotonic (monotone) regression.

/// Arithmetic mean; `None` for an empty slice.
pub fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Root mean square; `None` for an empty slice.
pub fn rms(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt())
}

/// Median; `None` for an empty slice.
pub fn median(v: &[f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    Some(if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    })
}

/// Pearson correlation of paired samples; `None` with fewer than three pairs or when either
/// variable does not vary (a covariate that is the same for every flight says nothing).
pub fn pearson(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len();
    if n < 3 || y.len() != n {
        return None;
    }
    let (mx, my) = (mean(x)?, mean(y)?);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    let syy: f64 = y.iter().map(|b| (b - my).powi(2)).sum();
    let varies = sxx > 1e-18 * (mx * mx).max(1e-300) * n as f64;
    (varies && syy > 0.0).then(|| sxy / (sxx * syy).sqrt())
}

/// Golden-section search for the minimum of `f` on `[a, b]`: the best of the last two interior
/// points after `iterations` steps, with its value.
pub fn golden_min(f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64, iterations: usize) -> (f64, f64) {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..iterations {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    if fc < fd { (c, fc) } else { (d, fd) }
}

/// Solves the `n × n` system `a·x = b` (row-major `a`) by Gaussian elimination with partial
/// pivoting. `None` when the matrix is singular to working precision.
pub fn solve(mut a: Vec<f64>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    if a.len() != n * n {
        return None;
    }
    let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-300);
    for col in 0..n {
        let piv =
            (col..n).max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))?;
        if a[piv * n + col].abs() <= 1e-14 * scale {
            return None;
        }
        if piv != col {
            for k in 0..n {
                a.swap(piv * n + k, col * n + k);
            }
            b.swap(piv, col);
        }
        for row in col + 1..n {
            let f = a[row * n + col] / a[col * n + col];
            if f != 0.0 {
                for k in col..n {
                    a[row * n + k] -= f * a[col * n + k];
                }
                b[row] -= f * b[col];
            }
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|k| a[row * n + k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row * n + row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Weighted isotonic regression (pool adjacent violators): the non-decreasing sequence closest
/// to `y` in weighted least squares. Weights must be positive.
pub fn isotonic(y: &[f64], w: &[f64]) -> Vec<f64> {
    // Blocks of (weighted mean, weight, length).
    let mut blocks: Vec<(f64, f64, usize)> = Vec::with_capacity(y.len());
    for (&v, &wt) in y.iter().zip(w) {
        blocks.push((v, wt.max(1e-12), 1));
        while blocks.len() > 1 {
            let k = blocks.len();
            if blocks[k - 2].0 <= blocks[k - 1].0 {
                break;
            }
            let (m2, w2, n2) = blocks[k - 1];
            let (m1, w1, n1) = blocks[k - 2];
            blocks.truncate(k - 2);
            blocks.push(((m1 * w1 + m2 * w2) / (w1 + w2), w1 + w2, n1 + n2));
        }
    }
    blocks
        .into_iter()
        .flat_map(|(m, _, n)| std::iter::repeat_n(m, n))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn golden_section_finds_a_parabola_minimum() {
        let (x, v) = golden_min(&|x| (x - 0.3).powi(2) + 1.0, -2.0, 5.0, 60);
        assert!((x - 0.3).abs() < 1e-6 && (v - 1.0).abs() < 1e-9);
    }

    #[test]
    fn solve_matches_a_known_system() {
        let x = solve(vec![2.0, 1.0, 1.0, 3.0], vec![3.0, 5.0]).unwrap();
        assert!((x[0] - 0.8).abs() < 1e-12 && (x[1] - 1.4).abs() < 1e-12);
        assert!(solve(vec![1.0, 2.0, 2.0, 4.0], vec![1.0, 2.0]).is_none());
    }

    #[test]
    fn statistics_of_small_samples() {
        assert_eq!(mean(&[]), None);
        assert_eq!(median(&[3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), Some(2.5));
        assert!((rms(&[3.0, 4.0]).unwrap() - 12.5f64.sqrt()).abs() < 1e-12);
        assert!((pearson(&[1.0, 2.0, 3.0], &[2.0, 4.0, 6.0]).unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(pearson(&[1.0, 1.0, 1.0], &[2.0, 4.0, 6.0]), None);
    }

    proptest! {
        #[test]
        fn isotonic_is_monotone_and_keeps_the_weighted_mean(
            y in proptest::collection::vec(-10.0f64..10.0, 1..40),
        ) {
            let w: Vec<f64> = (0..y.len()).map(|i| 1.0 + (i % 3) as f64).collect();
            let z = isotonic(&y, &w);
            prop_assert_eq!(z.len(), y.len());
            prop_assert!(z.windows(2).all(|p| p[0] <= p[1] + 1e-12));
            let a: f64 = y.iter().zip(&w).map(|(a, b)| a * b).sum();
            let b: f64 = z.iter().zip(&w).map(|(a, b)| a * b).sum();
            prop_assert!((a - b).abs() < 1e-9 * (1.0 + a.abs()));
        }
    }
}
