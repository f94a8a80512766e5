//! Fig. 3: per-rotor electrical power against thrust, measured and fitted, with the residuals.

use estimator::{PolyCurve, PowerCurve};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::render::{self, Draw, DrawResult, colour, num, padded, size, text, tick, tick_decimals};

/// One measured step of a rig sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasuredStep {
    /// Thrust of one rotor, g.
    pub thrust_g: f64,
    /// Electrical power of one rotor, W (mean of the step).
    pub power_w: f64,
    /// Standard deviation of the power over the step, W, when the sweep records it.
    pub power_std_w: Option<f64>,
}

/// The thrust limit at minimum battery voltage, drawn as a vertical marker.
#[derive(Debug, Clone, PartialEq)]
pub struct LimitMarker {
    /// Sustained maximum thrust of one rotor, g (`m_L` / rotor count).
    pub per_rotor_g: f64,
    /// Its standard uncertainty, g (0 when unknown).
    pub uncertainty_g: f64,
    /// Supply voltage the limit holds at, V, when known.
    pub supply_voltage_v: Option<f64>,
    /// How the limit was obtained, when it was not measured (e.g. "implied by …").
    pub note: Option<String>,
}

impl From<estimator::ThrustLimit> for LimitMarker {
    fn from(l: estimator::ThrustLimit) -> Self {
        Self {
            per_rotor_g: l.per_rotor_g,
            uncertainty_g: l.uncertainty_g,
            supply_voltage_v: Some(l.supply_voltage_v),
            note: None,
        }
    }
}

/// Fig. 3: the fitted per-rotor curve over its measured range, the measured steps (with ±1σ
/// error bars when known), the thrust limit at minimum voltage and, when there are measured
/// steps, a residual panel below.
#[derive(Debug, Clone, PartialEq)]
pub struct ThrustCurveFigure {
    /// The fitted curve (its validity range and supply voltage are drawn too).
    pub curve: PolyCurve,
    /// Measured steps; may be empty.
    pub measured: Vec<MeasuredStep>,
    /// The thrust limit at minimum battery voltage, if known.
    pub thrust_limit: Option<LimitMarker>,
    /// Where the measured steps come from (a file name), for the subtitle.
    pub source: Option<String>,
    /// Legend of the steps: `measured`, or what they are when they are not measurements.
    pub steps_label: String,
}

/// Summary of the residuals `measured − fitted`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResidualSummary {
    /// Points compared.
    pub n_points: usize,
    /// Root-mean-square residual, W.
    pub rmse_w: f64,
    /// Largest absolute residual, W.
    pub max_abs_w: f64,
    /// Thrust where it occurs, g.
    pub max_abs_at_g: f64,
}

/// Samples drawn along a fitted curve.
const CURVE_SAMPLES: usize = 240;

/// Most measured steps drawn one by one. A longer sweep (a raw log of millions of rows) is drawn
/// decimated: in each of [`DRAWN_BINS`] thrust bins, its lowest and highest point, so that the
/// envelope and every outlier stay visible and the files stay small.
pub const MAX_DRAWN_STEPS: usize = 2000;
/// Thrust bins of a decimated sweep (about one per pixel column of the plot).
pub const DRAWN_BINS: usize = 800;

/// The points to draw: all of them when there are at most [`MAX_DRAWN_STEPS`], else the lowest
/// and highest `y` in each of [`DRAWN_BINS`] bins of `x`, in bin order.
fn decimate<T: Copy>(items: &[T], x: impl Fn(&T) -> f64, y: impl Fn(&T) -> f64) -> Vec<T> {
    if items.len() <= MAX_DRAWN_STEPS {
        return items.to_vec();
    }
    let (lo, hi) = items
        .iter()
        .map(&x)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    let span = hi - lo;
    let mut bins: Vec<Option<(T, T)>> = vec![None; DRAWN_BINS];
    for it in items {
        let f = if span > 0.0 { (x(it) - lo) / span } else { 0.0 };
        let b = ((f * DRAWN_BINS as f64) as usize).min(DRAWN_BINS - 1);
        bins[b] = Some(match bins[b] {
            None => (*it, *it),
            Some((min, max)) => (
                if y(it) < y(&min) { *it } else { min },
                if y(it) > y(&max) { *it } else { max },
            ),
        });
    }
    let mut out = Vec::with_capacity(2 * DRAWN_BINS);
    for (min, max) in bins.into_iter().flatten() {
        out.push(min);
        if y(&max) != y(&min) || x(&max) != x(&min) {
            out.push(max);
        }
    }
    out
}

