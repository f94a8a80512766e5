//! Putting a signal logged at its own times onto the battery's time base.

/// Linear interpolation of `(t, v)` at each of `at`; held constant beyond the ends. `t` need
/// not be sorted (it is sorted here); non-finite pairs are dropped. `None` when no finite
/// pair is left.
pub(crate) fn linear(t: &[f64], v: &[f64], at: &[f64]) -> Option<Vec<f64>> {
    let mut pairs: Vec<(f64, f64)> = t
        .iter()
        .zip(v)
        .map(|(&a, &b)| (a, b))
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let &first = pairs.first()?;
    let mut out = Vec::with_capacity(at.len());
    let mut k = 0usize;
    for &x in at {
        // Advance to the last pair at or before x (at is usually sorted; restart when not).
        if k > 0 && pairs[k].0 > x {
            k = 0;
        }
        while k + 1 < pairs.len() && pairs[k + 1].0 <= x {
            k += 1;
        }
        let (t0, v0) = pairs[k];
        let value = if x <= first.0 {
            first.1
        } else if let Some(&(t1, v1)) = pairs.get(k + 1) {
            if t1 > t0 {
                v0 + (v1 - v0) * (x - t0) / (t1 - t0)
            } else {
                v0
            }
        } else {
            v0
        };
        out.push(value);
    }
    Some(out)
}

/// The last value of `(t, v)` at or before each of `at` (the first value before it begins).
pub(crate) fn hold(t: &[f64], v: &[bool], at: &[f64]) -> Vec<bool> {
    let mut pairs: Vec<(f64, bool)> = t
        .iter()
        .zip(v)
        .map(|(&a, &b)| (a, b))
        .filter(|(a, _)| a.is_finite())
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let Some(&first) = pairs.first() else {
        return vec![false; at.len()];
    };
    let mut out = Vec::with_capacity(at.len());
    let mut k = 0usize;
    for &x in at {
        if k > 0 && pairs[k].0 > x {
            k = 0;
        }
        while k + 1 < pairs.len() && pairs[k + 1].0 <= x {
            k += 1;
        }
        out.push(if x < first.0 { first.1 } else { pairs[k].1 });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_and_holds() {
        let v = linear(&[1.0, 0.0, 2.0], &[10.0, 0.0, 20.0], &[-1.0, 0.5, 1.5, 3.0]);
        assert_eq!(v.as_deref(), Some(&[0.0, 5.0, 15.0, 20.0][..]));
        let h = hold(&[0.0, 1.0], &[true, false], &[-1.0, 0.5, 1.0, 2.0]);
        assert_eq!(h, [true, true, false, false]);
        assert_eq!(linear(&[], &[], &[1.0]), None);
        assert_eq!(
            linear(&[0.0, 1.0], &[f64::NAN, f64::INFINITY], &[1.0]),
            None
        );
    }
}
