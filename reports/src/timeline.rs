//! Fig. 7-style mission timeline: hover and attached phases, energy left and reserved endurance
//! `t_R` (eq. 9) against mission time.

use estimator::{Eq8Form, MIN_PER_H, MissionSummary, SegmentOutcome};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::render::{self, Draw, DrawResult, colour, num, size, text, tick, tick_decimals};

/// One segment of an evaluated mission, with the values at both ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimelineSegment {
    /// Flown on the rotors (else attached to the ceiling, motors off).
    pub hover: bool,
    /// Mission time at its start, minutes.
    pub start_min: f64,
    /// Mission time at its end, minutes.
    pub end_min: f64,
    /// Energy left at its start, Wh.
    pub energy_start_wh: f64,
    /// Energy left at its end, Wh.
    pub energy_end_wh: f64,
    /// `t_R` at its start, minutes.
    pub reserved_start_min: f64,
    /// `t_R` at its end, minutes (eq. 9).
    pub reserved_end_min: f64,
}

/// Fig. 7-style timeline of a mission plan.
#[derive(Debug, Clone, PartialEq)]
pub struct TimelineFigure {
    /// Name of the battery flown.
    pub battery_name: String,
    /// `c_B`, Wh.
    pub battery_energy_wh: f64,
    /// The plan as text.
    pub plan: String,
    /// Form of eq. (8) the mission was evaluated with.
    pub eq8: Eq8Form,
    /// The evaluated segments.
    pub segments: Vec<TimelineSegment>,
    /// Mission time when the battery ran out (or hit the reserve floor), if it did before the
    /// plan's end.
    pub ran_out_at_min: Option<f64>,
    /// Total mission time, minutes.
    pub total_min: f64,
}

impl TimelineFigure {
    /// Builds the timeline from an evaluated mission (`Model::evaluate_mission_vec`).
    pub fn from_mission(
        battery_name: &str,
        plan: &str,
        eq8: Eq8Form,
        summary: &MissionSummary,
        outcomes: &[SegmentOutcome],
    ) -> Self {
        let e = &summary.estimate;
        let hover_w = e.motor_power_w + e.idle_power_w;
        let reserved = |wh: f64| wh / hover_w * MIN_PER_H;
        let segments = outcomes
            .iter()
            .map(|o| {
                let start_wh = o.energy_left_wh + o.energy_used_wh;
                TimelineSegment {
                    hover: o.segment.is_hover(),
                    start_min: o.start_min,
                    end_min: o.start_min + o.duration_min,
                    energy_start_wh: start_wh,
                    energy_end_wh: o.energy_left_wh,
                    reserved_start_min: reserved(start_wh),
                    reserved_end_min: o.reserved_endurance_min,
                }
            })
            .collect();
        Self {
            battery_name: battery_name.to_owned(),
            battery_energy_wh: e.battery_energy_wh,
            plan: plan.to_owned(),
            eq8,
            segments,
            ran_out_at_min: summary.depletion.map(|d| d.at_min),
            total_min: summary.total_min,
        }
    }

    /// Figure title.
    pub fn title(&self) -> String {
        format!("Fig. 7 · Mission timeline: {} min", num(self.total_min, 2))
    }

    fn subtitle(&self) -> String {
        format!(
            "{} ({} Wh): {}; eq. (8) {}",
            self.battery_name,
            num(self.battery_energy_wh, 2),
            self.plan,
            match self.eq8 {
                Eq8Form::Consistent => "consistent",
                Eq8Form::PrintedHours => "as printed (times in hours)",
            }
        )
    }

    fn shade<DB: DrawingBackend>(
        &self,
        chart: &mut ChartContext<'_, DB, Cartesian2d<render::Axis, render::Axis>>,
        y0: f64,
        y1: f64,
        legend: bool,
    ) -> DrawResult<DB> {
        for hover in [true, false] {
            let c = if hover { colour::ORANGE } else { colour::GREEN };
            let rects = self
                .segments
                .iter()
                .filter(|s| s.hover == hover)
                .map(move |s| {
                    Rectangle::new([(s.start_min, y0), (s.end_min, y1)], c.mix(0.2).filled())
                });
            let anno = chart.draw_series(rects)?;
            if legend {
                anno.label(if hover {
                    "hover"
                } else {
                    "attached, motors off"
                })
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 7), (x + 24, y + 7)], c.mix(0.4).filled())
                });
            }
        }
        Ok(())
    }
}

