//! The self-contained HTML report: figures inline as SVG, their numbers in tables, provenance.
//! No scripts, no external style sheets, fonts or images: it opens offline.

use std::fmt::Write as _;

use estimator::PowerCurve;

use crate::figure::RenderedFigure;
use crate::render::num;
use crate::{
    BatteryMassFigure, CatalogueFigure, Figure, PayloadFigure, ReportInput, ThrustCurveFigure,
    TimelineFigure,
};

/// Escapes text for HTML element content and attribute values.
pub(crate) fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// An SVG document as an inline `<svg>` element: HTML puts it in the SVG namespace itself, so
/// the namespace declaration (the only URL in plotters' output) is dropped.
fn inline_svg(svg: &str) -> String {
    let body = svg
        .trim_start()
        .strip_prefix("<?xml")
        .and_then(|rest| rest.split_once("?>").map(|(_, r)| r))
        .unwrap_or(svg);
    body.replacen(" xmlns=\"http://www.w3.org/2000/svg\"", "", 1)
        .trim()
        .to_owned()
}

struct Table {
    html: String,
}

impl Table {
    fn new(header: &[&str]) -> Self {
        let mut html = String::from("<table>\n<thead><tr>");
        for h in header {
            let _ = write!(html, "<th>{}</th>", escape(h));
        }
        html.push_str("</tr></thead>\n<tbody>\n");
        Self { html }
    }

    fn row<S: AsRef<str>>(&mut self, cells: &[S]) {
        self.html.push_str("<tr>");
        for c in cells {
            let _ = write!(self.html, "<td>{}</td>", escape(c.as_ref()));
        }
        self.html.push_str("</tr>\n");
    }

    fn finish(mut self) -> String {
        self.html.push_str("</tbody>\n</table>\n");
        self.html
    }
}

const STYLE: &str = "body{font-family:'DejaVu Sans',Verdana,sans-serif;max-width:1100px;margin:2em auto;\
padding:0 1em;color:#1e1e1e;line-height:1.4}\
h1{font-size:1.6em}h2{font-size:1.25em;margin-top:2em;border-bottom:1px solid #ccc}\
table{border-collapse:collapse;margin:0.8em 0;font-size:0.92em}\
th,td{border:1px solid #ccc;padding:0.25em 0.6em;text-align:left}\
td{font-variant-numeric:tabular-nums}th{background:#f2f2f2}\
figure{margin:1em 0}figure svg{max-width:100%;height:auto;border:1px solid #eee}\
figcaption{color:#555;font-size:0.9em}.note{color:#555;font-size:0.9em}";

/// The whole page.
pub(crate) fn page(input: &ReportInput, figures: &[Figure], rendered: &[RenderedFigure]) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{}</h1>\n",
        escape(&input.title),
        escape(&input.title)
    );
    h.push_str(&model_section(input));
    if !input.comparisons.is_empty() {
        h.push_str("<h2>Results beside their references</h2>\n");
        let mut t = Table::new(&[
            "result",
            "here",
            "reference",
            "difference",
            "reference source",
        ]);
        for c in &input.comparisons {
            let diff = if c.reference != 0.0 {
                format!("{:+.2} %", (c.value - c.reference) / c.reference * 100.0)
            } else {
                "–".to_owned()
            };
            t.row(&[
                c.what.clone(),
                format!("{} {}", num(c.value, 4), c.unit),
                format!("{} {}", c.reference, c.unit),
                diff,
                c.reference_source.clone(),
            ]);
        }
        h.push_str(&t.finish());
    }
    for (f, r) in figures.iter().zip(rendered) {
        let _ = write!(
            h,
            "<section id=\"{}\">\n<h2>{}</h2>\n<figure>\n{}\n<figcaption>{} (files: {}.svg, {}.png)</figcaption>\n</figure>\n",
            r.stem,
            escape(&r.title),
            inline_svg(&r.svg),
            escape(&r.title),
            r.stem,
            r.stem
        );
        h.push_str(&match f {
            Figure::ThrustCurve(f) => thrust_tables(f),
            Figure::BatteryMass(f) => battery_mass_tables(f),
            Figure::Catalogue(f) => catalogue_tables(f),
            Figure::Payload(f) => payload_tables(f),
            Figure::Timeline(f) => timeline_tables(f),
        });
        h.push_str("</section>\n");
    }
    h.push_str("<h2>Provenance</h2>\n");
    let mut t = Table::new(&["item", "value"]);
    for (k, v) in &input.provenance {
        t.row(&[k, v]);
    }
    t.row(&[
        "figures".to_owned(),
        format!(
            "drawn by hoverbench reports {} with plotters, text in the embedded DejaVu Sans font",
            env!("CARGO_PKG_VERSION")
        ),
    ]);
    h.push_str(&t.finish());
    h.push_str("</body>\n</html>\n");
    h
}

