//! The simulated bench: propulsion physics, supply and sensor models, advanced on a simulated
//! clock. The embedded-hal peripherals in [`crate::peripherals`] read it.

use crate::noise::Rng64;
use crate::physics::{BusLoad, Electrical, Propulsion, Supply};
use std::cell::Cell;
use std::rc::Rc;

/// Load cell and HX711 model constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadCellParams {
    /// True scale, g per ADC count.
    pub scale_g_per_count: f64,
    /// Electrical zero of the bridge + ADC, counts.
    pub zero_counts: i32,
    /// Mass of motor and mount resting on the cell (removed by tare), g.
    pub preload_g: f64,
    /// White noise per conversion, g (1 σ).
    pub noise_g: f64,
    /// Creep: fraction of the load the reading drifts by, at equilibrium.
    pub creep_fraction: f64,
    /// Creep time constant, s.
    pub creep_tau_s: f64,
    /// Conversion rate, samples per second (10 or 80).
    pub rate_sps: u32,
}

/// INA226 and shunt model constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowerSensorParams {
    /// Shunt resistance, Ω.
    pub shunt_ohm: f64,
    /// Shunt-voltage offset, V.
    pub shunt_offset_v: f64,
    /// Shunt-voltage noise per reading, V (1 σ).
    pub shunt_noise_v: f64,
    /// Bus-voltage offset, V.
    pub bus_offset_v: f64,
    /// Bus-voltage gain error (fraction).
    pub bus_gain_error: f64,
    /// Bus-voltage noise per reading, V (1 σ).
    pub bus_noise_v: f64,
}

/// Bit-level state of the simulated HX711.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Hx711State {
    pub next_conversion_us: u64,
    pub ready: bool,
    pub data: u32,
    pub pulses: u8,
    pub dout_high: bool,
    pub sck_high: bool,
}

/// Register state of the simulated INA226.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Ina226State {
    pub pointer: u8,
    pub config: u16,
    pub calibration: u16,
}

/// Ground truth at the current instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Truth {
    /// Simulated time, µs.
    pub time_us: u64,
    /// Rotor speed, rad/s.
    pub omega_rad_s: f64,
    /// Propeller thrust, g.
    pub thrust_g: f64,
    /// Pulse width reaching the ESC, µs.
    pub throttle_us: f64,
    /// Electrical operating point.
    pub electrical: Electrical,
}

/// A supply outside the rig model (such as a simulated programmable bench supply with a
/// current limit) that sets the rig's bus voltage. Each physics step the world hands it the
/// rig's present [`BusLoad`] and takes the bus voltage it answers; the world's own
/// [`Supply`] then becomes that voltage with no source resistance (the external model owns
/// the source resistance and the current limit).
pub trait ExternalBus: Send {
    /// The bus voltage while `load` is connected, V.
    fn bus_voltage_v(&mut self, load: BusLoad) -> f64;
}

impl<F: FnMut(BusLoad) -> f64 + Send> ExternalBus for F {
    fn bus_voltage_v(&mut self, load: BusLoad) -> f64 {
        self(load)
    }
}

/// The simulated bench.
pub struct World {
    pub(crate) time: Rc<Cell<u64>>,
    /// Motor, propeller and ESC.
    pub propulsion: Propulsion,
    /// The supply.
    pub supply: Supply,
    /// Pulse width from the PWM output, µs.
    pub throttle_us: f64,
    /// Calibration masses resting on the load cell, g.
    pub placed_mass_g: f64,
    /// Load-cell model.
    pub load_cell: LoadCellParams,
    /// Power-sensor model.
    pub power_sensor: PowerSensorParams,
    pub(crate) electrical: Electrical,
    pub(crate) creep_g: f64,
    pub(crate) rng: Rng64,
    pub(crate) hx: Hx711State,
    pub(crate) ina: Ina226State,
    pub(crate) external_bus: Option<Box<dyn ExternalBus>>,
}

impl std::fmt::Debug for World {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World")
            .field("time_us", &self.time.get())
            .field("propulsion", &self.propulsion)
            .field("supply", &self.supply)
            .field("throttle_us", &self.throttle_us)
            .field("placed_mass_g", &self.placed_mass_g)
            .field("external_bus", &self.external_bus.is_some())
            .finish_non_exhaustive()
    }
}

