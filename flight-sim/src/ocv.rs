//! Open-circuit voltage of one cell against state of charge, per chemistry.
//!
//! For the chemistries with measured electrode curves (LiCoO2, NMC, NCA against graphite), the
//! cell's open-circuit voltage is the positive electrode's potential minus the negative
//! electrode's: `U(s) = U_p(y(s)) − U_n(x(s))`, with the negative stoichiometry `x` running from
//! `x0` (empty) to `x100` (full) and the positive `y` the other way, from `y0` down to `y100`.
//! Charge is conserved between the electrodes: each chemistry has one balance (the ratio of the
//! electrodes' capacities, from its textbook window), so `x` and `y` move on one line whose
//! offset is the lithium the pack can cycle. A pack draws its own lithium inventory, and its
//! full and empty points are where the cell then reads the chemistry's full and empty voltages
//! (with a little per-pack scatter), as electrode state-of-health algorithms do. A voltage
//! the electrodes cannot reach is an error ([`OcvOutOfRange`]), never a clamp. LiFePO4 uses a
//! Nernst-type formula with Shepherd
//! exponential zones at both ends.

use crate::Chemistry;

/// A measured electrode potential curve: stoichiometry (increasing) and potential, V.
#[derive(Debug, Clone)]
struct Electrode {
    sto: Vec<f64>,
    volts: Vec<f64>,
}

impl Electrode {
    /// Parses PyBaMM's two-column files (`#` comments, comma or space separated).
    fn parse(text: &str) -> Self {
        let mut pts: Vec<(f64, f64)> = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('#'))
            .filter_map(|l| {
                let mut it = l
                    .split(|c: char| c == ',' || c.is_whitespace())
                    .filter(|s| !s.is_empty());
                Some((it.next()?.parse().ok()?, it.next()?.parse().ok()?))
            })
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        pts.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-12);
        Self {
            sto: pts.iter().map(|p| p.0).collect(),
            volts: pts.iter().map(|p| p.1).collect(),
        }
    }

    /// Potential at stoichiometry `s` (linear between points, clamped at the ends).
    fn at(&self, s: f64) -> f64 {
        interp(&self.sto, &self.volts, s)
    }
}

/// Linear interpolation in an increasing table, clamped.
pub(crate) fn interp(x: &[f64], y: &[f64], at: f64) -> f64 {
    let n = x.len();
    if at <= x[0] {
        return y[0];
    }
    if at >= x[n - 1] {
        return y[n - 1];
    }
    let k = x.partition_point(|v| *v <= at).clamp(1, n - 1);
    let f = (at - x[k - 1]) / (x[k] - x[k - 1]);
    y[k - 1] + f * (y[k] - y[k - 1])
}

const LICO2: &str = include_str!("../data/lico2_ocp_Ai2020.csv");
const GRAPHITE_AI: &str = include_str!("../data/graphite_ocp_Enertech_Ai2020.csv");
const NMC: &str = include_str!("../data/nmc_LGM50_ocp_Chen2020.csv");
const GRAPHITE_CHEN: &str = include_str!("../data/graphite_LGM50_ocp_Chen2020.csv");
const NCA: &str = include_str!("../data/nca_ocp_Kim2011_data.csv");
const NCO: &str = include_str!("../data/nco_ocp_Ecker2015.csv");
const GRAPHITE_ECKER: &str = include_str!("../data/graphite_ocp_Ecker2015.csv");

/// How a pack of a chemistry differs from the textbook cell (drawn per pack).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OcvScatter {
    /// Shift of the negative electrode's window (lithium inventory), stoichiometry units.
    pub window_shift: f64,
    /// Charger's end-of-charge voltage error, V.
    pub full_offset_v: f64,
    /// Offset of the empty voltage, V.
    pub empty_offset_v: f64,
}

impl OcvScatter {
    /// One pack's draw as the simulator makes it: σ 1 % lithium inventory (negative-electrode
    /// stoichiometry), σ 6 mV charger error, σ 20 mV empty-voltage offset.
    pub fn draw(rng: &mut rand_chacha::ChaCha8Rng) -> Self {
        Self {
            window_shift: 0.01 * crate::normal(rng),
            full_offset_v: 0.006 * crate::normal(rng),
            empty_offset_v: 0.02 * crate::normal(rng),
        }
    }

    /// No scatter.
    pub const NONE: Self = Self {
        window_shift: 0.0,
        full_offset_v: 0.0,
        empty_offset_v: 0.0,
    };
}

