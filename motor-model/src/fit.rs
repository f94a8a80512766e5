//! Fitting the model to measured sweeps: noise-normalised residuals, weak physical priors that
//! keep unobservable combinations (e.g. Kv without a speed sensor) from drifting, bounds per
//! parameter, and a Huber-robust Levenberg–Marquardt solve with standard errors.

use serde::Serialize;

use crate::lm::{self, LmOptions};
use crate::{Param, Params, Quantity, Sweep};

/// Measurement noise floors: the σ a residual is divided by is
/// `√((relative·|measured|)² + (absolute·max|measured|)²)` per quantity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NoiseFloors {
    /// Power and current: relative, and absolute as a share of the largest value.
    pub power: (f64, f64),
    /// Voltage.
    pub voltage: (f64, f64),
    /// Speed.
    pub speed: (f64, f64),
    /// Torque.
    pub torque: (f64, f64),
}

impl Default for NoiseFloors {
    fn default() -> Self {
        Self {
            power: (0.01, 0.01),
            voltage: (0.002, 0.002),
            speed: (0.005, 0.005),
            torque: (0.02, 0.02),
        }
    }
}

impl NoiseFloors {
    fn of(&self, q: Quantity) -> (f64, f64) {
        match q {
            Quantity::PowerW | Quantity::CurrentA => self.power,
            Quantity::VoltageV => self.voltage,
            Quantity::SpeedRpm => self.speed,
            Quantity::TorqueNm => self.torque,
        }
    }
}

/// The scale of a data set, for bounds and initial guesses.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Scale {
    /// Largest thrust reading, g.
    pub max_thrust_g: f64,
    /// Largest measured value of every quantity (0 when not logged), in [`Quantity::ALL`] order.
    pub max_measured: [f64; 5],
    /// Median time between consecutive steps, s (1 when the logs have no time: a step).
    pub step_s: f64,
}

impl Scale {
    /// The scale of some sweeps.
    pub fn of(sweeps: &[&Sweep]) -> Self {
        let mut max_thrust_g: f64 = 0.0;
        let mut max_measured = [0.0f64; 5];
        let mut dts: Vec<f64> = sweeps
            .iter()
            .flat_map(|s| s.steps.windows(2).map(|w| w[1].time_s - w[0].time_s))
            .filter(|d| *d > 0.0 && d.is_finite())
            .collect();
        dts.sort_by(f64::total_cmp);
        let step_s = dts.get(dts.len() / 2).copied().unwrap_or(1.0);
        for s in sweeps {
            for o in &s.steps {
                max_thrust_g = max_thrust_g.max(o.thrust_g.abs());
                for (k, q) in Quantity::ALL.iter().enumerate() {
                    if let Some(v) = o.measured(*q) {
                        max_measured[k] = max_measured[k].max(v.abs());
                    }
                }
            }
        }
        Self {
            max_thrust_g,
            max_measured,
            step_s,
        }
    }

    /// Largest measured value of a quantity.
    pub fn max(&self, q: Quantity) -> f64 {
        self.max_measured[Quantity::ALL.iter().position(|x| *x == q).unwrap_or(0)]
    }
}

/// Bounds of a parameter for data of this scale.
pub fn bounds(p: Param, s: &Scale) -> (f64, f64) {
    let t = s.max_thrust_g.max(1.0);
    let v = s.max(Quantity::VoltageV).max(1.0);
    let i = (s.max(Quantity::PowerW) / v)
        .max(s.max(Quantity::CurrentA))
        .max(0.1);
    match p {
        Param::KvRpmPerV => (10.0, 200_000.0),
        // At the largest current the winding drops at most half the supply voltage.
        Param::ResistanceOhm => (1e-4, (0.5 * v / i).max(2e-4)),
        Param::NoLoadCurrentA => (1e-4, 100.0),
        Param::EscEfficiency => (0.5, 1.0),
        Param::ThrustCoeffGPerKrpm2 => (1e-6, 1e6),
        Param::TorqueCoeffNmPerKrpm2 => (1e-12, 10.0),
        Param::SupplyVoltageV => (0.5, 1000.0),
        // A source dropping at most a third of the voltage at the largest current.
        Param::SourceResistanceOhm => (0.0, v / (3.0 * i)),
        // Wide: only the product with the (often poorly known) winding resistance is seen; the
        // diagnosis checks the winding temperature rise it implies instead.
        Param::ThermalResistanceKPerW => (0.0, 5000.0),
        Param::ThermalTauS => (0.5 * s.step_s, 200.0 * s.step_s),
        Param::NoLoadSlopeAPerKrpm => (-0.5 * i / 10.0, i / 10.0),
        Param::EscPartialLoss => (0.0, 0.4),
        Param::DragReExponent => (-0.4, 0.4),
        Param::LoadcellOffsetG => (-0.1 * t, 0.1 * t),
        // At most a tenth of the largest thrust over ten steps at the start.
        Param::LoadcellRateGPerS => (-0.01 * t / s.step_s, 0.01 * t / s.step_s),
        // From a step to a thousand steps (the latter a steady linear drift over a session).
        Param::LoadcellTauS => (s.step_s, 1000.0 * s.step_s),
        Param::PolarisationOhm => (0.0, v / (3.0 * i)),
        Param::PolarisationTauS => (0.5 * s.step_s, 200.0 * s.step_s),
        Param::BlockageFraction => (0.0, 0.3),
        // At most a quarter of the voltage over 20 steps at the largest current.
        Param::DischargeVPerAs => (0.0, 0.25 * v / (20.0 * i * s.step_s)),
    }
}

