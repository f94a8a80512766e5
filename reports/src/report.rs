//! The high-level entry: a [`ReportInput`] in, every figure it supports and an HTML report out.

use std::path::{Path, PathBuf};

use estimator::{MissionOptions, Model, Params, Payload, PolyCurve, Segment};

use crate::figure::RenderedFigure;
use crate::{
    BatteryMassFigure, CatalogueFigure, Figure, LimitMarker, MeasuredFlight, MeasuredStep,
    NamedBattery, PayloadFigure, ReportError, ThrustCurveFigure, TimelineFigure, WrittenFigure,
    html,
};

/// A rig sweep's measured steps.
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    /// Where they come from (a file name).
    pub source: String,
    /// What they are, for the legend: `measured` for a rig sweep.
    pub label: String,
    /// The steps.
    pub steps: Vec<MeasuredStep>,
}

impl Sweep {
    /// Reads a hoverbench sweep table: `thrust_g` and `power_w` (or `voltage_v × current_a`) over
    /// the rows not marked invalid, and `power_std_w` when the table has it.
    pub fn from_table(table: &import::Table, source: &str) -> Result<Self, ReportError> {
        let xy = table.xy("thrust_g", &import::YSource::power_default())?;
        // An empty cell (a single-sample step, as `hoverbench import` writes) is no spread.
        let std = if table.has("power_std_w") {
            Some(table.uncertainty_column("power_std_w")?)
        } else {
            None
        };
        let steps =
            xy.x.iter()
                .zip(&xy.y)
                .enumerate()
                .map(|(i, (&thrust_g, &power_w))| MeasuredStep {
                    thrust_g,
                    power_w,
                    power_std_w: std.as_ref().and_then(|s| s.get(i).copied().flatten()),
                })
                .collect();
        Ok(Self {
            source: source.to_owned(),
            label: "measured".to_owned(),
            steps,
        })
    }
}

/// Fig. 6's study: batteries and payload powers.
#[derive(Debug, Clone, PartialEq)]
pub struct PayloadStudy {
    /// One pair of lines per battery.
    pub batteries: Vec<NamedBattery>,
    /// One line per payload power, W (the paper: 0 and 5 W).
    pub payload_powers_w: Vec<f64>,
}

/// A mission plan to evaluate and draw.
#[derive(Debug, Clone, PartialEq)]
pub struct MissionInput {
    /// The plan as written (for titles and tables).
    pub plan: String,
    /// The plan's segments (`estimator::plan::parse_plan`).
    pub segments: Vec<Segment>,
    /// The battery flown.
    pub battery: NamedBattery,
    /// Eq. (8) form and reserve floor.
    pub options: MissionOptions,
}

/// A reproduced number beside a reference (a published or measured value).
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// What is compared.
    pub what: String,
    /// The value computed here.
    pub value: f64,
    /// The reference value.
    pub reference: f64,
    /// Unit of both.
    pub unit: String,
    /// Where the reference comes from.
    pub reference_source: String,
}

/// What a report knows of the vehicle: the curve alone, or the curve with a platform.
#[derive(Debug, Clone)]
pub enum ReportModel {
    /// A parameter file alone (no `--structure-mass`, `--avionics-power`): the curve, the rotor
    /// count and the thrust limit. Only Fig. 3 can be drawn.
    CurveOnly {
        /// Per-rotor thrust → power curve.
        curve: PolyCurve,
        /// Rotors sharing the take-off mass.
        rotor_count: u8,
        /// `m_L`, kg, when measured.
        thrust_limit_kg: Option<f64>,
    },
    /// The curve with a platform and the thrust limit: every figure can be drawn.
    Platform(Model<PolyCurve>),
}

impl ReportModel {
    /// The curve of a parameter file, without a platform.
    pub fn curve_only(params: &Params) -> Self {
        Self::CurveOnly {
            curve: params.curve,
            rotor_count: params.rotor_count,
            thrust_limit_kg: params.thrust_limit_kg(),
        }
    }

    /// The per-rotor thrust → power curve.
    pub fn curve(&self) -> &PolyCurve {
        match self {
            Self::CurveOnly { curve, .. } => curve,
            Self::Platform(m) => &m.curve,
        }
    }

    /// Rotors sharing the take-off mass.
    pub fn rotor_count(&self) -> u8 {
        match self {
            Self::CurveOnly { rotor_count, .. } => *rotor_count,
            Self::Platform(m) => m.platform.rotor_count,
        }
    }

    /// `m_L`: total thrust limit over all rotors, kg, when known.
    pub fn thrust_limit_kg(&self) -> Option<f64> {
        match self {
            Self::CurveOnly {
                thrust_limit_kg, ..
            } => *thrust_limit_kg,
            Self::Platform(m) => m.thrust_limit_kg,
        }
    }

    /// The model with its platform, when one was given.
    pub fn with_platform(&self) -> Option<&Model<PolyCurve>> {
        match self {
            Self::CurveOnly { .. } => None,
            Self::Platform(m) => Some(m),
        }
    }

    /// The model with its platform, or the error of `figure`, which needs one.
    fn platform_for(&self, figure: &'static str) -> Result<&Model<PolyCurve>, ReportError> {
        self.with_platform().ok_or_else(|| ReportError::NoData {
            figure,
            what: "no platform given (--structure-mass, --avionics-power)".to_owned(),
        })
    }
}

