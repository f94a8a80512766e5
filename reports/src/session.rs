//! The report of a characterisation: a session folder (or a `params.toml`) with its sweeps, a
//! battery catalogue, measured flights and a mission plan, assembled into a [`ReportInput`] and
//! written.

use std::path::{Path, PathBuf};

use estimator::file::ParamsFile;
use estimator::{Battery, Eq8Form, MissionOptions, Payload};
use fit::sweeps::LimitSweep;
use import::Table;
use import::stand::{StandLog, StandOptions};

use crate::{
    LimitMarker, MeasuredFlight, MissionInput, NamedBattery, PayloadStudy, ReportError,
    ReportFiles, ReportInput, Sweep,
};

/// What to draw a report of.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionReport {
    /// A session folder (params.toml, optional sweep.csv and limit.csv) or a params.toml file.
    pub input: PathBuf,
    /// Folder to write the figures and report.html into.
    pub output: PathBuf,
    /// The nominal sweep [default: the session's sweep.csv, else the params file's
    /// provenance.input_file, as recorded or beside the params file].
    pub sweep: Option<PathBuf>,
    /// Battery catalogue for Fig. 5.
    pub catalogue: Option<PathBuf>,
    /// Mission plan for the timeline.
    pub plan: Option<String>,
    /// Measured flights for Fig. 6.
    pub flights: Option<PathBuf>,
    /// `m_S`, kg [default: the session's `platform.toml`].
    pub structure_mass_kg: Option<f64>,
    /// `p_A`, W [default: the session's `platform.toml`].
    pub avionics_power_w: Option<f64>,
    /// Payload for Fig. 4, Fig. 5 and the mission.
    pub payload: Payload,
    /// Overrides the thrust limit `m_L`, kg.
    pub thrust_limit_kg: Option<f64>,
    /// `e_D` of Fig. 4's batteries [default: the paper's 164 Wh/kg].
    pub energy_density_wh_per_kg: Option<f64>,
    /// A battery (mass kg, Wh/kg) to fly the mission and draw in Fig. 6 [default: the best
    /// catalogue pack].
    pub battery: Option<(f64, f64)>,
    /// Payload powers of Fig. 6's lines, W.
    pub payload_powers_w: Vec<f64>,
    /// Form of eq. (8) for the mission.
    pub eq8: Eq8Form,
    /// Who wrote the report and when, for the provenance table.
    pub written_by: String,
}

/// The platform a session was characterised for, stored in the session folder as
/// `platform.toml` so that `hoverbench report SESSION` needs no `--structure-mass` or
/// `--avionics-power`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionPlatform {
    /// `m_S`: structure mass without battery, kg.
    pub structure_mass_kg: f64,
    /// `p_A`: avionics power, W.
    pub avionics_power_w: f64,
    /// A battery's mass, kg, for the mission and Fig. 6.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub battery_mass_kg: Option<f64>,
    /// Its energy density, Wh/kg.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub battery_energy_density_wh_per_kg: Option<f64>,
}

impl SessionPlatform {
    /// The file in a session folder.
    pub const FILE: &'static str = "platform.toml";

    /// The TOML text of `platform.toml`.
    pub fn to_toml_string(&self) -> String {
        let body = toml::to_string_pretty(self).unwrap_or_else(|e| format!("# {e}\n"));
        format!(
            "# hoverbench session platform: what `hoverbench report` draws the figures for.\n\n{body}"
        )
    }

    /// Reads `platform.toml` from a session folder; `Ok(None)` when the session has none.
    pub fn load(dir: &Path) -> Result<Option<Self>, ReportError> {
        let path = dir.join(Self::FILE);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(source) => return Err(ReportError::Io { path, source }),
        };
        let p: Self = toml::from_str(&text).map_err(|e| ReportError::NoData {
            figure: "platform",
            what: format!("{}: {}", path.display(), e.message().trim()),
        })?;
        for (what, v) in [
            ("structure_mass_kg", p.structure_mass_kg),
            ("avionics_power_w", p.avionics_power_w),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ReportError::NoData {
                    figure: "platform",
                    what: format!("{}: {what} = {v} is not a mass or power", path.display()),
                });
            }
        }
        Ok(Some(p))
    }
}

