//! Replay figures: per flight, the remaining time each method predicted against the true
//! remaining time (the online estimator with its one-sigma band); and the median absolute
//! error of each method against the checkpoint.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::render::{self, Draw, DrawResult, colour};

/// One method's predictions over a flight.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayMethodSeries {
    /// Method name.
    pub name: String,
    /// Predicted remaining time, s (NaN: no prediction).
    pub remaining_s: Vec<f64>,
    /// One-sigma band, s (NaN where none).
    pub sigma_s: Vec<f64>,
}

/// Predicted against true remaining time over one flight.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayFlightFigure {
    /// Flight name.
    pub name: String,
    /// Time since take-off, s.
    pub time_s: Vec<f64>,
    /// True remaining time, s.
    pub true_remaining_s: Vec<f64>,
    /// Methods (the first one drawn with its sigma band when it has one).
    pub methods: Vec<ReplayMethodSeries>,
}

/// Median absolute error per method against the checkpoint.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayErrorFigure {
    /// Flights scored.
    pub flights: usize,
    /// Checkpoint fractions.
    pub fractions: Vec<f64>,
    /// (method, median absolute error % per checkpoint, NaN where none).
    pub methods: Vec<(String, Vec<f64>)>,
}

fn finite_max(values: impl Iterator<Item = f64>) -> f64 {
    values.filter(|v| v.is_finite()).fold(0.0, f64::max)
}

fn runs(t: &[f64], v: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![Vec::new()];
    for (x, y) in t.iter().zip(v) {
        if y.is_finite() {
            if let Some(last) = out.last_mut() {
                last.push((*x / 60.0, *y / 60.0));
            }
        } else if out.last().is_some_and(|l| !l.is_empty()) {
            out.push(Vec::new());
        }
    }
    out.retain(|r| !r.is_empty());
    out
}

impl Draw for ReplayFlightFigure {
    fn stem(&self) -> &'static str {
        "replay-flight"
    }

    fn size_px(&self) -> (u32, u32) {
        (1000, 640)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let truth_known = self.true_remaining_s.iter().any(|v| v.is_finite());
        let body = render::titled(
            root,
            &format!("Replay · {}", self.name),
            if truth_known {
                "remaining time to the cut-off, predicted sample by sample, against the truth"
            } else {
                "landed before the cut-off: the remaining time to it as each method predicted (no truth to score)"
            },
        )?;
        let x1 = finite_max(self.time_s.iter().map(|t| t / 60.0)).max(1e-3);
        let y1 = finite_max(self.true_remaining_s.iter().copied().chain(
            self.methods.iter().flat_map(|m| {
                m.remaining_s
                    .iter()
                    .zip(&m.sigma_s)
                    .map(|(r, s)| if s.is_finite() { r + s } else { *r })
            }),
        )) / 60.0;
        // Keep the truth readable when a method predicts far too long.
        let y1 = if truth_known {
            let cap = finite_max(self.true_remaining_s.iter().copied()) / 60.0 * 2.0;
            y1.min(cap.max(1e-3))
        } else {
            y1.max(1e-3)
        } * 1.05;
        let mut chart = render::chart(
            &body,
            None,
            (0.0, x1),
            (0.0, y1),
            ("time since take-off (min)", "remaining time (min)"),
        )?;
        let clip = |v: f64| v.min(y1 * 60.0);
        if let Some(first) = self.methods.first() {
            // The sigma band of the first method, as a filled polygon per run.
            let upper: Vec<f64> = first
                .remaining_s
                .iter()
                .zip(&first.sigma_s)
                .map(|(r, s)| clip(r + s))
                .collect();
            let lower: Vec<f64> = first
                .remaining_s
                .iter()
                .zip(&first.sigma_s)
                .map(|(r, s)| (r - s).max(0.0))
                .collect();
            let up = runs(&self.time_s, &upper);
            let lo = runs(&self.time_s, &lower);
            for (i, (u, l)) in up.into_iter().zip(lo).enumerate() {
                let mut poly = u;
                poly.extend(l.into_iter().rev());
                let s = chart.draw_series(std::iter::once(Polygon::new(
                    poly,
                    colour::BLUE.mix(0.18).filled(),
                )))?;
                if i == 0 {
                    s.label(format!("{} ± 1σ", first.name)).legend(|(x, y)| {
                        Rectangle::new(
                            [(x, y - 6), (x + 24, y + 6)],
                            colour::BLUE.mix(0.18).filled(),
                        )
                    });
                }
            }
        }
        let truth = runs(&self.time_s, &self.true_remaining_s);
        for (i, run) in truth.into_iter().enumerate() {
            let s = chart.draw_series(LineSeries::new(run, colour::INK.stroke_width(3)))?;
            if i == 0 {
                s.label("true remaining").legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], colour::INK.stroke_width(3))
                });
            }
        }
        for (k, m) in self.methods.iter().enumerate() {
            let c = colour::series(if k == 0 { 0 } else { k });
            let c = if k == 1 { colour::RED } else { c };
            let clipped: Vec<f64> = m.remaining_s.iter().map(|v| clip(*v)).collect();
            for (i, run) in runs(&self.time_s, &clipped).into_iter().enumerate() {
                let s = if k == 0 {
                    chart.draw_series(LineSeries::new(run, c.stroke_width(2)))?
                } else {
                    chart.draw_series(DashedLineSeries::new(run, 8, 5, c.stroke_width(2)))?
                };
                if i == 0 {
                    s.label(m.name.clone()).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(2))
                    });
                }
            }
        }
        render::legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        Ok(())
    }
}

