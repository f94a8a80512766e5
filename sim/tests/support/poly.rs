//! A small least-squares polynomial in `T/100`, written apart from the `fit` crate (which `sim`
//! does not depend on), shared by `tests/paper_preset.rs` and `examples/physical_paper.rs`
//! through `#[path]`.

/// Least-squares polynomial of `degree` in x = T/100 (normal equations, partial pivoting).
#[allow(clippy::needless_range_loop)]
pub fn polyfit(xs: &[f64], ys: &[f64], degree: usize) -> Vec<f64> {
    let n = degree + 1;
    let mut a = vec![vec![0.0; n + 1]; n];
    for (&x, &y) in xs.iter().zip(ys) {
        let x = x / 100.0;
        for i in 0..n {
            for j in 0..n {
                a[i][j] += x.powi((i + j) as i32);
            }
            a[i][n] += y * x.powi(i as i32);
        }
    }
    for c in 0..n {
        let p = (c..n)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .unwrap();
        a.swap(c, p);
        for r in 0..n {
            if r != c {
                let f = a[r][c] / a[c][c];
                for k in c..=n {
                    a[r][k] -= f * a[c][k];
                }
            }
        }
    }
    (0..n).map(|i| a[i][n] / a[i][i]).collect()
}

pub fn poly(c: &[f64], t_g: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, k| acc * (t_g / 100.0) + k)
}
