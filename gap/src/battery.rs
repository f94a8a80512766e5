//! The battery the diagnosis learns from the flights: open-circuit voltage against state of
//! charge (monotone, smooth), series resistance and one RC pair, per battery type.
//!
//! Real users fly packs whose curve nobody measured, so the diagnosis does not assume one. For
//! every battery type among the training flights (same `battery_id`, else same cell count and
//! rated energy) it identifies a [`LearnedBattery`] from the flights themselves, before the
//! effect search:
//!
//! - **State of charge by charge counting**: from the logged current or, without current (the
//!   Crazyflie), from the current the power model draws at the measured voltage (`I = P / V`),
//!   over the rated capacity (`battery_energy_wh` over the cells and the curve's mean voltage);
//!   the start from the first samples' voltage. The fit runs twice, the second round counting
//!   on the first round's curve. When a flight with logged current, counted from the start the
//!   voltage reads on that curve, runs more than [`MAX_COUNT_PAST_EMPTY`] of the charge past
//!   empty (a start read on a flat stretch of the curve; a pack cannot give more than it held),
//!   the fit's note marks the learned battery UNRELIABLE: the second round then piles those
//!   flights' last samples onto its lowest knots and its curve can collapse (issue 9; taking
//!   such a start from the count instead made some held-out predictions worse, so it is not
//!   done yet).
//! - **The usable capacity** is reported beside it ([`BatteryFit::usable_capacity_ah`],
//!   [`BatteryFit::capacity_lost_fraction`]): the charge a full pack (resting within 30 mV per
//!   cell of the type's highest resting voltage) gave until the cut-off, over the share of the
//!   charge the curve says the cut-off leaves (at most 15 %); the median over such flights.
//!   It is not yet what the state of charge is counted over: doing so kept a lost capacity out
//!   of the curve's shape, but made some held-out predictions of the blind study worse (cut-offs
//!   that are not an empty pack: a thrust limit, a noisy last sample).
//! - **Each flight's charge is counted with the logged current as it is**: no per-flight
//!   scale for the current sensor's gain. Flight-controller logs carry one (from flight to
//!   flight a Hall sensor's gain differs by some per cent) and it smears the learned curve, but
//!   a count scale per flight, estimated on the first round's curve (jointly with a shift of
//!   the start, prior σ 4 % on the scale, the type's geometric mean kept at 1, taken when it
//!   improves the fit by more than its freedom) made held-out predictions worse on the tuning
//!   families (issue 9, session 8: 9 of 40 gap-eval runs worse by more than 0.25 pp, 8
//!   better; 14 of 96 replayed flights worse, 42 better). The scales it finds do follow the
//!   sensors (median spread 4–5 % on 10 Hz flight-controller logs against 2–3 % on 1 Hz lab
//!   logs), but the lab logs' 2–3 % is the curve's own misfit, which such scales absorb too.
//! - **A regularised linear fit** of the per-cell terminal voltage
//!   `v = OCV(s) − I·R₀ − R₁·x(τ)` (`x` the current through the RC pair's low-pass of time
//!   constant τ): 21 open-circuit knots as deviations from a chemistry prior with a smoothness
//!   penalty on their second differences and a pull towards the prior (σ 0.03 V when the
//!   chemistry is given, 0.3 V when it is not), `R₀ ≥ 0`, `R₁ ≥ 0`, τ from a grid; the knots are then made monotone by isotonic
//!   regression. The priors on the voltage level of the flights' highest resting voltage per
//!   cell are tried (full-charge voltages fall in two levels, LiFePO₄ near 3.6 V and the
//!   cobalt/nickel chemistries at 4.2–4.35 V; the level of a full pack's resting voltage is the
//!   plainest signature of its chemistry) and the one fitting best is kept.
//! - **Chemistry priors** ([`Chemistry`]) are built from measured electrode potentials copied
//!   from PyBaMM (`gap/data/pybamm/`, BSD-3-Clause): LiPo and LiHV (LiCoO₂/graphite, Ai 2020),
//!   Li-ion NMC (LG M50, Chen 2020) and NCA (Kim 2011); LiFePO₄ from the published closed form
//!   of Afshar et al. 2017 (PyBaMM's `LFP_ocp_Afshar2017`) against the LG M50 graphite.
//! - **A measured curve** ([`LearnedBattery::from_ocv_csv`], `soc,ocv_v` per cell) overrides
//!   the prior: the knots are taken as given and only the resistances are learned.
//!
//! How much data: the knots are learned over the span of state of charge the flights cover;
//! outside it the curve follows the prior's shape. Below a quarter of the charge
//! ([`KNEE_FREE_SOC`]) the curve keeps the prior's shape, shifted with the curve above it: the
//! voltage alone cannot tell where a pack's knee sits from a capacity it has lost, so the
//! chemistry says where the knee is. With flights covering less than a quarter
//! of the charge, or fewer than 200 voltage samples, the fit keeps the prior's shape and learns
//! only an offset and the resistances ([`BatteryFit::note`] says so). The usable capacity needs
//! at least one flight from a full pack to the cut-off. An RC pair needs a load that changes
//! (a steady hover cannot tell a fast sag from the series resistance). What a fit's flights did
//! not teach is listed in [`BatteryFit::warnings`] ([`plausibility`]): one flight, charge no
//! flight visited (and whether it lies below the cut-off, where it is never used), knots
//! pulled beyond the prior's band, no RC pair; `hoverbench battery learn` prints them. A
//! LiFePO₄ pack learned from one hover flight (flight-sim `lfp/fc-10hz/varied` seed 20) shows
//! 1.48 V per cell at 0 %: that is the prior's shape (its own end, the electrodes' limit in
//! the Afshar formula's window, is 1.56 V), kept below the 11 % the flight reached. The
//! diagnosis's baseline
//! takes the learned series resistance up to the nominal (5 mΩ per cell): resistance above it
//! stays a diagnosable effect (`internal_resistance`) instead of vanishing into the battery; the
//! learned value is reported either way. The effect is named only when the model's resistance
//! is above what a healthy pack of the fit's chemistry and rated capacity has
//! ([`Chemistry::healthy_resistance`], published cell data in Ω·Ah per cell; the nominal for a
//! measured curve or an unknown capacity; [`crate::diagnose::healthy_resistance`]).
//!
//! [`LearnedBattery`] is plain data of fixed size (`f64` fields and arrays), so it can be stored
//! in a parameter file and read by a `no_std` in-flight estimator.

use serde::Serialize;

use crate::flight::FlightRecord;
use crate::stats::{isotonic, solve};

/// Open-circuit knots, at state of charge 0, 0.05, …, 1.
pub const OCV_KNOTS: usize = 21;

/// A pack's learned behaviour, per cell: plain `f64` data of fixed size.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LearnedBattery {
    /// Open-circuit voltage of one cell at state of charge `k / (OCV_KNOTS − 1)`, V; strictly
    /// increasing. Between knots the curve is the monotone cubic (Fritsch–Carlson) through
    /// them.
    pub ocv_cell_v: [f64; OCV_KNOTS],
    /// Series resistance of one cell, Ω.
    pub series_resistance_cell_ohm: f64,
    /// Resistance of the RC pair of one cell, Ω (0: no RC pair).
    pub rc_resistance_cell_ohm: f64,
    /// Time constant of the RC pair, s.
    pub rc_time_constant_s: f64,
}

/// A chemistry prior.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Chemistry {
    /// LiCoO₂/graphite, 4.20 V full (hobby LiPo).
    Lipo,
    /// LiCoO₂/graphite charged to 4.35 V (LiHV).
    Lihv,
    /// NMC811/graphite-SiOx (Li-ion, LG M50).
    LiIonNmc,
    /// NCA/graphite (Li-ion).
    LiIonNca,
    /// LiFePO₄/graphite (LFP, 3.6 V full, a flat plateau near 3.3 V).
    Lifepo4,
    /// A curve the user measured.
    Measured,
}

impl Chemistry {
    /// The priors tried when the chemistry is not given.
    pub const PRIORS: [Chemistry; 5] = [
        Chemistry::Lipo,
        Chemistry::Lihv,
        Chemistry::LiIonNmc,
        Chemistry::LiIonNca,
        Chemistry::Lifepo4,
    ];

