//! Missions and the flight plans of a scenario.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::world::Family;

/// Height of the test hall's ceiling above the take-off point, m.
pub const HALL_CEILING_M: f64 = 2.5;

/// A phase name as the flight-log format writes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoggedPhase {
    /// On the ground, motors off.
    Ground,
    /// Hovering.
    Hover,
    /// Climbing.
    Climb,
    /// Descending.
    Descend,
    /// Attached to the ceiling, motors off.
    Attached,
}

impl LoggedPhase {
    /// The name in the CSV's `phase` column.
    pub fn name(self) -> &'static str {
        match self {
            LoggedPhase::Ground => "ground",
            LoggedPhase::Hover => "hover",
            LoggedPhase::Climb => "climb",
            LoggedPhase::Descend => "descend",
            LoggedPhase::Attached => "attached",
        }
    }
}

/// A mission segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Leg {
    /// On the ground, motors off, s.
    Ground(f64),
    /// Climb to an altitude at a speed (m, m/s).
    Climb(f64, f64),
    /// Descend to an altitude at a speed (m, m/s).
    Descend(f64, f64),
    /// Hover for a time at the current altitude, s.
    Hover(f64),
    /// Attached to the ceiling, motors off, s.
    Attached(f64),
    /// Hover until the autopilot lands at its cut-off.
    HoverToCutoff,
}

/// One flight to simulate: mission and what the robot carries.
#[derive(Debug, Clone, PartialEq)]
pub struct FlightPlan {
    /// Name (file stem).
    pub name: String,
    /// Mission.
    pub legs: Vec<Leg>,
    /// Which of the world's two packs (0 or 1).
    pub pack: usize,
    /// Payload mass, kg.
    pub payload_mass_kg: f64,
    /// Payload power, W.
    pub payload_power_w: f64,
    /// Ambient temperature, °C.
    pub ambient_c: f64,
    /// Where in the site's density deficit this flight sits (0.5–1; used only when the air
    /// density effect is on).
    pub density_draw: f64,
    /// Charge cycles of the pack.
    pub cycles: u32,
}

fn mission(kind: usize) -> (&'static str, Vec<Leg>) {
    let c = HALL_CEILING_M;
    match kind {
        0 => (
            "hover",
            vec![Leg::Ground(5.0), Leg::Climb(1.0, 0.5), Leg::HoverToCutoff],
        ),
        1 => (
            "attach",
            vec![
                Leg::Ground(5.0),
                Leg::Climb(1.0, 0.5),
                Leg::Hover(60.0),
                Leg::Climb(c, 0.3),
                Leg::Attached(600.0),
                Leg::Descend(1.0, 0.3),
                Leg::Hover(60.0),
                Leg::Climb(c, 0.3),
                Leg::Attached(600.0),
                Leg::Descend(1.0, 0.3),
                Leg::HoverToCutoff,
            ],
        ),
        2 => (
            "ceiling",
            vec![
                Leg::Ground(5.0),
                Leg::Climb(c - 0.08, 0.5),
                Leg::Hover(150.0),
                Leg::Descend(1.0, 0.5),
                Leg::Hover(30.0),
                Leg::Climb(c - 0.08, 0.5),
                Leg::Hover(150.0),
                Leg::Descend(1.0, 0.5),
                Leg::HoverToCutoff,
            ],
        ),
        _ => ("climbs", {
            let mut v = vec![Leg::Ground(5.0), Leg::Climb(0.5, 0.5)];
            for _ in 0..6 {
                v.push(Leg::Climb(2.2, 1.0));
                v.push(Leg::Descend(0.5, 1.0));
            }
            v.push(Leg::HoverToCutoff);
            v
        }),
    }
}

/// The training and held-out flight plans of a scenario: missions (hover, ceiling attachment
/// cycles, hovering under the ceiling, climbs), both packs, payload mass and power, ambient
/// temperature; every flight to the cut-off.
pub fn plans(family: &Family, seed: u64) -> (Vec<FlightPlan>, Vec<FlightPlan>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x706c_616e);
    let packs = family.chemistry.packs();
    let mut make = |k: usize, kind: usize, pack: usize, payload_kg: f64, payload_w: f64| {
        let (name, legs) = mission(kind);
        FlightPlan {
            name: format!("{k}-{name}-{}", packs[pack].0),
            legs,
            pack,
            payload_mass_kg: payload_kg,
            payload_power_w: payload_w,
            ambient_c: 16.0 + 12.0 * rng.random::<f64>(),
            density_draw: 0.5 + 0.5 * rng.random::<f64>(),
            cycles: rng.random_range(3..80),
        }
    };
    let train = vec![
        make(1, 0, 0, 0.0, 0.0),
        make(2, 1, 0, 0.0, 5.0),
        make(3, 2, 1, 0.02, 0.0),
        make(4, 3, 1, 0.0, 5.0),
        make(5, 0, 1, 0.05, 5.0),
        make(6, 1, 1, 0.02, 0.0),
        make(7, 2, 0, 0.0, 5.0),
        make(8, 3, 0, 0.02, 0.0),
    ];
    let heldout = vec![
        make(9, 0, 0, 0.02, 5.0),
        make(10, 1, 1, 0.05, 0.0),
        make(11, 2, 0, 0.02, 5.0),
        make(12, 3, 1, 0.05, 0.0),
    ];
    (train, heldout)
}
