//! Is a systematic gap left? The test behind the diagnosis's `unexplained` flag.
//!
//! Flights scatter: each carries its own pack (capacity, resistance), its own sensor errors
//! (current scale and offset, voltage scale) and its own air. That scatter is noise, however
//! large; what the selected effects must explain is what the flights *share*. So after the
//! selected effects every flight gives one number per quantity — its endurance error, its
//! energy error summed over phases, the drift of its measured-over-predicted power from the
//! early to the late half of the flight (within each phase, so that a flight whose halves fly
//! different phases does not read the model's error on one phase against another), and (for flights without current) its mean voltage
//! residual in each third of the discharge — and the test asks whether the mean over the
//! held-out flights, or over the training flights, differs from zero by more than the flights'
//! own scatter allows:
//!
//! - the scatter σ is pooled from both sets, each around its own mean (so a shift of one set
//!   does not inflate it), with n_train + n_heldout − 2 degrees of freedom;
//! - the training mean's standard error is σ/√n_train; the held-out mean's is
//!   σ·√(1/n_heldout + 1/n_train): its own scatter plus that of what the fit learned from the
//!   training flights (a held-out shift is what a model that stands in for an outside effect
//!   leaves when extrapolated to other missions);
//! - the power drift is different: no library effect changes the power within a flight, so
//!   no fit absorbs it, and its mean over every flight (training and held-out together, SE
//!   σ/√n from its own scatter) is tested once;
//! - a mean is systematic when |mean| > `t_max`·SE **and** |mean| is at least the quantity's
//!   noise floor (a 0.1 % shift measured very precisely is real but not worth a flag).
//!
//! A flight whose endurance the model misses by more than half (`gross_miss_fraction`, e.g. a
//! learned curve that collapsed and predicts 0 s) is a gap by itself, whatever the scatter.
//!
//! ```
//! use gap::systematic::{FlightSet, Quantity, shared_patterns};
//!
//! // Eight training and four held-out flights: endurance errors that scatter by about 5 %
//! // around zero on training but sit 10 % high on every held-out flight.
//! let train = [4.0, -5.0, 6.0, -3.0, 2.0, -6.0, 5.0, -3.0];
//! let held = [11.0, 9.0, 10.5, 9.5];
//! let p = shared_patterns(Quantity::Endurance, &train, &held, 1.0, 3.5);
//! let held_out = p.iter().find(|p| p.set == FlightSet::HeldOut).unwrap();
//! assert!(held_out.systematic && (held_out.mean - 10.0).abs() < 1e-9);
//! let training = p.iter().find(|p| p.set == FlightSet::Training).unwrap();
//! assert!(!training.systematic);
//! ```

use serde::Serialize;

use crate::diagnose::FlightResiduals;

/// A per-flight quantity the test looks at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// Predicted minus measured endurance, % (flights that ended at the cut-off).
    Endurance,
    /// Predicted minus measured energy summed over phases, % of the flight's energy (flights
    /// with current).
    Energy,
    /// Measured over predicted power in the late half of the flight minus in the early half,
    /// within each phase flown in both (weighted by its samples and its power squared), %
    /// (flights with current): a power that drifts within the flight.
    PowerDrift,
    /// Mean voltage residual (measured − predicted) in the early third of the discharge, V.
    VoltageEarly,
    /// The same in the middle third, V.
    VoltageMiddle,
    /// The same in the late third, V.
    VoltageLate,
}

impl Quantity {
    /// Every quantity, in the order they are reported.
    pub const ALL: [Quantity; 6] = [
        Quantity::Endurance,
        Quantity::Energy,
        Quantity::PowerDrift,
        Quantity::VoltageEarly,
        Quantity::VoltageMiddle,
        Quantity::VoltageLate,
    ];

