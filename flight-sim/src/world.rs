//! World families: battery chemistry × logging (rate and sensor quality) × robot variation,
//! and the effects a scenario can withhold from the model.

use serde::Serialize;

/// Cell chemistry of a world's packs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Chemistry {
    /// LiCoO2 / graphite pouch cells ("LiPo"), 4.20 V full.
    LiPo,
    /// High-voltage LiPo, a layered oxide charged to 4.35 V.
    LiHv,
    /// Li-ion NMC / graphite cylindrical cells.
    Nmc,
    /// Li-ion NCA / graphite cylindrical cells, charged to 4.10 V.
    Nca,
    /// LiFePO4 / graphite: a flat plateau near 3.3 V.
    LiFePo4,
}

impl Chemistry {
    /// Every chemistry.
    pub const ALL: [Chemistry; 5] = [
        Chemistry::LiPo,
        Chemistry::LiHv,
        Chemistry::Nmc,
        Chemistry::Nca,
        Chemistry::LiFePo4,
    ];

    /// Short name as in family names.
    pub fn name(self) -> &'static str {
        match self {
            Chemistry::LiPo => "lipo",
            Chemistry::LiHv => "lihv",
            Chemistry::Nmc => "nmc",
            Chemistry::Nca => "nca",
            Chemistry::LiFePo4 => "lfp",
        }
    }

    /// Open-circuit voltage of a cell when full and when empty, V.
    pub fn full_empty_cell_v(self) -> (f64, f64) {
        match self {
            Chemistry::LiPo => (4.20, 3.30),
            Chemistry::LiHv => (4.35, 3.30),
            Chemistry::Nmc => (4.20, 2.50),
            Chemistry::Nca => (4.10, 2.60),
            Chemistry::LiFePo4 => (3.60, 2.75),
        }
    }

    /// Cells in series for the paper's 12.5 V robot.
    pub fn cells(self) -> u8 {
        match self {
            Chemistry::LiFePo4 => 4,
            _ => 3,
        }
    }

    /// The autopilot's landing voltage per cell, V.
    pub fn cutoff_cell_v(self) -> f64 {
        match self {
            Chemistry::LiFePo4 => 2.6,
            Chemistry::Nmc | Chemistry::Nca => 2.9,
            _ => 3.0,
        }
    }

    /// The world's two packs: (id, mass kg, rated specific energy Wh/kg).
    pub fn packs(self) -> [(&'static str, f64, f64); 2] {
        match self {
            Chemistry::LiPo => [("A", 0.144, 164.0), ("B", 0.085, 172.0)],
            Chemistry::LiHv => [("A", 0.140, 182.0), ("B", 0.090, 178.0)],
            Chemistry::Nmc => [("A", 0.140, 205.0), ("B", 0.095, 195.0)],
            Chemistry::Nca => [("A", 0.140, 215.0), ("B", 0.095, 205.0)],
            Chemistry::LiFePo4 => [("A", 0.170, 110.0), ("B", 0.120, 105.0)],
        }
    }

    /// Cell impedance at 25 °C for a 1 Ah cell (scaled by 1/capacity): series resistance,
    /// fast and slow RC pairs (Ω, s), and the hysteresis half-width, V.
    pub(crate) fn impedance(self) -> CellImpedance {
        match self {
            Chemistry::LiPo => CellImpedance {
                r0_ohm_ah: 0.010,
                rc: [(0.006, 12.0), (0.004, 180.0)],
                hysteresis_v: 0.008,
            },
            Chemistry::LiHv => CellImpedance {
                r0_ohm_ah: 0.011,
                rc: [(0.007, 15.0), (0.004, 220.0)],
                hysteresis_v: 0.008,
            },
            Chemistry::Nmc => CellImpedance {
                r0_ohm_ah: 0.030,
                rc: [(0.015, 25.0), (0.010, 300.0)],
                hysteresis_v: 0.010,
            },
            Chemistry::Nca => CellImpedance {
                r0_ohm_ah: 0.026,
                rc: [(0.014, 20.0), (0.008, 250.0)],
                hysteresis_v: 0.010,
            },
            Chemistry::LiFePo4 => CellImpedance {
                r0_ohm_ah: 0.018,
                rc: [(0.010, 30.0), (0.0, 1.0)],
                hysteresis_v: 0.020,
            },
        }
    }
}

/// Per-cell impedance of a chemistry (for a 1 Ah cell).
#[derive(Debug, Clone, Copy)]
pub(crate) struct CellImpedance {
    pub(crate) r0_ohm_ah: f64,
    pub(crate) rc: [(f64, f64); 2],
    pub(crate) hysteresis_v: f64,
}

