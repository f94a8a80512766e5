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
