//! The simulated rig: the real firmware core and drivers on simulated peripherals, stepped on
//! the simulated clock, and [`SimLink`], an in-process byte transport to it.

use crate::peripherals::{
    INA226_ADDRESS, NoDelay, PWM_PERIOD_US, Shared, SimClock, SimDout, SimI2c, SimPwm, SimSck,
    SimWatchdog,
};
use crate::physics::Propulsion;
use crate::presets::Preset;
use crate::world::{Truth, World};
use rig_firmware::Firmware;
use rig_firmware::drivers::esc::{Esc, EscError};
use rig_firmware::drivers::hx711::{FixedRate, Gain, Hx711, Hx711Error, Rate};
use rig_firmware::drivers::ina226::{DEFAULT_CONFIG, Ina226, Ina226Error};
use rig_protocol::client::{Client, ClientConfig, Transport};
use rig_protocol::frame::Decoder;
use rig_protocol::{Clock, Message, Sample};
use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::convert::Infallible;
use std::rc::Rc;
use thiserror::Error;

/// Firmware tick and physics step of the simulation, µs.
pub const STEP_US: u64 = 1000;

/// The firmware type the simulator runs.
pub type SimFirmware = Firmware<
    Hx711<SimSck, SimDout, FixedRate, NoDelay>,
    Ina226<SimI2c>,
    Esc<SimPwm>,
    SimClock,
    SimWatchdog,
>;

