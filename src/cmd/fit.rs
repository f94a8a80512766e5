//! `hoverbench fit`: a least-squares polynomial through a rig sweep (or any CSV), written as
//! `params.toml`.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use estimator::file::Provenance;
use fit::export::{CurveLabels, LimitRecord};
use import::stand::{StandLog, StandOptions};
use import::{Table, YSource};

use crate::output::{self, StandArgs, Table as TextTable};

/// Fit electrical power against thrust from a rig sweep — hoverbench's own, a Tyto
/// RCbenchmark / Flight Stand export, or any table of thrust, voltage, current (or power) — or
/// fit any two named columns of a CSV (--x/--y), and write params.toml.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The sweep (CSV or whitespace-separated; step tests are reduced to settled steps).
    file: PathBuf,
    #[command(flatten)]
    stand: StandArgs,
    /// Generic fit: abscissa column, taken as it is (no unit conversion, no step reduction).
    #[arg(long, value_name = "COL", requires = "y")]
    x: Option<String>,
    /// Generic fit: ordinate column.
    #[arg(long, value_name = "COL", requires = "x")]
    y: Option<String>,
    /// Polynomial degree.
    #[arg(long, value_name = "N", default_value_t = fit::DEFAULT_DEGREE)]
    degree: usize,
    /// A sweep taken at the minimum battery voltage (columns throttle, thrust_g, optional
    /// thrust_std_g); its sustained maximum thrust gives the thrust limit m_L.
    #[arg(long, value_name = "FILE")]
    limit: Option<PathBuf>,
    /// Rotors sharing the take-off mass.
    #[arg(long, value_name = "N", default_value_t = 4, value_parser = clap::value_parser!(u8).range(1..))]
    rotors: u8,
    /// Supply voltage of the sweep [default: mean of its voltage column]; with a log that has
    /// current but no voltage, power is taken as this voltage × current.
    #[arg(long, value_name = "V")]
    volts: Option<f64>,
    /// Supply voltage of the limit sweep [default: mean of its voltage column].
    #[arg(long, value_name = "V")]
    limit_volts: Option<f64>,
    /// Write the parameter file here.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Also write the estimator's allocation-free binary form (for firmware: include_bytes!).
    #[arg(long, value_name = "FILE")]
    blob: Option<PathBuf>,
    /// Print machine-readable JSON.
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
struct LimitJson {
    per_rotor_g: f64,
    uncertainty_g: f64,
    total_kg: f64,
    supply_voltage_v: Option<f64>,
    method: String,
}

#[derive(serde::Serialize)]
struct Report<'a> {
    input: String,
    log_kind: &'static str,
    notes: Vec<String>,
    x: &'a str,
    y: &'a str,
    degree: usize,
    /// Ascending powers of the original x.
    coefficients: Vec<f64>,
    coefficients_scaled: &'a [f64],
    center: f64,
    scale: f64,
    valid_range: (f64, f64),
    n_points: usize,
    skipped_invalid_rows: usize,
    rmse: f64,
    r_squared: f64,
    max_abs_residual: Option<f64>,
    max_residual_at: Option<f64>,
    condition_number: f64,
    coefficient_std_errors: Option<&'a [f64]>,
    warnings: Vec<String>,
    thrust_limit: Option<LimitJson>,
    written: Vec<String>,
}

/// The data to fit: x, y, their names, and what the reader did.
struct Data {
    x: Vec<f64>,
    y: Vec<f64>,
    x_name: String,
    y_name: String,
    y_label: String,
    kind: &'static str,
    notes: Vec<String>,
    skipped_invalid: usize,
    supply_voltage_v: Option<f64>,
    bytes: Vec<u8>,
}

fn positive_volts(v: Option<f64>) -> Result<Option<f64>> {
    match v {
        Some(v) if !(v.is_finite() && v > 0.0) => {
            bail!("supply voltage must be a positive number of volts, got {v}")
        }
        v => Ok(v),
    }
}

