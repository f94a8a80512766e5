//! The pack the online estimator flies and the vehicle that carries it: plain fixed-size data,
//! stored in `params.toml` (`[battery]`, `[vehicle]`) and in the parameter blob.

use crate::EstimateError;
use crate::curve::{require_finite, require_non_negative, require_positive};

/// Open-circuit knots of a [`BatteryModel`], at state of charge 0, 0.05, …, 1.
pub const OCV_KNOTS: usize = 21;

/// The built-in LiPo open-circuit curve, V per cell at state of charge 0, 5 %, …, 100 %: the
/// widely used hobby-pack rest-voltage table (flat 3.7–3.9 V plateau, knee below 10 %). Used
/// when a parameter file has no `[battery]` section.
pub const LIPO_OCV_CELL_V: [f64; OCV_KNOTS] = [
    3.27, 3.61, 3.69, 3.71, 3.73, 3.75, 3.77, 3.79, 3.80, 3.82, 3.84, 3.85, 3.87, 3.91, 3.95, 3.98,
    4.02, 4.08, 4.11, 4.15, 4.20,
];

/// Series resistance of one cell when nothing better is known, Ω (PX4's default, 5 mΩ).
pub const DEFAULT_SERIES_RESISTANCE_CELL_OHM: f64 = 0.005;
/// Cut-off voltage of one cell under load when nothing better is known, V.
pub const DEFAULT_CUTOFF_CELL_V: f64 = 3.3;

/// Cell chemistry, as a name in files and a code in the blob.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Chemistry {
    /// LiCoO₂/graphite, 4.20 V full (hobby LiPo).
    Lipo = 1,
    /// LiCoO₂/graphite charged to 4.35 V (LiHV).
    Lihv = 2,
    /// NMC/graphite Li-ion.
    LiIonNmc = 3,
    /// NCA/graphite Li-ion.
    LiIonNca = 4,
    /// LiFePO₄.
    LiFePo4 = 5,
    /// A curve someone measured.
    Measured = 6,
    /// Anything else, or not said.
    Other = 0,
}

impl Chemistry {
    /// Every chemistry.
    pub const ALL: [Chemistry; 7] = [
        Chemistry::Lipo,
        Chemistry::Lihv,
        Chemistry::LiIonNmc,
        Chemistry::LiIonNca,
        Chemistry::LiFePo4,
        Chemistry::Measured,
        Chemistry::Other,
    ];

    /// Name as in files (the same names the gap diagnosis uses).
    pub fn name(self) -> &'static str {
        match self {
            Chemistry::Lipo => "lipo",
            Chemistry::Lihv => "lihv",
            Chemistry::LiIonNmc => "li_ion_nmc",
            Chemistry::LiIonNca => "li_ion_nca",
            Chemistry::LiFePo4 => "lifepo4",
            Chemistry::Measured => "measured",
            Chemistry::Other => "other",
        }
    }

    /// The chemistry of a name (case-insensitive), `None` when unknown.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(name.trim()))
    }

    /// The chemistry of a blob code.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.into_iter().find(|c| *c as u8 == code)
    }
}

/// A battery pack as the online estimator models it: per-cell open-circuit voltage against
/// state of charge (21 knots, monotone cubic between them), a series resistance and one RC pair
/// per cell, `cells` in series, a rated capacity and the cut-off voltage under load.
///
/// This is the form the gap diagnosis learns (`gap::LearnedBattery`) plus what it is learned
/// for: it is stored in `params.toml` as the `[battery]` section and in the parameter blob.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BatteryModel {
    /// Cells in series.
    pub cells: u8,
    /// Rated capacity, Ah.
    pub rated_capacity_ah: f64,
    /// Chemistry (informative; the curve is what the estimator uses).
    pub chemistry: Chemistry,
    /// Open-circuit voltage of one cell at state of charge `k / 20`, V; strictly increasing.
    pub ocv_cell_v: [f64; OCV_KNOTS],
    /// Series resistance of one cell, Ω.
    pub series_resistance_cell_ohm: f64,
    /// Resistance of the RC pair of one cell, Ω (0: no RC pair).
    pub rc_resistance_cell_ohm: f64,
    /// Time constant of the RC pair, s.
    pub rc_time_constant_s: f64,
    /// Voltage of one cell under load at which the flight ends, V.
    pub cutoff_cell_v: f64,
}

