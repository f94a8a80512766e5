//! The motor map: per-rotor electrical power from the ESC command and the supply voltage.
//!
//! Many small flight controllers log no current, but every one logs the commands it sends its
//! ESCs. A PWM ESC drives its motor with the average voltage `duty · V`,
//! `duty = (us − zero_us) / (full_us − zero_us)` clamped to `0..=1`, and the rotor's speed — so
//! its shaft power, and with the winding and ESC losses its electrical power — is close to a
//! single smooth function of that drive voltage `x = duty · V`, whatever the supply voltage.
//! [`MotorMap`] is that function, fitted by `fit::motor` from the rig's nominal and limit
//! sweeps (two supply voltages): `power_w = P(x)`, a [`PolyCurve`] over the drive voltage.
//!
//! This map is not in the paper (its eqs. 1–9 take the power from thrust); it is hoverbench's
//! own, and its accuracy is what its fit says (`fit_rmse_fraction`, the relative RMS residual
//! over both sweeps).
//!
//! Like every curve of the crate it is never extrapolated: a drive voltage outside the range
//! the sweeps covered is an error value, [`EstimateError::DriveBelowRange`] (the motor idles
//! slower than the first sweep step; at idle on the ground this is expected) or
//! [`EstimateError::DriveAboveRange`], which a caller tells apart by the variant.
//!
//! ```
//! use estimator::MotorMap;
//!
//! // P(x) = 2 + 3·t + t², t = (x − 6 V) / 4 V, measured from 2 V to 10 V of drive.
//! let map = MotorMap::new(1100.0, 2000.0, &[2.0, 3.0, 1.0], 6.0, 4.0, (2.0, 10.0), 0.01)?;
//! // 1550 µs on a 12 V pack: duty 0.5, 6 V of drive.
//! assert!((map.drive_v(1550.0, 12.0) - 6.0).abs() < 1e-12);
//! assert!((map.power_w(1550.0, 12.0)? - 2.0).abs() < 1e-12);
//! // Four motors.
//! let total = map.total_power_w(&[1550.0; 4], 12.0)?;
//! assert!((total - 8.0).abs() < 1e-12);
//! // Idle on the ground: slower than the sweeps went.
//! assert!(matches!(
//!     map.power_w(1120.0, 12.0),
//!     Err(estimator::EstimateError::DriveBelowRange { .. })
//! ));
//! # Ok::<(), estimator::EstimateError>(())
//! ```

use crate::EstimateError;
use crate::curve::{PolyCurve, require_finite, require_non_negative};

/// Tolerance on the drive-voltage range, V: drives within it of the ends count as inside.
const RANGE_SLACK_V: f64 = 1e-9;

/// Per-rotor electrical power (W) as a function of the ESC command (µs) and the supply voltage
/// (V), through the drive voltage `x = duty · V` (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorMap {
    zero_us: f64,
    full_us: f64,
    /// Power (W) over drive voltage (V): the curve's abscissa is volts here, not grams.
    curve: PolyCurve,
    fit_rmse_fraction: f64,
}

impl MotorMap {
    /// Builds a map from the ESC's zero and full command, µs, the power curve over drive voltage
    /// (scaled-basis coefficients, ascending powers of `t = (x − center_v) / scale_v`), the
    /// drive-voltage range the sweeps covered and the fit's relative RMS residual.
    ///
    /// Checks that the commands are finite with `zero_us < full_us`, that the curve is valid
    /// (as [`PolyCurve::new`]: 1 to `MAX_DEGREE + 1` finite coefficients, `scale_v > 0`,
    /// `0 ≤ min < max`) and that the RMSE is a finite fraction ≥ 0.
    pub fn new(
        zero_us: f64,
        full_us: f64,
        coefficients_scaled: &[f64],
        center_v: f64,
        scale_v: f64,
        drive_range_v: (f64, f64),
        fit_rmse_fraction: f64,
    ) -> Result<Self, EstimateError> {
        require_finite("motor map zero_us", zero_us)?;
        require_finite("motor map full_us", full_us)?;
        if full_us <= zero_us {
            return Err(EstimateError::MotorCommandRange { zero_us, full_us });
        }
        require_non_negative("motor map fit_rmse_fraction", fit_rmse_fraction)?;
        let curve = PolyCurve::new(coefficients_scaled, center_v, scale_v, drive_range_v, None)?;
        Ok(Self {
            zero_us,
            full_us,
            curve,
            fit_rmse_fraction,
        })
    }

