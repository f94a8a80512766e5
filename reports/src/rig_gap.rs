//! The stand gap diagnosis' figure (`hoverbench rig-gap -o`): the residual of every measured
//! quantity against thrust, before (base model) and after (with the selected effects), training
//! and held-out steps marked apart.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::ReportError;
use crate::render::{self, Draw, DrawResult, colour};

/// One step's residual of one quantity.
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualPoint {
    /// The quantity, e.g. `power_w`.
    pub quantity: String,
    /// Whether the step is held out.
    pub heldout: bool,
    /// Thrust reading, g.
    pub thrust_g: f64,
    /// Residual of the base model (predicted − measured), %.
    pub before_pct: f64,
    /// Residual with the selected effects, %.
    pub after_pct: f64,
}

/// Residuals against thrust, one panel per quantity (up to four).
#[derive(Debug, Clone, PartialEq)]
pub struct RigGapFigure {
    /// The verdict, e.g. `supply_sag` or `none`.
    pub verdict: String,
    /// The residuals.
    pub points: Vec<ResidualPoint>,
}

impl Draw for RigGapFigure {
    fn stem(&self) -> &'static str {
        "rig-gap"
    }

    fn size_px(&self) -> (u32, u32) {
        (1100, 820)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let body = render::titled(
            root,
            "Stand gap · residuals against thrust, before and after",
            &format!(
                "red: base model, blue: with {}; filled: held out, hollow: training",
                self.verdict
            ),
        )?;
        let mut quantities: Vec<&str> = Vec::new();
        for p in &self.points {
            if !quantities.contains(&p.quantity.as_str()) {
                quantities.push(&p.quantity);
            }
        }
        quantities.truncate(4);
        let panels = render::panels(&body, quantities.len());
        for (panel, q) in panels.iter().zip(&quantities) {
            let pts: Vec<&ResidualPoint> =
                self.points.iter().filter(|p| p.quantity == *q).collect();
            let fin = |v: f64| v.is_finite();
            let (x0, x1) = render::finite_range(
                pts.iter().map(|p| p.thrust_g),
                (f64::INFINITY, f64::NEG_INFINITY),
            );
            let (y0, y1) = render::finite_range(
                pts.iter().flat_map(|p| [p.before_pct, p.after_pct]),
                (0.0, 0.0),
            );
            let (x0, x1) = render::padded(x0, x1, 0.04);
            let (y0, y1) = render::padded(y0, y1, 0.08);
            let mut chart = render::panel_chart(
                panel,
                q,
                (x0, x1),
                (y0, y1),
                ("thrust (g)", "residual, predicted − measured (%)"),
            )?;
            chart.draw_series(LineSeries::new(
                vec![(x0, 0.0), (x1, 0.0)],
                colour::GREY.stroke_width(1),
            ))?;
            for (c, before) in [(colour::RED, true), (colour::BLUE, false)] {
                chart.draw_series(pts.iter().filter(|p| fin(p.thrust_g)).map(|p| {
                    let y = if before { p.before_pct } else { p.after_pct };
                    let style = if p.heldout {
                        c.filled()
                    } else {
                        c.stroke_width(2)
                    };
                    Circle::new((p.thrust_g, y), 4, style)
                }))?;
            }
        }
        Ok(())
    }
}

/// Writes the figure as SVG and PNG.
pub fn draw(figure: &RigGapFigure, svg_path: &Path, png_path: &Path) -> Result<(), ReportError> {
    if figure.points.is_empty() {
        return Err(ReportError::NoData {
            figure: "rig-gap",
            what: "no residuals to draw".into(),
        });
    }
    render::write_atomic(svg_path, render::svg(figure)?.as_bytes())?;
    render::write_atomic(png_path, &render::png(figure)?)
}
