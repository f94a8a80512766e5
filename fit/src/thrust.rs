//! Extraction of the rotor thrust limit `m_L` from a throttle sweep.
//!
//! The paper measures the thrust limit with the supply held at the minimum
//! battery voltage (9.0 V for its 3-cell pack): the largest thrust the motor
//! and propeller can sustain at that voltage bounds the payload.

use crate::error::{FitError, Input};

/// Options for [`thrust_limit`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrustLimitOptions<'a> {
    /// Per-step standard deviation of the thrust reading (g), parallel to
    /// the sweep (e.g. from the samples averaged at each throttle step).
    pub thrust_std_g: Option<&'a [f64]>,
    /// Measurement noise σ (g) applying to every step, used when
    /// `thrust_std_g` is `None`. When both are `None`, σ is estimated
    /// robustly from the sweep itself (median absolute deviation of the
    /// second differences, which ignores smooth curvature).
    pub noise_std_g: Option<f64>,
    /// Coverage factor: two readings whose difference is within
    /// `k_sigma · σ_diff` are "within noise" of each other. Default 3
    /// (a plateau of ten noisy readings is then rarely split by chance).
    pub k_sigma: f64,
    /// Fewest points that make a plateau when the maximum is at the top of
    /// the sweep (at least 2). Default 3.
    pub min_plateau_points: usize,
}

impl Default for ThrustLimitOptions<'_> {
    fn default() -> Self {
        ThrustLimitOptions {
            thrust_std_g: None,
            noise_std_g: None,
            k_sigma: 3.0,
            min_plateau_points: 3,
        }
    }
}

/// How the thrust limit was determined.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ThrustLimitKind {
    /// The thrust saturates: from `from_throttle` on, more throttle yields
    /// no more thrust (within noise). The limit is the mean over the plateau.
    Plateau {
        /// First throttle value of the plateau.
        from_throttle: f64,
        /// Last throttle value of the plateau.
        to_throttle: f64,
        /// Number of sweep points averaged (plateau members; isolated low
        /// outliers between `from_throttle` and `to_throttle` are excluded).
        n_points: usize,
    },
    /// The thrust was still rising at the end of the sweep: the limit is the
    /// last reading, a lower bound on what the rotor could deliver.
    TopOfRange,
}

/// Thrust falling off beyond the plateau (e.g. supply or ESC sag at high
/// throttle). The limit reported is the maximum *sustained* thrust, not the
/// final reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrustSag {
    /// First throttle value whose reading fell significantly below the plateau.
    pub from_throttle: f64,
    /// Thrust at the top of the sweep (g).
    pub final_thrust_g: f64,
    /// How far the final reading is below the reported limit (g).
    pub drop_g: f64,
}

/// The thrust limit `m_L` of a rotor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrustLimit {
    /// Maximum sustained thrust (g).
    pub thrust_g: f64,
    /// Standard uncertainty of `thrust_g` (g): the larger of the scatter of
    /// the plateau points about their mean and the propagated per-step σ,
    /// or σ of the last step for [`ThrustLimitKind::TopOfRange`].
    pub uncertainty_g: f64,
    /// Which case applied.
    pub kind: ThrustLimitKind,
    /// Present when thrust drops significantly after the plateau.
    pub sag: Option<ThrustSag>,
    /// The measurement noise σ (g) used for the "within noise" decisions
    /// (root-mean-square of the per-step values when those were given).
    pub noise_std_g: f64,
}