/// How flights are logged: rate, which sensors, and how good they are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Logging {
    /// A lab logger at 1 Hz: calibrated current and voltage, no dropped samples.
    Lab1Hz,
    /// A flight controller at 10 Hz: Hall current sensor with offset and scale errors, voltage
    /// divider scale error, dropped samples, clock jitter; the motor commands.
    Fc10Hz,
    /// A small flight controller at 5 Hz logging voltage only (no current sensor), with a
    /// voltage offset, dropped samples and jitter; its motor commands are logged, as a flight
    /// controller's are.
    VoltageOnly5Hz,
    /// A blackbox at 50 Hz: noisy current and voltage with offset and scale errors, bursts of
    /// dropped samples, jitter; the motor commands.
    Blackbox50Hz,
}

impl Logging {
    /// Every logging profile.
    pub const ALL: [Logging; 4] = [
        Logging::Lab1Hz,
        Logging::Fc10Hz,
        Logging::VoltageOnly5Hz,
        Logging::Blackbox50Hz,
    ];

    /// Short name as in family names.
    pub fn name(self) -> &'static str {
        match self {
            Logging::Lab1Hz => "lab-1hz",
            Logging::Fc10Hz => "fc-10hz",
            Logging::VoltageOnly5Hz => "vonly-5hz",
            Logging::Blackbox50Hz => "bb-50hz",
        }
    }

    pub(crate) fn sensors(self) -> SensorSpec {
        match self {
            Logging::Lab1Hz => SensorSpec {
                rate_hz: 1.0,
                current: true,
                v_noise: 0.004,
                i_noise: 0.03,
                v_scale_sd: 0.001,
                v_offset_sd: 0.0,
                i_scale_sd: 0.003,
                i_offset_sd: 0.01,
                drop_p: 0.0,
                burst_p: 0.0,
                jitter_frac: 0.0,
                alt_noise: 0.01,
                v_quantum: 0.001,
                motors: false,
            },
            Logging::Fc10Hz => SensorSpec {
                rate_hz: 10.0,
                current: true,
                v_noise: 0.015,
                i_noise: 0.25,
                v_scale_sd: 0.008,
                v_offset_sd: 0.0,
                i_scale_sd: 0.04,
                i_offset_sd: 0.25,
                drop_p: 0.01,
                burst_p: 0.0005,
                jitter_frac: 0.1,
                alt_noise: 0.05,
                v_quantum: 0.01,
                motors: true,
            },
            Logging::VoltageOnly5Hz => SensorSpec {
                rate_hz: 5.0,
                current: false,
                v_noise: 0.02,
                i_noise: 0.0,
                v_scale_sd: 0.01,
                v_offset_sd: 0.04,
                i_scale_sd: 0.0,
                i_offset_sd: 0.0,
                drop_p: 0.02,
                burst_p: 0.001,
                jitter_frac: 0.15,
                alt_noise: 0.03,
                v_quantum: 0.01,
                motors: true,
            },
            Logging::Blackbox50Hz => SensorSpec {
                rate_hz: 50.0,
                current: true,
                v_noise: 0.03,
                i_noise: 0.6,
                v_scale_sd: 0.01,
                v_offset_sd: 0.02,
                i_scale_sd: 0.05,
                i_offset_sd: 0.4,
                drop_p: 0.005,
                burst_p: 0.0001,
                jitter_frac: 0.2,
                alt_noise: 0.08,
                v_quantum: 0.01,
                motors: true,
            },
        }
    }
}

/// A logging profile's sensors (1 σ values).
#[derive(Debug, Clone, Copy)]
pub(crate) struct SensorSpec {
    pub(crate) rate_hz: f64,
    pub(crate) current: bool,
    pub(crate) v_noise: f64,
    pub(crate) i_noise: f64,
    pub(crate) v_scale_sd: f64,
    pub(crate) v_offset_sd: f64,
    pub(crate) i_scale_sd: f64,
    pub(crate) i_offset_sd: f64,
    /// Probability a sample is dropped.
    pub(crate) drop_p: f64,
    /// Probability a burst (up to 3 s) of samples is dropped.
    pub(crate) burst_p: f64,
    /// Clock jitter as a fraction of the interval (1 σ, clipped at ±0.3).
    pub(crate) jitter_frac: f64,
    pub(crate) alt_noise: f64,
    pub(crate) v_quantum: f64,
    /// Whether the log carries the motors' ESC commands (a flight controller's own log does;
    /// a lab logger on the battery leads does not).
    pub(crate) motors: bool,
}

