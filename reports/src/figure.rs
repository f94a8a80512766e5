//! [`Figure`]: any of the report's figures, rendered to SVG or PNG and written to files.

use std::path::{Path, PathBuf};

use crate::render::{self, Draw};
use crate::{
    BatteryMassFigure, CatalogueFigure, PayloadFigure, ReportError, ThrustCurveFigure,
    TimelineFigure,
};

/// One of the report's figures.
#[derive(Debug, Clone, PartialEq)]
pub enum Figure {
    /// Fig. 3: power against thrust.
    ThrustCurve(ThrustCurveFigure),
    /// Fig. 4: endurance against battery mass.
    BatteryMass(BatteryMassFigure),
    /// Fig. 5: a catalogue ranked by endurance.
    Catalogue(CatalogueFigure),
    /// Fig. 6: endurance against payload mass.
    Payload(PayloadFigure),
    /// Fig. 7-style mission timeline.
    Timeline(TimelineFigure),
}

macro_rules! dispatch {
    ($self:expr, $f:ident => $body:expr) => {
        match $self {
            Figure::ThrustCurve($f) => $body,
            Figure::BatteryMass($f) => $body,
            Figure::Catalogue($f) => $body,
            Figure::Payload($f) => $body,
            Figure::Timeline($f) => $body,
        }
    };
}

impl Figure {
    /// File name without extension, e.g. `fig3-thrust-curve`.
    pub fn stem(&self) -> &'static str {
        dispatch!(self, f => f.stem())
    }

    /// The figure's title.
    pub fn title(&self) -> String {
        dispatch!(self, f => f.title())
    }

    /// Width and height, px (SVG user units and PNG pixels).
    pub fn size_px(&self) -> (u32, u32) {
        dispatch!(self, f => f.size_px())
    }

    /// The figure as SVG text. Deterministic: the same data give the same bytes.
    pub fn to_svg(&self) -> Result<String, ReportError> {
        dispatch!(self, f => render::svg(f))
    }

    /// The figure as an 8-bit RGB PNG, text drawn with the embedded font.
    pub fn to_png(&self) -> Result<Vec<u8>, ReportError> {
        dispatch!(self, f => render::png(f))
    }

    /// Writes the figure as SVG to `path` (through a temporary file and a rename).
    pub fn write_svg(&self, path: &Path) -> Result<(), ReportError> {
        render::write_atomic(path, self.to_svg()?.as_bytes())
    }

    /// Writes the figure as PNG to `path` (through a temporary file and a rename).
    pub fn write_png(&self, path: &Path) -> Result<(), ReportError> {
        render::write_atomic(path, &self.to_png()?)
    }

    /// Renders both formats, then writes `<stem>.svg` and `<stem>.png` into `dir`.
    pub fn write(&self, dir: &Path) -> Result<WrittenFigure, ReportError> {
        let rendered = RenderedFigure::render(self)?;
        rendered.write(dir)
    }
}

/// A figure rendered in both formats, not yet written.
#[derive(Debug, Clone)]
pub(crate) struct RenderedFigure {
    pub(crate) stem: &'static str,
    pub(crate) title: String,
    pub(crate) svg: String,
    pub(crate) png: Vec<u8>,
}

impl RenderedFigure {
    pub(crate) fn render(f: &Figure) -> Result<Self, ReportError> {
        Ok(Self {
            stem: f.stem(),
            title: f.title(),
            svg: f.to_svg()?,
            png: f.to_png()?,
        })
    }

    pub(crate) fn write(&self, dir: &Path) -> Result<WrittenFigure, ReportError> {
        let svg = dir.join(format!("{}.svg", self.stem));
        let png = dir.join(format!("{}.png", self.stem));
        render::write_atomic(&svg, self.svg.as_bytes())?;
        render::write_atomic(&png, &self.png)?;
        Ok(WrittenFigure {
            stem: self.stem,
            title: self.title.clone(),
            svg,
            png,
        })
    }
}

/// Files written for one figure.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WrittenFigure {
    /// File stem, e.g. `fig3-thrust-curve`.
    pub stem: &'static str,
    /// The figure's title.
    pub title: String,
    /// The SVG file.
    pub svg: PathBuf,
    /// The PNG file.
    pub png: PathBuf,
}

macro_rules! from_figure {
    ($($t:ident => $v:ident),*) => {
        $(impl From<$t> for Figure {
            fn from(f: $t) -> Self {
                Self::$v(f)
            }
        })*
    };
}

from_figure!(
    ThrustCurveFigure => ThrustCurve,
    BatteryMassFigure => BatteryMass,
    CatalogueFigure => Catalogue,
    PayloadFigure => Payload,
    TimelineFigure => Timeline
);