impl World {
    /// A bench at rest at time 0.
    pub fn new(
        propulsion: Propulsion,
        supply: Supply,
        load_cell: LoadCellParams,
        power_sensor: PowerSensorParams,
        seed: u64,
        time: Rc<Cell<u64>>,
    ) -> Self {
        let electrical = propulsion.electrical(0.0, 0.0, supply);
        Self {
            time,
            propulsion,
            supply,
            throttle_us: propulsion.esc.min_us,
            placed_mass_g: 0.0,
            load_cell,
            power_sensor,
            electrical,
            creep_g: 0.0,
            rng: Rng64::new(seed),
            hx: Hx711State {
                dout_high: true,
                ..Default::default()
            },
            ina: Ina226State::default(),
            external_bus: None,
        }
    }

    /// Simulated time, µs.
    pub fn now_us(&self) -> u64 {
        self.time.get()
    }

    /// Total load on the cell, g (thrust plus placed masses plus preload).
    pub fn load_g(&self) -> f64 {
        self.propulsion.thrust_g(self.propulsion.omega_rad_s)
            + self.placed_mass_g
            + self.load_cell.preload_g
    }

    /// Advances physics by `dt_us`.
    pub fn step(&mut self, dt_us: u64) {
        let dt_s = dt_us as f64 * 1e-6;
        if let Some(bus) = self.external_bus.as_mut() {
            let load = self.propulsion.bus_load(self.throttle_us);
            let v = bus.bus_voltage_v(load);
            self.supply = Supply {
                voltage_v: if v.is_finite() { v.max(0.0) } else { 0.0 },
                resistance_ohm: 0.0,
            };
        }
        self.electrical = self.propulsion.step(dt_s, self.throttle_us, self.supply);
        let lc = self.load_cell;
        let net = self.load_g() - lc.preload_g;
        self.creep_g += (lc.creep_fraction * net - self.creep_g) * (dt_s / lc.creep_tau_s).min(1.0);
        self.time.set(self.time.get() + dt_us);
    }

    /// Connects an external supply that sets the bus voltage from now on (see
    /// [`ExternalBus`]); `None` goes back to the world's own [`Supply`].
    pub fn set_external_bus(&mut self, bus: Option<Box<dyn ExternalBus>>) {
        self.external_bus = bus;
    }

    /// Whether an external supply sets the bus voltage.
    pub fn has_external_bus(&self) -> bool {
        self.external_bus.is_some()
    }

    /// Ground truth now.
    pub fn truth(&self) -> Truth {
        Truth {
            time_us: self.now_us(),
            omega_rad_s: self.propulsion.omega_rad_s,
            thrust_g: self.propulsion.thrust_g(self.propulsion.omega_rad_s),
            throttle_us: self.throttle_us,
            electrical: self.electrical,
        }
    }

    /// One HX711 conversion (24-bit two's complement), with noise, creep and quantisation.
    pub(crate) fn convert_load_cell(&mut self) -> u32 {
        let lc = self.load_cell;
        let grams = self.load_g() + self.creep_g + lc.noise_g * self.rng.gaussian();
        let counts = (f64::from(lc.zero_counts) + grams / lc.scale_g_per_count).round();
        let clamped = counts.clamp(-8_388_608.0, 8_388_607.0) as i32;
        (clamped as u32) & 0x00FF_FFFF
    }

    /// INA226 bus-voltage register.
    pub(crate) fn bus_voltage_register(&mut self) -> u16 {
        let p = self.power_sensor;
        let v = self.electrical.bus_voltage_v * (1.0 + p.bus_gain_error)
            + p.bus_offset_v
            + p.bus_noise_v * self.rng.gaussian();
        (v / 1.25e-3).round().clamp(0.0, 32767.0) as u16
    }

    /// INA226 shunt-voltage register.
    pub(crate) fn shunt_voltage_register(&mut self) -> i16 {
        let p = self.power_sensor;
        let v = self.electrical.bus_current_a * p.shunt_ohm
            + p.shunt_offset_v
            + p.shunt_noise_v * self.rng.gaussian();
        (v / 2.5e-6).round().clamp(-32768.0, 32767.0) as i16
    }
}
