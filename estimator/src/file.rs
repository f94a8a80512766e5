//! The canonical parameter file, `params.toml` (`std` feature).
//!
//! One versioned, self-describing TOML file carries the rotor count, the fitted curve (degree,
//! scaling, coefficients in the scaled basis the estimator evaluates and in the physical monomial
//! basis for people, validity range, supply voltage), the thrust limit and the voltage it was
//! taken at, the fit's statistics and the provenance (input file hashes, date, tool version).
//! Unknown keys and a newer schema version are errors that name the line and column.
//!
//! Two optional sections feed the online estimator ([`crate::online`]): `[battery]`
//! (versioned: `version = 1`; the pack model the gap diagnosis learns) and `[vehicle]` (the
//! masses and powers of eqs. 1–2). A file without them is read as before.
//!
//! The optional `[motor]` section is the motor map ([`crate::MotorMap`]: per-rotor power from
//! the ESC command and the supply voltage, not in the paper), which `fit` writes when both
//! sweeps logged the throttle and the power; its `[[motor.sweeps]]` say how well it fits each
//! sweep. A file without it reads as `motor: None`, and is written back byte for byte.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::online::{BatteryModel, Chemistry, OCV_KNOTS, Vehicle};
use crate::params::{Params, ThrustLimit};
use crate::{EstimateError, MotorMap, PolyCurve};

/// Value of the `schema` key.
pub const SCHEMA: &str = "hoverbench.params";
/// Schema version this crate writes and the newest it reads.
pub const SCHEMA_VERSION: u32 = 1;
/// Version of the `[battery]` section this crate writes and reads.
pub const BATTERY_SECTION_VERSION: u32 = 1;

/// `params.toml` as a Rust value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParamsFile {
    /// Always [`SCHEMA`].
    pub schema: String,
    /// Always [`SCHEMA_VERSION`] when written by this version.
    pub schema_version: u32,
    /// Rotors sharing the take-off mass.
    pub rotor_count: u8,
    /// The fitted curve.
    pub curve: CurveSection,
    /// Thrust limit at minimum battery voltage, when a limit sweep was given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thrust_limit: Option<ThrustLimitSection>,
    /// Statistics of the fit.
    pub fit: FitSection,
    /// Where the numbers came from.
    pub provenance: Provenance,
    /// The pack the robot flies, for the online estimator.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub battery: Option<BatterySection>,
    /// The robot's masses and powers (eqs. 1–2), for the online estimator.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vehicle: Option<VehicleSection>,
    /// Per-rotor power from the ESC command and the supply voltage (not in the paper).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motor: Option<MotorSection>,
}

/// `[motor]`: the motor map, `power_w = Σ coefficients_scaled[k] · tᵏ`,
/// `t = (drive_v − center_v) / scale_v`, `drive_v = duty · supply voltage`,
/// `duty = (us − zero_us) / (full_us − zero_us)` clamped to 0..1 (see [`crate::motor`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorSection {
    /// ESC command where the duty starts to rise from zero, µs (fitted).
    pub zero_us: f64,
    /// ESC command of full duty, µs (the rig's top of range).
    pub full_us: f64,
    /// Degree of the power curve over drive voltage.
    pub degree: usize,
    /// Centre of the drive-voltage scaling, V.
    pub center_v: f64,
    /// Half-width of the drive-voltage scaling, V.
    pub scale_v: f64,
    /// Coefficients of power (W) in `t`, ascending: what the estimator evaluates.
    pub coefficients_scaled: Vec<f64>,
    /// The same polynomial in ascending powers of the drive voltage itself (W per Vᵏ), for
    /// people and other tools; the estimator does not read it.
    pub coefficients_monomial: Vec<f64>,
    /// Lowest drive voltage the sweeps covered, V.
    pub drive_v_min: f64,
    /// Highest drive voltage the sweeps covered, V.
    pub drive_v_max: f64,
    /// Relative RMS residual of the fit over all its points (0.01 = 1 %).
    pub fit_rmse_fraction: f64,
    /// Where the map came from, as text.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub source: String,
    /// How well it fits each sweep.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sweeps: Vec<MotorSweepSection>,
}

/// `[[motor.sweeps]]`: one sweep the motor map was fitted to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorSweepSection {
    /// The sweep's file.
    pub file: String,
    /// Its supply voltage, V.
    pub supply_voltage_v: f64,
    /// Steps fitted.
    pub n_points: usize,
    /// Relative RMS residual of the map on them.
    pub rmse_fraction: f64,
}

impl MotorSection {
    /// The map, checked; the error names the key at fault.
    pub fn to_map(&self) -> Result<MotorMap, (&'static str, String)> {
        if self.coefficients_scaled.len() != self.degree + 1 {
            return Err((
                "degree",
                format!(
                    "motor.degree is {} but motor.coefficients_scaled has {} entries",
                    self.degree,
                    self.coefficients_scaled.len()
                ),
            ));
        }
        MotorMap::new(
            self.zero_us,
            self.full_us,
            &self.coefficients_scaled,
            self.center_v,
            self.scale_v,
            (self.drive_v_min, self.drive_v_max),
            self.fit_rmse_fraction,
        )
        .map_err(|e| {
            let key = match e {
                EstimateError::NonFinite { what, .. }
                | EstimateError::NotPositive { what, .. }
                | EstimateError::Negative { what, .. } => match what {
                    "motor map zero_us" => "zero_us",
                    "motor map full_us" => "full_us",
                    "motor map fit_rmse_fraction" => "fit_rmse_fraction",
                    "curve center_g" => "center_v",
                    "curve scale_g" => "scale_v",
                    "curve valid_min_g" => "drive_v_min",
                    "curve valid_max_g" => "drive_v_max",
                    _ => "coefficients_scaled",
                },
                EstimateError::MotorCommandRange { .. } => "full_us",
                EstimateError::CurveDegree { .. } => "degree",
                EstimateError::CurveRange { min_g, .. } if min_g < 0.0 => "drive_v_min",
                EstimateError::CurveRange { .. } => "drive_v_max",
                _ => "zero_us",
            };
            // The curve's checks speak of grams; the map's curve is over volts.
            if let EstimateError::CurveRange { min_g, max_g } = e {
                return (
                    key,
                    format!(
                        "motor.{key}: the drive-voltage range must satisfy 0 ≤ drive_v_min < drive_v_max, got {min_g} V .. {max_g} V"
                    ),
                );
            }
            let message = e
                .to_string()
                .replace("curve center_g", "the drive-voltage centre")
                .replace("curve scale_g", "the drive-voltage scale")
                .replace("curve valid_min_g", "drive_v_min")
                .replace("curve valid_max_g", "drive_v_max")
                .replace("curve coefficient", "a coefficient");
            (key, format!("motor.{key}: {message}"))
        })
    }