/// A weak Gaussian prior on a positive parameter, in log space.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Prior {
    /// The parameter.
    pub param: Param,
    /// Centre.
    pub center: f64,
    /// σ of `ln(value)`.
    pub log_sigma: f64,
}

/// The quantities that can be compared in these sweeps: power if logged (current only when
/// power is not), voltage, speed and torque when logged and not all zero.
pub fn quantities(sweeps: &[&Sweep]) -> Vec<Quantity> {
    let has = |q: Quantity| {
        sweeps
            .iter()
            .flat_map(|s| &s.steps)
            .any(|o| o.measured(q).is_some_and(|v| v.abs() > 0.0))
    };
    let mut out = Vec::new();
    if has(Quantity::PowerW) {
        out.push(Quantity::PowerW);
    } else if has(Quantity::CurrentA) {
        out.push(Quantity::CurrentA);
    }
    for q in [Quantity::VoltageV, Quantity::SpeedRpm, Quantity::TorqueNm] {
        if has(q) {
            out.push(q);
        }
    }
    out
}

/// Starting values and weak priors for the base model from the data alone.
pub fn initial_guess(sweeps: &[&Sweep]) -> (Params, Vec<Prior>) {
    let s = Scale::of(sweeps);
    let steps: Vec<_> = sweeps
        .iter()
        .flat_map(|s| &s.steps)
        .filter(|o| !o.drive_only)
        .collect();
    let top = steps
        .iter()
        .copied()
        .max_by(|a, b| a.thrust_g.total_cmp(&b.thrust_g))
        .copied()
        .unwrap_or_default();
    let v0 = steps
        .iter()
        .filter_map(|o| o.voltage_v)
        .fold(0.0f64, f64::max);
    let v0 = if v0 > 0.0 { v0 * 1.01 } else { 12.0 };
    let p_top = top
        .power_w
        .or(top.current_a.map(|i| i * v0))
        .unwrap_or(0.0)
        .max(1e-3);
    let median = |mut v: Vec<f64>| -> Option<f64> {
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        Some(v[v.len() / 2])
    };
    let t_min = 0.2 * s.max_thrust_g;
    let ct_data = median(
        steps
            .iter()
            .filter(|o| o.thrust_g > t_min)
            .filter_map(|o| {
                o.speed_rpm
                    .filter(|r| *r > 0.0)
                    .map(|r| o.thrust_g / (r / 1000.0).powi(2))
            })
            .collect(),
    );
    let kv_data = top
        .speed_rpm
        .filter(|r| *r > 0.0)
        .map(|r| r / (0.8 * top.voltage_v.unwrap_or(v0)));
    let kv = kv_data.unwrap_or(1000.0);
    let ct = ct_data
        .unwrap_or_else(|| top.thrust_g.max(1.0) / (0.75 * kv * v0 / 1000.0).powi(2))
        .max(1e-6);
    let rpm_top = 1000.0 * (top.thrust_g.max(1e-6) / ct).sqrt();
    let cq_data = median(
        steps
            .iter()
            .filter(|o| o.thrust_g > t_min)
            .filter_map(|o| match (o.torque_nm, o.speed_rpm) {
                (Some(q), Some(r)) if r > 0.0 && q > 0.0 => Some(q / (r / 1000.0).powi(2)),
                _ => None,
            })
            .collect(),
    );
    let omega_top = rpm_top * std::f64::consts::PI / 30.0;
    let cq = cq_data
        .unwrap_or_else(|| 0.75 * 0.95 * p_top / (omega_top * (rpm_top / 1000.0).powi(2)))
        .max(1e-12);
    let i_top = p_top / v0;
    let r = (0.08 * p_top / i_top.powi(2)).max(1e-4);
    let i0 = (0.04 * i_top).max(1e-4);
    let mut p = Params::default();
    p.set_base(kv, r, i0, 0.95, ct, cq, v0);
    p.reference_rpm = rpm_top.max(1.0);
    let has_v = steps.iter().any(|o| o.voltage_v.is_some());
    let priors = vec![
        Prior {
            param: Param::KvRpmPerV,
            center: kv,
            log_sigma: if kv_data.is_some() { 1.0 } else { 0.7 },
        },
        Prior {
            param: Param::ResistanceOhm,
            center: r,
            log_sigma: 1.5,
        },
        Prior {
            param: Param::NoLoadCurrentA,
            center: i0,
            log_sigma: 1.5,
        },
        Prior {
            param: Param::EscEfficiency,
            center: 0.95,
            log_sigma: 0.03,
        },
        Prior {
            param: Param::ThrustCoeffGPerKrpm2,
            center: ct,
            log_sigma: if ct_data.is_some() { 1.0 } else { 0.7 },
        },
        Prior {
            param: Param::TorqueCoeffNmPerKrpm2,
            center: cq,
            log_sigma: 1.5,
        },
        Prior {
            param: Param::SupplyVoltageV,
            center: v0,
            log_sigma: if has_v { 0.5 } else { 0.05 },
        },
    ];
    (p, priors)
}