impl ThrustCurveFigure {
    /// `measured − fitted` for each measured step inside the curve's range, with its thrust.
    pub fn residuals(&self) -> Vec<(MeasuredStep, f64)> {
        let (lo, hi) = self.curve.valid_range_g();
        self.measured
            .iter()
            .filter(|m| m.thrust_g >= lo && m.thrust_g <= hi)
            .map(|m| (*m, m.power_w - self.curve.eval_unchecked(m.thrust_g)))
            .collect()
    }

    /// RMSE and largest residual of the measured steps, if any lie in the curve's range.
    pub fn residual_summary(&self) -> Option<ResidualSummary> {
        let r = self.residuals();
        if r.is_empty() {
            return None;
        }
        let n = r.len();
        let rmse_w = (r.iter().map(|(_, e)| e * e).sum::<f64>() / n as f64).sqrt();
        let (at, max) = r.iter().fold((0.0, 0.0), |(at, max), (m, e)| {
            if e.abs() > max {
                (m.thrust_g, e.abs())
            } else {
                (at, max)
            }
        });
        Some(ResidualSummary {
            n_points: n,
            rmse_w,
            max_abs_w: max,
            max_abs_at_g: at,
        })
    }

    /// Figure title.
    pub fn title(&self) -> String {
        match self.curve.supply_voltage_v() {
            Some(v) => format!("Fig. 3 · Power per rotor vs thrust at {} V", num(v, 1)),
            None => "Fig. 3 · Power per rotor vs thrust".to_owned(),
        }
    }

    fn subtitle(&self) -> String {
        let (lo, hi) = self.curve.valid_range_g();
        let mut s = format!(
            "degree-{} least-squares fit, valid {}–{} g",
            self.curve.degree(),
            num(lo, 0),
            num(hi, 0)
        );
        if let Some(src) = &self.source {
            let n = self.measured.len();
            let steps = if n == 1 { "step" } else { "steps" };
            s.push_str(&format!(", {n} {steps} from {src}"));
        }
        if self.measured.len() > MAX_DRAWN_STEPS {
            s.push_str(&format!(
                "\nsteps drawn as the lowest and highest of each of {DRAWN_BINS} thrust bins"
            ));
        }
        s
    }

    fn curve_points(&self) -> Vec<(f64, f64)> {
        let (lo, hi) = self.curve.valid_range_g();
        (0..=CURVE_SAMPLES)
            .map(|i| {
                let t = lo + (hi - lo) * i as f64 / CURVE_SAMPLES as f64;
                (t, self.curve.eval_unchecked(t))
            })
            .collect()
    }
}