    /// The section of a map, with its provenance and per-sweep fit.
    pub fn from_map(
        map: &MotorMap,
        coefficients_monomial: Vec<f64>,
        source: &str,
        sweeps: Vec<MotorSweepSection>,
    ) -> Self {
        let (lo, hi) = map.drive_range_v();
        Self {
            zero_us: map.zero_us(),
            full_us: map.full_us(),
            degree: map.degree(),
            center_v: map.center_v(),
            scale_v: map.scale_v(),
            coefficients_scaled: map.coefficients_scaled().to_vec(),
            coefficients_monomial,
            drive_v_min: lo,
            drive_v_max: hi,
            fit_rmse_fraction: map.fit_rmse_fraction(),
            source: source.to_owned(),
            sweeps,
        }
    }
}

/// `[battery]`: the pack model (per cell: open-circuit curve, series resistance, one RC pair).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BatterySection {
    /// Section layout version, [`BATTERY_SECTION_VERSION`].
    pub version: u32,
    /// Cells in series.
    pub cells: u8,
    /// Rated capacity, Ah (give this or `rated_capacity_mah`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rated_capacity_ah: Option<f64>,
    /// Rated capacity, mAh (give this or `rated_capacity_ah`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rated_capacity_mah: Option<f64>,
    /// Chemistry: `lipo`, `lihv`, `li_ion_nmc`, `li_ion_nca`, `lifepo4`, `measured` or `other`.
    pub chemistry: String,
    /// Open-circuit voltage of one cell at state of charge 0, 0.05, …, 1 (21 values), V.
    pub ocv_cell_v: Vec<f64>,
    /// Series resistance of one cell, Ω.
    pub series_resistance_cell_ohm: f64,
    /// Resistance of the RC pair of one cell, Ω (0: none).
    #[serde(default)]
    pub rc_resistance_cell_ohm: f64,
    /// Time constant of the RC pair, s.
    #[serde(default)]
    pub rc_time_constant_s: f64,
    /// Cut-off voltage of one cell under load, V.
    pub cutoff_cell_v: f64,
    /// Where the model came from (e.g. the gap diagnosis and its flights), as text.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub source: String,
    /// Root-mean-square voltage residual per cell of the fit the curve was learned by, V (the
    /// gap diagnosis writes it; absent in hand-written sections and older files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit_rmse_cell_v: Option<f64>,
    /// Standard deviation per cell of the chemistry prior the curve was pulled towards, V: the
    /// gap diagnosis's 0.03 V when the chemistry was given, 0.3 V when it was not (then any
    /// chemistry's low end may be the pack's). Absent in hand-written sections and older files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub curve_prior_sigma_cell_v: Option<f64>,
}

impl BatterySection {
    /// The section of a battery model (capacity in Ah).
    pub fn from_model(b: &BatteryModel, source: &str) -> Self {
        Self {
            version: BATTERY_SECTION_VERSION,
            cells: b.cells,
            rated_capacity_ah: Some(b.rated_capacity_ah),
            rated_capacity_mah: None,
            chemistry: b.chemistry.name().to_owned(),
            ocv_cell_v: b.ocv_cell_v.to_vec(),
            series_resistance_cell_ohm: b.series_resistance_cell_ohm,
            rc_resistance_cell_ohm: b.rc_resistance_cell_ohm,
            rc_time_constant_s: b.rc_time_constant_s,
            cutoff_cell_v: b.cutoff_cell_v,
            source: source.to_owned(),
            fit_rmse_cell_v: None,
            curve_prior_sigma_cell_v: None,
        }
    }

    /// The online band's curve-shape uncertainty at the cut-off for this section, V per cell
    /// ([`crate::online::OnlineConfig::cutoff_curve_sigma_cell_v`]): `√2 × max(prior σ, fit
    /// RMSE)` (two independent points of the curve, now and at the cut-off) when the section
    /// says how its curve was learned, else `default` (a section without these keys keeps
    /// today's behaviour). A missing one of the two keys counts as 0; neither raises the value
    /// below `default`.
    pub fn curve_shape_sigma_cell_v(&self, default: f64) -> f64 {
        let known = |v: Option<f64>| v.filter(|x| x.is_finite() && *x >= 0.0);
        let prior = known(self.curve_prior_sigma_cell_v);
        let rmse = known(self.fit_rmse_cell_v);
        if prior.is_none() && rmse.is_none() {
            return default;
        }
        let s = core::f64::consts::SQRT_2 * prior.unwrap_or(0.0).max(rmse.unwrap_or(0.0));
        s.max(default)
    }

    /// The battery model, checked; the message names the key at fault.
    pub fn to_model(&self) -> Result<BatteryModel, (&'static str, String)> {
        if self.version != BATTERY_SECTION_VERSION {
            return Err((
                "version",
                format!(
                    "battery.version = {} is not a [battery] layout this hoverbench reads (version {BATTERY_SECTION_VERSION})",
                    self.version
                ),
            ));
        }
        for (key, v) in [
            ("fit_rmse_cell_v", self.fit_rmse_cell_v),
            ("curve_prior_sigma_cell_v", self.curve_prior_sigma_cell_v),
        ] {
            if let Some(v) = v
                && !(v.is_finite() && v >= 0.0)
            {
                return Err((
                    key,
                    format!("battery.{key} = {v} must be a finite voltage of 0 or more"),
                ));
            }
        }
        let capacity = match (self.rated_capacity_ah, self.rated_capacity_mah) {
            (Some(ah), None) => ah,
            (None, Some(mah)) => mah / 1000.0,
            (Some(_), Some(_)) => {
                return Err((
                    "rated_capacity_mah",
                    "give battery.rated_capacity_ah or battery.rated_capacity_mah, not both".into(),
                ));
            }
            (None, None) => {
                return Err((
                    "cells",
                    "battery.rated_capacity_ah (or rated_capacity_mah) is missing".into(),
                ));
            }
        };
        let chemistry = Chemistry::from_name(&self.chemistry).ok_or_else(|| {
            (
                "chemistry",
                format!(
                    "battery.chemistry = {:?} is not one of lipo, lihv, li_ion_nmc, li_ion_nca, lifepo4, measured, other",
                    self.chemistry
                ),
            )
        })?;
        if self.ocv_cell_v.len() != OCV_KNOTS {
            return Err((
                "ocv_cell_v",
                format!(
                    "battery.ocv_cell_v has {} values; it needs {OCV_KNOTS} (state of charge 0, 0.05, …, 1)",
                    self.ocv_cell_v.len()
                ),
            ));
        }
        let mut ocv = [0.0; OCV_KNOTS];
        ocv.copy_from_slice(&self.ocv_cell_v);
        let b = BatteryModel {
            cells: self.cells,
            rated_capacity_ah: capacity,
            chemistry,
            ocv_cell_v: ocv,
            series_resistance_cell_ohm: self.series_resistance_cell_ohm,
            rc_resistance_cell_ohm: self.rc_resistance_cell_ohm,
            rc_time_constant_s: self.rc_time_constant_s,
            cutoff_cell_v: self.cutoff_cell_v,
        };
        b.validate().map_err(|e| {
            let key = match e {
                EstimateError::NotPositive { what, .. }
                | EstimateError::NonFinite { what, .. }
                | EstimateError::Negative { what, .. } => {
                    if what.contains("cells") {
                        "cells"
                    } else if what.contains("capacity") {
                        if self.rated_capacity_ah.is_some() {
                            "rated_capacity_ah"
                        } else {
                            "rated_capacity_mah"
                        }
                    } else if what.contains("series") {
                        "series_resistance_cell_ohm"
                    } else if what.contains("RC-pair") {
                        "rc_resistance_cell_ohm"
                    } else if what.contains("time constant") {
                        "rc_time_constant_s"
                    } else if what.contains("cut-off") {
                        "cutoff_cell_v"
                    } else {
                        "ocv_cell_v"
                    }
                }
                EstimateError::Battery { reason, .. } if reason.contains("cut-off") => {
                    "cutoff_cell_v"
                }
                _ => "ocv_cell_v",
            };
            (key, format!("battery.{key}: {e}"))
        })?;
        Ok(b)
    }
}

