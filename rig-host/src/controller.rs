//! The thrust-targeted throttle controller of a nominal sweep, pure: state in, set-point out.
//!
//! Thrust grows about as the square of the throttle above a dead zone, so √thrust is close to
//! linear in throttle; the controller steps by secants in √thrust, each correction bounded by
//! `max_correction_us` and the throttle range. It knows nothing of rigs, clocks or logs — the
//! sweep runner settles the rig at each set-point it proposes and reports the settled thrust
//! back through [`StepController::observe`].
//!
//! ```
//! use rig_host::controller::{ControllerConfig, Decision, StepController};
//!
//! let cfg = ControllerConfig { umin: 1000.0, umax: 2000.0, ..ControllerConfig::default() };
//! // A rotor whose thrust is 0.0006·(u − 1050)² g.
//! let plant = |u: f64| 0.0006 * (u - 1050.0).max(0.0).powi(2);
//! let mut c = StepController::new(cfg, 120.0, &[]);
//! let mut u = c.start();
//! let hit = loop {
//!     match c.observe(u, plant(u), 0.05) {
//!         Decision::Next { throttle_us, .. } => u = throttle_us,
//!         other => break other,
//!     }
//! };
//! assert!(matches!(hit, Decision::Hit));
//! assert!((plant(u) - 120.0).abs() <= 1.0);
//! ```

/// The controller's settings (from [`SweepConfig`](crate::sweep::SweepConfig) and the rig's
/// throttle range).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerConfig {
    /// Lowest throttle, µs.
    pub umin: f64,
    /// Highest throttle, µs.
    pub umax: f64,
    /// Thrust tolerance of a step, ± g.
    pub tolerance_g: f64,
    /// Largest throttle change of one correction, µs.
    pub max_correction_us: f64,
    /// First probe, as a fraction of the throttle range.
    pub probe_fraction: f64,
    /// Attempts per step before the closest is taken.
    pub max_attempts: usize,
}

impl Default for ControllerConfig {
    fn default() -> Self {
        Self {
            umin: 1000.0,
            umax: 2000.0,
            tolerance_g: 1.0,
            max_correction_us: 150.0,
            probe_fraction: 0.12,
            max_attempts: 10,
        }
    }
}

impl ControllerConfig {
    /// The first throttle to try for `target` g, from the settled `(throttle, thrust)` points
    /// of the steps so far: a probe, then extrapolation in √thrust, never below the last step
    /// and never more than one correction above it.
    pub fn first_guess(&self, history: &[(f64, f64)], target: f64) -> f64 {
        let (umin, umax) = (self.umin, self.umax);
        let probe = umin + self.probe_fraction * (umax - umin);
        if target <= 0.0 {
            return umin;
        }
        let pts: Vec<(f64, f64)> = history
            .iter()
            .copied()
            .filter(|&(_, t)| t > self.tolerance_g)
            .collect();
        let u = match pts.len() {
            0 => probe,
            1 => {
                let (u1, t1) = pts[0];
                umin + (u1 - umin) * (target / t1).sqrt()
            }
            n => {
                let (u1, t1) = pts[n - 2];
                let (u2, t2) = pts[n - 1];
                u2 + (target.sqrt() - t2.sqrt()) * (u2 - u1) / (t2.sqrt() - t1.sqrt())
            }
        };
        let floor = history.last().map_or(umin, |&(u, _)| u);
        let u = if u.is_finite() { u } else { probe };
        u.clamp(floor, floor + self.max_correction_us)
            .clamp(umin, umax)
            .round()
    }
}

/// What to do after a settled attempt.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decision {
    /// The thrust is within tolerance of the target: keep this attempt.
    Hit,
    /// More throttle gives no more thrust (or the throttle is at its top): the rotor's
    /// maximum; keep this attempt and end the sweep.
    Maximum,
    /// Try this throttle next. `best` says whether the attempt just observed is the closest
    /// so far (the one to keep if the step is missed).
    Next {
        /// The next set-point, µs.
        throttle_us: f64,
        /// Whether the observed attempt is the closest so far.
        best: bool,
    },
    /// No more attempts (or no further change): keep the closest attempt, the target missed.
    Missed {
        /// Whether the observed attempt is the closest so far.
        best: bool,
    },
}

/// The controller of one step: proposes set-points until the target is hit, the rotor's
/// maximum is found, or the attempts run out.
#[derive(Debug, Clone, PartialEq)]
pub struct StepController {
    cfg: ControllerConfig,
    target: f64,
    /// The previous settled step `(throttle, thrust)`.
    last_step: Option<(f64, f64)>,
    start: f64,
    /// This step's attempts: (throttle, thrust, standard error).
    pts: Vec<(f64, f64, f64)>,
    best_error: f64,
}

impl StepController {
    /// A controller for `target` g after the settled steps in `history`.
    pub fn new(cfg: ControllerConfig, target: f64, history: &[(f64, f64)]) -> Self {
        Self {
            start: cfg.first_guess(history, target),
            cfg,
            target,
            last_step: history.last().copied(),
            pts: Vec::new(),
            best_error: f64::INFINITY,
        }
    }

    /// The first set-point, µs.
    pub fn start(&self) -> f64 {
        self.start
    }

    /// Attempts observed so far.
    pub fn attempts(&self) -> usize {
        self.pts.len()
    }