    /// Name as in reports.
    pub fn name(self) -> &'static str {
        match self {
            Chemistry::Lipo => "lipo",
            Chemistry::Lihv => "lihv",
            Chemistry::LiIonNmc => "li_ion_nmc",
            Chemistry::LiIonNca => "li_ion_nca",
            Chemistry::Lifepo4 => "lifepo4",
            Chemistry::Measured => "measured",
        }
    }

    /// Nominal series resistance of one cell, Ω (PX4's default estimate, 5 mΩ per cell, for
    /// every chemistry): the prior's starting value and the baseline's cap (what a healthy pack
    /// of a given size has, against which `internal_resistance` is named, is
    /// [`Self::healthy_resistance`]).
    pub fn nominal_cell_resistance_ohm(self) -> f64 {
        crate::model::NOMINAL_CELL_RESISTANCE_OHM
    }

    /// The series resistance a healthy cell of this chemistry has, per rated capacity (a cell's
    /// resistance falls as its electrode area, and so its capacity, grows; cells in parallel
    /// divide it the same way, so `R × C` of one series group of a pack is that of its cells).
    /// `None` for [`Chemistry::Measured`]: a curve from a file does not say the chemistry.
    ///
    /// The values are the DC resistance of published cells (a pulse of about a second, the
    /// series resistance the fit learns beside its RC pair; a charger's or an AC 1 kHz meter's
    /// reading is its lower end), at room temperature and mid charge, new cells:
    ///
    /// - **LiPo and LiHV** (LiCoO₂ pouch packs of hobby drones, high-rate): new packs read
    ///   1–4 mΩ per cell at 3–5 Ah and about 5–8 mΩ at 2.2 Ah on hobby chargers' DC test
    ///   (rchelicopterfun.com "LiPo internal resistance", 2023; the same order in the DC pulse
    ///   measurements of thejumperwire.com "LiPo characteristics part 3"), i.e. 0.005–0.02 Ω·Ah;
    ///   typical 0.012 Ω·Ah. LiHV cells are built the same way.
    /// - **Li-ion NMC and NCA** (cylindrical 18650/21700 cells): Samsung INR18650-25R datasheet
    ///   ≤ 18 mΩ AC 1 kHz at 2.5 Ah (0.045 Ω·Ah, AC: the DC value is higher); high-rate 21700s
    ///   (Molicel P42A, Samsung 50S) about 12–15 mΩ DC at 4.2–5 Ah (0.06 Ω·Ah); energy cells
    ///   (LG M50, Panasonic NCR18650B) 25–60 mΩ DC at 3.4–5 Ah (0.12–0.2 Ω·Ah). Typical
    ///   0.08 Ω·Ah; the cell's format and rate, not its cathode, sets the spread.
    /// - **LiFePO₄**: A123 ANR26650M1B datasheet about 6 mΩ AC 1 kHz typical at 2.5 Ah, about
    ///   10 mΩ DC (0.025 Ω·Ah); energy-type LFP 18650/32700 cells (1.5–6 Ah) 0.05–0.07 Ω·Ah DC.
    ///   Typical 0.035 Ω·Ah.
    ///
    /// The spread is a factor 2 either way for every chemistry (the ranges above: power cells
    /// at the low end, energy cells at the high end; manufacturing scatter within one cell type
    /// is some per cent). Only the 25R's datasheet figure and the hobby LiPo range were checked
    /// against their sources when these values were set (session 11); the other cells' figures
    /// are as recalled from their datasheets and tests, and a re-read may move the typical
    /// values within their factor-2 band.
    pub fn healthy_resistance(self) -> Option<HealthyResistance> {
        let (typical_ohm_ah, spread_factor) = match self {
            Chemistry::Lipo | Chemistry::Lihv => (0.012, 2.0),
            Chemistry::LiIonNmc | Chemistry::LiIonNca => (0.08, 2.0),
            Chemistry::Lifepo4 => (0.035, 2.0),
            Chemistry::Measured => return None,
        };
        Some(HealthyResistance {
            typical_ohm_ah,
            spread_factor,
        })
    }

    /// The prior battery: the chemistry's open-circuit curve, nominal resistance, no RC pair.
    /// `None` for [`Chemistry::Measured`] (that curve comes from a file).
    pub fn prior(self) -> Option<LearnedBattery> {
        let lco = || parse_points(include_str!("../data/pybamm/lico2_ocp_Ai2020.csv"));
        let gr_ai = || {
            parse_points(include_str!(
                "../data/pybamm/graphite_ocp_Enertech_Ai2020.csv"
            ))
        };
        let gr_chen = || {
            parse_points(include_str!(
                "../data/pybamm/graphite_LGM50_ocp_Chen2020.csv"
            ))
        };
        // Stoichiometry windows (empty → full) of each electrode.
        let knots = match self {
            // Ai 2020's cell at 100 %: graphite 0.84, LiCoO₂ 0.435; empty where LiCoO₂ is
            // nearly fully lithiated (0.99) and graphite nearly empty (0.01).
            Chemistry::Lipo => full_cell(&lco(), &gr_ai(), (0.99, 0.435), (0.01, 0.84)),
            Chemistry::Lihv => {
                // The same cell charged further: the LiCoO₂ window extended until 4.35 V.
                let (p, n) = (lco(), gr_ai());
                let top = |y: f64| interp(&p, y) - interp(&n, 0.84) - 4.35;
                let (mut a, mut b) = (0.4, 0.435);
                for _ in 0..60 {
                    let m = 0.5 * (a + b);
                    if top(m) > 0.0 { a = m } else { b = m }
                }
                full_cell(&p, &n, (0.99, 0.5 * (a + b)), (0.01, 0.84))
            }
            // Chen 2020's published windows of the LG M50.
            Chemistry::LiIonNmc => full_cell(
                &parse_points(include_str!("../data/pybamm/nmc_LGM50_ocp_Chen2020.csv")),
                &gr_chen(),
                (0.9084, 0.2661),
                (0.0279, 0.9014),
            ),
            Chemistry::LiIonNca => full_cell(
                &parse_points(include_str!("../data/pybamm/nca_ocp_Kim2011_data.csv")),
                &gr_chen(),
                (0.99, 0.375),
                (0.0279, 0.9014),
            ),
            // LiFePO₄: the published closed form of Afshar, Morris & Khajepour (2017) (as in
            // PyBaMM's `LFP_ocp_Afshar2017`), a two-phase plateau with exponential ends, sampled
            // over its stoichiometry; against the LG M50 graphite over Chen 2020's window.
            Chemistry::Lifepo4 => {
                let lfp: Vec<(f64, f64)> = (0..=400)
                    .map(|k| {
                        let y = f64::from(k) / 400.0;
                        let u = 3.4077 - 0.020269 * y + 0.5 * (-150.0 * y).exp()
                            - 0.9 * (-30.0 * (1.0 - y)).exp();
                        (y, u)
                    })
                    .collect();
                full_cell(&lfp, &gr_chen(), (0.99, 0.004), (0.0279, 0.9014))
            }
            Chemistry::Measured => return None,
        };
        Some(LearnedBattery {
            ocv_cell_v: strictly_increasing(knots),
            series_resistance_cell_ohm: self.nominal_cell_resistance_ohm(),
            rc_resistance_cell_ohm: 0.0,
            rc_time_constant_s: 0.0,
        })
    }
}

/// The series resistance of healthy cells of one chemistry, scaled by the rated capacity
/// ([`Chemistry::healthy_resistance`]): a cell of `C` Ah has about `typical_ohm_ah / C` Ω,
/// within a factor `spread_factor` either way.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HealthyResistance {
    /// Typical series resistance of one cell times its rated capacity, Ω·Ah.
    pub typical_ohm_ah: f64,
    /// Healthy cells lie between the typical value over and times this factor (≥ 1).
    pub spread_factor: f64,
}

impl HealthyResistance {
    /// Typical series resistance of one cell (one series group) of `capacity_ah`, Ω; `None`
    /// when the capacity is not a positive number.
    pub fn typical_cell_ohm(&self, capacity_ah: f64) -> Option<f64> {
        (capacity_ah.is_finite() && capacity_ah > 0.0).then(|| self.typical_ohm_ah / capacity_ah)
    }

    /// The highest series resistance a healthy cell of `capacity_ah` has, Ω (the typical value
    /// times the spread); `None` when the capacity is not a positive number.
    pub fn upper_cell_ohm(&self, capacity_ah: f64) -> Option<f64> {
        self.typical_cell_ohm(capacity_ah)
            .map(|r| r * self.spread_factor)
    }
}

/// What can be wrong with a measured open-circuit curve.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OcvCsvError {
    /// A line is not two numbers.
    #[error("line {line}: expected `soc,ocv_v` (two numbers), found {text:?}")]
    Line {
        /// 1-based line.
        line: usize,
        /// The line.
        text: String,
    },
    /// A value is out of range.
    #[error("line {line}: {what}")]
    Range {
        /// 1-based line.
        line: usize,
        /// What is wrong.
        what: String,
    },
    /// Too little of the curve.
    #[error("{0}")]
    Coverage(String),
}