/// Which robot flies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RobotVariant {
    /// The paper's platform, propulsion calibrated to its rig curve.
    Paper,
    /// A sibling build: masses, avionics power and propulsion efficiency scattered by seed.
    Varied,
}

impl RobotVariant {
    /// Both variants.
    pub const ALL: [RobotVariant; 2] = [RobotVariant::Paper, RobotVariant::Varied];

    /// Short name as in family names.
    pub fn name(self) -> &'static str {
        match self {
            RobotVariant::Paper => "paper",
            RobotVariant::Varied => "varied",
        }
    }
}

/// A world family: `chemistry/logging/robot`, e.g. `lipo/fc-10hz/paper`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub struct Family {
    /// Battery chemistry.
    pub chemistry: Chemistry,
    /// Logging profile.
    pub logging: Logging,
    /// Robot.
    pub robot: RobotVariant,
}

impl Family {
    /// Every family, chemistry-major.
    pub fn all() -> Vec<Family> {
        let mut v = Vec::new();
        for chemistry in Chemistry::ALL {
            for logging in Logging::ALL {
                for robot in RobotVariant::ALL {
                    v.push(Family {
                        chemistry,
                        logging,
                        robot,
                    });
                }
            }
        }
        v
    }

    /// `chemistry/logging/robot`.
    pub fn name(&self) -> String {
        format!(
            "{}/{}/{}",
            self.chemistry.name(),
            self.logging.name(),
            self.robot.name()
        )
    }

    /// Parses `chemistry/logging/robot`.
    pub fn parse(s: &str) -> Option<Family> {
        Family::all().into_iter().find(|f| f.name() == s.trim())
    }

    /// Whether the family matches a pattern of `/`-separated parts, each a name or `*`; missing
    /// trailing parts match anything (`lfp` matches every LiFePO4 family).
    pub fn matches(&self, pattern: &str) -> bool {
        let name = self.name();
        let mine: Vec<&str> = name.split('/').collect();
        let parts: Vec<&str> = pattern.trim().split('/').collect();
        parts.len() <= 3
            && parts
                .iter()
                .zip(&mine)
                .all(|(p, m)| *p == "*" || p.eq_ignore_ascii_case(m))
    }

    /// The families a comma-separated filter selects, in order, without repeats: family
    /// patterns (see [`Family::matches`]), `all`, and `tuning` / `heldout` (or `held-out`) by
    /// the study's own `is_tuning` (which families a study tunes on is the study's choice, not
    /// the worlds'). A part that selects nothing (or an empty filter) is an error naming it.
    pub fn select(
        filter: &str,
        is_tuning: impl Fn(&Family) -> bool,
    ) -> Result<Vec<Family>, NoFamily> {
        let all = Family::all();
        let mut out: Vec<Family> = Vec::new();
        for part in filter.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let hits: Vec<Family> = all
                .iter()
                .copied()
                .filter(|f| match part {
                    "all" => true,
                    "tuning" => is_tuning(f),
                    "heldout" | "held-out" => !is_tuning(f),
                    p => f.matches(p),
                })
                .collect();
            if hits.is_empty() {
                return Err(NoFamily(part.to_owned()));
            }
            for h in hits {
                if !out.contains(&h) {
                    out.push(h);
                }
            }
        }
        if out.is_empty() {
            return Err(NoFamily(filter.to_owned()));
        }
        Ok(out)
    }
}

/// A family filter part that selects no family ([`Family::select`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("no world family matches {0:?} (families are chemistry/logging/robot, e.g. lfp/*/paper)")]
pub struct NoFamily(pub String);

/// An effect a scenario can switch on and withhold from the model. The names of the first
/// eight are those of the diagnosis's library (so the study can score verdicts); each is
/// implemented here in its own physical form and unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectKind {
    /// Nothing beyond the simulator's own realism.
    None,
    /// A worn connector or lead: extra series resistance outside the cells, Ω.
    InternalResistance,
    /// An aged pack: fraction of its charge capacity lost.
    CapacityFade,
    /// Rate-dependent capacity: the exponent `k` of `Q(I) = Q₁C·(I₁C/I)^k`.
    Peukert,
    /// Airframe download: the rotor wash pushes on the frame, so the rotors carry more than the
    /// weight in flight than on the rig; fraction of the weight.
    ControlOverhead,
    /// A perching gripper holding current while attached, A (at the pack voltage).
    AttachedPower,
    /// The site's air is thinner than the rig's: fractional density deficit at its largest
    /// (flights draw their density between half and all of it; the metadata records it).
    AirDensity,
    /// Ceiling effect after Sanchez-Cuevas et al. (2017): thrust at equal rotor speed grows as
    /// `1/(1 − (1/K₁)·(R/(d + K₂))²)` with the rotor's distance `d` to the ceiling; the
    /// magnitude is `1/K₁`.
    CeilingEffect,
    /// Climbs cost power: momentum theory's climb power (`T·v_c/2` and the induced-velocity
    /// change) divided by a climb efficiency; the magnitude is the reciprocal of that
    /// efficiency.
    ClimbPower,
    /// Outside the library: the motor windings heat up in flight (steady rise in K, reached
    /// with a 150 s time constant), copper losses grow with their resistance.
    MotorHeating,
    /// Outside the library: a sprayer payload drains its liquid (kg at take-off, included in
    /// the logged payload mass) over the first five minutes airborne.
    DrainingPayload,
}