    /// Takes the settled thrust `thrust_g` (standard error `se_g`) at throttle `u` and
    /// decides what comes next.
    pub fn observe(&mut self, u: f64, thrust_g: f64, se_g: f64) -> Decision {
        let (cfg, target, t) = (self.cfg, self.target, thrust_g);
        let tol = cfg.tolerance_g;
        if target <= 0.0 || (target - t).abs() <= tol {
            return Decision::Hit;
        }
        if u >= cfg.umax && t < target {
            return Decision::Maximum;
        }
        // The previous point: this step's last attempt, else the last settled step.
        let prev = self
            .pts
            .last()
            .copied()
            .or_else(|| self.last_step.map(|(u, t)| (u, t, se_g)));
        // Secant in √thrust through the previous point when it is usable, else through the
        // dead-zone end at minimum throttle.
        let mut slope = f64::NAN;
        if let Some((up, tp, sep)) = prev {
            if u > up && t - tp <= 3.0 * se_g.hypot(sep) && t < target {
                return Decision::Maximum;
            }
            if (u - up).abs() >= 1.0 && tp > tol {
                slope = (t.max(0.0).sqrt() - tp.sqrt()) / (u - up);
            }
        }
        if !(slope.is_finite() && slope > 0.0) {
            slope = (t.max(tol).sqrt() / (u - cfg.umin).max(1.0)).max(1e-4);
        }
        self.pts.push((u, t, se_g));
        let error = (target - t).abs();
        let best = error < self.best_error;
        if best {
            self.best_error = error;
        }
        if self.pts.len() >= cfg.max_attempts.max(1) {
            return Decision::Missed { best };
        }
        let du = ((target.sqrt() - t.max(0.0).sqrt()) / slope)
            .clamp(-cfg.max_correction_us, cfg.max_correction_us);
        let next = (u + du).clamp(cfg.umin, cfg.umax).round();
        if next == u {
            return Decision::Missed { best };
        }
        Decision::Next {
            throttle_us: next,
            best,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn plant(u0: f64, k: f64) -> impl Fn(f64) -> f64 {
        move |u: f64| k * (u - u0).max(0.0).powi(2)
    }

    /// Runs one step to its end; returns the decision, the last throttle and the attempts.
    fn run(c: &mut StepController, p: &dyn Fn(f64) -> f64) -> (Decision, f64, usize) {
        let mut u = c.start();
        loop {
            match c.observe(u, p(u), 0.05) {
                Decision::Next { throttle_us, .. } => u = throttle_us,
                d => return (d, u, c.attempts()),
            }
        }
    }

    #[test]
    fn first_guess_probes_then_extrapolates_in_root_thrust() {
        let cfg = ControllerConfig::default();
        assert_eq!(cfg.first_guess(&[], 10.0), 1120.0);
        assert_eq!(cfg.first_guess(&[], 0.0), 1000.0);
        // On t = k(u − 1000)², √t is linear: two points extrapolate exactly.
        let p = plant(1000.0, 0.001);
        let h = [(1100.0, p(1100.0)), (1200.0, p(1200.0))];
        assert_eq!(cfg.first_guess(&h, p(1300.0)), 1300.0);
        // Never below the last step, never more than one correction above it.
        assert_eq!(cfg.first_guess(&h, 1.0), 1200.0);
        assert_eq!(cfg.first_guess(&h, 1e6), 1350.0);
    }

    #[test]
    fn a_flat_top_is_the_rotors_maximum() {
        let cfg = ControllerConfig::default();
        let flat = |u: f64| (0.001 * (u - 1000.0).powi(2)).min(200.0);
        let h = [(1400.0, 160.0), (1500.0, 200.0)];
        let mut c = StepController::new(cfg, 210.0, &h);
        let (d, _, _) = run(&mut c, &flat);
        assert_eq!(d, Decision::Maximum);
    }

    #[test]
    fn an_unreachable_target_ends_at_full_throttle() {
        let cfg = ControllerConfig::default();
        let p = plant(1000.0, 0.0001); // 100 g at full throttle
        let mut c = StepController::new(cfg, 150.0, &[(1900.0, p(1900.0))]);
        let (d, u, _) = run(&mut c, &p);
        assert_eq!(d, Decision::Maximum);
        assert_eq!(u, 2000.0);
    }

    proptest! {
        /// On any square-law rotor, every set-point is inside the throttle range, moves by at
        /// most one correction, and a reachable target is hit within the attempts.
        #[test]
        fn hits_reachable_targets_within_bounds(
            u0 in 1000.0..1200.0f64,
            k in 2e-4..3e-3f64,
            frac in 0.05..0.9f64,
        ) {
            let cfg = ControllerConfig::default();
            let p = plant(u0, k);
            let target = frac * p(cfg.umax);
            prop_assume!(target > 5.0);
            let mut c = StepController::new(cfg, target, &[]);
            let mut u = c.start();
            prop_assert!((cfg.umin..=cfg.umax).contains(&u));
            let d = loop {
                match c.observe(u, p(u), 0.05) {
                    Decision::Next { throttle_us, .. } => {
                        prop_assert!((cfg.umin..=cfg.umax).contains(&throttle_us));
                        prop_assert!((throttle_us - u).abs() <= cfg.max_correction_us + 0.5);
                        u = throttle_us;
                    }
                    d => break d,
                }
            };
            prop_assert!(c.attempts() <= cfg.max_attempts);
            // Throttle is quantised to 1 µs: accept the nearest achievable thrust.
            let reachable = (p(u + 1.0) - p(u)).abs() < 2.0 * cfg.tolerance_g;
            if reachable {
                prop_assert_eq!(d, Decision::Hit, "u {} thrust {} target {}", u, p(u), target);
            }
        }
    }
}
