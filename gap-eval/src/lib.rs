//! The blind study of the gap diagnosis, on worlds from the independent truth simulator.
//!
//! Per scenario: a world family and an effect (or none, or one outside the diagnosis's
//! library) with its magnitude are drawn from the seed; `flight-sim` renders the training and
//! held-out flights as flight-log CSV files with TOML sidecars and sweeps the robot's rotor on a
//! rig; the study reads the files back with `flightlog` (as `hoverbench gap` would), fits the rig
//! curve (as `hoverbench characterise` would), hands flights and curve to the diagnosis through
//! [`adapter`] — the only module that calls `gap` — and scores the verdict against the truth,
//! which never leaves this crate.
//!
//! Families ([`flight_sim::Family`]: chemistry × logging × robot) are split into those the
//! diagnosis may be tuned on ([`is_tuning_family`]) and those held out; reports give every family
//! and the roll-ups, held-out first.
//!
//! Main items: [`run_scenario`] (one scored [`ScenarioResult`]), [`study`] (many, on threads,
//! summarised per family in a [`StudyReport`]).
//!
//! ```no_run
//! use gap_eval::{StudyOptions, study};
//!
//! let report = study(&StudyOptions { seeds: 0..20, ..StudyOptions::default() }, &|_| {})?;
//! for row in &report.groups {
//!     println!("{} {:?}", row.name, row.strict_rate());
//! }
//! # Ok::<(), gap_eval::EvalError>(())
//! ```

pub mod adapter;
pub mod oracle;

use std::ops::Range;
use std::path::Path;

use estimator::PolyCurve;
use flight_sim::{
    Chemistry, EffectKind, Family, Logging, RigSweep, RobotVariant, SimFlight, Truth, draw_effect,
    generate,
};
use flightlog::summary::error_chain;
use flightlog::{Flight, FlightMeta, LogFormat};
pub use gap::diagnose::UnexplainedRule;
use serde::Serialize;

/// What can go wrong in the study.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// A simulated file did not read back (a bug of the simulator or the reader).
    #[error("reading back simulated flight {name}: {message}")]
    ReadBack {
        /// Flight.
        name: String,
        /// Reader's message.
        message: String,
    },
    /// Fitting the rig curve failed.
    #[error("fitting the rig curve: {0}")]
    Rig(String),
    /// The diagnosis refused the flights.
    #[error("diagnosis: {0}")]
    Diagnosis(String),
    /// No family matches the filter.
    #[error(
        "no world family matches {0:?} (families are chemistry/logging/robot, e.g. lfp/*/paper)"
    )]
    NoFamily(String),
}

/// Whether the diagnosis may be tuned on a family: LiPo and Li-ion NMC packs, logged at 1 Hz in
/// the lab or 10 Hz by a flight controller with a current sensor, on the paper's robot. Every
/// other family is held out: LiHV, NCA and LiFePO4 entirely, voltage-only and 50 Hz blackbox
/// logs entirely, and every varied robot.
pub fn is_tuning_family(f: &Family) -> bool {
    matches!(f.chemistry, Chemistry::LiPo | Chemistry::Nmc)
        && matches!(f.logging, Logging::Lab1Hz | Logging::Fc10Hz)
        && f.robot == RobotVariant::Paper
}

/// Families matching a comma-separated filter: family patterns (`lfp`, `*/fc-10hz`,
/// `lipo/lab-1hz/paper`), `tuning`, `heldout` (by [`is_tuning_family`]), or `all`.
pub fn select_families(filter: &str) -> Result<Vec<Family>, EvalError> {
    Family::select(filter, is_tuning_family).map_err(|e| EvalError::NoFamily(e.0))
}

/// Reads simulated flights back from their file bytes, exactly as from a folder: the CSV by the
/// flight-log reader, the sidecar merged over the format's defaults.
pub fn read_back(flights: &[SimFlight]) -> Result<Vec<Flight>, EvalError> {
    flights
        .iter()
        .map(|f| {
            let csv_path = format!("{}.csv", f.name);
            let toml_path = format!("{}.toml", f.name);
            let err = |e: flightlog::FlightLogError| EvalError::ReadBack {
                name: f.name.clone(),
                message: error_chain(&e),
            };
            let mut flight = Flight::parse(f.csv.as_bytes(), Path::new(&csv_path), LogFormat::Csv)
                .map_err(err)?;
            let meta = FlightMeta::parse(&f.toml, Path::new(&toml_path)).map_err(err)?;
            flight.meta = meta.merged_over(&flight.meta);
            Ok(flight)
        })
        .collect()
}

/// The rig characterisation a user would make from the sweep: a fifth-order least-squares
/// polynomial of power against thrust, valid at the sweep's voltage.
pub fn rig_curve(rig: &RigSweep) -> Result<PolyCurve, EvalError> {
    let f = fit::fit_polynomial(&rig.thrust_g, &rig.power_w, 5)
        .map_err(|e| EvalError::Rig(e.to_string()))?;
    PolyCurve::new(
        f.coeffs_scaled(),
        f.center(),
        f.scale(),
        f.domain(),
        Some(rig.voltage_v),
    )
    .map_err(|e| EvalError::Rig(e.to_string()))
}

