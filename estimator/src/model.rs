//! The paper's endurance model: equations (1)–(9) and a [`Model`] that combines them.

use crate::EstimateError;
use crate::curve::{PowerCurve, require_non_negative, require_positive};

/// Minutes per hour: the equations work in W and Wh, the results are given in minutes.
pub const MIN_PER_H: f64 = 60.0;

/// Eq. (1): total take-off mass `m_T = m_S + m_B + m_P`, kg.
pub fn total_mass_kg(structure_mass_kg: f64, battery_mass_kg: f64, payload_mass_kg: f64) -> f64 {
    structure_mass_kg + battery_mass_kg + payload_mass_kg
}

/// Eq. (2): total idle-state power `p_I = p_A + p_P`, W.
pub fn idle_power_w(avionics_power_w: f64, payload_power_w: f64) -> f64 {
    avionics_power_w + payload_power_w
}

/// Eq. (3): battery capacity `c_B = e_D · m_B`, Wh.
pub fn battery_energy_wh(energy_density_wh_per_kg: f64, battery_mass_kg: f64) -> f64 {
    energy_density_wh_per_kg * battery_mass_kg
}

/// Eq. (4): flight endurance `t_E = c_B / (p_M + p_I)`, minutes.
pub fn flight_endurance_min(battery_energy_wh: f64, motor_power_w: f64, idle_power_w: f64) -> f64 {
    battery_energy_wh / (motor_power_w + idle_power_w) * MIN_PER_H
}

/// Eq. (5): payload mass limit `m_X = m_L − m_T`, kg; negative when the robot is too heavy to
/// keep climbing at the minimum battery voltage.
pub fn payload_limit_kg(thrust_limit_kg: f64, total_mass_kg: f64) -> f64 {
    thrust_limit_kg - total_mass_kg
}

/// Eq. (6): ceiling endurance `t_C = c_B / p_I`, minutes: how long the battery lasts perched.
pub fn ceiling_endurance_min(battery_energy_wh: f64, idle_power_w: f64) -> f64 {
    battery_energy_wh / idle_power_w * MIN_PER_H
}

/// Eq. (7): reserved endurance energy ratio `r_E = (t_E − t_F) / t_E` after `t_F` of flight.
pub fn reserve_ratio(flight_endurance_min: f64, flight_time_min: f64) -> f64 {
    (flight_endurance_min - flight_time_min) / flight_endurance_min
}

/// Which form of eq. (8) to use.
///
/// Eq. (8) as printed, `r_Ep = r_E − t_E · t_A / t_C`, subtracts a *time* from a ratio: it is
/// dimensionally inconsistent, and its value depends on the unit the times are written in. The
/// energy balance of the same model gives `r_Ep = r_E − t_A / t_C`: while attached the robot
/// spends `p_I · t_A` of `c_B = p_I · t_C`. That consistent form is the default. The printed form
/// with times in hours reproduces the paper's Table I figure (103.3 min) and is available only by
/// explicit choice, to show that reproduction beside the consistent estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Eq8Form {
    /// `r_Ep = r_E − t_A / t_C` (energy balance; the default).
    #[default]
    Consistent,
    /// `r_Ep = r_E − t_E · t_A / t_C` with every time in hours, as printed in the paper.
    PrintedHours,
}

impl Eq8Form {
    /// Fraction of the battery spent attached for `attached_min`, given `t_E` and `t_C`.
    pub fn attached_fraction(
        self,
        attached_min: f64,
        flight_endurance_min: f64,
        ceiling_endurance_min: f64,
    ) -> f64 {
        match self {
            Self::Consistent => attached_min / ceiling_endurance_min,
            Self::PrintedHours => {
                (flight_endurance_min / MIN_PER_H) * (attached_min / MIN_PER_H)
                    / (ceiling_endurance_min / MIN_PER_H)
            }
        }
    }
}

/// Eq. (8): post-ceiling endurance energy ratio `r_Ep` after `t_A` attached, in the chosen form.
pub fn post_ceiling_ratio(
    form: Eq8Form,
    reserve_ratio: f64,
    flight_endurance_min: f64,
    attached_min: f64,
    ceiling_endurance_min: f64,
) -> f64 {
    reserve_ratio
        - form.attached_fraction(attached_min, flight_endurance_min, ceiling_endurance_min)
}

/// Eq. (9): reserved endurance `t_R = c_B · r_Ep / (p_M + p_I)`, minutes.
pub fn reserved_endurance_min(
    battery_energy_wh: f64,
    post_ceiling_ratio: f64,
    motor_power_w: f64,
    idle_power_w: f64,
) -> f64 {
    battery_energy_wh * post_ceiling_ratio / (motor_power_w + idle_power_w) * MIN_PER_H
}

/// The robot without its battery: structure, avionics and rotors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Platform {
    /// `m_S`: structure mass including embedded electronics, without battery, kg.
    pub structure_mass_kg: f64,
    /// `p_A`: avionics power, W.
    pub avionics_power_w: f64,
    /// Number of rotors sharing the take-off mass (the paper's quadrotor: 4).
    pub rotor_count: u8,
}