impl Draw for ReplayErrorFigure {
    fn stem(&self) -> &'static str {
        "replay-error-by-checkpoint"
    }

    fn size_px(&self) -> (u32, u32) {
        (900, 560)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let body = render::titled(
            root,
            "Replay · median absolute error of the remaining time",
            &format!(
                "% of the flight's duration, over {} flight(s) ending at the cut-off",
                self.flights
            ),
        )?;
        let y1 = finite_max(self.methods.iter().flat_map(|m| m.1.iter().copied())).max(1.0) * 1.1;
        let mut chart = render::chart(
            &body,
            None,
            (0.0, 100.0),
            (0.0, y1),
            (
                "checkpoint (% of the flight)",
                "median |error| (% of duration)",
            ),
        )?;
        for (k, (name, errs)) in self.methods.iter().enumerate() {
            let c = if k == 1 {
                colour::RED
            } else {
                colour::series(k)
            };
            let pts: Vec<(f64, f64)> = self
                .fractions
                .iter()
                .zip(errs)
                .filter(|(_, e)| e.is_finite())
                .map(|(f, e)| (f * 100.0, *e))
                .collect();
            if pts.is_empty() {
                continue;
            }
            chart
                .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?
                .label(name.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(2))
                });
            chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 5, c.filled())))?;
        }
        render::legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        Ok(())
    }
}

/// Renders one figure per flight that landed before the cut-off
/// (`replay-unscored-NN-NAME.{svg,png}`: [`ReplayFlightFigure`]s whose truth is all NaN) into
/// `dir` (which must exist); everything is rendered before anything is written.
pub fn write_unscored_figures(
    flights: &[ReplayFlightFigure],
    dir: &Path,
) -> Result<Vec<PathBuf>, crate::ReportError> {
    let mut rendered = Vec::new();
    for (i, f) in flights.iter().enumerate() {
        rendered.push((
            format!("replay-unscored-{:02}-{}", i + 1, safe_name(&f.name)),
            render::svg(f)?,
            render::png(f)?,
        ));
    }
    write_rendered(rendered, dir)
}