impl BatteryModel {
    /// The built-in LiPo pack ([`LIPO_OCV_CELL_V`], 5 mΩ per cell, no RC pair, 3.3 V cut-off)
    /// with the cell count and rated capacity of the pack flown.
    pub fn lipo(cells: u8, rated_capacity_ah: f64) -> Result<Self, EstimateError> {
        let b = Self {
            cells,
            rated_capacity_ah,
            chemistry: Chemistry::Lipo,
            ocv_cell_v: LIPO_OCV_CELL_V,
            series_resistance_cell_ohm: DEFAULT_SERIES_RESISTANCE_CELL_OHM,
            rc_resistance_cell_ohm: 0.0,
            rc_time_constant_s: 0.0,
            cutoff_cell_v: DEFAULT_CUTOFF_CELL_V,
        };
        b.validate()?;
        Ok(b)
    }

    /// The built-in LiPo pack holding `energy_wh` (rated capacity = energy over the cells and
    /// the curve's mean voltage).
    pub fn lipo_from_energy(cells: u8, energy_wh: f64) -> Result<Self, EstimateError> {
        require_positive("battery energy (Wh)", energy_wh)?;
        let mut b = Self::lipo(cells, 1.0)?;
        b.rated_capacity_ah = energy_wh / (f64::from(cells) * b.mean_ocv_cell_v());
        b.validate()?;
        Ok(b)
    }

    /// The parameters' battery model when they have one (a `[battery]` section), else the
    /// built-in LiPo pack ([`Self::lipo_from_energy`]) with the cell count and rated energy of
    /// the pack flown (e.g. from the flight's metadata).
    pub fn from_params_or_lipo(
        params: &crate::Params,
        cells: u8,
        energy_wh: f64,
    ) -> Result<Self, EstimateError> {
        match params.battery {
            Some(b) => {
                b.validate()?;
                Ok(b)
            }
            None => Self::lipo_from_energy(cells, energy_wh),
        }
    }

    /// Checks every value: at least one cell, a positive capacity, a strictly increasing curve
    /// of plausible cell voltages (0.5–5.5 V), non-negative resistances, a positive time
    /// constant when there is an RC pair, and a cut-off below the full voltage.
    pub fn validate(&self) -> Result<(), EstimateError> {
        if self.cells == 0 {
            return Err(EstimateError::NotPositive {
                what: "battery cells",
                value: 0.0,
            });
        }
        require_positive("battery rated capacity (Ah)", self.rated_capacity_ah)?;
        for (k, &v) in self.ocv_cell_v.iter().enumerate() {
            require_finite("battery open-circuit voltage (V per cell)", v)?;
            if !(0.5..=5.5).contains(&v) {
                return Err(EstimateError::Battery {
                    reason: "an open-circuit voltage per cell is outside 0.5–5.5 V",
                    value: v,
                });
            }
            if k > 0 && v <= self.ocv_cell_v[k - 1] {
                return Err(EstimateError::Battery {
                    reason: "the open-circuit curve must rise strictly with the state of charge; knot value",
                    value: v,
                });
            }
        }
        require_non_negative(
            "battery series resistance (Ω per cell)",
            self.series_resistance_cell_ohm,
        )?;
        require_non_negative(
            "battery RC-pair resistance (Ω per cell)",
            self.rc_resistance_cell_ohm,
        )?;
        require_non_negative("battery RC time constant (s)", self.rc_time_constant_s)?;
        if self.rc_resistance_cell_ohm > 0.0 {
            require_positive(
                "battery RC time constant (s) of a pack with an RC pair",
                self.rc_time_constant_s,
            )?;
        }
        require_positive("battery cut-off voltage (V per cell)", self.cutoff_cell_v)?;
        if self.cutoff_cell_v >= self.ocv_cell_v[OCV_KNOTS - 1] {
            return Err(EstimateError::Battery {
                reason: "the cut-off voltage per cell is not below the full open-circuit voltage",
                value: self.cutoff_cell_v,
            });
        }
        Ok(())
    }