/// The world family of a seed among `families`.
pub fn family_of(seed: u64, families: &[Family]) -> Family {
    families[(seed % families.len() as u64) as usize]
}

/// Smallest endurance impact, %, for a library effect to count in the strict score.
pub const STRICT_IMPACT_PCT: f64 = 2.0;
/// A held-out endurance error made worse by more than this many percentage points is flagged.
pub const WORSE_FLAG_PP: f64 = 0.25;

/// One scored scenario.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScenarioResult {
    /// Seed.
    pub seed: u64,
    /// World family.
    pub family: String,
    /// Whether the family is one the diagnosis may be tuned on.
    pub tuning: bool,
    /// The truth: effect name (`none`, a library name, or an outside effect's name).
    pub truth: String,
    /// Whether the truth is outside the diagnosis's library.
    pub outside_library: bool,
    /// The truth's magnitude in its own unit.
    pub magnitude: f64,
    /// Unit of the magnitude.
    pub unit: String,
    /// Mean endurance impact of the truth effect, %.
    pub impact_pct: f64,
    /// Verdict: selected effects joined by `+`, `none`, and ` (unexplained)` when flagged.
    pub verdict: String,
    /// The selected effect with the largest share of the gap.
    pub top_effect: Option<String>,
    /// Flagged `unexplained` (by the rule the study runs).
    pub unexplained: bool,
    /// Why, in the diagnosis's words with its numbers.
    pub unexplained_reasons: Vec<String>,
    /// What the χ² rule says, whichever rule the study runs.
    pub unexplained_by_chi2: bool,
    /// What the systematic rule says, whichever rule the study runs.
    pub unexplained_by_systematic: bool,
    /// Counted in the strict score (none, outside, or a library effect with impact ≥ 2 %).
    pub strict_scored: bool,
    /// Strictly right.
    pub strict_correct: bool,
    /// Held-out endurance error before and after, %.
    pub heldout_endurance_before_pct: Option<f64>,
    /// After.
    pub heldout_endurance_after_pct: Option<f64>,
    /// Headline held-out gap before and after (as the diagnosis defines it).
    pub heldout_headline: (f64, f64),
    /// Why a strictly scored library effect was missed (`None` when right or not such a run).
    pub miss: Option<Miss>,
    /// What the effect search saw (every effect alone, the combinations tried).
    pub search: adapter::SearchEvidence,
    /// Effects the diagnosis lists as fitting these flights as well as its verdict.
    pub look_alikes: Vec<String>,
    /// The hover power the diagnosis estimated from the training flights, W (a study without
    /// the rig, [`Baseline::FromFlights`]).
    pub estimated_hover_power_w: Option<f64>,
}

/// Where the effect search lost a library effect it should have named: the study's account,
/// read against the truth from what the search saw ([`adapter::SearchEvidence`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Miss {
    /// The step that lost it.
    pub cause: MissCause,
    /// The numbers behind the cause, in words.
    pub detail: String,
    /// The true effect fitted alone (on the training flights) would have lowered the held-out
    /// endurance error below the baseline's (`None`: no cut-off flight held out, or the effect
    /// was not fitted).
    pub true_alone_helps: Option<bool>,
}

/// The step of the effect search that lost a library effect, first that applies in this order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MissCause {
    /// The baseline's training χ² was within noise: nothing is searched.
    WithinNoise,
    /// The effect is not observable on these training flights (e.g. no perching phase).
    NotObservable,
    /// Fitted alone, it lowers the training χ² by less than the search's smallest step.
    BelowSensitivity,
    /// Named, but another selected effect has the larger share of the gap.
    OutShared,
    /// An extra resistance selected but within a healthy pack's band, so kept unnamed.
    KeptUnnamed,
    /// Selected on the training flights, dropped on the held-out ones.
    DroppedOnHeldout,
    /// Another effect alone fits the training flights better.
    Outranked,
    /// The best single on the training flights, but no effect passed cross-validation.
    NotCrossValidated,
    /// The best single on the training flights, but another of the three best had the lower
    /// cross-validated χ².
    OutrankedInCrossValidation,
}

impl MissCause {
    /// Snake-case name, as in the JSON.
    pub fn name(self) -> &'static str {
        match self {
            Self::WithinNoise => "within_noise",
            Self::NotObservable => "not_observable",
            Self::BelowSensitivity => "below_sensitivity",
            Self::OutShared => "out_shared",
            Self::KeptUnnamed => "kept_unnamed",
            Self::DroppedOnHeldout => "dropped_on_heldout",
            Self::Outranked => "outranked",
            Self::NotCrossValidated => "not_cross_validated",
            Self::OutrankedInCrossValidation => "outranked_in_cross_validation",
        }
    }
}

