//! A simulated bench: the simulated rig and the simulated bench supply, each behind its own
//! real pseudo-terminal, coupled electrically — the supply's output voltage is the rig's bus
//! voltage and the rig's bus current is the supply's load, so the set-point, the output
//! switch, the source resistance and constant-current limiting act on the rig's physics.
//!
//! The rig runs at `speed` × real time (the supply answers in real time, like an
//! instrument); a host talks to both through [`SimBench::rig_path`] and
//! [`SimBench::supply_path`] exactly as it would to hardware.
//!
//! The host runs in real time, so the rig's host timeout is kept in real time too: the
//! preset's `firmware.host_timeout_us` is multiplied by `speed` (at 10× the paper's 250 ms
//! becomes 2.5 s of rig time, 250 ms of the host's). Unscaled, a host at 10× would have to
//! answer within 25 ms, which a loaded machine does not guarantee; on hardware it has 250 ms.

use std::io;

use sim::Preset;
use sim::physics::BusLoad;
use sim::pty::{BenchCommand, PtyRig, PtyRigOptions, PtyRigSnapshot};
use supply::sim::{Device, Dialect as SimDialect, SimConfig, SimulatedSupply};

use crate::bench_supply::Dialect;
use crate::error::HostError;
use crate::sweep::MassPlacer;

/// How a [`SimBench`] runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimBenchOptions {
    /// Rig time per real time.
    pub speed: f64,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// The supply's command set.
    pub dialect: Dialect,
    /// Record every sample the rig sends (for link tests).
    pub record_samples: bool,
}

impl Default for SimBenchOptions {
    fn default() -> Self {
        Self {
            speed: 10.0,
            seed: 1,
            dialect: Dialect::Scpi,
            record_samples: false,
        }
    }
}

/// The simulated rig and supply, coupled; see the [module docs](self).
#[derive(Debug)]
pub struct SimBench {
    // Field order: the rig (which calls into the supply device) stops first.
    rig: PtyRig,
    supply: SimulatedSupply,
    preset_name: &'static str,
    options: SimBenchOptions,
}

/// The rig's bus, fed by the simulated supply `device`.
pub fn supply_bus(device: Device) -> Box<dyn sim::world::ExternalBus> {
    Box::new(move |load: BusLoad| {
        device.set_load(move |v: f64| load.current_a(v).max(0.0));
        device.output().voltage_v
    })
}

/// A host timeout of `host_timeout_us` of real time, in the time of a rig running at `speed`
/// × real time.
pub fn host_timeout_in_rig_time_us(host_timeout_us: u64, speed: f64) -> u64 {
    (host_timeout_us as f64 * speed).round() as u64
}

impl SimBench {
    /// Starts both on their pseudo-terminals.
    /// The rig's host timeout is scaled to real time (module docs).
    pub fn spawn(mut preset: Preset, options: SimBenchOptions) -> io::Result<Self> {
        preset.firmware.host_timeout_us =
            host_timeout_in_rig_time_us(preset.firmware.host_timeout_us, options.speed);
        let config = SimConfig {
            rating_current_a: 30.0,
            initial: supply::sim::Settings {
                voltage_v: 0.0,
                current_limit_a: 1.0,
                output_on: false,
                source_resistance_ohm: preset.supply.resistance_ohm,
            },
            ..SimConfig::default()
        };
        let dialect = match options.dialect {
            Dialect::Scpi => SimDialect::Scpi,
            Dialect::Korad => SimDialect::Korad,
        };
        let device = Device::new(dialect, |_v: f64| 0.0, config);
        let supply = SimulatedSupply::serve(device.clone())?;
        let preset_name = preset.name;
        let rig = PtyRig::spawn_with_bus(
            preset,
            PtyRigOptions {
                speed: options.speed,
                seed: options.seed,
                record_samples: options.record_samples,
            },
            supply_bus(device),
        )?;
        Ok(Self {
            rig,
            supply,
            preset_name,
            options,
        })
    }

    /// The rig's pseudo-terminal.
    pub fn rig_path(&self) -> String {
        self.rig.path().display().to_string()
    }

    /// The supply's pseudo-terminal.
    pub fn supply_path(&self) -> &str {
        self.supply.port_path()
    }

    /// The preset's name.
    pub fn preset_name(&self) -> &'static str {
        self.preset_name
    }

    /// How it runs.
    pub fn options(&self) -> SimBenchOptions {
        self.options
    }

    /// The rig's state (ground truth, firmware state, samples sent if recording).
    pub fn rig_snapshot(&self) -> PtyRigSnapshot {
        self.rig.snapshot()
    }

    /// The rig.
    pub fn rig(&self) -> &PtyRig {
        &self.rig
    }

    /// The simulated supply (settings, faults, counters).
    pub fn supply_device(&self) -> &Device {
        self.supply.device()
    }

    /// Places calibration masses on the simulated load cell.
    pub fn mass_placer(&self) -> SimMassPlacer<'_> {
        SimMassPlacer { rig: &self.rig }
    }
}

/// Puts masses on a simulated load cell ([`SimBench::mass_placer`]).
#[derive(Debug)]
pub struct SimMassPlacer<'a> {
    rig: &'a PtyRig,
}

impl MassPlacer for SimMassPlacer<'_> {
    fn place(&mut self, mass_g: f64) -> Result<(), HostError> {
        self.rig.command(BenchCommand::PlaceMass(mass_g));
        Ok(())
    }
}
