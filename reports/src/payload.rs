//! Fig. 6: endurance against payload mass for several batteries, with and without payload power,
//! and measured flights.

use estimator::{Model, Payload, Platform, PowerCurve};
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::render::{self, Draw, DrawResult, colour, num, size, text, tick, tick_decimals};
use crate::{NamedBattery, ReportError};

/// Points along each Fig. 6 line.
const PAYLOAD_SAMPLES: usize = 120;

/// A measured flight (or the mean of several): endurance for one battery, payload mass and
/// payload power.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredFlight {
    /// Battery name, matched against the figure's batteries (exactly, or as a part of the
    /// battery's name: `Battery-A` matches `TP-2100-3S1P (Battery-A)`).
    pub battery: String,
    /// `m_P`, kg.
    pub payload_mass_kg: f64,
    /// `p_P`, W.
    pub payload_power_w: f64,
    /// Mean measured endurance, minutes.
    pub endurance_mean_min: f64,
    /// Standard deviation of the endurance, minutes, when known.
    pub endurance_std_min: Option<f64>,
    /// Number of flights averaged, when known.
    pub samples: Option<u32>,
}

impl MeasuredFlight {
    /// Reads measured flights from a table with columns `battery`, `payload_mass_kg`,
    /// `payload_power_w`, `endurance_mean_min` and optionally `endurance_std_min` and `samples`
    /// (an empty optional cell means unknown).
    pub fn from_table(table: &import::Table) -> Result<Vec<Self>, ReportError> {
        let names = table.text_column("battery")?;
        let mut out = Vec::with_capacity(table.len());
        for (r, name) in names.iter().enumerate() {
            let opt = |col: &str| -> Result<Option<f64>, ReportError> {
                if table.has(col) && !table.cell_text(r, col).is_empty() {
                    Ok(Some(table.cell_number(r, col)?))
                } else {
                    Ok(None)
                }
            };
            let non_negative = |col: &str| -> Result<f64, ReportError> {
                let v = table.cell_number(r, col)?;
                if v < 0.0 {
                    return Err(table.bad_value(r, col, "a number ≥ 0").into());
                }
                Ok(v)
            };
            if name.is_empty() {
                return Err(table.bad_value(r, "battery", "a battery name").into());
            }
            let endurance_std_min = opt("endurance_std_min")?;
            if endurance_std_min.is_some_and(|s| s < 0.0) {
                return Err(table
                    .bad_value(r, "endurance_std_min", "a standard deviation ≥ 0")
                    .into());
            }
            let samples = match opt("samples")? {
                Some(s) if s >= 1.0 && s.fract() == 0.0 && s <= f64::from(u32::MAX) => {
                    Some(s as u32)
                }
                Some(_) => return Err(table.bad_value(r, "samples", "a whole number ≥ 1").into()),
                None => None,
            };
            out.push(Self {
                battery: (*name).to_owned(),
                payload_mass_kg: non_negative("payload_mass_kg")?,
                payload_power_w: non_negative("payload_power_w")?,
                endurance_mean_min: non_negative("endurance_mean_min")?,
                endurance_std_min,
                samples,
            });
        }
        Ok(out)
    }

    /// Whether this flight was flown with `battery`.
    pub fn matches(&self, battery: &str) -> bool {
        battery == self.battery || battery.contains(self.battery.as_str())
    }
}

/// One line of Fig. 6: a battery at one payload power, up to its payload limit.
#[derive(Debug, Clone, PartialEq)]
pub struct PayloadSeries {
    /// The battery.
    pub battery: NamedBattery,
    /// `p_P`, W.
    pub payload_power_w: f64,
    /// (`m_P` kg, `t_E` min), from no payload up to the payload limit.
    pub points: Vec<(f64, f64)>,
    /// Payload limit `m_X` without payload, kg (the end of the line), when the thrust limit is
    /// known; negative when the battery alone is over the limit (the line is then empty).
    pub payload_limit_kg: Option<f64>,
}

/// A measured flight beside the estimate for the same battery and payload.
#[derive(Debug, Clone, PartialEq)]
pub struct FlightComparison {
    /// The flight.
    pub flight: MeasuredFlight,
    /// The estimate, minutes; `None` when no battery of the figure matches or the payload is
    /// outside what the model can estimate.
    pub estimate_min: Option<f64>,
}

impl FlightComparison {
    /// `(estimate − measured) / measured`, %.
    pub fn error_pct(&self) -> Option<f64> {
        self.estimate_min
            .map(|e| (e - self.flight.endurance_mean_min) / self.flight.endurance_mean_min * 100.0)
    }
}

/// Fig. 6: endurance against payload mass.
#[derive(Debug, Clone, PartialEq)]
pub struct PayloadFigure {
    /// The platform (for the subtitle).
    pub platform: Platform,
    /// One line per battery and payload power.
    pub series: Vec<PayloadSeries>,
    /// Measured flights with the matching estimates.
    pub measured: Vec<FlightComparison>,
}