/// A cell's open-circuit curve as a table on a uniform state-of-charge grid, from full (1) to
/// the rated empty (0), and on below the rated empty while the electrodes still hold lithium.
#[derive(Debug, Clone, PartialEq)]
pub struct OcvCurve {
    /// Open-circuit voltage at state of charge `k / (n − 1)`, V.
    volts: Vec<f64>,
    /// Below the rated empty: the voltage at state of charge `−(k + 1) / (n − 1)`, V, down to
    /// where the electrodes run out.
    below_empty: Vec<f64>,
    /// The state of charge at which the electrodes are exhausted (no charge is left to draw);
    /// at most 0 for the layered oxides, above 0 for a LiFePO₄ pack whose window starts late.
    exhausted_soc: f64,
}

/// Points of the table.
const GRID: usize = 401;

/// A pack's scatter asks for a voltage its electrodes cannot reach.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error(
    "{chemistry:?} pack: a cell voltage of {target_v:.4} V lies outside what its electrodes reach \
     on their lithium line ({lo_v:.4}–{hi_v:.4} V)"
)]
pub struct OcvOutOfRange {
    /// The pack's chemistry.
    pub chemistry: Chemistry,
    /// The full or empty voltage asked for, V.
    pub target_v: f64,
    /// The lowest cell voltage reachable, V.
    pub lo_v: f64,
    /// The highest cell voltage reachable, V.
    pub hi_v: f64,
}

/// The electrode pair of a layered-oxide chemistry and its charge balance.
///
/// Charge is conserved between the electrodes: with capacities `Q_n` and `Q_p`, the lithium a
/// pack can cycle fixes `Q_n·x + Q_p·y`, so the stoichiometries move on the line
/// `y = c − r·x` with `r = Q_n / Q_p`. The ratio `r` is the chemistry's (one balance per
/// chemistry, from its textbook window); `c` is the pack's lithium inventory.
struct Oxide {
    pos: Electrode,
    neg: Electrode,
    /// `Q_n / Q_p`.
    ratio: f64,
    /// The textbook pack's `c`.
    inventory: f64,
}

impl Oxide {
    /// The chemistry's electrode pair and balance, built once per process (the tables are
    /// parsed and the textbook window solved at the first pack of the chemistry, not at every
    /// pack).
    fn of(chem: Chemistry) -> &'static Self {
        static OXIDES: [std::sync::OnceLock<Oxide>; 4] = [const { std::sync::OnceLock::new() }; 4];
        let k = match chem {
            Chemistry::LiPo => 0,
            Chemistry::LiHv => 1,
            Chemistry::Nmc => 2,
            _ => 3,
        };
        OXIDES[k].get_or_init(|| Self::new(chem))
    }

    fn new(chem: Chemistry) -> Self {
        let (pos, neg, x0, x100) = match chem {
            Chemistry::LiPo => (LICO2, GRAPHITE_AI, 0.02, 0.82),
            Chemistry::LiHv => (NCO, GRAPHITE_ECKER, 0.02, 0.85),
            Chemistry::Nmc => (NMC, GRAPHITE_CHEN, 0.03, 0.90),
            _ => (NCA, GRAPHITE_CHEN, 0.03, 0.88),
        };
        let (pos, neg) = (Electrode::parse(pos), Electrode::parse(neg));
        let (v_full, v_empty) = chem.full_empty_cell_v();
        // The textbook window: the positive stoichiometries that read the chemistry's full and
        // empty voltages at the negative window's ends (U_p falls as y grows).
        let solve_y = |target: f64| {
            let (mut lo, mut hi) = (pos.sto[0], pos.sto[pos.sto.len() - 1]);
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                if pos.at(mid) > target {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            0.5 * (lo + hi)
        };
        let y100 = solve_y(v_full + neg.at(x100));
        let y0 = solve_y(v_empty + neg.at(x0));
        let ratio = (y0 - y100) / (x100 - x0);
        Self {
            inventory: y0 + ratio * x0,
            pos,
            neg,
            ratio,
        }
    }

    /// The negative stoichiometries on the line `y = c − r·x` that both electrodes' tables
    /// cover.
    fn domain(&self, inventory: f64) -> (f64, f64) {
        let (n, p) = (&self.neg.sto, &self.pos.sto);
        let lo = n[0].max((inventory - p[p.len() - 1]) / self.ratio);
        let hi = n[n.len() - 1].min((inventory - p[0]) / self.ratio);
        (lo, hi)
    }

    /// Cell voltage at negative stoichiometry `x` on the line of `inventory`, V (rises with x).
    fn cell_v(&self, inventory: f64, x: f64) -> f64 {
        self.pos.at(inventory - self.ratio * x) - self.neg.at(x)
    }

    /// The `x` on the line where the cell reads `target`, or why there is none.
    fn x_at(&self, chem: Chemistry, inventory: f64, target: f64) -> Result<f64, OcvOutOfRange> {
        let (mut lo, mut hi) = self.domain(inventory);
        let (lo_v, hi_v) = (self.cell_v(inventory, lo), self.cell_v(inventory, hi));
        if !(lo < hi && lo_v <= target && target <= hi_v) {
            return Err(OcvOutOfRange {
                chemistry: chem,
                target_v: target,
                lo_v,
                hi_v,
            });
        }
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if self.cell_v(inventory, mid) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Ok(0.5 * (lo + hi))
    }
}