/// Everything a report can show. Each figure is drawn when its inputs are present.
#[derive(Debug, Clone)]
pub struct ReportInput {
    /// Report title.
    pub title: String,
    /// The model: fitted curve, thrust limit and, when given, the platform.
    pub model: ReportModel,
    /// Payload for Fig. 4, Fig. 5 and the mission.
    pub payload: Payload,
    /// Measured steps for Fig. 3 (the curve alone is drawn without them).
    pub sweep: Option<Sweep>,
    /// Thrust limit marker for Fig. 3.
    pub thrust_limit: Option<LimitMarker>,
    /// Energy density for Fig. 4, Wh/kg (no Fig. 4 without it).
    pub energy_density_wh_per_kg: Option<f64>,
    /// Packs for Fig. 5 (no Fig. 5 when empty).
    pub catalogue: Vec<NamedBattery>,
    /// Batteries and payload powers for Fig. 6.
    pub payload_study: Option<PayloadStudy>,
    /// Measured flights for Fig. 6.
    pub flights: Vec<MeasuredFlight>,
    /// A mission for the Fig. 7-style timeline.
    pub mission: Option<MissionInput>,
    /// Numbers to show beside references.
    pub comparisons: Vec<Comparison>,
    /// Where the inputs come from: (key, value) rows for the report's provenance table.
    pub provenance: Vec<(String, String)>,
}

/// Files a report wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReportFiles {
    /// Each figure's SVG and PNG.
    pub figures: Vec<WrittenFigure>,
    /// The self-contained HTML report.
    pub html: PathBuf,
}

impl ReportFiles {
    /// Every file written, figures first (SVG then PNG), the HTML last.
    pub fn paths(&self) -> Vec<&Path> {
        let mut out: Vec<&Path> = Vec::with_capacity(self.figures.len() * 2 + 1);
        for f in &self.figures {
            out.push(&f.svg);
            out.push(&f.png);
        }
        out.push(&self.html);
        out
    }
}

/// File name of the HTML report.
pub const HTML_FILE: &str = "report.html";

/// The figures `input` supports, in the paper's order (Fig. 3 to 7).
pub fn figures(input: &ReportInput) -> Result<Vec<Figure>, ReportError> {
    let model = &input.model;
    let mut out = Vec::new();
    out.push(Figure::from(ThrustCurveFigure {
        curve: *model.curve(),
        measured: input
            .sweep
            .as_ref()
            .map(|s| s.steps.clone())
            .unwrap_or_default(),
        thrust_limit: input.thrust_limit.clone(),
        source: input.sweep.as_ref().map(|s| s.source.clone()),
        steps_label: input
            .sweep
            .as_ref()
            .map_or_else(|| "measured".to_owned(), |s| s.label.clone()),
    }));
    if let Some(e_d) = input.energy_density_wh_per_kg {
        let m = model.platform_for("battery mass")?;
        out.push(BatteryMassFigure::from_model(m, e_d, &input.payload)?.into());
    }
    if !input.catalogue.is_empty() {
        let m = model.platform_for("catalogue")?;
        out.push(CatalogueFigure::rank(m, &input.payload, &input.catalogue)?.into());
    }
    if let Some(study) = &input.payload_study {
        if !study.batteries.is_empty() && !study.payload_powers_w.is_empty() {
            out.push(
                PayloadFigure::from_model(
                    model.platform_for("payload")?,
                    &study.batteries,
                    &study.payload_powers_w,
                    &input.flights,
                )?
                .into(),
            );
        }
    }
    if let Some(m) = &input.mission {
        let (summary, outcomes) = model
            .platform_for("mission timeline")?
            .evaluate_mission_vec(&m.battery.battery, &input.payload, &m.segments, &m.options)
            .map_err(ReportError::estimate(format!(
                "mission {:?} with {}",
                m.plan, m.battery.name
            )))?;
        out.push(
            TimelineFigure::from_mission(
                &m.battery.name,
                &m.plan,
                m.options.eq8,
                &summary,
                &outcomes,
            )
            .into(),
        );
    }
    Ok(out)
}

/// Whether a file name is one a report writes (a figure's SVG or PNG, `report.html`): an
/// output folder holding only such files is an earlier report and may be replaced.
pub fn is_report_file(name: &str) -> bool {
    name == HTML_FILE || name.ends_with(".svg") || name.ends_with(".png")
}

/// Draws every figure `input` supports as SVG and PNG and writes them, with a self-contained
/// `report.html` (figures inline as SVG, numbers in tables, provenance), into `out_dir`.
/// Everything is computed and rendered before the first file is written; the folder is built
/// aside ([`outfile::StagedDir`]) and renamed into place, so it appears whole or not at all
/// (an interrupted run leaves no partial folder; the next run removes its hidden staging
/// folder). An existing `out_dir` is replaced only if it holds nothing but an earlier report's
/// files ([`is_report_file`]).
pub fn write_report(input: &ReportInput, out_dir: &Path) -> Result<ReportFiles, ReportError> {
    // A folder that cannot be replaced fails before the work.
    let staged = outfile::StagedDir::owning(out_dir, is_report_file)?;
    let figures = figures(input)?;
    let rendered = figures
        .iter()
        .map(RenderedFigure::render)
        .collect::<Result<Vec<_>, _>>()?;
    let page = html::page(input, &figures, &rendered);
    let written = rendered
        .iter()
        .map(|r| r.write(staged.path()))
        .collect::<Result<Vec<_>, _>>()?;
    crate::render::write_atomic(&staged.path().join(HTML_FILE), page.as_bytes())?;
    staged.commit()?;
    let moved = |p: &Path| out_dir.join(p.file_name().unwrap_or_default());
    Ok(ReportFiles {
        figures: written
            .into_iter()
            .map(|w| WrittenFigure {
                svg: moved(&w.svg),
                png: moved(&w.png),
                ..w
            })
            .collect(),
        html: out_dir.join(HTML_FILE),
    })
}
