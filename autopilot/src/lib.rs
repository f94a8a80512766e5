//! Flight-stack parameters from a rig characterisation.
//!
//! A thrust sweep against the ESC command gives the thrust-curve shape that PX4 and ArduPilot
//! linearise their throttle with; the estimator's curve and a take-off mass give the hover
//! throttle; a battery description gives the battery parameters. This crate fits and formats
//! them — it does no I/O.
//!
//! Main items:
//! - [`fit_thrust_expo`]: `thrust = T_max · ((1 − e)·a + e·a²)` by least squares (QR), the model
//!   behind PX4's `THR_MDL_FAC` and ArduPilot's `MOT_THST_EXPO`;
//!   [`ardupilot_thrust_fraction`] is ArduPilot's own formula including its battery-voltage
//!   scaling (`MOT_BAT_VOLT_MAX`), and [`fit_expo_with_voltage_scaling`] fits it across sweeps
//!   taken at several supply voltages.
//! - [`Px4Params`] / [`ArduPilotParams`]: parameter files (QGroundControl `.params`, tab
//!   separated with MAVLink type codes; ArduPilot `NAME,VALUE` `.param`), each value preceded by a
//!   comment that says where it came from.
//! - [`c_header`]: the estimator's parameters as a C header for non-Rust flight computers.
//!
//! ```
//! use autopilot::{Command, fit_thrust_expo};
//!
//! // A rotor whose thrust follows 300 g · (0.4·a + 0.6·a²) over the command range.
//! let a: Vec<f64> = (1..=10).map(|i| i as f64 / 10.0).collect();
//! let thrust: Vec<f64> = a.iter().map(|a| 300.0 * (0.4 * a + 0.6 * a * a)).collect();
//! let fit = fit_thrust_expo(&a, &thrust)?;
//! assert!((fit.expo - 0.6).abs() < 1e-12);
//! assert!((fit.max_thrust_g - 300.0).abs() < 1e-9);
//! // ESC microseconds map onto the 0..1 command.
//! assert_eq!(Command::Microseconds { min_us: 1000.0, max_us: 2000.0 }.normalise(1250.0), 0.25);
//! # Ok::<(), autopilot::ExportError>(())
//! ```

use std::fmt::Write as _;

use nalgebra::{DMatrix, DVector};

/// Why a parameter set could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    /// Too few usable points for the fit.
    #[error(
        "{usable} usable sweep points (command above the spin-up threshold, thrust > 0); at least {needed} are needed"
    )]
    TooFewPoints {
        /// Points usable.
        usable: usize,
        /// Points needed.
        needed: usize,
    },
    /// Throttle and thrust have different lengths.
    #[error("{throttle} throttle values but {thrust} thrust values")]
    LengthMismatch {
        /// Throttle count.
        throttle: usize,
        /// Thrust count.
        thrust: usize,
    },
    /// A value is not finite.
    #[error("{what} at index {index} is {value}, not a finite number")]
    NonFinite {
        /// The series.
        what: &'static str,
        /// Index.
        index: usize,
        /// Value.
        value: f64,
    },
    /// The robot cannot hover on these rotors.
    #[error("hovering needs {hover_g:.1} g per rotor but the rotors give at most {max_g:.1} g")]
    CannotHover {
        /// Hover thrust per rotor, g.
        hover_g: f64,
        /// Maximum thrust per rotor, g.
        max_g: f64,
    },
    /// A setting is out of its range.
    #[error("{what} must be {expected}, got {value}")]
    Setting {
        /// The setting.
        what: &'static str,
        /// What is allowed.
        expected: &'static str,
        /// Value given.
        value: f64,
    },
}

/// How the ESC command of a sweep is expressed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Command {
    /// PWM pulse width in µs between `min_us` (motor off) and `max_us` (full).
    Microseconds {
        /// Pulse width for zero command, µs.
        min_us: f64,
        /// Pulse width for full command, µs.
        max_us: f64,
    },
    /// A fraction 0..1.
    Fraction,
    /// A percentage 0..100.
    Percent,
}

/// The largest command [`Command::guess`] still reads as a fraction of full scale.
const FRACTION_MAX: f64 = 1.5;

impl Command {
    /// Guesses the unit from the largest command in a sweep: ≤ 1.5 a fraction (a command a little
    /// past full scale, 1.01, is still a fraction: no sweep tops out at 1.5 % throttle), ≤ 100 a
    /// percentage, else microseconds between 1000 and 2000.
    pub fn guess(throttle: &[f64]) -> Self {
        let max = throttle.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if max <= FRACTION_MAX {
            Self::Fraction
        } else if max <= 100.0 {
            Self::Percent
        } else {
            Self::Microseconds {
                min_us: 1000.0,
                max_us: 2000.0,
            }
        }
    }

    /// The command as a fraction 0..1 of full scale.
    pub fn normalise(&self, value: f64) -> f64 {
        match *self {
            Self::Microseconds { min_us, max_us } => (value - min_us) / (max_us - min_us),
            Self::Fraction => value,
            Self::Percent => value / 100.0,
        }
    }
}

/// `thrust = T_max · ((1 − e)·a + e·a²)` fitted to a sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExpoFit {
    /// The curve factor `e` (PX4 `THR_MDL_FAC`, ArduPilot `MOT_THST_EXPO`), clamped to 0..1.
    pub expo: f64,
    /// The unclamped least-squares value of `e`.
    pub expo_unclamped: f64,
    /// Thrust at full command, g.
    pub max_thrust_g: f64,
    /// RMS of the residuals relative to `max_thrust_g`, %.
    pub rms_error_pct: f64,
    /// Points used.
    pub points: usize,
}

