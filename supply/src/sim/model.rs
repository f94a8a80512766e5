//! The electrical model of the simulated supply and its loads.

use crate::supply::RegulationMode;

/// What the simulated supply powers: the current it draws at a given bus voltage.
///
/// The model solves for the operating point, so it calls [`Load::current_a`] many times per
/// solve (a bracketing search over the voltage): it must be a function of the voltage, with no
/// side effects that count calls. Negative currents are read as zero (the simulated supply
/// sources current and does not sink it). Closures `FnMut(f64) -> f64` are loads.
///
/// A rig simulator plugs its motor in here, in one of two ways:
///
/// - exact (also in constant-current mode): each step, hand the device a load that evaluates
///   the motor's bus current at a given bus voltage for the present throttle and speed, then
///   read the bus voltage the supply settles at:
///
///   ```
///   # use supply::sim::{Device, Dialect, SimConfig};
///   # let device = Device::new(Dialect::Korad, |_v: f64| 0.0, SimConfig::default());
///   # let (duty, back_emf_v, winding_ohm) = (0.5, 4.0, 0.1);
///   // (duty, back_emf_v) come from the rig's state at this step.
///   device.set_load(move |bus_v: f64| (duty * (duty * bus_v - back_emf_v) / winding_ohm).max(0.0));
///   let bus_voltage_v = device.output().voltage_v; // feed this to the motor model
///   # assert_eq!(bus_voltage_v, 0.0);
///   ```
/// - approximate: keep a [`crate::sim::SharedLoad`] that the rig updates with its latest bus
///   voltage and current (a resistance through the last operating point).
pub trait Load: Send {
    /// Current drawn at `bus_voltage_v`, A.
    fn current_a(&mut self, bus_voltage_v: f64) -> f64;
}

impl<F: FnMut(f64) -> f64 + Send> Load for F {
    fn current_a(&mut self, bus_voltage_v: f64) -> f64 {
        self(bus_voltage_v)
    }
}

/// A resistor: `I = V / R`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResistiveLoad {
    /// Resistance, Ω (non-positive or NaN: open circuit).
    pub resistance_ohm: f64,
}

impl Load for ResistiveLoad {
    fn current_a(&mut self, bus_voltage_v: f64) -> f64 {
        if self.resistance_ohm > 0.0 {
            bus_voltage_v / self.resistance_ohm
        } else {
            0.0
        }
    }
}

/// A regulated load such as an ESC at fixed throttle: `I = P / V` above a cut-off voltage,
/// nothing below it (the undervoltage lock-out).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantPowerLoad {
    /// Power drawn, W.
    pub power_w: f64,
    /// Below this bus voltage the load draws nothing, V (must be positive).
    pub cutoff_voltage_v: f64,
}

impl Load for ConstantPowerLoad {
    fn current_a(&mut self, bus_voltage_v: f64) -> f64 {
        if bus_voltage_v >= self.cutoff_voltage_v.max(1e-3) {
            self.power_w / bus_voltage_v
        } else {
            0.0
        }
    }
}

/// The supply's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Voltage set-point, V.
    pub voltage_v: f64,
    /// Current limit, A.
    pub current_limit_a: f64,
    /// Output switch.
    pub output_on: bool,
    /// Source resistance (supply, leads, connectors), Ω: in constant-voltage mode the output
    /// is `V_set − I·R`.
    pub source_resistance_ohm: f64,
}

/// The operating point: what the output terminals see.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Output {
    /// Output (bus) voltage, V.
    pub voltage_v: f64,
    /// Output current, A.
    pub current_a: f64,
    /// Regulation mode.
    pub mode: RegulationMode,
}

/// Segments of the downward scan that brackets the operating point.
const SCAN: usize = 64;
/// Bisection steps after bracketing (the bracket shrinks by 2⁻⁶⁰).
const BISECT: usize = 60;

fn draw(load: &mut dyn Load, v: f64) -> f64 {
    let i = load.current_a(v);
    if i.is_finite() { i.max(0.0) } else { 0.0 }
}

