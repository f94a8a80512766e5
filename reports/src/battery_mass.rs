//! Fig. 4: endurance against battery mass, with the ideal and realistic optima and the payload
//! limit.

use estimator::{Battery, Model, Payload, Platform, PowerCurve};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::ReportError;
use crate::render::{self, Draw, DrawResult, colour, num, padded, size, text, tick, tick_decimals};

/// A battery mass and the endurance it gives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassEndurance {
    /// `m_B`, kg.
    pub battery_mass_kg: f64,
    /// `t_E`, minutes.
    pub endurance_min: f64,
}

/// Fig. 4: `t_E(m_B)` for batteries of one energy density (eqs. 1–4), the ideal optimum, the
/// payload limit of eq. (5) as a battery mass, and the realistic optimum within it.
#[derive(Debug, Clone, PartialEq)]
pub struct BatteryMassFigure {
    /// `e_D` of the batteries, Wh/kg.
    pub energy_density_wh_per_kg: f64,
    /// The platform (for the subtitle).
    pub platform: Platform,
    /// The payload carried.
    pub payload: Payload,
    /// The curve, in increasing battery mass.
    pub curve: Vec<MassEndurance>,
    /// The ideal optimum (no payload limit).
    pub ideal: MassEndurance,
    /// The realistic optimum (within the payload limit), when the thrust limit is known.
    pub realistic: Option<MassEndurance>,
    /// Battery mass at which the payload limit is reached (`m_X = 0`), kg, when known.
    pub limit_battery_mass_kg: Option<f64>,
    /// `m_L`, kg, when known.
    pub thrust_limit_kg: Option<f64>,
}

/// Points along the Fig. 4 curve.
pub const BATTERY_MASS_SAMPLES: usize = 300;

impl BatteryMassFigure {
    /// Computes the figure from a model: the curve over the battery masses the measured thrust
    /// range covers, and both optima.
    pub fn from_model<C: PowerCurve>(
        model: &Model<C>,
        energy_density_wh_per_kg: f64,
        payload: &Payload,
    ) -> Result<Self, ReportError> {
        let opt = model
            .optimise_battery(energy_density_wh_per_kg, payload)
            .map_err(ReportError::estimate("Fig. 4: optimising the battery mass"))?;
        let (lo, hi) = opt.search_range_kg;
        let mut curve = Vec::with_capacity(BATTERY_MASS_SAMPLES + 1);
        for i in 0..=BATTERY_MASS_SAMPLES {
            let m = lo + (hi - lo) * i as f64 / BATTERY_MASS_SAMPLES as f64;
            let b = Battery::from_density(m, energy_density_wh_per_kg)
                .map_err(ReportError::estimate("Fig. 4: a battery on the curve"))?;
            let e = model
                .estimate_unchecked(&b, payload)
                .map_err(ReportError::estimate(format!(
                    "Fig. 4: endurance at m_B = {m} kg"
                )))?;
            curve.push(MassEndurance {
                battery_mass_kg: m,
                endurance_min: e.endurance_min,
            });
        }
        let point = |o: &estimator::Optimum| MassEndurance {
            battery_mass_kg: o.battery_mass_kg,
            endurance_min: o.endurance_min,
        };
        Ok(Self {
            energy_density_wh_per_kg,
            platform: model.platform,
            payload: *payload,
            curve,
            ideal: point(&opt.ideal),
            realistic: opt.realistic.as_ref().map(point),
            limit_battery_mass_kg: model
                .thrust_limit_kg
                .map(|l| l - model.platform.structure_mass_kg - payload.mass_kg),
            thrust_limit_kg: model.thrust_limit_kg,
        })
    }

    /// Figure title.
    pub fn title(&self) -> String {
        "Fig. 4 · Endurance vs battery mass".to_owned()
    }

    fn subtitle(&self) -> String {
        format!(
            "m_S = {} kg, m_P = {} kg, p_A = {} W, p_P = {} W, e_D = {} Wh/kg{}",
            num(self.platform.structure_mass_kg, 3),
            num(self.payload.mass_kg, 3),
            num(self.platform.avionics_power_w, 2),
            num(self.payload.power_w, 2),
            num(self.energy_density_wh_per_kg, 0),
            self.thrust_limit_kg
                .map(|l| format!(", m_L = {} kg", num(l, 3)))
                .unwrap_or_default()
        )
    }
}