impl BatteryModel {
    /// The battery model of a `[battery]` section, checked (the error names the key).
    pub fn from_section(section: &BatterySection) -> Result<Self, ParamsFileError> {
        section
            .to_model()
            .map_err(|(_, message)| ParamsFileError::Battery {
                path: None,
                message,
            })
    }
}

/// `[vehicle]`: the robot's masses and powers (eqs. 1–2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleSection {
    /// `m_S`, kg.
    pub structure_mass_kg: f64,
    /// `m_B`, kg.
    pub battery_mass_kg: f64,
    /// `m_P`, kg.
    #[serde(default)]
    pub payload_mass_kg: f64,
    /// `p_A`, W.
    pub avionics_power_w: f64,
    /// `p_P`, W.
    #[serde(default)]
    pub payload_power_w: f64,
}

impl VehicleSection {
    /// The section of a vehicle.
    pub fn from_vehicle(v: &Vehicle) -> Self {
        Self {
            structure_mass_kg: v.structure_mass_kg,
            battery_mass_kg: v.battery_mass_kg,
            payload_mass_kg: v.payload_mass_kg,
            avionics_power_w: v.avionics_power_w,
            payload_power_w: v.payload_power_w,
        }
    }

    /// The vehicle (unchecked).
    pub fn to_vehicle(&self) -> Vehicle {
        Vehicle {
            structure_mass_kg: self.structure_mass_kg,
            battery_mass_kg: self.battery_mass_kg,
            payload_mass_kg: self.payload_mass_kg,
            avionics_power_w: self.avionics_power_w,
            payload_power_w: self.payload_power_w,
        }
    }
}

/// `[curve]`: the fitted polynomial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurveSection {
    /// Column fitted as abscissa (`thrust_g` for a rig characterisation).
    pub x: String,
    /// Column fitted as ordinate (`power_w` for a rig characterisation).
    pub y: String,
    /// Polynomial degree.
    pub degree: usize,
    /// Centre of the abscissa scaling, in x's unit.
    pub center: f64,
    /// Half-width of the abscissa scaling, in x's unit.
    pub scale: f64,
    /// Coefficients of `y = Σ c_k t^k`, `t = (x − center)/scale`: what the estimator evaluates.
    pub coefficients_scaled: Vec<f64>,
    /// The same polynomial in ascending powers of x itself (for a thrust curve: W per g^k),
    /// for people and other tools; the estimator does not read it.
    pub coefficients_monomial: Vec<f64>,
    /// Lowest x measured.
    pub valid_min: f64,
    /// Highest x measured.
    pub valid_max: f64,
    /// Supply voltage of the sweep, V (absent for generic fits of other quantities).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub supply_voltage_v: Option<f64>,
}

/// `[thrust_limit]`: the paper's `m_L`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThrustLimitSection {
    /// Sustained maximum thrust of one rotor, g.
    pub per_rotor_g: f64,
    /// Its standard uncertainty, g.
    pub uncertainty_g: f64,
    /// `m_L` = rotor count × per-rotor limit, kg.
    pub total_kg: f64,
    /// Supply voltage of the limit sweep, V.
    pub supply_voltage_v: f64,
    /// How it was found: `plateau` or `top_of_range`.
    pub method: String,
}

/// `[fit]`: how well the polynomial fits.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitSection {
    /// Points fitted.
    pub n_points: usize,
    /// Root-mean-square residual, in y's unit.
    pub rmse: f64,
    /// Coefficient of determination.
    pub r_squared: f64,
    /// Largest absolute residual, in y's unit (absent when the fit has no residuals).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "nan_as_none"
    )]
    pub max_abs_residual: Option<f64>,
    /// x where it occurs.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "nan_as_none"
    )]
    pub max_residual_at: Option<f64>,
    /// Condition number of the scaled design matrix.
    pub condition_number: f64,
    /// Standard errors of `coefficients_scaled`.
    pub coefficient_std_errors_scaled: Vec<f64>,
    /// Warnings the fit raised, as text.
    #[serde(default)]
    pub warnings: Vec<String>,
}

/// Files written before the `Option` fields spelled a missing value `nan`: read it as absent.
fn nan_as_none<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.filter(|v| !v.is_nan()))
}

/// `[provenance]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Provenance {
    /// The nominal sweep fitted.
    pub input_file: String,
    /// Its SHA-256, hex.
    pub input_sha256: String,
    /// The limit sweep, when given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limit_input_file: Option<String>,
    /// Its SHA-256, hex.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limit_input_sha256: Option<String>,
    /// When the file was written (RFC 3339).
    pub created: String,
    /// Tool and version that wrote it.
    pub tool: String,
}

