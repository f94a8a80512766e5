//! A flight as the diagnosis sees it: time series, phases, and what the robot carried.

use serde::Serialize;

pub use flightlog::Phase;

/// Whether the rotors carry the robot in a phase (everything but ground and attached;
/// transitions such as take-off and detaching count as flying).
pub fn rotors_on(phase: Phase) -> bool {
    !matches!(phase, Phase::Ground | Phase::Attached)
}

/// What a flight carried and how it ended (the metadata of a flight log).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlightInfo {
    /// `m_S`, kg.
    pub structure_mass_kg: f64,
    /// `m_B`, kg.
    pub battery_mass_kg: f64,
    /// `c_B`, Wh.
    pub battery_energy_wh: f64,
    /// Cells in series.
    pub cells: u8,
    /// `m_P`, kg.
    pub payload_mass_kg: f64,
    /// `p_P`, W.
    pub payload_power_w: f64,
    /// `p_A`, W.
    pub avionics_power_w: f64,
    /// Which pack flew.
    pub battery_id: Option<String>,
    /// Charge cycles the pack had seen.
    pub battery_cycles: Option<u32>,
    /// Ambient temperature, °C.
    pub ambient_temperature_c: Option<f64>,
    /// Air density, kg/m³.
    pub air_density_kg_m3: Option<f64>,
    /// Landing (cut-off) voltage of the pack, V.
    pub cutoff_voltage_v: f64,
    /// The flight ran until the cut-off, so its duration is a measured endurance.
    pub ended_at_cutoff: bool,
    /// Height of the ceiling above the take-off point, m, when known.
    pub ceiling_height_m: Option<f64>,
    /// The pack's measured open-circuit curve (metadata `battery_ocv_csv`), when given: it
    /// overrides the chemistry prior for the flight's battery type.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured_ocv: Option<crate::battery::LearnedBattery>,
}

impl FlightInfo {
    /// `m_T`, kg (eq. 1).
    pub fn total_mass_kg(&self) -> f64 {
        self.structure_mass_kg + self.battery_mass_kg + self.payload_mass_kg
    }

    /// `p_I`, W (eq. 2).
    pub fn idle_power_w(&self) -> f64 {
        self.avionics_power_w + self.payload_power_w
    }
}

/// A logged flight: samples on a common time base.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlightRecord {
    /// Name (file stem).
    pub name: String,
    /// Time since the start of the log, s.
    pub time_s: Vec<f64>,
    /// Battery voltage, V.
    pub voltage_v: Vec<f64>,
    /// Battery current, A, when logged.
    pub current_a: Option<Vec<f64>>,
    /// Phase of every sample (logged or inferred).
    pub phase: Vec<Phase>,
    /// Altitude above take-off, m, when logged.
    pub altitude_m: Option<Vec<f64>>,
    /// What the robot carried.
    pub info: FlightInfo,
}

impl FlightRecord {
    /// The voltages logged before the rotors first start (the pack at rest), V; empty when the
    /// log starts in the air.
    pub fn resting_voltages_v(&self) -> &[f64] {
        let n = self.phase.iter().take_while(|p| !rotors_on(**p)).count();
        &self.voltage_v[..n.min(self.voltage_v.len())]
    }

    /// Duration of the log, s.
    pub fn duration_s(&self) -> f64 {
        match (self.time_s.first(), self.time_s.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }

    /// Time the rotors carried the robot, s: the sum of the sample intervals that start in a
    /// flying phase ([`rotors_on`]).
    pub fn flying_s(&self) -> f64 {
        self.time_s
            .windows(2)
            .zip(&self.phase)
            .filter(|(_, p)| rotors_on(**p))
            .map(|(w, _)| (w[1] - w[0]).max(0.0))
            // from +0.0: an empty `sum()` of f64 is -0.0, printed "-0.0 s"
            .fold(0.0, |a, b| a + b)
    }

    /// Vertical speed at every sample from the altitude log (central differences over a
    /// window of about `window_s`), m/s.
    pub fn vertical_speed_m_s(&self, window_s: f64) -> Option<Vec<f64>> {
        let z = self.altitude_m.as_ref()?;
        let t = &self.time_s;
        let n = t.len();
        let mut out = vec![0.0; n];
        let mut lo = 0;
        let mut hi = 0;
        for i in 0..n {
            while lo < i && t[i] - t[lo] > window_s / 2.0 {
                lo += 1;
            }
            while hi + 1 < n && t[hi + 1] - t[i] <= window_s / 2.0 {
                hi += 1;
            }
            if hi > lo && t[hi] > t[lo] {
                out[i] = (z[hi] - z[lo]) / (t[hi] - t[lo]);
            }
        }
        Some(out)
    }
}