/// Why the search missed `truth` (a library effect's name) on an outcome whose top effect is not
/// it.
pub fn classify_miss(truth: &str, o: &adapter::Outcome) -> Miss {
    let ev = &o.search;
    let alone = ev.singles.iter().find(|s| s.effect == truth);
    let true_alone_helps =
        alone.and_then(|a| Some(a.heldout_endurance_pct? < o.heldout_endurance_before_pct?));
    let miss = |cause, detail: String| Miss {
        cause,
        detail,
        true_alone_helps,
    };
    if ev.within_noise {
        return miss(
            MissCause::WithinNoise,
            format!("baseline training χ² {:.1} within noise", ev.baseline_chi2),
        );
    }
    let Some(alone) = alone else {
        return miss(
            MissCause::NotObservable,
            format!("{truth} not observable on the training flights"),
        );
    };
    let drop = ev.baseline_chi2 - alone.chi2;
    if drop < ev.min_delta_chi2 {
        return miss(
            MissCause::BelowSensitivity,
            format!(
                "{truth} alone lowers the training χ² by {drop:.1} (the search's step {:.0})",
                ev.min_delta_chi2
            ),
        );
    }
    if o.verdict.iter().any(|v| v == truth) {
        return miss(
            MissCause::OutShared,
            format!("verdict {}", o.verdict.join("+")),
        );
    }
    if truth == "internal_resistance" && ev.resistance_kept_unnamed {
        return miss(
            MissCause::KeptUnnamed,
            "selected within a healthy pack's resistance".to_owned(),
        );
    }
    if ev.dropped_on_heldout.iter().any(|v| v == truth) {
        return miss(
            MissCause::DroppedOnHeldout,
            format!("verdict {}", verdict_words(&o.verdict)),
        );
    }
    let best = &ev.singles[0];
    if best.effect != truth {
        return miss(
            MissCause::Outranked,
            format!(
                "{} alone fits the training flights better by χ² {:.1} ({truth} lowers it by {drop:.1})",
                best.effect,
                alone.chi2 - best.chi2
            ),
        );
    }
    if o.verdict.is_empty() {
        miss(
            MissCause::NotCrossValidated,
            format!(
                "cross-validated χ² {} against the baseline's step {:.0}",
                alone
                    .cv_chi2
                    .map_or("not computed".to_owned(), |c| format!("{c:.1}")),
                ev.min_delta_chi2
            ),
        )
    } else {
        miss(
            MissCause::OutrankedInCrossValidation,
            format!("verdict {}", o.verdict.join("+")),
        )
    }
}

fn verdict_words(v: &[String]) -> String {
    if v.is_empty() {
        "none".to_owned()
    } else {
        v.join("+")
    }
}

impl ScenarioResult {
    /// Whether no effect was selected (the verdict `none`, flagged or not).
    pub fn verdict_effects_empty(&self) -> bool {
        self.verdict == "none" || self.verdict == "none (unexplained)"
    }

    /// How much the held-out endurance error grew, percentage points (≤ 0: not worse).
    pub fn worse_by_pp(&self) -> Option<f64> {
        Some(self.heldout_endurance_after_pct? - self.heldout_endurance_before_pct?)
    }

    /// Held-out gap shrinkage, fraction (negative when it grew): on endurance when known.
    pub fn shrinkage(&self) -> f64 {
        let (b, a) = match (
            self.heldout_endurance_before_pct,
            self.heldout_endurance_after_pct,
        ) {
            (Some(b), Some(a)) => (b, a),
            _ => self.heldout_headline,
        };
        if b > 0.0 { 1.0 - a / b } else { 0.0 }
    }
}

/// Scores an outcome against the truth.
pub fn score(truth: &Truth, family: &Family, o: &adapter::Outcome) -> ScenarioResult {
    let kind = truth.effect.kind;
    let impact = truth.endurance_impact_pct();
    let top = o
        .shares
        .iter()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(n, _)| n.clone());
    let outside = !kind.named_in_library() && kind != EffectKind::None;
    let (strict_scored, strict_correct) = if kind == EffectKind::None {
        (true, o.verdict.is_empty() && !o.unexplained)
    } else if outside {
        (true, o.unexplained)
    } else if impact.abs() >= STRICT_IMPACT_PCT {
        (true, top.as_deref() == Some(kind.name()))
    } else {
        (false, top.as_deref() == Some(kind.name()))
    };
    let mut verdict = if o.verdict.is_empty() {
        "none".to_owned()
    } else {
        o.verdict.join("+")
    };
    if o.unexplained {
        verdict.push_str(" (unexplained)");
    }
    ScenarioResult {
        seed: truth.seed,
        family: family.name(),
        tuning: is_tuning_family(family),
        truth: kind.name().to_owned(),
        outside_library: outside,
        magnitude: truth.effect.magnitude,
        unit: truth.unit.to_owned(),
        impact_pct: impact,
        verdict,
        top_effect: top,
        unexplained: o.unexplained,
        unexplained_reasons: o.unexplained_reasons.clone(),
        unexplained_by_chi2: o.unexplained_by_chi2,
        unexplained_by_systematic: o.unexplained_by_systematic,
        strict_scored,
        strict_correct,
        heldout_endurance_before_pct: o.heldout_endurance_before_pct,
        heldout_endurance_after_pct: o.heldout_endurance_after_pct,
        heldout_headline: o.heldout_headline,
        miss: (strict_scored
            && !strict_correct
            && kind.named_in_library()
            && kind != EffectKind::None)
            .then(|| classify_miss(kind.name(), o)),
        search: o.search.clone(),
        look_alikes: o.look_alikes.clone(),
        estimated_hover_power_w: o.estimated_hover_power_w,
    }
}