impl LearnedBattery {
    /// The LiPo prior (see [`Chemistry::prior`]).
    pub fn lipo() -> Self {
        Chemistry::Lipo
            .prior()
            .unwrap_or_else(|| unreachable!("LiPo has a prior"))
    }

    /// Reads a measured open-circuit curve, `soc,ocv_v` per cell (a header line and `#`
    /// comments allowed; state of charge 0..1 or 0..100 %). It must span at least 0.1–0.9 of the
    /// charge and rise with it; it is resampled onto the knots (linear between points, held
    /// flat beyond the ends).
    pub fn from_ocv_csv(text: &str) -> Result<Self, OcvCsvError> {
        let mut pts = Vec::new();
        for (k, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let f: Vec<&str> = line.split(',').map(str::trim).collect();
            let nums: Option<Vec<f64>> = (f.len() == 2)
                .then(|| f.iter().map(|s| s.parse::<f64>().ok()).collect())
                .flatten();
            match nums {
                Some(v) => {
                    if !v.iter().all(|x| x.is_finite()) || !(0.5..=5.5).contains(&v[1]) {
                        return Err(OcvCsvError::Range {
                            line: k + 1,
                            what: format!(
                                "open-circuit voltage {} V per cell is not plausible (0.5–5.5 V)",
                                v[1]
                            ),
                        });
                    }
                    pts.push((v[0], v[1]));
                }
                None if pts.is_empty() && k == 0 => {} // header
                None => {
                    return Err(OcvCsvError::Line {
                        line: k + 1,
                        text: line.to_owned(),
                    });
                }
            }
        }
        if pts.iter().any(|p| p.0 > 1.0 + 1e-9) {
            for p in &mut pts {
                p.0 /= 100.0;
            }
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (lo, hi) = match (pts.first(), pts.last()) {
            (Some(a), Some(b)) => (a.0, b.0),
            _ => return Err(OcvCsvError::Coverage("no points".into())),
        };
        if lo > 0.1 || hi < 0.9 {
            return Err(OcvCsvError::Coverage(format!(
                "the curve spans state of charge {lo:.2}–{hi:.2}; it must cover at least 0.10–0.90"
            )));
        }
        if pts.last().map(|p| p.1) <= pts.first().map(|p| p.1) {
            return Err(OcvCsvError::Coverage(
                "the voltage does not rise with the state of charge".into(),
            ));
        }
        let mut knots = [0.0; OCV_KNOTS];
        for (k, slot) in knots.iter_mut().enumerate() {
            *slot = interp(&pts, k as f64 / (OCV_KNOTS - 1) as f64);
        }
        let w = [1.0; OCV_KNOTS];
        let iso = isotonic(&knots, &w);
        knots.copy_from_slice(&iso);
        Ok(Self {
            ocv_cell_v: strictly_increasing(knots),
            series_resistance_cell_ohm: Chemistry::Measured.nominal_cell_resistance_ohm(),
            rc_resistance_cell_ohm: 0.0,
            rc_time_constant_s: 0.0,
        })
    }

    /// Open-circuit voltage of one cell at state of charge `soc` (clamped to 0..1), V.
    pub fn ocv_cell_v(&self, soc: f64) -> f64 {
        // The workspace's one monotone cubic (Fritsch–Carlson), shared with the in-flight
        // estimator so the curve stored in a `[battery]` section reads the same in both.
        estimator::online::monotone_cubic(&self.ocv_cell_v, soc).0
    }

    /// State of charge whose open-circuit voltage is `v` per cell (inverse of
    /// [`Self::ocv_cell_v`], clamped to 0..1).
    pub fn soc_for_ocv(&self, v: f64) -> f64 {
        if v <= self.ocv_cell_v[0] {
            return 0.0;
        }
        if v >= self.ocv_cell_v[OCV_KNOTS - 1] {
            return 1.0;
        }
        let (mut a, mut b) = (0.0, 1.0);
        for _ in 0..50 {
            let m = 0.5 * (a + b);
            if self.ocv_cell_v(m) < v { a = m } else { b = m }
        }
        0.5 * (a + b)
    }

    /// Mean open-circuit voltage over a full discharge, V per cell: a cell's stored energy is
    /// its charge times this.
    pub fn mean_ocv_cell_v(&self) -> f64 {
        let n = 200;
        (0..n)
            .map(|k| self.ocv_cell_v((k as f64 + 0.5) / n as f64))
            .sum::<f64>()
            / n as f64
    }

    /// The state of charge where the curve bends down at the end of the discharge (the
    /// "knee"): the largest charge below half at which the curve's slope is twice its median
    /// slope over 0.2–0.8, and the open-circuit voltage there. `None` when the curve has no
    /// such bend.
    pub fn knee(&self) -> Option<(f64, f64)> {
        let slope = |s: f64| (self.ocv_cell_v(s + 0.005) - self.ocv_cell_v(s - 0.005)) / 0.01;
        let mid: Vec<f64> = (20..=80).map(|k| slope(f64::from(k) / 100.0)).collect();
        let m = crate::stats::median(&mid)?;
        (1..50)
            .rev()
            .map(|k| f64::from(k) / 100.0)
            .find(|&s| {
                slope(s) > 2.0 * m && (1..=5).all(|j| slope(s - 0.01 * f64::from(j)) > 2.0 * m)
            })
            .map(|s| (s, self.ocv_cell_v(s)))
    }
}

fn strictly_increasing(mut k: [f64; OCV_KNOTS]) -> [f64; OCV_KNOTS] {
    for j in 1..OCV_KNOTS {
        if k[j] < k[j - 1] + 1e-4 {
            k[j] = k[j - 1] + 1e-4;
        }
    }
    k
}

fn parse_points(text: &str) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> = text
        .lines()
        .filter_map(|l| {
            let mut it = l.split(',').map(|s| s.trim().parse::<f64>());
            match (it.next(), it.next()) {
                (Some(Ok(a)), Some(Ok(b))) => Some((a, b)),
                _ => None,
            }
        })
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    pts
}

/// Linear interpolation in sorted points, held flat beyond the ends.
fn interp(pts: &[(f64, f64)], x: f64) -> f64 {
    let i = pts.partition_point(|p| p.0 < x);
    if i == 0 {
        return pts.first().map_or(f64::NAN, |p| p.1);
    }
    if i >= pts.len() {
        return pts.last().map_or(f64::NAN, |p| p.1);
    }
    let ((x0, y0), (x1, y1)) = (pts[i - 1], pts[i]);
    if x1 > x0 {
        y0 + (y1 - y0) * (x - x0) / (x1 - x0)
    } else {
        y1
    }
}

/// A full cell's open-circuit curve from its electrodes' potentials: positive minus negative,
/// each at its stoichiometry, moving linearly between the empty and the full window ends.
fn full_cell(
    pos: &[(f64, f64)],
    neg: &[(f64, f64)],
    pos_window: (f64, f64),
    neg_window: (f64, f64),
) -> [f64; OCV_KNOTS] {
    let mut k = [0.0; OCV_KNOTS];
    for (j, slot) in k.iter_mut().enumerate() {
        let s = j as f64 / (OCV_KNOTS - 1) as f64;
        let y = pos_window.0 + s * (pos_window.1 - pos_window.0);
        let x = neg_window.0 + s * (neg_window.1 - neg_window.0);
        *slot = interp(pos, y) - interp(neg, x);
    }
    k
}

/// Where a flight's current comes from in the battery fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CurrentSource {
    /// Logged.
    Logged,
    /// The power model's draw at the measured voltage.
    PowerModel,
}

/// One flight prepared for the battery fit: its samples and the current through the pack.
#[derive(Debug, Clone)]
pub struct BatteryData<'a> {
    /// The flight.
    pub flight: &'a FlightRecord,
    /// Current at every sample, A.
    pub current_a: Vec<f64>,
    /// Where it came from.
    pub source: CurrentSource,
}