    /// Unit of the quantity's values.
    pub fn unit(self) -> &'static str {
        match self {
            Quantity::Endurance | Quantity::Energy | Quantity::PowerDrift => "%",
            _ => "V",
        }
    }

    /// What the quantity is, in words (for "… is systematically +3.1 % …").
    pub fn describe(self) -> &'static str {
        match self {
            Quantity::Endurance => "endurance (predicted − measured)",
            Quantity::Energy => "energy summed over phases (predicted − measured)",
            Quantity::PowerDrift => {
                "measured/predicted power within each phase, late half of the flight minus early half"
            }
            Quantity::VoltageEarly => "voltage in the early third (measured − predicted)",
            Quantity::VoltageMiddle => "voltage in the middle third (measured − predicted)",
            Quantity::VoltageLate => "voltage in the late third (measured − predicted)",
        }
    }

    /// The quantity's value for one flight, in its unit; `None` when the flight does not
    /// measure it.
    pub fn of(self, r: &FlightResiduals) -> Option<f64> {
        match self {
            Quantity::Endurance => r.endurance_error.map(|e| e * 100.0),
            Quantity::Energy => {
                let total: f64 = r.phase_power.iter().map(|p| p.measured_w * p.time_s).sum();
                (total > 0.0).then(|| {
                    r.phase_power
                        .iter()
                        .map(|p| (p.predicted_w - p.measured_w) * p.time_s)
                        .sum::<f64>()
                        / total
                        * 100.0
                })
            }
            Quantity::PowerDrift => r.power_drift.map(|d| d * 100.0),
            Quantity::VoltageEarly => r.voltage_by_charge_v[0],
            Quantity::VoltageMiddle => r.voltage_by_charge_v[1],
            Quantity::VoltageLate => r.voltage_by_charge_v[2],
        }
    }
}

/// Which flights a mean is over.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FlightSet {
    /// The training flights.
    Training,
    /// The held-out flights.
    HeldOut,
    /// Every flight, training and held-out.
    All,
}

impl FlightSet {
    /// In words.
    pub fn name(self) -> &'static str {
        match self {
            FlightSet::Training => "training",
            FlightSet::HeldOut => "held-out",
            FlightSet::All => "every flight's",
        }
    }
}

/// The mean of one quantity over one set of flights, against the flights' scatter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Pattern {
    /// The quantity.
    pub quantity: Quantity,
    /// The flights the mean is over.
    pub set: FlightSet,
    /// Flights in the mean.
    pub flights: usize,
    /// Mean over the flights, in the quantity's unit.
    pub mean: f64,
    /// The flights' scatter σ (for training and held-out means: pooled over both sets, each
    /// around its own mean).
    pub scatter: f64,
    /// Standard error of the mean.
    pub std_error: f64,
    /// mean / standard error.
    pub t: f64,
    /// Smallest |mean| that counts (the quantity's noise floor).
    pub floor: f64,
    /// |t| above the threshold and |mean| at least the floor.
    pub systematic: bool,
}

impl Pattern {
    /// "held-out endurance (predicted − measured) is systematically +6.10 % ± 1.40 % (4
    /// flights, t = 4.4; flight-to-flight scatter 2.4 %)".
    pub fn sentence(&self) -> String {
        let u = self.quantity.unit();
        let (m, s, sc) = if u == "V" {
            (
                format!("{:+.3} V", self.mean),
                format!("{:.3} V", self.std_error),
                format!("{:.3} V", self.scatter),
            )
        } else {
            (
                format!("{:+.2} %", self.mean),
                format!("{:.2} %", self.std_error),
                format!("{:.2} %", self.scatter),
            )
        };
        format!(
            "{} {} is systematically {m} ± {s} ({} flights, t = {:.1}; flight-to-flight scatter {sc})",
            self.set.name(),
            self.quantity.describe(),
            self.flights,
            self.t,
        )
    }
}

