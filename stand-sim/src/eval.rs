//! Scoring a diagnosis blind: scenarios are drawn by seed, the diagnosis sees only their CSV
//! logs, its verdict is compared with the truth afterwards.

use serde::Serialize;

use crate::{Scenario, Truth};

/// What a diagnosis said about one scenario.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Outcome {
    /// Its verdict (`none`, `unexplained`, or effect names).
    pub verdict: Vec<String>,
    /// Held-out error of power before (base model), %.
    pub before_pct: f64,
    /// Held-out error of power after (selected model), %.
    pub after_pct: f64,
    /// Held-out χ² per observation before.
    pub chi2_before: f64,
    /// Held-out χ² per observation after.
    pub chi2_after: f64,
}

/// One scored scenario.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scored {
    /// The scenario (truth, magnitude, impact).
    pub scenario: Scenario,
    /// What the diagnosis said (or why it failed).
    pub outcome: Result<Outcome, String>,
    /// Whether the verdict is right: `none` for none; the effect named first for an effect;
    /// `unexplained` (or `none`) for a truth outside the library.
    pub right: bool,
    /// Held-out shrinkage of the largest-χ² error, (before − after)/before.
    pub shrinkage: Option<f64>,
    /// Whether the selected model is worse on the held-out sweep than the base model.
    pub worse: bool,
}

/// Summary of a study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Seeds run.
    pub seeds: (u64, u64),
    /// Single in-library effects moving power or current by ≥ 2 %: (right, total).
    pub effects_right: (usize, usize),
    /// `none` scenarios: (right, total).
    pub none_right: (usize, usize),
    /// Outside-library scenarios: (said unexplained or none, total).
    pub outside_right: (usize, usize),
    /// Median held-out χ² shrinkage over the in-library effect scenarios (≥ 2 %) diagnosed
    /// right.
    pub median_shrinkage: Option<f64>,
    /// Runs made worse on the held-out sweep.
    pub worse: usize,
    /// Per-truth (right, total).
    pub by_truth: Vec<(&'static str, usize, usize)>,
    /// Failures of the diagnosis (errors), by seed.
    pub errors: Vec<(u64, String)>,
}

/// Scores one scenario's outcome.
pub fn score(scenario: Scenario, outcome: Result<Outcome, String>) -> Scored {
    let (right, shrinkage, worse) = match &outcome {
        Ok(o) => {
            let first = o.verdict.first().map(String::as_str).unwrap_or("none");
            let right = match scenario.truth {
                Truth::None => first == "none",
                Truth::Hysteresis => first == "unexplained" || first == "none",
                t => first == t.label(),
            };
            let shrink = (o.chi2_before > 1.0)
                .then(|| (o.chi2_before - o.chi2_after) / (o.chi2_before - 1.0));
            (right, shrink, o.chi2_after > o.chi2_before * 1.001 + 1e-9)
        }
        Err(_) => (false, None, false),
    };
    Scored {
        scenario,
        outcome,
        right,
        shrinkage,
        worse,
    }
}

/// Summarises scored scenarios.
pub fn summarise(seeds: (u64, u64), runs: &[Scored]) -> Summary {
    let count = |f: &dyn Fn(&Scored) -> bool| {
        let sel: Vec<&Scored> = runs.iter().filter(|r| f(r)).collect();
        (sel.iter().filter(|r| r.right).count(), sel.len())
    };
    let in_library = |r: &Scored| {
        !matches!(r.scenario.truth, Truth::None | Truth::Hysteresis)
            && r.scenario.power_impact >= 0.02
    };
    let mut shr: Vec<f64> = runs
        .iter()
        .filter(|r| in_library(r) && r.right)
        .filter_map(|r| r.shrinkage)
        .collect();
    shr.sort_by(f64::total_cmp);
    Summary {
        seeds,
        effects_right: count(&in_library),
        none_right: count(&|r| r.scenario.truth == Truth::None),
        outside_right: count(&|r| r.scenario.truth == Truth::Hysteresis),
        median_shrinkage: (!shr.is_empty()).then(|| shr[shr.len() / 2]),
        worse: runs.iter().filter(|r| r.worse).count(),
        by_truth: Truth::ALL
            .iter()
            .map(|t| {
                let (a, b) = count(&|r| r.scenario.truth == *t);
                (t.label(), a, b)
            })
            .collect(),
        errors: runs
            .iter()
            .filter_map(|r| {
                r.outcome
                    .as_ref()
                    .err()
                    .map(|e| (r.scenario.seed, e.clone()))
            })
            .collect(),
    }
}