fn generic_data(args: &Args, x: &str, y: &str) -> Result<Data> {
    let (table, bytes) = Table::read(&args.file)?;
    let xy = table.xy(x, &YSource::Column(y.to_owned()))?;
    let volts = match positive_volts(args.volts)? {
        Some(v) => Some(v),
        None if table.has("voltage_v") => {
            let v = table.column("voltage_v")?;
            Some(v.iter().sum::<f64>() / v.len() as f64)
        }
        None => None,
    };
    Ok(Data {
        x: xy.x,
        y: xy.y,
        x_name: x.to_owned(),
        y_name: y.to_owned(),
        y_label: y.to_owned(),
        kind: "generic table",
        notes: Vec::new(),
        skipped_invalid: xy.skipped_invalid,
        supply_voltage_v: volts,
        bytes,
    })
}

fn stand_data(args: &Args) -> Result<Data> {
    let log = StandLog::read(&args.file, &args.stand.options())?;
    let volts = positive_volts(args.volts)?;
    let mut notes = log.notes.clone();
    let (power, source) = log.power_w(volts)?;
    if let import::stand::PowerSource::AssumedVoltage(v) = source {
        notes.push(format!(
            "no voltage logged: power taken as {v} V (--volts) × current"
        ));
    }
    Ok(Data {
        x: log.thrust_g(),
        y: power,
        x_name: "thrust_g".into(),
        y_name: "power_w".into(),
        y_label: source.label(),
        kind: log.kind.describe(),
        notes,
        skipped_invalid: log.skipped_invalid,
        supply_voltage_v: volts.or_else(|| log.mean_voltage_v()),
        bytes: log.bytes,
    })
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    if args.output.is_none() && args.blob.is_some() {
        bail!("--blob needs -o params.toml too: the blob is written beside the canonical file");
    }
    let data = match (&args.x, &args.y) {
        (Some(x), Some(y)) => generic_data(&args, x, y)?,
        _ => stand_data(&args)?,
    };
    let fitted = fit::fit_polynomial(&data.x, &data.y, args.degree).with_context(|| {
        format!(
            "fitting {} against {} in {}",
            data.y_name,
            data.x_name,
            args.file.display()
        )
    })?;
    let supply_voltage_v = data.supply_voltage_v;

    let limit = match &args.limit {
        None => None,
        Some(path) => {
            let log = StandLog::read(path, &StandOptions::default())?;
            let throttle = log.column(|s| s.throttle).with_context(|| {
                format!("{}: a limit sweep needs a throttle column", path.display())
            })?;
            let thrust = log.thrust_g();
            let std = log.column(|s| s.thrust_std_g);
            let opts = fit::ThrustLimitOptions {
                thrust_std_g: std.as_deref(),
                ..Default::default()
            };
            let l = fit::thrust_limit(&throttle, &thrust, &opts)
                .with_context(|| format!("extracting the thrust limit from {}", path.display()))?;
            let v = positive_volts(args.limit_volts)?
                .or_else(|| log.mean_voltage_v())
                .with_context(|| {
                    format!(
                        "{} has no voltage column: give --limit-volts",
                        path.display()
                    )
                })?;
            Some((
                LimitRecord {
                    limit: l,
                    supply_voltage_v: v,
                },
                path,
                log.bytes,
            ))
        }
    };

    let labels = CurveLabels {
        x: &data.x_name,
        y: &data.y_name,
        supply_voltage_v,
    };
    let provenance = Provenance {
        input_file: args.file.display().to_string(),
        input_sha256: import::sha256_hex(&data.bytes),
        limit_input_file: limit.as_ref().map(|(_, p, _)| p.display().to_string()),
        limit_input_sha256: limit.as_ref().map(|(_, _, b)| import::sha256_hex(b)),
        created: jiff::Timestamp::now().to_string(),
        tool: format!("hoverbench {}", env!("CARGO_PKG_VERSION")),
    };
    let file = fit::export::params_file(
        &fitted,
        &labels,
        args.rotors,
        limit.as_ref().map(|(l, _, _)| l),
        provenance,
    );

    // Everything is computed and checked before anything is written.
    let mut written = Vec::new();
    let blob = match &args.blob {
        Some(path) => {
            let params = file
                .to_params()
                .with_context(|| format!("--blob {}", path.display()))?;
            let mut buf = [0u8; estimator::params::MAX_BLOB_LEN];
            let n = params.encode(&mut buf)?;
            Some((path, buf[..n].to_vec()))
        }
        None => None,
    };
    if let Some(path) = &args.output {
        output::write_atomic(path, file.to_toml_string().as_bytes())?;
        written.push(path.display().to_string());
    }
    if let Some((path, bytes)) = blob {
        output::write_atomic(path, &bytes)?;
        written.push(path.display().to_string());
    }

    let stats = fitted.stats();
    let rep = Report {
        input: args.file.display().to_string(),
        log_kind: data.kind,
        notes: data.notes.clone(),
        x: &data.x_name,
        y: &data.y_label,
        degree: fitted.degree(),
        coefficients: fitted.monomial_coefficients(),
        coefficients_scaled: fitted.coeffs_scaled(),
        center: fitted.center(),
        scale: fitted.scale(),
        valid_range: fitted.domain(),
        n_points: stats.n_points,
        skipped_invalid_rows: data.skipped_invalid,
        rmse: stats.rmse,
        r_squared: stats.r_squared,
        max_abs_residual: stats.max_residual.map(|m| m.abs_value),
        max_residual_at: stats.max_residual.map(|m| m.x),
        condition_number: stats.condition_number,
        coefficient_std_errors: stats.std_errors_monomial.as_deref(),
        warnings: fitted.warnings().iter().map(ToString::to_string).collect(),
        thrust_limit: file.thrust_limit.as_ref().map(|l| LimitJson {
            per_rotor_g: l.per_rotor_g,
            uncertainty_g: l.uncertainty_g,
            total_kg: l.total_kg,
            supply_voltage_v: Some(l.supply_voltage_v),
            method: l.method.clone(),
        }),
        written,
    };
    if args.json {
        return output::print_json(&rep);
    }
    print_human(&rep);
    Ok(())
}