impl PayloadFigure {
    /// Computes the lines for every battery at every payload power, each up to that battery's
    /// payload limit (or the heaviest payload the thrust curve covers when the limit is unknown),
    /// and the estimates for the measured flights.
    pub fn from_model<C: PowerCurve>(
        model: &Model<C>,
        batteries: &[NamedBattery],
        payload_powers_w: &[f64],
        measured: &[MeasuredFlight],
    ) -> Result<Self, ReportError> {
        let mut series = Vec::new();
        for b in batteries {
            let fixed = model.platform.structure_mass_kg + b.battery.mass_kg;
            let limit = model.thrust_limit_kg.map(|l| l - fixed);
            let max_payload = limit.unwrap_or(model.max_curve_mass_kg() - fixed);
            for &p_w in payload_powers_w {
                let mut points = Vec::new();
                if max_payload >= 0.0 {
                    for i in 0..=PAYLOAD_SAMPLES {
                        let m = max_payload * i as f64 / PAYLOAD_SAMPLES as f64;
                        let e = model
                            .estimate_unchecked(
                                &b.battery,
                                &Payload {
                                    mass_kg: m,
                                    power_w: p_w,
                                },
                            )
                            .map_err(ReportError::estimate(format!(
                                "Fig. 6: {} with {m} kg payload at {p_w} W",
                                b.name
                            )))?;
                        points.push((m, e.endurance_min));
                    }
                }
                series.push(PayloadSeries {
                    battery: b.clone(),
                    payload_power_w: p_w,
                    points,
                    payload_limit_kg: limit,
                });
            }
        }
        let measured = measured
            .iter()
            .map(|f| {
                let estimate_min = batteries.iter().find(|b| f.matches(&b.name)).and_then(|b| {
                    model
                        .estimate(
                            &b.battery,
                            &Payload {
                                mass_kg: f.payload_mass_kg,
                                power_w: f.payload_power_w,
                            },
                        )
                        .ok()
                        .map(|e| e.endurance_min)
                });
                FlightComparison {
                    flight: f.clone(),
                    estimate_min,
                }
            })
            .collect();
        Ok(Self {
            platform: model.platform,
            series,
            measured,
        })
    }

    /// Figure title.
    pub fn title(&self) -> String {
        "Fig. 6 · Endurance vs payload mass".to_owned()
    }

    fn subtitle(&self) -> String {
        let mut s = format!(
            "m_S = {} kg, p_A = {} W\n",
            num(self.platform.structure_mass_kg, 3),
            num(self.platform.avionics_power_w, 2)
        );
        let mut seen: Vec<&str> = Vec::new();
        for b in self.series.iter().map(|s| &s.battery) {
            if !seen.contains(&b.name.as_str()) {
                seen.push(&b.name);
                if seen.len() > 1 {
                    s.push_str("; ");
                }
                // A name that already states mass and density is not followed by them again.
                if b.name.contains("Wh/kg") {
                    s.push_str(&b.name);
                } else {
                    s.push_str(&format!(
                        "{}: {} kg, {} Wh/kg",
                        b.name,
                        num(b.battery.mass_kg, 3),
                        num(b.energy_density_wh_per_kg(), 0)
                    ));
                }
            }
        }
        s
    }

    fn battery_index(&self, name: &str) -> usize {
        let mut names: Vec<&str> = Vec::new();
        for s in &self.series {
            if !names.contains(&s.battery.name.as_str()) {
                names.push(&s.battery.name);
            }
        }
        names.iter().position(|n| *n == name).unwrap_or(0)
    }
}

