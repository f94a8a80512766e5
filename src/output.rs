//! Presentation helpers shared by the subcommands: unit-aware flag parsing, the model flags,
//! plain-text tables, JSON printing and atomic file writes.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use estimator::file::ParamsFile;
use estimator::{Model, Payload, Platform, PolyCurve};

/// Parses a number with an optional unit suffix, scaled into the flag's unit.
///
/// `units` maps accepted suffixes to the factor into the flag's unit; the first entry is the
/// flag's own unit. A bare number is taken in the flag's own unit.
fn with_unit(s: &str, units: &[(&str, f64)]) -> Result<f64, String> {
    let t = s.trim();
    if let Ok(v) = t.parse::<f64>() {
        return if v.is_finite() {
            Ok(v)
        } else {
            Err(format!("{s:?} is not a finite number"))
        };
    }
    let split = t
        .find(|c: char| c.is_alphabetic() || c == '/')
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let v: f64 = num
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number (optionally followed by a unit)"))?;
    if !v.is_finite() {
        return Err(format!("{s:?} is not a finite number"));
    }
    let unit = unit.trim();
    if unit.is_empty() {
        return Ok(v);
    }
    units
        .iter()
        .find(|(u, _)| u.eq_ignore_ascii_case(unit))
        .map(|(_, f)| v * f)
        .ok_or_else(|| {
            let names: Vec<_> = units.iter().map(|(u, _)| *u).collect();
            format!("unknown unit {unit:?}: use {}", names.join(", "))
        })
}

fn non_negative(v: f64, s: &str) -> Result<f64, String> {
    if v < 0.0 {
        Err(format!("{s:?} is negative"))
    } else {
        Ok(v)
    }
}

fn positive(v: f64, s: &str) -> Result<f64, String> {
    if v <= 0.0 {
        Err(format!("{s:?} must be greater than zero"))
    } else {
        Ok(v)
    }
}

/// A mass in kg (`0.431`, `0.431kg`, `431g`), not negative.
pub fn mass_kg(s: &str) -> Result<f64, String> {
    non_negative(with_unit(s, &[("kg", 1.0), ("g", 1e-3)])?, s)
}

/// A mass in kg that must be positive.
pub fn positive_mass_kg(s: &str) -> Result<f64, String> {
    positive(mass_kg(s)?, s)
}

/// A power in W (`2.44`, `2.44W`, `500mW`), not negative.
pub fn power_w(s: &str) -> Result<f64, String> {
    non_negative(with_unit(s, &[("W", 1.0), ("mW", 1e-3)])?, s)
}

/// An energy density in Wh/kg, positive.
pub fn energy_density(s: &str) -> Result<f64, String> {
    positive(with_unit(s, &[("Wh/kg", 1.0)])?, s)
}

/// An energy in Wh, positive.
pub fn energy_wh(s: &str) -> Result<f64, String> {
    positive(with_unit(s, &[("Wh", 1.0), ("mWh", 1e-3)])?, s)
}

/// A fraction 0..1, given as `0.1` or `10%`.
pub fn fraction(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let v = if let Some(p) = t.strip_suffix('%') {
        with_unit(p, &[])? / 100.0
    } else {
        with_unit(t, &[])?
    };
    if (0.0..1.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "{s:?} must be a fraction from 0 up to 1 (or 0% to 100%)"
        ))
    }
}

/// The flags that describe the robot and where its thrust curve comes from.
#[derive(Debug, Clone, clap::Args)]
pub struct ModelArgs {
    /// Rig characterisation (params.toml from `hoverbench fit` or `characterise`).
    #[arg(long, value_name = "FILE", required_unless_present = "paper")]
    pub params: Option<PathBuf>,
    /// Use the paper's platform: its reconstructed Fig. 3 curve (fitted as in the paper), its
    /// implied thrust limit (0.600 kg) and, unless given, its structure mass and avionics power.
    #[arg(long, conflicts_with = "params")]
    pub paper: bool,
    /// m_S: structure mass without battery (kg; or e.g. 431g).
    #[arg(long, value_name = "MASS", value_parser = mass_kg, allow_negative_numbers = true, required_unless_present = "paper")]
    pub structure_mass: Option<f64>,
    /// p_A: avionics power (W).
    #[arg(long, value_name = "POWER", value_parser = power_w, allow_negative_numbers = true, required_unless_present = "paper")]
    pub avionics_power: Option<f64>,
    /// m_P: payload mass (kg).
    #[arg(long, value_name = "MASS", value_parser = mass_kg, allow_negative_numbers = true, default_value = "0")]
    pub payload_mass: f64,
    /// p_P: payload power (W).
    #[arg(long, value_name = "POWER", value_parser = power_w, allow_negative_numbers = true, default_value = "0")]
    pub payload_power: f64,
    /// Override the thrust limit m_L, total over all rotors (kg).
    #[arg(long, value_name = "MASS", value_parser = positive_mass_kg, allow_negative_numbers = true)]
    pub thrust_limit: Option<f64>,
}

