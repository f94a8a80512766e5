//! The motor map: per-rotor electrical power against the ESC's drive voltage, fitted from
//! sweeps at two (or more) supply voltages (see `estimator::motor`; not in the paper).
//!
//! A PWM ESC gives its motor `x = duty · V` on average, `duty = (us − zero_us) / (full_us −
//! zero_us)`; the power is then close to one function `P(x)` whatever the supply voltage `V`.
//! [`fit_motor_map`] fits `P` as a polynomial in `x` by the crate's QR least squares, weighted
//! by `1/P²` so that it minimises the *relative* residuals (the low steps, a few per cent of the
//! top's power, keep their say), over all sweeps pooled; `full_us` is the rig's top of range and
//! `zero_us` — where the ESC starts to drive, some deadband above the rig's lowest command — is
//! chosen by a bounded 1-D search minimising the pooled relative RMS residual: a scan at 1 µs,
//! then a golden-section search around the best scan point.
//!
//! Steps whose thrust is below [`MIN_THRUST_FRACTION`] of the highest are left out: a rotor that
//! barely turns is dominated by the ESC's start-up and bearing friction, not by its drive.

use crate::{FitError, PolyFit, fit_polynomial_weighted};

/// Steps lighter than this fraction of the sweeps' highest thrust are not fitted (0.02: 5 g
/// of a 260 g rotor).
pub const MIN_THRUST_FRACTION: f64 = 0.02;
/// Degree of the power curve over drive voltage. On the simulated session the pooled relative
/// RMSE is 7.5 % at degree 3, 2.4 % at 4 and 0.3 % at 5; on the real 3S pair (RCbenchmark
/// 2020-06-16 22:03/22:05) 1.0–1.2 % at degrees 3–5: the fifth degree of the rig curve.
pub const DEFAULT_MOTOR_DEGREE: usize = 5;

/// One sweep's steps for the motor map.
#[derive(Debug, Clone, PartialEq)]
pub struct MotorPoints {
    /// ESC command of each step, µs.
    pub throttle_us: Vec<f64>,
    /// Supply voltage at each step, V.
    pub voltage_v: Vec<f64>,
    /// Electrical power of each step, W.
    pub power_w: Vec<f64>,
    /// Thrust of each step, g (to leave out the steps where the rotor barely turns).
    pub thrust_g: Vec<f64>,
    /// The sweep's supply voltage, V (its label).
    pub supply_voltage_v: f64,
    /// The file.
    pub source_name: String,
    /// The rig's command range the log states (lowest, full), µs, when it does.
    pub command_range_us: Option<(f64, f64)>,
}

/// How [`fit_motor_map`] fits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorMapOptions {
    /// Degree of the power curve over drive voltage.
    pub degree: usize,
    /// Command of full duty, µs (the rig's top of range).
    pub full_us: f64,
    /// The rig's lowest command, µs: the search for `zero_us` starts a quarter of the range
    /// below it.
    pub min_us: f64,
    /// A known ESC zero, µs, instead of the search (then one sweep is enough: a map fitted at
    /// one supply voltage, to be checked at another).
    pub zero_us: Option<f64>,
}

impl MotorMapOptions {
    /// Degree [`DEFAULT_MOTOR_DEGREE`] over the rig's command range `min_us..full_us`.
    pub fn new(min_us: f64, full_us: f64) -> Self {
        Self {
            degree: DEFAULT_MOTOR_DEGREE,
            full_us,
            min_us,
            zero_us: None,
        }
    }
}

/// How the map fits one sweep.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SweepResidual {
    /// The sweep's file.
    pub source_name: String,
    /// Its supply voltage, V.
    pub supply_voltage_v: f64,
    /// Steps fitted.
    pub n_points: usize,
    /// Relative RMS residual on them.
    pub rmse_fraction: f64,
}

