//! Fig. 5: a battery catalogue ranked by endurance.

use estimator::{Battery, EstimateError, Model, Payload, Platform, PowerCurve};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::ReportError;
use crate::render::{self, Draw, DrawResult, colour, num, size, text, tick, tick_decimals};

/// A battery with a name (a catalogue pack, or one of the paper's).
#[derive(Debug, Clone, PartialEq)]
pub struct NamedBattery {
    /// Name shown in figures and tables.
    pub name: String,
    /// Mass and energy.
    pub battery: Battery,
}

impl NamedBattery {
    /// A catalogue pack as a named battery.
    pub fn from_pack(pack: &import::catalogue::Pack) -> Result<Self, ReportError> {
        let battery = Battery::new(pack.mass_g / 1000.0, pack.energy_wh)
            .map_err(ReportError::estimate(format!("battery {:?}", pack.name)))?;
        Ok(Self {
            name: pack.name.clone(),
            battery,
        })
    }

    /// Energy density, Wh/kg.
    pub fn energy_density_wh_per_kg(&self) -> f64 {
        self.battery.energy_wh / self.battery.mass_kg
    }
}

/// One pack's place in the ranking.
#[derive(Debug, Clone, PartialEq)]
pub struct RankedPack {
    /// 1-based rank.
    pub rank: usize,
    /// The pack.
    pub battery: NamedBattery,
    /// `t_E`, minutes; zero for packs over the payload limit (the paper's convention).
    pub endurance_min: f64,
    /// The pack makes the robot heavier than the thrust limit at minimum voltage.
    pub over_payload_limit: bool,
    /// What the pack would give if it could fly, minutes; `None` when even the measured thrust
    /// curve does not reach its take-off mass.
    pub unlimited_endurance_min: Option<f64>,
}

/// Fig. 5: packs sorted by endurance, best first; packs over the payload limit at zero, marked.
#[derive(Debug, Clone, PartialEq)]
pub struct CatalogueFigure {
    /// The platform (for the subtitle).
    pub platform: Platform,
    /// The payload carried.
    pub payload: Payload,
    /// The ranking, best first.
    pub ranking: Vec<RankedPack>,
}

impl CatalogueFigure {
    /// Ranks `packs` by endurance with the paper's convention for packs over the payload limit.
    /// Ties keep the catalogue order.
    pub fn rank<C: PowerCurve>(
        model: &Model<C>,
        payload: &Payload,
        packs: &[NamedBattery],
    ) -> Result<Self, ReportError> {
        let mut ranking = Vec::with_capacity(packs.len());
        for p in packs {
            let entry = match model.rank_entry(&p.battery, payload) {
                Ok(r) => RankedPack {
                    rank: 0,
                    battery: p.clone(),
                    endurance_min: r.endurance_min,
                    over_payload_limit: r.over_payload_limit,
                    unlimited_endurance_min: Some(r.estimate.endurance_min),
                },
                // Heavier than the curve reaches, and over the thrust limit too: the paper ranks
                // it at zero; what it would give is unknown.
                Err(EstimateError::ThrustOutOfRange { .. })
                    if model.thrust_limit_kg.is_some_and(|l| {
                        model.platform.structure_mass_kg + p.battery.mass_kg + payload.mass_kg > l
                    }) =>
                {
                    RankedPack {
                        rank: 0,
                        battery: p.clone(),
                        endurance_min: 0.0,
                        over_payload_limit: true,
                        unlimited_endurance_min: None,
                    }
                }
                Err(e) => {
                    return Err(ReportError::Estimate {
                        context: format!("Fig. 5: ranking {:?}", p.name),
                        source: e,
                    });
                }
            };
            ranking.push(entry);
        }
        ranking.sort_by(|a, b| b.endurance_min.total_cmp(&a.endurance_min));
        for (i, r) in ranking.iter_mut().enumerate() {
            r.rank = i + 1;
        }
        Ok(Self {
            platform: model.platform,
            payload: *payload,
            ranking,
        })
    }

    /// Figure title.
    pub fn title(&self) -> String {
        format!(
            "Fig. 5 · {} battery pack{} ranked by endurance",
            self.ranking.len(),
            if self.ranking.len() == 1 { "" } else { "s" }
        )
    }

