//! `hoverbench battery learn`: the pack model learned from flights (the gap diagnosis's
//! battery fit) stored as the `[battery]` section of a parameter file, for the online
//! estimator and `hoverbench replay`.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::builder::PossibleValue;
use estimator::file::ParamsFile;
use flightlog::FlightSet;
use flightlog::summary::error_chain;
use gap::battery::Chemistry;

/// A chemistry prior as `--chemistry` takes it: the values are the names of
/// [`Chemistry::PRIORS`], so help and errors list exactly what is accepted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChemistryArg(pub Chemistry);

/// Every prior, in [`Chemistry::PRIORS`]' order.
const CHEMISTRY_ARGS: [ChemistryArg; Chemistry::PRIORS.len()] = {
    let mut out = [ChemistryArg(Chemistry::PRIORS[0]); Chemistry::PRIORS.len()];
    let mut i = 1;
    while i < out.len() {
        out[i] = ChemistryArg(Chemistry::PRIORS[i]);
        i += 1;
    }
    out
};

impl clap::ValueEnum for ChemistryArg {
    fn value_variants<'a>() -> &'a [Self] {
        &CHEMISTRY_ARGS
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(PossibleValue::new(self.0.name()))
    }
}

/// The pack model of a parameter file.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: Sub,
}

#[derive(Debug, clap::Subcommand)]
enum Sub {
    /// Learn the pack's open-circuit curve, series resistance and RC pair from flights of one
    /// pack type and write them into the parameter file's `[battery]` section (the file is
    /// rewritten atomically; its other sections are kept).
    Learn(LearnArgs),
}

#[derive(Debug, clap::Args)]
struct LearnArgs {
    /// The parameter file (its rig curve gives the power when no current is logged).
    #[arg(long, value_name = "FILE")]
    params: PathBuf,
    /// Flight logs or folders of flight logs of the pack (nominal flights: no known fault).
    #[arg(required = true, value_name = "FLIGHTS")]
    flights: Vec<PathBuf>,
    /// The pack type to learn when the flights hold several: its `battery_id`, else cells and
    /// rated energy as `NS E Wh` (e.g. "3S 23.6 Wh").
    #[arg(long, value_name = "TYPE")]
    battery_type: Option<String>,
    /// Pin the chemistry prior.
    #[arg(long, value_enum)]
    chemistry: Option<ChemistryArg>,
    /// Print the section as JSON instead of a summary.
    #[arg(long)]
    json: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> Result<()> {
    match args.command {
        Sub::Learn(a) => learn(a),
    }
}

fn learn(a: LearnArgs) -> Result<()> {
    let mut file = ParamsFile::load(&a.params)?;
    let params = file
        .to_params()
        .with_context(|| format!("{} cannot drive the estimator", a.params.display()))?;
    let chemistry = a.chemistry.map(|c| c.0);
    let set = FlightSet::read_paths(&a.flights)?;
    for s in &set.skipped {
        eprintln!("skipped {}: {}", s.path.display(), s.why());
    }
    let mut records = Vec::new();
    for f in &set.flights {
        match gap::logs::record_from_log(f) {
            Ok(r) => records.push(r),
            Err(e) => eprintln!("skipped {}: {}", f.name, error_chain(&e)),
        }
    }
    if records.is_empty() {
        bail!("no flight could be read with the metadata the battery fit needs");
    }
    let model = gap::model::Model {
        curve: &params.curve,
        rotor_count: params.rotor_count,
    };
    let learned =
        gap::params_link::learn_section(model, &records, a.battery_type.as_deref(), chemistry)?;
    learned
        .section
        .to_model()
        .map_err(|(key, msg)| anyhow::anyhow!("the learned battery is not valid ({key}): {msg}"))?;
    file.battery = Some(learned.section.clone());
    outfile::write_atomic(&a.params, file.to_toml_string().as_bytes())?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "params": a.params,
                "battery": learned.section,
                "fit": learned.fit,
            }))?
        );
    } else {
        let s = &learned.section;
        println!(
            "[battery] of {}: {} cells, {:.3} Ah rated, chemistry {}, OCV {:.3}–{:.3} V/cell, R0 {:.1} mΩ/cell, RC {:.1} mΩ × {:.0} s, cut-off {:.2} V/cell",
            a.params.display(),
            s.cells,
            s.rated_capacity_ah.unwrap_or(f64::NAN),
            s.chemistry,
            s.ocv_cell_v.first().copied().unwrap_or(f64::NAN),
            s.ocv_cell_v.last().copied().unwrap_or(f64::NAN),
            s.series_resistance_cell_ohm * 1000.0,
            s.rc_resistance_cell_ohm * 1000.0,
            s.rc_time_constant_s,
            s.cutoff_cell_v
        );
        println!("{}", s.source);
        if !learned.fit.note.is_empty() {
            println!("note: {}", learned.fit.note);
        }
    }
    // What the flights could not teach (also in `--json`: `fit.warnings`).
    for w in &learned.fit.warnings {
        eprintln!("warning: {w}");
    }
    Ok(())
}