/// The parameter file of a session folder, or the given file.
pub(crate) fn params_path(input: &Path) -> PathBuf {
    if input.is_dir() {
        input.join("params.toml")
    } else {
        input.to_owned()
    }
}

/// A file of the session folder `input`, if `input` is a folder and the file is there.
fn in_session(input: &Path, name: &str) -> Option<PathBuf> {
    input
        .is_dir()
        .then(|| input.join(name))
        .filter(|p| p.is_file())
}

/// The nominal sweep that goes with the parameters: `given`, else the session's
/// `sweep.csv`, else the params file's `provenance.input_file` (as recorded, or beside the
/// params file).
pub(crate) fn nominal_sweep(
    input: &Path,
    given: Option<&Path>,
    params: &Path,
    file: &ParamsFile,
) -> Option<PathBuf> {
    let recorded = Path::new(&file.provenance.input_file);
    let beside = params.parent().map(|d| d.join(recorded));
    given
        .map(Path::to_owned)
        .or_else(|| in_session(input, "sweep.csv"))
        .or_else(|| {
            [Some(recorded.to_owned()), beside]
                .into_iter()
                .flatten()
                .find(|p| p.is_file())
        })
}

/// The report's provenance line of the parameter file.
pub(crate) fn parameters_provenance(params_path: &Path, file: &ParamsFile) -> (String, String) {
    (
        "parameters".to_owned(),
        format!(
            "{} (written {} by {}; fitted from {}, SHA-256 {})",
            params_path.display(),
            file.provenance.created,
            file.provenance.tool,
            file.provenance.input_file,
            file.provenance.input_sha256
        ),
    )
}

/// The nominal sweep and the session's limit sweep that go with the parameters.
fn locate(
    r: &SessionReport,
    params: &Path,
    file: &ParamsFile,
) -> (Option<PathBuf>, Option<PathBuf>) {
    (
        nominal_sweep(&r.input, r.sweep.as_deref(), params, file),
        in_session(&r.input, "limit.csv"),
    )
}

fn read(path: &Path) -> Result<(Table, String), ReportError> {
    let (table, bytes) = Table::read(path)?;
    Ok((table, import::sha256_hex(&bytes)))
}

/// The thrust limit of a session's limit sweep, extracted as `hoverbench fit --limit` and the
/// characterise session do ([`fit::sweeps::LimitSweep`]).
fn limit_from_sweep(path: &Path) -> Result<LimitMarker, ReportError> {
    let log = StandLog::read(path, &StandOptions::default())?;
    let sweep = LimitSweep::from_stand(&log, None)?;
    let l = sweep.thrust_limit()?;
    Ok(LimitMarker {
        per_rotor_g: l.thrust_g,
        uncertainty_g: l.uncertainty_g,
        supply_voltage_v: sweep.supply_voltage_v,
        note: Some(format!("from {}", path.display())),
    })
}

fn estimate_err(context: String) -> impl FnOnce(estimator::EstimateError) -> ReportError {
    move |source| ReportError::Estimate { context, source }
}

