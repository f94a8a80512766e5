//! Physical motor–propeller–ESC–supply equations for a thrust stand, their bounded extensions,
//! and a robust fit to measured sweeps.
//!
//! The model takes the stand's measured thrust as its input (it needs no knowledge of how an
//! ESC maps its command to a duty cycle) and predicts what the stand measures besides: rotor
//! speed, propeller torque, supply voltage, supply current and electrical power.
//!
//! * Propeller: `T = C_T·(n/1000)²` (g, n in rpm), `Q = C_Q·(n/1000)²` (N·m) — the thrust and
//!   power coefficients with the air density and diameter lumped in (`C_P = 2π·C_Q`).
//! * Motor: `K_t = 30/(π·K_v)`, `I_m = Q/K_t + I_0`, `V_m = K_t·ω + I_m·R`.
//! * ESC: `P_in = V_m·I_m / η`.
//! * Supply: `V_bus = V_0 − R_s·I_bus`, `I_bus = P_in / V_bus` (base: `R_s = 0`).
//!
//! [`Effect`]s extend it, each by one or two bounded parameters: `supply_sag` (source
//! resistance), `winding_heating` (copper resistance rising with a first-order winding
//! temperature), `no_load_current` (rising with speed), `esc_loss` (efficiency falling at
//! partial duty), `reynolds_effect` (torque coefficient varying with speed),
//! `loadcell_drift` (tare offset and creep) and `stand_blockage` (a share of thrust lost to
//! the stand's structure). [`fit::fit`] fits a chosen set of parameters to sweeps of
//! [`Observation`]s with a Huber-robust Levenberg–Marquardt solve ([`lm`]) and returns
//! standard errors from the Jacobian at the solution.
//!
//! ```
//! use motor_model::{Params, Point, predict_sweep};
//! let mut p = Params::default();
//! p.set_base(2300.0, 0.08, 0.5, 0.95, 20.0, 0.002, 12.0);
//! let pred = predict_sweep(&p, &[Point { thrust_g: 400.0, time_frac: 0.0, time_s: 0.0, tare_time_s: 0.0, measured_current_a: None }]);
//! assert!(pred[0].power_w > 10.0 && pred[0].power_w < 200.0);
//! assert!((pred[0].rpm - 1000.0 * (400.0f64 / 20.0).sqrt()).abs() < 1e-9);
//! ```

pub mod fit;
pub mod lm;

use serde::Serialize;

/// Copper's temperature coefficient of resistance, 1/K.
pub const COPPER_ALPHA_PER_K: f64 = 0.003_93;

/// One parameter of the model (an index into [`Params`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Param {
    /// Motor speed constant, rpm/V (in the rpm the stand reports).
    KvRpmPerV,
    /// Winding (phase-to-phase) resistance, Ω.
    ResistanceOhm,
    /// No-load current, A.
    NoLoadCurrentA,
    /// ESC efficiency, fraction.
    EscEfficiency,
    /// Thrust coefficient, g per (1000 rpm)².
    ThrustCoeffGPerKrpm2,
    /// Torque coefficient, N·m per (1000 rpm)².
    TorqueCoeffNmPerKrpm2,
    /// Supply open-circuit voltage, V.
    SupplyVoltageV,
    /// `supply_sag`: source resistance of the supply or battery, Ω.
    SourceResistanceOhm,
    /// `winding_heating`: winding thermal resistance, K/W.
    ThermalResistanceKPerW,
    /// `winding_heating`: winding thermal time constant, s (in steps when the log has no time).
    ThermalTauS,
    /// `no_load_current`: rise of the no-load current with speed, A per 1000 rpm.
    NoLoadSlopeAPerKrpm,
    /// `esc_loss`: efficiency lost at zero duty (linear in `1 − duty`), fraction.
    EscPartialLoss,
    /// `reynolds_effect`: exponent of the torque coefficient on rotor speed.
    DragReExponent,
    /// `loadcell_drift`: tare offset, g.
    LoadcellOffsetG,
    /// `loadcell_drift`: drift rate of the load cell's zero at the start of the log, g/s (g per
    /// step when the log has no time).
    LoadcellRateGPerS,
    /// `stand_blockage`: share of thrust lost to the stand, fraction.
    BlockageFraction,
    /// `supply_sag`: a battery's open-circuit voltage drop per charge drawn, V per A·s (per
    /// ampere-step when the log has no time): the state of charge falling during the sweep.
    DischargeVPerAs,
    /// `loadcell_drift`: time constant over which the zero's drift settles (a strain-gauge
    /// bridge warming up, creep under load), s; very long is a steady linear drift.
    LoadcellTauS,
    /// `supply_sag`: a battery's polarisation resistance (its RC branch), Ω.
    PolarisationOhm,
    /// `supply_sag`: the polarisation's time constant, s (steps when the log has no time).
    PolarisationTauS,
}

