//! The blind study: draw an effect (or none, or one outside the library) and a magnitude,
//! simulate training and held-out flights with the truth simulator, diagnose without the label,
//! and score.
//!
//! The diagnosis sees only the flights and the rig curve; the truth (`TruthEffect`, the
//! magnitudes, the seed) stays in this module. Thresholds in [`DiagnoseOptions::default`] were
//! tuned on seeds 1000–1199 ([`TUNING_SEEDS`]); reports use seeds from 0 ([`REPORT_SEEDS`]).

use std::ops::Range;

use estimator::PowerCurve;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::diagnose::{DiagnoseOptions, Diagnosis, diagnose};
use crate::flight::{FlightInfo, FlightRecord};
use crate::model::{Effect, Model};
use crate::truth::{FlightPlan, Leg, OutOfLibrary, Robot, Truth, TruthEffect, simulate_with_truth};

/// Seeds the thresholds were tuned on.
pub const TUNING_SEEDS: Range<u64> = 1000..1200;
/// Seeds reports start from.
pub const REPORT_SEEDS: Range<u64> = 0..200;

/// Height of the test hall's ceiling, m.
pub const CEILING_M: f64 = 2.5;

/// Draws the scenario's truth from its seed: 15 % none, 15 % out of the library, 70 % one
/// library effect, magnitudes log-uniform over ranges whose endurance impact runs from well
/// below 1 % to over 10 %.
pub fn draw_truth(seed: u64) -> TruthEffect {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_7277_7468);
    let u: f64 = rng.random();
    let log_uniform = |rng: &mut ChaCha8Rng, lo: f64, hi: f64| {
        let x: f64 = rng.random();
        (lo.ln() + x * (hi.ln() - lo.ln())).exp()
    };
    if u < 0.15 {
        TruthEffect::None
    } else if u < 0.30 {
        if rng.random::<bool>() {
            TruthEffect::OutOfLibrary(OutOfLibrary::MotorHeating, log_uniform(&mut rng, 0.03, 0.2))
        } else {
            TruthEffect::OutOfLibrary(
                OutOfLibrary::HighVoltageCells,
                log_uniform(&mut rng, 0.03, 0.12),
            )
        }
    } else {
        let e = Effect::ALL[rng.random_range(0..Effect::ALL.len())];
        let m = match e {
            Effect::InternalResistance => log_uniform(&mut rng, 0.005, 0.12),
            Effect::CapacityFade => log_uniform(&mut rng, 0.005, 0.2),
            Effect::Peukert => log_uniform(&mut rng, 0.003, 0.08),
            Effect::ControlOverhead => log_uniform(&mut rng, 0.005, 0.2),
            Effect::AttachedPower => log_uniform(&mut rng, 0.1, 4.0),
            Effect::AirDensity => log_uniform(&mut rng, 0.05, 1.0),
            Effect::CeilingEffect => log_uniform(&mut rng, 0.05, 0.5),
            Effect::ClimbPower => log_uniform(&mut rng, 0.2, 3.0),
        };
        TruthEffect::Library(e, m)
    }
}