/// A fitted motor map.
#[derive(Debug, Clone, PartialEq)]
pub struct MotorMapFit {
    /// The map, as the estimator evaluates it.
    pub map: estimator::MotorMap,
    /// The polynomial over drive voltage.
    pub fit: PolyFit,
    /// Per sweep, in the order given.
    pub per_sweep: Vec<SweepResidual>,
    /// The search range of `zero_us`, µs.
    pub zero_us_bounds: (f64, f64),
}

/// Fitted steps pooled: command, voltage, power and the sweep each came from.
struct Pooled {
    us: Vec<f64>,
    volts: Vec<f64>,
    power: Vec<f64>,
    sweep: Vec<usize>,
}

fn invalid(name: &'static str, value: f64, reason: &'static str) -> FitError {
    FitError::InvalidOption {
        name,
        value,
        reason,
    }
}

fn pool(sweeps: &[MotorPoints]) -> Result<Pooled, FitError> {
    let max_thrust = sweeps
        .iter()
        .flat_map(|s| s.thrust_g.iter().copied())
        .filter(|t| t.is_finite())
        .fold(0.0, f64::max);
    let mut p = Pooled {
        us: Vec::new(),
        volts: Vec::new(),
        power: Vec::new(),
        sweep: Vec::new(),
    };
    for (k, s) in sweeps.iter().enumerate() {
        let n = s.throttle_us.len();
        for (second, len) in [
            (crate::Input::Voltage, s.voltage_v.len()),
            (crate::Input::Power, s.power_w.len()),
            (crate::Input::Thrust, s.thrust_g.len()),
        ] {
            if len != n {
                return Err(FitError::LengthMismatch {
                    first: crate::Input::Throttle,
                    first_len: n,
                    second,
                    second_len: len,
                });
            }
        }
        for i in 0..n {
            let (u, v, w, t) = (
                s.throttle_us[i],
                s.voltage_v[i],
                s.power_w[i],
                s.thrust_g[i],
            );
            let usable = u.is_finite() && v.is_finite() && v > 0.0 && w.is_finite() && w > 0.0;
            if usable && t >= MIN_THRUST_FRACTION * max_thrust {
                p.us.push(u);
                p.volts.push(v);
                p.power.push(w);
                p.sweep.push(k);
            }
        }
    }
    Ok(p)
}

/// The weighted fit at one `zero_us` and its pooled relative RMS residual.
fn fit_at(
    p: &Pooled,
    zero_us: f64,
    full_us: f64,
    degree: usize,
) -> Result<(PolyFit, f64), FitError> {
    let x: Vec<f64> =
        p.us.iter()
            .zip(&p.volts)
            .map(|(u, v)| (u - zero_us) / (full_us - zero_us) * v)
            .collect();
    let w: Vec<f64> = p.power.iter().map(|y| 1.0 / (y * y)).collect();
    let f = fit_polynomial_weighted(&x, &p.power, &w, degree)?;
    let ss: f64 = x
        .iter()
        .zip(&p.power)
        .map(|(x, y)| ((f.eval(*x) - y) / y).powi(2))
        .sum();
    Ok((f, (ss / x.len() as f64).sqrt()))
}

