//! Figures and reports for hoverbench: the paper's Fig. 3–7 drawn from a characterisation, as
//! SVG and PNG, and a self-contained HTML report.
//!
//! Text is drawn with an embedded font (DejaVu Sans, from the `dejavu` crate) through plotters'
//! pure-Rust `ab_glyph` backend: no system font library and no installed font is needed, and the
//! same data give byte-identical SVG on every machine.
//!
//! Main types:
//! - one plain data struct per figure, each with a constructor from the estimator's [`Model`]
//!   where the numbers are computed: [`ThrustCurveFigure`] (Fig. 3), [`BatteryMassFigure`]
//!   (Fig. 4), [`CatalogueFigure`] (Fig. 5), [`PayloadFigure`] (Fig. 6), [`TimelineFigure`]
//!   (Fig. 7-style mission timeline);
//! - [`Figure`]: any of them, rendered with [`Figure::to_svg`] / [`Figure::to_png`] or written
//!   with [`Figure::write`];
//! - [`ReportInput`] → [`write_report`] → [`ReportFiles`]: every figure the inputs allow and
//!   `report.html`; [`paper_figures`] does it for the paper's reproduction.
//!
//! ```
//! use estimator::Payload;
//! use reports::{BatteryMassFigure, Figure};
//!
//! let r = paper::reproduce()?;
//! let fig4 = BatteryMassFigure::from_model(&r.model(), 164.0, &Payload::default())?;
//! assert!((fig4.ideal.battery_mass_kg - 0.353).abs() < 0.001);
//! let svg = Figure::from(fig4).to_svg()?;
//! assert!(svg.contains("ideal optimum: 0.353 kg"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Invariants: the library never prints; figures are written only after everything has been
//! computed and rendered, each through a temporary file and a rename, and a report's folder is
//! built aside and renamed into place whole; the HTML report refers to nothing outside itself.
//!
//! [`Model`]: estimator::Model

mod battery_mass;
mod catalogue;
mod curve_report;
mod error;
mod figure;
mod font;
pub mod gap;
mod html;
mod paper_figures;
mod payload;
mod render;
pub mod replay;
mod report;
pub mod rig_gap;
pub mod session;
mod thrust_curve;
mod timeline;

pub use battery_mass::{BATTERY_MASS_SAMPLES, BatteryMassFigure, MassEndurance};
pub use catalogue::{CatalogueFigure, NamedBattery, RankedPack};
pub use curve_report::write_curve_report;
pub use error::ReportError;
pub use figure::{Figure, WrittenFigure};
pub use font::FONT_FAMILY;
pub use paper_figures::{FIG6_PAYLOAD_POWERS_W, paper_figures};
pub use payload::{FlightComparison, MeasuredFlight, PayloadFigure, PayloadSeries};
pub use report::{
    Comparison, HTML_FILE, MissionInput, PayloadStudy, ReportFiles, ReportInput, ReportModel,
    Sweep, figures, is_report_file, write_report,
};
pub use thrust_curve::{LimitMarker, MeasuredStep, ResidualSummary, ThrustCurveFigure};
pub use timeline::{TimelineFigure, TimelineSegment};