    /// Open-circuit voltage of one cell at state of charge `soc` (clamped to 0..1), V: the
    /// monotone cubic (Fritsch–Carlson) through the knots.
    pub fn ocv_cell_at(&self, soc: f64) -> f64 {
        self.ocv_and_slope(soc).0
    }

    /// Open-circuit voltage of one cell and its slope dV/dsoc at `soc` (clamped to 0..1).
    pub fn ocv_and_slope(&self, soc: f64) -> (f64, f64) {
        monotone_cubic(&self.ocv_cell_v, soc)
    }

    /// State of charge whose open-circuit voltage is `v` per cell (clamped to 0..1).
    pub fn soc_for_ocv_cell(&self, v: f64) -> f64 {
        if v.is_nan() || v <= self.ocv_cell_v[0] {
            return 0.0;
        }
        if v >= self.ocv_cell_v[OCV_KNOTS - 1] {
            return 1.0;
        }
        let (mut a, mut b) = (0.0, 1.0);
        for _ in 0..40 {
            let m = 0.5 * (a + b);
            if self.ocv_cell_at(m) < v {
                a = m
            } else {
                b = m
            }
        }
        0.5 * (a + b)
    }

    /// Mean open-circuit voltage over a full discharge, V per cell (Simpson's rule on the
    /// curve): the energy a cell stores is its charge times this.
    pub fn mean_ocv_cell_v(&self) -> f64 {
        let n = 200;
        let mut s = 0.0;
        for k in 0..n {
            s += self.ocv_cell_at((k as f64 + 0.5) / n as f64);
        }
        s / n as f64
    }

    /// Energy the pack stores when full, Wh (rated capacity × cells × mean open-circuit
    /// voltage; eq. 3's `c_B` for this pack).
    pub fn energy_wh(&self) -> f64 {
        self.rated_capacity_ah * f64::from(self.cells) * self.mean_ocv_cell_v()
    }
}

/// The monotone cubic (Fritsch–Carlson) through [`OCV_KNOTS`] knots at `x` = 0, 0.05, …, 1:
/// its value and slope d/dx at `x` (clamped to 0..1; NaN is read as 0). Between knots it is the
/// cubic Hermite with harmonic-mean slopes (0 where the neighbouring differences change sign,
/// one-sided at the ends), so it never overshoots a monotone table. The one interpolation of
/// open-circuit curves in the workspace (the gap diagnosis's learned battery uses it too).
pub fn monotone_cubic(knots: &[f64; OCV_KNOTS], x: f64) -> (f64, f64) {
    let k = knots;
    let n = OCV_KNOTS - 1;
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let u = x * n as f64;
    // (`u` is in 0..=n: truncation is its floor, without a call into libm.)
    let i = (u as usize).min(n - 1);
    let t = u - i as f64;
    let d = |j: usize| k[j + 1] - k[j];
    let slope = |j: usize| -> f64 {
        if j == 0 {
            return d(0);
        }
        if j == n {
            return d(n - 1);
        }
        let (a, b) = (d(j - 1), d(j));
        if a * b <= 0.0 {
            0.0
        } else {
            2.0 * a * b / (a + b)
        }
    };
    let (m0, m1) = (slope(i), slope(i + 1));
    let (y0, y1) = (k[i], k[i + 1]);
    let (t2, t3) = (t * t, t * t * t);
    let v = (2.0 * t3 - 3.0 * t2 + 1.0) * y0
        + (t3 - 2.0 * t2 + t) * m0
        + (-2.0 * t3 + 3.0 * t2) * y1
        + (t3 - t2) * m1;
    let dv_dt = (6.0 * t2 - 6.0 * t) * y0
        + (3.0 * t2 - 4.0 * t + 1.0) * m0
        + (-6.0 * t2 + 6.0 * t) * y1
        + (3.0 * t2 - 2.0 * t) * m1;
    (v, dv_dt * n as f64)
}