impl Draw for TimelineFigure {
    fn stem(&self) -> &'static str {
        "fig7-mission-timeline"
    }

    fn size_px(&self) -> (u32, u32) {
        (1000, 760)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = render::titled(root, &self.title(), &self.subtitle())?;
        let h = area.dim_in_pixel().1;
        let (upper, lower) = area.split_vertically(h / 2);
        let x1 = if self.total_min > 0.0 {
            self.total_min * 1.03
        } else {
            1.0
        };
        let e_hi = self
            .segments
            .iter()
            .map(|s| s.energy_start_wh)
            .fold(self.battery_energy_wh, f64::max);
        let r_hi = self
            .segments
            .iter()
            .map(|s| s.reserved_start_min)
            .fold(0.0_f64, f64::max);
        let e1 = if e_hi > 0.0 { e_hi * 1.12 } else { 1.0 };
        let r1 = if r_hi > 0.0 { r_hi * 1.12 } else { 1.0 };
        let xd = tick_decimals(x1);
        let x_fmt = |v: &f64| tick(*v, xd);

        let panels: [(&DrawingArea<DB, Shift>, f64, &str, bool); 2] = [
            (&upper, e1, "energy left (Wh)", true),
            (&lower, r1, "reserved endurance t_R (min)", false),
        ];
        for (panel, y1, y_desc, top) in panels {
            let mut chart = ChartBuilder::on(panel)
                .margin_left(16)
                .margin_right(28)
                .margin_top(8)
                .x_label_area_size(if top { 36 } else { 60 })
                .y_label_area_size(76)
                .build_cartesian_2d(render::axis("time", 0.0, x1)?, render::axis("y", 0.0, y1)?)?;
            let yd = tick_decimals(y1);
            let y_fmt = |v: &f64| tick(*v, yd);
            let mut mesh = chart.configure_mesh();
            mesh.y_desc(y_desc)
                .x_label_formatter(&x_fmt)
                .y_label_formatter(&y_fmt)
                .label_style(text(size::TICK))
                .axis_desc_style(text(size::AXIS))
                .bold_line_style(colour::GREY.mix(0.25))
                .max_light_lines(0);
            if !top {
                mesh.x_desc("mission time (min)");
            }
            mesh.draw()?;
            self.shade(&mut chart, 0.0, y1, top)?;
            let pts: Vec<(f64, f64)> = self
                .segments
                .iter()
                .flat_map(|s| {
                    if top {
                        [
                            (s.start_min, s.energy_start_wh),
                            (s.end_min, s.energy_end_wh),
                        ]
                    } else {
                        [
                            (s.start_min, s.reserved_start_min),
                            (s.end_min, s.reserved_end_min),
                        ]
                    }
                })
                .collect();
            let line = chart.draw_series(LineSeries::new(pts, colour::BLUE.stroke_width(3)))?;
            if top {
                line.label("energy left").legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], colour::BLUE.stroke_width(3))
                });
            }
            if !top {
                // t_R at the end of each attached segment: what is left to fly home.
                chart.draw_series(self.segments.iter().filter(|s| !s.hover).map(|s| {
                    EmptyElement::at((s.end_min, s.reserved_end_min))
                        + Circle::new((0, 0), 5, colour::BLUE.filled())
                        + Text::new(
                            format!("{} min", num(s.reserved_end_min, 2)),
                            (-6, -10),
                            render::anchored(size::NOTE, &colour::INK, HPos::Right, VPos::Bottom),
                        )
                }))?;
            }
            let end = self.ran_out_at_min.unwrap_or(self.total_min);
            let end_label = match self.ran_out_at_min {
                Some(t) => format!("runs out at {} min", num(t, 2)),
                None => format!("end: {} min", num(end, 2)),
            };
            chart.draw_series(DashedLineSeries::new(
                vec![(end, 0.0), (end, y1)],
                10,
                6,
                colour::RED.stroke_width(2),
            ))?;
            if top {
                chart.draw_series(std::iter::once(
                    EmptyElement::at((end, y1 * 0.55))
                        + Text::new(
                            end_label,
                            (-8, 0),
                            render::anchored(size::NOTE, &colour::RED, HPos::Right, VPos::Center),
                        ),
                ))?;
                render::legend(&mut chart, SeriesLabelPosition::LowerLeft)?;
            }
        }
        Ok(())
    }
}