/// Runs one scenario blind and scores it: the family from `families` and the effect from the
/// seed.
pub fn run_scenario(seed: u64, families: &[Family]) -> Result<ScenarioResult, EvalError> {
    run_scenario_with(seed, families, UnexplainedRule::default())
}

/// [`run_scenario`] with the rule that sets the diagnosis's `unexplained` flag.
pub fn run_scenario_with(
    seed: u64,
    families: &[Family],
    rule: UnexplainedRule,
) -> Result<ScenarioResult, EvalError> {
    run_scenario_oracle(seed, families, rule, oracle::BatteryOracle::Off)
}

/// [`run_scenario_with`] with an oracle-battery experiment switch ([`oracle`]; `Off`: the same
/// run).
pub fn run_scenario_oracle(
    seed: u64,
    families: &[Family],
    rule: UnexplainedRule,
    battery_oracle: oracle::BatteryOracle,
) -> Result<ScenarioResult, EvalError> {
    run_scenario_full(seed, families, rule, battery_oracle, Baseline::Rig)
}

/// Where the diagnosis's baseline power comes from in a study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Baseline {
    /// The rig sweep flight-sim writes beside the flights, fitted as `hoverbench fit` would
    /// (the default).
    #[default]
    Rig,
    /// No rig: the hover power estimated from the training flights, as `hoverbench gap` does
    /// without `--params` (a user who never put the robot's rotor on a stand).
    FromFlights,
}

/// [`run_scenario_oracle`] with the baseline's source.
pub fn run_scenario_full(
    seed: u64,
    families: &[Family],
    rule: UnexplainedRule,
    battery_oracle: oracle::BatteryOracle,
    baseline: Baseline,
) -> Result<ScenarioResult, EvalError> {
    let family = family_of(seed, families);
    let effect = draw_effect(seed);
    let mut set = generate(&family, &effect, seed);
    // Kept until the flights are diagnosed: the measured curve's file, when the oracle writes one.
    let _curve_file = oracle::apply(
        battery_oracle,
        &family,
        seed,
        &mut set,
        &std::env::temp_dir(),
    )?;
    let train = read_back(&set.train)?;
    let heldout = read_back(&set.heldout)?;
    let curve = rig_curve(&set.rig)?;
    // Blind: flights (read from their files, the hall's ceiling in their metadata), the rig
    // curve and the rotors.
    let o = match baseline {
        Baseline::Rig => {
            adapter::diagnose_blind_with(&train, &heldout, &curve, set.rig.rotor_count, rule)?
        }
        Baseline::FromFlights => adapter::diagnose_blind_without_rig(&train, &heldout, rule)?,
    };
    Ok(score(&set.truth, &family, &o))
}

/// `none` right and outside flagged under each rule for `unexplained`: ((runs, right), (runs,
/// flagged)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RuleScores {
    /// Under the χ² rule.
    pub chi2: ((usize, usize), (usize, usize)),
    /// Under the systematic rule.
    pub systematic: ((usize, usize), (usize, usize)),
}

/// A group of scenarios (a family or a roll-up) and its scores.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GroupSummary {
    /// Family name or roll-up (`held-out`, `tuning`, `chemistry lfp`, …).
    pub name: String,
    /// `held out` (every family in it held out from tuning), `tuning` (every one a tuning
    /// family) or `mixed`.
    pub split: &'static str,
    /// Scenarios.
    pub scenarios: usize,
    /// Strictly scored scenarios and the right ones.
    pub strict: (usize, usize),
    /// Library effects with impact ≥ 2 %: scenarios, top effect right.
    pub library: (usize, usize),
    /// `none`: scenarios, empty verdict and not unexplained.
    pub none: (usize, usize),
    /// Outside the library: scenarios, flagged unexplained.
    pub outside: (usize, usize),
    /// `none` right and outside flagged as each rule for `unexplained` would score them,
    /// whichever rule the study ran: χ² rule (none, outside), systematic rule (none, outside).
    pub by_rule: RuleScores,
    /// Runs whose held-out endurance error got worse, and by more than 0.25 pp.
    pub worse: (usize, usize),
    /// Largest growth of the held-out endurance error, pp.
    pub max_worse_pp: Option<f64>,
    /// Median held-out shrinkage over library effects with impact ≥ 2 %, fraction.
    pub median_shrinkage: Option<f64>,
    /// The library effects with impact ≥ 2 % that were missed, by the step that lost them
    /// ([`MissCause`]): (cause, runs, runs where the true effect alone would have lowered the
    /// held-out endurance error).
    pub library_misses: Vec<(MissCause, usize, usize)>,
    /// Library effects with impact ≥ 2 % whose truth is the top effect or among the
    /// look-alikes the diagnosis lists: (runs, such runs).
    pub library_named_or_look_alike: (usize, usize),
    /// `none` worlds with an empty verdict that still list look-alikes: (runs with an empty
    /// verdict, such runs).
    pub none_with_look_alikes: (usize, usize),
}