fn check(throttle: &[f64], thrust_g: &[f64]) -> Result<(), ExportError> {
    if throttle.len() != thrust_g.len() {
        return Err(ExportError::LengthMismatch {
            throttle: throttle.len(),
            thrust: thrust_g.len(),
        });
    }
    for (what, v) in [("command", throttle), ("thrust", thrust_g)] {
        if let Some((index, &value)) = v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            return Err(ExportError::NonFinite { what, index, value });
        }
    }
    Ok(())
}

/// Least squares without an intercept on `[a, a²]` by QR: returns (α, β) of `α·a + β·a²`.
fn fit_quadratic_through_origin(a: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    let m = DMatrix::from_fn(a.len(), 2, |i, j| if j == 0 { a[i] } else { a[i] * a[i] });
    let qr = m.qr();
    let rhs = DVector::from_column_slice(y);
    let qty = qr.q().transpose() * rhs;
    let r = qr.r();
    let sol = r.solve_upper_triangular(&qty)?;
    Some((sol[0], sol[1]))
}

/// Fits `thrust = T_max · ((1 − e)·a + e·a²)` to commands `a` (0..1 of the range the flight stack
/// maps onto the motor) and thrusts. Points with `a ≤ 0` or no thrust (below spin-up) are left
/// out. `e` outside 0..1 is clamped (both flight stacks accept only that range) and reported.
pub fn fit_thrust_expo(a: &[f64], thrust_g: &[f64]) -> Result<ExpoFit, ExportError> {
    check(a, thrust_g)?;
    let (xs, ys): (Vec<f64>, Vec<f64>) = a
        .iter()
        .zip(thrust_g)
        .filter(|&(&a, &t)| a > 0.0 && a <= 1.0 + 1e-9 && t > 0.0)
        .map(|(&a, &t)| (a, t))
        .unzip();
    if xs.len() < 3 {
        return Err(ExportError::TooFewPoints {
            usable: xs.len(),
            needed: 3,
        });
    }
    let (alpha, beta) =
        fit_quadratic_through_origin(&xs, &ys).ok_or(ExportError::TooFewPoints {
            usable: xs.len(),
            needed: 3,
        })?;
    let t_max = alpha + beta;
    let expo_unclamped = beta / t_max;
    let expo = expo_unclamped.clamp(0.0, 1.0);
    // With a clamped expo, T_max is refitted for that shape.
    let shape = |a: f64| (1.0 - expo) * a + expo * a * a;
    let t_max = if expo == expo_unclamped {
        t_max
    } else {
        let num: f64 = xs.iter().zip(&ys).map(|(&a, &t)| shape(a) * t).sum();
        let den: f64 = xs.iter().map(|&a| shape(a) * shape(a)).sum();
        num / den
    };
    let rms = (xs
        .iter()
        .zip(&ys)
        .map(|(&a, &t)| (t - t_max * shape(a)).powi(2))
        .sum::<f64>()
        / xs.len() as f64)
        .sqrt();
    Ok(ExpoFit {
        expo,
        expo_unclamped,
        max_thrust_g: t_max,
        rms_error_pct: rms / t_max * 100.0,
        points: xs.len(),
    })
}

/// ArduPilot's actuator scale: a normalised PWM `p` (0..1 between the PWM limits) as the
/// fraction `a` between `MOT_SPIN_MIN` and `MOT_SPIN_MAX`.
pub fn ardupilot_actuator(p: f64, spin_min: f64, spin_max: f64) -> f64 {
    (p - spin_min) / (spin_max - spin_min)
}

/// ArduPilot's thrust model with its battery-voltage scaling (`AP_MotorsMulticopter`): the
/// fraction of full thrust (at `MOT_BAT_VOLT_MAX`) given by actuator `a` at
/// `v_ratio = V / MOT_BAT_VOLT_MAX`. The motor sees an effective command `a·v_ratio`, and thrust
/// follows `(1 − e)·r + e·r²` of it — the relation `apply_thrust_curve_and_volt_scaling` inverts.
pub fn ardupilot_thrust_fraction(a: f64, v_ratio: f64, expo: f64) -> f64 {
    let r = a * v_ratio;
    (1.0 - expo) * r + expo * r * r
}

/// The actuator ArduPilot outputs for thrust demand `t` (0..1) at `v_ratio`, as
/// `apply_thrust_curve_and_volt_scaling` computes it (`lift_max = v(1 − e) + e·v²`).
pub fn ardupilot_actuator_for_thrust(t: f64, v_ratio: f64, expo: f64) -> f64 {
    let lift_max = v_ratio * (1.0 - expo) + expo * v_ratio * v_ratio;
    let ratio = if expo.abs() < 1e-12 {
        lift_max * t
    } else {
        ((expo - 1.0)
            + ((1.0 - expo).powi(2) + 4.0 * expo * lift_max * t)
                .max(0.0)
                .sqrt())
            / (2.0 * expo)
    };
    (ratio / v_ratio).clamp(0.0, 1.0)
}

/// One sweep at a fixed supply voltage, for [`fit_expo_with_voltage_scaling`].
#[derive(Debug, Clone, PartialEq)]
pub struct VoltageSweep {
    /// Supply voltage of the sweep, V.
    pub voltage_v: f64,
    /// ArduPilot actuator values (0..1 between spin min and max).
    pub actuator: Vec<f64>,
    /// Thrust, g.
    pub thrust_g: Vec<f64>,
}