/// A learned battery with what it was learned from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BatteryFit {
    /// The battery type: `battery_id`, else cells and rated energy.
    pub battery_type: String,
    /// The learned battery.
    pub battery: LearnedBattery,
    /// The prior it started from.
    pub prior: Chemistry,
    /// Training flights it was learned from.
    pub flights: usize,
    /// Voltage samples used.
    pub samples: usize,
    /// State of charge covered by the flights (lowest, highest).
    pub soc_covered: (f64, f64),
    /// RMS of the fit's voltage residual on the training flights, V per cell.
    pub rmse_cell_v: f64,
    /// Where the current came from (logged on all flights, or the power model on some).
    pub current: CurrentSource,
    /// What the fit could and could not learn from these data.
    pub note: String,
    /// Rated capacity, Ah: the rated energy over the cells and the learned curve's mean
    /// voltage (the first flight's metadata).
    pub rated_capacity_ah: f64,
    /// Usable capacity the flights showed, Ah: the charge from a full pack to the cut-off
    /// (median over flights that started full and flew to the cut-off); `None` when no flight
    /// did. A pack that lost capacity shows it here, below the rated one.
    pub usable_capacity_ah: Option<f64>,
    /// What these flights could not teach, in words with numbers ([`plausibility`]): a single
    /// flight, charge no flight visited (where the curve is the prior's shape), knots pulled
    /// beyond the prior's band, no RC pair. Empty when nothing is missing.
    pub warnings: Vec<String>,
}

impl BatteryFit {
    /// The capacity the pack lost against its rating, as a fraction (negative: it holds more
    /// than rated), when the flights measured the usable capacity.
    pub fn capacity_lost_fraction(&self) -> Option<f64> {
        let u = self.usable_capacity_ah?;
        (self.rated_capacity_ah > 0.0).then(|| 1.0 - u / self.rated_capacity_ah)
    }
}

/// Below this state of charge the learned curve keeps its prior's shape (shifted with the curve
/// above it).
pub const KNEE_FREE_SOC: f64 = 0.25;
const KNEE_KNOT: usize = 5;

/// Fewest voltage samples, and least span of charge, for the knots to be learned.
pub const MIN_SAMPLES: usize = 200;
/// See [`MIN_SAMPLES`].
pub const MIN_SOC_SPAN: f64 = 0.25;

/// The battery type of a flight: its `battery_id`, else its cells and rated energy.
pub fn battery_type(f: &FlightRecord) -> String {
    match &f.info.battery_id {
        Some(id) => id.clone(),
        None => format!("{}S {:.1} Wh", f.info.cells, f.info.battery_energy_wh),
    }
}

#[derive(Debug, Clone, Copy)]
struct Row {
    soc: f64,
    y: f64,
    /// Current times the temperature factor of the resistances (so the fitted resistances are
    /// at the reference temperature).
    i: f64,
    x_by_tau: [f64; TAUS_S.len()],
    w: f64,
}

/// Time constants tried for the RC pair, s.
const TAUS_S: [f64; 5] = [3.0, 10.0, 30.0, 100.0, 300.0];

/// How far below the highest resting voltage of its battery type a flight may start, per cell,
/// and still count as starting from a full charge.
const FULL_START_CELL_V: f64 = 0.03;

/// Most charge a cut-off leaves in a pack, as a fraction.
const MAX_SOC_AT_CUTOFF: f64 = 0.15;

/// Priors whose full-charge voltage lies further than this above the best match's distance
/// from the flights' highest resting voltage per cell are not tried: the level of a full pack's
/// resting voltage is the plainest signature of its chemistry (LiFePO₄ 3.6 V against 4.2–4.35 V
/// for LiPo, LiHV and Li-ion). The window spans a level (LiPo to LiHV, 0.15 V) and stops short
/// of the other (0.6 V away): within a level every prior is tried and the best fit decides, as
/// a partly charged or warm pack's resting voltage does not tell LiPo from LiHV or NMC. (An 80
/// mV window, narrowing the choice within a level too, made 8 of 40 predictions on the tuning
/// families worse.)
const PRIOR_FULL_MATCH_CELL_V: f64 = 0.3;

/// What the charge counted over the flights says about a battery type's usable capacity.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ChargeAnchor {
    /// Charge from full to the cut-off, Ah (`None`: no flight started full and ended at the
    /// cut-off, so the rated capacity is used).
    usable_ah: Option<f64>,
}

/// Per flight: the charge drawn, Ah, the resting voltage per cell at the start, and the state
/// of charge left at the cut-off (from `b`'s curve at the open-circuit voltage the cut-off
/// implies under the last samples' current), when the flight ended there.
fn charge_of(d: &BatteryData<'_>, b: &LearnedBattery) -> (f64, f64, Option<f64>) {
    let f = d.flight;
    let n = f.time_s.len();
    let cells = f64::from(f.info.cells.max(1));
    let q_ah = charge_drawn_ah(d);
    let v_rest = resting_start_cell_v(f);
    // The last airborne sample: the voltage the autopilot cut off at (the knee falls fast, so
    // an average over the last samples would read it fuller than it was).
    let last = (0..n).rev().find(|&j| crate::flight::rotors_on(f.phase[j]));
    let s_end = last.filter(|_| f.info.ended_at_cutoff).map(|j| {
        let (i, v) = (d.current_a[j], f.voltage_v[j]);
        // A cut-off is set where the pack is nearly empty: more left than that says the
        // prior's curve is off at its end, not that the pack stopped early.
        b.soc_for_ocv((v + i * cells * b.series_resistance_cell_ohm) / cells)
            .min(MAX_SOC_AT_CUTOFF)
    });
    (q_ah, v_rest, s_end)
}

/// The voltage per cell a flight rests at before its rotors start: the mean over the samples
/// before the first with the rotors on, else over its first five samples.
pub fn resting_start_cell_v(f: &FlightRecord) -> f64 {
    let cells = f64::from(f.info.cells.max(1));
    let rest = f.resting_voltages_v();
    let head = f.voltage_v.len().min(5);
    if rest.is_empty() {
        f.voltage_v[..head].iter().sum::<f64>() / head.max(1) as f64 / cells
    } else {
        rest.iter().sum::<f64>() / rest.len() as f64 / cells
    }
}