/// Number of parameters.
pub const N_PARAMS: usize = 20;

impl Param {
    /// Every parameter, in index order.
    pub const ALL: [Param; N_PARAMS] = [
        Param::KvRpmPerV,
        Param::ResistanceOhm,
        Param::NoLoadCurrentA,
        Param::EscEfficiency,
        Param::ThrustCoeffGPerKrpm2,
        Param::TorqueCoeffNmPerKrpm2,
        Param::SupplyVoltageV,
        Param::SourceResistanceOhm,
        Param::ThermalResistanceKPerW,
        Param::ThermalTauS,
        Param::NoLoadSlopeAPerKrpm,
        Param::EscPartialLoss,
        Param::DragReExponent,
        Param::LoadcellOffsetG,
        Param::LoadcellRateGPerS,
        Param::BlockageFraction,
        Param::DischargeVPerAs,
        Param::LoadcellTauS,
        Param::PolarisationOhm,
        Param::PolarisationTauS,
    ];

    /// The base model's parameters.
    pub const BASE: [Param; 7] = [
        Param::KvRpmPerV,
        Param::ResistanceOhm,
        Param::NoLoadCurrentA,
        Param::EscEfficiency,
        Param::ThrustCoeffGPerKrpm2,
        Param::TorqueCoeffNmPerKrpm2,
        Param::SupplyVoltageV,
    ];

    /// Index into [`Params::values`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// Name with unit, as in JSON and tables.
    pub fn name(self) -> &'static str {
        match self {
            Param::KvRpmPerV => "kv_rpm_per_v",
            Param::ResistanceOhm => "resistance_ohm",
            Param::NoLoadCurrentA => "no_load_current_a",
            Param::EscEfficiency => "esc_efficiency",
            Param::ThrustCoeffGPerKrpm2 => "thrust_coeff_g_per_krpm2",
            Param::TorqueCoeffNmPerKrpm2 => "torque_coeff_nm_per_krpm2",
            Param::SupplyVoltageV => "supply_voltage_v",
            Param::SourceResistanceOhm => "source_resistance_ohm",
            Param::ThermalResistanceKPerW => "thermal_resistance_k_per_w",
            Param::ThermalTauS => "thermal_tau_s",
            Param::NoLoadSlopeAPerKrpm => "no_load_slope_a_per_krpm",
            Param::EscPartialLoss => "esc_partial_loss",
            Param::DragReExponent => "drag_re_exponent",
            Param::LoadcellOffsetG => "loadcell_offset_g",
            Param::LoadcellRateGPerS => "loadcell_rate_g_per_s",
            Param::BlockageFraction => "blockage_fraction",
            Param::DischargeVPerAs => "discharge_v_per_as",
            Param::LoadcellTauS => "loadcell_tau_s",
            Param::PolarisationOhm => "polarisation_ohm",
            Param::PolarisationTauS => "polarisation_tau_s",
        }
    }

    /// Whether the parameter is strictly positive and fitted in log space.
    pub fn positive(self) -> bool {
        Param::BASE.contains(&self)
            || self == Param::LoadcellTauS
            || self == Param::PolarisationTauS
    }
}

/// An unmodelled effect: a bounded physical extension of the base model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Supply or battery source resistance: the bus voltage sags with current (and a battery's
    /// open-circuit voltage with the charge drawn).
    SupplySag,
    /// Winding resistance rising with a first-order winding temperature.
    WindingHeating,
    /// No-load (iron and bearing) current rising with speed.
    NoLoadCurrent,
    /// ESC efficiency falling at partial duty.
    EscLoss,
    /// Propeller torque coefficient varying with Reynolds number (rotor speed).
    ReynoldsEffect,
    /// Load-cell tare offset and creep.
    LoadcellDrift,
    /// A share of thrust lost to the stand's structure in the slipstream.
    StandBlockage,
}