/// Fits ArduPilot's thrust model *with* its voltage scaling to sweeps at several voltages:
/// `thrust = T_max · ((1 − e)·a·v + e·(a·v)²)`, `v = V / v_max`. A small RMS error across
/// voltages says ArduPilot's compensation will hold for this rotor.
pub fn fit_expo_with_voltage_scaling(
    sweeps: &[VoltageSweep],
    v_max: f64,
) -> Result<ExpoFit, ExportError> {
    if !(v_max.is_finite() && v_max > 0.0) {
        return Err(ExportError::Setting {
            what: "MOT_BAT_VOLT_MAX",
            expected: "a positive voltage",
            value: v_max,
        });
    }
    let mut r = Vec::new();
    let mut t = Vec::new();
    for s in sweeps {
        check(&s.actuator, &s.thrust_g)?;
        let v = s.voltage_v / v_max;
        r.extend(s.actuator.iter().map(|a| a * v));
        t.extend_from_slice(&s.thrust_g);
    }
    fit_thrust_expo(&r, &t)
}

/// The hover thrust as a fraction of full thrust (ArduPilot `MOT_THST_HOVER`, PX4
/// `MPC_THR_HOVER`: both flight stacks linearise thrust, so hover throttle is that fraction).
pub fn hover_fraction(
    takeoff_mass_kg: f64,
    rotors: u8,
    max_thrust_g: f64,
) -> Result<f64, ExportError> {
    let hover_g = takeoff_mass_kg * 1000.0 / f64::from(rotors);
    if hover_g > max_thrust_g {
        return Err(ExportError::CannotHover {
            hover_g,
            max_g: max_thrust_g,
        });
    }
    Ok(hover_g / max_thrust_g)
}

/// A battery as the flight stacks describe it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BatterySpec {
    /// Cells in series.
    pub cells: u8,
    /// Capacity, mAh.
    pub capacity_mah: f64,
    /// Empty (landing) voltage per cell, V.
    pub empty_cell_v: f64,
    /// Full voltage per cell, V.
    pub full_cell_v: f64,
    /// Internal resistance of the pack, Ω, when it has been estimated.
    pub internal_resistance_ohm: Option<f64>,
    /// The chemistry whose [`px4_cell_voltages`] the empty and full voltages are, when they
    /// are (said in the parameter file's comments).
    pub voltages_of: Option<Chemistry>,
}

pub use estimator::online::Chemistry;

/// PX4's per-cell battery voltages: `BAT1_V_EMPTY` and `BAT1_V_CHARGED`, which PX4 reads under
/// load (its parameter docs: "5C load") and, with its internal-resistance estimate, compares
/// with the load-compensated cell voltage to get a voltage-based state of charge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Px4CellVoltages {
    /// `BAT1_V_EMPTY`, V per cell.
    pub empty_cell_v: f64,
    /// `BAT1_V_CHARGED`, V per cell.
    pub charged_cell_v: f64,
}

/// PX4's defaults (PX4-Autopilot `src/lib/battery/module.yaml`: `BAT${i}_V_EMPTY` 3.6 V,
/// `BAT${i}_V_CHARGED` 4.05 V), made for lithium cells charged to 4.2 V.
pub const PX4_DEFAULT_CELL_VOLTAGES: Px4CellVoltages = Px4CellVoltages {
    empty_cell_v: 3.6,
    charged_cell_v: 4.05,
};

/// `BAT1_V_EMPTY` / `BAT1_V_CHARGED` of a PX4 configured for a pack of `chemistry`
/// (`hoverbench export px4 --chemistry` writes them); `None` when the chemistry says nothing
/// about its voltages (`measured`, `other`).
///
/// - LiPo, LiHV, Li-ion NMC and NCA: PX4's defaults, [`PX4_DEFAULT_CELL_VOLTAGES`] (PX4 ships
///   them for these cells; LiHV is left at them too, although its 4.35 V charge would allow a
///   higher `V_CHARGED`).
/// - LiFePO₄: 3.0 V empty, 3.35 V charged. Its open-circuit voltage sits on a plateau near
///   3.3 V (about 3.33–3.35 V at 90 % charge, 3.2 V at 10 %) and falls to about 3.0 V near 5 %;
///   PX4's defaults (3.6 / 4.05 V) put a LiFePO₄ cell below "empty" from take-off. The two
///   values are placed as PX4's defaults are on a LiPo curve (4.05 V: about 90 % charge;
///   3.6 V: about 5 %), from published LiFePO₄ curves, not fitted to any flight.
pub fn px4_cell_voltages(chemistry: Chemistry) -> Option<Px4CellVoltages> {
    match chemistry {
        Chemistry::Lipo | Chemistry::Lihv | Chemistry::LiIonNmc | Chemistry::LiIonNca => {
            Some(PX4_DEFAULT_CELL_VOLTAGES)
        }
        Chemistry::LiFePo4 => Some(Px4CellVoltages {
            empty_cell_v: 3.0,
            charged_cell_v: 3.35,
        }),
        Chemistry::Measured | Chemistry::Other => None,
    }
}

/// One parameter: name, value, MAVLink type, and where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    /// Parameter name.
    pub name: &'static str,
    /// Value.
    pub value: f64,
    /// MAVLink parameter type: 6 = INT32, 9 = REAL32.
    pub mav_type: u8,
    /// Where the value comes from.
    pub source: String,
}

/// MAV_PARAM_TYPE_INT32.
pub const MAV_INT32: u8 = 6;
/// MAV_PARAM_TYPE_REAL32.
pub const MAV_REAL32: u8 = 9;

/// What both exports are built from.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportInput {
    /// Thrust-curve fit (over the range the flight stack maps onto the motor).
    pub expo: ExpoFit,
    /// Description of the sweep, for the comments.
    pub sweep_name: String,
    /// Take-off mass for the hover throttle, kg, when given.
    pub takeoff_mass_kg: Option<f64>,
    /// Rotors.
    pub rotors: u8,
    /// Battery, when given.
    pub battery: Option<BatterySpec>,
}

