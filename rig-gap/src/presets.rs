//! Physical presets: coefficients a stand's motor, propeller and ESC are known to have before any
//! sweep is fitted, so `rig-gap --preset NAME` holds them fixed and judges the data against
//! physics instead of absorbing the gap into free base parameters (which also makes effects
//! such as `stand_blockage`, a share of thrust lost to the stand, identifiable).
//!
//! Each value is derived in its doc comment from what the source states: the paper
//! (`../shared/paper/`), its reconstruction (`../shared/reference/paper-targets.md`), the motor's
//! name, momentum theory, and the range of static propeller coefficients measured for
//! 8–10-inch propellers at low Reynolds number (Brandt & Selig, "Propeller performance data at
//! low Reynolds numbers", AIAA 2011-1255, UIUC Propeller Data Site: static `C_T ≈ 0.08–0.13`,
//! `C_P ≈ 0.03–0.06`).
//!
//! Conversions (ρ = 1.225 kg/m³ at sea level, n in rev/s, D in m): the model's
//! `C_T [g/(krpm)²] = C_T·ρ·(1000/60)²·D⁴/g·1000` and `C_Q [N·m/(krpm)²] = C_P/(2π)·ρ·(1000/60)²·D⁵`.

use motor_model::Param;
use serde::Serialize;

/// Sea-level air density, kg/m³ (ISA).
pub const AIR_DENSITY_KG_M3: f64 = 1.225;

/// Standard gravity, m/s².
const G: f64 = 9.806_65;

/// Thrust coefficient in the model's units, g per (1000 rpm)², from a static `C_T` and a
/// diameter, m.
pub fn thrust_coeff_g_per_krpm2(ct: f64, diameter_m: f64) -> f64 {
    ct * AIR_DENSITY_KG_M3 * (1000.0f64 / 60.0).powi(2) * diameter_m.powi(4) / G * 1000.0
}

/// Torque coefficient in the model's units, N·m per (1000 rpm)², from a static `C_P` and a
/// diameter, m.
pub fn torque_coeff_nm_per_krpm2(cp: f64, diameter_m: f64) -> f64 {
    cp / (2.0 * std::f64::consts::PI)
        * AIR_DENSITY_KG_M3
        * (1000.0f64 / 60.0).powi(2)
        * diameter_m.powi(5)
}

/// A preset: the base parameters it fixes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Preset {
    /// Name on the command line.
    pub name: &'static str,
    /// What it describes.
    pub description: &'static str,
    /// The fixed parameters and their values.
    pub fixed: Vec<(Param, f64)>,
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

/// Static thrust coefficient of the paper's 200 mm plastic propeller: the middle of the
/// measured 0.08–0.13 range (Brandt & Selig 2011); the paper names no propeller model.
pub const PAPER_CT: f64 = 0.10;
/// Static power coefficient of the same propeller: with [`PAPER_CT`] it gives a figure of merit
/// `C_T^1.5/(√2·C_P)` of 0.50, typical of small fixed-pitch propellers (0.4–0.6), inside the
/// measured 0.03–0.06.
pub const PAPER_CP: f64 = 0.045;
/// The paper's propeller diameter, m ("200 mm contra-rotating plastic propellers").
pub const PAPER_DIAMETER_M: f64 = 0.200;