impl Effect {
    /// Every effect in the library.
    pub const ALL: [Effect; 7] = [
        Effect::SupplySag,
        Effect::WindingHeating,
        Effect::NoLoadCurrent,
        Effect::EscLoss,
        Effect::ReynoldsEffect,
        Effect::LoadcellDrift,
        Effect::StandBlockage,
    ];

    /// Its name, as in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Effect::SupplySag => "supply_sag",
            Effect::WindingHeating => "winding_heating",
            Effect::NoLoadCurrent => "no_load_current",
            Effect::EscLoss => "esc_loss",
            Effect::ReynoldsEffect => "reynolds_effect",
            Effect::LoadcellDrift => "loadcell_drift",
            Effect::StandBlockage => "stand_blockage",
        }
    }

    /// Parses a name.
    pub fn from_name(s: &str) -> Option<Self> {
        Effect::ALL.into_iter().find(|e| e.name() == s)
    }

    /// The parameters of its short form, tried first on little data: `supply_sag` without the
    /// battery's polarisation branch; the others have one form.
    pub fn short_params(self) -> &'static [Param] {
        match self {
            Effect::SupplySag => &[Param::SourceResistanceOhm, Param::DischargeVPerAs],
            e => e.params(),
        }
    }

    /// The parameters it adds.
    pub fn params(self) -> &'static [Param] {
        match self {
            Effect::SupplySag => &[
                Param::SourceResistanceOhm,
                Param::DischargeVPerAs,
                Param::PolarisationOhm,
                Param::PolarisationTauS,
            ],
            Effect::WindingHeating => &[Param::ThermalResistanceKPerW, Param::ThermalTauS],
            Effect::NoLoadCurrent => &[Param::NoLoadSlopeAPerKrpm],
            Effect::EscLoss => &[Param::EscPartialLoss],
            Effect::ReynoldsEffect => &[Param::DragReExponent],
            Effect::LoadcellDrift => &[
                Param::LoadcellOffsetG,
                Param::LoadcellRateGPerS,
                Param::LoadcellTauS,
            ],
            Effect::StandBlockage => &[Param::BlockageFraction],
        }
    }
}

/// All parameter values (base and extensions; an extension at its neutral value is off).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// Values, indexed by [`Param::index`].
    pub values: [f64; N_PARAMS],
    /// Reference speed of the Reynolds-number extension, rpm.
    pub reference_rpm: f64,
}

impl Default for Params {
    fn default() -> Self {
        let mut values = [0.0; N_PARAMS];
        values[Param::KvRpmPerV.index()] = 1000.0;
        values[Param::ResistanceOhm.index()] = 0.1;
        values[Param::NoLoadCurrentA.index()] = 0.5;
        values[Param::EscEfficiency.index()] = 0.95;
        values[Param::ThrustCoeffGPerKrpm2.index()] = 10.0;
        values[Param::TorqueCoeffNmPerKrpm2.index()] = 0.000_2;
        values[Param::SupplyVoltageV.index()] = 12.0;
        values[Param::ThermalTauS.index()] = 10.0;
        values[Param::LoadcellTauS.index()] = 100.0;
        values[Param::PolarisationTauS.index()] = 10.0;
        Self {
            values,
            reference_rpm: 10_000.0,
        }
    }
}

impl Params {
    /// A parameter's value.
    pub fn get(&self, p: Param) -> f64 {
        self.values[p.index()]
    }

    /// Sets a parameter's value.
    pub fn set(&mut self, p: Param, v: f64) {
        self.values[p.index()] = v;
    }

    /// Sets the base model: Kv (rpm/V), R (Ω), I₀ (A), η, C_T (g/krpm²), C_Q (N·m/krpm²), V₀ (V).
    #[allow(clippy::too_many_arguments)]
    pub fn set_base(&mut self, kv: f64, r: f64, i0: f64, eta: f64, ct: f64, cq: f64, v0: f64) {
        self.set(Param::KvRpmPerV, kv);
        self.set(Param::ResistanceOhm, r);
        self.set(Param::NoLoadCurrentA, i0);
        self.set(Param::EscEfficiency, eta);
        self.set(Param::ThrustCoeffGPerKrpm2, ct);
        self.set(Param::TorqueCoeffNmPerKrpm2, cq);
        self.set(Param::SupplyVoltageV, v0);
    }
}

