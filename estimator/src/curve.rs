//! Per-rotor thrust → electrical power curves (the paper's Fig. 3).

use crate::EstimateError;

/// Highest polynomial degree a [`PolyCurve`] can hold.
pub const MAX_DEGREE: usize = 12;

/// A per-rotor curve giving electrical power (W) for a static thrust (g).
///
/// The estimator reads `p_M` from it (eq. 4): the power one rotor draws when it lifts its share
/// of the take-off mass.
pub trait PowerCurve {
    /// Electrical power in watts one rotor draws at `thrust_g` grams of thrust.
    ///
    /// Returns [`EstimateError::ThrustOutOfRange`] outside [`PowerCurve::valid_range_g`]: the
    /// curve is a fit to measurements and is not extrapolated.
    fn power_w(&self, thrust_g: f64) -> Result<f64, EstimateError>;

    /// The thrust range, in grams per rotor, over which the curve was measured.
    fn valid_range_g(&self) -> (f64, f64);
}

/// A polynomial thrust → power curve kept in a centred and scaled basis.
///
/// `power_w(T) = Σ c_k · t^k` with `t = (T − center_g) / scale_g`, evaluated by Horner's rule.
/// This is the form `fit` produces: evaluating in the scaled basis keeps every term of order one,
/// where the physical monomial basis (W per g^k, up to g^5) would lose digits to cancellation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolyCurve {
    degree: usize,
    coefficients_scaled: [f64; MAX_DEGREE + 1],
    center_g: f64,
    scale_g: f64,
    valid_min_g: f64,
    valid_max_g: f64,
    supply_voltage_v: Option<f64>,
}

impl PolyCurve {
    /// Builds a curve from scaled-basis coefficients (ascending powers of `t`).
    ///
    /// Checks that there is at least one and at most `MAX_DEGREE + 1` coefficients, that every
    /// number is finite, that `scale_g > 0`, that the validity range is ordered and that the
    /// supply voltage, when known, is positive.
    pub fn new(
        coefficients_scaled: &[f64],
        center_g: f64,
        scale_g: f64,
        valid_range_g: (f64, f64),
        supply_voltage_v: Option<f64>,
    ) -> Result<Self, EstimateError> {
        let n = coefficients_scaled.len();
        if n == 0 || n > MAX_DEGREE + 1 {
            return Err(EstimateError::CurveDegree {
                coefficients: n,
                max_degree: MAX_DEGREE,
            });
        }
        let mut coefficients = [0.0; MAX_DEGREE + 1];
        for (i, &c) in coefficients_scaled.iter().enumerate() {
            if !c.is_finite() {
                return Err(EstimateError::NonFinite {
                    what: "curve coefficient",
                    value: c,
                });
            }
            coefficients[i] = c;
        }
        require_finite("curve center_g", center_g)?;
        require_positive("curve scale_g", scale_g)?;
        let (lo, hi) = valid_range_g;
        require_finite("curve valid_min_g", lo)?;
        require_finite("curve valid_max_g", hi)?;
        if lo < 0.0 || hi <= lo {
            return Err(EstimateError::CurveRange {
                min_g: lo,
                max_g: hi,
            });
        }
        if let Some(v) = supply_voltage_v {
            require_positive("curve supply_voltage_v", v)?;
        }
        Ok(Self {
            degree: n - 1,
            coefficients_scaled: coefficients,
            center_g,
            scale_g,
            valid_min_g: lo,
            valid_max_g: hi,
            supply_voltage_v,
        })
    }

    /// Polynomial degree.
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Coefficients in the scaled basis, ascending powers of `t`.
    pub fn coefficients_scaled(&self) -> &[f64] {
        &self.coefficients_scaled[..=self.degree]
    }

    /// Centre of the scaling, grams.
    pub fn center_g(&self) -> f64 {
        self.center_g
    }

    /// Half-width of the scaling, grams.
    pub fn scale_g(&self) -> f64 {
        self.scale_g
    }

    /// Supply voltage the curve was measured at, volts, when known.
    pub fn supply_voltage_v(&self) -> Option<f64> {
        self.supply_voltage_v
    }

    /// Evaluates the polynomial anywhere, without the validity check.
    pub fn eval_unchecked(&self, thrust_g: f64) -> f64 {
        let t = (thrust_g - self.center_g) / self.scale_g;
        self.coefficients_scaled[..=self.degree]
            .iter()
            .rev()
            .fold(0.0, |acc, &c| acc * t + c)
    }
}

impl PowerCurve for PolyCurve {
    fn power_w(&self, thrust_g: f64) -> Result<f64, EstimateError> {
        check_in_range(thrust_g, self.valid_range_g())?;
        Ok(self.eval_unchecked(thrust_g))
    }