/// Where the model came from, for the output's first lines.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ModelSource {
    /// `paper` or the params file path.
    pub curve: String,
    /// How the thrust limit was obtained.
    pub thrust_limit: String,
}

impl ModelArgs {
    /// Builds the estimator model and payload the flags describe.
    pub fn build(&self) -> Result<(Model<PolyCurve>, Payload, ModelSource)> {
        let (mut model, curve_src) = if let Some(path) = &self.params {
            let file = ParamsFile::load(path)?;
            let params = file
                .to_params()
                .with_context(|| format!("{} cannot drive the estimator", path.display()))?;
            let model = params.model(
                self.structure_mass.unwrap_or_default(),
                self.avionics_power.unwrap_or_default(),
            );
            (model, path.display().to_string())
        } else if self.paper {
            let (_, curve) = paper::fitted_curve()?;
            let mut m = paper::paper_model(curve);
            m.platform = Platform {
                structure_mass_kg: self.structure_mass.unwrap_or(paper::STRUCTURE_MASS_KG),
                avionics_power_w: self.avionics_power.unwrap_or(paper::AVIONICS_POWER_W),
                rotor_count: paper::ROTOR_COUNT,
            };
            (m, "the paper's reconstructed Fig. 3 curve".to_owned())
        } else {
            bail!("no thrust curve: pass --params params.toml (from `hoverbench fit`) or --paper");
        };
        let limit_src = match (self.thrust_limit, model.thrust_limit_kg) {
            (Some(l), _) => {
                model.thrust_limit_kg = Some(l);
                "given with --thrust-limit".to_owned()
            }
            (None, Some(_)) if self.paper => {
                "implied by the paper's realistic optimum (its 9.0 V sweep is unpublished)".into()
            }
            (None, Some(_)) => "measured (params file)".to_owned(),
            (None, None) => "unknown: no payload limit applied".to_owned(),
        };
        model.validate()?;
        let payload = Payload {
            mass_kg: self.payload_mass,
            power_w: self.payload_power,
        };
        Ok((
            model,
            payload,
            ModelSource {
                curve: curve_src,
                thrust_limit: limit_src,
            },
        ))
    }
}

/// How to read a thrust-stand log: column mapping, names for headerless files, row filters.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct StandArgs {
    /// Thrust column [default: detected: thrust_g, "Thrust (gf)", thrust_n, a scale's weight
    /// column, …]. Units come from the name: g, gf, kg, kgf, N, lbf, ozf.
    #[arg(long, value_name = "COL")]
    pub thrust: Option<String>,
    /// Voltage column [default: detected: voltage_v, "Voltage (V)", a power monitor's v, …].
    #[arg(long, value_name = "COL")]
    pub voltage: Option<String>,
    /// Current column [default: detected].
    #[arg(long, value_name = "COL")]
    pub current: Option<String>,
    /// Electrical power column [default: detected, else voltage × current].
    #[arg(long, value_name = "COL")]
    pub power: Option<String>,
    /// Throttle / ESC command column [default: detected].
    #[arg(long, value_name = "COL")]
    pub throttle: Option<String>,
    /// Names for the columns of a file without a header row, comma-separated (units in the
    /// names: esc_us,torque_nm,thrust_n,rpm,current_a).
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub columns: Option<Vec<String>>,
    /// Keep only rows where COLUMN equals VALUE (repeatable), e.g. --where "propeller=DJI plastic 9450".
    #[arg(long = "where", value_name = "COLUMN=VALUE")]
    pub filters: Vec<import::stand::RowFilter>,
}

impl StandArgs {
    /// The importer's options.
    pub fn options(&self) -> import::stand::StandOptions {
        import::stand::StandOptions {
            columns: import::stand::ColumnMap {
                thrust: self.thrust.clone(),
                voltage: self.voltage.clone(),
                current: self.current.clone(),
                power: self.power.clone(),
                throttle: self.throttle.clone(),
                ..Default::default()
            },
            names: self.columns.clone(),
            filters: self.filters.clone(),
        }
    }
}

