//! The crate's error type.

use std::path::PathBuf;

/// Why a figure or report could not be made. Every variant says which figure, file or input.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    /// The embedded font could not be registered with the plotting library.
    #[error("the embedded font {family:?} could not be loaded")]
    Font {
        /// Font family name.
        family: &'static str,
    },
    /// Drawing a figure failed.
    #[error("drawing {figure} as {format}: {message}")]
    Draw {
        /// File stem of the figure.
        figure: &'static str,
        /// `SVG` or `PNG`.
        format: &'static str,
        /// What the plotting library said.
        message: String,
    },
    /// Encoding a PNG failed.
    #[error("encoding {figure} as PNG: {message}")]
    Png {
        /// File stem of the figure.
        figure: &'static str,
        /// What the encoder said.
        message: String,
    },
    /// An axis of a figure would span a range that cannot be drawn: not finite, empty, or so
    /// large that the input must hold an absurd value.
    #[error(
        "{figure}: the {axis} axis would span {lo:.3e} to {hi:.3e}, which cannot be plotted; an input value is absurd (check the parameter file's coefficients and validity range and the sweep's values)"
    )]
    Unplottable {
        /// File stem of the figure.
        figure: &'static str,
        /// Which axis.
        axis: &'static str,
        /// Lower end.
        lo: f64,
        /// Upper end.
        hi: f64,
    },
    /// A figure has nothing to draw.
    #[error("{figure}: {what}")]
    NoData {
        /// File stem of the figure.
        figure: &'static str,
        /// What is missing.
        what: String,
    },
    /// The estimator refused an input while preparing a figure.
    #[error("{context}")]
    Estimate {
        /// What was being computed.
        context: String,
        /// The estimator's reason.
        source: estimator::EstimateError,
    },
    /// An input table could not be read.
    #[error(transparent)]
    Import(#[from] import::ImportError),
    /// The parameter file could not be read or does not describe a thrust curve.
    #[error(transparent)]
    Params(#[from] estimator::file::ParamsFileError),
    /// The mission plan does not parse.
    #[error("mission plan")]
    Plan(#[from] estimator::plan::PlanError),
    /// A fit needed by a figure failed.
    #[error("{context}")]
    Fit {
        /// What was being fitted.
        context: String,
        /// The fit's reason.
        source: fit::FitError,
    },
    /// A sweep could not be turned into a curve or a thrust limit.
    #[error(transparent)]
    Sweep(#[from] fit::sweeps::SweepFitError),
    /// An output file could not be written (nothing half-written is left).
    #[error(transparent)]
    Write(#[from] outfile::WriteError),
    /// A file could not be read.
    #[error("cannot read {}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl ReportError {
    pub(crate) fn estimate(
        context: impl Into<String>,
    ) -> impl FnOnce(estimator::EstimateError) -> Self {
        let context = context.into();
        move |source| Self::Estimate { context, source }
    }
}
