//! Battery selection (the paper's section III-D and Fig. 4–5): the battery mass that maximises
//! endurance, ideal and limited by the payload limit of eq. (5), and catalogue ranking.

use crate::EstimateError;
use crate::curve::{PowerCurve, require_positive};
use crate::model::{Battery, Estimate, Model, Payload};

/// Points of the coarse scan that brackets the global maximum before the golden-section search.
///
/// A fitted fifth-order curve need not make `t_E(m_B)` unimodal everywhere, so the search first
/// scans the whole feasible range and only then refines around the best scanned point.
const SCAN_POINTS: usize = 512;
/// Golden-section stops when the bracket is this narrow, kg.
const MASS_TOLERANCE_KG: f64 = 1e-10;
/// Smallest battery mass considered, kg.
const MIN_BATTERY_KG: f64 = 1e-6;

/// One point of the endurance-vs-battery-mass curve chosen as an optimum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Optimum {
    /// `m_B`, kg.
    pub battery_mass_kg: f64,
    /// `t_E` at that mass, minutes.
    pub endurance_min: f64,
    /// The full estimate at the optimum.
    pub estimate: Estimate,
}

/// Ideal and realistic battery optima (Fig. 4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BatteryOptimum {
    /// The ideal optimum: a battery that holds its voltage until empty, so only the measured
    /// curve's range bounds the mass.
    pub ideal: Optimum,
    /// The realistic optimum: the best battery whose take-off mass stays within the thrust limit
    /// at minimum voltage (`m_X ≥ 0`, eq. 5). `None` when the model has no thrust limit.
    pub realistic: Option<Optimum>,
    /// True when the payload limit, not the endurance curve, fixes the realistic optimum.
    pub realistic_is_limited: bool,
    /// Battery masses searched, kg: from almost nothing to the heaviest the curve covers.
    pub search_range_kg: (f64, f64),
}

impl<C: PowerCurve> Model<C> {
    /// Battery mass range over which the curve's measured range lets eq. (4) be evaluated.
    pub fn battery_mass_range_kg(&self, payload: &Payload) -> Result<(f64, f64), EstimateError> {
        self.validate()?;
        payload.validate()?;
        let n = f64::from(self.platform.rotor_count);
        let (lo_g, hi_g) = self.curve.valid_range_g();
        let fixed = self.platform.structure_mass_kg + payload.mass_kg;
        let lo = (lo_g * n / 1000.0 - fixed).max(MIN_BATTERY_KG);
        let hi = hi_g * n / 1000.0 - fixed;
        if hi <= lo {
            return Err(EstimateError::NoFeasibleBattery {
                fixed_mass_kg: fixed,
                max_mass_kg: hi_g * n / 1000.0,
            });
        }
        Ok((lo, hi))
    }

    /// Finds the ideal and realistic battery optima for batteries of `energy_density_wh_per_kg`.
    pub fn optimise_battery(
        &self,
        energy_density_wh_per_kg: f64,
        payload: &Payload,
    ) -> Result<BatteryOptimum, EstimateError> {
        require_positive("energy density (Wh/kg)", energy_density_wh_per_kg)?;
        let (lo, hi) = self.battery_mass_range_kg(payload)?;
        let ideal = self.maximise(energy_density_wh_per_kg, payload, lo, hi)?;
        let (realistic, realistic_is_limited) = match self.thrust_limit_kg {
            None => (None, false),
            Some(m_l) => {
                let cap = m_l - self.platform.structure_mass_kg - payload.mass_kg;
                if cap <= lo {
                    return Err(EstimateError::OverPayloadLimit {
                        total_mass_kg: self.platform.structure_mass_kg + payload.mass_kg,
                        thrust_limit_kg: m_l,
                    });
                }
                if ideal.battery_mass_kg <= cap {
                    (Some(ideal), false)
                } else {
                    let r = self.maximise(energy_density_wh_per_kg, payload, lo, cap.min(hi))?;
                    (Some(r), true)
                }
            }
        };
        Ok(BatteryOptimum {
            ideal,
            realistic,
            realistic_is_limited,
            search_range_kg: (lo, hi),
        })
    }

    fn endurance_at(
        &self,
        e_d: f64,
        payload: &Payload,
        m_b: f64,
    ) -> Result<Estimate, EstimateError> {
        let battery = Battery::from_density(m_b, e_d)?;
        self.estimate_unchecked(&battery, payload)
    }