impl OcvCurve {
    /// The curve of one pack of `chem` with its scatter.
    ///
    /// # Panics
    /// If the scatter asks for a voltage the electrodes cannot reach (see [`Self::try_new`]);
    /// never for [`OcvScatter::NONE`].
    pub fn new(chem: Chemistry, scatter: OcvScatter) -> Self {
        match Self::try_new(chem, scatter) {
            Ok(c) => c,
            Err(e) => panic!("{e}"),
        }
    }

    /// The curve of one pack of `chem` with its scatter, or the voltage it cannot reach.
    ///
    /// Layered oxides: the pack's lithium inventory moves the electrodes along their
    /// charge-conserving line by `window_shift` (in negative-electrode stoichiometry); the
    /// pack's full and empty points are where the cell then reads the chemistry's full and
    /// empty voltages plus the pack's offsets. LiFePO4: the formula, shifted by the scatter.
    ///
    /// The rated empty is not the end of the cell: below it the curve goes on along the same
    /// electrodes (falling steeply) until they run out ([`Self::exhausted_soc`]), so a pack
    /// discharged past its rated empty keeps falling towards its autopilot's cut-off.
    pub fn try_new(chem: Chemistry, scatter: OcvScatter) -> Result<Self, OcvOutOfRange> {
        let step = 1.0 / (GRID - 1) as f64;
        let (volts, below_empty, exhausted_soc) = match chem {
            Chemistry::LiFePo4 => {
                // The formula's window ends where `soc + window_shift` reaches its lowest
                // stoichiometry: the electrode's lithium is used up there.
                let exhausted = LFP_LOWEST_STO - scatter.window_shift;
                let below: Vec<f64> = (1..)
                    .map(|k| -(k as f64) * step)
                    .take_while(|s| *s >= exhausted)
                    .map(|s| lfp_cell_v(s, scatter))
                    .collect();
                let volts = (0..GRID)
                    .map(|k| lfp_cell_v(k as f64 * step, scatter))
                    .collect();
                let exhausted = exhausted.max(-(below.len() as f64) * step);
                (volts, below, exhausted)
            }
            _ => {
                let ox = Oxide::of(chem);
                let (v_full, v_empty) = chem.full_empty_cell_v();
                let inventory = ox.inventory + ox.ratio * scatter.window_shift;
                let x0 = ox.x_at(chem, inventory, v_empty + scatter.empty_offset_v)?;
                let x100 = ox.x_at(chem, inventory, v_full + scatter.full_offset_v)?;
                let x_of = |s: f64| x0 + s * (x100 - x0);
                let (x_lowest, _) = ox.domain(inventory);
                let below: Vec<f64> = (1..)
                    .map(|k| -(k as f64) * step)
                    .take_while(|s| x_of(*s) >= x_lowest)
                    .map(|s| ox.cell_v(inventory, x_of(s)))
                    .collect();
                let volts = (0..GRID)
                    .map(|k| ox.cell_v(inventory, x_of(k as f64 * step)))
                    .collect();
                let exhausted = -(below.len() as f64) * step;
                (volts, below, exhausted)
            }
        };
        Ok(Self {
            volts,
            below_empty,
            exhausted_soc,
        })
    }