/// A whole number ≥ 1 (`--scenarios`, `--threads`).
pub fn at_least_one(s: &str) -> Result<u64, String> {
    match s.trim().parse::<u64>() {
        Ok(n) if n >= 1 => Ok(n),
        Ok(_) => Err(format!("{s:?} must be at least 1")),
        Err(_) => Err(format!("{s:?} is not a whole number ≥ 1")),
    }
}

/// [`at_least_one`] as a `usize`.
pub fn at_least_one_usize(s: &str) -> Result<usize, String> {
    at_least_one(s).and_then(|n| usize::try_from(n).map_err(|_| format!("{s:?} is too large")))
}

/// `ohm` as a resistance a flag may take (finite, 0 or more), or an error naming `flag`.
pub fn require_ohms(flag: &str, ohm: f64) -> Result<()> {
    if ohm.is_finite() && ohm >= 0.0 {
        Ok(())
    } else {
        anyhow::bail!("{flag} takes a resistance in ohms, 0 or more; got {ohm}")
    }
}

/// One past the last seed of a study of `scenarios` seeds from `first` (`--seed`,
/// `--scenarios`), refused when it would pass the largest seed.
pub fn seed_end(first: u64, scenarios: u64) -> Result<u64> {
    first.checked_add(scenarios).ok_or_else(|| {
        anyhow::anyhow!(
            "seeds {first} + {scenarios} scenarios run past the largest seed ({}): start lower",
            u64::MAX
        )
    })
}

/// Prints a value as pretty JSON on stdout.
pub fn print_json(value: &impl serde::Serialize) -> Result<()> {
    println!("{}", serde_json::to_string_pretty(value)?);
    Ok(())
}

/// A plain-text table: a header and rows, columns padded; numbers right-aligned.
#[derive(Debug, Default)]
pub struct Table {
    rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with a header row.
    pub fn new(header: &[&str]) -> Self {
        Self {
            rows: vec![header.iter().map(|s| (*s).to_owned()).collect()],
        }
    }

    /// Adds a row.
    pub fn row(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }

    /// Renders the table, two spaces between columns, a rule under the header.
    pub fn render(&self) -> String {
        let cols = self.rows.iter().map(Vec::len).max().unwrap_or(0);
        let width = |c: usize| {
            self.rows
                .iter()
                .filter_map(|r| r.get(c))
                .map(|s| s.chars().count())
                .max()
                .unwrap_or(0)
        };
        let widths: Vec<usize> = (0..cols).map(width).collect();
        let mut out = String::new();
        for (i, row) in self.rows.iter().enumerate() {
            let mut line = String::new();
            for (c, cell) in row.iter().enumerate() {
                let numeric = i > 0
                    && c > 0
                    && cell
                        .chars()
                        .next()
                        .is_some_and(|ch| ch.is_ascii_digit() || ch == '-' || ch == '+');
                let pad = widths[c] - cell.chars().count();
                if c > 0 {
                    line.push_str("  ");
                }
                if numeric {
                    line.push_str(&" ".repeat(pad));
                    line.push_str(cell);
                } else {
                    line.push_str(cell);
                    if c + 1 < row.len() {
                        line.push_str(&" ".repeat(pad));
                    }
                }
            }
            let _ = writeln!(out, "{}", line.trim_end());
            if i == 0 {
                let total: usize = widths.iter().sum::<usize>() + 2 * cols.saturating_sub(1);
                let _ = writeln!(out, "{}", "-".repeat(total));
            }
        }
        out
    }
}

/// Writes a file atomically (`outfile::write_atomic`: a temporary file beside it, fsync,
/// rename; the temporary file is removed on error).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    Ok(outfile::write_atomic(path, bytes)?)
}

/// [`write_atomic`], refusing a target that is the same file as one of `inputs` (so that
/// `import X -o X` cannot overwrite its input).
pub fn write_atomic_checked(path: &Path, bytes: &[u8], inputs: &[PathBuf]) -> Result<()> {
    Ok(outfile::write_atomic_checked(path, bytes, inputs)?)
}

/// What the replayed flights carried, beside the online estimator's configuration.
#[derive(Debug, Clone, Copy, Default)]
pub struct ReplayInputs {
    /// Each pack's measured capacity carried to its next flight.
    pub pack_history: bool,
    /// Held-out flights replayed without their current column.
    pub voltage_only: bool,
    /// The rotors' power read from the motor commands (`--motor-power`).
    pub motor_power: bool,
}