    /// The command at which the ESC's duty starts to rise from zero, µs.
    pub fn zero_us(&self) -> f64 {
        self.zero_us
    }

    /// The command of full duty, µs (the rig's top of range).
    pub fn full_us(&self) -> f64 {
        self.full_us
    }

    /// The power curve over drive voltage: its "thrust" accessors (`center_g`, `scale_g`,
    /// `valid_range_g`) hold volts here.
    pub fn curve(&self) -> &PolyCurve {
        &self.curve
    }

    /// Polynomial degree of the power curve.
    pub fn degree(&self) -> usize {
        self.curve.degree()
    }

    /// Coefficients of the power curve in the scaled basis, ascending powers of `t`.
    pub fn coefficients_scaled(&self) -> &[f64] {
        self.curve.coefficients_scaled()
    }

    /// Centre of the drive-voltage scaling, V.
    pub fn center_v(&self) -> f64 {
        self.curve.center_g()
    }

    /// Half-width of the drive-voltage scaling, V.
    pub fn scale_v(&self) -> f64 {
        self.curve.scale_g()
    }

    /// The drive-voltage range the sweeps covered, V.
    pub fn drive_range_v(&self) -> (f64, f64) {
        crate::PowerCurve::valid_range_g(&self.curve)
    }

    /// Relative RMS residual of the fit over both sweeps (0.01 = 1 %).
    pub fn fit_rmse_fraction(&self) -> f64 {
        self.fit_rmse_fraction
    }

    /// The ESC's duty for a command, `(us − zero_us) / (full_us − zero_us)` clamped to `0..=1`
    /// (below its zero the ESC does not drive; above full it cannot drive more); NaN for a
    /// command that is not a number.
    pub fn duty(&self, us: f64) -> f64 {
        let d = (us - self.zero_us) / (self.full_us - self.zero_us);
        if d.is_nan() { d } else { d.clamp(0.0, 1.0) }
    }

    /// Drive voltage `x = duty(us) · volts`, V (not a number when either input is not).
    pub fn drive_v(&self, us: f64, volts: f64) -> f64 {
        if !volts.is_finite() {
            return f64::NAN;
        }
        self.duty(us) * volts
    }

    /// Electrical power of one rotor at ESC command `us` on a supply of `volts`, W.
    ///
    /// Errors: a command or voltage that is not finite ([`EstimateError::NonFinite`]), a voltage
    /// ≤ 0 ([`EstimateError::NotPositive`]), a drive voltage below the map's range
    /// ([`EstimateError::DriveBelowRange`]: the motor turns slower than the sweeps' first step,
    /// e.g. at idle) or above it ([`EstimateError::DriveAboveRange`]). Never panics.
    pub fn power_w(&self, us: f64, volts: f64) -> Result<f64, EstimateError> {
        require_finite("ESC command (µs)", us)?;
        crate::curve::require_positive("supply voltage (V)", volts)?;
        let x = self.drive_v(us, volts);
        let (min_v, max_v) = self.drive_range_v();
        if x < min_v - RANGE_SLACK_V {
            return Err(EstimateError::DriveBelowRange {
                drive_v: x,
                min_v,
                max_v,
            });
        }
        if x > max_v + RANGE_SLACK_V {
            return Err(EstimateError::DriveAboveRange {
                drive_v: x,
                min_v,
                max_v,
            });
        }
        Ok(self.curve.eval_unchecked(x))
    }