/// The flight plans of a scenario: training and held-out, varying battery, payload mass and
/// power, air density and mission (hover, ceiling attachment cycles, hovering under the ceiling,
/// climbs), every flight to the cut-off.
pub fn plans(seed: u64) -> (Vec<FlightPlan>, Vec<FlightPlan>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0070_6c61_6e73);
    let missions: [(&str, Vec<Leg>); 4] = [
        (
            "hover",
            vec![Leg::Ground(5.0), Leg::Climb(1.0, 0.5), Leg::HoverToCutoff],
        ),
        (
            "attach",
            vec![
                Leg::Ground(5.0),
                Leg::Climb(1.0, 0.5),
                Leg::Hover(60.0),
                Leg::Climb(CEILING_M, 0.3),
                Leg::Attached(600.0),
                Leg::Descend(1.0, 0.3),
                Leg::Hover(60.0),
                Leg::Climb(CEILING_M, 0.3),
                Leg::Attached(600.0),
                Leg::Descend(1.0, 0.3),
                Leg::HoverToCutoff,
            ],
        ),
        (
            "ceiling",
            vec![
                Leg::Ground(5.0),
                Leg::Climb(CEILING_M - 0.05, 0.5),
                Leg::Hover(150.0),
                Leg::Descend(1.0, 0.5),
                Leg::Hover(30.0),
                Leg::Climb(CEILING_M - 0.05, 0.5),
                Leg::Hover(150.0),
                Leg::Descend(1.0, 0.5),
                Leg::HoverToCutoff,
            ],
        ),
        ("climbs", {
            let mut v = vec![Leg::Ground(5.0), Leg::Climb(0.5, 0.5)];
            for _ in 0..6 {
                v.push(Leg::Climb(2.2, 1.0));
                v.push(Leg::Descend(0.5, 1.0));
            }
            v.push(Leg::HoverToCutoff);
            v
        }),
    ];
    let batteries = [(0.144, 164.0, "A"), (0.085, 172.0, "B")];
    let mut make = |k: usize, mission: usize, battery: usize, payload_kg: f64, payload_w: f64| {
        let (m_b, e_d, id) = batteries[battery];
        let rho = 1.05 + 0.18 * rng.random::<f64>();
        FlightPlan {
            name: format!("{}-{}-{}", k, missions[mission].0, id),
            legs: missions[mission].1.clone(),
            info: FlightInfo {
                structure_mass_kg: 0.431,
                battery_mass_kg: m_b,
                battery_energy_wh: m_b * e_d,
                cells: 3,
                payload_mass_kg: payload_kg,
                payload_power_w: payload_w,
                avionics_power_w: 2.44,
                battery_id: Some(format!("Battery-{id}")),
                battery_cycles: Some(rng.random_range(5..60)),
                ambient_temperature_c: Some(18.0 + 8.0 * rng.random::<f64>()),
                air_density_kg_m3: Some(rho),
                cutoff_voltage_v: 9.0,
                ended_at_cutoff: false,
                ceiling_height_m: Some(CEILING_M),
            },
        }
    };
    let train = vec![
        make(1, 0, 0, 0.0, 0.0),
        make(2, 1, 0, 0.0, 5.0),
        make(3, 2, 1, 0.02, 0.0),
        make(4, 3, 1, 0.0, 5.0),
        make(5, 0, 1, 0.05, 5.0),
        make(6, 1, 1, 0.02, 0.0),
        make(7, 2, 0, 0.0, 5.0),
        make(8, 3, 0, 0.02, 0.0),
    ];
    let held = vec![
        make(9, 0, 0, 0.02, 5.0),
        make(10, 1, 1, 0.05, 0.0),
        make(11, 2, 0, 0.02, 5.0),
        make(12, 3, 1, 0.05, 0.0),
    ];
    (train, held)
}

/// The robot's rig characterisation: its simulated 10 g sweep at 12.5 V fitted with a
/// fifth-order polynomial, as `hoverbench characterise` would produce it.
pub fn rig_curve(robot: &Robot) -> Result<estimator::PolyCurve, crate::GapError> {
    let (x, y) = robot.rig_sweep(12.5, 10.0);
    let f = fit::fit_polynomial(&x, &y, 5)?;
    Ok(estimator::PolyCurve::new(
        f.coeffs_scaled(),
        f.center(),
        f.scale(),
        f.domain(),
        Some(12.5),
    )?)
}

/// The flights of a scenario and their truth.
#[derive(Debug, Clone)]
pub struct GeneratedSet {
    /// Training flights.
    pub train: Vec<FlightRecord>,
    /// Held-out flights.
    pub heldout: Vec<FlightRecord>,
    /// The truth (never given to the diagnosis).
    pub truth: Truth,
}