    fn subtitle(&self) -> String {
        format!(
            "eqs. 4–5; m_S = {} kg, m_P = {} kg, p_A = {} W, p_P = {} W; packs over the payload limit count as 0",
            num(self.platform.structure_mass_kg, 3),
            num(self.payload.mass_kg, 3),
            num(self.platform.avionics_power_w, 2),
            num(self.payload.power_w, 2),
        )
    }

    fn label(r: &RankedPack) -> String {
        format!(
            "{}  ({} g, {} Wh)",
            r.battery.name,
            num(r.battery.battery.mass_kg * 1000.0, 0),
            num(r.battery.battery.energy_wh, 1)
        )
    }
}

/// Height of one bar row, px.
const ROW_PX: u32 = 34;

impl Draw for CatalogueFigure {
    fn stem(&self) -> &'static str {
        "fig5-battery-ranking"
    }

    fn size_px(&self) -> (u32, u32) {
        let n = u32::try_from(self.ranking.len()).unwrap_or(u32::MAX / ROW_PX);
        (1100, 200 + ROW_PX * n.max(3))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = render::titled(root, &self.title(), &self.subtitle())?;
        let n = self.ranking.len();
        let t_max = self
            .ranking
            .iter()
            .map(|r| r.endurance_min)
            .fold(0.0_f64, f64::max);
        let x1 = if t_max > 0.0 { t_max * 1.3 } else { 1.0 };
        let labels: Vec<String> = self.ranking.iter().map(Self::label).collect();
        let label_px = labels
            .iter()
            .map(|l| {
                area.estimate_text_size(l, &text(size::TICK))
                    .map_or(0, |(w, _)| w)
            })
            .max()
            .unwrap_or(0);
        // Row i from the top is rank i + 1; plotters counts segments from the bottom.
        let row_of = |rank_index: usize| n - 1 - rank_index;
        let mut chart = ChartBuilder::on(&area)
            .margin_left(16)
            .margin_right(36)
            .margin_top(8)
            .x_label_area_size(60)
            .y_label_area_size(label_px + 24)
            .build_cartesian_2d(
                render::axis("endurance", 0.0, x1)?,
                render::axis("pack", 0.0, n as f64)?,
            )?;
        let xd = tick_decimals(x1);
        let x_fmt = |v: &f64| tick(*v, xd);
        chart
            .configure_mesh()
            .x_desc("flight endurance t_E (min)")
            .x_label_formatter(&x_fmt)
            .y_labels(0)
            .disable_y_mesh()
            .label_style(text(size::TICK))
            .axis_desc_style(text(size::AXIS))
            .bold_line_style(colour::GREY.mix(0.25))
            .max_light_lines(0)
            .draw()?;
        // Pack names left of the axis, one per row, in backend pixels.
        for (i, l) in labels.iter().enumerate() {
            let (x, y) = chart.backend_coord(&(0.0, row_of(i) as f64 + 0.5));
            root.draw(&Text::new(
                l.clone(),
                (x - 10, y),
                render::anchored(size::TICK, &colour::INK, HPos::Right, VPos::Center),
            ))?;
        }

        chart.draw_series(self.ranking.iter().enumerate().map(|(i, r)| {
            let row = row_of(i) as f64;
            Rectangle::new(
                [(0.0, row + 0.18), (r.endurance_min, row + 0.82)],
                if i == 0 {
                    colour::BLUE.filled()
                } else {
                    colour::BLUE.mix(0.6).filled()
                },
            )
        }))?;
        chart.draw_series(self.ranking.iter().enumerate().map(|(i, r)| {
            let (s, c) = if r.over_payload_limit {
                let would = r.unlimited_endurance_min.map_or_else(
                    || "beyond the measured thrust range".to_owned(),
                    |t| format!("would give {} min", num(t, 2)),
                );
                (
                    format!("✕ 0 min: over the payload limit ({would})"),
                    colour::RED,
                )
            } else {
                (format!("{} min", num(r.endurance_min, 2)), colour::INK)
            };
            EmptyElement::at((r.endurance_min, row_of(i) as f64 + 0.5))
                + Text::new(
                    s,
                    (8, 0),
                    render::anchored(size::NOTE, &c, HPos::Left, VPos::Center),
                )
        }))?;
        Ok(())
    }
}