/// Why a parameter file could not be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ParamsFileError {
    /// The file could not be read.
    #[error("cannot read {}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// Malformed TOML, an unknown key, a missing key or a wrongly typed value.
    #[error("{}line {line}, column {column}: {message}", path_prefix(path.as_deref()))]
    Syntax {
        /// The file, when read from one.
        path: Option<PathBuf>,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What the parser said.
        message: String,
    },
    /// Not text (a flight log, an image, …): not a parameter file.
    #[error(
        "{}: not a hoverbench parameter file: byte {offset} is not UTF-8 text (a parameter file is TOML)",
        path.display()
    )]
    NotText {
        /// The file.
        path: PathBuf,
        /// 0-based offset of the first byte that is not UTF-8.
        offset: usize,
    },
    /// Not a hoverbench parameter file.
    #[error("{}not a hoverbench parameter file (schema = {found:?}, expected {SCHEMA:?})", path_prefix(path.as_deref()))]
    Schema {
        /// The file.
        path: Option<PathBuf>,
        /// The `schema` value found.
        found: String,
    },
    /// Written by a newer hoverbench.
    #[error(
        "{}schema_version {found} is newer than this hoverbench reads ({SCHEMA_VERSION}): upgrade hoverbench",
        path_prefix(path.as_deref())
    )]
    NewerSchema {
        /// The file.
        path: Option<PathBuf>,
        /// Version found.
        found: i64,
    },
    /// Values that parse but make no sense.
    #[error("{}{}values the estimator cannot use", path_prefix(path.as_deref()), key_prefix(at.as_ref()))]
    Invalid {
        /// The file.
        path: Option<PathBuf>,
        /// Where in the file, when parsed from text: 1-based line and column of the value and
        /// its key (`curve.scale`).
        at: Option<(usize, usize, String)>,
        /// What is wrong.
        source: EstimateError,
    },
    /// The file holds a fit of other quantities than thrust → power.
    #[error(
        "{}the curve is {y} vs {x}, not power_w vs thrust_g: it is a generic fit, not a rig characterisation",
        path_prefix(path.as_deref())
    )]
    NotAThrustCurve {
        /// The file.
        path: Option<PathBuf>,
        /// Its x column.
        x: String,
        /// Its y column.
        y: String,
    },
    /// The `[battery]` section is not a valid battery model.
    #[error("{}{message}", path_prefix(path.as_deref()))]
    Battery {
        /// The file.
        path: Option<PathBuf>,
        /// What is wrong.
        message: String,
    },
    /// The `[motor]` section is not a valid motor map.
    #[error("{}{message}", path_prefix(path.as_deref()))]
    Motor {
        /// The file.
        path: Option<PathBuf>,
        /// What is wrong.
        message: String,
    },
    /// The scaled coefficients disagree with the stated degree.
    #[error("{}curve.degree is {degree} but curve.coefficients_scaled has {len} entries", path_prefix(path.as_deref()))]
    DegreeMismatch {
        /// The file.
        path: Option<PathBuf>,
        /// Stated degree.
        degree: usize,
        /// Coefficients given.
        len: usize,
    },
}

fn key_prefix(at: Option<&(usize, usize, String)>) -> String {
    at.map(|(line, column, key)| format!("line {line}, column {column}, {key}: "))
        .unwrap_or_default()
}

/// The file key (`section`, `key`) a curve check names: the check speaks of the estimator's
/// fields (`curve scale_g`), the file of its keys (`[curve] scale`).
fn curve_error_key(e: &EstimateError) -> (&'static str, &'static str) {
    let what = match e {
        EstimateError::NonFinite { what, .. }
        | EstimateError::NotPositive { what, .. }
        | EstimateError::Negative { what, .. } => *what,
        EstimateError::NoRotors => return ("", "rotor_count"),
        EstimateError::CurveDegree { .. } => return ("curve", "degree"),
        EstimateError::CurveRange { min_g, .. } if *min_g < 0.0 => return ("curve", "valid_min"),
        EstimateError::CurveRange { .. } => return ("curve", "valid_max"),
        _ => "",
    };
    let key = match what {
        "curve coefficient" => "coefficients_scaled",
        "curve center_g" => "center",
        "curve scale_g" => "scale",
        "curve valid_min_g" => "valid_min",
        "curve valid_max_g" => "valid_max",
        "curve supply_voltage_v" => "supply_voltage_v",
        _ => "",
    };
    ("curve", key)
}

fn path_prefix(path: Option<&Path>) -> String {
    path.map(|p| format!("{}: ", p.display()))
        .unwrap_or_default()
}

/// `v` rounded to `digits` significant digits (for messages).
fn round_sig(v: f64, digits: i32) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let scale = 10f64.powi(digits - 1 - v.abs().log10().floor() as i32);
    (v * scale).round() / scale
}

/// 1-based line and column of the value of `key` in `[section]` (the section's line, or 1:1,
/// when the key is not found as written).
fn key_position(text: &str, section: &str, key: &str) -> (usize, usize) {
    let mut current = "";
    let mut section_line = (1, 1);
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if let Some(name) = t.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
            current = name.trim();
            if current == section {
                section_line = (i + 1, 1);
            }
            continue;
        }
        if current == section {
            if let Some(rest) = t.strip_prefix(key) {
                if rest.trim_start().starts_with('=') {
                    let eq = line.find('=').unwrap_or(0);
                    let after = &line[eq + 1..];
                    let value_at = eq + 1 + (after.len() - after.trim_start().len());
                    return (i + 1, line[..value_at].chars().count() + 1);
                }
            }
        }
    }
    section_line
}