impl Platform {
    /// Checks that masses and powers are finite and non-negative and that there is a rotor.
    pub fn validate(&self) -> Result<(), EstimateError> {
        require_non_negative("structure mass (kg)", self.structure_mass_kg)?;
        require_non_negative("avionics power (W)", self.avionics_power_w)?;
        if self.rotor_count == 0 {
            return Err(EstimateError::NoRotors);
        }
        Ok(())
    }
}

/// A battery: its mass and the energy it stores.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Battery {
    /// `m_B`, kg.
    pub mass_kg: f64,
    /// `c_B`, Wh.
    pub energy_wh: f64,
}

impl Battery {
    /// A battery of `mass_kg` at `energy_density_wh_per_kg` (eq. 3).
    pub fn from_density(
        mass_kg: f64,
        energy_density_wh_per_kg: f64,
    ) -> Result<Self, EstimateError> {
        require_positive("battery mass (kg)", mass_kg)?;
        require_positive("energy density (Wh/kg)", energy_density_wh_per_kg)?;
        Ok(Self {
            mass_kg,
            energy_wh: battery_energy_wh(energy_density_wh_per_kg, mass_kg),
        })
    }

    /// A battery of known mass and energy.
    pub fn new(mass_kg: f64, energy_wh: f64) -> Result<Self, EstimateError> {
        require_positive("battery mass (kg)", mass_kg)?;
        require_positive("battery energy (Wh)", energy_wh)?;
        Ok(Self { mass_kg, energy_wh })
    }
}

/// What the robot carries besides its structure and battery.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Payload {
    /// `m_P`, kg.
    pub mass_kg: f64,
    /// `p_P`, W.
    pub power_w: f64,
}

impl Payload {
    /// Checks that mass and power are finite and non-negative.
    pub fn validate(&self) -> Result<(), EstimateError> {
        require_non_negative("payload mass (kg)", self.mass_kg)?;
        require_non_negative("payload power (W)", self.power_w)?;
        Ok(())
    }
}

/// Everything eqs. (1)–(9) need besides the battery and payload: the rig's curve, the platform
/// and, when measured, the thrust limit `m_L` at minimum battery voltage.
#[derive(Debug, Clone, Copy)]
pub struct Model<C> {
    /// Per-rotor thrust → power curve (Fig. 3).
    pub curve: C,
    /// Structure, avionics, rotor count.
    pub platform: Platform,
    /// `m_L`: total thrust limit of all rotors at minimum battery voltage, kg.
    pub thrust_limit_kg: Option<f64>,
}

/// The result of eqs. (1)–(6) for one battery and payload.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// `m_T`, kg (eq. 1).
    pub total_mass_kg: f64,
    /// `p_I`, W (eq. 2).
    pub idle_power_w: f64,
    /// `c_B`, Wh (eq. 3).
    pub battery_energy_wh: f64,
    /// Thrust each rotor must give to hover, g.
    pub thrust_per_rotor_g: f64,
    /// `p_M` for all rotors, W.
    pub motor_power_w: f64,
    /// `t_E`, minutes (eq. 4).
    pub endurance_min: f64,
    /// `m_X`, kg (eq. 5), when the thrust limit is known.
    pub payload_limit_kg: Option<f64>,
    /// `t_C`, minutes (eq. 6).
    pub ceiling_endurance_min: f64,
}

impl<C: PowerCurve> Model<C> {
    /// A model with the given curve and platform and no thrust limit.
    pub fn new(curve: C, platform: Platform) -> Self {
        Self {
            curve,
            platform,
            thrust_limit_kg: None,
        }
    }

    /// Sets the total thrust limit `m_L`, kg.
    pub fn with_thrust_limit_kg(mut self, thrust_limit_kg: f64) -> Self {
        self.thrust_limit_kg = Some(thrust_limit_kg);
        self
    }

    /// Checks the platform and the thrust limit.
    pub fn validate(&self) -> Result<(), EstimateError> {
        self.platform.validate()?;
        if let Some(l) = self.thrust_limit_kg {
            require_positive("thrust limit (kg)", l)?;
        }
        Ok(())
    }

    /// `p_M`: power of all rotors hovering `total_mass_kg`, W. Each rotor gives
    /// `total_mass_kg / rotor_count` of thrust (the paper reads the curve at a quarter of `m_T`
    /// and multiplies by four).
    pub fn motor_power_w(&self, total_mass_kg: f64) -> Result<f64, EstimateError> {
        let n = f64::from(self.platform.rotor_count);
        let per_rotor_g = total_mass_kg * 1000.0 / n;
        Ok(self.curve.power_w(per_rotor_g)? * n)
    }

    /// The heaviest take-off mass the curve's measured range covers, kg.
    pub fn max_curve_mass_kg(&self) -> f64 {
        self.curve.valid_range_g().1 * f64::from(self.platform.rotor_count) / 1000.0
    }

