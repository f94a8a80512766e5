//! The gap diagnosis' figures: held-out flights' voltage against time, measured and predicted
//! before and after the selected effects, and the voltage residual by phase before and after.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::render::{self, Draw, DrawResult, colour, size, text, tick, tick_decimals};

/// One held-out flight's voltage: measured, and predicted by the baseline and by the model with
/// the selected effects (NaN where a prediction has ended at its cut-off).
#[derive(Debug, Clone, PartialEq)]
pub struct GapSeries {
    /// Flight name.
    pub name: String,
    /// Time, s.
    pub time_s: Vec<f64>,
    /// Measured voltage, V.
    pub measured_v: Vec<f64>,
    /// Baseline prediction, V.
    pub before_v: Vec<f64>,
    /// Prediction with the selected effects, V.
    pub after_v: Vec<f64>,
}

/// Held-out voltage over time, before and after (up to four flights, one panel each).
#[derive(Debug, Clone, PartialEq)]
pub struct GapVoltageFigure {
    /// The verdict, e.g. `internal_resistance` or `none`.
    pub verdict: String,
    /// The flights.
    pub flights: Vec<GapSeries>,
}

/// Mean voltage residual (measured − predicted) by phase, before and after.
#[derive(Debug, Clone, PartialEq)]
pub struct GapPhaseFigure {
    /// The verdict.
    pub verdict: String,
    /// (phase, residual before V, residual after V).
    pub phases: Vec<(String, f64, f64)>,
}

fn finite_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    render::finite_range(values, (f64::INFINITY, f64::NEG_INFINITY))
}

/// Runs of finite points (a prediction stops at its cut-off).
fn runs(t: &[f64], v: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![Vec::new()];
    for (x, y) in t.iter().zip(v) {
        if y.is_finite() {
            if let Some(last) = out.last_mut() {
                last.push((*x / 60.0, *y));
            }
        } else if out.last().is_some_and(|l| !l.is_empty()) {
            out.push(Vec::new());
        }
    }
    out.retain(|r| !r.is_empty());
    out
}

impl GapVoltageFigure {
    /// Title.
    pub fn title(&self) -> String {
        "Gap · held-out voltage, measured and predicted".to_owned()
    }
}

impl Draw for GapVoltageFigure {
    fn stem(&self) -> &'static str {
        "gap-voltage-over-time"
    }

    fn size_px(&self) -> (u32, u32) {
        (1100, 820)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let body = render::titled(
            root,
            &self.title(),
            &format!("before: the baseline model; after: with {}", self.verdict),
        )?;
        let shown: Vec<&GapSeries> = self.flights.iter().take(4).collect();
        let panels = render::panels(&body, shown.len());
        for (k, (panel, f)) in panels.iter().zip(&shown).enumerate() {
            let (x0, x1) = finite_range(f.time_s.iter().map(|t| t / 60.0));
            let (y0, y1) = finite_range(
                f.measured_v
                    .iter()
                    .chain(&f.before_v)
                    .chain(&f.after_v)
                    .copied(),
            );
            let (y0, y1) = render::padded(y0, y1, 0.05);
            let mut chart = render::panel_chart(
                panel,
                &f.name,
                (x0, x1.max(x0 + 1e-6)),
                (y0, y1),
                ("time (min)", "battery voltage (V)"),
            )?;
            for (i, run) in runs(&f.time_s, &f.measured_v).into_iter().enumerate() {
                let s = chart.draw_series(LineSeries::new(run, colour::INK.stroke_width(1)))?;
                if i == 0 && k == 0 {
                    s.label("measured").legend(|(x, y)| {
                        PathElement::new(vec![(x, y), (x + 24, y)], colour::INK.stroke_width(2))
                    });
                }
            }
            for (i, run) in runs(&f.time_s, &f.before_v).into_iter().enumerate() {
                let s = chart.draw_series(DashedLineSeries::new(
                    run,
                    8,
                    5,
                    colour::RED.stroke_width(2),
                ))?;
                if i == 0 && k == 0 {
                    s.label("before (baseline)").legend(|(x, y)| {
                        PathElement::new(vec![(x, y), (x + 24, y)], colour::RED.stroke_width(2))
                    });
                }
            }
            for (i, run) in runs(&f.time_s, &f.after_v).into_iter().enumerate() {
                let s = chart.draw_series(LineSeries::new(run, colour::BLUE.stroke_width(2)))?;
                if i == 0 && k == 0 {
                    s.label("after (with the effects)").legend(|(x, y)| {
                        PathElement::new(vec![(x, y), (x + 24, y)], colour::BLUE.stroke_width(2))
                    });
                }
            }
            if k == 0 {
                render::legend(&mut chart, SeriesLabelPosition::LowerLeft)?;
            }
        }
        Ok(())
    }
}