/// One measured operating point: the stand's thrust reading and when in its sweep it was taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Thrust as the load cell read it, g.
    pub thrust_g: f64,
    /// Position in the sweep, 0 (first step) … 1 (last step).
    pub time_frac: f64,
    /// Time since the log started, s (the step index when the log has no time column): the
    /// clock of the thermal, discharge and load-cell drift extensions.
    pub time_s: f64,
    /// When the load cell was last tared (zeroed), on the same clock, s.
    pub tare_time_s: f64,
    /// The supply current the stand measured, A, when logged: the supply model (sag,
    /// polarisation, discharge) is driven by it, so a supply whose form the model misses cannot
    /// bend the motor–propeller part through the predicted current.
    pub measured_current_a: Option<f64>,
}

/// What the model predicts at one point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Prediction {
    /// The propeller's true thrust, g.
    pub thrust_true_g: f64,
    /// Rotor speed, rpm.
    pub rpm: f64,
    /// Propeller torque, N·m.
    pub torque_nm: f64,
    /// Motor (phase-equivalent DC) current, A.
    pub motor_current_a: f64,
    /// Motor (phase-equivalent DC) voltage, V.
    pub motor_voltage_v: f64,
    /// ESC duty, fraction (may exceed 1 when the supply cannot reach the point).
    pub duty: f64,
    /// Supply (bus) voltage, V.
    pub voltage_v: f64,
    /// Supply (bus) current, A.
    pub current_a: f64,
    /// Electrical input power, W.
    pub power_w: f64,
    /// Copper loss, W.
    pub copper_loss_w: f64,
    /// Winding temperature rise, K.
    pub winding_rise_k: f64,
}