fn hover(input: &ExportInput) -> Result<Option<(f64, String)>, ExportError> {
    input
        .takeoff_mass_kg
        .map(|m| {
            hover_fraction(m, input.rotors, input.expo.max_thrust_g).map(|h| {
                (
                    h,
                    format!(
                        "{m:.3} kg take-off mass / {} rotors = {:.1} g per rotor, of {:.1} g full thrust ({})",
                        input.rotors,
                        m * 1000.0 / f64::from(input.rotors),
                        input.expo.max_thrust_g,
                        input.sweep_name
                    ),
                )
            })
        })
        .transpose()
}

fn expo_source(input: &ExportInput) -> String {
    let e = &input.expo;
    let clamp = if e.expo == e.expo_unclamped {
        String::new()
    } else {
        format!(", clamped from {:.4}", e.expo_unclamped)
    };
    format!(
        "least-squares fit of thrust = T_max((1-e)a + e a^2) to {} points of {} (RMS error {:.2} % of {:.1} g{clamp})",
        e.points, input.sweep_name, e.rms_error_pct, e.max_thrust_g
    )
}

/// PX4 parameters (QGroundControl `.params`).
#[derive(Debug, Clone, PartialEq)]
pub struct Px4Params(pub Vec<Param>);

impl Px4Params {
    /// Builds `THR_MDL_FAC`, `MPC_THR_HOVER` (with a take-off mass) and the `BAT1_*` parameters.
    pub fn new(input: &ExportInput) -> Result<Self, ExportError> {
        let mut p = vec![Param {
            name: "THR_MDL_FAC",
            value: input.expo.expo,
            mav_type: MAV_REAL32,
            source: expo_source(input),
        }];
        if let Some((h, src)) = hover(input)? {
            p.push(Param {
                name: "MPC_THR_HOVER",
                value: h,
                mav_type: MAV_REAL32,
                source: src,
            });
        }
        if let Some(b) = input.battery {
            battery_params(
                &mut p,
                &b,
                &[(
                    "BAT1_N_CELLS",
                    "BAT1_CAPACITY",
                    "BAT1_V_EMPTY",
                    "BAT1_V_CHARGED",
                    "BAT1_R_INTERNAL",
                )],
            );
        }
        Ok(Self(p))
    }

    /// The QGroundControl parameter file: comment lines, then
    /// `vehicle-id <TAB> component-id <TAB> name <TAB> value <TAB> type` rows.
    pub fn render(&self) -> String {
        let mut s = String::from(
            "# Onboard parameters for Vehicle 1\n#\n# Stack: PX4 Pro\n# Vehicle: Multi-Rotor\n# Written by hoverbench from a rig characterisation\n#\n# Vehicle-Id Component-Id Name Value Type\n",
        );
        for p in &self.0 {
            let _ = writeln!(s, "# {}: {}", p.name, p.source);
            let value = if p.mav_type == MAV_INT32 {
                format!("{}", p.value.round() as i64)
            } else {
                format!("{:.6}", p.value)
            };
            let _ = writeln!(s, "1\t1\t{}\t{}\t{}", p.name, value, p.mav_type);
        }
        s
    }
}

fn battery_params(
    p: &mut Vec<Param>,
    b: &BatterySpec,
    names: &[(
        &'static str,
        &'static str,
        &'static str,
        &'static str,
        &'static str,
    )],
) {
    let (cells, cap, empty, full, r) = names[0];
    p.push(Param {
        name: cells,
        value: f64::from(b.cells),
        mav_type: MAV_INT32,
        source: "battery description (--cells)".into(),
    });
    p.push(Param {
        name: cap,
        value: b.capacity_mah,
        mav_type: MAV_REAL32,
        source: "battery description (--capacity)".into(),
    });
    let of = |what: &str| {
        format!(
            "PX4's per-cell {what} voltage for {} cells (--chemistry)",
            b.voltages_of.map_or("", |c| c.name())
        )
    };
    p.push(Param {
        name: empty,
        value: b.empty_cell_v,
        mav_type: MAV_REAL32,
        source: match b.voltages_of {
            Some(_) => of("empty"),
            None => {
                "per-cell landing voltage (the paper's 3.0 V/cell cut-off unless --empty-cell-v)"
                    .into()
            }
        },
    });
    p.push(Param {
        name: full,
        value: b.full_cell_v,
        mav_type: MAV_REAL32,
        source: match b.voltages_of {
            Some(_) => of("full-charge"),
            None => "per-cell full-charge voltage".into(),
        },
    });
    if let Some(ohm) = b.internal_resistance_ohm {
        p.push(Param {
            name: r,
            value: ohm,
            mav_type: MAV_REAL32,
            source: "estimated pack internal resistance".into(),
        });
    }
}

/// The range ArduPilot accepts for `MOT_THST_HOVER`.
pub const ARDUPILOT_HOVER_RANGE: (f64, f64) = (0.125, 0.6875);

/// ArduPilot parameters (`NAME,VALUE` `.param`).
#[derive(Debug, Clone, PartialEq)]
pub struct ArduPilotParams(pub Vec<Param>);

/// ArduPilot's motor-range settings the expo is fitted within.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpinRange {
    /// `MOT_SPIN_MIN`: normalised PWM where the motor spins reliably.
    pub spin_min: f64,
    /// `MOT_SPIN_MAX`: normalised PWM where thrust saturates.
    pub spin_max: f64,
}

