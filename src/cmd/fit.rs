//! `hoverbench fit`: a least-squares polynomial through a rig sweep (or any CSV), written as
//! `params.toml`.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use fit::sweeps::{LimitSweep, NominalSweep, SweepFitOptions, fit_sweeps};
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
    /// Supply voltage of the sweep, V [default: mean of its voltage column]; with a log that has
    /// current but no voltage, power is taken as this voltage × current.
    #[arg(long, value_name = "V")]
    volts: Option<f64>,
    /// Supply voltage of the limit sweep, V [default: mean of its voltage column].
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
    /// The motor map (power from ESC command and supply voltage), when both sweeps gave one.
    #[serde(skip_serializing_if = "Option::is_none")]
    motor_map: Option<fit::sweeps::MotorMapSummary>,
    /// Why there is none (also said as a note).
    #[serde(skip_serializing_if = "Option::is_none")]
    motor_map_skipped: Option<String>,
    written: Vec<String>,
}

fn generic_data(args: &Args, x: &str, y: &str) -> Result<NominalSweep> {
    let (table, bytes) = Table::read(&args.file)?;
    let xy = table.xy(x, &YSource::Column(y.to_owned()))?;
    let volts = match args.volts {
        Some(v) => Some(v),
        None if table.has("voltage_v") => {
            let v = table.column("voltage_v")?;
            Some(v.iter().sum::<f64>() / v.len() as f64)
        }
        None => None,
    };
    Ok(NominalSweep::generic(
        xy,
        volts,
        &args.file.display().to_string(),
        &bytes,
    )?)
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    if args.output.is_none() && args.blob.is_some() {
        bail!("--blob needs -o params.toml too: the blob is written beside the canonical file");
    }
    let data = match (&args.x, &args.y) {
        (Some(x), Some(y)) => generic_data(&args, x, y)?,
        _ => {
            let log = StandLog::read(&args.file, &args.stand.options())?;
            NominalSweep::from_stand(&log, args.volts)?
        }
    };
    let limit = match &args.limit {
        None => None,
        Some(path) => {
            let log = StandLog::read(path, &StandOptions::default())?;
            Some(LimitSweep::from_stand(&log, args.limit_volts)?)
        }
    };
    let opts = SweepFitOptions {
        degree: args.degree,
        rotors: args.rotors,
        tool: format!("hoverbench {}", env!("CARGO_PKG_VERSION")),
        created: humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string(),
        motor_degree: fit::motor::DEFAULT_MOTOR_DEGREE,
    };
    let done = fit_sweeps(&data, limit.as_ref(), &opts)?;
    let (file, fitted) = (&done.params, &done.fit);

    // Everything is computed and checked before anything is written.
    let mut outputs = Vec::new();
    if let Some(path) = &args.output {
        outputs.push((path.clone(), file.to_toml_string().into_bytes()));
    }
    if let Some(path) = &args.blob {
        let params = file
            .to_params()
            .with_context(|| format!("--blob {}", path.display()))?;
        let mut buf = [0u8; estimator::params::MAX_BLOB_LEN];
        let n = params.encode(&mut buf)?;
        outputs.push((path.clone(), buf[..n].to_vec()));
    }
    let mut inputs = vec![args.file.clone()];
    inputs.extend(args.limit.iter().cloned());
    let mut written = Vec::new();
    for (path, bytes) in &outputs {
        output::write_atomic_checked(path, bytes, &inputs)?;
        written.push(path.display().to_string());
    }

    let stats = fitted.stats();
    let rep = Report {
        input: args.file.display().to_string(),
        log_kind: data.kind,
        notes: done.notes.clone(),
        x: &data.x_name,
        y: &data.y_label,
        degree: fitted.degree(),
        coefficients: fitted.monomial_coefficients(),
        coefficients_scaled: fitted.coeffs_scaled(),
        center: fitted.center(),
        scale: fitted.scale(),
        valid_range: done.summary.valid_range_g,
        n_points: stats.n_points,
        skipped_invalid_rows: data.skipped_invalid,
        rmse: stats.rmse,
        r_squared: stats.r_squared,
        max_abs_residual: stats.max_residual.map(|m| m.abs_value),
        max_residual_at: stats.max_residual.map(|m| m.x),
        condition_number: stats.condition_number,
        coefficient_std_errors: stats.std_errors_monomial.as_deref(),
        warnings: file.fit.warnings.clone(),
        thrust_limit: file.thrust_limit.as_ref().map(|l| LimitJson {
            per_rotor_g: l.per_rotor_g,
            uncertainty_g: l.uncertainty_g,
            total_kg: l.total_kg,
            supply_voltage_v: Some(l.supply_voltage_v),
            method: l.method.clone(),
        }),
        motor_map: done.summary.motor_map.clone(),
        motor_map_skipped: done.summary.motor_map_skipped.clone(),
        written,
    };
    if args.json {
        return output::print_json(&rep);
    }
    print_human(&rep);
    Ok(())
}

/// `n` and a noun, in the singular for one (`1 row`, `3 rows`).
fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// Decimals that show a quantity spanning `span` to about four significant digits.
fn decimals_for(span: f64) -> usize {
    if !(span.is_finite() && span > 0.0) {
        return 3;
    }
    (3.0 - span.log10().floor()).clamp(0.0, 12.0) as usize
}

/// `v` with `d` decimals, never a negative zero.
fn fixed(v: f64, d: usize) -> String {
    let s = format!("{v:.d$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_owned()
    } else {
        s
    }
}

fn print_human(rep: &Report<'_>) {
    println!("{} ({})", rep.input, rep.log_kind);
    // What was assumed about the log and what to watch for goes to stderr: stdout is the result.
    for n in &rep.notes {
        eprintln!("note: {n}");
    }
    println!(
        "{} = p({}), degree {}, {}{}",
        rep.y,
        rep.x,
        rep.degree,
        count(rep.n_points, "point"),
        if rep.skipped_invalid_rows > 0 {
            format!(
                " ({} marked invalid {} skipped)",
                count(rep.skipped_invalid_rows, "row"),
                if rep.skipped_invalid_rows == 1 {
                    "was"
                } else {
                    "were"
                }
            )
        } else {
            String::new()
        }
    );
    let d = decimals_for(rep.valid_range.1 - rep.valid_range.0);
    println!(
        "valid over {} = {} .. {}",
        rep.x,
        fixed(rep.valid_range.0, d),
        fixed(rep.valid_range.1, d)
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
            (Some(r), Some(x)) => format!("{r:.4e} at {} = {}", rep.x, fixed(x, d)),
            _ => "-".into(),
        },
        rep.condition_number
    );
    // A warning the fit also gave as a note (a tare offset) was printed above.
    for w in rep.warnings.iter().filter(|w| !rep.notes.contains(w)) {
        eprintln!("warning: {w}");
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
    if let Some(m) = &rep.motor_map {
        println!("{}", m.line());
    }
    for w in &rep.written {
        println!("wrote {w}");
    }
}