/// Extracts the maximum sustained thrust from a throttle sweep.
///
/// `throttle` must be strictly increasing (any unit: %, µs, 0–1) and
/// `thrust_g` parallel to it, at least 2 points.
///
/// * The plateau starts at the first reading that no later reading exceeds
///   by more than `k_sigma · √(σⱼ² + σₖ²)`: from there on, more throttle
///   yields no more thrust within noise.
/// * The plateau is made of the readings from there on that are not
///   significantly below the plateau mean (by more than
///   `k_sigma · √(σᵢ² + σ_mean²)`), found by iterating to a fixed point;
///   isolated low readings inside it are treated as outliers and left out.
///   The limit is the maximum *sustained* thrust, the mean over the plateau.
/// * Readings after the last plateau member (all significantly lower) are a
///   sag, reported as [`ThrustSag`].
/// * If there is no sag and the plateau has fewer than
///   `min_plateau_points` readings, the thrust was still rising: the result
///   is [`TopOfRange`](ThrustLimitKind::TopOfRange) with the last reading,
///   a lower bound on the true limit.
pub fn thrust_limit(
    throttle: &[f64],
    thrust_g: &[f64],
    opts: &ThrustLimitOptions<'_>,
) -> Result<ThrustLimit, FitError> {
    validate(throttle, thrust_g, opts)?;
    let n = thrust_g.len();
    let sigma: Vec<f64> = match (opts.thrust_std_g, opts.noise_std_g) {
        (Some(s), _) => s.to_vec(),
        (None, Some(s)) => vec![s; n],
        (None, None) => vec![estimate_noise(thrust_g); n],
    };
    let noise_std_g = (sigma.iter().map(|s| s * s).sum::<f64>() / n as f64).sqrt();
    let z = opts.k_sigma;
    let pair = |i: usize, j: usize| z * sigma[i].hypot(sigma[j]);

    // Plateau start: the first reading that no later reading exceeds by
    // more than noise ("more throttle yields no more thrust"). The highest
    // reading always qualifies, so the start is at or before it.
    let start = (0..n)
        .find(|&k| (k + 1..n).all(|j| thrust_g[j] - thrust_g[k] <= pair(j, k)))
        .unwrap_or(n - 1);

    // Plateau members: readings from the start on that are not
    // significantly below the members' mean. Dropping low readings raises
    // the mean, so iterate to the fixed point (the set only shrinks, and the
    // highest reading always stays in it).
    let mut member = vec![false; n];
    member[start..].fill(true);
    let (mut mean, mut sigma_mean) = members_mean(thrust_g, &sigma, &member);
    loop {
        let mut changed = false;
        for i in start..n {
            if member[i] && mean - thrust_g[i] > z * sigma[i].hypot(sigma_mean) {
                member[i] = false;
                changed = true;
            }
        }
        if !changed {
            break;
        }
        (mean, sigma_mean) = members_mean(thrust_g, &sigma, &member);
    }
    let first = member.iter().position(|&m| m).unwrap_or(start);
    let end = member.iter().rposition(|&m| m).unwrap_or(start);
    let count = member.iter().filter(|&&m| m).count();

    if end == n - 1 && count < opts.min_plateau_points {
        return Ok(ThrustLimit {
            thrust_g: thrust_g[n - 1],
            uncertainty_g: sigma[n - 1],
            kind: ThrustLimitKind::TopOfRange,
            sag: None,
            noise_std_g,
        });
    }

    let k = count as f64;
    let scatter = if count > 1 {
        let ss: f64 = (0..n)
            .filter(|&i| member[i])
            .map(|i| (thrust_g[i] - mean).powi(2))
            .sum();
        (ss / (k - 1.0)).sqrt() / k.sqrt()
    } else {
        0.0
    };
    let sag = (end < n - 1).then(|| ThrustSag {
        from_throttle: throttle[end + 1],
        final_thrust_g: thrust_g[n - 1],
        drop_g: mean - thrust_g[n - 1],
    });
    Ok(ThrustLimit {
        thrust_g: mean,
        uncertainty_g: scatter.max(sigma_mean),
        kind: ThrustLimitKind::Plateau {
            from_throttle: throttle[first],
            to_throttle: throttle[end],
            n_points: count,
        },
        sag,
        noise_std_g,
    })
}

/// Mean of the member readings and its propagated standard error
/// `√(Σσᵢ²)/n`. Each term is divided by `n` before summing so that readings
/// near `f64::MAX` cannot overflow the sum.
fn members_mean(thrust: &[f64], sigma: &[f64], member: &[bool]) -> (f64, f64) {
    let n = member.iter().filter(|&&m| m).count() as f64;
    let picked = || {
        thrust
            .iter()
            .zip(sigma)
            .zip(member)
            .filter(|(_, m)| **m)
            .map(|(ts, _)| ts)
    };
    let mean = picked().map(|(&t, _)| t / n).sum();
    let var: f64 = picked().map(|(_, &s)| (s / n) * (s / n)).sum();
    (mean, var.sqrt())
}