/// Tests one quantity's per-flight values (training and held-out, in the quantity's unit): the
/// training mean and the held-out mean against the pooled scatter (see the module's doc).
/// Empty when fewer than two degrees of freedom are left to measure the scatter.
pub fn shared_patterns(
    quantity: Quantity,
    train: &[f64],
    heldout: &[f64],
    floor: f64,
    t_max: f64,
) -> Vec<Pattern> {
    let (nt, nh) = (train.len(), heldout.len());
    let dof = nt.saturating_sub(1) + nh.saturating_sub(1);
    if dof < 2 {
        return Vec::new();
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let ss = |v: &[f64]| {
        let m = mean(v);
        v.iter().map(|x| (x - m).powi(2)).sum::<f64>()
    };
    let scatter = ((ss(train) + ss(heldout)) / dof as f64).sqrt();
    let mut out = Vec::new();
    let mut push = |set: FlightSet, v: &[f64], se: f64| {
        if v.is_empty() {
            return;
        }
        out.push(pattern(quantity, set, v, scatter, se, floor, t_max));
    };
    if nt > 0 {
        push(FlightSet::Training, train, scatter / (nt as f64).sqrt());
    }
    if nh > 0 {
        let inv_nt = if nt > 0 { 1.0 / nt as f64 } else { 0.0 };
        push(
            FlightSet::HeldOut,
            heldout,
            scatter * (1.0 / nh as f64 + inv_nt).sqrt(),
        );
    }
    out
}

/// Tests the mean of one quantity over every flight against its own scatter (σ/√n): for a
/// quantity no fit absorbs. `None` with fewer than three flights.
pub fn pooled_pattern(quantity: Quantity, all: &[f64], floor: f64, t_max: f64) -> Option<Pattern> {
    let n = all.len();
    if n < 3 {
        return None;
    }
    let m = all.iter().sum::<f64>() / n as f64;
    let scatter = (all.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
    Some(pattern(
        quantity,
        FlightSet::All,
        all,
        scatter,
        scatter / (n as f64).sqrt(),
        floor,
        t_max,
    ))
}

fn pattern(
    quantity: Quantity,
    set: FlightSet,
    v: &[f64],
    scatter: f64,
    se: f64,
    floor: f64,
    t_max: f64,
) -> Pattern {
    let m = v.iter().sum::<f64>() / v.len().max(1) as f64;
    let t = if se > 0.0 {
        m / se
    } else if m == 0.0 {
        0.0
    } else {
        f64::INFINITY.copysign(m)
    };
    Pattern {
        quantity,
        set,
        flights: v.len(),
        mean: m,
        scatter,
        std_error: se,
        t,
        floor,
        systematic: t.abs() > t_max && m.abs() >= floor,
    }
}

/// A flight whose endurance the model misses by more than the gross-miss fraction.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GrossMiss {
    /// Flight.
    pub flight: String,
    /// Held out (else training).
    pub heldout: bool,
    /// Predicted, s.
    pub predicted_s: f64,
    /// Measured, s.
    pub measured_s: f64,
}

/// Why the gap left after the selected effects is, or is not, called `unexplained`: the
/// patterns shared by the flights, gross misses and the stability of the selected effects.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct SystematicCheck {
    /// Every quantity tested on each set, systematic or not.
    pub patterns: Vec<Pattern>,
    /// Flights whose endurance the model misses by more than the gross-miss fraction.
    pub gross_misses: Vec<GrossMiss>,
    /// Flights with an endurance (cut-off flights), training and held-out.
    pub flights_with_endurance: usize,
    /// The reasons the gap counts as unexplained, in words with their numbers (empty: it does
    /// not).
    pub reasons: Vec<String>,
}

impl SystematicCheck {
    /// Whether a systematic gap is left.
    pub fn unexplained(&self) -> bool {
        !self.reasons.is_empty()
    }
}

/// The noise floors and thresholds of the check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckOptions {
    /// Endurance floor, %.
    pub endurance_pct: f64,
    /// Energy floor, %.
    pub power_pct: f64,
    /// Power-drift floor, %.
    pub drift_pct: f64,
    /// Voltage floor, V.
    pub voltage_v: f64,
    /// Largest |t| of a shared mean that is still scatter.
    pub t_max: f64,
    /// A flight's endurance missed by more than this fraction is a gross miss.
    pub gross_miss_fraction: f64,
}