impl Default for SpinRange {
    /// ArduPilot's defaults, 0.15 and 0.95.
    fn default() -> Self {
        Self {
            spin_min: 0.15,
            spin_max: 0.95,
        }
    }
}

impl SpinRange {
    /// Checks `0 ≤ spin_min < spin_max ≤ 1`.
    pub fn validate(&self) -> Result<(), ExportError> {
        if !(0.0..1.0).contains(&self.spin_min) {
            return Err(ExportError::Setting {
                what: "MOT_SPIN_MIN",
                expected: "in 0..1",
                value: self.spin_min,
            });
        }
        if !(self.spin_max > self.spin_min && self.spin_max <= 1.0) {
            return Err(ExportError::Setting {
                what: "MOT_SPIN_MAX",
                expected: "above MOT_SPIN_MIN and at most 1",
                value: self.spin_max,
            });
        }
        Ok(())
    }
}

impl ArduPilotParams {
    /// Builds `MOT_THST_EXPO`, `MOT_SPIN_MIN/MAX`, `MOT_THST_HOVER` (with a take-off mass) and
    /// the battery parameters (`BATT_CAPACITY`, `MOT_BAT_VOLT_MAX/MIN`, `BATT_LOW_VOLT`).
    /// `input.expo` must have been fitted on the actuator scale of `spin`
    /// ([`ardupilot_actuator`]).
    pub fn new(input: &ExportInput, spin: SpinRange) -> Result<Self, ExportError> {
        spin.validate()?;
        let mut p = vec![
            Param {
                name: "MOT_THST_EXPO",
                value: input.expo.expo,
                mav_type: MAV_REAL32,
                source: format!(
                    "{}; actuator a = (PWM fraction - MOT_SPIN_MIN) / (MOT_SPIN_MAX - MOT_SPIN_MIN)",
                    expo_source(input)
                ),
            },
            Param {
                name: "MOT_SPIN_MIN",
                value: spin.spin_min,
                mav_type: MAV_REAL32,
                source: "spin range the expo was fitted within".into(),
            },
            Param {
                name: "MOT_SPIN_MAX",
                value: spin.spin_max,
                mav_type: MAV_REAL32,
                source: "spin range the expo was fitted within".into(),
            },
        ];
        if let Some((h, src)) = hover(input)? {
            // ArduPilot keeps the hover throttle within this range and clamps what lies outside.
            let (lo, hi) = ARDUPILOT_HOVER_RANGE;
            let source = if (lo..=hi).contains(&h) {
                src
            } else {
                format!(
                    "{src}; outside ArduPilot's accepted {lo}–{hi}: it will clamp it, so check the propulsion sizing"
                )
            };
            p.push(Param {
                name: "MOT_THST_HOVER",
                value: h,
                mav_type: MAV_REAL32,
                source,
            });
        }
        if let Some(b) = input.battery {
            let cells = f64::from(b.cells);
            p.push(Param {
                name: "BATT_CAPACITY",
                value: b.capacity_mah,
                mav_type: MAV_INT32,
                source: "battery description (--capacity)".into(),
            });
            p.push(Param {
                name: "MOT_BAT_VOLT_MAX",
                value: cells * b.full_cell_v,
                mav_type: MAV_REAL32,
                source: format!("{} cells x {} V full", b.cells, b.full_cell_v),
            });
            p.push(Param {
                name: "MOT_BAT_VOLT_MIN",
                value: cells * b.empty_cell_v,
                mav_type: MAV_REAL32,
                source: format!("{} cells x {} V empty", b.cells, b.empty_cell_v),
            });
            p.push(Param {
                name: "BATT_LOW_VOLT",
                value: cells * b.empty_cell_v,
                mav_type: MAV_REAL32,
                source: "the landing voltage (the paper's automatic landing threshold)".into(),
            });
        }
        Ok(Self(p))
    }

    /// The `.param` file: `#` comments and `NAME,VALUE` lines.
    pub fn render(&self) -> String {
        let mut s = String::from(
            "# ArduPilot parameters written by hoverbench from a rig characterisation\n",
        );
        for p in &self.0 {
            let _ = writeln!(s, "# {}: {}", p.name, p.source);
            if p.mav_type == MAV_INT32 {
                let _ = writeln!(s, "{},{}", p.name, p.value.round() as i64);
            } else {
                let _ = writeln!(s, "{},{:.6}", p.name, p.value);
            }
        }
        s
    }
}