/// Assembles the report's input from the files and draws it.
pub fn write_session_report(r: &SessionReport) -> Result<ReportFiles, ReportError> {
    let params_path = params_path(&r.input);
    let file = ParamsFile::load(&params_path)?;
    let params = file.to_params()?;
    let (sweep_path, limit_path) = locate(r, &params_path, &file);
    let stored = if r.input.is_dir() {
        SessionPlatform::load(&r.input)?
    } else {
        None
    };
    let (structure_mass_kg, avionics_power_w) = match (
        r.structure_mass_kg.or(stored.map(|p| p.structure_mass_kg)),
        r.avionics_power_w.or(stored.map(|p| p.avionics_power_w)),
    ) {
        (Some(m), Some(p)) => (m, p),
        _ => {
            return Err(ReportError::NoData {
                figure: "endurance figures",
                what: format!(
                    "the platform: {} has no {}; give --structure-mass and --avionics-power",
                    r.input.display(),
                    SessionPlatform::FILE
                ),
            });
        }
    };
    let mut model = params.model(structure_mass_kg, avionics_power_w);
    let rotors = f64::from(model.platform.rotor_count);
    let mut provenance = vec![parameters_provenance(&params_path, &file)];

    let mut thrust_limit = params.thrust_limit.map(LimitMarker::from);
    if let Some(l) = r.thrust_limit_kg {
        model.thrust_limit_kg = Some(l);
        thrust_limit = Some(LimitMarker {
            per_rotor_g: l * 1000.0 / rotors,
            uncertainty_g: 0.0,
            supply_voltage_v: None,
            note: Some("given with --thrust-limit".to_owned()),
        });
    } else if let (None, Some(path)) = (&thrust_limit, &limit_path) {
        let marker = limit_from_sweep(path)?;
        model.thrust_limit_kg = Some(marker.per_rotor_g * rotors / 1000.0);
        thrust_limit = Some(marker);
    }
    model
        .validate()
        .map_err(estimate_err("the platform".to_owned()))?;

    let sweep = match &sweep_path {
        Some(path) => {
            let (t, sha) = read(path)?;
            provenance.push((
                "sweep".into(),
                format!("{} (SHA-256 {sha})", path.display()),
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
    if let Some(path) = &limit_path {
        let (_, sha) = read(path)?;
        provenance.push((
            "limit sweep".into(),
            format!("{} (SHA-256 {sha})", path.display()),
        ));
    }

    let mut catalogue = Vec::new();
    if let Some(path) = &r.catalogue {
        let (t, sha) = read(path)?;
        provenance.push((
            "catalogue".into(),
            format!("{} (SHA-256 {sha})", path.display()),
        ));
        for pack in t.catalogue()? {
            catalogue.push(NamedBattery::from_pack(&pack)?);
        }
    }
    let flights = match &r.flights {
        Some(path) => {
            let (t, sha) = read(path)?;
            provenance.push((
                "flights".into(),
                format!("{} (SHA-256 {sha})", path.display()),
            ));
            MeasuredFlight::from_table(&t)?
        }
        None => Vec::new(),
    };

    let battery = r
        .battery
        .or(stored.and_then(|p| p.battery_mass_kg.zip(p.battery_energy_density_wh_per_kg)));
    let given = match battery {
        Some((m, d)) => Some(NamedBattery {
            name: format!("battery {m} kg, {d} Wh/kg"),
            battery: Battery::from_density(m, d).map_err(estimate_err("the battery".to_owned()))?,
        }),
        None => None,
    };
    // Feasible catalogue packs, best first.
    let ranked: Vec<NamedBattery> = if catalogue.is_empty() {
        Vec::new()
    } else {
        crate::CatalogueFigure::rank(&model, &r.payload, &catalogue)?
            .ranking
            .into_iter()
            .filter(|p| !p.over_payload_limit)
            .map(|p| p.battery)
            .collect()
    };
    // Fig. 6: the given battery and the packs flown, else the two best packs.
    let mut study: Vec<NamedBattery> = given.iter().cloned().collect();
    let flown: Vec<NamedBattery> = catalogue
        .iter()
        .filter(|b| flights.iter().any(|f| f.matches(&b.name)))
        .cloned()
        .collect();
    if !flown.is_empty() {
        study.extend(flown);
    } else if study.is_empty() {
        study.extend(ranked.iter().take(2).cloned());
    }

    let mission = match &r.plan {
        None => None,
        Some(text) => {
            let segments = estimator::plan::parse_plan(text)?;
            let Some(battery) = given.clone().or_else(|| ranked.first().cloned()) else {
                return Err(ReportError::NoData {
                    figure: "mission timeline",
                    what: "the plan needs a battery: give one, or a catalogue with a pack within the payload limit".into(),
                });
            };
            Some(MissionInput {
                plan: text.clone(),
                segments,
                battery,
                options: MissionOptions {
                    eq8: r.eq8,
                    ..Default::default()
                },
            })
        }
    };
    provenance.push(("report".into(), r.written_by.clone()));

    let input = ReportInput {
        title: format!("hoverbench report: {}", r.input.display()),
        model: crate::ReportModel::Platform(model),
        payload: r.payload,
        sweep,
        thrust_limit,
        energy_density_wh_per_kg: Some(
            r.energy_density_wh_per_kg
                .unwrap_or(paper::FIG4_ENERGY_DENSITY_WH_PER_KG),
        ),
        catalogue,
        payload_study: Some(PayloadStudy {
            batteries: study,
            payload_powers_w: r.payload_powers_w.clone(),
        }),
        flights,
        mission,
        comparisons: Vec::new(),
        provenance,
    };
    crate::write_report(&input, &r.output)
}