fn validate(
    throttle: &[f64],
    thrust: &[f64],
    opts: &ThrustLimitOptions<'_>,
) -> Result<(), FitError> {
    if throttle.len() != thrust.len() {
        return Err(FitError::LengthMismatch {
            first: Input::Throttle,
            first_len: throttle.len(),
            second: Input::Thrust,
            second_len: thrust.len(),
        });
    }
    if let Some(len) = opts
        .thrust_std_g
        .map(<[f64]>::len)
        .filter(|&len| len != thrust.len())
    {
        return Err(FitError::LengthMismatch {
            first: Input::Thrust,
            first_len: thrust.len(),
            second: Input::ThrustStd,
            second_len: len,
        });
    }
    if thrust.len() < 2 {
        return Err(FitError::TooFewPoints {
            what: "thrust-limit extraction",
            needed: 2,
            got: thrust.len(),
        });
    }
    if !(opts.k_sigma.is_finite() && opts.k_sigma > 0.0) {
        return Err(FitError::InvalidOption {
            name: "k_sigma",
            value: opts.k_sigma,
            reason: "must be finite and > 0",
        });
    }
    if opts.min_plateau_points < 2 {
        return Err(FitError::InvalidOption {
            name: "min_plateau_points",
            value: opts.min_plateau_points as f64,
            reason: "must be at least 2",
        });
    }
    if let Some(s) = opts.noise_std_g.filter(|s| !(s.is_finite() && *s >= 0.0)) {
        return Err(FitError::InvalidOption {
            name: "noise_std_g",
            value: s,
            reason: "must be finite and >= 0",
        });
    }
    let columns = [
        Some((Input::Throttle, throttle)),
        Some((Input::Thrust, thrust)),
        opts.thrust_std_g.map(|s| (Input::ThrustStd, s)),
    ];
    for (input, col) in columns.into_iter().flatten() {
        if let Some((index, &value)) = col.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(FitError::NonFinite {
                input,
                index,
                value,
            });
        }
    }
    let negative_std = opts
        .thrust_std_g
        .and_then(|s| s.iter().copied().enumerate().find(|&(_, v)| v < 0.0));
    if let Some((index, value)) = negative_std {
        return Err(FitError::Negative {
            input: Input::ThrustStd,
            index,
            value,
        });
    }
    if let Some(index) = (1..throttle.len()).find(|&i| throttle[i] <= throttle[i - 1]) {
        return Err(FitError::ThrottleNotIncreasing {
            index,
            previous: throttle[index - 1],
            value: throttle[index],
        });
    }
    Ok(())
}

/// Robust σ of white noise on a smooth curve: second differences have
/// variance 6σ² and the median absolute deviation ignores the (slowly
/// varying) curvature contribution. Zero with fewer than 3 points.
fn estimate_noise(thrust: &[f64]) -> f64 {
    if thrust.len() < 3 {
        return 0.0;
    }
    let d2: Vec<f64> = thrust
        .windows(3)
        .map(|w| w[2] - 2.0 * w[1] + w[0])
        .collect();
    let med = median(&d2);
    let mad = median(&d2.iter().map(|v| (v - med).abs()).collect::<Vec<_>>());
    mad / 0.674_489_750_196_081_7 / 6f64.sqrt()
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let m = s.len() / 2;
    if s.len() % 2 == 1 {
        s[m]
    } else {
        0.5 * (s[m - 1] + s[m])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_estimate_ignores_constant_curvature() {
        let t: Vec<f64> = (0..20).map(|i| 3.0 * (i as f64).powi(2)).collect();
        assert_eq!(estimate_noise(&t), 0.0);
        assert_eq!(median(&[3.0, 1.0, 2.0, 10.0]), 2.5);
    }
}