/// The estimator's parameters as a C header: the binary blob (decoded by the Rust estimator) and
/// the curve as plain constants with a Horner evaluator for C flight code; with a motor map
/// (`[motor]`), its constants too (`HB_MOTOR_*`), with the drive voltage and the power at it.
pub fn c_header(params: &estimator::Params, blob: &[u8], guard: &str) -> String {
    let c = &params.curve;
    let (lo, hi) = estimator::PowerCurve::valid_range_g(c);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "/* hoverbench rig parameters: per-rotor electrical power (W) vs thrust (g)."
    );
    let _ = writeln!(
        s,
        " * power_w = sum_k HB_CURVE_COEFFS_SCALED[k] * t^k, t = (thrust_g - HB_CURVE_CENTER_G) / HB_CURVE_SCALE_G,"
    );
    let _ = writeln!(
        s,
        " * valid for HB_CURVE_MIN_G <= thrust_g <= HB_CURVE_MAX_G. Generated: do not edit. */"
    );
    let _ = writeln!(
        s,
        "#ifndef {guard}\n#define {guard}\n\n#include <stdint.h>\n"
    );
    let _ = writeln!(s, "#define HB_ROTOR_COUNT {}", params.rotor_count);
    let _ = writeln!(s, "#define HB_CURVE_DEGREE {}", c.degree());
    let _ = writeln!(s, "#define HB_CURVE_CENTER_G {:e}", c.center_g());
    let _ = writeln!(s, "#define HB_CURVE_SCALE_G {:e}", c.scale_g());
    let _ = writeln!(s, "#define HB_CURVE_MIN_G {lo:e}");
    let _ = writeln!(s, "#define HB_CURVE_MAX_G {hi:e}");
    if let Some(v) = c.supply_voltage_v() {
        let _ = writeln!(s, "#define HB_CURVE_SUPPLY_V {v:e}");
    }
    if let Some(l) = params.thrust_limit {
        let _ = writeln!(s, "#define HB_THRUST_LIMIT_PER_ROTOR_G {:e}", l.per_rotor_g);
        let _ = writeln!(
            s,
            "#define HB_THRUST_LIMIT_SUPPLY_V {:e}",
            l.supply_voltage_v
        );
    }
    let coeffs: Vec<String> = c
        .coefficients_scaled()
        .iter()
        .map(|v| format!("{v:e}"))
        .collect();
    let _ = writeln!(
        s,
        "\nstatic const double HB_CURVE_COEFFS_SCALED[{}] = {{ {} }};\n",
        coeffs.len(),
        coeffs.join(", ")
    );
    let _ = writeln!(
        s,
        "/* Electrical power of one rotor at thrust_g, W (no range check). */"
    );
    let _ = writeln!(s, "static inline double hb_power_w(double thrust_g) {{");
    let _ = writeln!(
        s,
        "    double t = (thrust_g - HB_CURVE_CENTER_G) / HB_CURVE_SCALE_G;"
    );
    let _ = writeln!(s, "    double p = 0.0;");
    let _ = writeln!(
        s,
        "    for (int k = HB_CURVE_DEGREE; k >= 0; --k) p = p * t + HB_CURVE_COEFFS_SCALED[k];"
    );
    let _ = writeln!(s, "    return p;\n}}\n");
    if let Some(m) = &params.motor {
        motor_map_c(&mut s, m);
    }
    let _ = writeln!(
        s,
        "/* The same parameters as the blob estimator::Params::decode reads{}. */",
        if params.motor.is_some() {
            " (the motor map included:\n * hb_motor_map_init of libhoverbench_online.a reads it)"
        } else {
            ""
        }
    );
    let _ = write!(
        s,
        "static const uint8_t HB_PARAMS_BLOB[{}] = {{",
        blob.len()
    );
    for (i, b) in blob.iter().enumerate() {
        if i % 12 == 0 {
            s.push_str("\n   ");
        }
        let _ = write!(s, " 0x{b:02x},");
    }
    let _ = writeln!(s, "\n}};\n\n#endif /* {guard} */");
    s
}