    /// Electrical power of several rotors on one supply, W: the sum of [`MotorMap::power_w`]
    /// over the commands `us` (the first rotor's error, when one fails). An empty slice is
    /// [`EstimateError::NoRotors`].
    pub fn total_power_w(&self, us: &[f64], volts: f64) -> Result<f64, EstimateError> {
        if us.is_empty() {
            return Err(EstimateError::NoRotors);
        }
        us.iter()
            .try_fold(0.0, |acc, &u| Ok(acc + self.power_w(u, volts)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn map() -> MotorMap {
        MotorMap::new(
            1080.0,
            2000.0,
            &[20.0, 25.0, 8.0, 1.0],
            6.0,
            5.0,
            (1.0, 11.0),
            0.01,
        )
        .unwrap()
    }

    #[test]
    fn drive_voltage_is_duty_times_supply_clamped() {
        let m = map();
        assert!((m.drive_v(1540.0, 12.0) - 6.0).abs() < 1e-12);
        assert_eq!(m.drive_v(1000.0, 12.0), 0.0);
        assert_eq!(m.drive_v(2100.0, 12.0), 12.0);
        assert!(m.drive_v(f64::NAN, 12.0).is_nan());
        assert!(m.drive_v(1500.0, f64::INFINITY).is_nan());
    }

    #[test]
    fn power_is_the_curve_at_the_drive_voltage_and_never_extrapolated() {
        let m = map();
        let x = m.drive_v(1700.0, 12.0);
        assert_eq!(
            m.power_w(1700.0, 12.0).unwrap(),
            m.curve().eval_unchecked(x)
        );
        // Below: idle turns slower than the first step.
        match m.power_w(1090.0, 12.0) {
            Err(EstimateError::DriveBelowRange { drive_v, min_v, .. }) => {
                assert!(drive_v < min_v);
            }
            other => panic!("{other:?}"),
        }
        // Above: full throttle on a fresh 4S pack.
        assert!(matches!(
            m.power_w(2000.0, 16.8),
            Err(EstimateError::DriveAboveRange { .. })
        ));
        assert!(matches!(
            m.power_w(f64::NAN, 12.0),
            Err(EstimateError::NonFinite { .. })
        ));
        assert!(matches!(
            m.power_w(1500.0, 0.0),
            Err(EstimateError::NotPositive { .. })
        ));
        // The sum over rotors, and its first error.
        let t = m.total_power_w(&[1700.0, 1600.0], 12.0).unwrap();
        let want = m.power_w(1700.0, 12.0).unwrap() + m.power_w(1600.0, 12.0).unwrap();
        assert!((t - want).abs() < 1e-12);
        assert!(matches!(
            m.total_power_w(&[1700.0, 1090.0], 12.0),
            Err(EstimateError::DriveBelowRange { .. })
        ));
        assert!(matches!(
            m.total_power_w(&[], 12.0),
            Err(EstimateError::NoRotors)
        ));
    }

    #[test]
    fn invalid_maps_are_refused() {
        let c = [1.0, 2.0];
        assert!(matches!(
            MotorMap::new(2000.0, 1000.0, &c, 5.0, 5.0, (0.0, 10.0), 0.0),
            Err(EstimateError::MotorCommandRange { .. })
        ));
        assert!(MotorMap::new(f64::NAN, 2000.0, &c, 5.0, 5.0, (0.0, 10.0), 0.0).is_err());
        assert!(MotorMap::new(1000.0, 2000.0, &c, 5.0, 0.0, (0.0, 10.0), 0.0).is_err());
        assert!(MotorMap::new(1000.0, 2000.0, &c, 5.0, 5.0, (10.0, 1.0), 0.0).is_err());
        assert!(MotorMap::new(1000.0, 2000.0, &c, 5.0, 5.0, (0.0, 10.0), -0.1).is_err());
        assert!(MotorMap::new(1000.0, 2000.0, &[], 5.0, 5.0, (0.0, 10.0), 0.0).is_err());
    }

    proptest! {
        #[test]
        fn power_never_panics_and_is_finite_or_an_error(us in proptest::num::f64::ANY, volts in proptest::num::f64::ANY) {
            if let Ok(p) = map().power_w(us, volts) {
                prop_assert!(p.is_finite());
            }
        }
    }
}