/// The 1-based line of a CSV header, when the first line that is neither blank nor a `#`
/// comment holds commas and no `=` (a sweep or catalogue, not TOML).
fn csv_header_line(text: &str) -> Option<usize> {
    let (i, first) = text
        .lines()
        .enumerate()
        .find(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'))?;
    (first.contains(',') && !first.contains('=') && !first.trim_start().starts_with('['))
        .then_some(i + 1)
}

fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

impl ParamsFile {
    /// Parses and checks `params.toml` text.
    pub fn from_toml_str(text: &str) -> Result<Self, ParamsFileError> {
        Self::parse(text, None)
    }

    /// Reads and checks a `params.toml` file.
    pub fn load(path: &Path) -> Result<Self, ParamsFileError> {
        let bytes = std::fs::read(path).map_err(|source| ParamsFileError::Io {
            path: path.to_owned(),
            source,
        })?;
        let text = String::from_utf8(bytes).map_err(|e| ParamsFileError::NotText {
            path: path.to_owned(),
            offset: e.utf8_error().valid_up_to(),
        })?;
        Self::parse(&text, Some(path))
    }

    fn parse(text: &str, path: Option<&Path>) -> Result<Self, ParamsFileError> {
        let syntax = |e: toml::de::Error| {
            let (line, column) = e.span().map_or((1, 1), |s| line_column(text, s.start));
            let message = e.message().trim();
            // serde's "missing field `curve`": a key or a whole [section] of the file
            let message = match message
                .strip_prefix("missing field `")
                .and_then(|m| m.strip_suffix('`'))
            {
                Some(name) => {
                    format!("`{name}` is missing: every hoverbench parameter file has it")
                }
                None => message.to_owned(),
            };
            ParamsFileError::Syntax {
                path: path.map(Path::to_owned),
                line,
                column,
                message,
            }
        };
        // Check the schema and version before the strict parse, so that a file from a newer
        // hoverbench says so instead of complaining about the keys it added.
        let table: toml::Table = toml::from_str(text).map_err(|e| {
            // A sweep given where the parameters go: say so, not "expected `=`".
            match csv_header_line(text) {
                Some(line) => ParamsFileError::Syntax {
                    path: path.map(Path::to_owned),
                    line,
                    column: 1,
                    message: "this is a table of comma-separated values, not a TOML parameter \
                              file: fit the sweep first (hoverbench fit SWEEP -o params.toml)"
                        .to_owned(),
                },
                None => syntax(e),
            }
        })?;
        let found = table
            .get("schema")
            .and_then(|v| v.as_str())
            .unwrap_or("(missing)");
        if found != SCHEMA {
            return Err(ParamsFileError::Schema {
                path: path.map(Path::to_owned),
                found: found.to_owned(),
            });
        }
        if let Some(v) = table
            .get("schema_version")
            .and_then(toml::Value::as_integer)
        {
            if v > i64::from(SCHEMA_VERSION) {
                return Err(ParamsFileError::NewerSchema {
                    path: path.map(Path::to_owned),
                    found: v,
                });
            }
        }
        if let Some(v) = table
            .get("battery")
            .and_then(|b| b.get("version"))
            .and_then(toml::Value::as_integer)
        {
            if v != i64::from(BATTERY_SECTION_VERSION) {
                let (line, column) = key_position(text, "battery", "version");
                return Err(ParamsFileError::Syntax {
                    path: path.map(Path::to_owned),
                    line,
                    column,
                    message: format!(
                        "battery.version = {v} is not a [battery] layout this hoverbench reads (version {BATTERY_SECTION_VERSION}): upgrade hoverbench or rewrite the section"
                    ),
                });
            }
        }
        let file: Self = toml::from_str(text).map_err(syntax)?;
        if file.curve.coefficients_scaled.len() != file.curve.degree + 1 {
            return Err(ParamsFileError::DegreeMismatch {
                path: path.map(Path::to_owned),
                degree: file.curve.degree,
                len: file.curve.coefficients_scaled.len(),
            });
        }
        file.curve_checked().map_err(|source| {
            let (section, key) = curve_error_key(&source);
            let (line, column) = key_position(text, section, key);
            let name = match (section, key) {
                (s, "") => format!("[{s}]"),
                ("", k) => k.to_owned(),
                (s, k) => format!("{s}.{k}"),
            };
            ParamsFileError::Invalid {
                path: path.map(Path::to_owned),
                at: Some((line, column, name)),
                source,
            }
        })?;
        file.check_values(text, path)?;
        Ok(file)
    }

    /// Values a strict parse lets through but no hoverbench file holds: a thrust limit whose
    /// `total_kg` contradicts `per_rotor_g × rotor_count`, and uncertainties that are not finite
    /// and ≥ 0. Each error names the key's line and column.
    fn check_values(&self, text: &str, path: Option<&Path>) -> Result<(), ParamsFileError> {
        let at = |section: &str, key: &str, message: String| {
            let (line, column) = key_position(text, section, key);
            ParamsFileError::Syntax {
                path: path.map(Path::to_owned),
                line,
                column,
                message,
            }
        };
        if let Some(l) = &self.thrust_limit {
            if !(l.uncertainty_g.is_finite() && l.uncertainty_g >= 0.0) {
                return Err(at(
                    "thrust_limit",
                    "uncertainty_g",
                    format!(
                        "thrust_limit.uncertainty_g is {}: an uncertainty is a finite number ≥ 0",
                        l.uncertainty_g
                    ),
                ));
            }
            let implied_kg = l.per_rotor_g * f64::from(self.rotor_count) / 1000.0;
            // the writer stores both at full precision; allow for hand-rounded values
            let tolerance_kg = (implied_kg.abs() * 5e-3).max(5e-4);
            if !l.total_kg.is_finite() || (l.total_kg - implied_kg).abs() > tolerance_kg {
                return Err(at(
                    "thrust_limit",
                    "total_kg",
                    format!(
                        "thrust_limit.total_kg = {} contradicts per_rotor_g × rotor_count = {} g × {} = {} kg",
                        l.total_kg,
                        round_sig(l.per_rotor_g, 6),
                        self.rotor_count,
                        round_sig(implied_kg, 6)
                    ),
                ));
            }
        }
        if let Some((k, v)) = self
            .fit
            .coefficient_std_errors_scaled
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
        {
            return Err(at(
                "fit",
                "coefficient_std_errors_scaled",
                format!(
                    "fit.coefficient_std_errors_scaled[{k}] is {v}: a standard error is a finite number ≥ 0"
                ),
            ));
        }
        if let Some(b) = &self.battery {
            b.to_model()
                .map_err(|(key, message)| at("battery", key, message))?;
        }
        if let Some(m) = &self.motor {
            m.to_map()
                .map_err(|(key, message)| at("motor", key, message))?;
        }
        if let Some(v) = &self.vehicle {
            v.to_vehicle().validate().map_err(|e| {
                let key = match e {
                    EstimateError::NotPositive { what, .. }
                    | EstimateError::NonFinite { what, .. }
                    | EstimateError::Negative { what, .. } => {
                        if what.contains("structure") {
                            "structure_mass_kg"
                        } else if what.contains("battery") {
                            "battery_mass_kg"
                        } else if what.contains("payload mass") {
                            "payload_mass_kg"
                        } else if what.contains("avionics") {
                            "avionics_power_w"
                        } else if what.contains("payload power") {
                            "payload_power_w"
                        } else {
                            "structure_mass_kg"
                        }
                    }
                    _ => "structure_mass_kg",
                };
                at("vehicle", key, format!("vehicle.{key}: {e}"))
            })?;
        }
        Ok(())
    }

    /// Renders the file as TOML.
    pub fn to_toml_string(&self) -> String {
        // Serialising plain structs of numbers, strings and vectors cannot fail.
        let body = toml::to_string_pretty(self).unwrap_or_else(|e| format!("# {e}\n"));
        format!(
            "# hoverbench rig parameters: per-rotor electrical power vs thrust, thrust limit, provenance.\n\
             # Evaluate the curve as  y = sum_k coefficients_scaled[k] * t^k,  t = (x - center) / scale.\n\n{body}"
        )
    }

    fn curve_checked(&self) -> Result<PolyCurve, EstimateError> {
        if self.rotor_count == 0 {
            return Err(EstimateError::NoRotors);
        }
        PolyCurve::new(
            &self.curve.coefficients_scaled,
            self.curve.center,
            self.curve.scale,
            (self.curve.valid_min, self.curve.valid_max),
            self.curve.supply_voltage_v,
        )
    }

    /// The estimator's view of the file. Fails when the file holds a generic fit rather than a
    /// thrust → power curve.
    pub fn to_params(&self) -> Result<Params, ParamsFileError> {
        if self.curve.x != "thrust_g" || self.curve.y != "power_w" {
            return Err(ParamsFileError::NotAThrustCurve {
                path: None,
                x: self.curve.x.clone(),
                y: self.curve.y.clone(),
            });
        }
        let invalid = |source| ParamsFileError::Invalid {
            path: None,
            at: None,
            source,
        };
        let curve = self.curve_checked().map_err(invalid)?;
        let thrust_limit = match &self.thrust_limit {
            None => None,
            Some(l) => {
                crate::curve::require_positive("thrust_limit.per_rotor_g", l.per_rotor_g)
                    .map_err(invalid)?;
                Some(ThrustLimit {
                    per_rotor_g: l.per_rotor_g,
                    uncertainty_g: l.uncertainty_g,
                    supply_voltage_v: l.supply_voltage_v,
                })
            }
        };
        let battery = match &self.battery {
            None => None,
            Some(b) => Some(
                b.to_model()
                    .map_err(|(_, message)| ParamsFileError::Battery {
                        path: None,
                        message,
                    })?,
            ),
        };
        let vehicle = match &self.vehicle {
            None => None,
            Some(v) => {
                let v = v.to_vehicle();
                v.validate().map_err(invalid)?;
                Some(v)
            }
        };
        let motor = match &self.motor {
            None => None,
            Some(m) => Some(m.to_map().map_err(|(_, message)| ParamsFileError::Motor {
                path: None,
                message,
            })?),
        };
        Ok(Params {
            rotor_count: self.rotor_count,
            curve,
            thrust_limit,
            battery,
            vehicle,
            motor,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> ParamsFile {
        ParamsFile {
            schema: SCHEMA.into(),
            schema_version: SCHEMA_VERSION,
            rotor_count: 4,
            curve: CurveSection {
                x: "thrust_g".into(),
                y: "power_w".into(),
                degree: 2,
                center: 130.0,
                scale: 130.0,
                coefficients_scaled: vec![20.0, 25.0, 5.0],
                coefficients_monomial: vec![1.0, 2.0, 3.0],
                valid_min: 0.0,
                valid_max: 260.0,
                supply_voltage_v: Some(12.5),
            },
            thrust_limit: Some(ThrustLimitSection {
                per_rotor_g: 150.0,
                uncertainty_g: 0.5,
                total_kg: 0.6,
                supply_voltage_v: 9.0,
                method: "plateau".into(),
            }),
            fit: FitSection {
                n_points: 27,
                rmse: 0.01,
                r_squared: 0.9999,
                max_abs_residual: Some(0.02),
                max_residual_at: Some(250.0),
                condition_number: 12.0,
                coefficient_std_errors_scaled: vec![0.1, 0.1, 0.1],
                warnings: vec![],
            },
            provenance: Provenance {
                input_file: "sweep.csv".into(),
                input_sha256: "00".into(),
                limit_input_file: None,
                limit_input_sha256: None,
                created: "2026-11-22T00:00:00Z".into(),
                tool: "hoverbench test".into(),
            },
            battery: None,
            vehicle: None,
            motor: None,
        }
    }

    fn with_battery() -> ParamsFile {
        let mut f = sample();
        let mut b = BatteryModel::lipo(3, 2.2).unwrap();
        b.rc_resistance_cell_ohm = 0.002;
        b.rc_time_constant_s = 30.0;
        f.battery = Some(BatterySection::from_model(&b, "test pack"));
        f.vehicle = Some(VehicleSection {
            structure_mass_kg: 0.431,
            battery_mass_kg: 0.144,
            payload_mass_kg: 0.0,
            avionics_power_w: 2.44,
            payload_power_w: 0.0,
        });
        f
    }

    #[test]
    fn battery_and_vehicle_sections_round_trip() {
        let f = with_battery();
        let text = f.to_toml_string();
        assert!(
            text.contains("[battery]") && text.contains("\nversion = 1"),
            "{text}"
        );
        let back = ParamsFile::from_toml_str(&text).unwrap();
        assert_eq!(back, f);
        let p = back.to_params().unwrap();
        let b = p.battery.unwrap();
        assert_eq!(
            BatteryModel::from_section(back.battery.as_ref().unwrap()).unwrap(),
            b
        );
        let mut bad = back.battery.clone().unwrap();
        bad.version = 2;
        assert!(
            BatteryModel::from_section(&bad)
                .unwrap_err()
                .to_string()
                .contains("version")
        );
        assert_eq!(b.cells, 3);
        assert_eq!(b.rc_time_constant_s, 30.0);
        assert!((p.vehicle.unwrap().total_mass_kg() - 0.575).abs() < 1e-12);
        // Capacity in mAh reads the same.
        let mah = text.replace("rated_capacity_ah = 2.2", "rated_capacity_mah = 2200");
        let p2 = ParamsFile::from_toml_str(&mah)
            .unwrap()
            .to_params()
            .unwrap();
        assert!((p2.battery.unwrap().rated_capacity_ah - 2.2).abs() < 1e-12);
    }

    fn motor_section() -> MotorSection {
        let map = MotorMap::new(
            1083.25,
            2000.0,
            &[31.5, 42.25, 12.0, 1.125],
            6.5,
            5.25,
            (1.25, 11.75),
            0.0125,
        )
        .unwrap();
        MotorSection::from_map(
            &map,
            vec![0.5, 1.0, 0.25, 0.125],
            "sweep.csv (12.5 V) and limit.csv (9 V)",
            vec![
                MotorSweepSection {
                    file: "sweep.csv".into(),
                    supply_voltage_v: 12.5,
                    n_points: 27,
                    rmse_fraction: 0.01,
                },
                MotorSweepSection {
                    file: "limit.csv".into(),
                    supply_voltage_v: 9.0,
                    n_points: 21,
                    rmse_fraction: 0.015,
                },
            ],
        )
    }

    #[test]
    fn the_motor_section_round_trips_and_gives_the_map() {
        let mut f = sample();
        f.motor = Some(motor_section());
        let text = f.to_toml_string();
        for key in [
            "[motor]",
            "zero_us = 1083.25",
            "full_us = 2000.0",
            "drive_v_min = 1.25",
            "drive_v_max = 11.75",
            "fit_rmse_fraction = 0.0125",
            "[[motor.sweeps]]",
            "supply_voltage_v = 9.0",
        ] {
            assert!(text.contains(key), "{key}: {text}");
        }
        let back = ParamsFile::from_toml_str(&text).unwrap();
        assert_eq!(back, f);
        let m = back.to_params().unwrap().motor.unwrap();
        assert_eq!(m.zero_us(), 1083.25);
        assert_eq!(m.coefficients_scaled(), &[31.5, 42.25, 12.0, 1.125]);
        assert_eq!(m.drive_range_v(), (1.25, 11.75));
        // A hand-written section needs neither source nor sweeps.
        let mut bare = f.clone();
        let b = bare.motor.as_mut().unwrap();
        b.source.clear();
        b.sweeps.clear();
        let t = bare.to_toml_string();
        assert!(!t.contains("motor.sweeps") && !t.contains("source"), "{t}");
        assert_eq!(ParamsFile::from_toml_str(&t).unwrap(), bare);
    }

    #[test]
    fn a_file_without_motor_reads_as_none_and_writes_back_byte_for_byte() {
        let text = with_battery().to_toml_string();
        let back = ParamsFile::from_toml_str(&text).unwrap();
        assert_eq!(back.motor, None);
        assert_eq!(back.to_params().unwrap().motor, None);
        assert_eq!(back.to_toml_string(), text);
        // A file an earlier hoverbench wrote (the replay tests' parameters).
        let old = include_str!("../../tests/data/replay/params.toml");
        let f = ParamsFile::from_toml_str(old).unwrap();
        assert_eq!(f.motor, None);
        assert_eq!(f.to_toml_string(), old);
    }

    #[test]
    fn motor_section_errors_name_the_key_and_line() {
        let mut f = sample();
        f.motor = Some(motor_section());
        let text = f.to_toml_string();
        let line_of =
            |t: &str, prefix: &str| t.lines().position(|l| l.starts_with(prefix)).unwrap() + 1;
        for (bad, key, needle) in [
            (
                text.replace("zero_us = 1083.25", "zero_us = 2500.0"),
                "full_us",
                "below full_us",
            ),
            (
                text.replace("scale_v = 5.25", "scale_v = 0.0"),
                "scale_v",
                "drive-voltage scale",
            ),
            (
                text.replace("drive_v_min = 1.25", "drive_v_min = 20.0"),
                "drive_v_max",
                "motor.drive_v_max",
            ),
            (
                text.replace("fit_rmse_fraction = 0.0125", "fit_rmse_fraction = -1.0"),
                "fit_rmse_fraction",
                "fit_rmse_fraction",
            ),
            (
                text.replace("degree = 3\ncenter_v", "degree = 4\ncenter_v"),
                "degree",
                "motor.degree is 4",
            ),
        ] {
            assert_ne!(bad, text, "{key}");
            match ParamsFile::from_toml_str(&bad).unwrap_err() {
                ParamsFileError::Syntax { line, message, .. } => {
                    let (want, _) = key_position(&bad, "motor", key);
                    assert_eq!(line, want, "{message}");
                    assert!(
                        bad.lines().nth(line - 1).unwrap().starts_with(key),
                        "{key}: line {line}"
                    );
                    assert!(message.contains(needle), "{message}");
                }
                e => panic!("unexpected {e}"),
            }
        }
        let _ = line_of(&text, "zero_us");
        // An unknown key in the section.
        let t = text.replace("[motor]\n", "[motor]\nzero_pct = 5\n");
        assert!(matches!(
            ParamsFile::from_toml_str(&t),
            Err(ParamsFileError::Syntax { .. })
        ));
    }

    proptest::proptest! {
        #[test]
        fn motor_sections_round_trip_through_toml(
            zero_us in 800.0f64..1300.0,
            span_us in 100.0f64..1500.0,
            coefficients in proptest::collection::vec(-1e4f64..1e4, 1..=crate::MAX_DEGREE + 1),
            center_v in 0.0f64..50.0,
            scale_v in 1e-3f64..50.0,
            lo_v in 0.0f64..20.0,
            width_v in 1e-6f64..40.0,
            rmse in 0.0f64..1.0,
            battery in proptest::prelude::any::<bool>(),
        ) {
            let map = MotorMap::new(zero_us, zero_us + span_us, &coefficients, center_v, scale_v, (lo_v, lo_v + width_v), rmse).unwrap();
            let mut f = if battery { with_battery() } else { sample() };
            let without = f.to_toml_string();
            f.motor = Some(MotorSection::from_map(&map, coefficients.clone(), "p", vec![]));
            let text = f.to_toml_string();
            let back = ParamsFile::from_toml_str(&text).unwrap();
            proptest::prop_assert_eq!(&back, &f);
            proptest::prop_assert_eq!(back.to_params().unwrap().motor, Some(map));
            // The rest of the file is what it was without the section.
            let mut g = back;
            g.motor = None;
            proptest::prop_assert_eq!(g.to_toml_string(), without);
        }
    }

    #[test]
    fn battery_section_fit_keys_size_the_curve_band() {
        let f = with_battery();
        let b = f.battery.clone().unwrap();
        // A section without the keys (hand-written, older files) keeps the configured value.
        assert_eq!(b.fit_rmse_cell_v, None);
        assert!(!f.to_toml_string().contains("fit_rmse_cell_v"));
        assert_eq!(b.curve_shape_sigma_cell_v(0.042), 0.042);
        // With them: they survive the file, and the larger of prior and fit sets the value.
        let mut g = f.clone();
        let gb = g.battery.as_mut().unwrap();
        gb.fit_rmse_cell_v = Some(0.012);
        gb.curve_prior_sigma_cell_v = Some(0.3);
        let back = ParamsFile::from_toml_str(&g.to_toml_string()).unwrap();
        let bb = back.battery.unwrap();
        assert_eq!(bb.fit_rmse_cell_v, Some(0.012));
        assert_eq!(bb.curve_prior_sigma_cell_v, Some(0.3));
        assert!((bb.curve_shape_sigma_cell_v(0.042) - 0.3 * 2f64.sqrt()).abs() < 1e-12);
        let mut c = bb.clone();
        c.curve_prior_sigma_cell_v = Some(0.03);
        c.fit_rmse_cell_v = Some(0.05);
        assert!((c.curve_shape_sigma_cell_v(0.042) - 0.05 * 2f64.sqrt()).abs() < 1e-12);
        // Never below the configured value.
        c.curve_prior_sigma_cell_v = None;
        c.fit_rmse_cell_v = Some(0.001);
        assert_eq!(c.curve_shape_sigma_cell_v(0.042), 0.042);
    }

    #[test]
    fn battery_section_errors_name_the_line() {
        let text = with_battery().to_toml_string();
        let line_of =
            |t: &str, prefix: &str| t.lines().position(|l| l.starts_with(prefix)).unwrap() + 1;
        // An unknown version.
        let t = text.replace("\nversion = 1", "\nversion = 7");
        let e = ParamsFile::from_toml_str(&t).unwrap_err();
        match &e {
            ParamsFileError::Syntax { line, message, .. } => {
                assert_eq!(*line, line_of(&t, "version = 7"));
                assert!(message.contains("battery.version = 7"), "{message}");
            }
            e => panic!("unexpected {e}"),
        }
        // A falling curve, a cut-off above full, a negative resistance, a missing capacity.
        let knots = |b: &BatterySection| {
            format!("{:?}", b.ocv_cell_v)
                .replace('[', "")
                .replace(']', "")
        };
        let b = with_battery().battery.unwrap();
        let mut falling = b.clone();
        falling.ocv_cell_v[10] = 3.0;
        for (bad, key, needle) in [
            (
                {
                    let mut f = with_battery();
                    f.battery = Some(falling);
                    f.to_toml_string()
                },
                "ocv_cell_v",
                "rise strictly",
            ),
            (
                text.replace("cutoff_cell_v = 3.3", "cutoff_cell_v = 4.5"),
                "cutoff_cell_v",
                "cut-off",
            ),
            (
                text.replace(
                    "series_resistance_cell_ohm = 0.005",
                    "series_resistance_cell_ohm = -0.01",
                ),
                "series_resistance_cell_ohm",
                "negative",
            ),
            (
                text.replace("rated_capacity_ah = 2.2\n", ""),
                "cells",
                "rated_capacity_ah",
            ),
            (
                text.replace("chemistry = \"lipo\"", "chemistry = \"plutonium\""),
                "chemistry",
                "plutonium",
            ),
            (
                text.replace(
                    "chemistry = \"lipo\"",
                    "chemistry = \"lipo\"\nfit_rmse_cell_v = -0.02",
                ),
                "fit_rmse_cell_v",
                "fit_rmse_cell_v = -0.02",
            ),
        ] {
            let _ = knots(&b);
            match ParamsFile::from_toml_str(&bad).unwrap_err() {
                ParamsFileError::Syntax { line, message, .. } => {
                    assert_eq!(line, line_of(&bad, key), "{message}");
                    assert!(message.contains(needle), "{message}");
                }
                e => panic!("unexpected {e}"),
            }
        }
        // 20 knots.
        let mut f = with_battery();
        f.battery.as_mut().unwrap().ocv_cell_v.pop();
        let e = ParamsFile::from_toml_str(&f.to_toml_string())
            .unwrap_err()
            .to_string();
        assert!(e.contains("needs 21"), "{e}");
        // A negative vehicle mass.
        let t = text.replace("structure_mass_kg = 0.431", "structure_mass_kg = -1.0");
        let e = ParamsFile::from_toml_str(&t).unwrap_err().to_string();
        assert!(
            e.contains("vehicle.structure_mass_kg") && e.contains("line"),
            "{e}"
        );
    }

    #[test]
    fn a_file_that_is_not_text_is_named_not_a_parameter_file() {
        let path = std::env::temp_dir().join(format!("hb-not-text-{}.ulg", std::process::id()));
        std::fs::write(&path, b"ULog\x01\x12\x35\x01\x00\xff\xfe").unwrap();
        let e = ParamsFile::load(&path).unwrap_err();
        std::fs::remove_file(&path).unwrap();
        assert!(
            matches!(e, ParamsFileError::NotText { offset: 9, .. }),
            "{e:?}"
        );
        assert!(
            e.to_string()
                .ends_with(": not a hoverbench parameter file: byte 9 is not UTF-8 text (a parameter file is TOML)"),
            "{e}"
        );
    }

    #[test]
    fn the_readme_example_sections_parse() {
        let readme = include_str!("../../README.md");
        let start = readme
            .find("[battery]\nversion = 1")
            .expect("the README's example");
        let block = &readme[start..start + readme[start..].find("```").unwrap()];
        let text = format!("{}\n{block}", sample().to_toml_string());
        let p = ParamsFile::from_toml_str(&text)
            .unwrap()
            .to_params()
            .unwrap();
        assert!((p.battery.unwrap().rated_capacity_ah - 2.2).abs() < 1e-12);
        assert_eq!(p.vehicle.unwrap().payload_mass_kg, 0.0);
    }

    #[test]
    fn missing_fit_statistics_are_absent_not_nan() {
        let mut f = sample();
        f.fit.max_abs_residual = None;
        f.fit.max_residual_at = None;
        let text = f.to_toml_string();
        assert!(
            !text.contains("max_abs_residual") && !text.contains("= nan"),
            "{text}"
        );
        assert_eq!(ParamsFile::from_toml_str(&text).unwrap(), f);
        // Files written before spelled them `nan`.
        let old = sample()
            .to_toml_string()
            .replace("max_abs_residual = 0.02", "max_abs_residual = nan")
            .replace("max_residual_at = 250.0", "max_residual_at = nan");
        assert!(old.contains("= nan"));
        let back = ParamsFile::from_toml_str(&old).unwrap();
        assert_eq!(back.fit.max_abs_residual, None);
        assert_eq!(back.fit.max_residual_at, None);
    }

    #[test]
    fn round_trips_through_toml() {
        let f = sample();
        let text = f.to_toml_string();
        assert_eq!(ParamsFile::from_toml_str(&text).unwrap(), f);
        let p = f.to_params().unwrap();
        assert!((p.thrust_limit_kg().unwrap() - 0.6).abs() < 1e-12);
    }

    #[test]
    fn unknown_key_is_an_error_with_its_line() {
        let text = sample()
            .to_toml_string()
            .replace("[fit]\n", "[fit]\nbogus = 1\n");
        let line = text.lines().position(|l| l == "bogus = 1").unwrap() + 1;
        match ParamsFile::from_toml_str(&text).unwrap_err() {
            ParamsFileError::Syntax {
                line: l, message, ..
            } => {
                assert_eq!(l, line);
                assert!(message.contains("bogus"), "{message}");
            }
            e => panic!("unexpected {e}"),
        }
    }

    #[test]
    fn newer_schema_and_foreign_files_are_refused() {
        let text = sample()
            .to_toml_string()
            .replace("schema_version = 1", "schema_version = 2\nnew_key = 3");
        assert!(matches!(
            ParamsFile::from_toml_str(&text),
            Err(ParamsFileError::NewerSchema { found: 2, .. })
        ));
        assert!(matches!(
            ParamsFile::from_toml_str("schema = \"other\"\n"),
            Err(ParamsFileError::Schema { .. })
        ));
    }

    #[test]
    fn generic_fit_is_not_a_thrust_curve() {
        let mut f = sample();
        f.curve.x = "rpm".into();
        assert!(matches!(
            f.to_params(),
            Err(ParamsFileError::NotAThrustCurve { .. })
        ));
    }

    #[test]
    fn total_kg_must_agree_with_the_per_rotor_limit() {
        let text = sample()
            .to_toml_string()
            .replace("total_kg = 0.6", "total_kg = 0.9");
        let line = text.lines().position(|l| l == "total_kg = 0.9").unwrap() + 1;
        match ParamsFile::from_toml_str(&text).unwrap_err() {
            ParamsFileError::Syntax {
                line: l,
                column,
                message,
                ..
            } => {
                assert_eq!((l, column), (line, 12));
                assert!(
                    message.contains("contradicts per_rotor_g × rotor_count = 150 g × 4 = 0.6 kg"),
                    "{message}"
                );
            }
            e => panic!("unexpected {e}"),
        }
    }

    #[test]
    fn uncertainties_are_finite_and_not_negative() {
        for bad in ["nan", "-0.5", "inf"] {
            let text = sample()
                .to_toml_string()
                .replace("uncertainty_g = 0.5", &format!("uncertainty_g = {bad}"));
            let e = ParamsFile::from_toml_str(&text).unwrap_err().to_string();
            assert!(
                e.contains("uncertainty_g") && e.contains("finite number ≥ 0"),
                "{e}"
            );
            assert!(e.contains("line "), "{e}");
        }
        let mut f = sample();
        f.fit.coefficient_std_errors_scaled[1] = -0.1;
        let e = ParamsFile::from_toml_str(&f.to_toml_string())
            .unwrap_err()
            .to_string();
        assert!(e.contains("coefficient_std_errors_scaled[1]"), "{e}");
    }

    #[test]
    fn degree_mismatch_is_reported() {
        let mut f = sample();
        f.curve.degree = 5;
        let text = f.to_toml_string();
        assert!(matches!(
            ParamsFile::from_toml_str(&text),
            Err(ParamsFileError::DegreeMismatch {
                degree: 5,
                len: 3,
                ..
            })
        ));
    }
}