/// Bringing up the simulated board failed (a driver rejected its configuration).
#[derive(Debug, Error)]
pub enum SimError {
    /// HX711 initialisation.
    #[error("HX711 init")]
    Hx711(#[from] Hx711Error),
    /// INA226 initialisation.
    #[error("INA226 init")]
    Ina226(#[from] Ina226Error),
    /// ESC initialisation.
    #[error("ESC init")]
    Esc(#[from] EscError),
}

/// A simulated rig; see the [module docs](self).
pub struct SimRig {
    fw: SimFirmware,
    world: Shared,
    clock: SimClock,
    watchdog: SimWatchdog,
    out: VecDeque<u8>,
    record: Option<(Decoder, Vec<Sample>)>,
}

impl SimRig {
    /// A rig built from `preset`, with sensor noise drawn from `seed`.
    pub fn new(preset: &Preset, seed: u64) -> Result<Self, SimError> {
        let time = Rc::new(Cell::new(0u64));
        let clock = SimClock(time.clone());
        let world = Rc::new(RefCell::new(World::new(
            Propulsion::new(preset.motor, preset.prop, preset.esc),
            preset.supply,
            preset.load_cell,
            preset.power_sensor,
            seed,
            time,
        )));
        let mut adc = Hx711::new(
            SimSck(world.clone()),
            SimDout(world.clone()),
            FixedRate,
            NoDelay,
        );
        let rate = if preset.load_cell.rate_sps >= 80 {
            Rate::Sps80
        } else {
            Rate::Sps10
        };
        adc.init(Gain::A128, rate)?;
        let mut ina = Ina226::new(
            SimI2c(world.clone()),
            INA226_ADDRESS,
            preset.power_sensor.shunt_ohm as f32,
            preset.ina226_max_current_a,
        )?;
        ina.init(DEFAULT_CONFIG)?;
        let esc = Esc::new(SimPwm(world.clone()), PWM_PERIOD_US, 1000, 2000)?;
        let watchdog = SimWatchdog {
            clock: clock.clone(),
            ..Default::default()
        };
        let fw = Firmware::new(
            adc,
            ina,
            esc,
            clock.clone(),
            watchdog.clone(),
            preset.firmware,
        );
        Ok(Self {
            fw,
            world,
            clock,
            watchdog,
            out: VecDeque::new(),
            record: None,
        })
    }

    /// The simulated clock (shared; a host in the same process can wait on it).
    pub fn clock(&self) -> SimClock {
        self.clock.clone()
    }

    /// Simulated time, µs.
    pub fn now_us(&self) -> u64 {
        self.clock.now_us()
    }

    /// Bytes from the host.
    pub fn receive(&mut self, bytes: &[u8]) {
        let out = &mut self.out;
        self.fw.receive(bytes, &mut |b: &[u8]| out.extend(b));
    }

    /// Advances the simulation by `dt_us` (in steps of [`STEP_US`]).
    pub fn advance(&mut self, dt_us: u64) {
        let end = self.now_us() + dt_us;
        while self.now_us() < end {
            let step = STEP_US.min(end - self.now_us());
            self.world.borrow_mut().step(step);
            let out = &mut self.out;
            let record = &mut self.record;
            self.fw.tick(&mut |b: &[u8]| {
                out.extend(b);
                if let Some((dec, log)) = record.as_mut() {
                    for &x in b {
                        if let Some(Ok(f)) = dec.push(x) {
                            if let Message::Sample(s) = f.message {
                                log.push(s);
                            }
                        }
                    }
                }
            });
        }
    }

    /// Takes up to `buf.len()` bytes the rig sent to the host.
    pub fn read_output(&mut self, buf: &mut [u8]) -> usize {
        let n = buf.len().min(self.out.len());
        for (dst, src) in buf.iter_mut().zip(self.out.drain(..n)) {
            *dst = src;
        }
        n
    }

    /// Bytes waiting for the host.
    pub fn pending_output(&self) -> usize {
        self.out.len()
    }

    /// Starts recording every sample the rig sends (see [`SimRig::sent_samples`]).
    pub fn record_samples(&mut self) {
        self.record = Some((Decoder::new(), Vec::new()));
    }

    /// Samples sent so far, if recording.
    pub fn sent_samples(&self) -> &[Sample] {
        self.record
            .as_ref()
            .map(|(_, v)| v.as_slice())
            .unwrap_or(&[])
    }

    /// Sets the supply voltage, V.
    pub fn set_supply_voltage(&mut self, voltage_v: f64) {
        self.world.borrow_mut().supply.voltage_v = voltage_v;
    }

    /// Sets the source resistance of the supply, Ω.
    pub fn set_supply_resistance(&mut self, ohm: f64) {
        self.world.borrow_mut().supply.resistance_ohm = ohm;
    }

    /// Connects an external supply (such as a simulated bench supply with a current limit)
    /// that sets the bus voltage each step; see [`crate::world::ExternalBus`].
    pub fn set_external_bus(&mut self, bus: Box<dyn crate::world::ExternalBus>) {
        self.world.borrow_mut().set_external_bus(Some(bus));
    }

    /// Puts a known mass on the load cell (0 to remove it), g.
    pub fn place_mass_g(&mut self, mass_g: f64) {
        self.world.borrow_mut().placed_mass_g = mass_g;
    }

    /// Ground truth now.
    pub fn truth(&self) -> Truth {
        self.world.borrow().truth()
    }

    /// The bench (physics and sensor models).
    pub fn world(&self) -> std::cell::Ref<'_, World> {
        self.world.borrow()
    }

    /// The firmware.
    pub fn firmware(&self) -> &SimFirmware {
        &self.fw
    }

    /// Watchdog feeds so far and the time of the last, µs.
    pub fn watchdog(&self) -> (u64, u64) {
        (self.watchdog.feeds.get(), self.watchdog.last_feed_us.get())
    }

    /// An in-process host connection: a [`Client`] over a [`SimLink`], waiting on the
    /// simulated clock. Call [`Client::handshake`] first.
    pub fn into_client(self, config: ClientConfig) -> Client<SimLink, SimClock> {
        let clock = self.clock();
        Client::new(SimLink { rig: self }, clock, config)
    }
}

/// In-process transport to a [`SimRig`]. Reading when nothing is pending advances the
/// simulation by one step, so a host waiting for an answer makes simulated time pass.
pub struct SimLink {
    rig: SimRig,
}

impl SimLink {
    /// A link to `rig`.
    pub fn new(rig: SimRig) -> Self {
        Self { rig }
    }

    /// The rig.
    pub fn rig(&self) -> &SimRig {
        &self.rig
    }

    /// The rig, mutably (advance time, change the supply, place masses).
    pub fn rig_mut(&mut self) -> &mut SimRig {
        &mut self.rig
    }
}

impl Transport for SimLink {
    type Error = Infallible;

    fn write_all(&mut self, bytes: &[u8]) -> Result<(), Infallible> {
        self.rig.receive(bytes);
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        if self.rig.pending_output() == 0 {
            self.rig.advance(STEP_US);
        }
        Ok(self.rig.read_output(buf))
    }
}