impl EffectKind {
    /// Every kind.
    pub const ALL: [EffectKind; 11] = [
        EffectKind::None,
        EffectKind::InternalResistance,
        EffectKind::CapacityFade,
        EffectKind::Peukert,
        EffectKind::ControlOverhead,
        EffectKind::AttachedPower,
        EffectKind::AirDensity,
        EffectKind::CeilingEffect,
        EffectKind::ClimbPower,
        EffectKind::MotorHeating,
        EffectKind::DrainingPayload,
    ];

    /// Name as in reports.
    pub fn name(self) -> &'static str {
        match self {
            EffectKind::None => "none",
            EffectKind::InternalResistance => "internal_resistance",
            EffectKind::CapacityFade => "capacity_fade",
            EffectKind::Peukert => "peukert",
            EffectKind::ControlOverhead => "control_overhead",
            EffectKind::AttachedPower => "attached_power",
            EffectKind::AirDensity => "air_density",
            EffectKind::CeilingEffect => "ceiling_effect",
            EffectKind::ClimbPower => "climb_power",
            EffectKind::MotorHeating => "motor_heating",
            EffectKind::DrainingPayload => "draining_payload",
        }
    }

    /// Parses a name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|e| e.name() == s.trim())
    }

    /// Whether a diagnosis library effect carries this name (`none` and the outside effects
    /// do not).
    pub fn named_in_library(self) -> bool {
        !matches!(
            self,
            EffectKind::None | EffectKind::MotorHeating | EffectKind::DrainingPayload
        )
    }

    /// The magnitude's unit.
    pub fn unit(self) -> &'static str {
        match self {
            EffectKind::None => "-",
            EffectKind::InternalResistance => "ohm",
            EffectKind::CapacityFade => "fraction of capacity",
            EffectKind::Peukert => "exponent",
            EffectKind::ControlOverhead => "fraction of weight",
            EffectKind::AttachedPower => "A",
            EffectKind::AirDensity => "fraction of density",
            EffectKind::CeilingEffect => "1/K1",
            EffectKind::ClimbPower => "1/efficiency",
            EffectKind::MotorHeating => "K",
            EffectKind::DrainingPayload => "kg",
        }
    }

    /// Range magnitudes are drawn from (log-uniformly), spanning endurance impacts from well
    /// under 1 % to over 10 %.
    pub fn range(self) -> (f64, f64) {
        match self {
            EffectKind::None => (0.0, 0.0),
            EffectKind::InternalResistance => (0.005, 0.12),
            EffectKind::CapacityFade => (0.005, 0.2),
            EffectKind::Peukert => (0.005, 0.08),
            EffectKind::ControlOverhead => (0.004, 0.12),
            EffectKind::AttachedPower => (0.03, 0.8),
            EffectKind::AirDensity => (0.03, 0.3),
            EffectKind::CeilingEffect => (0.03, 0.4),
            EffectKind::ClimbPower => (1.0, 12.0),
            EffectKind::MotorHeating => (15.0, 120.0),
            EffectKind::DrainingPayload => (0.02, 0.08),
        }
    }

    /// A typical magnitude (the geometric middle of the range).
    pub fn typical(self) -> f64 {
        let (lo, hi) = self.range();
        (lo * hi).sqrt()
    }
}

/// An effect with its magnitude.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Withheld {
    /// The effect.
    pub kind: EffectKind,
    /// Its magnitude in [`EffectKind::unit`].
    pub magnitude: f64,
}

impl Withheld {
    /// Nothing withheld.
    pub const NONE: Withheld = Withheld {
        kind: EffectKind::None,
        magnitude: 0.0,
    };

    /// The magnitude if this is `kind`, else 0.
    pub(crate) fn of(&self, kind: EffectKind) -> f64 {
        if self.kind == kind {
            self.magnitude
        } else {
            0.0
        }
    }
}