/// Runs the check on the residuals after the selected effects. Voltage by thirds is tested
/// only when neither set has current (then the energy and drift are not measured): with
/// current, the voltage shape is left to the learned battery.
pub fn check(
    train: &[FlightResiduals],
    heldout: &[FlightResiduals],
    o: &CheckOptions,
) -> SystematicCheck {
    let values = |q: Quantity, set: &[FlightResiduals]| -> Vec<f64> {
        set.iter()
            .filter_map(|r| q.of(r))
            .filter(|v| v.is_finite())
            .collect()
    };
    let has_current = train
        .iter()
        .chain(heldout)
        .any(|r| !r.phase_power.is_empty());
    let mut patterns = Vec::new();
    for q in Quantity::ALL {
        let floor = match q {
            Quantity::Endurance => o.endurance_pct,
            Quantity::Energy => o.power_pct,
            Quantity::PowerDrift => o.drift_pct,
            _ => o.voltage_v,
        };
        if q.unit() == "V" && has_current {
            continue;
        }
        let (tr, he) = (values(q, train), values(q, heldout));
        if q == Quantity::PowerDrift {
            let all: Vec<f64> = tr.iter().chain(&he).copied().collect();
            patterns.extend(pooled_pattern(q, &all, floor, o.t_max));
        } else {
            patterns.extend(shared_patterns(q, &tr, &he, floor, o.t_max));
        }
    }
    let mut gross_misses = Vec::new();
    let mut flights_with_endurance = 0;
    for (set, heldout_set) in [(train, false), (heldout, true)] {
        for r in set {
            if let Some(e) = r.endurance_error {
                flights_with_endurance += 1;
                if e.abs() > o.gross_miss_fraction {
                    gross_misses.push(GrossMiss {
                        flight: r.name.clone(),
                        heldout: heldout_set,
                        predicted_s: r.endurance.predicted_s,
                        measured_s: r.endurance.measured_s,
                    });
                }
            }
        }
    }
    let mut reasons: Vec<String> = patterns
        .iter()
        .filter(|p| p.systematic)
        .map(Pattern::sentence)
        .collect();
    if let Some(first) = gross_misses.first() {
        reasons.push(format!(
            "the model misses the endurance of {} of {} flights by more than {:.0} % (e.g. {}: {:.0} s predicted, {:.0} s flown)",
            gross_misses.len(),
            flights_with_endurance,
            o.gross_miss_fraction * 100.0,
            first.flight,
            first.predicted_s,
            first.measured_s
        ));
    }
    SystematicCheck {
        patterns,
        gross_misses,
        flights_with_endurance,
        reasons,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn normal(rng: &mut ChaCha8Rng) -> f64 {
        // Box–Muller.
        let (u1, u2): (f64, f64) = (rng.random::<f64>().max(1e-300), rng.random());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    fn draw(rng: &mut ChaCha8Rng, n: usize, shift: f64, sigma: f64) -> Vec<f64> {
        (0..n).map(|_| shift + sigma * normal(rng)).collect()
    }

    #[test]
    fn scatter_alone_is_rarely_systematic_and_a_shared_shift_is_found() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let (mut false_alarms, mut found) = (0, 0);
        let runs = 400;
        for _ in 0..runs {
            // Per-flight scatter of 6 % (a flight controller's current sensor), no shift.
            let tr = draw(&mut rng, 8, 0.0, 6.0);
            let he = draw(&mut rng, 4, 0.0, 6.0);
            let p = shared_patterns(Quantity::Endurance, &tr, &he, 1.0, 3.5);
            false_alarms += usize::from(p.iter().any(|p| p.systematic));
            // The same scatter, and every held-out flight 20 % off.
            let he = draw(&mut rng, 4, 20.0, 6.0);
            let p = shared_patterns(Quantity::Endurance, &tr, &he, 1.0, 3.5);
            found += usize::from(
                p.iter()
                    .any(|p| p.set == FlightSet::HeldOut && p.systematic),
            );
        }
        // Two tests at |t| > 3.5 with 10 degrees of freedom: about 1 % of runs by chance.
        assert!(false_alarms <= runs / 25, "{false_alarms} of {runs}");
        assert!(found >= runs * 9 / 10, "{found} of {runs}");
    }

    #[test]
    fn a_tiny_precise_shift_is_below_the_floor_and_a_large_one_is_not() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        // A shift shared by every flight, training and held-out, of 0.2 % with a scatter of
        // 0.01 %: very significant, but below the 1 % floor.
        let tr = draw(&mut rng, 8, 0.2, 0.01);
        let he = draw(&mut rng, 4, 0.2, 0.01);
        let p = shared_patterns(Quantity::Endurance, &tr, &he, 1.0, 3.5);
        assert!(p.iter().all(|p| p.t.abs() > 3.5 && !p.systematic), "{p:?}");
        // A training shift of 5 % with the same tiny scatter is both.
        let tr = draw(&mut rng, 8, 5.0, 0.01);
        let p = shared_patterns(Quantity::Endurance, &tr, &he, 1.0, 3.5);
        assert!(
            p.iter()
                .any(|p| p.set == FlightSet::Training && p.systematic)
        );
    }

    /// A flight with current: endurance error `e` (fraction), energy error `energy` (fraction
    /// of its energy) and power drift `drift` (fraction).
    fn flight(name: &str, e: f64, energy: f64, drift: f64) -> FlightResiduals {
        use crate::diagnose::{Endurance, PhasePower};
        use crate::flight::Phase;
        FlightResiduals {
            name: name.into(),
            endurance_error: Some(e),
            endurance: Endurance {
                predicted_s: 600.0 * (1.0 + e),
                measured_s: 600.0,
            },
            phase_power: vec![PhasePower {
                phase: Phase::Hover,
                measured_w: 100.0,
                predicted_w: 100.0 * (1.0 + energy),
                time_s: 600.0,
            }],
            voltage_rmse_v: 0.1,
            voltage_by_charge_v: [Some(0.3), Some(-0.3), Some(0.5)],
            voltage_by_phase_v: Vec::new(),
            power_drift: Some(drift),
            chi2: 1000.0,
            n_obs: 10.0,
        }
    }

    fn opts() -> CheckOptions {
        CheckOptions {
            endurance_pct: 1.0,
            power_pct: 1.5,
            drift_pct: 1.0,
            voltage_v: 0.04,
            t_max: 3.5,
            gross_miss_fraction: 0.5,
        }
    }

    /// Flights drawn as a fleet's: per-flight endurance scatter 6 %, energy 5 %, drift 2 %,
    /// plus the shared shifts given.
    fn fleet(
        rng: &mut ChaCha8Rng,
        shift: (f64, f64, f64),
    ) -> (Vec<FlightResiduals>, Vec<FlightResiduals>) {
        let mut one = |k: usize| {
            flight(
                &format!("f{k}"),
                shift.0 + 0.06 * normal(rng),
                shift.1 + 0.05 * normal(rng),
                shift.2 + 0.02 * normal(rng),
            )
        };
        let train = (0..8).map(&mut one).collect();
        let held = (8..12).map(&mut one).collect();
        (train, held)
    }

    #[test]
    fn the_check_passes_scatter_and_flags_a_shared_drift_with_its_numbers() {
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let runs = 200;
        let mut flagged = 0;
        for _ in 0..runs {
            let (tr, he) = fleet(&mut rng, (0.0, 0.0, 0.0));
            let c = check(&tr, &he, &opts());
            // With current logged, the voltage shape is left to the learned battery.
            assert!(c.patterns.iter().all(|p| p.quantity.unit() == "%"));
            assert_eq!(c.patterns.len(), 5);
            flagged += usize::from(c.unexplained());
        }
        // Five tests at |t| > 3.5: a few percent of scatter-only runs at most.
        assert!(flagged <= runs / 20, "{flagged} of {runs}");
        // A payload that drains: the power falls by 5 % from the first to the second half.
        let (tr, he) = fleet(&mut rng, (0.0, 0.0, -0.05));
        let c = check(&tr, &he, &opts());
        assert!(c.unexplained());
        let p = c
            .patterns
            .iter()
            .find(|p| p.quantity == Quantity::PowerDrift)
            .unwrap();
        assert_eq!((p.set, p.flights), (FlightSet::All, 12));
        assert!(p.systematic && (p.mean + 5.0).abs() < 2.0, "{p:?}");
        assert!(
            c.reasons
                .iter()
                .any(|r| r.contains("every flight's measured/predicted power"))
        );
    }

    /// The drift has its own floor, below the energy's: a precise 1.2 % drift shared by every
    /// flight is flagged, a precise 1.2 % energy shift is not.
    #[test]
    fn a_precise_drift_above_its_floor_is_flagged_where_an_energy_shift_is_not() {
        let mut rng = ChaCha8Rng::seed_from_u64(23);
        let precise = |rng: &mut ChaCha8Rng, energy: f64, drift: f64| {
            (0..12)
                .map(|k| {
                    flight(
                        &format!("f{k}"),
                        0.01 * normal(rng),
                        energy + 0.002 * normal(rng),
                        drift + 0.002 * normal(rng),
                    )
                })
                .collect::<Vec<_>>()
        };
        let pattern = |c: &SystematicCheck, q: Quantity| {
            c.patterns
                .iter()
                .filter(|p| p.quantity == q)
                .any(|p| p.systematic)
        };
        let drift = precise(&mut rng, 0.0, 0.012);
        let c = check(&drift[..8], &drift[8..], &opts());
        assert!(pattern(&c, Quantity::PowerDrift), "{:?}", c.patterns);
        let energy = precise(&mut rng, 0.012, 0.0);
        let c = check(&energy[..8], &energy[8..], &opts());
        assert!(!pattern(&c, Quantity::Energy), "{:?}", c.patterns);
        assert!(
            c.patterns
                .iter()
                .any(|p| p.quantity == Quantity::Energy && p.t.abs() > 3.5)
        );
    }

    #[test]
    fn a_flight_predicted_to_fly_nothing_is_a_gross_miss() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (mut tr, he) = fleet(&mut rng, (0.0, 0.0, 0.0));
        tr[3] = flight("3-ceiling-B", -1.0, 0.0, 0.0);
        let c = check(&tr, &he, &opts());
        assert_eq!(c.gross_misses.len(), 1);
        assert_eq!(c.flights_with_endurance, 12);
        assert!(
            c.reasons
                .iter()
                .any(|r| r.contains("1 of 12 flights by more than 50 %")
                    && r.contains("0 s predicted")),
            "{:?}",
            c.reasons
        );
    }

    #[test]
    fn without_current_the_voltage_thirds_are_tested() {
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let (mut tr, mut he) = fleet(&mut rng, (0.0, 0.0, 0.0));
        for (k, r) in tr.iter_mut().chain(he.iter_mut()).enumerate() {
            r.phase_power.clear();
            r.power_drift = None;
            // The late third 0.15 V low on every flight, ±0.03 V.
            let late = -0.15 + 0.03 * if k % 2 == 0 { 1.0 } else { -1.0 };
            r.voltage_by_charge_v = [Some(0.01 * normal(&mut rng)), None, Some(late)];
        }
        let c = check(&tr, &he, &opts());
        assert!(c.patterns.iter().all(|p| p.quantity != Quantity::Energy));
        assert!(
            c.patterns
                .iter()
                .any(|p| p.quantity == Quantity::VoltageLate && p.systematic)
        );
        assert!(
            c.patterns
                .iter()
                .all(|p| p.quantity != Quantity::VoltageEarly || !p.systematic)
        );
    }

    #[test]
    fn too_few_flights_say_nothing() {
        assert!(shared_patterns(Quantity::Energy, &[1.0, 2.0], &[30.0], 1.5, 3.5).is_empty());
        let p = shared_patterns(Quantity::Energy, &[1.0, 2.0, 1.5], &[30.0], 1.5, 3.5);
        assert_eq!(p.len(), 2);
    }

    #[test]
    fn sentences_carry_the_numbers() {
        let p = shared_patterns(
            Quantity::PowerDrift,
            &[-3.0, -4.0, -5.0, -4.0],
            &[-4.5, -3.5],
            1.5,
            3.5,
        );
        let s = p[0].sentence();
        assert!(s.starts_with("training measured/predicted power"), "{s}");
        assert!(s.contains("-4.00 %") && s.contains("(4 flights"), "{s}");
    }
}