    /// Open-circuit voltage at state of charge `soc` (0 rated empty, 1 full; above 1 the full
    /// voltage; below 0 the curve below the rated empty, down to [`Self::exhausted_soc`] and
    /// the last voltage there beyond it), V.
    pub fn at(&self, soc: f64) -> f64 {
        if soc < 0.0 {
            let x = -soc * (GRID - 1) as f64;
            let i = x.floor() as usize;
            let f = x - i as f64;
            let v = |k: usize| {
                if k == 0 {
                    self.volts[0]
                } else {
                    let below = &self.below_empty;
                    below
                        .get(k - 1)
                        .or(below.last())
                        .copied()
                        .unwrap_or(self.volts[0])
                }
            };
            return v(i) * (1.0 - f) + v(i + 1) * f;
        }
        let x = soc.min(1.0) * (GRID - 1) as f64;
        let i = (x.floor() as usize).min(GRID - 2);
        let f = x - i as f64;
        self.volts[i] * (1.0 - f) + self.volts[i + 1] * f
    }

    /// The state of charge at which the cell's electrodes are exhausted: no charge is left to
    /// draw below it. At most 0 for the layered oxides (their electrodes reach below the rated
    /// empty voltage); for LiFePO₄ `0.002 − window_shift`, above 0 for a pack whose window
    /// starts late.
    pub fn exhausted_soc(&self) -> f64 {
        self.exhausted_soc
    }

    /// Mean open-circuit voltage over a full discharge, V (charge-weighted: energy per charge).
    pub fn mean_v(&self) -> f64 {
        let n = self.volts.len();
        (self.volts.iter().sum::<f64>() - 0.5 * (self.volts[0] + self.volts[n - 1]))
            / (n - 1) as f64
    }
}

/// The lowest (and `1 −` the highest) stoichiometry of the LiFePO₄ formula's window.
const LFP_LOWEST_STO: f64 = 0.002;