impl GapPhaseFigure {
    /// Title.
    pub fn title(&self) -> String {
        "Gap · voltage residual by phase".to_owned()
    }
}

impl Draw for GapPhaseFigure {
    fn stem(&self) -> &'static str {
        "gap-residual-by-phase"
    }

    fn size_px(&self) -> (u32, u32) {
        (900, 560)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let body = render::titled(
            root,
            &self.title(),
            &format!(
                "mean of measured − predicted voltage, held-out flights; after: with {}",
                self.verdict
            ),
        )?;
        let n = self.phases.len().max(1);
        let (lo, hi) = finite_range(self.phases.iter().flat_map(|p| [p.1, p.2]).chain([0.0]));
        let (lo, hi) = render::padded(lo, hi, 0.15);
        let mut chart = ChartBuilder::on(&body)
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(76)
            .build_cartesian_2d(
                render::axis("x", 0.0, n as f64)?,
                render::axis("y", lo, hi)?,
            )?;
        let yd = tick_decimals(hi - lo);
        chart
            .configure_mesh()
            .y_desc("voltage residual (V)")
            .x_desc("phase")
            .x_labels(0)
            .y_label_formatter(&|v| tick(*v, yd))
            .label_style(text(size::TICK))
            .axis_desc_style(text(size::AXIS))
            .bold_line_style(colour::GREY.mix(0.25))
            .max_light_lines(0)
            .disable_x_mesh()
            .draw()?;
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(0.0, 0.0), (n as f64, 0.0)],
            colour::GREY.stroke_width(1),
        )))?;
        // Phase names along the top of the plot, over their bars.
        chart.draw_series(self.phases.iter().enumerate().map(|(i, p)| {
            EmptyElement::at((i as f64 + 0.5, hi))
                + Text::new(
                    p.0.clone(),
                    (0, 6),
                    render::anchored(
                        size::TICK,
                        &colour::INK,
                        plotters::style::text_anchor::HPos::Center,
                        plotters::style::text_anchor::VPos::Top,
                    ),
                )
        }))?;
        chart
            .draw_series(self.phases.iter().enumerate().map(|(i, p)| {
                let x = i as f64;
                Rectangle::new(
                    [(x + 0.12, 0.0), (x + 0.48, p.1)],
                    colour::RED.mix(0.8).filled(),
                )
            }))?
            .label("before")
            .legend(|(x, y)| {
                Rectangle::new([(x, y - 6), (x + 20, y + 6)], colour::RED.mix(0.8).filled())
            });
        chart
            .draw_series(self.phases.iter().enumerate().map(|(i, p)| {
                let x = i as f64;
                Rectangle::new(
                    [(x + 0.52, 0.0), (x + 0.88, p.2)],
                    colour::BLUE.mix(0.8).filled(),
                )
            }))?
            .label("after")
            .legend(|(x, y)| {
                Rectangle::new(
                    [(x, y - 6), (x + 20, y + 6)],
                    colour::BLUE.mix(0.8).filled(),
                )
            });
        render::legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        Ok(())
    }
}

/// Writes both gap figures (SVG and PNG) into `dir`, rendering everything before writing; the
/// folder is built aside and renamed into place (see [`crate::write_report`]).
pub fn write_gap_figures(
    voltage: &GapVoltageFigure,
    phases: &GapPhaseFigure,
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, crate::ReportError> {
    let staged = outfile::StagedDir::owning(dir, crate::is_report_file)?;
    let rendered = [
        (voltage.stem(), render::svg(voltage)?, render::png(voltage)?),
        (phases.stem(), render::svg(phases)?, render::png(phases)?),
    ];
    let mut out = Vec::new();
    for (stem, svg, png) in rendered {
        let (s, p) = (format!("{stem}.svg"), format!("{stem}.png"));
        render::write_atomic(&staged.path().join(&s), svg.as_bytes())?;
        render::write_atomic(&staged.path().join(&p), &png)?;
        out.push(dir.join(s));
        out.push(dir.join(p));
    }
    staged.commit()?;
    Ok(out)
}