/// Simulates a scenario's flights with the given truth.
pub fn generate(robot: &Robot, seed: u64, effect: TruthEffect) -> GeneratedSet {
    let (tp, hp) = plans(seed);
    let mut endurance_s = Vec::new();
    let mut run = |plans: &[FlightPlan], salt: u64| -> Vec<FlightRecord> {
        plans
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let (rec, (with, without)) = simulate_with_truth(
                    robot,
                    p,
                    effect,
                    seed.wrapping_mul(1000).wrapping_add(salt + i as u64),
                );
                endurance_s.push((p.name.clone(), with, without));
                rec
            })
            .collect()
    };
    let train = run(&tp, 0);
    let heldout = run(&hp, 100);
    GeneratedSet {
        train,
        heldout,
        truth: Truth {
            effect,
            endurance_s,
        },
    }
}

/// The label a verdict or a truth gets in the confusion matrix.
pub fn label_of_truth(t: &TruthEffect) -> String {
    match t {
        TruthEffect::None => "none".into(),
        TruthEffect::Library(e, _) => e.name().into(),
        TruthEffect::OutOfLibrary(..) => "out_of_library".into(),
    }
}

/// The label of a diagnosis.
pub fn label_of_verdict(d: &Diagnosis) -> String {
    if d.unexplained {
        "unexplained".into()
    } else if d.verdict.is_empty() {
        "none".into()
    } else {
        d.verdict
            .iter()
            .map(|e| e.name())
            .collect::<Vec<_>>()
            .join("+")
    }
}

/// One scored scenario.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScenarioResult {
    /// Seed.
    pub seed: u64,
    /// Truth label.
    pub truth: String,
    /// Truth magnitude (0 for none).
    pub magnitude: f64,
    /// Mean endurance impact of the truth effect, %.
    pub impact_pct: f64,
    /// Verdict label.
    pub verdict: String,
    /// Verdict right.
    pub correct: bool,
    /// Held-out headline gap before and after.
    pub heldout_before: f64,
    /// After.
    pub heldout_after: f64,
}

impl ScenarioResult {
    /// Held-out gap shrinkage, 0..1 (negative when it grew).
    pub fn shrinkage(&self) -> f64 {
        if self.heldout_before > 0.0 {
            1.0 - self.heldout_after / self.heldout_before
        } else {
            0.0
        }
    }
}

/// Runs one scenario blind and scores it.
pub fn run_scenario<C: PowerCurve>(
    robot: &Robot,
    model: Model<'_, C>,
    seed: u64,
    opts: &DiagnoseOptions,
) -> ScenarioResult {
    let truth = draw_truth(seed);
    let set = generate(robot, seed, truth);
    let train: Vec<&FlightRecord> = set.train.iter().collect();
    let held: Vec<&FlightRecord> = set.heldout.iter().collect();
    // Blind: only flights and the rig curve go in.
    let d = match diagnose(model, &train, &held, opts) {
        Ok(d) => d,
        Err(e) => {
            return ScenarioResult {
                seed,
                truth: label_of_truth(&truth),
                magnitude: 0.0,
                impact_pct: set.truth.endurance_impact_pct(),
                verdict: format!("error: {e}"),
                correct: false,
                heldout_before: f64::NAN,
                heldout_after: f64::NAN,
            };
        }
    };
    let t = label_of_truth(&truth);
    let v = label_of_verdict(&d);
    let correct = match truth {
        TruthEffect::OutOfLibrary(..) => d.unexplained,
        _ => t == v,
    };
    ScenarioResult {
        seed,
        truth: t,
        magnitude: match truth {
            TruthEffect::None => 0.0,
            TruthEffect::Library(_, m) | TruthEffect::OutOfLibrary(_, m) => m,
        },
        impact_pct: set.truth.endurance_impact_pct(),
        verdict: v,
        correct,
        heldout_before: d.baseline.heldout.headline(),
        heldout_after: d.after.heldout.headline(),
    }
}

/// Summary of a blind study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StudyReport {
    /// Seeds run.
    pub seeds: (u64, u64),
    /// Every scenario.
    pub scenarios: Vec<ScenarioResult>,
    /// Confusion matrix: (truth, verdict, count).
    pub confusion: Vec<(String, String, usize)>,
    /// Correct verdicts for single library effects with |impact| ≥ 2 %, fraction.
    pub single_effect_accuracy_2pct: Option<f64>,
    /// Detection rate by |impact| bin: (bin, scenarios, correct fraction).
    pub detection_by_impact: Vec<(String, usize, f64)>,
    /// False positives on `none`, fraction.
    pub false_positive_rate_none: Option<f64>,
    /// `unexplained` on out-of-library effects, fraction.
    pub unexplained_rate_out_of_library: Option<f64>,
    /// Median held-out gap shrinkage when the verdict is right (library effects), fraction.
    pub median_shrinkage_when_right: Option<f64>,
}