/// The highest `v` in `[0, top]` where `f` turns from positive (above) to non-positive
/// (below), given `f(top) > 0`: returns the bracket's lower end (where `f ≤ 0`), or 0 when `f`
/// stays positive down to 0.
fn highest_crossing(top: f64, mut f: impl FnMut(f64) -> f64) -> f64 {
    let mut hi = top;
    for k in 1..=SCAN {
        let lo = top * (1.0 - k as f64 / SCAN as f64);
        if f(lo) <= 0.0 {
            let mut lo = lo;
            for _ in 0..BISECT {
                let mid = 0.5 * (lo + hi);
                if f(mid) <= 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return lo;
        }
        hi = lo;
    }
    0.0
}

/// Solves the operating point of a supply with `settings` feeding `load`.
///
/// Constant voltage: the highest `V ≤ V_set` with `V = V_set − R·I(V)` (the stable point for
/// loads whose current falls with voltage, such as [`ConstantPowerLoad`]). If the load would
/// then draw more than the limit, constant current: the output drops to the highest voltage
/// at which the load draws no more than the limit (for a continuous load, exactly the limit).
pub fn solve(settings: &Settings, load: &mut dyn Load) -> Output {
    let v_set = if settings.voltage_v.is_finite() {
        settings.voltage_v.max(0.0)
    } else {
        0.0
    };
    let limit = if settings.current_limit_a.is_finite() {
        settings.current_limit_a.max(0.0)
    } else {
        0.0
    };
    let r = if settings.source_resistance_ohm.is_finite() {
        settings.source_resistance_ohm.max(0.0)
    } else {
        0.0
    };
    if !settings.output_on {
        return Output {
            voltage_v: 0.0,
            current_a: 0.0,
            mode: RegulationMode::Off,
        };
    }
    let i_top = draw(load, v_set);
    let v_cv = if r == 0.0 || i_top == 0.0 {
        v_set
    } else {
        highest_crossing(v_set, |v| v + r * draw(load, v) - v_set)
    };
    let i_cv = draw(load, v_cv);
    if i_cv <= limit {
        return Output {
            voltage_v: v_cv,
            current_a: i_cv,
            mode: RegulationMode::ConstantVoltage,
        };
    }
    let v_cc = highest_crossing(v_cv, |v| draw(load, v) - limit);
    Output {
        voltage_v: v_cc,
        current_a: draw(load, v_cc).min(limit),
        mode: RegulationMode::ConstantCurrent,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn on(voltage_v: f64, current_limit_a: f64, source_resistance_ohm: f64) -> Settings {
        Settings {
            voltage_v,
            current_limit_a,
            output_on: true,
            source_resistance_ohm,
        }
    }

    #[test]
    fn resistive_cv_with_source_resistance() {
        // 12 V behind 0.5 Ω into 5.5 Ω: I = 2 A, V = 11 V.
        let out = solve(
            &on(12.0, 5.0, 0.5),
            &mut ResistiveLoad {
                resistance_ohm: 5.5,
            },
        );
        assert_eq!(out.mode, RegulationMode::ConstantVoltage);
        assert!((out.current_a - 2.0).abs() < 1e-9, "{out:?}");
        assert!((out.voltage_v - 11.0).abs() < 1e-9, "{out:?}");
    }

    #[test]
    fn resistive_cc() {
        // 12 V into 2 Ω wants 6 A; the 3 A limit holds the output at 6 V.
        let out = solve(
            &on(12.0, 3.0, 0.0),
            &mut ResistiveLoad {
                resistance_ohm: 2.0,
            },
        );
        assert_eq!(out.mode, RegulationMode::ConstantCurrent);
        assert!((out.current_a - 3.0).abs() < 1e-9, "{out:?}");
        assert!((out.voltage_v - 6.0).abs() < 1e-9, "{out:?}");
    }

    #[test]
    fn constant_power_takes_the_stable_root() {
        // 60 W at 12 V behind 0.2 Ω: V² − 12 V + 12 = 0 → V = 6 + √24.
        let mut load = ConstantPowerLoad {
            power_w: 60.0,
            cutoff_voltage_v: 3.0,
        };
        let out = solve(&on(12.0, 10.0, 0.2), &mut load);
        assert_eq!(out.mode, RegulationMode::ConstantVoltage);
        assert!(
            (out.voltage_v - (6.0 + 24f64.sqrt())).abs() < 1e-9,
            "{out:?}"
        );
        // Limit below the demand: the supply cannot hold the power; the load browns out.
        let out = solve(&on(12.0, 2.0, 0.2), &mut load);
        assert_eq!(out.mode, RegulationMode::ConstantCurrent);
        assert!(out.current_a <= 2.0);
    }

    #[test]
    fn off_and_degenerate_inputs() {
        let mut off = on(12.0, 1.0, 0.0);
        off.output_on = false;
        let out = solve(
            &off,
            &mut ResistiveLoad {
                resistance_ohm: 1.0,
            },
        );
        assert_eq!(out.mode, RegulationMode::Off);
        let out = solve(&on(f64::NAN, f64::INFINITY, -1.0), &mut |_v: f64| f64::NAN);
        assert_eq!(out.mode, RegulationMode::ConstantVoltage);
        assert_eq!(out.voltage_v, 0.0);
        // A short circuit behind a resistance: everything drops across the source.
        let out = solve(&on(10.0, 100.0, 1.0), &mut |_v: f64| 50.0);
        assert_eq!(out.voltage_v, 0.0);
    }
}