fn rate(p: (usize, usize)) -> Option<f64> {
    (p.0 > 0).then(|| p.1 as f64 / p.0 as f64)
}

impl GroupSummary {
    /// Strict rate.
    pub fn strict_rate(&self) -> Option<f64> {
        rate(self.strict)
    }

    /// Library rate (impact ≥ 2 %).
    pub fn library_rate(&self) -> Option<f64> {
        rate(self.library)
    }

    /// Right on `none`.
    pub fn none_rate(&self) -> Option<f64> {
        rate(self.none)
    }

    /// `unexplained` outside the library.
    pub fn outside_rate(&self) -> Option<f64> {
        rate(self.outside)
    }

    fn of(name: String, rs: &[&ScenarioResult]) -> Self {
        let count = |f: &dyn Fn(&ScenarioResult) -> bool, g: &dyn Fn(&ScenarioResult) -> bool| {
            let sel: Vec<&&ScenarioResult> = rs.iter().filter(|r| f(r)).collect();
            (sel.len(), sel.iter().filter(|r| g(r)).count())
        };
        let lib = |r: &ScenarioResult| {
            !r.outside_library && r.truth != "none" && r.impact_pct.abs() >= STRICT_IMPACT_PCT
        };
        let worse: Vec<f64> = rs.iter().filter_map(|r| r.worse_by_pp()).collect();
        let mut shr: Vec<f64> = rs
            .iter()
            .filter(|r| lib(r))
            .map(|r| r.shrinkage())
            .collect();
        shr.sort_by(f64::total_cmp);
        let mut library_misses: Vec<(MissCause, usize, usize)> = Vec::new();
        for m in rs.iter().filter_map(|r| r.miss.as_ref()) {
            let helps = usize::from(m.true_alone_helps == Some(true));
            match library_misses.iter_mut().find(|c| c.0 == m.cause) {
                Some(c) => {
                    c.1 += 1;
                    c.2 += helps;
                }
                None => library_misses.push((m.cause, 1, helps)),
            }
        }
        library_misses.sort();
        Self {
            name,
            split: if rs.iter().all(|r| !r.tuning) {
                "held out"
            } else if rs.iter().all(|r| r.tuning) {
                "tuning"
            } else {
                "mixed"
            },
            scenarios: rs.len(),
            strict: count(&|r| r.strict_scored, &|r| r.strict_correct),
            library: count(&lib, &|r| r.strict_correct),
            none: count(&|r| r.truth == "none", &|r| r.strict_correct),
            outside: count(&|r| r.outside_library, &|r| r.strict_correct),
            by_rule: RuleScores {
                chi2: (
                    count(&|r| r.truth == "none", &|r| {
                        r.verdict_effects_empty() && !r.unexplained_by_chi2
                    }),
                    count(&|r| r.outside_library, &|r| r.unexplained_by_chi2),
                ),
                systematic: (
                    count(&|r| r.truth == "none", &|r| {
                        r.verdict_effects_empty() && !r.unexplained_by_systematic
                    }),
                    count(&|r| r.outside_library, &|r| r.unexplained_by_systematic),
                ),
            },
            worse: (
                worse.iter().filter(|w| **w > 1e-9).count(),
                worse.iter().filter(|w| **w > WORSE_FLAG_PP).count(),
            ),
            max_worse_pp: worse.iter().copied().reduce(f64::max),
            median_shrinkage: (!shr.is_empty()).then(|| {
                let n = shr.len();
                if n % 2 == 1 {
                    shr[n / 2]
                } else {
                    0.5 * (shr[n / 2 - 1] + shr[n / 2])
                }
            }),
            library_misses,
            library_named_or_look_alike: count(&lib, &|r| {
                r.strict_correct || r.look_alikes.contains(&r.truth)
            }),
            none_with_look_alikes: count(
                &|r| r.truth == "none" && r.verdict_effects_empty(),
                &|r| !r.look_alikes.is_empty(),
            ),
        }
    }
}

/// Options of a study.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyOptions {
    /// Seeds (one scenario each).
    pub seeds: Range<u64>,
    /// Families scenarios are drawn from (round robin by seed).
    pub families: Vec<Family>,
    /// Worker threads.
    pub threads: usize,
    /// The rule that sets the diagnosis's `unexplained` flag.
    pub unexplained_rule: UnexplainedRule,
    /// Where the baseline's power comes from.
    pub baseline: Baseline,
}

impl Default for StudyOptions {
    fn default() -> Self {
        Self {
            seeds: 0..200,
            families: Family::all(),
            threads: 2,
            unexplained_rule: UnexplainedRule::default(),
            baseline: Baseline::Rig,
        }
    }
}