/// Fits the motor map to sweeps at different supply voltages (see the [module docs](self)).
///
/// Errors: fewer than two sweeps, options that make no sense, too few usable steps for the
/// degree, or a least-squares failure ([`FitError`]); never panics.
pub fn fit_motor_map(
    sweeps: &[MotorPoints],
    opts: &MotorMapOptions,
) -> Result<MotorMapFit, FitError> {
    if sweeps.len() < 2 && opts.zero_us.is_none() {
        return Err(FitError::TooFewPoints {
            what: "a motor map (sweeps at different supply voltages)",
            needed: 2,
            got: sweeps.len(),
        });
    }
    if !(opts.full_us.is_finite() && opts.min_us.is_finite() && opts.min_us < opts.full_us) {
        return Err(invalid(
            "full_us",
            opts.full_us,
            "the rig's command range must be finite with min_us < full_us",
        ));
    }
    let p = pool(sweeps)?;
    let needed = 2 * (opts.degree + 1);
    if p.us.len() < needed {
        return Err(FitError::TooFewPoints {
            what: "a motor map of this degree (steps with power and thrust)",
            needed,
            got: p.us.len(),
        });
    }
    let first_us = p.us.iter().copied().fold(f64::INFINITY, f64::min);
    let lo = opts.min_us - 0.25 * (opts.full_us - opts.min_us);
    // Every fitted step must have a positive duty: the ESC starts below the first one.
    let hi = first_us - 1.0;
    if hi.is_nan() || hi <= lo {
        return Err(invalid(
            "min_us",
            first_us,
            "the lowest fitted command leaves no room for the ESC's zero above the search's lower end",
        ));
    }
    if let Some(z) = opts.zero_us {
        if !(z.is_finite() && z < first_us) {
            return Err(invalid(
                "zero_us",
                z,
                "a given ESC zero must be finite and below the lowest fitted command",
            ));
        }
        return finish(sweeps, &p, z, opts, (z, z));
    }
    let objective = |z: f64| fit_at(&p, z, opts.full_us, opts.degree).map(|(_, r)| r);
    // Scan at 1 µs, then golden-section around the best scan point.
    let steps = ((hi - lo).floor() as usize).max(1);
    let mut best = (f64::INFINITY, lo);
    for i in 0..=steps {
        let z = (lo + i as f64).min(hi);
        if let Ok(r) = objective(z) {
            if r < best.0 {
                best = (r, z);
            }
        }
    }
    if !best.0.is_finite() {
        // Every candidate failed: say why at the scan's best-placed point.
        objective(hi)?;
    }
    let (mut a, mut b) = ((best.1 - 1.0).max(lo), (best.1 + 1.0).min(hi));
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (
        objective(c).unwrap_or(f64::INFINITY),
        objective(d).unwrap_or(f64::INFINITY),
    );
    while b - a > 1e-3 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = objective(c).unwrap_or(f64::INFINITY);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = objective(d).unwrap_or(f64::INFINITY);
        }
    }
    let golden = 0.5 * (a + b);
    let zero_us = match objective(golden) {
        Ok(r) if r < best.0 => golden,
        _ => best.1,
    };
    finish(sweeps, &p, zero_us, opts, (lo, hi))
}

/// The map at `zero_us` and its residuals per sweep.
fn finish(
    sweeps: &[MotorPoints],
    p: &Pooled,
    zero_us: f64,
    opts: &MotorMapOptions,
    (lo, hi): (f64, f64),
) -> Result<MotorMapFit, FitError> {
    let (fit, rmse) = fit_at(p, zero_us, opts.full_us, opts.degree)?;
    let (x_lo, x_hi) = fit.domain();
    let map = estimator::MotorMap::new(
        zero_us,
        opts.full_us,
        fit.coeffs_scaled(),
        fit.center(),
        fit.scale(),
        (x_lo.max(0.0), x_hi),
        rmse,
    )
    .map_err(|_| FitError::NumericalFailure {
        context: "the motor map's coefficients or range are not usable",
    })?;
    let per_sweep = sweeps
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let (mut ss, mut n) = (0.0, 0usize);
            for i in (0..p.us.len()).filter(|&i| p.sweep[i] == k) {
                let x = map.drive_v(p.us[i], p.volts[i]);
                ss += ((fit.eval(x) - p.power[i]) / p.power[i]).powi(2);
                n += 1;
            }
            SweepResidual {
                source_name: s.source_name.clone(),
                supply_voltage_v: s.supply_voltage_v,
                n_points: n,
                rmse_fraction: if n > 0 { (ss / n as f64).sqrt() } else { 0.0 },
            }
        })
        .collect();
    Ok(MotorMapFit {
        map,
        fit,
        per_sweep,
        zero_us_bounds: (lo, hi),
    })
}
