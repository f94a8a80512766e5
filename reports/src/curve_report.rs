//! The report of a parameter file alone, without a platform: Fig. 3 (the fitted curve, its
//! measured steps and the thrust limit) and `report.html`. Fig. 4–7 need the platform's
//! structure mass and avionics power and are left out.

use std::path::Path;

use estimator::Payload;
use estimator::file::ParamsFile;
use import::Table;

use crate::session::{nominal_sweep, parameters_provenance, params_path};
use crate::{LimitMarker, ReportError, ReportFiles, ReportInput, ReportModel, Sweep};

/// Writes Fig. 3 and `report.html` for `input` (a session folder or a `params.toml`) into
/// `output`. The measured steps come from `sweep`, else the session's `sweep.csv`, else the
/// params file's `provenance.input_file` (as recorded, or beside the params file).
pub fn write_curve_report(
    input: &Path,
    sweep: Option<&Path>,
    output: &Path,
    written_by: &str,
) -> Result<ReportFiles, ReportError> {
    let params_path = params_path(input);
    let file = ParamsFile::load(&params_path)?;
    let params = file.to_params()?;
    let sweep_path = nominal_sweep(input, sweep, &params_path, &file);
    let mut provenance = vec![parameters_provenance(&params_path, &file)];
    let sweep = match &sweep_path {
        Some(path) => {
            let (t, bytes) = Table::read(path)?;
            provenance.push((
                "sweep".into(),
                format!(
                    "{} (SHA-256 {})",
                    path.display(),
                    import::sha256_hex(&bytes)
                ),
            ));
            Some(Sweep::from_table(&t, &path.display().to_string())?)
        }
        None => {
            provenance.push((
                "sweep".into(),
                "not found: Fig. 3 shows the fitted curve alone".into(),
            ));
            None
        }
    };
    provenance.push((
        "platform".into(),
        "not given: Fig. 4 (endurance vs battery mass), Fig. 5 (catalogue), Fig. 6 (payload) and the mission timeline need --structure-mass and --avionics-power".into(),
    ));
    provenance.push(("report".into(), written_by.to_owned()));
    let input = ReportInput {
        title: format!("hoverbench report: {}", input.display()),
        // No platform: the HTML says so, and only Fig. 3 is drawn.
        model: ReportModel::curve_only(&params),
        payload: Payload::default(),
        sweep,
        thrust_limit: params.thrust_limit.map(LimitMarker::from),
        energy_density_wh_per_kg: None,
        catalogue: Vec::new(),
        payload_study: None,
        flights: Vec::new(),
        mission: None,
        comparisons: Vec::new(),
        provenance,
    };
    crate::write_report(&input, output)
}