/// LiFePO4: a flat two-phase plateau with a Nernst term in the middle and Shepherd exponential
/// zones where the electrodes run out of lithium sites at both ends, V.
fn lfp_cell_v(soc: f64, scatter: OcvScatter) -> f64 {
    // RT/F at 298 K, V.
    const THERMAL_V: f64 = 0.025_693;
    let s = (soc + scatter.window_shift).clamp(LFP_LOWEST_STO, 1.0 - LFP_LOWEST_STO);
    3.300 + 0.045 * (s - 0.5) + 0.5 * THERMAL_V * (s / (1.0 - s)).ln()
        - (0.45 - scatter.empty_offset_v) * (-s / 0.035).exp()
        + (0.19 + scatter.full_offset_v) * (-(1.0 - s) / 0.025).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curves_span_their_chemistry_and_fall_monotonically() {
        for chem in Chemistry::ALL {
            let c = OcvCurve::new(chem, OcvScatter::NONE);
            let (full, empty) = chem.full_empty_cell_v();
            assert!(
                (c.at(1.0) - full).abs() < 0.03,
                "{chem:?} full {}",
                c.at(1.0)
            );
            assert!(
                (c.at(0.0) - empty).abs() < 0.06,
                "{chem:?} empty {}",
                c.at(0.0)
            );
            let mut last = f64::INFINITY;
            for k in 0..=100 {
                let v = c.at(1.0 - k as f64 / 100.0);
                assert!(v <= last + 0.01, "{chem:?} rises at {k}: {v} after {last}");
                last = v;
            }
        }
    }

    #[test]
    fn chemistries_have_their_own_shapes() {
        let mid = |c: Chemistry| OcvCurve::new(c, OcvScatter::NONE).at(0.5);
        // LiFePO4's plateau sits near 3.3 V; the layered oxides around 3.7–3.9 V.
        assert!((mid(Chemistry::LiFePo4) - 3.30).abs() < 0.05);
        for c in [Chemistry::LiPo, Chemistry::Nmc, Chemistry::Nca] {
            assert!((3.5..4.0).contains(&mid(c)), "{c:?} {}", mid(c));
        }
        // LiHV holds more: higher mean voltage than LiPo.
        let mean = |c: Chemistry| OcvCurve::new(c, OcvScatter::NONE).mean_v();
        assert!(mean(Chemistry::LiHv) > mean(Chemistry::LiPo) + 0.02);
        // The LFP plateau is flat: 20–80 % spans under 0.1 V, the oxides' over 0.2 V.
        let span = |c: Chemistry| {
            let k = OcvCurve::new(c, OcvScatter::NONE);
            k.at(0.8) - k.at(0.2)
        };
        assert!(span(Chemistry::LiFePo4) < 0.1);
        assert!(span(Chemistry::Nmc) > 0.2);
    }

    /// Every drawn pack (the simulator's scatter: σ 1 % lithium inventory, 6 mV charger, 20 mV
    /// empty) reads its own full and empty voltages, falls monotonically and stays near its
    /// chemistry's curve: a 1 % inventory shift is a few millivolts, not a cliff.
    #[test]
    fn drawn_packs_stay_physical() {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x0c5);
        for chem in Chemistry::ALL {
            if chem == Chemistry::LiFePo4 {
                continue;
            }
            let nominal = OcvCurve::new(chem, OcvScatter::NONE);
            let wiggle = nominal
                .volts
                .windows(2)
                .map(|w| w[0] - w[1])
                .fold(0.0, f64::max);
            assert!(wiggle < 2e-3, "{chem:?} textbook curve rises by {wiggle}");
            let (full, empty) = chem.full_empty_cell_v();
            let mut worst = 0.0f64;
            for _ in 0..200 {
                let sc = OcvScatter::draw(&mut rng);
                let c = OcvCurve::try_new(chem, sc).unwrap_or_else(|e| panic!("{sc:?}: {e}"));
                assert!(
                    (c.at(1.0) - full - sc.full_offset_v).abs() < 1e-3,
                    "{chem:?} {sc:?}"
                );
                assert!(
                    (c.at(0.0) - empty - sc.empty_offset_v).abs() < 1e-3,
                    "{chem:?} {sc:?}"
                );
                // The measured electrode tables wiggle by under a millivolt (the textbook
                // curve too); a pack must not rise more than that as it discharges.
                for w in c.volts.windows(2) {
                    assert!(
                        w[1] >= w[0] - 2e-3,
                        "{chem:?} {sc:?} rises by {}",
                        w[0] - w[1]
                    );
                }
                for k in 10..=95 {
                    let s = f64::from(k) / 100.0;
                    worst = worst.max((c.at(s) - nominal.at(s)).abs());
                }
            }
            assert!(
                worst < 0.05,
                "{chem:?}: a pack {worst:.3} V off its chemistry"
            );
        }
    }

    /// The rated empty is not the end of a cell: below it every drawn pack's curve goes on
    /// falling along its electrodes, past its autopilot's cut-off (a loaded cut-off, so the
    /// open-circuit voltage must fall below it for any load to reach it) before the
    /// electrodes run out; no stretch of it is flat (a clamp would be).
    #[test]
    fn curves_go_on_below_the_rated_empty_until_the_electrodes_run_out() {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0xe4);
        for chem in Chemistry::ALL {
            for _ in 0..200 {
                let sc = OcvScatter::draw(&mut rng);
                let c = OcvCurve::try_new(chem, sc).unwrap_or_else(|e| panic!("{sc:?}: {e}"));
                let end = c.exhausted_soc();
                if chem == Chemistry::LiFePo4 {
                    // The formula's window: exhausted where `soc + shift` reaches 0.002.
                    assert!(
                        (end - (LFP_LOWEST_STO - sc.window_shift)).abs() < 1.0 / 400.0,
                        "{sc:?}: {end}"
                    );
                } else {
                    assert!(end < 0.0, "{chem:?} {sc:?}: {end}");
                    assert!(
                        c.at(end) < chem.cutoff_cell_v() - 0.05,
                        "{chem:?} {sc:?}: {} V where the electrodes run out",
                        c.at(end)
                    );
                }
                // From the electrodes' end up to 2 % above it, the curve rises step by step.
                let h = 1.0 / 400.0;
                let mut s = end;
                let mut last = c.at(s);
                while s < end + 0.02 {
                    s += h;
                    let v = c.at(s);
                    assert!(
                        v > last + 1e-4,
                        "{chem:?} {sc:?}: flat at {s}: {v} after {last}"
                    );
                    last = v;
                }
            }
        }
    }

    #[test]
    fn unreachable_voltages_are_errors_not_clamps() {
        let far = OcvScatter {
            window_shift: 0.0,
            full_offset_v: 1.0,
            empty_offset_v: 0.0,
        };
        let e = OcvCurve::try_new(Chemistry::Nmc, far).unwrap_err();
        assert!((e.target_v - 5.2).abs() < 1e-9 && e.hi_v < 5.2, "{e}");
    }

    #[test]
    fn scatter_moves_the_curve() {
        let a = OcvCurve::new(Chemistry::Nmc, OcvScatter::NONE);
        let b = OcvCurve::new(
            Chemistry::Nmc,
            OcvScatter {
                window_shift: 0.02,
                full_offset_v: 0.01,
                empty_offset_v: 0.0,
            },
        );
        assert!((a.at(0.5) - b.at(0.5)).abs() > 1e-3);
    }
}
