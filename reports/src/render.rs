//! Rendering a figure to SVG text or PNG bytes, and the styles the figures share.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::DrawingErrorKind;

use crate::ReportError;
use crate::font::{FONT_FAMILY, ensure_registered};

/// What a figure's drawing code returns.
pub(crate) type DrawResult<DB> =
    Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// A figure that can draw itself on any plotters backend.
pub(crate) trait Draw {
    /// File stem, e.g. `fig3-thrust-curve`.
    fn stem(&self) -> &'static str;
    /// Size in pixels (SVG user units and PNG pixels alike).
    fn size_px(&self) -> (u32, u32);
    /// Draws the whole figure on `root`, which is already filled white.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB>;
}

fn draw_error<E: std::error::Error + Send + Sync>(
    figure: &'static str,
    format: &'static str,
) -> impl FnOnce(DrawingAreaErrorKind<E>) -> ReportError {
    move |e| {
        if let DrawingAreaErrorKind::BackendError(DrawingErrorKind::FontError(inner)) = &e {
            if let Some(u) = inner.downcast_ref::<Unplottable>() {
                return ReportError::Unplottable {
                    figure,
                    axis: u.axis,
                    lo: u.lo,
                    hi: u.hi,
                };
            }
        }
        ReportError::Draw {
            figure,
            format,
            message: e.to_string(),
        }
    }
}

/// Largest magnitude an axis may reach: beyond it the input holds an absurd value (a power of
/// 1e300 W is a corrupt file, not a measurement) and the figure is refused, not drawn.
pub(crate) const AXIS_LIMIT: f64 = 1e15;

/// An axis range that cannot be drawn; carried through plotters' error type and turned into
/// [`ReportError::Unplottable`] by the renderers.
#[derive(Debug)]
struct Unplottable {
    axis: &'static str,
    lo: f64,
    hi: f64,
}

impl std::fmt::Display for Unplottable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the {} axis spans {:e}..{:e}",
            self.axis, self.lo, self.hi
        )
    }
}

impl std::error::Error for Unplottable {}

/// A linear `f64` axis from `lo` to `hi` whose tick placement terminates for every range (plotters'
/// own loops forever on an infinite span). Ranges that cannot be drawn — not finite, empty, or
/// reversed, or beyond ±[`AXIS_LIMIT`] — are refused; an empty span gets a margin with an error naming the axis.
pub(crate) fn axis<E: std::error::Error + Send + Sync>(
    name: &'static str,
    lo: f64,
    hi: f64,
) -> Result<Axis, DrawingAreaErrorKind<E>> {
    let ok = lo.is_finite()
        && hi.is_finite()
        && lo <= hi
        && lo.abs() <= AXIS_LIMIT
        && hi.abs() <= AXIS_LIMIT;
    if ok {
        // an empty (or numerically empty) span gets a margin around its value
        let magnitude = hi.abs().max(lo.abs());
        if hi - lo <= magnitude * 1e-12 {
            let pad = (magnitude * 1e-6).max(0.5);
            return Ok(Axis {
                lo: lo - pad,
                hi: hi + pad,
            });
        }
        Ok(Axis { lo, hi })
    } else {
        Err(DrawingAreaErrorKind::BackendError(
            DrawingErrorKind::FontError(Box::new(Unplottable { axis: name, lo, hi })),
        ))
    }
}

/// A linear axis (see [`axis`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Axis {
    lo: f64,
    hi: f64,
}

impl Axis {
    /// Tick values: multiples of 1, 2 or 5 × 10ⁿ, at most `max_points` of them; a bounded loop.
    fn ticks(&self, max_points: usize) -> Vec<f64> {
        let span = self.hi - self.lo;
        if max_points == 0 || !(span.is_finite() && span > 0.0) {
            return Vec::new();
        }
        let raw = span / max_points as f64;
        let magnitude = 10f64.powf(raw.log10().floor());
        let step = [1.0, 2.0, 5.0, 10.0]
            .iter()
            .map(|m| m * magnitude)
            .find(|s| span / s <= max_points as f64)
            .unwrap_or(10.0 * magnitude);
        if !(step.is_finite() && step > 0.0) {
            return Vec::new();
        }
        let first = (self.lo / step).ceil();
        let n = ((self.hi / step).floor() - first).max(-1.0);
        let n = if n.is_finite() {
            (n as usize + 1).min(max_points + 1)
        } else {
            0
        };
        (0..n)
            .map(|i| (first + i as f64) * step)
            // -0 and 1e-17 are 0
            .map(|v| if v.abs() < step * 1e-9 { 0.0 } else { v })
            .filter(|v| *v >= self.lo - step * 1e-9 && *v <= self.hi + step * 1e-9)
            .collect()
    }
}