/// The prior battery for flights whose chemistry may be unknown: `chemistry`'s when given,
/// else the prior whose full-charge voltage lies nearest the flights' highest resting voltage
/// per cell (the level that tells LiFePO₄ from the 4.2–4.35 V chemistries), LiPo's when no
/// flight has a voltage.
pub fn prior_by_resting_level(
    flights: &[&FlightRecord],
    chemistry: Option<Chemistry>,
) -> LearnedBattery {
    if let Some(b) = chemistry.and_then(Chemistry::prior) {
        return b;
    }
    let vmax = flights
        .iter()
        .filter(|f| !f.voltage_v.is_empty())
        .map(|f| resting_start_cell_v(f))
        .filter(|v| v.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    if !vmax.is_finite() {
        return LearnedBattery::lipo();
    }
    Chemistry::PRIORS
        .iter()
        .filter_map(|c| c.prior())
        .min_by(|a, b| {
            let d = |x: &LearnedBattery| (x.ocv_cell_v[OCV_KNOTS - 1] - vmax).abs();
            d(a).total_cmp(&d(b))
        })
        .unwrap_or_else(LearnedBattery::lipo)
}

/// The usable capacity of a battery type: the median, over flights that started from a full
/// charge (resting within [`FULL_START_CELL_V`] of the type's highest) and flew to the
/// cut-off, of the charge they drew over the share of the charge they used.
fn anchor_of(data: &[BatteryData<'_>], b: &LearnedBattery) -> ChargeAnchor {
    let per: Vec<(f64, f64, Option<f64>)> = data.iter().map(|d| charge_of(d, b)).collect();
    let vmax = per.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
    let mut q: Vec<f64> = per
        .iter()
        .filter(|p| p.1 >= vmax - FULL_START_CELL_V)
        .filter_map(|p| p.2.map(|s_end| p.0 / (1.0 - s_end).max(0.5)))
        .filter(|q| q.is_finite() && *q > 0.0)
        .collect();
    q.sort_by(f64::total_cmp);
    ChargeAnchor {
        usable_ah: crate::stats::median(&q),
    }
}

/// Per flight, the rows of the fit with the charge drawn up to each, Ah: everything of a row
/// but its state of charge, which depends on the curve ([`rows_of`] fills it in).
fn row_seeds(data: &[BatteryData<'_>]) -> Vec<Vec<(f64, Row)>> {
    data.iter()
        .map(|d| {
            let f = d.flight;
            let n = f.time_s.len();
            let mut seeds = Vec::new();
            if n < 2 {
                return seeds;
            }
            let cells = f64::from(f.info.cells.max(1));
            let (r_temp, _) = crate::lipo::temperature_factors(f.info.ambient_temperature_c);
            let stride = (n / 300).max(1);
            let per_sample_w = 40.0 / (n / stride).max(1) as f64;
            let mut q_ah = 0.0;
            let mut x = [d.current_a[0]; TAUS_S.len()];
            for j in 0..n {
                if j > 0 {
                    let dt = (f.time_s[j] - f.time_s[j - 1]).max(0.0);
                    let ia = 0.5 * (d.current_a[j] + d.current_a[j - 1]);
                    q_ah += ia * dt / 3600.0;
                    for (xk, tau) in x.iter_mut().zip(TAUS_S) {
                        let a = (-dt / tau).exp();
                        *xk = a * *xk + (1.0 - a) * d.current_a[j];
                    }
                }
                if j % stride == 0 && f.voltage_v[j].is_finite() && d.current_a[j].is_finite() {
                    seeds.push((
                        q_ah,
                        Row {
                            soc: f64::NAN,
                            y: f.voltage_v[j] / cells,
                            i: d.current_a[j] * r_temp,
                            x_by_tau: x.map(|v| v * r_temp),
                            w: per_sample_w,
                        },
                    ));
                }
            }
            seeds
        })
        .collect()
}

/// The rows of the fit on `b`'s curve; `seeds` are [`row_seeds`] of `data`.
fn rows_of(
    data: &[BatteryData<'_>],
    seeds: &[Vec<(f64, Row)>],
    b: &LearnedBattery,
) -> (Vec<Row>, ChargeAnchor) {
    let anchor = anchor_of(data, b);
    let mut rows = Vec::new();
    for (d, seeds) in data.iter().zip(seeds) {
        let Some((s0, capacity_ah)) = start_of(d, b) else {
            continue;
        };
        rows.extend(seeds.iter().map(|(q_ah, r)| Row {
            soc: s0 - q_ah / capacity_ah,
            ..*r
        }));
    }
    (rows, anchor)
}

/// A flight's start of charge as the voltage reads it on `b`, and the rated capacity on `b`, Ah
/// (`None` for a log too short or a capacity that is not a number).
fn start_of(d: &BatteryData<'_>, b: &LearnedBattery) -> Option<(f64, f64)> {
    let f = d.flight;
    let n = f.time_s.len();
    if n < 2 {
        return None;
    }
    let cells = f64::from(f.info.cells.max(1));
    // The pack's behaviour with temperature is the baseline's, as in the prediction.
    let (r_temp, c_temp) = crate::lipo::temperature_factors(f.info.ambient_temperature_c);
    // State of charge is counted over the rated capacity, from the start the prediction
    // reads (rest voltage, or the first samples with their sag). Counting it over the
    // usable capacity instead (so that the curve cannot swallow a lost capacity) made 9 of
    // 36 held-out predictions of the blind study worse (seeds 0-39): the usable capacity is
    // only reported ([`BatteryFit::usable_capacity_ah`]) until the cut-offs that are not
    // an empty pack (a thrust limit, a noisy last sample) are told apart.
    let capacity_ah = f.info.battery_energy_wh / (cells * b.mean_ocv_cell_v()) * c_temp;
    if !(capacity_ah.is_finite() && capacity_ah > 0.0) {
        return None;
    }
    let head = n.min(5);
    let i0 = d.current_a[..head].iter().sum::<f64>() / head as f64;
    let s0 = f.initial_soc(b, cells * b.series_resistance_cell_ohm * r_temp, i0);
    Some((s0, capacity_ah))
}

/// How far past empty a flight's count may run before the fit says its state of charge is
/// inconsistent (in the note of its [`BatteryFit`]), as a share of the rated charge: a pack
/// cannot give more charge than it held, and the errors of the count (a current sensor's scale,
/// a pack's capacity against its rating, the cut-off's remaining charge) stay well below this.
/// On the tuning families (seeds 0–39) the flights of healthy fits run at most 0.29 past empty
/// on the first round's curve, those of the collapsing ones (seeds 8, 26, 30, 32, 39) 0.36–1.05.
pub const MAX_COUNT_PAST_EMPTY: f64 = 0.3;

/// The flights with logged current that, counted from the start the voltage reads on `b`, run
/// more than [`MAX_COUNT_PAST_EMPTY`] of the rated charge past empty: their start sits on a
/// flat stretch of `b` (or their count is far off), and a curve learned from them piles their
/// last samples onto its lowest knots.
fn counted_past_empty(data: &[BatteryData<'_>], b: &LearnedBattery) -> usize {
    data.iter()
        .filter(|d| {
            d.source == CurrentSource::Logged
                && start_of(d, b).is_some_and(|(s0, capacity_ah)| {
                    s0 - charge_drawn_ah(d) / capacity_ah < -MAX_COUNT_PAST_EMPTY
                })
        })
        .count()
}

/// The charge a flight drew over its whole log, Ah (trapezoidal count of its current).
fn charge_drawn_ah(d: &BatteryData<'_>) -> f64 {
    let f = d.flight;
    let mut q_ah = 0.0;
    for j in 1..f.time_s.len() {
        let dt = (f.time_s[j] - f.time_s[j - 1]).max(0.0);
        q_ah += 0.5 * (d.current_a[j] + d.current_a[j - 1]) * dt / 3600.0;
    }
    q_ah
}

fn hat(soc: f64) -> (usize, f64) {
    let n = OCV_KNOTS - 1;
    let x = soc.clamp(0.0, 1.0) * n as f64;
    let i = (x.floor() as usize).min(n - 1);
    (i, x - i as f64)
}

/// One regularised fit for a prior and a time constant (`None`: no RC pair). Returns the
/// battery and the penalised objective.
fn fit_once(
    rows: &[Row],
    prior: &LearnedBattery,
    prior_ocv: &[f64],
    tau: Option<usize>,
    learn_shape: bool,
    prior_sigma_v: f64,
) -> Option<(LearnedBattery, f64, f64)> {
    // Unknowns: knot deviations (or one offset), r0, r1.
    let nk = if learn_shape { OCV_KNOTS } else { 1 };
    let has_rc = tau.is_some();
    let mut free_r0 = true;
    let mut free_r1 = has_rc;
    for _ in 0..3 {
        let nr = usize::from(free_r0) + usize::from(free_r1);
        let m = nk + nr;
        let mut ata = vec![0.0; m * m];
        let mut atb = vec![0.0; m];
        let sigma_v = 0.01;
        for (r, ocv) in rows.iter().zip(prior_ocv) {
            // The row's non-zero entries, by column: two knots (or the offset), r0, r1. (The
            // zero entries would add zeros: they change no sum.)
            let mut a = [(0usize, 0.0); 4];
            let mut len = 0;
            let mut put = |col: usize, v: f64| {
                if v != 0.0 {
                    a[len] = (col, v);
                    len += 1;
                }
            };
            if learn_shape {
                let (i, t) = hat(r.soc);
                put(i, 1.0 - t);
                put(i + 1, t);
            } else {
                put(0, 1.0);
            }
            let mut c = nk;
            if free_r0 {
                put(c, -r.i);
                c += 1;
            }
            if free_r1 {
                put(c, -tau.map_or(0.0, |t| r.x_by_tau[t]));
            }
            let y = r.y - ocv;
            let w = r.w / (sigma_v * sigma_v);
            for &(p, ap) in &a[..len] {
                atb[p] += w * ap * y;
                for &(q, aq) in &a[..len] {
                    ata[p * m + q] += w * ap * aq;
                }
            }
        }
        // Pull towards the prior (σ `prior_sigma_v`) and smoothness (second differences,
        // σ 0.03 V).
        let l0 = 1.0 / (prior_sigma_v * prior_sigma_v);
        let l2 = 1.0 / (0.03f64 * 0.03);
        for k in 0..nk {
            ata[k * m + k] += l0;
        }
        if learn_shape {
            // The end of the discharge keeps the prior's shape (σ 0.05 V about the deviation at
            // KNEE_FREE_SOC): where the knee sits cannot be told from a lost capacity by the
            // voltage alone, so the chemistry says it, and a capacity lost stays the effect
            // `capacity_fade` instead of a curve that dives early.
            let lk = 1.0 / (0.05f64 * 0.05);
            let anchor = KNEE_KNOT;
            for k in 0..anchor {
                for (p, cp) in [(k, 1.0), (anchor, -1.0)] {
                    for (q, cq) in [(k, 1.0), (anchor, -1.0)] {
                        ata[p * m + q] += lk * cp * cq;
                    }
                }
            }
            for k in 1..nk - 1 {
                let idx = [k - 1, k, k + 1];
                let coef = [1.0, -2.0, 1.0];
                for (p, cp) in idx.iter().zip(coef) {
                    for (q, cq) in idx.iter().zip(coef) {
                        ata[p * m + q] += l2 * cp * cq;
                    }
                }
            }
        }
        let sol = solve(ata, atb)?;
        let mut c = nk;
        let r0 = if free_r0 {
            c += 1;
            sol[c - 1]
        } else {
            0.0
        };
        let r1 = if free_r1 { sol[c] } else { 0.0 };
        if free_r0 && r0 < 0.0 {
            free_r0 = false;
            continue;
        }
        if free_r1 && r1 < 0.0 {
            free_r1 = false;
            continue;
        }
        let mut knots = prior.ocv_cell_v;
        for (k, slot) in knots.iter_mut().enumerate() {
            *slot += if learn_shape { sol[k] } else { sol[0] };
        }
        // Monotone: isotonic regression weighted by how much data each knot saw.
        let mut wk = [1.0; OCV_KNOTS];
        for r in rows {
            let (i, t) = hat(r.soc);
            wk[i] += r.w * (1.0 - t);
            wk[i + 1] += r.w * t;
        }
        let iso = isotonic(&knots, &wk);
        knots.copy_from_slice(&iso);
        let b = LearnedBattery {
            ocv_cell_v: strictly_increasing(knots),
            series_resistance_cell_ohm: r0,
            rc_resistance_cell_ohm: r1,
            rc_time_constant_s: if r1 > 0.0 {
                tau.map_or(0.0, |t| TAUS_S[t])
            } else {
                0.0
            },
        };
        // Objective: weighted squared residual plus the penalties.
        let mut sse = 0.0;
        let mut sw = 0.0;
        let mut obj = 0.0;
        for r in rows {
            let x1 = tau.map_or(0.0, |t| r.x_by_tau[t]);
            let e = r.y - b.ocv_cell_v(r.soc) + r.i * r0 + x1 * r1;
            sse += r.w * e * e;
            sw += r.w;
            obj += r.w * e * e / (sigma_v * sigma_v);
        }
        for k in 0..OCV_KNOTS {
            let dk = b.ocv_cell_v[k] - prior.ocv_cell_v[k];
            obj += if learn_shape {
                l0 * dk * dk / OCV_KNOTS as f64
            } else {
                0.0
            };
        }
        return Some((b, obj, (sse / sw.max(1e-300)).sqrt()));
    }
    None
}

/// Widest departure of a learned knot from its prior, in σ of the prior's pull in the fit
/// (0.03 V per cell with the chemistry given, 0.3 V without): beyond it the data pulled the
/// curve out of the chemistry's band, which a healthy pack of that chemistry does not do (a
/// count far off, a wrong chemistry, a measured curve that is not this pack's).
pub const PRIOR_BAND_SIGMAS: f64 = 3.0;

/// What the flights behind a learned battery could not teach, in words with numbers; empty
/// when nothing is missing. Nothing here changes the learned battery (where no flight
/// measured the curve, the fit already keeps the prior's shape there): it says which parts of
/// it are the prior's and which data would teach them.
///
/// - **One flight**: nothing to judge the fit against (a second flight's scatter: its own
///   current sensor's scale, its own start).
/// - **Charge no flight visited** (more than one knot, 5 %, at either end): there the curve is
///   the prior's shape, shifted with the learned part. When the lowest charge reached is next
///   to the flights' cut-off (per cell, the median over the flights; within a knot), the part
///   below is charge the autopilot never uses, whatever its voltage.
/// - **Knots beyond the prior's band** ([`PRIOR_BAND_SIGMAS`] × the prior's σ) inside the
///   charge the flights covered, where the prior lies above the cut-off.
/// - **No RC pair**: its fit came out at zero, so the series resistance carries the whole sag
///   (a steady load, e.g. one hover, cannot tell a fast sag from a resistance; changing loads
///   can).
///
/// `prior_sigma_v` is the σ of the prior's pull in the fit, V per cell.
pub fn plausibility(fit: &BatteryFit, data: &[BatteryData<'_>], prior_sigma_v: f64) -> Vec<String> {
    let mut out = Vec::new();
    if fit.samples == 0 {
        return out;
    }
    let b = &fit.battery;
    if fit.flights == 1 {
        out.push(
            "learned from one flight: nothing to judge the fit against (another flight's scatter, its current sensor's own scale); learn from several flights of the pack, from full to the cut-off".to_owned(),
        );
    }
    let measured = fit.prior == Chemistry::Measured;
    let step = 1.0 / (OCV_KNOTS - 1) as f64;
    let (lo, hi) = fit.soc_covered;
    if !measured {
        let mut cutoffs: Vec<f64> = data
            .iter()
            .map(|d| d.flight.info.cutoff_voltage_v / f64::from(d.flight.info.cells.max(1)))
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect();
        cutoffs.sort_by(f64::total_cmp);
        let cutoff = crate::stats::median(&cutoffs);
        if lo > step {
            let at_zero = format!(
                "the curve there is the {} prior's shape, not these flights' ({:.2} V per cell at 0 %)",
                fit.prior.name(),
                b.ocv_cell_v[0]
            );
            // Where the flights' cut-off sits on this curve (its open-circuit voltage is at
            // least the loaded cut-off, so the charge below it is never flown).
            let s_cut = cutoff.map(|c| (c, b.soc_for_ocv(c)));
            out.push(match s_cut {
                Some((c, sc)) if lo <= sc + step => format!(
                    "no flight reached below {:.0} % charge, next to the flights' cut-off ({c:.2} V per cell, {:.0} % charge on this curve): {at_zero}, charge the autopilot never uses",
                    lo * 100.0,
                    sc * 100.0
                ),
                _ => format!(
                    "no flight reached below {:.0} % charge: {at_zero}; fly a flight to the cut-off to learn it",
                    lo * 100.0
                ),
            });
        }
        if hi < 1.0 - step {
            out.push(format!(
                "no flight started above {:.0} % charge: above it the curve is the {} prior's shape, not these flights' ({:.2} V per cell full); start a flight from a full pack to learn it",
                hi * 100.0,
                fit.prior.name(),
                b.ocv_cell_v[OCV_KNOTS - 1]
            ));
        }
        if let Some(prior) = fit.prior.prior() {
            let band = PRIOR_BAND_SIGMAS * prior_sigma_v;
            let worst = (0..OCV_KNOTS)
                // Inside the charge the flights covered, and where the prior lies above the
                // cut-off (below it a prior's end is the electrodes' stoichiometric limit, e.g.
                // LiFePO₄'s 1.56 V per cell at 0 %, not a state any flight reaches).
                .filter(|&k| {
                    let soc = k as f64 * step;
                    soc >= lo - 1e-9
                        && soc <= hi + 1e-9
                        && cutoff.is_none_or(|c| prior.ocv_cell_v[k] >= c)
                })
                .map(|k| (k, b.ocv_cell_v[k] - prior.ocv_cell_v[k]))
                .max_by(|x, y| x.1.abs().total_cmp(&y.1.abs()));
            if let Some((k, d)) = worst.filter(|(_, d)| d.abs() > band) {
                out.push(format!(
                    "the curve leaves the {} prior's band: {:+.2} V per cell at {:.0} % charge, beyond {band:.2} V ({PRIOR_BAND_SIGMAS:.0} σ of the prior); a count far off, another chemistry (--chemistry), or a pack unlike its rating",
                    fit.prior.name(),
                    d,
                    k as f64 * step * 100.0
                ));
            }
        }
    }
    if b.rc_resistance_cell_ohm <= 0.0 {
        out.push(format!(
            "no RC pair identified (its fit came out at zero): the series resistance ({:.1} mΩ per cell) carries the whole sag; flights whose load changes (climbs, attachment, a hover after a climb) separate the two",
            b.series_resistance_cell_ohm * 1000.0
        ));
    }
    out
}

/// Learns one battery type's behaviour from its training flights (see the module docs).
/// `measured`: a given curve (kept as it is); else `chemistry`'s prior when known, else every
/// chemistry prior, the best-fitting kept.
pub fn fit_battery(
    battery_type: &str,
    data: &[BatteryData<'_>],
    measured: Option<&LearnedBattery>,
    chemistry: Option<Chemistry>,
) -> BatteryFit {
    let priors: Vec<(Chemistry, LearnedBattery)> = match (measured, chemistry) {
        (Some(b), _) => vec![(Chemistry::Measured, *b)],
        (None, Some(c)) => c.prior().map(|b| (c, b)).into_iter().collect(),
        (None, None) => Chemistry::PRIORS
            .iter()
            .filter_map(|c| c.prior().map(|b| (*c, b)))
            .collect(),
    };
    // A known chemistry's curve varies little from pack to pack (σ 0.03 V); an unknown one may
    // be any of them and between (σ 0.3 V).
    let prior_sigma_v = if chemistry.is_some() { 0.03 } else { 0.3 };
    let vmax = data
        .iter()
        .map(|d| charge_of(d, &LearnedBattery::lipo()).1)
        .fold(f64::NEG_INFINITY, f64::max);
    let priors: Vec<(Chemistry, LearnedBattery)> = if priors.len() > 1 && vmax.is_finite() {
        let dist = |b: &LearnedBattery| (b.ocv_cell_v[OCV_KNOTS - 1] - vmax).abs();
        let best = priors
            .iter()
            .map(|p| dist(&p.1))
            .fold(f64::INFINITY, f64::min);
        priors
            .into_iter()
            .filter(|p| dist(&p.1) <= best + PRIOR_FULL_MATCH_CELL_V)
            .collect()
    } else {
        priors
    };
    let current = if data.iter().all(|d| d.source == CurrentSource::Logged) {
        CurrentSource::Logged
    } else {
        CurrentSource::PowerModel
    };
    let seeds = row_seeds(data);
    let mut best: Option<(BatteryFit, f64)> = None;
    for (chem, prior) in priors {
        // Rounds: the state of charge depends on the curve (start and capacity).
        let mut start = prior;
        let mut result = None;
        for round in 0..2 {
            let (rows, anchor) = rows_of(data, &seeds, &start);
            // Counted on the first round's curve: flights whose count the voltage's start runs
            // far past empty (see the note below).
            let past_empty = if round == 1 {
                counted_past_empty(data, &start)
            } else {
                0
            };
            let prior_ocv: Vec<f64> = rows.iter().map(|r| prior.ocv_cell_v(r.soc)).collect();
            let lo = rows.iter().map(|r| r.soc).fold(f64::INFINITY, f64::min);
            let hi = rows.iter().map(|r| r.soc).fold(f64::NEG_INFINITY, f64::max);
            let span = (hi - lo).max(0.0);
            // Without current the state of charge comes from the power model, and the curve's
            // shape would trade off against that power: only an offset is learned then.
            let learn_shape = chem != Chemistry::Measured
                && current == CurrentSource::Logged
                && rows.len() >= MIN_SAMPLES
                && span >= MIN_SOC_SPAN;
            let mut round: Option<(LearnedBattery, f64, f64)> = None;
            for tau in std::iter::once(None).chain((0..TAUS_S.len()).map(Some)) {
                if let Some(c) =
                    fit_once(&rows, &prior, &prior_ocv, tau, learn_shape, prior_sigma_v)
                {
                    if round.as_ref().is_none_or(|r| c.1 < r.1) {
                        round = Some(c);
                    }
                }
            }
            let Some((mut b, obj, rmse)) = round else {
                break;
            };
            if chem == Chemistry::Measured {
                b.ocv_cell_v = prior.ocv_cell_v;
            }
            let mut note = if chem == Chemistry::Measured {
                "open-circuit curve as measured (given); resistances learned".to_owned()
            } else if learn_shape {
                format!(
                    "open-circuit curve learned over state of charge {:.2}–{:.2}, the {} prior's shape beyond",
                    lo.max(0.0),
                    hi.min(1.0),
                    chem.name()
                )
            } else if current == CurrentSource::PowerModel {
                format!(
                    "no current logged: the {} prior's shape shifted to the flights (the shape would trade off against the power model), resistances learned",
                    chem.name()
                )
            } else {
                format!(
                    "too little data to learn the curve's shape ({} samples over {:.2} of the charge; needs {MIN_SAMPLES} over {MIN_SOC_SPAN}): the {} prior shifted, resistances learned",
                    rows.len(),
                    span,
                    chem.name()
                )
            };
            if past_empty > 0 {
                note.push_str(&format!(
                    "; UNRELIABLE: on the first round's curve the voltage reads starts that the charge counted runs {past_empty} of {} flights more than {:.0} % of the charge past empty (a flat stretch of the curve, or a count far off): their last samples pile onto the curve's lowest knots",
                    data.len(),
                    MAX_COUNT_PAST_EMPTY * 100.0
                ));
            }
            result = Some((
                BatteryFit {
                    battery_type: battery_type.to_owned(),
                    battery: b,
                    prior: chem,
                    flights: data.len(),
                    samples: rows.len(),
                    soc_covered: (lo.max(0.0), hi.min(1.0)),
                    rmse_cell_v: rmse,
                    current,
                    note,
                    rated_capacity_ah: data.first().map_or(f64::NAN, |d| {
                        d.flight.info.battery_energy_wh
                            / (f64::from(d.flight.info.cells.max(1)) * b.mean_ocv_cell_v())
                    }),
                    usable_capacity_ah: anchor.usable_ah,
                    warnings: Vec::new(),
                },
                obj,
            ));
            start = b;
        }
        if let Some((fit, obj)) = result {
            if best.as_ref().is_none_or(|b| obj < b.1) {
                best = Some((fit, obj));
            }
        }
    }
    best.map(|(mut fit, _)| {
        fit.warnings = plausibility(&fit, data, prior_sigma_v);
        fit
    })
    .unwrap_or_else(|| {
        let prior = measured.copied().unwrap_or_else(LearnedBattery::lipo);
        BatteryFit {
            battery_type: battery_type.to_owned(),
            battery: prior,
            prior: if measured.is_some() {
                Chemistry::Measured
            } else {
                Chemistry::Lipo
            },
            flights: data.len(),
            samples: 0,
            soc_covered: (0.0, 0.0),
            rmse_cell_v: f64::NAN,
            current,
            note: "no usable samples: the LiPo prior as it is".to_owned(),
            rated_capacity_ah: f64::NAN,
            usable_capacity_ah: None,
            warnings: vec!["no usable samples: nothing was learned".to_owned()],
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn priors_are_monotone_and_span_their_chemistry() {
        for c in Chemistry::PRIORS {
            let b = c.prior().unwrap();
            assert!(b.ocv_cell_v.windows(2).all(|w| w[1] > w[0]), "{c:?}");
            let full = b.ocv_cell_v[OCV_KNOTS - 1];
            let want = match c {
                Chemistry::Lihv => 4.35,
                Chemistry::Lifepo4 => 3.55,
                _ => 4.2,
            };
            assert!((full - want).abs() < 0.1, "{c:?} full at {full} V");
            for k in 0..=100 {
                let s = f64::from(k) / 100.0;
                assert!(
                    (b.soc_for_ocv(b.ocv_cell_v(s)) - s).abs() < 1e-6,
                    "{c:?} at {s}"
                );
            }
            let m = b.mean_ocv_cell_v();
            let range = if c == Chemistry::Lifepo4 {
                3.1..3.4
            } else {
                3.3..4.0
            };
            assert!(range.contains(&m), "{c:?} mean {m}");
        }
    }

    #[test]
    fn a_measured_curve_is_read_resampled_and_checked() {
        let b = LearnedBattery::from_ocv_csv("soc,ocv_v\n0,3.0\n0.5,3.7\n1.0,4.2\n").unwrap();
        assert!((b.ocv_cell_v(0.5) - 3.7).abs() < 1e-9);
        assert!((b.ocv_cell_v(0.25) - 3.35).abs() < 0.02);
        let pct = LearnedBattery::from_ocv_csv("0,3.0\n50,3.7\n100,4.2\n").unwrap();
        assert_eq!(pct.ocv_cell_v, b.ocv_cell_v);
        assert!(matches!(
            LearnedBattery::from_ocv_csv("soc,ocv_v\n0.4,3.7\n1.0,4.2\n"),
            Err(OcvCsvError::Coverage(_))
        ));
        assert!(matches!(
            LearnedBattery::from_ocv_csv("soc,ocv_v\n0,3.0\nhalf,3.7\n"),
            Err(OcvCsvError::Line { line: 3, .. })
        ));
        assert!(matches!(
            LearnedBattery::from_ocv_csv("0,3.0\n1,42\n"),
            Err(OcvCsvError::Range { line: 2, .. })
        ));
    }

    #[test]
    fn the_lifepo4_prior_is_flat_between_its_ends() {
        let b = Chemistry::Lifepo4.prior().unwrap();
        // The two-phase plateau: from 20 % to 80 % charge it rises less than half as much as
        // the LiPo curve.
        let rise = |b: &LearnedBattery| b.ocv_cell_v(0.8) - b.ocv_cell_v(0.2);
        let lipo = LearnedBattery::lipo();
        assert!(rise(&b) < 0.5 * rise(&lipo), "{:?}", b.ocv_cell_v);
        assert!(b.ocv_cell_v(0.0) < 3.0, "{:?}", b.ocv_cell_v);
    }

    /// A 4S, 40 Wh pack resting at 4.16 V per cell for 20 s, then drawing 10 A at 1 Hz until it
    /// has drawn `drawn` of the rated capacity on `b`.
    fn flight_drawing(b: &LearnedBattery, drawn: f64) -> (FlightRecord, Vec<f64>) {
        use crate::flight::{FlightInfo, Phase};
        let (cells, rest_cell_v) = (4.0, 4.16);
        let capacity_ah = 40.0 / (cells * b.mean_ocv_cell_v());
        let flying = (drawn * capacity_ah * 3600.0 / 10.0).round() as usize;
        let n = 20 + flying;
        let current_a: Vec<f64> = (0..n).map(|j| if j < 20 { 0.0 } else { 10.0 }).collect();
        let f = FlightRecord {
            name: "to-cutoff".into(),
            time_s: (0..n).map(|j| j as f64).collect(),
            voltage_v: (0..n)
                .map(|j| {
                    let fr = j.saturating_sub(20) as f64 / flying as f64;
                    cells
                        * if j < 20 {
                            rest_cell_v
                        } else {
                            rest_cell_v - 0.1 - 0.6 * fr
                        }
                })
                .collect(),
            current_a: Some(current_a.clone()),
            phase: (0..n)
                .map(|j| if j < 20 { Phase::Ground } else { Phase::Hover })
                .collect(),
            altitude_m: None,
            info: FlightInfo {
                structure_mass_kg: 1.0,
                battery_mass_kg: 0.3,
                battery_energy_wh: 40.0,
                cells: 4,
                payload_mass_kg: 0.0,
                payload_power_w: 0.0,
                avionics_power_w: 0.0,
                battery_id: None,
                battery_cycles: None,
                ambient_temperature_c: None,
                air_density_kg_m3: None,
                cutoff_voltage_v: cells * (rest_cell_v - 0.7),
                ended_at_cutoff: true,
                ceiling_height_m: None,
                measured_ocv: None,
            },
        };
        (f, current_a)
    }

    #[test]
    fn the_prior_for_an_unknown_chemistry_matches_the_resting_level() {
        // Flights resting at 4.16 V per cell read on a 4.2 V prior; the same flights scaled
        // to 3.6 V per cell on LiFePO4's; a given chemistry wins over the level.
        let (f, _) = flight_drawing(&LearnedBattery::lipo(), 0.8);
        let full = |b: LearnedBattery| b.ocv_cell_v[OCV_KNOTS - 1];
        let hi = prior_by_resting_level(&[&f], None);
        assert!((full(hi) - 4.2).abs() < 0.1, "{}", full(hi));
        let mut lfp = f.clone();
        for v in &mut lfp.voltage_v {
            *v *= 3.6 / 4.16;
        }
        assert!((resting_start_cell_v(&lfp) - 3.6).abs() < 1e-9);
        let lo = prior_by_resting_level(&[&lfp], None);
        assert_eq!(lo, Chemistry::Lifepo4.prior().unwrap());
        let given = prior_by_resting_level(&[&lfp], Some(Chemistry::Lihv));
        assert_eq!(given, Chemistry::Lihv.prior().unwrap());
        assert_eq!(prior_by_resting_level(&[], None), LearnedBattery::lipo());
    }

    /// A learned battery says what its flights could not teach, and nothing when they taught it
    /// all.
    #[test]
    fn plausibility_names_what_the_flights_did_not_cover() {
        let prior = Chemistry::Lipo.prior().unwrap();
        let (f, i) = flight_drawing(&prior, 0.5);
        let data = [BatteryData {
            flight: &f,
            current_a: i,
            source: CurrentSource::Logged,
        }];
        let fit = |b: LearnedBattery, flights: usize, covered: (f64, f64)| BatteryFit {
            battery_type: "4S 40.0 Wh".into(),
            battery: b,
            prior: Chemistry::Lipo,
            flights,
            samples: 300,
            soc_covered: covered,
            rmse_cell_v: 0.01,
            current: CurrentSource::Logged,
            note: String::new(),
            rated_capacity_ah: 3.0,
            usable_capacity_ah: None,
            warnings: Vec::new(),
        };
        let mut with_rc = prior;
        with_rc.rc_resistance_cell_ohm = 0.004;
        with_rc.rc_time_constant_s = 10.0;
        // Several flights over the whole charge, on the prior, with an RC pair: nothing missing.
        assert!(plausibility(&fit(with_rc, 4, (0.0, 1.0)), &data, 0.03).is_empty());
        // One flight over the upper half, no RC pair: each named, with its numbers.
        let w = plausibility(&fit(prior, 1, (0.5, 1.0)), &data, 0.03);
        assert_eq!(w.len(), 3, "{w:?}");
        assert!(w[0].starts_with("learned from one flight"), "{w:?}");
        assert!(
            w[1].starts_with("no flight reached below 50 % charge")
                && w[1].contains("lipo prior's shape")
                && w[1].contains("fly a flight to the cut-off"),
            "{w:?}"
        );
        assert!(w[2].starts_with("no RC pair identified"), "{w:?}");
        // Reaching down to the cut-off (3.46 V per cell here): the rest is charge never used.
        let s_cut = prior.soc_for_ocv(3.46);
        let w = plausibility(&fit(with_rc, 4, (s_cut + 0.02, 1.0)), &data, 0.03);
        assert!(
            w.len() == 1 && w[0].contains("charge the autopilot never uses"),
            "{w:?}"
        );
        // A start short of full.
        let w = plausibility(&fit(with_rc, 4, (0.0, 0.8)), &data, 0.03);
        assert!(
            w.len() == 1 && w[0].starts_with("no flight started above 80 % charge"),
            "{w:?}"
        );
        // A knot pulled 0.2 V off the prior inside the covered charge: beyond 3 × 0.03 V, but
        // within 3 × 0.3 V when the chemistry was not given.
        let mut off = with_rc;
        off.ocv_cell_v[10] += 0.2;
        let w = plausibility(&fit(off, 4, (0.0, 1.0)), &data, 0.03);
        assert!(
            w.len() == 1 && w[0].contains("+0.20 V per cell at 50 % charge"),
            "{w:?}"
        );
        assert!(plausibility(&fit(off, 4, (0.0, 1.0)), &data, 0.3).is_empty());
    }

    #[test]
    fn a_start_read_on_a_flat_stretch_is_counted_far_past_empty() {
        // A curve flat from 0.45 of the charge up, as a first round's isotonic fit leaves it when
        // a pack's flights disagree in voltage (tuning seed 39's pack nmc-B): resting at 4.16 V
        // per cell reads a start near 0.4, and a flight that then drew 90 % of the rated charge
        // is counted half a pack past empty.
        let mut flat = LearnedBattery::lipo();
        for (k, v) in flat.ocv_cell_v.iter_mut().enumerate() {
            let s = k as f64 / (OCV_KNOTS - 1) as f64;
            *v = if s < 0.45 { 3.6 + 1.4 * s } else { 4.245 };
        }
        flat.ocv_cell_v = strictly_increasing(flat.ocv_cell_v);
        let (f, i) = flight_drawing(&flat, 0.9);
        assert!(f.initial_soc(&flat, 0.0, 0.0) < 0.5);
        let logged = [BatteryData {
            flight: &f,
            current_a: i.clone(),
            source: CurrentSource::Logged,
        }];
        assert_eq!(counted_past_empty(&logged, &flat), 1);
        let (rows, _) = rows_of(&logged, &row_seeds(&logged), &flat);
        let lowest = rows.iter().map(|r| r.soc).fold(f64::INFINITY, f64::min);
        assert!(lowest < -MAX_COUNT_PAST_EMPTY, "{lowest}");
        // On the LiPo prior the same flight reads nearly full and ends above empty.
        let lipo = LearnedBattery::lipo();
        let (f, i) = flight_drawing(&lipo, 0.9);
        let on_lipo = [BatteryData {
            flight: &f,
            current_a: i.clone(),
            source: CurrentSource::Logged,
        }];
        assert_eq!(counted_past_empty(&on_lipo, &lipo), 0);
        // The power model's current is no measurement of the charge: never counted.
        let (f, i) = flight_drawing(&flat, 0.9);
        let modelled = [BatteryData {
            flight: &f,
            current_a: i,
            source: CurrentSource::PowerModel,
        }];
        assert_eq!(counted_past_empty(&modelled, &flat), 0);
    }

    #[test]
    fn the_lipo_prior_has_its_knee_at_the_end_of_the_discharge() {
        let (s, v) = LearnedBattery::lipo().knee().unwrap();
        assert!(s < 0.2 && v < 3.7, "knee at {s} ({v} V)");
    }
}