fn model_section(input: &ReportInput) -> String {
    let c = input.model.curve();
    let (lo, hi) = c.valid_range_g();
    let mut t = Table::new(&["quantity", "value"]);
    t.row(&["rotors".to_owned(), input.model.rotor_count().to_string()]);
    if let Some(m) = input.model.with_platform() {
        t.row(&[
            "structure mass m_S".to_owned(),
            format!("{} kg", num(m.platform.structure_mass_kg, 3)),
        ]);
        t.row(&[
            "avionics power p_A".to_owned(),
            format!("{} W", num(m.platform.avionics_power_w, 3)),
        ]);
        t.row(&[
            "payload m_P, p_P".to_owned(),
            format!(
                "{} kg, {} W",
                num(input.payload.mass_kg, 3),
                num(input.payload.power_w, 3)
            ),
        ]);
    } else {
        // A report of a parameter file alone has no platform: say so.
        t.row(&[
            "platform m_S, p_A".to_owned(),
            "not given (--structure-mass, --avionics-power)".to_owned(),
        ]);
    }
    t.row(&[
        "thrust curve".to_owned(),
        format!(
            "degree {}, valid {}–{} g per rotor{}",
            c.degree(),
            num(lo, 1),
            num(hi, 1),
            c.supply_voltage_v()
                .map(|v| format!(", at {} V", num(v, 2)))
                .unwrap_or_default()
        ),
    ]);
    let coeffs: Vec<String> = c
        .coefficients_scaled()
        .iter()
        .map(|v| format!("{v:.9e}"))
        .collect();
    t.row(&[
        format!(
            "P(T) = Σ c_k t^k, t = (T − {}) / {}",
            num(c.center_g(), 3),
            num(c.scale_g(), 3)
        ),
        coeffs.join(", "),
    ]);
    t.row(&[
        "thrust limit m_L".to_owned(),
        match (input.model.thrust_limit_kg(), &input.thrust_limit) {
            (Some(l), Some(mk)) => format!(
                "{} kg ({}{} g per rotor{}{})",
                num(l, 3),
                num(mk.per_rotor_g, 1),
                if mk.uncertainty_g > 0.0 {
                    format!(" ± {}", num(mk.uncertainty_g, 1))
                } else {
                    String::new()
                },
                mk.supply_voltage_v
                    .map(|v| format!(" at {} V", num(v, 2)))
                    .unwrap_or_default(),
                mk.note
                    .as_ref()
                    .map(|n| format!("; {n}"))
                    .unwrap_or_default()
            ),
            (Some(l), None) => format!("{} kg", num(l, 3)),
            (None, _) => "unknown: no payload limit applied".to_owned(),
        },
    ]);
    format!("<h2>Model</h2>\n{}", t.finish())
}

/// Most measured steps listed in the report's table.
const MAX_TABLE_STEPS: usize = 500;

fn thrust_tables(f: &ThrustCurveFigure) -> String {
    let Some(s) = f.residual_summary() else {
        return "<p class=\"note\">No measured steps: the fitted curve alone is drawn.</p>\n"
            .to_owned();
    };
    let mut out = format!(
        "<p>{} measured steps: RMSE {} W, largest residual {} W at {} g.</p>\n",
        s.n_points,
        num(s.rmse_w, 4),
        num(s.max_abs_w, 4),
        num(s.max_abs_at_g, 1)
    );
    if s.n_points > MAX_TABLE_STEPS {
        out.push_str(&format!(
            "<p class=\"note\">The {} steps are too many for a table; they are in the sweep file.</p>\n",
            s.n_points
        ));
        return out;
    }
    let mut t = Table::new(&[
        "thrust (g)",
        "measured (W)",
        "± 1σ (W)",
        "fitted (W)",
        "residual (W)",
    ]);
    for (m, r) in f.residuals() {
        t.row(&[
            num(m.thrust_g, 1),
            num(m.power_w, 3),
            m.power_std_w.map_or("–".to_owned(), |s| num(s, 3)),
            num(m.power_w - r, 3),
            num(r, 4),
        ]);
    }
    out.push_str(&t.finish());
    out
}