fn print_human(rep: &Report<'_>) {
    println!("{} ({})", rep.input, rep.log_kind);
    for n in &rep.notes {
        println!("note: {n}");
    }
    println!(
        "{} = p({}), degree {}, {} points{}",
        rep.y,
        rep.x,
        rep.degree,
        rep.n_points,
        if rep.skipped_invalid_rows > 0 {
            format!(
                " ({} rows marked invalid were skipped)",
                rep.skipped_invalid_rows
            )
        } else {
            String::new()
        }
    );
    println!(
        "valid over {} = {} .. {}",
        rep.x, rep.valid_range.0, rep.valid_range.1
    );
    println!();
    let mut t = TextTable::new(&["k", "coefficient b_k (per x^k)", "std error"]);
    for (k, b) in rep.coefficients.iter().enumerate() {
        let se = rep
            .coefficient_std_errors
            .and_then(|s| s.get(k))
            .map_or("-".to_owned(), |s| format!("{s:.3e}"));
        t.row(vec![k.to_string(), format!("{b:.9e}"), se]);
    }
    print!("{}", t.render());
    println!();
    println!(
        "RMSE {:.4e}, R² {:.8}, max |residual| {}, condition number {:.1}",
        rep.rmse,
        rep.r_squared,
        match (rep.max_abs_residual, rep.max_residual_at) {
            (Some(r), Some(x)) => format!("{r:.4e} at {} = {x}", rep.x),
            _ => "-".into(),
        },
        rep.condition_number
    );
    for w in &rep.warnings {
        println!("warning: {w}");
    }
    if let Some(l) = &rep.thrust_limit {
        println!(
            "thrust limit: {:.1} ± {:.1} g per rotor ({}) at {:.2} V → m_L = {:.3} kg",
            l.per_rotor_g,
            l.uncertainty_g,
            l.method,
            l.supply_voltage_v.unwrap_or(f64::NAN),
            l.total_kg
        );
    }
    for w in &rep.written {
        println!("wrote {w}");
    }
}