/// The motor map's part of [`c_header`]: its constants and two evaluators, named so as not to
/// clash with `hoverbench_online.h` (whose `hb_motor_power_w` sums the rotors with range
/// checks).
fn motor_map_c(s: &mut String, m: &estimator::MotorMap) {
    let (lo, hi) = m.drive_range_v();
    let _ = writeln!(
        s,
        "/* Motor map: per-rotor electrical power (W) from the ESC command (us) and the supply voltage (V)."
    );
    let _ = writeln!(
        s,
        " * duty = (command_us - HB_MOTOR_ZERO_US) / (HB_MOTOR_FULL_US - HB_MOTOR_ZERO_US) clamped to 0..1,"
    );
    let _ = writeln!(
        s,
        " * drive_v = duty * supply_v; power_w = sum_k HB_MOTOR_COEFFS_SCALED[k] * t^k,"
    );
    let _ = writeln!(
        s,
        " * t = (drive_v - HB_MOTOR_CENTER_V) / HB_MOTOR_SCALE_V, valid for"
    );
    let _ = writeln!(
        s,
        " * HB_MOTOR_DRIVE_MIN_V <= drive_v <= HB_MOTOR_DRIVE_MAX_V (outside: not measured, do not use)."
    );
    let _ = writeln!(
        s,
        " * HB_MOTOR_FIT_RMSE_FRACTION: the fit's relative RMS residual over both sweeps. */"
    );
    let _ = writeln!(s, "#define HB_MOTOR_ZERO_US {:e}", m.zero_us());
    let _ = writeln!(s, "#define HB_MOTOR_FULL_US {:e}", m.full_us());
    let _ = writeln!(s, "#define HB_MOTOR_DEGREE {}", m.degree());
    let _ = writeln!(s, "#define HB_MOTOR_CENTER_V {:e}", m.center_v());
    let _ = writeln!(s, "#define HB_MOTOR_SCALE_V {:e}", m.scale_v());
    let _ = writeln!(s, "#define HB_MOTOR_DRIVE_MIN_V {lo:e}");
    let _ = writeln!(s, "#define HB_MOTOR_DRIVE_MAX_V {hi:e}");
    let _ = writeln!(
        s,
        "#define HB_MOTOR_FIT_RMSE_FRACTION {:e}",
        m.fit_rmse_fraction()
    );
    let coeffs: Vec<String> = m
        .coefficients_scaled()
        .iter()
        .map(|v| format!("{v:e}"))
        .collect();
    let _ = writeln!(
        s,
        "\nstatic const double HB_MOTOR_COEFFS_SCALED[{}] = {{ {} }};\n",
        coeffs.len(),
        coeffs.join(", ")
    );
    let _ = writeln!(
        s,
        "/* Drive voltage of a motor at command_us on a supply of supply_v, V (duty clamped to 0..1). */"
    );
    let _ = writeln!(
        s,
        "static inline double hb_motor_drive_v(double command_us, double supply_v) {{"
    );
    let _ = writeln!(
        s,
        "    double duty = (command_us - HB_MOTOR_ZERO_US) / (HB_MOTOR_FULL_US - HB_MOTOR_ZERO_US);"
    );
    let _ = writeln!(
        s,
        "    duty = duty < 0.0 ? 0.0 : (duty > 1.0 ? 1.0 : duty);"
    );
    let _ = writeln!(s, "    return duty * supply_v;\n}}\n");
    let _ = writeln!(
        s,
        "/* Electrical power of one rotor at drive voltage drive_v, W (no range check). */"
    );
    let _ = writeln!(
        s,
        "static inline double hb_motor_power_at_drive_w(double drive_v) {{"
    );
    let _ = writeln!(
        s,
        "    double t = (drive_v - HB_MOTOR_CENTER_V) / HB_MOTOR_SCALE_V;"
    );
    let _ = writeln!(s, "    double p = 0.0;");
    let _ = writeln!(
        s,
        "    for (int k = HB_MOTOR_DEGREE; k >= 0; --k) p = p * t + HB_MOTOR_COEFFS_SCALED[k];"
    );
    let _ = writeln!(s, "    return p;\n}}\n");
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The motor map's constants read back to the map's values bit for bit (shortest
    /// round-trip digits), and a file without `[motor]` gets no motor block.
    #[test]
    fn the_c_header_carries_the_motor_map_exactly() {
        let curve =
            estimator::PolyCurve::new(&[22.36, 29.12, 6.76], 130.0, 130.0, (0.0, 260.0), None)
                .unwrap();
        let mut p = estimator::Params::new(4, curve);
        let without = c_header(&p, &[1, 2, 3], "G_H");
        assert!(!without.contains("HB_MOTOR"), "{without}");
        let map = estimator::MotorMap::new(
            1003.7,
            2000.0,
            &[0.1 + 0.2, 1.0 / 3.0, 2e-17, -4.25],
            6.2,
            5.1,
            (1.1, 11.3),
            0.012,
        )
        .unwrap();
        p.motor = Some(map);
        let text = c_header(&p, &[1, 2, 3], "G_H");
        let define = |name: &str| -> f64 {
            text.lines()
                .find_map(|l| l.strip_prefix(&format!("#define {name} ")))
                .unwrap_or_else(|| panic!("{name} in\n{text}"))
                .parse()
                .unwrap()
        };
        assert_eq!(define("HB_MOTOR_ZERO_US"), map.zero_us());
        assert_eq!(define("HB_MOTOR_FULL_US"), map.full_us());
        assert_eq!(define("HB_MOTOR_DEGREE"), 3.0);
        assert_eq!(define("HB_MOTOR_CENTER_V"), map.center_v());
        assert_eq!(define("HB_MOTOR_SCALE_V"), map.scale_v());
        assert_eq!(define("HB_MOTOR_DRIVE_MIN_V"), map.drive_range_v().0);
        assert_eq!(define("HB_MOTOR_DRIVE_MAX_V"), map.drive_range_v().1);
        assert_eq!(
            define("HB_MOTOR_FIT_RMSE_FRACTION"),
            map.fit_rmse_fraction()
        );
        let coefficients: Vec<f64> = text
            .lines()
            .find_map(|l| l.strip_prefix("static const double HB_MOTOR_COEFFS_SCALED[4] = { "))
            .unwrap()
            .trim_end_matches(" };")
            .split(", ")
            .map(|v| v.parse().unwrap())
            .collect();
        assert_eq!(coefficients, map.coefficients_scaled());
        assert!(text.contains("(the motor map included"), "{text}");
    }

    #[test]
    fn a_fraction_a_little_past_full_scale_is_still_a_fraction() {
        // tests/data/paper-sweep.csv tops out at 1.010; read as a percentage, every command
        // was a hundredth of itself and the exponent fit came out wrong or failed.
        assert_eq!(Command::guess(&[0.1, 0.5, 1.01]), Command::Fraction);
        assert_eq!(Command::guess(&[0.1, 0.5, 1.0]), Command::Fraction);
        assert_eq!(Command::guess(&[10.0, 50.0, 100.0]), Command::Percent);
        assert_eq!(Command::guess(&[5.0, 40.0]), Command::Percent);
        assert!(matches!(
            Command::guess(&[1100.0, 1900.0]),
            Command::Microseconds { .. }
        ));
    }

    #[test]
    fn ardupilot_inverse_matches_forward_model() {
        for expo in [0.0, 0.3, 0.65, 1.0] {
            for v in [0.75, 0.9, 1.0] {
                for t in [0.1, 0.3, 0.5] {
                    let a = ardupilot_actuator_for_thrust(t, v, expo);
                    let lift_max = v * (1.0 - expo) + expo * v * v;
                    let got = ardupilot_thrust_fraction(a, v, expo);
                    assert!((got - lift_max * t).abs() < 1e-12, "e={expo} v={v} t={t}");
                }
            }
        }
    }

    #[test]
    fn clamps_and_reports_out_of_range_expo() {
        // Thrust that bends the other way (concave) has e < 0: clamped to 0.
        let a: Vec<f64> = (1..=10).map(|i| f64::from(i) / 10.0).collect();
        let t: Vec<f64> = a.iter().map(|a| 100.0 * (1.3 * a - 0.3 * a * a)).collect();
        let f = fit_thrust_expo(&a, &t).unwrap();
        assert_eq!(f.expo, 0.0);
        assert!((f.expo_unclamped + 0.3).abs() < 1e-9);
        assert!(f.rms_error_pct > 0.0);
    }

    #[test]
    fn voltage_scaled_fit_recovers_a_rotor_that_follows_ardupilots_model() {
        let sweeps: Vec<VoltageSweep> = [12.6, 11.1, 9.9]
            .iter()
            .map(|&v| {
                let a: Vec<f64> = (1..=12).map(|i| f64::from(i) / 12.0).collect();
                let thrust = a
                    .iter()
                    .map(|&a| 800.0 * ardupilot_thrust_fraction(a, v / 12.6, 0.55))
                    .collect();
                VoltageSweep {
                    voltage_v: v,
                    actuator: a,
                    thrust_g: thrust,
                }
            })
            .collect();
        let f = fit_expo_with_voltage_scaling(&sweeps, 12.6).unwrap();
        assert!((f.expo - 0.55).abs() < 1e-9);
        assert!((f.max_thrust_g - 800.0).abs() < 1e-6);
    }

    #[test]
    fn hover_outside_ardupilots_range_is_flagged() {
        let mut i = input();
        i.takeoff_mass_kg = Some(0.15);
        let text = ArduPilotParams::new(&i, SpinRange::default())
            .unwrap()
            .render();
        assert!(
            text.contains("outside ArduPilot's accepted 0.125–0.6875"),
            "{text}"
        );
    }

    #[test]
    fn hover_needs_enough_thrust() {
        assert!((hover_fraction(0.6, 4, 300.0).unwrap() - 0.5).abs() < 1e-12);
        assert!(matches!(
            hover_fraction(1.6, 4, 300.0),
            Err(ExportError::CannotHover { .. })
        ));
    }

    fn input() -> ExportInput {
        ExportInput {
            expo: ExpoFit {
                expo: 0.62,
                expo_unclamped: 0.62,
                max_thrust_g: 410.0,
                rms_error_pct: 0.8,
                points: 20,
            },
            sweep_name: "sweep.csv".into(),
            takeoff_mass_kg: Some(0.575),
            rotors: 4,
            battery: Some(BatterySpec {
                cells: 3,
                capacity_mah: 2100.0,
                empty_cell_v: 3.0,
                full_cell_v: 4.2,
                internal_resistance_ohm: None,
                voltages_of: None,
            }),
        }
    }

    #[test]
    fn px4_file_format() {
        insta::assert_snapshot!(Px4Params::new(&input()).unwrap().render());
    }

    #[test]
    fn px4_cell_voltages_keep_px4_defaults_for_lithium_oxide_cells_and_move_for_lifepo4() {
        for c in [
            Chemistry::Lipo,
            Chemistry::Lihv,
            Chemistry::LiIonNmc,
            Chemistry::LiIonNca,
        ] {
            assert_eq!(
                px4_cell_voltages(c),
                Some(PX4_DEFAULT_CELL_VOLTAGES),
                "{c:?}"
            );
        }
        assert_eq!(px4_cell_voltages(Chemistry::Measured), None);
        assert_eq!(px4_cell_voltages(Chemistry::Other), None);
        // LiFePO4: both below PX4's empty 3.6 V (its whole plateau is), empty below charged
        let lfp = px4_cell_voltages(Chemistry::LiFePo4).unwrap();
        assert!(lfp.empty_cell_v < lfp.charged_cell_v);
        assert!(lfp.charged_cell_v < PX4_DEFAULT_CELL_VOLTAGES.empty_cell_v);
        // written with where they came from
        let mut i = input();
        let b = i.battery.as_mut().unwrap();
        b.empty_cell_v = lfp.empty_cell_v;
        b.full_cell_v = lfp.charged_cell_v;
        b.voltages_of = Some(Chemistry::LiFePo4);
        let text = Px4Params::new(&i).unwrap().render();
        assert!(
            text.contains(
                "# BAT1_V_EMPTY: PX4's per-cell empty voltage for lifepo4 cells (--chemistry)\n1\t1\tBAT1_V_EMPTY\t3.000000\t9"
            ),
            "{text}"
        );
    }

    #[test]
    fn ardupilot_file_format() {
        insta::assert_snapshot!(
            ArduPilotParams::new(&input(), SpinRange::default())
                .unwrap()
                .render()
        );
    }

    #[test]
    fn px4_rows_have_five_tab_separated_fields_and_valid_types() {
        let text = Px4Params::new(&input()).unwrap().render();
        for line in text.lines().filter(|l| !l.starts_with('#')) {
            let f: Vec<&str> = line.split('\t').collect();
            assert_eq!(f.len(), 5, "{line}");
            let ty: u8 = f[4].parse().unwrap();
            assert!(ty == MAV_INT32 || ty == MAV_REAL32);
            if ty == MAV_INT32 {
                f[3].parse::<i64>().unwrap();
            } else {
                f[3].parse::<f32>().unwrap();
            }
        }
    }

    proptest! {
        #[test]
        fn expo_fit_recovers_random_curves(e in 0.0f64..1.0, t_max in 10.0f64..5000.0, n in 4usize..40) {
            let a: Vec<f64> = (1..=n).map(|i| i as f64 / n as f64).collect();
            let t: Vec<f64> = a.iter().map(|a| t_max * ((1.0 - e) * a + e * a * a)).collect();
            let f = fit_thrust_expo(&a, &t).unwrap();
            prop_assert!((f.expo - e).abs() < 1e-8);
            prop_assert!((f.max_thrust_g - t_max).abs() < 1e-6 * t_max);
        }

        #[test]
        fn expo_fit_never_panics(a in proptest::collection::vec(-1.0f64..2.0, 0..20), t in proptest::collection::vec(-10.0f64..1e4, 0..20)) {
            let _ = fit_thrust_expo(&a, &t);
        }
    }
}