/// The study's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StudyReport {
    /// Seeds run.
    pub seeds: (u64, u64),
    /// Families held out from tuning (of those run).
    pub heldout_families: Vec<String>,
    /// Families the diagnosis may be tuned on (of those run).
    pub tuning_families: Vec<String>,
    /// Roll-ups (held-out, tuning, by chemistry, logging, robot) then every family.
    pub groups: Vec<GroupSummary>,
    /// Confusion: (truth, verdict, count).
    pub confusion: Vec<(String, String, usize)>,
    /// Every scenario.
    pub scenarios: Vec<ScenarioResult>,
    /// Scenarios that failed to run, with the reason.
    pub failed: Vec<(u64, String)>,
}

/// Summarises scored scenarios.
pub fn summarise(
    seeds: (u64, u64),
    families: &[Family],
    scenarios: Vec<ScenarioResult>,
    failed: Vec<(u64, String)>,
) -> StudyReport {
    let mut groups = Vec::new();
    let pick = |f: &dyn Fn(&ScenarioResult) -> bool| -> Vec<&ScenarioResult> {
        scenarios.iter().filter(|r| f(r)).collect()
    };
    let mut push = |name: String, rs: Vec<&ScenarioResult>| {
        if !rs.is_empty() {
            groups.push(GroupSummary::of(name, &rs));
        }
    };
    push("all held-out families".into(), pick(&|r| !r.tuning));
    push("all tuning families".into(), pick(&|r| r.tuning));
    for c in Chemistry::ALL {
        let p = format!("{}/", c.name());
        push(
            format!("chemistry {}", c.name()),
            pick(&|r| r.family.starts_with(&p)),
        );
    }
    for l in Logging::ALL {
        let p = format!("/{}/", l.name());
        push(
            format!("logging {}", l.name()),
            pick(&|r| r.family.contains(&p)),
        );
    }
    for v in RobotVariant::ALL {
        let p = format!("/{}", v.name());
        push(
            format!("robot {}", v.name()),
            pick(&|r| r.family.ends_with(&p)),
        );
    }
    for f in families {
        let n = f.name();
        push(n.clone(), pick(&|r| r.family == n));
    }
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
    StudyReport {
        seeds,
        heldout_families: families
            .iter()
            .filter(|f| !is_tuning_family(f))
            .map(Family::name)
            .collect(),
        tuning_families: families
            .iter()
            .filter(|f| is_tuning_family(f))
            .map(Family::name)
            .collect(),
        groups,
        confusion,
        scenarios,
        failed,
    }
}