/// The paper's rotor (paper §II–III; paper-targets.md): 200 mm plastic propeller, a 3S
/// out-runner and a Mikrokopter ESC on a 12.5 V rig.
///
/// * Propeller: [`PAPER_CT`], [`PAPER_CP`] at [`PAPER_DIAMETER_M`].
/// * Motor speed constant and winding resistance: from the paper's two thrust limits at full
///   duty (`V = K_e·ω + I·R`): about 260 g at the maximum battery voltage 12.6 V and 150 g at
///   the minimum 9.0 V (the limit paper-targets.md derives from the published optimum), with
///   the speeds from the propeller above (6.84 and 5.20 krpm) and the currents from the
///   published Fig. 3 power at those thrusts (97.5 W / 12.6 V = 7.74 A and 26.6 W / 9.0 V =
///   2.96 A): `K_e = 0.01547 V·s/rad` (617 rpm/V), `R = 0.195 Ω`.
/// * No-load current 0.4 A: the paper names no motor; 0.3–0.5 A is what makers list for
///   600–1000 rpm/V out-runners of this size (22–28 mm stators) at 10 V.
/// * ESC efficiency 0.95: a MOSFET ESC at these currents (0.92–0.97).
pub fn paper() -> Preset {
    let speed = |t_g: f64| {
        1000.0
            * (t_g / thrust_coeff_g_per_krpm2(PAPER_CT, PAPER_DIAMETER_M)).sqrt()
            * std::f64::consts::PI
            / 30.0
    };
    // Fig. 3 as reconstructed (paper-targets.md), W.
    let fig3 = |t_g: f64| 0.157_434_234 * t_g + 0.341_190_317 * (t_g / 100.0).powf(5.348_657_28);
    let (w1, i1, v1) = (speed(260.0), fig3(260.0) / 12.6, 12.6);
    let (w2, i2, v2) = (speed(150.0), fig3(150.0) / 9.0, 9.0);
    let det = w1 * i2 - i1 * w2;
    let ke = (v1 * i2 - i1 * v2) / det;
    let r = (w1 * v2 - w2 * v1) / det;
    Preset {
        name: "paper",
        description: "the paper's rotor: 200 mm plastic propeller (C_T 0.10, C_P 0.045), 3S \
                      out-runner with K_v and R from the two published thrust limits, I₀ 0.4 A, \
                      ESC 95 %",
        fixed: vec![
            (Param::KvRpmPerV, 60.0 / (2.0 * std::f64::consts::PI * ke)),
            (Param::ResistanceOhm, r),
            (Param::NoLoadCurrentA, 0.4),
            (Param::EscEfficiency, 0.95),
            (
                Param::ThrustCoeffGPerKrpm2,
                thrust_coeff_g_per_krpm2(PAPER_CT, PAPER_DIAMETER_M),
            ),
            (
                Param::TorqueCoeffNmPerKrpm2,
                torque_coeff_nm_per_krpm2(PAPER_CP, PAPER_DIAMETER_M),
            ),
        ],
    }
}

/// Readytosky 2312 920KV with a DJI 9450 propeller (9.4 × 5.0 in, 0.239 m) on 4S, the CTU-MRS
/// motor tests. Fixed: the speed constant the motor is sold with (920 rpm/V) and the
/// propeller's static coefficients from the same measured range as [`paper`] (`C_T` 0.11,
/// `C_P` 0.045 for a 9–10-inch, pitch-to-diameter 0.53 propeller). The winding resistance,
/// no-load current and ESC efficiency have no source (the maker lists none) and stay free.
pub fn ctu_2312_9450() -> Preset {
    let d = 9.4 * 0.0254;
    Preset {
        name: "ctu-2312-9450",
        description: "Readytosky 2312 920KV (K_v as sold) + DJI 9450 (C_T 0.11, C_P 0.045); R, \
                      I₀ and the ESC free",
        fixed: vec![
            (Param::KvRpmPerV, 920.0),
            (
                Param::ThrustCoeffGPerKrpm2,
                thrust_coeff_g_per_krpm2(0.11, d),
            ),
            (
                Param::TorqueCoeffNmPerKrpm2,
                torque_coeff_nm_per_krpm2(0.045, d),
            ),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_paper_rotor_reaches_its_published_thrust_limits() {
        let p = paper();
        let get = |q: Param| {
            p.fixed
                .iter()
                .find(|x| x.0 == q)
                .map(|x| x.1)
                .expect("fixed")
        };
        let (kv, r, ct) = (
            get(Param::KvRpmPerV),
            get(Param::ResistanceOhm),
            get(Param::ThrustCoeffGPerKrpm2),
        );
        // 260 g needs 6.84 krpm; at full duty on 12.6 V with 7.74 A the motor turns exactly so.
        let krpm = (260.0 / ct).sqrt();
        assert!((krpm - 6.84).abs() < 0.01, "{krpm}");
        let ke = 60.0 / (2.0 * std::f64::consts::PI * kv);
        let v = ke * krpm * 1000.0 * std::f64::consts::PI / 30.0 + 97.498 / 12.6 * r;
        assert!((v - 12.6).abs() < 1e-3, "{v}");
        assert!((600.0..640.0).contains(&kv), "{kv}");
        assert!((0.15..0.25).contains(&r), "{r}");
        // The propeller's figure of merit is physical (0.4–0.6).
        let fm = PAPER_CT.powf(1.5) / (2.0f64.sqrt() * PAPER_CP);
        assert!((0.4..0.6).contains(&fm), "{fm}");
    }

    #[test]
    fn names_resolve() {
        for n in NAMES {
            assert_eq!(by_name(n).map(|p| p.name), Some(n));
        }
        assert!(by_name("nope").is_none());
    }
}