impl Draw for BatteryMassFigure {
    fn stem(&self) -> &'static str {
        "fig4-endurance-vs-battery-mass"
    }

    fn size_px(&self) -> (u32, u32) {
        (1000, 660)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = render::titled(root, &self.title(), &self.subtitle())?;
        let x_lo = self.curve.first().map_or(0.0, |p| p.battery_mass_kg);
        let x_hi = self.curve.last().map_or(1.0, |p| p.battery_mass_kg);
        let y_hi = self
            .curve
            .iter()
            .map(|p| p.endurance_min)
            .fold(self.ideal.endurance_min, f64::max);
        let (x0, x1) = (0.0_f64.min(x_lo), padded(x_lo, x_hi, 0.02).1);
        let (y0, y1) = (0.0, y_hi * 1.15);
        let mut chart = ChartBuilder::on(&area)
            .margin_left(16)
            .margin_right(28)
            .margin_top(8)
            .x_label_area_size(60)
            .y_label_area_size(76)
            .build_cartesian_2d(
                render::axis("battery mass", x0, x1)?,
                render::axis("endurance", y0, y1)?,
            )?;
        let (xd, yd) = (tick_decimals(x1 - x0), tick_decimals(y1 - y0));
        let x_fmt = |v: &f64| tick(*v, xd);
        let y_fmt = |v: &f64| tick(*v, yd);
        chart
            .configure_mesh()
            .x_desc("battery mass m_B (kg)")
            .y_desc("flight endurance t_E (min)")
            .x_label_formatter(&x_fmt)
            .y_label_formatter(&y_fmt)
            .label_style(text(size::TICK))
            .axis_desc_style(text(size::AXIS))
            .bold_line_style(colour::GREY.mix(0.25))
            .max_light_lines(0)
            .draw()?;

        if let Some(m) = self.limit_battery_mass_kg.filter(|m| *m < x1) {
            let m = m.max(x0);
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(m, y0), (x1, y1)],
                    colour::GREY.mix(0.12).filled(),
                )))?
                .label("over the payload limit (m_X < 0)")
                .legend(|(x, y)| {
                    Rectangle::new(
                        [(x, y - 7), (x + 24, y + 7)],
                        colour::GREY.mix(0.25).filled(),
                    )
                });
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(m, y0), (m, y1)],
                    10,
                    6,
                    colour::RED.stroke_width(2),
                ))?
                .label(format!("payload limit m_X = 0 at m_B = {} kg", num(m, 3)))
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], colour::RED.stroke_width(2))
                });
        }

        render::curve(
            &chart,
            &render::thin(
                &self
                    .curve
                    .iter()
                    .map(|p| (p.battery_mass_kg, p.endurance_min))
                    .collect::<Vec<_>>(),
                render::CURVE_POINTS,
            ),
            colour::BLUE.stroke_width(3),
            None,
        )?;
        render::legend_entry(&mut chart)?
            .label(format!(
                "t_E at e_D = {} Wh/kg (eq. 4)",
                num(self.energy_density_wh_per_kg, 0)
            ))
            .legend(|(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], colour::BLUE.stroke_width(3))
            });

        // Labels sit beside their points, anchored so that they stay inside the plot.
        let frac = |m: f64| (m - x0) / (x1 - x0);
        let ideal = self.ideal;
        let h = render::h_anchor(frac(ideal.battery_mass_kg));
        chart.draw_series(std::iter::once(
            EmptyElement::at((ideal.battery_mass_kg, ideal.endurance_min))
                + Circle::new((0, 0), 7, colour::BLUE.filled())
                + Circle::new((0, 0), 7, colour::INK.stroke_width(2))
                + Text::new(
                    format!(
                        "ideal optimum: {} kg, {} min",
                        num(ideal.battery_mass_kg, 3),
                        num(ideal.endurance_min, 2)
                    ),
                    (0, -16),
                    render::anchored(size::NOTE, &colour::INK, h, VPos::Bottom),
                ),
        ))?;
        if let Some(r) = self.realistic {
            // Below and to the side of the point, away from the rising curve.
            let (h, dx) = if frac(r.battery_mass_kg) > 0.6 {
                (HPos::Right, -14)
            } else {
                (HPos::Left, 14)
            };
            chart.draw_series(std::iter::once(
                EmptyElement::at((r.battery_mass_kg, r.endurance_min))
                    + Circle::new((0, 0), 7, colour::RED.filled())
                    + Circle::new((0, 0), 7, colour::INK.stroke_width(2))
                    + Text::new(
                        format!(
                            "realistic optimum: {} kg, {} min",
                            num(r.battery_mass_kg, 3),
                            num(r.endurance_min, 2)
                        ),
                        (dx, 12),
                        render::anchored(size::NOTE, &colour::RED, h, VPos::Top),
                    ),
            ))?;
        }
        render::legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        Ok(())
    }
}