/// A fit's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct FitResult {
    /// Fitted parameters (the ones not fitted keep their starting values).
    pub params: Params,
    /// Standard errors of the fitted parameters, in natural units.
    pub std_errors: Vec<(Param, f64)>,
    /// Robust cost of the data residuals alone.
    pub data_cost: f64,
    /// Number of data residuals.
    pub data_residuals: usize,
    /// Whether the solver converged.
    pub converged: bool,
}

/// Noise-normalised residuals `(predicted − measured)/σ` of every logged quantity in `qs`.
pub fn residuals(
    p: &Params,
    sweeps: &[&Sweep],
    qs: &[Quantity],
    floors: &NoiseFloors,
    scale: &Scale,
    out: &mut Vec<f64>,
) {
    for s in sweeps {
        let pred = s.predict(p);
        for (o, pr) in s.steps.iter().zip(&pred) {
            for &q in qs {
                if let Some(m) = o.measured(q) {
                    let (rel, abs) = floors.of(q);
                    let sigma = ((rel * m).powi(2) + (abs * scale.max(q)).powi(2))
                        .sqrt()
                        .max(1e-12);
                    let v = (q.predicted(pr) - m) / sigma;
                    out.push(if v.is_finite() { v } else { 1e6 });
                }
            }
        }
    }
}

/// The σ of every residual [`residuals`] writes, in its order: they depend on the measured
/// values alone, so a fit computes them once, not at every evaluation.
fn sigmas(sweeps: &[&Sweep], qs: &[Quantity], floors: &NoiseFloors, scale: &Scale) -> Vec<f64> {
    let mut out = Vec::new();
    for s in sweeps {
        for o in &s.steps {
            for &q in qs {
                if let Some(m) = o.measured(q) {
                    let (rel, abs) = floors.of(q);
                    out.push(
                        ((rel * m).powi(2) + (abs * scale.max(q)).powi(2))
                            .sqrt()
                            .max(1e-12),
                    );
                }
            }
        }
    }
    out
}

/// [`residuals`] with the σ of [`sigmas`]: the same numbers, bit for bit.
fn residuals_with(
    p: &Params,
    sweeps: &[&Sweep],
    qs: &[Quantity],
    sigma: &[f64],
    out: &mut Vec<f64>,
) {
    let mut k = 0;
    for s in sweeps {
        let pred = s.predict(p);
        for (o, pr) in s.steps.iter().zip(&pred) {
            for &q in qs {
                if let Some(m) = o.measured(q) {
                    let v = (q.predicted(pr) - m) / sigma[k];
                    k += 1;
                    out.push(if v.is_finite() { v } else { 1e6 });
                }
            }
        }
    }
}