/// Predicts a sweep's points in order (the winding temperature and the charge drawn carry from
/// one to the next over the time between them, starting cold and full).
pub fn predict_sweep(p: &Params, points: &[Point]) -> Vec<Prediction> {
    let kv = p.get(Param::KvRpmPerV);
    let r0 = p.get(Param::ResistanceOhm);
    let i0 = p.get(Param::NoLoadCurrentA);
    let eta = p.get(Param::EscEfficiency);
    let ct = p.get(Param::ThrustCoeffGPerKrpm2);
    let cq = p.get(Param::TorqueCoeffNmPerKrpm2);
    let v0 = p.get(Param::SupplyVoltageV);
    let rs = p.get(Param::SourceResistanceOhm);
    let rth = p.get(Param::ThermalResistanceKPerW);
    let tau = p.get(Param::ThermalTauS).max(1e-3);
    // Time between steps; the first step lasts as long as the typical one.
    let dt_of = |k: usize| -> f64 {
        if k > 0 {
            (points[k].time_s - points[k - 1].time_s).max(0.0)
        } else if points.len() > 1 {
            (points[points.len() - 1].time_s - points[0].time_s).max(0.0)
                / (points.len() - 1) as f64
        } else {
            1.0
        }
    };
    let slope = p.get(Param::NoLoadSlopeAPerKrpm);
    let esc_e = p.get(Param::EscPartialLoss);
    let re_a = p.get(Param::DragReExponent);
    let off = p.get(Param::LoadcellOffsetG);
    let rate = p.get(Param::LoadcellRateGPerS);
    let drift_tau = p.get(Param::LoadcellTauS).max(1e-3);
    // The zero's drift since the log started, first order: rate·τ·(1 − e^(−t/τ)).
    let drift = |t: f64| rate * drift_tau * -(-t / drift_tau).exp_m1();
    // Without drift (or blockage, thermal and supply dynamics, a Reynolds exponent) the terms
    // below are exact zeros or ones: they are skipped, not approximated, so every prediction is
    // bit for bit what the full expressions give (these evaluations are most of a fit's time).
    let no_drift = rate == 0.0 && drift_tau.is_finite();
    let block = p.get(Param::BlockageFraction);
    let discharge = p.get(Param::DischargeVPerAs);
    let r1 = p.get(Param::PolarisationOhm);
    let tau1 = p.get(Param::PolarisationTauS).max(1e-3);
    let dynamic = !(rth == 0.0 && discharge == 0.0 && r1 == 0.0);
    let mut v_rc_prev = 0.0;
    let mut charge_as = 0.0;
    let kt = 30.0 / (std::f64::consts::PI * kv);
    let mut rise_prev = 0.0;
    points
        .iter()
        .enumerate()
        .map(|(k, pt)| {
            let dt = dt_of(k);
            let (relax, relax1) = if dynamic {
                (1.0 - (-dt / tau).exp(), 1.0 - (-dt / tau1).exp())
            } else {
                (0.0, 0.0)
            };
            // Load cell: reading = (1 − blockage)·T + offset + the drift since it was tared.
            let creep = if no_drift {
                0.0
            } else {
                drift(pt.time_s) - drift(pt.tare_time_s)
            };
            let t_true = ((pt.thrust_g - off - creep) / (1.0 - block)).max(1e-9);
            let rpm = 1000.0 * (t_true / ct).sqrt();
            let omega = rpm * std::f64::consts::PI / 30.0;
            let cq_eff = if re_a == 0.0 {
                cq
            } else {
                cq * (rpm.max(1.0) / p.reference_rpm).powf(re_a)
            };
            let q = cq_eff * (rpm / 1000.0).powi(2);
            let im = q / kt + i0 + slope * rpm / 1000.0;
            // The step is read at the end of its dwell: the winding has heated and the battery
            // discharged during it at the step's own load (a fixed point, a few passes).
            let mut rise = rise_prev;
            let mut v_rc = v_rc_prev;
            let mut i_bus = 0.0;
            let mut pred = None;
            for _ in 0..3 {
                let i_bus_in = i_bus;
                let r = r0 * (1.0 + COPPER_ALPHA_PER_K * rise);
                let vm = kt * omega + im * r;
                let p_motor = vm * im;
                let voc = (v0 - discharge * (charge_as + i_bus * dt) - v_rc).max(0.05 * v0);
                let mut vbus = voc;
                let mut p_in = p_motor / eta;
                for _ in 0..6 {
                    let duty = (vm / vbus).min(1.0);
                    let e = (eta * (1.0 - esc_e * (1.0 - duty))).max(0.05);
                    p_in = p_motor / e;
                    let next = match pt.measured_current_a {
                        Some(i) => (voc - rs * i).max(0.05 * v0),
                        None => {
                            let disc = voc * voc - 4.0 * rs * p_in;
                            0.5 * (voc + disc.max(0.0).sqrt())
                        }
                    };
                    // A fixed point reached exactly: further passes would repeat this one.
                    let settled = next.to_bits() == vbus.to_bits();
                    vbus = next;
                    if settled {
                        break;
                    }
                }
                i_bus = pt.measured_current_a.unwrap_or(p_in / vbus);
                let pcu = im * im * r;
                pred = Some(Prediction {
                    thrust_true_g: t_true,
                    rpm,
                    torque_nm: q,
                    motor_current_a: im,
                    motor_voltage_v: vm,
                    duty: vm / vbus,
                    voltage_v: vbus,
                    current_a: p_in / vbus,
                    power_w: p_in,
                    copper_loss_w: pcu,
                    winding_rise_k: rise,
                });
                if !dynamic {
                    break;
                }
                let next_rise = rise_prev + (rth * pcu - rise_prev) * relax;
                let next_v_rc = v_rc_prev + (i_bus * r1 - v_rc_prev) * relax1;
                // The state this pass started from came back exactly (e.g. a measured current
                // drives the supply): a further pass would repeat this one.
                let settled = next_rise.to_bits() == rise.to_bits()
                    && next_v_rc.to_bits() == v_rc.to_bits()
                    && i_bus.to_bits() == i_bus_in.to_bits();
                rise = next_rise;
                v_rc = next_v_rc;
                if settled {
                    break;
                }
            }
            rise_prev = rise;
            v_rc_prev = v_rc;
            charge_as += i_bus * dt;
            pred.expect("at least one pass")
        })
        .collect()
}

/// A measured quantity the model is compared with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// Electrical power, W.
    PowerW,
    /// Supply current, A (compared only when power is not).
    CurrentA,
    /// Supply voltage, V.
    VoltageV,
    /// Rotor speed, rpm.
    SpeedRpm,
    /// Propeller torque, N·m.
    TorqueNm,
}

impl Quantity {
    /// Every quantity.
    pub const ALL: [Quantity; 5] = [
        Quantity::PowerW,
        Quantity::CurrentA,
        Quantity::VoltageV,
        Quantity::SpeedRpm,
        Quantity::TorqueNm,
    ];

