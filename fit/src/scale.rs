//! Exact power-of-two units for data columns: the batch and streaming fits normalise y and
//! the weights with these so that sums of squares neither overflow nor underflow.

/// Exact power-of-two scaling of a data column so that its largest
/// magnitude lies in `[0.5, 1)`. Applied in two steps so that neither
/// factor over- or underflows.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pow2 {
    exp: i32,
}

impl Pow2 {
    /// No scaling.
    pub(crate) const IDENTITY: Pow2 = Pow2 { exp: 0 };

    pub(crate) fn for_max_abs(m: f64) -> Pow2 {
        if !(m > 0.0 && m.is_finite()) {
            return Pow2::IDENTITY;
        }
        // m = f · 2^exp with f in [0.5, 1)
        let mut exp = m.log2().floor() as i32 + 1;
        let probe = Pow2 { exp }.down(m);
        if probe >= 1.0 {
            exp += 1;
        } else if probe < 0.5 {
            exp -= 1;
        }
        Pow2 { exp }
    }

    fn apply(v: f64, e: i32) -> f64 {
        let h = e / 2;
        v * 2f64.powi(h) * 2f64.powi(e - h)
    }

    /// `v · 2^-exp`.
    pub(crate) fn down(self, v: f64) -> f64 {
        Pow2::apply(v, -self.exp)
    }

    /// `v · 2^exp`.
    pub(crate) fn up(self, v: f64) -> f64 {
        Pow2::apply(v, self.exp)
    }

    /// `v · √(2^exp)`.
    pub(crate) fn up_sqrt(self, v: f64) -> f64 {
        let h = Pow2 {
            exp: self.exp.div_euclid(2),
        };
        let v = h.up(v);
        if self.exp.rem_euclid(2) == 1 {
            v * std::f64::consts::SQRT_2
        } else {
            v
        }
    }
}

/// `k · 10^exp` as the `f64` nearest the decimal number, so that it prints as `k` digits
/// (`1351e-1` is stored as `135.1`, not as `1351 × 0.1 = 135.10000000000002`).
fn decimal(k: f64, exp: i32) -> f64 {
    format!("{k:.0}e{exp}")
        .parse()
        .unwrap_or(k * 10f64.powi(exp))
}

/// The centre and scale of the abscissa `t = (x − center)/scale` for data spanning `[lo, hi]`
/// (`lo < hi`, both finite): round numbers — the midpoint rounded to three significant digits
/// of the half-width, and the half-width rounded up so that every `x` in `[lo, hi]` still has
/// `|t| ≤ 1` — chosen before the fit, so that the parameter file stores short, exact values
/// (`center = 135.0`, not `135.14135000000002`) and the curve needs no re-expression.
pub(crate) fn rounded_center_scale(lo: f64, hi: f64) -> (f64, f64) {
    let mid = 0.5 * lo + 0.5 * hi;
    let half = 0.5 * hi - 0.5 * lo;
    if !(half > 0.0 && half.is_finite() && mid.is_finite()) {
        return (mid, if half > 0.0 { half } else { hi - lo });
    }
    // three significant digits of the half-width
    let exp = half.log10().floor() as i32 - 2;
    let q = 10f64.powi(exp);
    if !(q > 0.0 && q.is_finite()) {
        return (mid, half);
    }
    let center = decimal((mid / q).round(), exp);
    // the data's furthest distance from the centre, as the fit will compute it
    // (less the rounding of the subtraction: 1.2 − 1.15 is 0.050000000000000044, and |t| a
    // few ulps above 1 is harmless)
    let need = (hi - center).abs().max((lo - center).abs()) * (1.0 - 1e-12);
    let mut scale = decimal((need / q).ceil(), exp);
    if scale < need {
        scale = need;
    }
    if !(center.is_finite() && scale.is_finite() && scale > 0.0) {
        return (mid, half);
    }
    (center, scale)
}

#[cfg(test)]
mod tests {
    use super::rounded_center_scale;

    #[test]
    fn centre_and_scale_are_short_round_numbers_covering_the_data() {
        // the thrust range of an imported stand log
        let (c, s) = rounded_center_scale(10.2827, 260.0);
        assert_eq!((c.to_string(), s.to_string()), ("135".into(), "125".into()));
        let (c, s) = rounded_center_scale(0.0, 1.0);
        assert_eq!((c, s), (0.5, 0.5));
        let (c, s) = rounded_center_scale(1.1, 1.2);
        assert_eq!(
            (c.to_string(), s.to_string()),
            ("1.15".into(), "0.05".into())
        );
        for (lo, hi) in [
            (10.2827, 260.0),
            (-3.7, 1e6 + 0.3),
            (1e-300, 3e-300),
            (-1e300, 1e300),
            (1234567.891, 1234567.9),
            (0.1, 0.3),
        ] {
            let (c, s) = rounded_center_scale(lo, hi);
            assert!(
                s > 0.0 && s.is_finite() && c.is_finite(),
                "{lo}..{hi}: {c} {s}"
            );
            let covered = |x: f64| (x - c).abs() <= s * (1.0 + 1e-11);
            assert!(covered(lo) && covered(hi), "{lo}..{hi}: {c} {s}");
            // at most 1.5 % wider than the data's half-width
            assert!(
                s <= 1.016 * (0.5 * hi - 0.5 * lo) + 1e-300,
                "{lo}..{hi}: {s}"
            );
            // stored text is short
            let short = |v: f64| format!("{v:e}").len() <= 16;
            assert!(short(c) && short(s), "{c:e} {s:e}");
        }
    }
}