impl plotters::coord::ranged1d::Ranged for Axis {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        // as plotters maps, with far-outside points clamped (drawing clips them) and NaN mapped
        // to the start
        let fraction = (v - self.lo) / (self.hi - self.lo);
        let length = f64::from(limit.1 - limit.0);
        let offset = if length >= 0.0 {
            (length * fraction + 1e-3).floor()
        } else {
            (length * fraction - 1e-3).ceil()
        };
        if offset.is_nan() {
            limit.0
        } else {
            limit.0 + offset.clamp(-1e6, 1e6) as i32
        }
    }

    fn key_points<H: plotters::coord::ranged1d::KeyPointHint>(&self, hint: H) -> Vec<f64> {
        self.ticks(hint.max_num_points())
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}

/// Renders a figure as SVG text.
pub(crate) fn svg<F: Draw>(figure: &F) -> Result<String, ReportError> {
    ensure_registered()?;
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, figure.size_px()).into_drawing_area();
        let err = || draw_error(figure.stem(), "SVG");
        root.fill(&WHITE).map_err(err())?;
        figure.draw(&root).map_err(err())?;
        root.present().map_err(err())?;
    }
    Ok(out)
}

/// Renders a figure as an 8-bit RGB PNG.
pub(crate) fn png<F: Draw>(figure: &F) -> Result<Vec<u8>, ReportError> {
    ensure_registered()?;
    let (w, h) = figure.size_px();
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        let err = || draw_error(figure.stem(), "PNG");
        root.fill(&WHITE).map_err(err())?;
        figure.draw(&root).map_err(err())?;
        root.present().map_err(err())?;
    }
    let png_error = |e: png::EncodingError| ReportError::Png {
        figure: figure.stem(),
        message: e.to_string(),
    };
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        // The "up" filter alone compresses these flat, mostly white images as well as adaptive
        // filtering does, at a fraction of the time.
        enc.set_compression(png::Compression::Balanced);
        enc.set_filter(png::Filter::Up);
        let mut writer = enc.write_header().map_err(png_error)?;
        writer.write_image_data(&rgb).map_err(png_error)?;
        writer.finish().map_err(png_error)?;
    }
    Ok(out)
}

/// Writes bytes atomically (`outfile::write_atomic`: a temporary file beside `path`, fsync,
/// rename; the temporary file is removed on error), so that a failure never leaves a
/// half-written file or a stray temporary one.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), ReportError> {
    outfile::write_atomic(path, bytes).map_err(ReportError::from)
}

/// Colours of the figures (colour-blind-safe, after Okabe and Ito).
pub(crate) mod colour {
    use plotters::style::RGBColor;

    /// Fitted curves, first series.
    pub const BLUE: RGBColor = RGBColor(0, 114, 178);
    /// Limits and over-limit marks.
    pub const RED: RGBColor = RGBColor(213, 94, 0);
    /// Second series.
    pub const ORANGE: RGBColor = RGBColor(230, 159, 0);
    /// Third series, attached phases.
    pub const GREEN: RGBColor = RGBColor(0, 158, 115);
    /// Fourth series.
    pub const PURPLE: RGBColor = RGBColor(204, 121, 167);
    /// Measurements, text.
    pub const INK: RGBColor = RGBColor(30, 30, 30);
    /// Grid and secondary marks.
    pub const GREY: RGBColor = RGBColor(120, 120, 120);

    /// Colour of the `i`-th series.
    pub fn series(i: usize) -> RGBColor {
        [BLUE, ORANGE, GREEN, PURPLE, GREY][i % 5]
    }
}

