//! Bench presets: a motor, propeller, ESC, supply and sensors, plus the board's limits.
//!
//! - [`paper`]: the platform of the paper (200 mm propellers, 3S, 12.5 V rig). Its constants
//!   were derived once by `sim/tools/fit_paper_preset.py` (documented there and in the
//!   fields below): Ke and R from the two published thrust limits (150 g at 9.0 V, ~260 g at
//!   12.6 V) given the reconstructed power curve, then the torque terms by a minimax fit of
//!   the steady-state electrical power at 12.5 V to
//!   `P(T) = 0.157434234·T + 0.341190317·(T/100)^5.34865728` W over 10..260 g (worst error
//!   0.30 %). `tests/paper_preset.rs` re-checks all of it through the firmware and protocol.
//!   Caveat: that curve is linear in T at low thrust, which a propeller obeying momentum
//!   theory (shaft power ∝ T^1.5) cannot follow, so the propeller's k_Q is pinned at 0.1 × the
//!   ideal-disk value and most of the low-thrust power is an iron-loss term ∝ ω² — a loss
//!   budget far worse than real motors'. With k_Q at the ideal value the curve is missed by
//!   ~3 %.
//! - [`ctu_2312_9450`]: Readytosky 2312 920KV with a DJI 9450 propeller on a 4S pack, fitted
//!   by `sim/tools/fit_ctu_preset.py` to the CTU-MRS motor test table
//!   (`tests/data/ctu_mrs_motor_tests.csv`); thrust, current and power within 2 % at 50–100 %
//!   throttle. Kv and R are effective values: they absorb the ESC's timing advance and
//!   throttle curve.

use crate::physics::{Esc, Motor, Propeller, Supply};
use crate::world::{LoadCellParams, PowerSensorParams};
use rig_firmware::Config;

/// A complete bench description.
#[derive(Debug, Clone, PartialEq)]
pub struct Preset {
    /// Name used on the command line.
    pub name: &'static str,
    /// One line of description.
    pub description: &'static str,
    /// Motor.
    pub motor: Motor,
    /// Propeller.
    pub prop: Propeller,
    /// ESC.
    pub esc: Esc,
    /// Supply.
    pub supply: Supply,
    /// Load cell and ADC.
    pub load_cell: LoadCellParams,
    /// Current/voltage sensor.
    pub power_sensor: PowerSensorParams,
    /// Firmware configuration (limits, timing).
    pub firmware: Config,
    /// INA226 full-scale current used for its calibration register, A.
    pub ina226_max_current_a: f32,
}

/// Names accepted by [`by_name`].
pub const NAMES: [&str; 2] = ["paper", "ctu-2312-9450"];

/// A preset by name.
pub fn by_name(name: &str) -> Option<Preset> {
    match name {
        "paper" => Some(paper()),
        "ctu-2312-9450" | "ctu" => Some(ctu_2312_9450()),
        _ => None,
    }
}

fn sensors(scale_g_per_count: f64, preload_g: f64) -> (LoadCellParams, PowerSensorParams) {
    (
        LoadCellParams {
            scale_g_per_count,
            zero_counts: 8_000,
            preload_g,
            noise_g: 0.15,
            creep_fraction: 3e-4,
            creep_tau_s: 60.0,
            rate_sps: 80,
        },
        PowerSensorParams {
            shunt_ohm: 0.002,
            shunt_offset_v: 1.0e-6,
            shunt_noise_v: 5.0e-6,
            bus_offset_v: 0.004,
            bus_gain_error: 0.0005,
            bus_noise_v: 0.003,
        },
    )
}

/// The paper's platform on a 12.5 V bench supply (see the module docs for the derivation).
pub fn paper() -> Preset {
    let g = crate::physics::G;
    let (load_cell, power_sensor) = sensors(0.0025, 180.0);
    Preset {
        name: "paper",
        description: "paper platform: 200 mm propeller, 3S motor, 12.5 V bench supply",
        motor: Motor {
            // Ke = 0.011212164841583789 V·s/rad
            kv_rpm_per_v: 60.0 / (2.0 * core::f64::consts::PI * 0.011_212_164_841_583_789),
            resistance_ohm: 0.153_138_573_551_330_23,
            no_load_current_a: 0.017_400_102_418_688_407,
            iron_drag_nm_s: 3.790_432_037_933_805e-5,
            inertia_kg_m2: 3.5e-5,
        },
        prop: Propeller {
            // 260 g at 1000 rad/s
            k_t: 0.260 * g / 1.0e6,
            k_q: 1.467_516_715_795_36e-9,
            drag_rise_torque_nm: 0.048_725_894_107_048_15,
            drag_rise_exponent: 9.589_988_385_211_441,
        },
        esc: Esc {
            min_us: 1000.0,
            max_us: 2000.0,
            max_duty: 1.0,
        },
        supply: Supply {
            voltage_v: 12.5,
            resistance_ohm: 0.01,
        },
        load_cell,
        power_sensor,
        firmware: Config {
            serial_number: 0x5000_0001,
            board: 0,
            max_current_a: 15.0,
            max_thrust_g: 400.0,
            min_voltage_v: 8.0,
            max_voltage_v: 14.0,
            nominal_scale_g_per_count: 0.0026,
            ..Config::default()
        },
        ina226_max_current_a: 20.0,
    }
}

/// Readytosky 2312 920KV + DJI 9450 on a 4S pack (CTU-MRS motor tests).
pub fn ctu_2312_9450() -> Preset {
    let (load_cell, power_sensor) = sensors(0.01, 250.0);
    Preset {
        name: "ctu-2312-9450",
        description: "Readytosky 2312 920KV + DJI 9450, 4S pack (CTU-MRS motor tests)",
        motor: Motor {
            kv_rpm_per_v: 1_399.658_271_661_581_5,
            resistance_ohm: 0.677_001_754_515_617_4,
            no_load_current_a: 1.023_954_204_990_790_8,
            iron_drag_nm_s: 0.0,
            inertia_kg_m2: 2.5e-5,
        },
        prop: Propeller {
            k_t: 1.119_780_349_099_190_2e-5,
            k_q: 1.012_559_618_407_358_1e-7,
            drag_rise_torque_nm: 0.0,
            drag_rise_exponent: 2.0,
        },
        esc: Esc {
            min_us: 1000.0,
            max_us: 2000.0,
            max_duty: 1.0,
        },
        supply: Supply {
            voltage_v: 16.752_885_540_595_283,
            resistance_ohm: 0.030_512_413_837_483_317,
        },
        load_cell,
        power_sensor,
        firmware: Config {
            serial_number: 0x5000_0002,
            board: 0,
            max_current_a: 30.0,
            max_thrust_g: 1500.0,
            min_voltage_v: 13.0,
            max_voltage_v: 17.5,
            nominal_scale_g_per_count: 0.0104,
            ..Config::default()
        },
        ina226_max_current_a: 30.0,
    }
}