    /// Coarse scan for the global maximum, then golden-section search in the bracket around it.
    fn maximise(
        &self,
        e_d: f64,
        payload: &Payload,
        lo: f64,
        hi: f64,
    ) -> Result<Optimum, EstimateError> {
        let f = |m: f64| {
            self.endurance_at(e_d, payload, m)
                .map_or(f64::NEG_INFINITY, |e| e.endurance_min)
        };
        let step = (hi - lo) / (SCAN_POINTS - 1) as f64;
        let mut best_i = 0;
        let mut best = f64::NEG_INFINITY;
        for i in 0..SCAN_POINTS {
            let v = f(lo + step * i as f64);
            if v > best {
                best = v;
                best_i = i;
            }
        }
        if !best.is_finite() {
            // Surface the real reason from the first point.
            self.endurance_at(e_d, payload, lo)?;
            return Err(EstimateError::NoFeasibleBattery {
                fixed_mass_kg: self.platform.structure_mass_kg + payload.mass_kg,
                max_mass_kg: self.max_curve_mass_kg(),
            });
        }
        let mut a = lo + step * best_i.saturating_sub(1) as f64;
        let mut b = (lo + step * (best_i + 1) as f64).min(hi);
        let inv_phi = (libm::sqrt(5.0) - 1.0) / 2.0;
        let mut c = b - inv_phi * (b - a);
        let mut d = a + inv_phi * (b - a);
        let (mut fc, mut fd) = (f(c), f(d));
        while b - a > MASS_TOLERANCE_KG {
            if fc >= fd {
                b = d;
                d = c;
                fd = fc;
                c = b - inv_phi * (b - a);
                fc = f(c);
            } else {
                a = c;
                c = d;
                fc = fd;
                d = a + inv_phi * (b - a);
                fd = f(d);
            }
        }
        // The ends of the bracket are candidates too (the maximum may sit on a bound).
        let mut m_best = 0.5 * (a + b);
        let mut v_best = f(m_best);
        for m in [lo + step * best_i as f64, a, b] {
            let v = f(m);
            if v > v_best {
                v_best = v;
                m_best = m;
            }
        }
        let estimate = self.endurance_at(e_d, payload, m_best)?;
        Ok(Optimum {
            battery_mass_kg: m_best,
            endurance_min: estimate.endurance_min,
            estimate,
        })
    }

    /// Endurance of one catalogue pack in the paper's ranking convention (Fig. 5): a pack whose
    /// take-off mass exceeds the thrust limit is ranked at zero endurance and marked.
    pub fn rank_entry(
        &self,
        battery: &Battery,
        payload: &Payload,
    ) -> Result<RankedEndurance, EstimateError> {
        let e = self.estimate_unchecked(battery, payload)?;
        let over_limit = e.payload_limit_kg.is_some_and(|m_x| m_x < 0.0);
        Ok(RankedEndurance {
            endurance_min: if over_limit { 0.0 } else { e.endurance_min },
            over_payload_limit: over_limit,
            estimate: e,
        })
    }
}

/// A catalogue pack's place in the ranking.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RankedEndurance {
    /// `t_E`, minutes; zero for packs over the payload limit, as the paper ranks them.
    pub endurance_min: f64,
    /// The pack makes the robot heavier than the thrust limit at minimum voltage.
    pub over_payload_limit: bool,
    /// The unclamped estimate (its `endurance_min` is what the pack would give if it could fly).
    pub estimate: Estimate,
}

/// Nominal LiPo cell voltage used to turn a pack's mAh rating into Wh when no energy is given.
pub const LIPO_NOMINAL_CELL_V: f64 = 3.7;

/// A pack's stored energy from its rating: `cells × nominal cell voltage × capacity`, Wh.
pub fn pack_energy_wh(cells: u8, capacity_mah: f64, nominal_cell_voltage_v: f64) -> f64 {
    f64::from(cells) * nominal_cell_voltage_v * capacity_mah / 1000.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::curve::FnCurve;
    use crate::model::Platform;

    fn model() -> Model<FnCurve<impl Fn(f64) -> f64>> {
        Model::new(
            FnCurve::new(
                |t: f64| 0.157434234 * t + 0.341190317 * libm::pow(t / 100.0, 5.34865728),
                (0.0, 260.0),
            ),
            Platform {
                structure_mass_kg: 0.431,
                avionics_power_w: 2.44,
                rotor_count: 4,
            },
        )
    }

    #[test]
    fn optimum_is_a_maximum_of_the_scan() {
        let m = model();
        let o = m.optimise_battery(164.0, &Payload::default()).unwrap();
        for dm in [-0.01, -0.001, 0.001, 0.01] {
            let e = m
                .estimate_unchecked(
                    &Battery::from_density(o.ideal.battery_mass_kg + dm, 164.0).unwrap(),
                    &Payload::default(),
                )
                .unwrap();
            assert!(e.endurance_min <= o.ideal.endurance_min + 1e-12);
        }
        assert!(o.realistic.is_none());
    }

    #[test]
    fn payload_limit_clamps_the_realistic_optimum() {
        let m = model().with_thrust_limit_kg(0.6);
        let o = m.optimise_battery(164.0, &Payload::default()).unwrap();
        let r = o.realistic.unwrap();
        assert!(o.realistic_is_limited);
        assert!((r.battery_mass_kg - 0.169).abs() < 1e-6);
        assert!(r.endurance_min < o.ideal.endurance_min);
    }

    #[test]
    fn a_structure_heavier_than_the_limit_has_no_realistic_battery() {
        let m = model().with_thrust_limit_kg(0.4);
        assert!(matches!(
            m.optimise_battery(164.0, &Payload::default()),
            Err(EstimateError::OverPayloadLimit { .. })
        ));
    }

    #[test]
    fn ranking_puts_over_limit_packs_at_zero() {
        let m = model().with_thrust_limit_kg(0.6);
        let heavy = Battery::from_density(0.3, 164.0).unwrap();
        let r = m.rank_entry(&heavy, &Payload::default()).unwrap();
        assert!(r.over_payload_limit);
        assert_eq!(r.endurance_min, 0.0);
        assert!(r.estimate.endurance_min > 0.0);
    }

    #[test]
    fn pack_energy_from_rating() {
        assert!((pack_energy_wh(3, 2100.0, LIPO_NOMINAL_CELL_V) - 23.31).abs() < 1e-9);
    }
}
