//! What a binary log says about itself: firmware, vehicle type, the battery read, and
//! metadata taken from its own parameters (each value with the parameter it came from).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::FlightMeta;
use crate::battery::BatteryInfo;

/// The kind of vehicle a log was recorded on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VehicleKind {
    /// Multirotor (quad, hexa, octa, tri, coaxial, …).
    Multirotor,
    /// Single-rotor or dual-rotor helicopter.
    Helicopter,
    /// Vertical take-off and landing aircraft with a forward-flight mode (quadplane,
    /// tailsitter, tiltrotor): the only kind with `transition` phases.
    Vtol,
    /// Fixed-wing aircraft.
    FixedWing,
    /// Ground or water vehicle.
    Rover,
    /// Anything else the log names.
    Other,
}

impl VehicleKind {
    /// Lowercase name (`multirotor`, `vtol`, …).
    pub fn name(self) -> &'static str {
        match self {
            Self::Multirotor => "multirotor",
            Self::Helicopter => "helicopter",
            Self::Vtol => "vtol",
            Self::FixedWing => "fixed_wing",
            Self::Rover => "rover",
            Self::Other => "other",
        }
    }

    /// In words, for messages (`a fixed-wing aircraft`).
    pub fn words(self) -> &'static str {
        match self {
            Self::Multirotor => "a multirotor",
            Self::Helicopter => "a helicopter",
            Self::Vtol => "a VTOL",
            Self::FixedWing => "a fixed-wing aircraft",
            Self::Rover => "a ground or water vehicle",
            Self::Other => "a vehicle of another kind",
        }
    }

    /// Whether this kind of vehicle hovers on its rotors: `Some(false)` for a fixed-wing
    /// aircraft and a ground or water vehicle (whose logs the paper's model does not describe),
    /// `None` when the log does not say what it is.
    pub fn hovers(self) -> Option<bool> {
        match self {
            Self::Multirotor | Self::Helicopter | Self::Vtol => Some(true),
            Self::FixedWing | Self::Rover => Some(false),
            Self::Other => None,
        }
    }

    /// The kind of a MAVLink `MAV_TYPE` (PX4's `MAV_TYPE` parameter,
    /// `vehicle_status.system_type`).
    pub fn from_mav_type(mav_type: u32) -> Self {
        match mav_type {
            1 | 16 => Self::FixedWing,
            2 | 3 | 13 | 14 | 15 | 29 | 35 => Self::Multirotor,
            4 => Self::Helicopter,
            19..=25 => Self::Vtol,
            10..=12 => Self::Rover,
            _ => Self::Other,
        }
    }
}

impl std::fmt::Display for VehicleKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The vehicle a log was recorded on, and how that is known.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Vehicle {
    /// Its kind.
    pub kind: VehicleKind,
    /// In words (`quadrotor (MAV_TYPE 2)`, `ArduCopter, quad (FRAME_CLASS 1)`).
    pub description: String,
}

/// What a log says about itself (empty for CSV logs).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct LogInfo {
    /// Firmware and version as the log gives them (`ArduCopter V4.6.2 (1ebd4d99)`,
    /// `PX4 v1.11.2_w_rc_sysid`).
    pub firmware: Option<String>,
    /// Hardware (`PX4_FMU_V6C`, `Pixhawk4 …`).
    pub hardware: Option<String>,
    /// The vehicle, when the log says.
    pub vehicle: Option<Vehicle>,
    /// The battery read, and the others skipped.
    pub battery: Option<BatteryInfo>,
    /// Where the motor commands ([`crate::Samples::motor_us`]) were read, when they were
    /// (`actuator_outputs instance 0, output[0]–output[3] (CA_ROTOR_COUNT 4)`).
    pub motors: Option<String>,
    /// Metadata taken from the log's own parameters and messages.
    pub meta: FlightMeta,
    /// For each key set in [`LogInfo::meta`], where in the log it came from (`BAT1_N_CELLS`,
    /// `battery_status.cell_count`, `BATT_CAPACITY × cells × 3.7 V`).
    pub meta_origins: BTreeMap<String, String>,
}

/// Nominal voltage of a lithium-polymer cell, V, to turn a capacity in mAh into energy.
pub const NOMINAL_CELL_V: f64 = 3.7;

impl LogInfo {
    /// Sets a metadata key from the log, with where it came from.
    pub(crate) fn set(
        &mut self,
        key: &str,
        origin: impl Into<String>,
        apply: impl FnOnce(&mut FlightMeta),
    ) {
        apply(&mut self.meta);
        self.meta_origins.insert(key.to_owned(), origin.into());
    }

    /// Fills battery energy from capacity and cells (when both are known and energy is not).
    pub(crate) fn derive_energy(&mut self) {
        if let (Some(mah), Some(cells), None) = (
            self.meta.capacity_mah,
            self.meta.cells,
            self.meta.battery_energy_wh,
        ) {
            let wh = mah / 1000.0 * f64::from(cells) * NOMINAL_CELL_V;
            let origin = format!(
                "{} × {} cells × {NOMINAL_CELL_V} V nominal",
                self.meta_origins
                    .get("capacity_mah")
                    .cloned()
                    .unwrap_or_default(),
                cells
            );
            self.set("battery_energy_wh", origin, |m| {
                m.battery_energy_wh = Some(wh);
            });
        }
    }
}