    /// Eqs. (1)–(6) without the payload-limit check: `payload_limit_kg` may be negative.
    pub fn estimate_unchecked(
        &self,
        battery: &Battery,
        payload: &Payload,
    ) -> Result<Estimate, EstimateError> {
        self.validate()?;
        payload.validate()?;
        require_positive("battery mass (kg)", battery.mass_kg)?;
        require_positive("battery energy (Wh)", battery.energy_wh)?;
        let m_t = total_mass_kg(
            self.platform.structure_mass_kg,
            battery.mass_kg,
            payload.mass_kg,
        );
        let p_i = idle_power_w(self.platform.avionics_power_w, payload.power_w);
        let p_m = self.motor_power_w(m_t)?;
        let p_total = p_m + p_i;
        if p_total.is_nan() || p_total <= 0.0 {
            return Err(EstimateError::NonPositivePower {
                power_w: p_total,
                total_mass_kg: m_t,
            });
        }
        Ok(Estimate {
            total_mass_kg: m_t,
            idle_power_w: p_i,
            battery_energy_wh: battery.energy_wh,
            thrust_per_rotor_g: m_t * 1000.0 / f64::from(self.platform.rotor_count),
            motor_power_w: p_m,
            endurance_min: flight_endurance_min(battery.energy_wh, p_m, p_i),
            payload_limit_kg: self.thrust_limit_kg.map(|l| payload_limit_kg(l, m_t)),
            ceiling_endurance_min: ceiling_endurance_min(battery.energy_wh, p_i),
        })
    }

    /// Eqs. (1)–(6). A take-off mass over the thrust limit (`m_X < 0`) is
    /// [`EstimateError::OverPayloadLimit`]: at minimum battery voltage the robot could no longer
    /// hold itself up, so the endurance figure would be a fiction.
    pub fn estimate(
        &self,
        battery: &Battery,
        payload: &Payload,
    ) -> Result<Estimate, EstimateError> {
        let e = self.estimate_unchecked(battery, payload)?;
        if let (Some(m_x), Some(m_l)) = (e.payload_limit_kg, self.thrust_limit_kg) {
            if m_x < 0.0 {
                return Err(EstimateError::OverPayloadLimit {
                    total_mass_kg: e.total_mass_kg,
                    thrust_limit_kg: m_l,
                });
            }
        }
        Ok(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::curve::FnCurve;

    fn linear_model() -> Model<FnCurve<impl Fn(f64) -> f64>> {
        // 0.1 W per gram per rotor
        Model::new(
            FnCurve::new(|t: f64| 0.1 * t, (0.0, 300.0)),
            Platform {
                structure_mass_kg: 0.4,
                avionics_power_w: 2.0,
                rotor_count: 4,
            },
        )
    }

    #[test]
    fn estimate_follows_equations_by_hand() {
        let m = linear_model().with_thrust_limit_kg(0.8);
        let b = Battery::from_density(0.2, 150.0).unwrap();
        let p = Payload {
            mass_kg: 0.1,
            power_w: 3.0,
        };
        let e = m.estimate(&b, &p).unwrap();
        assert!((e.total_mass_kg - 0.7).abs() < 1e-12);
        assert!((e.idle_power_w - 5.0).abs() < 1e-12);
        assert!((e.battery_energy_wh - 30.0).abs() < 1e-12);
        // 175 g per rotor × 0.1 W/g × 4 rotors = 70 W
        assert!((e.motor_power_w - 70.0).abs() < 1e-9);
        assert!((e.endurance_min - 30.0 / 75.0 * 60.0).abs() < 1e-9);
        assert!((e.payload_limit_kg.unwrap() - 0.1).abs() < 1e-12);
        assert!((e.ceiling_endurance_min - 360.0).abs() < 1e-9);
    }

    #[test]
    fn over_the_payload_limit_is_an_error_value() {
        let m = linear_model().with_thrust_limit_kg(0.6);
        let b = Battery::from_density(0.2, 150.0).unwrap();
        let err = m.estimate(&b, &Payload::default()).unwrap_err();
        assert!(matches!(err, EstimateError::OverPayloadLimit { .. }));
        let e = m.estimate_unchecked(&b, &Payload::default()).unwrap();
        assert!(e.payload_limit_kg.unwrap() < 0.0);
    }

    #[test]
    fn eq8_forms_differ_only_by_the_factor_t_e_in_hours() {
        let t_e = 13.8;
        let t_c = 580.0;
        let r_e = reserve_ratio(t_e, 6.0);
        let c = post_ceiling_ratio(Eq8Form::Consistent, r_e, t_e, 90.0, t_c);
        let p = post_ceiling_ratio(Eq8Form::PrintedHours, r_e, t_e, 90.0, t_c);
        assert!(((r_e - c) * (t_e / 60.0) - (r_e - p)).abs() < 1e-15);
    }

    #[test]
    fn bad_inputs_name_the_quantity() {
        assert!(matches!(
            Battery::from_density(0.1, 0.0),
            Err(EstimateError::NotPositive {
                what: "energy density (Wh/kg)",
                ..
            })
        ));
        let mut m = linear_model();
        m.platform.structure_mass_kg = -1.0;
        let b = Battery::from_density(0.1, 100.0).unwrap();
        assert!(matches!(
            m.estimate(&b, &Payload::default()),
            Err(EstimateError::Negative {
                what: "structure mass (kg)",
                ..
            })
        ));
    }
}