/// Runs the study on `opts.threads` threads; `progress(n)` after each finished scenario.
pub fn study(
    opts: &StudyOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<StudyReport, EvalError> {
    study_with_oracle(opts, oracle::BatteryOracle::Off, progress)
}

/// [`study`] with an oracle-battery experiment switch ([`oracle`]; `Off`: the same study).
pub fn study_with_oracle(
    opts: &StudyOptions,
    battery_oracle: oracle::BatteryOracle,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<StudyReport, EvalError> {
    if opts.families.is_empty() {
        return Err(EvalError::NoFamily(String::new()));
    }
    let all: Vec<u64> = opts.seeds.clone().collect();
    let threads = opts.threads.max(1).min(all.len().max(1));
    let done = std::sync::atomic::AtomicUsize::new(0);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let families = &opts.families;
    let results: Vec<(u64, Result<ScenarioResult, EvalError>)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|_| {
                let (all, done, next) = (&all, &done, &next);
                s.spawn(move || {
                    let mut out = Vec::new();
                    loop {
                        let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(&seed) = all.get(k) else { break };
                        out.push((
                            seed,
                            run_scenario_full(
                                seed,
                                families,
                                opts.unexplained_rule,
                                battery_oracle,
                                opts.baseline,
                            ),
                        ));
                        let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                        progress(n);
                    }
                    out
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_default())
            .collect()
    });
    let mut ok = Vec::new();
    let mut failed = Vec::new();
    for (seed, r) in results {
        match r {
            Ok(r) => ok.push(r),
            Err(e) => failed.push((seed, e.to_string())),
        }
    }
    ok.sort_by_key(|r| r.seed);
    failed.sort();
    Ok(summarise(
        (opts.seeds.start, opts.seeds.end),
        families,
        ok,
        failed,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use adapter::Outcome;
    use flight_sim::Withheld;

    fn truth(kind: EffectKind, with_s: f64) -> Truth {
        Truth {
            family: "lipo/lab-1hz/paper".into(),
            seed: 1,
            effect: Withheld {
                kind,
                magnitude: 0.1,
            },
            unit: kind.unit(),
            endurance_s: vec![("a".into(), with_s, 1000.0)],
        }
    }

    fn outcome(verdict: &[(&str, f64)], unexplained: bool, before: f64, after: f64) -> Outcome {
        Outcome {
            verdict: verdict.iter().map(|(n, _)| (*n).to_owned()).collect(),
            unexplained,
            shares: verdict.iter().map(|(n, s)| ((*n).to_owned(), *s)).collect(),
            heldout_endurance_before_pct: Some(before),
            heldout_endurance_after_pct: Some(after),
            heldout_headline: (before, after),
            unexplained_reasons: Vec::new(),
            unexplained_by_chi2: unexplained,
            unexplained_by_systematic: unexplained,
            look_alikes: Vec::new(),
            estimated_hover_power_w: None,
            search: adapter::SearchEvidence {
                within_noise: false,
                baseline_chi2: 100.0,
                baseline_cv_chi2: Some(110.0),
                min_delta_chi2: 12.0,
                singles: Vec::new(),
                combinations: Vec::new(),
                dropped_on_heldout: Vec::new(),
                resistance_kept_unnamed: false,
            },
        }
    }

    #[test]
    fn strict_rules() {
        let fam = Family::parse("lipo/lab-1hz/paper").unwrap();
        // A library effect with 5 % impact: right when it has the largest share.
        let t = truth(EffectKind::CapacityFade, 950.0);
        let o = outcome(
            &[("internal_resistance", 0.3), ("capacity_fade", 0.6)],
            true,
            5.0,
            1.0,
        );
        let r = score(&t, &fam, &o);
        assert!(r.strict_scored && r.strict_correct);
        assert_eq!(r.verdict, "internal_resistance+capacity_fade (unexplained)");
        assert!((r.shrinkage() - 0.8).abs() < 1e-12);
        let o = outcome(
            &[("internal_resistance", 0.7), ("capacity_fade", 0.2)],
            false,
            5.0,
            1.0,
        );
        assert!(!score(&t, &fam, &o).strict_correct);
        // Under 2 % impact: not in the strict score.
        let t = truth(EffectKind::CapacityFade, 990.0);
        assert!(!score(&t, &fam, &o).strict_scored);
        // none: an empty verdict that is not unexplained.
        let t = truth(EffectKind::None, 1000.0);
        assert!(score(&t, &fam, &outcome(&[], false, 0.5, 0.5)).strict_correct);
        assert!(!score(&t, &fam, &outcome(&[], true, 0.5, 0.5)).strict_correct);
        assert!(!score(&t, &fam, &outcome(&[("peukert", 1.0)], false, 0.5, 0.4)).strict_correct);
        // Outside the library: unexplained, whatever was selected.
        let t = truth(EffectKind::MotorHeating, 960.0);
        assert!(score(&t, &fam, &outcome(&[("peukert", 1.0)], true, 3.0, 2.0)).strict_correct);
        assert!(!score(&t, &fam, &outcome(&[("peukert", 1.0)], false, 3.0, 2.0)).strict_correct);
    }

    #[test]
    fn groups_count_worse_runs_and_median_shrinkage() {
        let fam = Family::parse("lfp/fc-10hz/varied").unwrap();
        let rs: Vec<ScenarioResult> = [(4.0, 1.0), (4.0, 2.0), (1.0, 1.5), (2.0, 2.1)]
            .iter()
            .map(|(b, a)| {
                score(
                    &truth(EffectKind::CapacityFade, 900.0),
                    &fam,
                    &outcome(&[("capacity_fade", 1.0)], false, *b, *a),
                )
            })
            .collect();
        let rep = summarise((0, 4), &[fam], rs, Vec::new());
        let g = rep
            .groups
            .iter()
            .find(|g| g.name == "lfp/fc-10hz/varied")
            .unwrap();
        assert_eq!(g.split, "held out");
        assert_eq!(g.worse, (2, 1));
        assert!((g.max_worse_pp.unwrap() - 0.5).abs() < 1e-12);
        // Shrinkages 0.75, 0.5, −0.5, −0.05: median −0.025 … 0.5 → (0.5 − 0.05) / 2.
        assert!((g.median_shrinkage.unwrap() - 0.225).abs() < 1e-12);
        assert_eq!(rep.groups[0].name, "all held-out families");
        assert_eq!(rep.tuning_families.len(), 0);
    }

    #[test]
    fn groups_score_none_and_outside_under_both_rules() {
        let fam = Family::parse("lipo/lab-1hz/paper").unwrap();
        // The χ² rule flags everything; the systematic rule only the outside effect.
        let mut none = outcome(&[], true, 1.0, 1.0);
        none.unexplained_by_systematic = false;
        let heat = outcome(&[("peukert", 1.0)], true, 3.0, 2.0);
        let mut drain = outcome(&[], true, 3.0, 3.0);
        drain.unexplained_by_systematic = false;
        let rs = vec![
            score(&truth(EffectKind::None, 1000.0), &fam, &none),
            score(&truth(EffectKind::MotorHeating, 960.0), &fam, &heat),
            score(&truth(EffectKind::DrainingPayload, 960.0), &fam, &drain),
        ];
        let rep = summarise((0, 3), &[fam], rs, Vec::new());
        let g = &rep.groups[0];
        assert_eq!(g.name, "all tuning families");
        // Scored by the rule the study ran (χ²): none wrong, both outside right.
        assert_eq!((g.none, g.outside), ((1, 0), (2, 2)));
        assert_eq!(g.by_rule.chi2, ((1, 0), (2, 2)));
        assert_eq!(g.by_rule.systematic, ((1, 1), (2, 1)));
    }

    #[test]
    fn family_selection() {
        assert_eq!(select_families("all").unwrap().len(), 40);
        let t = select_families("tuning").unwrap();
        assert_eq!(t.len(), 4);
        assert!(t.iter().all(is_tuning_family));
        assert_eq!(select_families("heldout").unwrap().len(), 36);
        assert_eq!(select_families("lfp").unwrap().len(), 8);
        assert_eq!(
            select_families("*/vonly-5hz/paper,lfp/*/paper")
                .unwrap()
                .len(),
            8
        );
        assert!(select_families("lead-acid").is_err());
        // At least one chemistry is held out entirely.
        for c in [Chemistry::LiHv, Chemistry::Nca, Chemistry::LiFePo4] {
            assert!(
                Family::all()
                    .iter()
                    .filter(|f| f.chemistry == c)
                    .all(|f| !is_tuning_family(f))
            );
        }
    }

    fn single(effect: &str, chi2: f64, heldout: f64) -> adapter::SingleEvidence {
        adapter::SingleEvidence {
            effect: effect.to_owned(),
            chi2,
            cv_chi2: None,
            heldout_endurance_pct: Some(heldout),
        }
    }

    #[test]
    fn misses_are_put_on_the_step_that_lost_them() {
        let fam = Family::parse("lipo/lab-1hz/paper").unwrap();
        let t = truth(EffectKind::CapacityFade, 950.0);
        let with = |verdict: &[(&str, f64)], singles: Vec<adapter::SingleEvidence>| {
            let mut o = outcome(verdict, false, 5.0, 4.0);
            o.search.singles = singles;
            o
        };
        let cause = |o: &Outcome| {
            score(&t, &fam, o)
                .miss
                .map(|m| (m.cause, m.true_alone_helps))
        };
        // Right: no miss.
        let o = with(
            &[("capacity_fade", 1.0)],
            vec![single("capacity_fade", 50.0, 1.0)],
        );
        assert_eq!(cause(&o), None);
        // Fitted alone it lowers χ² by 8 < 12.
        let o = with(&[], vec![single("capacity_fade", 92.0, 4.0)]);
        assert_eq!(cause(&o), Some((MissCause::BelowSensitivity, Some(true))));
        // Another single fits better; the true one alone would not have helped held out.
        let o = with(
            &[("peukert", 1.0)],
            vec![
                single("peukert", 40.0, 3.0),
                single("capacity_fade", 60.0, 6.0),
            ],
        );
        assert_eq!(cause(&o), Some((MissCause::Outranked, Some(false))));
        // Best single, selected, dropped on the held-out flights.
        let mut o = with(&[], vec![single("capacity_fade", 40.0, 6.0)]);
        o.search.dropped_on_heldout = vec!["capacity_fade".into()];
        assert_eq!(cause(&o), Some((MissCause::DroppedOnHeldout, Some(false))));
        // Best single, nothing passed cross-validation.
        let o = with(&[], vec![single("capacity_fade", 40.0, 2.0)]);
        assert_eq!(cause(&o), Some((MissCause::NotCrossValidated, Some(true))));
        // Best single, another of the three best won on cross-validation.
        let o = with(
            &[("peukert", 1.0)],
            vec![
                single("capacity_fade", 40.0, 2.0),
                single("peukert", 41.0, 2.0),
            ],
        );
        assert_eq!(
            cause(&o),
            Some((MissCause::OutrankedInCrossValidation, Some(true)))
        );
        // Named, with the smaller share.
        let o = with(
            &[("capacity_fade", 0.2), ("peukert", 0.7)],
            vec![single("capacity_fade", 40.0, 2.0)],
        );
        assert_eq!(cause(&o), Some((MissCause::OutShared, Some(true))));
        // Not observable, and within noise (searched for nothing).
        let o = with(&[], vec![single("peukert", 40.0, 2.0)]);
        assert_eq!(cause(&o), Some((MissCause::NotObservable, None)));
        let mut o = with(&[], vec![single("capacity_fade", 40.0, 2.0)]);
        o.search.within_noise = true;
        assert_eq!(cause(&o), Some((MissCause::WithinNoise, Some(true))));
        // An extra resistance kept unnamed.
        let t = truth(EffectKind::InternalResistance, 950.0);
        let mut o = with(&[], vec![single("internal_resistance", 40.0, 2.0)]);
        o.search.resistance_kept_unnamed = true;
        let m = score(&t, &fam, &o).miss.unwrap();
        assert_eq!(m.cause, MissCause::KeptUnnamed);
        // none, outside and small effects are not library misses.
        let o = with(&[("peukert", 1.0)], vec![single("peukert", 40.0, 2.0)]);
        assert!(
            score(&truth(EffectKind::None, 1000.0), &fam, &o)
                .miss
                .is_none()
        );
        assert!(
            score(&truth(EffectKind::CapacityFade, 990.0), &fam, &o)
                .miss
                .is_none()
        );
        // Rolled up per group.
        let r = score(&truth(EffectKind::CapacityFade, 950.0), &fam, &o);
        let g = GroupSummary::of("g".into(), &[&r, &r]);
        assert_eq!(g.library_misses, vec![(MissCause::NotObservable, 2, 0)]);
    }
}