    /// Name with unit.
    pub fn name(self) -> &'static str {
        match self {
            Quantity::PowerW => "power_w",
            Quantity::CurrentA => "current_a",
            Quantity::VoltageV => "voltage_v",
            Quantity::SpeedRpm => "speed_rpm",
            Quantity::TorqueNm => "torque_nm",
        }
    }

    /// The predicted value.
    pub fn predicted(self, p: &Prediction) -> f64 {
        match self {
            Quantity::PowerW => p.power_w,
            Quantity::CurrentA => p.current_a,
            Quantity::VoltageV => p.voltage_v,
            Quantity::SpeedRpm => p.rpm,
            Quantity::TorqueNm => p.torque_nm,
        }
    }
}

/// One measured step of a sweep.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Observation {
    /// Thrust reading, g.
    pub thrust_g: f64,
    /// Position in the sweep, 0 … 1.
    pub time_frac: f64,
    /// Time since the log started, s (the step index when the log has no time column).
    pub time_s: f64,
    /// Electrical power, W.
    pub power_w: Option<f64>,
    /// Supply current, A.
    pub current_a: Option<f64>,
    /// Supply voltage, V.
    pub voltage_v: Option<f64>,
    /// Rotor speed, rpm.
    pub speed_rpm: Option<f64>,
    /// Torque, N·m.
    pub torque_nm: Option<f64>,
    /// A step that only carries the sweep's history (its thrust, time and measured current
    /// drive the winding temperature, the battery's polarisation and charge and the load cell's
    /// drift) but is not compared: [`Observation::measured`] gives nothing for it. Half of a
    /// sweep's steps (every second one) keeps the other half this way, so its model sees the
    /// load the stand really went through.
    pub drive_only: bool,
}

impl Observation {
    /// The measured value of a quantity, if logged (never for a [`Observation::drive_only`]
    /// step).
    pub fn measured(&self, q: Quantity) -> Option<f64> {
        if self.drive_only {
            return None;
        }
        match q {
            Quantity::PowerW => self.power_w,
            Quantity::CurrentA => self.current_a,
            Quantity::VoltageV => self.voltage_v,
            Quantity::SpeedRpm => self.speed_rpm,
            Quantity::TorqueNm => self.torque_nm,
        }
    }

    /// The point the model is driven with.
    pub fn point(&self) -> Point {
        Point {
            thrust_g: self.thrust_g,
            time_frac: self.time_frac,
            time_s: self.time_s,
            tare_time_s: 0.0,
            measured_current_a: self
                .current_a
                .or_else(|| self.power_w.zip(self.voltage_v).map(|(p, v)| p / v))
                .filter(|i| i.is_finite()),
        }
    }
}

/// A sweep: observations in the order they were taken.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Sweep {
    /// Name, for messages.
    pub name: String,
    /// The steps.
    pub steps: Vec<Observation>,
    /// The supply's open-circuit voltage for this sweep when it was measured (e.g. a battery's
    /// voltage at idle before the sweep); it replaces [`Param::SupplyVoltageV`] for this sweep.
    pub open_circuit_v: Option<f64>,
    /// When the load cell was tared before this sweep, on the steps' clock, s.
    pub tare_time_s: f64,
    /// When no open-circuit voltage was measured: whether the supply's open-circuit voltage
    /// for this sweep is set so that the model meets the measured voltage at the first step that
    /// logs one (a battery's state of charge differs from one sweep to the next, and a sweep
    /// that starts spinning gives no idle reading), instead of [`Param::SupplyVoltageV`]. The
    /// sag, polarisation and discharge then show as the voltage falling from that step on.
    pub anchor_first_voltage: bool,
    /// Whether the load cell was zeroed at an idle reading before this sweep (its reading at
    /// zero thrust taken off every step): its offset is then gone, and only the drift since
    /// the tare is left; [`Param::LoadcellOffsetG`] applies to sweeps read without a tare.
    pub tared: bool,
}