fn frac(v: &[bool]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().filter(|x| **x).count() as f64 / v.len() as f64)
}

/// Scores a set of scenario results.
pub fn summarise(seeds: (u64, u64), scenarios: Vec<ScenarioResult>) -> StudyReport {
    let mut confusion: Vec<(String, String, usize)> = Vec::new();
    for s in &scenarios {
        match confusion
            .iter_mut()
            .find(|(t, v, _)| *t == s.truth && *v == s.verdict)
        {
            Some(c) => c.2 += 1,
            None => confusion.push((s.truth.clone(), s.verdict.clone(), 1)),
        }
    }
    confusion.sort();
    let is_lib = |s: &ScenarioResult| s.truth != "none" && s.truth != "out_of_library";
    let single: Vec<bool> = scenarios
        .iter()
        .filter(|s| is_lib(s) && s.impact_pct.abs() >= 2.0)
        .map(|s| s.correct)
        .collect();
    let bins = [
        (0.0, 1.0, "<1 %"),
        (1.0, 2.0, "1–2 %"),
        (2.0, 5.0, "2–5 %"),
        (5.0, 10.0, "5–10 %"),
        (10.0, f64::INFINITY, "≥10 %"),
    ];
    let detection_by_impact = bins
        .iter()
        .map(|(lo, hi, name)| {
            let v: Vec<bool> = scenarios
                .iter()
                .filter(|s| is_lib(s) && s.impact_pct.abs() >= *lo && s.impact_pct.abs() < *hi)
                .map(|s| s.correct)
                .collect();
            ((*name).to_owned(), v.len(), frac(&v).unwrap_or(0.0))
        })
        .collect();
    let none: Vec<bool> = scenarios
        .iter()
        .filter(|s| s.truth == "none")
        .map(|s| s.verdict != "none")
        .collect();
    let ool: Vec<bool> = scenarios
        .iter()
        .filter(|s| s.truth == "out_of_library")
        .map(|s| s.verdict == "unexplained")
        .collect();
    let mut shr: Vec<f64> = scenarios
        .iter()
        .filter(|s| is_lib(s) && s.correct)
        .map(ScenarioResult::shrinkage)
        .collect();
    shr.sort_by(f64::total_cmp);
    StudyReport {
        seeds,
        single_effect_accuracy_2pct: frac(&single),
        detection_by_impact,
        false_positive_rate_none: frac(&none),
        unexplained_rate_out_of_library: frac(&ool),
        median_shrinkage_when_right: (!shr.is_empty()).then(|| shr[shr.len() / 2]),
        confusion,
        scenarios,
    }
}

/// Runs scenarios `seeds` on `threads` threads (results in seed order).
pub fn study<C: PowerCurve + Sync>(
    robot: &Robot,
    curve: &C,
    rotor_count: u8,
    seeds: Range<u64>,
    opts: &DiagnoseOptions,
    threads: usize,
    progress: &(dyn Fn(usize) + Sync),
) -> StudyReport {
    let all: Vec<u64> = seeds.clone().collect();
    let threads = threads.max(1).min(all.len().max(1));
    let done = std::sync::atomic::AtomicUsize::new(0);
    let mut results: Vec<ScenarioResult> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let all = &all;
                let done = &done;
                s.spawn(move || {
                    let model = Model { curve, rotor_count };
                    all.iter()
                        .skip(t)
                        .step_by(threads)
                        .map(|&seed| {
                            let r = run_scenario(robot, model, seed, opts);
                            let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                            progress(n);
                            r
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_default())
            .collect()
    });
    results.sort_by_key(|r| r.seed);
    summarise((seeds.start, seeds.end), results)
}