/// The robot carrying the pack: eqs. (1)–(2)'s masses and powers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vehicle {
    /// `m_S`: structure mass without battery, kg.
    pub structure_mass_kg: f64,
    /// `m_B`: battery mass, kg.
    pub battery_mass_kg: f64,
    /// `m_P`: payload mass, kg.
    pub payload_mass_kg: f64,
    /// `p_A`: avionics power, W.
    pub avionics_power_w: f64,
    /// `p_P`: payload power, W.
    pub payload_power_w: f64,
}

impl Vehicle {
    /// `m_T` (eq. 1), kg.
    pub fn total_mass_kg(&self) -> f64 {
        crate::total_mass_kg(
            self.structure_mass_kg,
            self.battery_mass_kg,
            self.payload_mass_kg,
        )
    }

    /// `p_I` (eq. 2), W.
    pub fn idle_power_w(&self) -> f64 {
        crate::idle_power_w(self.avionics_power_w, self.payload_power_w)
    }

    /// Checks that every mass and power is finite and non-negative and the take-off mass
    /// positive.
    pub fn validate(&self) -> Result<(), EstimateError> {
        require_non_negative("vehicle structure mass (kg)", self.structure_mass_kg)?;
        require_non_negative("vehicle battery mass (kg)", self.battery_mass_kg)?;
        require_non_negative("vehicle payload mass (kg)", self.payload_mass_kg)?;
        require_non_negative("vehicle avionics power (W)", self.avionics_power_w)?;
        require_non_negative("vehicle payload power (W)", self.payload_power_w)?;
        require_positive("vehicle take-off mass (kg)", self.total_mass_kg())?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curve_passes_through_knots_rises_and_inverts() {
        let b = BatteryModel::lipo(3, 2.2).unwrap();
        for (k, &v) in LIPO_OCV_CELL_V.iter().enumerate() {
            assert!((b.ocv_cell_at(k as f64 / 20.0) - v).abs() < 1e-12);
        }
        let mut last = 0.0;
        for k in 0..=1000 {
            let s = f64::from(k) / 1000.0;
            let (v, slope) = b.ocv_and_slope(s);
            assert!(v >= last - 1e-12 && slope >= -1e-12, "{s}");
            last = v;
            if (0.02..0.98).contains(&s) {
                let h = 1e-6;
                let fd = (b.ocv_cell_at(s + h) - b.ocv_cell_at(s - h)) / (2.0 * h);
                assert!(
                    (fd - slope).abs() < 1e-4 * (1.0 + slope.abs()),
                    "{s}: {fd} vs {slope}"
                );
            }
            assert!((b.soc_for_ocv_cell(v) - s).abs() < 1e-6 || slope < 1e-9);
        }
        assert!(b.ocv_cell_at(f64::NAN).is_finite());
    }

    #[test]
    fn validation_names_the_fault() {
        let mut b = BatteryModel::lipo(3, 2.2).unwrap();
        b.ocv_cell_v[4] = b.ocv_cell_v[3];
        assert!(matches!(b.validate(), Err(EstimateError::Battery { .. })));
        let mut b = BatteryModel::lipo(3, 2.2).unwrap();
        b.cutoff_cell_v = 4.3;
        assert!(b.validate().is_err());
        assert!(BatteryModel::lipo(0, 2.2).is_err());
        assert!(BatteryModel::lipo(3, f64::NAN).is_err());
        let e = BatteryModel::lipo_from_energy(3, 24.4).unwrap();
        assert!((e.energy_wh() - 24.4).abs() < 1e-9);
    }

    #[test]
    fn chemistry_names_and_codes_round_trip() {
        for c in Chemistry::ALL {
            assert_eq!(Chemistry::from_name(c.name()), Some(c));
            assert_eq!(Chemistry::from_code(c as u8), Some(c));
        }
        assert_eq!(Chemistry::from_name("LiPo"), Some(Chemistry::Lipo));
        assert_eq!(Chemistry::from_name("unobtainium"), None);
    }
}