impl Draw for ThrustCurveFigure {
    fn stem(&self) -> &'static str {
        "fig3-thrust-curve"
    }

    fn size_px(&self) -> (u32, u32) {
        if self.measured.is_empty() {
            (1000, 640)
        } else {
            (1000, 860)
        }
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = render::titled(root, &self.title(), &self.subtitle())?;
        let curve = self.curve_points();
        let residuals = self.residuals();

        let mut x_lo = curve.first().map_or(0.0, |p| p.0);
        let mut x_hi = curve.last().map_or(1.0, |p| p.0);
        let mut y_lo = 0.0_f64;
        let mut y_hi = 0.0_f64;
        for &(_, p) in &curve {
            y_lo = y_lo.min(p);
            y_hi = y_hi.max(p);
        }
        for m in &self.measured {
            let s = m.power_std_w.unwrap_or(0.0);
            x_lo = x_lo.min(m.thrust_g);
            x_hi = x_hi.max(m.thrust_g);
            y_lo = y_lo.min(m.power_w - s);
            y_hi = y_hi.max(m.power_w + s);
        }
        if let Some(l) = &self.thrust_limit {
            x_lo = x_lo.min(l.per_rotor_g - l.uncertainty_g);
            x_hi = x_hi.max(l.per_rotor_g + l.uncertainty_g);
        }
        let (x0, x1) = padded(x_lo, x_hi, 0.03);
        let (_, y1) = padded(y_lo, y_hi, 0.06);
        let y0 = if y_lo >= 0.0 {
            0.0
        } else {
            padded(y_lo, y_hi, 0.06).0
        };

        let (upper, lower) = if residuals.is_empty() {
            (area.clone(), None)
        } else {
            let h = area.dim_in_pixel().1;
            let (u, l) = area.split_vertically(h * 68 / 100);
            (u, Some(l))
        };

        let mut chart = ChartBuilder::on(&upper)
            .margin_left(16)
            .margin_right(28)
            .margin_top(8)
            .x_label_area_size(if lower.is_some() { 36 } else { 60 })
            .y_label_area_size(84)
            .build_cartesian_2d(
                render::axis("thrust", x0, x1)?,
                render::axis("power", y0, y1)?,
            )?;
        let (xd, yd) = (tick_decimals(x1 - x0), tick_decimals(y1 - y0));
        let x_fmt = |v: &f64| tick(*v, xd);
        let y_fmt = |v: &f64| tick(*v, yd);
        let mut mesh = chart.configure_mesh();
        mesh.y_desc("electrical power per rotor (W)")
            .x_label_formatter(&x_fmt)
            .y_label_formatter(&y_fmt)
            .label_style(text(size::TICK))
            .axis_desc_style(text(size::AXIS))
            .bold_line_style(colour::GREY.mix(0.25))
            .max_light_lines(0);
        if lower.is_none() {
            mesh.x_desc("thrust per rotor (g)");
        }
        mesh.draw()?;

        if let Some(l) = &self.thrust_limit {
            let x = l.per_rotor_g;
            if l.uncertainty_g > 0.0 {
                chart.draw_series(std::iter::once(Rectangle::new(
                    [(x - l.uncertainty_g, y0), (x + l.uncertainty_g, y1)],
                    colour::RED.mix(0.15).filled(),
                )))?;
            }
            let at = l
                .supply_voltage_v
                .map(|v| format!(" at {} V", num(v, 1)))
                .unwrap_or_default();
            let unc = if l.uncertainty_g > 0.0 {
                format!(" ± {}", num(l.uncertainty_g, 1))
            } else {
                String::new()
            };
            let note = l
                .note
                .as_ref()
                .map(|n| format!(" ({n})"))
                .unwrap_or_default();
            let label = format!("thrust limit{at}: {}{unc} g{note}", num(x, 1));
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(x, y0), (x, y1)],
                    10,
                    6,
                    colour::RED.stroke_width(2),
                ))?
                .label(label)
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], colour::RED.stroke_width(2))
                });
            chart.draw_series(std::iter::once(
                // At the foot of the marker: the legend sits in the upper left.
                EmptyElement::at((x, y0))
                    + Text::new(
                        format!("{} g", num(x, 1)),
                        (8, -8),
                        render::anchored(size::NOTE, &colour::RED, HPos::Left, VPos::Bottom),
                    ),
            ))?;
        }

        let fit_label = match self.curve.supply_voltage_v() {
            Some(v) => format!("fit (degree {}) at {} V", self.curve.degree(), num(v, 1)),
            None => format!("fit (degree {})", self.curve.degree()),
        };
        render::curve(&chart, &curve, colour::BLUE.stroke_width(3), None)?;
        render::legend_entry(&mut chart)?
            .label(fit_label)
            .legend(|(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], colour::BLUE.stroke_width(3))
            });

        if !self.measured.is_empty() {
            let has_std = self.measured.iter().any(|m| m.power_std_w.is_some());
            let shown = decimate(&self.measured, |m| m.thrust_g, |m| m.power_w);
            chart.draw_series(shown.iter().filter_map(|m| {
                m.power_std_w.map(|s| {
                    ErrorBar::new_vertical(
                        m.thrust_g,
                        m.power_w - s,
                        m.power_w,
                        m.power_w + s,
                        colour::INK.stroke_width(1),
                        8,
                    )
                })
            }))?;
            chart
                .draw_series(
                    shown
                        .iter()
                        .map(|m| Circle::new((m.thrust_g, m.power_w), 4, colour::INK.filled())),
                )?
                .label(if has_std {
                    format!("{} (mean ± 1σ)", self.steps_label)
                } else {
                    self.steps_label.clone()
                })
                .legend(|(x, y)| Circle::new((x + 12, y), 4, colour::INK.filled()));
        }
        render::legend(&mut chart, SeriesLabelPosition::UpperLeft)?;

        if let Some(lower) = lower {
            let max_r = residuals
                .iter()
                .map(|(m, r)| r.abs() + m.power_std_w.unwrap_or(0.0))
                .fold(0.0_f64, f64::max);
            let r = if max_r > 0.0 { max_r * 1.25 } else { 1.0 };
            let rd = tick_decimals(2.0 * r);
            let r_fmt = |v: &f64| tick(*v, rd);
            let mut chart = ChartBuilder::on(&lower)
                .margin_left(16)
                .margin_right(28)
                .margin_top(10)
                .x_label_area_size(60)
                .y_label_area_size(84)
                .build_cartesian_2d(
                    render::axis("thrust", x0, x1)?,
                    render::axis("residual", -r, r)?,
                )?;
            chart
                .configure_mesh()
                .x_desc("thrust per rotor (g)")
                .y_desc("residual (W)")
                .x_label_formatter(&x_fmt)
                .y_label_formatter(&r_fmt)
                .label_style(text(size::TICK))
                .axis_desc_style(text(size::AXIS))
                .bold_line_style(colour::GREY.mix(0.25))
                .max_light_lines(0)
                .y_labels(5)
                .draw()?;
            chart.draw_series(LineSeries::new(
                vec![(x0, 0.0), (x1, 0.0)],
                colour::BLUE.stroke_width(2),
            ))?;
            let residuals = decimate(&residuals, |(m, _)| m.thrust_g, |(_, r)| *r);
            chart.draw_series(residuals.iter().filter_map(|(m, r)| {
                m.power_std_w.map(|s| {
                    ErrorBar::new_vertical(
                        m.thrust_g,
                        r - s,
                        *r,
                        r + s,
                        colour::INK.stroke_width(1),
                        8,
                    )
                })
            }))?;
            chart.draw_series(
                residuals
                    .iter()
                    .map(|(m, r)| Circle::new((m.thrust_g, *r), 4, colour::INK.filled())),
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_sweeps_keep_each_bins_extremes() {
        let items: Vec<(f64, f64)> = (0..100_000)
            .map(|i| (i as f64 * 0.01, (i as f64 * 0.37).sin()))
            .collect();
        let d = decimate(&items, |p| p.0, |p| p.1);
        assert!(d.len() <= 2 * DRAWN_BINS, "{}", d.len());
        // the overall extremes and the ends survive
        let max = d.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        let all_max = items.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        assert_eq!(max, all_max);
        assert!(d.iter().any(|p| p.0 >= 999.0));
        assert!(d.iter().any(|p| p.0 <= 1.25));
        // short sweeps are drawn whole
        assert_eq!(decimate(&items[..50], |p| p.0, |p| p.1).len(), 50);
    }
}