impl Draw for PayloadFigure {
    fn stem(&self) -> &'static str {
        "fig6-endurance-vs-payload"
    }

    fn size_px(&self) -> (u32, u32) {
        (1000, 680)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = render::titled(root, &self.title(), &self.subtitle())?;
        let mut x_hi = 0.0_f64;
        let mut y_hi = 0.0_f64;
        let mut y_lo = f64::INFINITY;
        for s in &self.series {
            for &(m, t) in &s.points {
                x_hi = x_hi.max(m);
                y_hi = y_hi.max(t);
                y_lo = y_lo.min(t);
            }
        }
        for c in &self.measured {
            let sd = c.flight.endurance_std_min.unwrap_or(0.0);
            x_hi = x_hi.max(c.flight.payload_mass_kg);
            y_hi = y_hi.max(c.flight.endurance_mean_min + sd);
            y_lo = y_lo.min(c.flight.endurance_mean_min - sd);
        }
        // Room on the right for the end labels; the endurance axis starts at zero unless the
        // lines span a narrow band far above it (a short payload range), which would leave the
        // plot mostly empty.
        let x1 = if x_hi > 0.0 { x_hi * 1.15 } else { 0.1 };
        let y0 = if y_lo.is_finite() && y_lo > 0.7 * y_hi {
            (y_lo - 0.5 * (y_hi - y_lo).max(0.05 * y_hi)).max(0.0)
        } else {
            0.0
        };
        let y1 = if y_hi > 0.0 {
            y_hi + 0.35 * (y_hi - y0)
        } else {
            1.0
        };
        let mut chart = ChartBuilder::on(&area)
            .margin_left(16)
            .margin_right(28)
            .margin_top(8)
            .x_label_area_size(60)
            .y_label_area_size(76)
            .build_cartesian_2d(
                render::axis("payload mass", -0.02 * x1, x1)?,
                render::axis("endurance", y0, y1)?,
            )?;
        let (xd, yd) = (tick_decimals(x1), tick_decimals(y1 - y0));
        let x_fmt = |v: &f64| tick(*v, xd);
        let y_fmt = |v: &f64| tick(*v, yd);
        chart
            .configure_mesh()
            .x_desc("payload mass m_P (kg)")
            .y_desc("flight endurance t_E (min)")
            .x_label_formatter(&x_fmt)
            .y_label_formatter(&y_fmt)
            .label_style(text(size::TICK))
            .axis_desc_style(text(size::AXIS))
            .bold_line_style(colour::GREY.mix(0.25))
            .max_light_lines(0)
            .draw()?;

        for s in &self.series {
            let c = colour::series(self.battery_index(&s.battery.name));
            let style = c.stroke_width(3);
            let label = format!("{}, p_P = {} W", s.battery.name, num(s.payload_power_w, 1));
            let points = render::thin(&s.points, render::CURVE_POINTS);
            if s.payload_power_w > 0.0 {
                render::curve(&chart, &points, style, Some((12.0, 6.0)))?;
                render::legend_entry(&mut chart)?
                    .label(label)
                    .legend(move |(x, y)| {
                        DashedPathElement::new(vec![(x, y), (x + 24, y)], 8, 4, c.stroke_width(3))
                    });
            } else {
                render::curve(&chart, &points, style, None)?;
                render::legend_entry(&mut chart)?
                    .label(label)
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(3))
                    });
            }
            // The end of the line, at the payload limit: its endurance there. Lines with payload
            // power lie below those without, so their labels go below the end.
            if let Some(&(m, t)) = s.points.last() {
                let (dy, v) = if s.payload_power_w > 0.0 {
                    (3, VPos::Top)
                } else {
                    (-3, VPos::Bottom)
                };
                chart.draw_series(std::iter::once(
                    EmptyElement::at((m, t))
                        + Text::new(
                            format!("{} min", num(t, 2)),
                            (8, dy),
                            render::anchored(size::NOTE, &c, HPos::Left, v),
                        ),
                ))?;
            }
        }
        // One marker per battery at its payload limit, labelled at the foot.
        let mut marked: Vec<&str> = Vec::new();
        for s in &self.series {
            let (Some(limit), Some(&(_, t))) = (s.payload_limit_kg, s.points.last()) else {
                continue;
            };
            if marked.contains(&s.battery.name.as_str()) {
                continue;
            }
            marked.push(&s.battery.name);
            let top = self
                .series
                .iter()
                .filter(|o| o.battery.name == s.battery.name)
                .filter_map(|o| o.points.last().map(|p| p.1))
                .fold(t, f64::max);
            let c = colour::series(self.battery_index(&s.battery.name));
            chart.draw_series(DashedLineSeries::new(
                vec![(limit, y0), (limit, top)],
                6,
                4,
                c.stroke_width(2),
            ))?;
            chart.draw_series(std::iter::once(
                EmptyElement::at((limit, y0))
                    + Text::new(
                        format!("m_X = {} kg", num(limit, 3)),
                        (-6, -8),
                        render::anchored(size::NOTE, &c, HPos::Right, VPos::Bottom),
                    ),
            ))?;
        }

        let mut labelled: Vec<usize> = Vec::new();
        for c in &self.measured {
            let f = &c.flight;
            let idx = self
                .series
                .iter()
                .find(|s| f.matches(&s.battery.name))
                .map(|s| self.battery_index(&s.battery.name));
            let col = idx.map_or(colour::INK, colour::series);
            if let Some(sd) = f.endurance_std_min {
                chart.draw_series(std::iter::once(ErrorBar::new_vertical(
                    f.payload_mass_kg,
                    f.endurance_mean_min - sd,
                    f.endurance_mean_min,
                    f.endurance_mean_min + sd,
                    colour::INK.stroke_width(2),
                    12,
                )))?;
            }
            let marker = EmptyElement::at((f.payload_mass_kg, f.endurance_mean_min))
                + Circle::new((0, 0), 6, col.filled())
                + Circle::new((0, 0), 6, colour::INK.stroke_width(2));
            let key = idx.unwrap_or(usize::MAX);
            if labelled.contains(&key) {
                chart.draw_series(std::iter::once(marker))?;
            } else {
                labelled.push(key);
                chart
                    .draw_series(std::iter::once(marker))?
                    .label(format!("measured, {} (mean ± 1σ)", f.battery))
                    .legend(move |(x, y)| {
                        EmptyElement::at((x + 12, y))
                            + Circle::new((0, 0), 6, col.filled())
                            + Circle::new((0, 0), 6, colour::INK.stroke_width(2))
                    });
            }
        }
        render::legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        Ok(())
    }
}