/// A flight's name as a file name's part: ASCII letters, digits, `-` and `_`; `_` for the rest.
fn safe_name(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Writes rendered figures (stem, SVG, PNG) into `dir`, each atomically.
fn write_rendered(
    rendered: Vec<(String, String, Vec<u8>)>,
    dir: &Path,
) -> Result<Vec<PathBuf>, crate::ReportError> {
    let mut out = Vec::new();
    for (stem, svg, png) in rendered {
        let s = dir.join(format!("{stem}.svg"));
        let p = dir.join(format!("{stem}.png"));
        render::write_atomic(&s, svg.as_bytes())?;
        render::write_atomic(&p, &png)?;
        out.push(s);
        out.push(p);
    }
    Ok(out)
}

/// Renders the figures of a replay: one per flight (`replay-flight-NN-NAME.{svg,png}`) and the
/// summary (`replay-error-by-checkpoint.{svg,png}`); everything is rendered before anything is
/// written, into `dir` (which must exist).
pub fn write_replay_figures(
    flights: &[ReplayFlightFigure],
    summary: &ReplayErrorFigure,
    dir: &Path,
) -> Result<Vec<PathBuf>, crate::ReportError> {
    let mut rendered = Vec::new();
    for (i, f) in flights.iter().enumerate() {
        rendered.push((
            format!("{}-{:02}-{}", f.stem(), i + 1, safe_name(&f.name)),
            render::svg(f)?,
            render::png(f)?,
        ));
    }
    rendered.push((
        summary.stem().to_owned(),
        render::svg(summary)?,
        render::png(summary)?,
    ));
    write_rendered(rendered, dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flight_without_truth_renders_its_predictions_alone() {
        let t: Vec<f64> = (0..50).map(|k| f64::from(k) * 6.0).collect();
        let f = ReplayFlightFigure {
            name: "landed".into(),
            time_s: t.clone(),
            true_remaining_s: vec![f64::NAN; 50],
            methods: vec![ReplayMethodSeries {
                name: "online".into(),
                remaining_s: t.iter().map(|x| 900.0 - x).collect(),
                sigma_s: vec![30.0; 50],
            }],
        };
        let svg = render::svg(&f).unwrap();
        assert!(svg.contains("no truth to score") && svg.contains("online ± 1σ"));
        assert!(!svg.contains("true remaining"));
        let dir = tempfile::tempdir().unwrap();
        let written = write_unscored_figures(&[f], dir.path()).unwrap();
        assert!(
            written
                .iter()
                .any(|p| p.ends_with("replay-unscored-01-landed.png"))
        );
    }

    #[test]
    fn figures_render_with_gaps_and_bands() {
        let t: Vec<f64> = (0..100).map(|k| f64::from(k) * 6.0).collect();
        let truth: Vec<f64> = t.iter().map(|x| 600.0 - x).collect();
        let f = ReplayFlightFigure {
            name: "hover".into(),
            time_s: t.clone(),
            true_remaining_s: truth.clone(),
            methods: vec![
                ReplayMethodSeries {
                    name: "online".into(),
                    remaining_s: truth.iter().map(|v| v * 1.05).collect(),
                    sigma_s: vec![20.0; 100],
                },
                ReplayMethodSeries {
                    name: "px4".into(),
                    remaining_s: (0..100)
                        .map(|k| if k < 5 { f64::NAN } else { 1e6 })
                        .collect(),
                    sigma_s: vec![f64::NAN; 100],
                },
            ],
        };
        let svg = render::svg(&f).unwrap();
        assert!(svg.contains("online ± 1σ") && svg.contains("true remaining"));
        let e = ReplayErrorFigure {
            flights: 3,
            fractions: vec![0.25, 0.5, 0.75, 0.9],
            methods: vec![
                ("online".into(), vec![2.0, 1.5, 1.0, 0.5]),
                ("px4".into(), vec![f64::NAN; 4]),
            ],
        };
        assert!(render::svg(&e).unwrap().contains("median |error|"));
        let dir = tempfile::tempdir().unwrap();
        let written = write_replay_figures(&[f], &e, dir.path()).unwrap();
        assert_eq!(written.len(), 4);
        assert!(dir.path().join("replay-flight-01-hover.png").exists());
    }
}