/// What the online estimator ran with, in words: the defaults, or the opt-ins and the band
/// (`replay` and `replay-eval` print it first).
pub fn online_settings_line(c: &estimator::online::OnlineConfig, inputs: ReplayInputs) -> String {
    let mut on = Vec::new();
    if c.input_average_s > 0.0 {
        on.push(format!("samples averaged over {} s", c.input_average_s));
    }
    if c.thrust_limit_end {
        on.push("the thrust-limit end (flights with a current)".to_owned());
    }
    if c.zero_current {
        on.push("the current sensor's zero read before take-off".to_owned());
    }
    if c.extra_resistance_sigma_ohm > 0.0 {
        on.push(format!(
            "an extra series resistance of {} ohm (one sigma) on flights without a current",
            c.extra_resistance_sigma_ohm
        ));
    }
    let resync = c.resync_resistance_sigma_ohm;
    if resync != estimator::online::OnlineConfig::default().resync_resistance_sigma_ohm {
        on.push(if resync > 0.0 {
            format!("the resistance reopened to {resync} ohm (one sigma) at a run of low voltages")
        } else {
            "the resistance never reopened at a run of low voltages".to_owned()
        });
    }
    if inputs.pack_history {
        on.push("the packs' history".to_owned());
    }
    if inputs.voltage_only {
        on.push("held-out flights without their current".to_owned());
    }
    if inputs.motor_power {
        on.push("the rotors' power from the motor commands".to_owned());
    }
    if on.is_empty() {
        "online estimator: the defaults".to_owned()
    } else if inputs.motor_power {
        format!(
            "online estimator: {}; band end_soc_sigma {} ({} once the motor commands measure the power)",
            on.join(", "),
            c.end_soc_sigma,
            c.end_soc_sigma_with_motor_power()
        )
    } else {
        format!(
            "online estimator: {}; band end_soc_sigma {}",
            on.join(", "),
            c.end_soc_sigma
        )
    }
}

/// The same as JSON: `input_average_s`, `thrust_limit_end`, `zero_current`,
/// `extra_resistance_sigma_ohm`, `resync_resistance_sigma_ohm`, `end_soc_sigma`, `end_soc_sigma_motor_cut`,
/// `motor_power_sigma_fraction`, `pack_history`, `voltage_only`, `motor_power`.
pub fn online_settings_json(
    c: &estimator::online::OnlineConfig,
    inputs: ReplayInputs,
) -> serde_json::Value {
    serde_json::json!({
        "input_average_s": c.input_average_s,
        "thrust_limit_end": c.thrust_limit_end,
        "zero_current": c.zero_current,
        "extra_resistance_sigma_ohm": c.extra_resistance_sigma_ohm,
        "resync_resistance_sigma_ohm": c.resync_resistance_sigma_ohm,
        "end_soc_sigma": c.end_soc_sigma,
        "end_soc_sigma_motor_cut": c.end_soc_sigma_motor_cut,
        "motor_power_sigma_fraction": c.motor_power_sigma_fraction,
        "pack_history": inputs.pack_history,
        "voltage_only": inputs.voltage_only,
        "motor_power": inputs.motor_power,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units() {
        assert_eq!(mass_kg("431g").unwrap(), 0.431);
        assert_eq!(mass_kg("0.5 kg").unwrap(), 0.5);
        assert_eq!(mass_kg("2").unwrap(), 2.0);
        assert!(mass_kg("-1").unwrap_err().contains("negative"));
        assert!(mass_kg("3 lb").unwrap_err().contains("unknown unit"));
        assert!(mass_kg("NaN").is_err());
        assert_eq!(energy_density("164Wh/kg").unwrap(), 164.0);
        assert!(
            energy_density("0")
                .unwrap_err()
                .contains("greater than zero")
        );
        assert_eq!(fraction("10%").unwrap(), 0.1);
        assert!(fraction("1.5").is_err());
        assert_eq!(power_w("500mW").unwrap(), 0.5);
    }

    #[test]
    fn table_alignment() {
        let mut t = Table::new(&["what", "value"]);
        t.row(vec!["a".into(), "1.5".into()]);
        t.row(vec!["longer".into(), "10.25".into()]);
        assert_eq!(
            t.render(),
            "what    value\n-------------\na         1.5\nlonger  10.25\n"
        );
    }
}