    fn valid_range_g(&self) -> (f64, f64) {
        (self.valid_min_g, self.valid_max_g)
    }
}

/// A curve given by a closure, for exact reference curves and tests.
#[derive(Debug, Clone, Copy)]
pub struct FnCurve<F> {
    f: F,
    valid_min_g: f64,
    valid_max_g: f64,
}

impl<F: Fn(f64) -> f64> FnCurve<F> {
    /// Wraps `f` (thrust in g → power in W) valid over `valid_range_g`.
    pub fn new(f: F, valid_range_g: (f64, f64)) -> Self {
        Self {
            f,
            valid_min_g: valid_range_g.0,
            valid_max_g: valid_range_g.1,
        }
    }
}

impl<F: Fn(f64) -> f64> PowerCurve for FnCurve<F> {
    fn power_w(&self, thrust_g: f64) -> Result<f64, EstimateError> {
        check_in_range(thrust_g, self.valid_range_g())?;
        Ok((self.f)(thrust_g))
    }

    fn valid_range_g(&self) -> (f64, f64) {
        (self.valid_min_g, self.valid_max_g)
    }
}

impl<C: PowerCurve + ?Sized> PowerCurve for &C {
    fn power_w(&self, thrust_g: f64) -> Result<f64, EstimateError> {
        (**self).power_w(thrust_g)
    }

    fn valid_range_g(&self) -> (f64, f64) {
        (**self).valid_range_g()
    }
}

/// Tolerance on the validity range, grams: thrusts within it of the ends count as inside.
const RANGE_SLACK_G: f64 = 1e-9;

fn check_in_range(thrust_g: f64, (lo, hi): (f64, f64)) -> Result<(), EstimateError> {
    if !thrust_g.is_finite() || thrust_g < lo - RANGE_SLACK_G || thrust_g > hi + RANGE_SLACK_G {
        return Err(EstimateError::ThrustOutOfRange {
            thrust_g,
            min_g: lo,
            max_g: hi,
        });
    }
    Ok(())
}

pub(crate) fn require_finite(what: &'static str, value: f64) -> Result<f64, EstimateError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(EstimateError::NonFinite { what, value })
    }
}

pub(crate) fn require_positive(what: &'static str, value: f64) -> Result<f64, EstimateError> {
    require_finite(what, value)?;
    if value > 0.0 {
        Ok(value)
    } else {
        Err(EstimateError::NotPositive { what, value })
    }
}

pub(crate) fn require_non_negative(what: &'static str, value: f64) -> Result<f64, EstimateError> {
    require_finite(what, value)?;
    if value >= 0.0 {
        Ok(value)
    } else {
        Err(EstimateError::Negative { what, value })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn horner_in_scaled_basis_matches_monomial_expansion() {
        // p(t) = 1 + 2t + 3t², t = (T − 100)/50
        let c = PolyCurve::new(&[1.0, 2.0, 3.0], 100.0, 50.0, (0.0, 200.0), Some(12.5)).unwrap();
        for thrust_g in [0.0, 37.5, 100.0, 163.0, 200.0] {
            let t = (thrust_g - 100.0) / 50.0;
            let want = 1.0 + 2.0 * t + 3.0 * t * t;
            assert!((c.power_w(thrust_g).unwrap() - want).abs() < 1e-12);
        }
        assert_eq!(c.degree(), 2);
    }

    #[test]
    fn outside_the_measured_range_is_an_error_not_an_extrapolation() {
        let c = PolyCurve::new(&[1.0, 1.0], 100.0, 100.0, (0.0, 200.0), Some(12.5)).unwrap();
        let err = c.power_w(200.5).unwrap_err();
        assert!(matches!(err, EstimateError::ThrustOutOfRange { max_g, .. } if max_g == 200.0));
        assert!(c.power_w(f64::NAN).is_err());
    }

    #[test]
    fn invalid_curves_are_rejected_with_the_reason() {
        assert!(matches!(
            PolyCurve::new(&[], 0.0, 1.0, (0.0, 1.0), Some(12.0)),
            Err(EstimateError::CurveDegree { .. })
        ));
        assert!(matches!(
            PolyCurve::new(&[1.0], 0.0, 0.0, (0.0, 1.0), Some(12.0)),
            Err(EstimateError::NotPositive {
                what: "curve scale_g",
                ..
            })
        ));
        assert!(matches!(
            PolyCurve::new(&[1.0], 0.0, 1.0, (5.0, 1.0), Some(12.0)),
            Err(EstimateError::CurveRange { .. })
        ));
        assert!(matches!(
            PolyCurve::new(&[f64::INFINITY], 0.0, 1.0, (0.0, 1.0), Some(12.0)),
            Err(EstimateError::NonFinite { .. })
        ));
    }
}