fn battery_mass_tables(f: &BatteryMassFigure) -> String {
    let mut t = Table::new(&["point", "battery mass m_B", "endurance t_E"]);
    t.row(&[
        "ideal optimum".to_owned(),
        format!("{} kg", num(f.ideal.battery_mass_kg, 4)),
        format!("{} min", num(f.ideal.endurance_min, 2)),
    ]);
    if let Some(m) = f.limit_battery_mass_kg {
        t.row(&[
            "payload limit (m_X = 0)".to_owned(),
            format!("{} kg", num(m, 4)),
            "–".to_owned(),
        ]);
    }
    if let Some(r) = f.realistic {
        t.row(&[
            "realistic optimum".to_owned(),
            format!("{} kg", num(r.battery_mass_kg, 4)),
            format!("{} min", num(r.endurance_min, 2)),
        ]);
    }
    t.finish()
}

fn catalogue_tables(f: &CatalogueFigure) -> String {
    let mut t = Table::new(&[
        "rank",
        "pack",
        "mass (g)",
        "energy (Wh)",
        "e_D (Wh/kg)",
        "t_E (min)",
        "over payload limit",
        "t_E if it could fly (min)",
    ]);
    for r in &f.ranking {
        t.row(&[
            r.rank.to_string(),
            r.battery.name.clone(),
            num(r.battery.battery.mass_kg * 1000.0, 1),
            num(r.battery.battery.energy_wh, 2),
            num(r.battery.energy_density_wh_per_kg(), 1),
            num(r.endurance_min, 2),
            if r.over_payload_limit { "yes" } else { "no" }.to_owned(),
            r.unlimited_endurance_min
                .map_or("beyond the curve".to_owned(), |t| num(t, 2)),
        ]);
    }
    t.finish()
}

fn payload_tables(f: &PayloadFigure) -> String {
    let mut t = Table::new(&[
        "battery",
        "p_P (W)",
        "t_E without payload (min)",
        "payload limit m_X (kg)",
        "t_E at the limit (min)",
    ]);
    for s in &f.series {
        t.row(&[
            s.battery.name.clone(),
            num(s.payload_power_w, 2),
            s.points.first().map_or("–".to_owned(), |p| num(p.1, 2)),
            s.payload_limit_kg
                .map_or("unknown".to_owned(), |l| num(l, 4)),
            s.points.last().map_or("–".to_owned(), |p| num(p.1, 2)),
        ]);
    }
    let mut out = t.finish();
    if !f.measured.is_empty() {
        let mut t = Table::new(&[
            "battery",
            "m_P (kg)",
            "p_P (W)",
            "measured (min)",
            "samples",
            "estimate (min)",
            "error",
        ]);
        for c in &f.measured {
            let m = &c.flight;
            t.row(&[
                m.battery.clone(),
                num(m.payload_mass_kg, 3),
                num(m.payload_power_w, 2),
                match m.endurance_std_min {
                    Some(s) => format!("{} ± {}", num(m.endurance_mean_min, 2), num(s, 2)),
                    None => num(m.endurance_mean_min, 2),
                },
                m.samples.map_or("–".to_owned(), |n| n.to_string()),
                c.estimate_min.map_or("–".to_owned(), |e| num(e, 2)),
                c.error_pct()
                    .map_or("–".to_owned(), |e| format!("{e:+.2} %")),
            ]);
        }
        out.push_str("<p>Measured flights beside the estimates; error = (estimate − measured) / measured.</p>\n");
        out.push_str(&t.finish());
    }
    out
}

fn timeline_tables(f: &TimelineFigure) -> String {
    let mut t = Table::new(&[
        "#",
        "phase",
        "start (min)",
        "end (min)",
        "energy left (Wh)",
        "t_R at end (min)",
    ]);
    for (i, s) in f.segments.iter().enumerate() {
        t.row(&[
            (i + 1).to_string(),
            if s.hover { "hover" } else { "attached" }.to_owned(),
            num(s.start_min, 2),
            num(s.end_min, 2),
            num(s.energy_end_wh, 3),
            num(s.reserved_end_min, 2),
        ]);
    }
    let mut out = format!(
        "<p>Total {} min{}.</p>\n",
        num(f.total_min, 2),
        f.ran_out_at_min
            .map(|t| format!(
                "; the battery runs out at {} min, before the plan ends",
                num(t, 2)
            ))
            .unwrap_or_default()
    );
    out.push_str(&t.finish());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_escaped() {
        assert_eq!(
            escape(r#"<a href="x">&'"#),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;"
        );
    }

    #[test]
    fn inline_svg_drops_the_xml_declaration_and_the_namespace_url() {
        let svg = "<?xml version=\"1.0\"?>\n<svg width=\"10\" height=\"10\" xmlns=\"http://www.w3.org/2000/svg\">\n</svg>\n";
        assert_eq!(inline_svg(svg), "<svg width=\"10\" height=\"10\">\n</svg>");
    }
}