/// Font sizes, px.
pub(crate) mod size {
    /// Figure title.
    pub const TITLE: f64 = 26.0;
    /// Subtitle (parameters under the title).
    pub const SUBTITLE: f64 = 18.0;
    /// Axis descriptions.
    pub const AXIS: f64 = 20.0;
    /// Tick labels, legend.
    pub const TICK: f64 = 17.0;
    /// Annotations in the plot.
    pub const NOTE: f64 = 17.0;
}

/// A text style in the embedded font.
pub(crate) fn text(size: f64) -> TextStyle<'static> {
    coloured(size, &colour::INK)
}

/// A text style in the embedded font and a colour.
pub(crate) fn coloured(size: f64, colour: &RGBColor) -> TextStyle<'static> {
    let mut style = TextStyle::from((FONT_FAMILY, size).into_font());
    style.color = colour.to_backend_color();
    style
}

/// A text style anchored at the given position.
pub(crate) fn anchored(size: f64, colour: &RGBColor, h: HPos, v: VPos) -> TextStyle<'static> {
    coloured(size, colour).pos(Pos::new(h, v))
}

/// Draws a title and a subtitle (one or more lines) at the top of `root` and returns the area
/// below them.
pub(crate) fn titled<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    subtitle: &str,
) -> Result<DrawingArea<DB, Shift>, DrawingAreaErrorKind<DB::ErrorType>> {
    let (w, _) = root.dim_in_pixel();
    let centre = i32::try_from(w / 2).unwrap_or(0);
    root.draw(&Text::new(
        title.to_owned(),
        (centre, 12),
        anchored(size::TITLE, &colour::INK, HPos::Center, VPos::Top),
    ))?;
    let mut top = 12 + size::TITLE as i32 + 6;
    for line in subtitle.lines().filter(|l| !l.is_empty()) {
        root.draw(&Text::new(
            line.to_owned(),
            (centre, top),
            anchored(size::SUBTITLE, &colour::GREY, HPos::Center, VPos::Top),
        ))?;
        top += size::SUBTITLE as i32 + 4;
    }
    top += 2;
    Ok(root.margin(top, 0, 0, 0))
}

/// Legend box style shared by the figures.
pub(crate) fn legend<'a, 'b, DB, CT>(
    chart: &'b mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> DrawResult<DB>
where
    DB: DrawingBackend + 'a,
    CT: plotters::coord::CoordTranslate,
{
    chart
        .configure_series_labels()
        .position(position)
        .margin(12)
        .legend_area_size(34)
        .label_font(text(size::TICK))
        .background_style(WHITE.mix(0.9))
        .border_style(colour::GREY)
        .draw()
}

/// Formats a number with `digits` decimals, without a negative zero.
pub(crate) fn num(v: f64, digits: usize) -> String {
    let s = format!("{v:.digits$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_owned()
    } else {
        s
    }
}

/// Linear range with a margin on both sides (and a unit span when the data have none).
pub(crate) fn padded(lo: f64, hi: f64, fraction: f64) -> (f64, f64) {
    let span = hi - lo;
    if span.is_finite() && span > 0.0 {
        (lo - span * fraction, hi + span * fraction)
    } else {
        (lo - 0.5, hi + 0.5)
    }
}

/// Tick label formatting for an axis spanning `span`: enough decimals for plotters' finest tick
/// step (it puts up to about ten ticks on an axis), trailing zeros trimmed.
pub(crate) fn tick_decimals(span: f64) -> usize {
    if !(span.is_finite() && span > 0.0) {
        return 3;
    }
    let d = (-(span / 10.0).log10()).ceil() + 1.0;
    if d <= 0.0 { 0 } else { d.min(8.0) as usize }
}

/// A tick label: `v` with `decimals` decimals, trailing zeros (and a bare point) trimmed.
pub(crate) fn tick(v: f64, decimals: usize) -> String {
    let s = num(v, decimals);
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        s
    }
}

/// Points of a smooth curve to draw as a thick polyline: at most `max`, evenly spaced through
/// `points`, the first and last kept. Pixel coordinates are whole numbers, so a curve drawn
/// through hundreds of points a few pixels apart becomes a staircase of one-pixel jumps; fewer,
/// longer segments stay straight and smooth.
pub(crate) fn thin(points: &[(f64, f64)], max: usize) -> Vec<(f64, f64)> {
    if points.len() <= max || max < 2 {
        return points.to_vec();
    }
    let last = points.len() - 1;
    (0..max)
        .map(|i| points[(i * last + (max - 1) / 2) / (max - 1)])
        .collect()
}