/// Fits `free` (base and/or effect parameters) to the sweeps, starting from `start`; the other
/// parameters stay as they are. `priors` apply to free positive parameters.
pub fn fit(
    sweeps: &[&Sweep],
    start: &Params,
    free: &[Param],
    priors: &[Prior],
    floors: &NoiseFloors,
    options: &LmOptions,
) -> FitResult {
    let scale = Scale::of(sweeps);
    let qs = quantities(sweeps);
    let to_internal = |p: Param, v: f64| if p.positive() { v.ln() } else { v };
    let to_natural = |p: Param, u: f64| if p.positive() { u.exp() } else { u };
    let lower: Vec<f64> = free
        .iter()
        .map(|&p| to_internal(p, bounds(p, &scale).0))
        .collect();
    let upper: Vec<f64> = free
        .iter()
        .map(|&p| to_internal(p, bounds(p, &scale).1))
        .collect();
    let x0: Vec<f64> = free.iter().map(|&p| to_internal(p, start.get(p))).collect();
    let pri: Vec<(usize, f64, f64)> = priors
        .iter()
        .filter_map(|pr| {
            free.iter()
                .position(|p| *p == pr.param)
                .map(|k| (k, pr.center.ln(), pr.log_sigma))
        })
        .collect();
    let build = |x: &[f64]| {
        let mut p = *start;
        for (k, &par) in free.iter().enumerate() {
            p.set(par, to_natural(par, x[k]));
        }
        p
    };
    let sigma = sigmas(sweeps, &qs, floors, &scale);
    let f = |x: &[f64], out: &mut Vec<f64>| {
        let p = build(x);
        residuals_with(&p, sweeps, &qs, &sigma, out);
        for &(k, c, s) in &pri {
            out.push((x[k] - c) / s);
        }
    };
    let sol = lm::solve(&f, &x0, &lower, &upper, options);
    let params = build(&sol.x);
    let mut data = Vec::new();
    residuals(&params, sweeps, &qs, floors, &scale, &mut data);
    let data_cost = data
        .iter()
        .map(|r| {
            let a = r.abs();
            if a <= options.huber_delta {
                0.5 * r * r
            } else {
                options.huber_delta * (a - 0.5 * options.huber_delta)
            }
        })
        .sum();
    let std_errors = free
        .iter()
        .enumerate()
        .map(|(k, &p)| {
            let se = sol.std_errors[k];
            // Log-space σ → natural σ by the delta method.
            (p, if p.positive() { se * params.get(p) } else { se })
        })
        .collect();
    FitResult {
        params,
        std_errors,
        data_cost,
        data_residuals: data.len(),
        converged: sol.converged,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Observation, Point, predict_sweep};

    fn synth(p: &Params, n: usize) -> Sweep {
        let pts: Vec<Point> = (0..n)
            .map(|i| Point {
                thrust_g: 100.0 + 900.0 * i as f64 / (n - 1) as f64,
                time_frac: i as f64 / (n - 1) as f64,
                time_s: 4.0 * i as f64,
                tare_time_s: 0.0,
                measured_current_a: None,
            })
            .collect();
        let pr = predict_sweep(p, &pts);
        Sweep {
            name: "synthetic".into(),
            steps: pts
                .iter()
                .zip(&pr)
                .map(|(pt, pr)| Observation {
                    thrust_g: pt.thrust_g,
                    time_frac: pt.time_frac,
                    time_s: pt.time_s,
                    power_w: Some(pr.power_w),
                    current_a: Some(pr.current_a),
                    voltage_v: Some(pr.voltage_v),
                    speed_rpm: Some(pr.rpm),
                    torque_nm: Some(pr.torque_nm),
                    drive_only: false,
                })
                .collect(),
            open_circuit_v: None,
            tare_time_s: 0.0,
            anchor_first_voltage: false,
            tared: false,
        }
    }

    #[test]
    fn recovers_source_resistance_with_its_uncertainty() {
        let mut truth = Params::default();
        truth.set_base(920.0, 0.12, 0.6, 0.95, 12.0, 0.000_25, 16.8);
        truth.set(Param::SourceResistanceOhm, 0.08);
        let s = synth(&truth, 12);
        let (start, priors) = initial_guess(&[&s]);
        let mut free = Param::BASE.to_vec();
        free.push(Param::SourceResistanceOhm);
        let r = fit(
            &[&s],
            &start,
            &free,
            &priors,
            &NoiseFloors::default(),
            &LmOptions::default(),
        );
        let rs = r.params.get(Param::SourceResistanceOhm);
        assert!((rs - 0.08).abs() < 0.005, "{rs}");
        let se = r
            .std_errors
            .iter()
            .find(|(p, _)| *p == Param::SourceResistanceOhm)
            .map(|x| x.1)
            .unwrap_or(f64::NAN);
        assert!(se.is_finite() && se > 0.0 && se < 0.05, "{se}");
        let pr = s.predict(&r.params);
        for (o, p) in s.steps.iter().zip(&pr) {
            let m = o.power_w.unwrap_or(0.0);
            assert!((p.power_w - m).abs() < 0.01 * m, "{} vs {m}", p.power_w);
        }
    }
}