impl Sweep {
    /// Predictions for every step.
    pub fn predict(&self, p: &Params) -> Vec<Prediction> {
        let pts: Vec<Point> = self
            .steps
            .iter()
            .map(|o| Point {
                tare_time_s: self.tare_time_s,
                ..o.point()
            })
            .collect();
        let mut q = *p;
        if let Some(v) = self.open_circuit_v {
            q.set(Param::SupplyVoltageV, v);
        }
        if self.tared {
            q.set(Param::LoadcellOffsetG, 0.0);
        }
        let first_v = self
            .steps
            .iter()
            .enumerate()
            .find_map(|(k, o)| o.voltage_v.map(|v| (k, v)));
        match first_v {
            Some((k, v_meas)) if self.open_circuit_v.is_none() && self.anchor_first_voltage => {
                // The bus voltage is (nearly) affine in the open-circuit voltage: two passes
                // meet the anchor to well within a sensor's resolution.
                let mut pred = predict_sweep(&q, &pts);
                for _ in 0..2 {
                    let miss = v_meas - pred[k].voltage_v;
                    let v0 = q.get(Param::SupplyVoltageV);
                    q.set(Param::SupplyVoltageV, (v0 + miss).max(0.01 * v0.abs()));
                    pred = predict_sweep(&q, &pts);
                }
                pred
            }
            _ => predict_sweep(&q, &pts),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> Params {
        let mut p = Params::default();
        p.set_base(920.0, 0.12, 0.6, 0.95, 12.0, 0.000_25, 16.8);
        p
    }

    #[test]
    fn power_balances() {
        let p = base();
        let pred = predict_sweep(
            &p,
            &[Point {
                thrust_g: 800.0,
                time_frac: 0.0,
                time_s: 0.0,
                tare_time_s: 0.0,
                measured_current_a: None,
            }],
        )[0];
        let omega = pred.rpm * std::f64::consts::PI / 30.0;
        let mech = omega * pred.torque_nm;
        let loss_cu = pred.motor_current_a.powi(2) * 0.12;
        let back_emf = omega * 30.0 / (std::f64::consts::PI * 920.0);
        let i0_loss = back_emf * 0.6;
        let motor = mech + loss_cu + i0_loss;
        assert!((pred.power_w * 0.95 - motor).abs() < 1e-9 * motor);
        assert!((pred.voltage_v - 16.8).abs() < 1e-12);
        assert!((pred.current_a * pred.voltage_v - pred.power_w).abs() < 1e-9);
    }

    #[test]
    fn sag_lowers_voltage_and_raises_current() {
        let mut p = base();
        let pt = [Point {
            thrust_g: 800.0,
            time_frac: 0.0,
            time_s: 0.0,
            tare_time_s: 0.0,
            measured_current_a: None,
        }];
        let a = predict_sweep(&p, &pt)[0];
        p.set(Param::SourceResistanceOhm, 0.1);
        let b = predict_sweep(&p, &pt)[0];
        assert!((b.voltage_v - (16.8 - 0.1 * b.current_a)).abs() < 1e-9);
        assert!(b.current_a > a.current_a);
        assert!((b.power_w - a.power_w).abs() < 1e-9);
    }

    #[test]
    fn heating_raises_power_over_time() {
        let mut p = base();
        p.set(Param::ThermalResistanceKPerW, 10.0);
        p.set(Param::ThermalTauS, 3.0);
        let pts: Vec<Point> = (0..10)
            .map(|i| Point {
                thrust_g: 800.0,
                time_frac: i as f64 / 9.0,
                time_s: i as f64,
                tare_time_s: 0.0,
                measured_current_a: None,
            })
            .collect();
        let pr = predict_sweep(&p, &pts);
        assert!(pr[9].power_w > pr[0].power_w);
        assert!(pr[9].winding_rise_k > 5.0);
    }

    fn at(thrust_g: f64, time_s: f64) -> Point {
        Point {
            thrust_g,
            time_frac: 0.0,
            time_s,
            tare_time_s: 0.0,
            measured_current_a: None,
        }
    }

    #[test]
    fn polarisation_relaxes_with_its_time_constant() {
        let mut p = base();
        p.set(Param::PolarisationOhm, 0.05);
        p.set(Param::PolarisationTauS, 8.0);
        // A long hold at one thrust: the drop approaches R1·I, and after τ it is 1 − e⁻¹ of it.
        let pts: Vec<Point> = (0..=40).map(|k| at(800.0, k as f64)).collect();
        let pr = predict_sweep(&p, &pts);
        let i = pr[40].current_a;
        let drop = |k: usize| 16.8 - pr[k].voltage_v;
        assert!(
            (drop(40) - 0.05 * i).abs() < 0.01 * 0.05 * i,
            "{}",
            drop(40)
        );
        let share_at_tau = drop(8) / drop(40);
        assert!(
            (share_at_tau - (1.0 - (-1.0f64).exp())).abs() < 0.05,
            "{share_at_tau}"
        );
        assert!(drop(1) < drop(8));
    }

    #[test]
    fn loadcell_drift_counts_from_the_tare() {
        let mut p = base();
        p.set(Param::LoadcellRateGPerS, 0.5);
        p.set(Param::LoadcellTauS, 50.0);
        let drift = |t: f64| 0.5 * 50.0 * (1.0 - (-t / 50.0f64).exp());
        // Same reading at 30 s after a tare at 0 s and at 130 s after a tare at 100 s: the true
        // thrust is the reading less the drift since the tare.
        let a = predict_sweep(&p, &[at(500.0, 30.0)])[0];
        let b = predict_sweep(
            &p,
            &[Point {
                tare_time_s: 100.0,
                ..at(500.0, 130.0)
            }],
        )[0];
        assert!((a.thrust_true_g - (500.0 - drift(30.0))).abs() < 1e-9);
        assert!((b.thrust_true_g - (500.0 - (drift(130.0) - drift(100.0)))).abs() < 1e-9);
        assert!(b.thrust_true_g > a.thrust_true_g);
    }

    #[test]
    fn measured_current_drives_the_supply_not_the_power() {
        let mut p = base();
        p.set(Param::SourceResistanceOhm, 0.1);
        let free = predict_sweep(&p, &[at(800.0, 0.0)])[0];
        let driven = predict_sweep(
            &p,
            &[Point {
                measured_current_a: Some(30.0),
                ..at(800.0, 0.0)
            }],
        )[0];
        assert!((driven.voltage_v - (16.8 - 0.1 * 30.0)).abs() < 1e-9);
        assert!((driven.power_w - free.power_w).abs() < 1e-9);
    }

    #[test]
    fn a_sweep_without_an_idle_reading_is_anchored_at_its_first_voltage() {
        let mut p = base();
        p.set(Param::SourceResistanceOhm, 0.1);
        // A pack at 16.2 V open circuit, whatever the fitted supply voltage says (16.8 V).
        let steps: Vec<Observation> = [(300.0, 8.0), (600.0, 16.0), (900.0, 24.0)]
            .iter()
            .enumerate()
            .map(|(k, &(thrust_g, i))| Observation {
                thrust_g,
                time_s: k as f64,
                current_a: Some(i),
                voltage_v: Some(16.2 - 0.1 * i),
                ..Observation::default()
            })
            .collect();
        let mut s = Sweep {
            name: "pack".into(),
            steps,
            ..Sweep::default()
        };
        let fitted_v0 = s.predict(&p);
        assert!((fitted_v0[0].voltage_v - (16.8 - 0.8)).abs() < 1e-9);
        s.anchor_first_voltage = true;
        for (o, pr) in s.steps.iter().zip(s.predict(&p)) {
            let v = o.voltage_v.unwrap_or(f64::NAN);
            assert!((pr.voltage_v - v).abs() < 1e-9, "{} vs {v}", pr.voltage_v);
        }
        // A measured open-circuit voltage wins over the anchor.
        s.open_circuit_v = Some(16.5);
        assert!((s.predict(&p)[0].voltage_v - (16.5 - 0.8)).abs() < 1e-9);
    }

    #[test]
    fn a_tared_sweep_has_no_offset_and_a_drive_only_step_is_not_compared() {
        let mut p = base();
        p.set(Param::LoadcellOffsetG, 20.0);
        let o = Observation {
            thrust_g: 500.0,
            power_w: Some(100.0),
            ..Observation::default()
        };
        let mut s = Sweep {
            steps: vec![o],
            ..Sweep::default()
        };
        let untared = s.predict(&p)[0].thrust_true_g;
        s.tared = true;
        assert!((untared - 480.0).abs() < 1e-9);
        assert!((s.predict(&p)[0].thrust_true_g - 500.0).abs() < 1e-9);
        let d = Observation {
            drive_only: true,
            ..o
        };
        assert_eq!(d.measured(Quantity::PowerW), None);
        assert_eq!(d.point(), o.point());
    }

    #[test]
    fn effect_names_round_trip() {
        for e in Effect::ALL {
            assert_eq!(Effect::from_name(e.name()), Some(e));
            assert!(!e.params().is_empty());
        }
        for (i, p) in Param::ALL.iter().enumerate() {
            assert_eq!(p.index(), i);
        }
    }
}