/// Points drawn along a smooth curve (see [`thin`]).
pub(crate) const CURVE_POINTS: usize = 48;

/// Horizontal anchor for a label beside a point at `fraction` (0 = left, 1 = right) of the plot
/// width, so that the label stays inside the plot.
pub(crate) fn h_anchor(fraction: f64) -> HPos {
    if fraction > 0.7 {
        HPos::Right
    } else if fraction < 0.3 {
        HPos::Left
    } else {
        HPos::Center
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_have_the_decimals_the_step_needs() {
        // plotters steps 0.05 over a 0.5 span: two decimals, trailing zeros trimmed.
        let d = tick_decimals(0.5);
        let labels: Vec<String> = [0.0, 0.05, 0.1, 0.15].iter().map(|&v| tick(v, d)).collect();
        assert_eq!(labels, ["0", "0.05", "0.1", "0.15"]);
        assert_eq!(tick(250.0, tick_decimals(260.0)), "250");
        assert_eq!(tick(-0.5, tick_decimals(2.0)), "-0.5");
        assert_eq!(tick(-0.0, 2), "0");
    }

    #[test]
    fn ticks_terminate_and_stay_few_for_any_range() {
        for (lo, hi) in [
            (0.0, 1.0),
            (-3.0, 7.5),
            (0.0, 1e15),
            (-1e15, 1e15),
            (1e14, 1e14 + 1.0),
            (0.0, 1e-300),
            (1e-310, 2e-310),
        ] {
            let a = Axis { lo, hi };
            let t = a.ticks(10);
            assert!(t.len() <= 11, "{lo}..{hi}: {t:?}");
            assert!(t.iter().all(|v| *v >= lo && *v <= hi), "{lo}..{hi}: {t:?}");
        }
        // infinite or NaN spans give no ticks instead of a loop
        for (lo, hi) in [(-1e308, 1e308), (0.0, f64::INFINITY), (f64::NAN, 1.0)] {
            assert!(Axis { lo, hi }.ticks(10).is_empty());
        }
        assert_eq!(Axis { lo: 0.0, hi: 1.0 }.ticks(10).len(), 11);
        assert_eq!(
            Axis { lo: 0.0, hi: 10.0 }.ticks(5),
            [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
        );
    }

    #[test]
    fn absurd_ranges_are_refused() {
        type E = std::io::Error;
        assert!(axis::<E>("x", 0.0, 1e300).is_err());
        assert!(axis::<E>("x", 0.0, f64::INFINITY).is_err());
        assert!(axis::<E>("x", 2.0, 1.0).is_err());
        assert!(axis::<E>("x", 1.0, 1.0).is_ok());
        assert!(axis::<E>("x", f64::NAN, 1.0).is_err());
        assert!(axis::<E>("x", -3.0, 120.0).is_ok());
    }

    #[test]
    fn numbers_never_show_a_negative_zero() {
        assert_eq!(num(-0.0001, 2), "0.00");
        assert_eq!(num(-0.01, 2), "-0.01");
        assert_eq!(num(13.826, 2), "13.83");
    }

    #[test]
    fn thinned_curves_keep_their_ends() {
        let pts: Vec<(f64, f64)> = (0..=300)
            .map(|i| (f64::from(i), f64::from(i * i)))
            .collect();
        let t = thin(&pts, 48);
        assert_eq!(t.len(), 48);
        assert_eq!(t[0], pts[0]);
        assert_eq!(*t.last().unwrap(), pts[300]);
        assert!(t.windows(2).all(|w| w[0].0 < w[1].0));
        assert_eq!(thin(&pts[..10], 48).len(), 10);
    }

    #[test]
    fn padded_ranges_always_have_a_span() {
        assert_eq!(padded(0.0, 10.0, 0.1), (-1.0, 11.0));
        let (lo, hi) = padded(3.0, 3.0, 0.1);
        assert!(lo < 3.0 && hi > 3.0);
    }
}
