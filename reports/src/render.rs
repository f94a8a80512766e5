//! Rendering a figure to SVG text or PNG bytes, and the styles the figures share.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind,
};

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
    Ok(decode_fine_svg(&out))
}

/// Renders a figure as an 8-bit RGB PNG.
pub(crate) fn png<F: Draw>(figure: &F) -> Result<Vec<u8>, ReportError> {
    ensure_registered()?;
    let (w, h) = figure.size_px();
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    {
        let root = Smooth(BitMapBackend::with_buffer(&mut rgb, (w, h))).into_drawing_area();
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

// --- Curves with sub-pixel precision -------------------------------------------------------
//
// plotters hands its backends whole-pixel coordinates, so a smooth curve becomes a staircase
// of one-pixel steps. [`curve`] computes a curve's pixel positions as floats and passes them
// through plotters encoded as "fine" coordinates (an offset far outside any figure, in
// 1/[`FINE`] px units): the SVG text is decoded back to decimals ([`decode_fine_svg`]), and the
// PNG backend ([`Smooth`]) draws such paths itself, anti-aliased.

/// Sub-pixel units per pixel of an encoded coordinate.
const FINE: f64 = 64.0;
/// Offset that marks an encoded (sub-pixel) backend coordinate; ordinary coordinates stay
/// within ±1e6 ([`Axis`] clamps them), far below half of it.
const FINE_OFFSET: i32 = 1 << 28;

fn encode(px: f64) -> i32 {
    let px = if px.is_finite() {
        px.clamp(-1e5, 1e5)
    } else {
        0.0
    };
    FINE_OFFSET + (px * FINE).round() as i32
}

fn decode(c: i32) -> Option<f64> {
    (c > FINE_OFFSET / 2).then(|| f64::from(c - FINE_OFFSET) / FINE)
}

/// Pixel coordinates (floats) to encoded backend coordinates.
#[derive(Debug, Clone, Copy)]
struct FinePx;

impl plotters::coord::CoordTranslate for FinePx {
    type From = (f64, f64);

    fn translate(&self, p: &(f64, f64)) -> BackendCoord {
        (encode(p.0), encode(p.1))
    }
}

/// Splits a polyline (pixels) into dashes of `on` px separated by gaps of `off` px.
fn dashes(points: &[(f64, f64)], on: f64, off: f64) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let Some(&first) = points.first() else {
        return out;
    };
    if !(on > 0.0 && off >= 0.0) {
        return vec![points.to_vec()];
    }
    let (mut solid, mut left) = (true, on);
    let mut current = vec![first];
    for w in points.windows(2) {
        let (mut a, b) = (w[0], w[1]);
        let mut d = (b.0 - a.0).hypot(b.1 - a.1);
        while d > left {
            let t = left / d;
            let m = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
            if solid {
                if current.last() != Some(&m) {
                    current.push(m);
                }
                if current.len() > 1 {
                    out.push(std::mem::take(&mut current));
                }
            } else {
                current = vec![m];
            }
            solid = !solid;
            d -= left;
            left = if solid { on } else { off };
            a = m;
        }
        left -= d;
        if solid {
            current.push(b);
        }
    }
    if solid && current.len() > 1 {
        out.push(current);
    }
    out
}

/// Draws a curve through `points` (data coordinates of `chart`) with sub-pixel precision,
/// solid or dashed (`dash`: on and off lengths, px). Register its legend entry separately
/// (see [`legend_entry`]).
pub(crate) fn curve<DB: DrawingBackend>(
    chart: &ChartContext<'_, DB, Cartesian2d<Axis, Axis>>,
    points: &[(f64, f64)],
    style: ShapeStyle,
    dash: Option<(f64, f64)>,
) -> DrawResult<DB> {
    let area = chart.plotting_area();
    let (xr, yr) = area.get_pixel_range();
    // as plotters' chart builder maps: x from the left edge to the last column, y from the
    // last row up to the top edge
    let (x0, x1) = (f64::from(xr.start), f64::from(xr.end - 1));
    let (y0, y1) = (f64::from(yr.end - 1), f64::from(yr.start));
    let (xa, ya) = (chart.x_range(), chart.y_range());
    let pixels: Vec<(f64, f64)> = points
        .iter()
        .map(|&(x, y)| {
            (
                x0 + (x1 - x0) * (x - xa.start) / (xa.end - xa.start),
                y0 + (y1 - y0) * (y - ya.start) / (ya.end - ya.start),
            )
        })
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    let fine = area.strip_coord_spec().apply_coord_spec(FinePx);
    let inside = clip(&pixels, (x0, x1.max(x0)), (y1.min(y0), y0.max(y1)));
    for piece in inside {
        let pieces = match dash {
            None => vec![piece],
            Some((on, off)) => dashes(&piece, on, off),
        };
        for p in pieces {
            fine.draw(&FinePath { points: p, style })?;
        }
    }
    Ok(())
}

/// Maps pixel coordinates without plotters' clamping to the drawing area (which would fold
/// encoded coordinates onto its corner); [`curve`] clips the path itself.
struct Unclipped;

impl plotters::element::CoordMapper for Unclipped {
    type Output = BackendCoord;

    fn map<CT: plotters::coord::CoordTranslate>(
        coord: &CT,
        from: &CT::From,
        _: &plotters::drawing::Rect,
    ) -> BackendCoord {
        coord.translate(from)
    }
}

/// A polyline in pixel coordinates, drawn through [`FinePx`].
struct FinePath {
    points: Vec<(f64, f64)>,
    style: ShapeStyle,
}

impl<'a> plotters::element::PointCollection<'a, (f64, f64), Unclipped> for &'a FinePath {
    type Point = &'a (f64, f64);
    type IntoIter = &'a [(f64, f64)];

    fn point_iter(self) -> Self::IntoIter {
        &self.points
    }
}

impl<DB: DrawingBackend> plotters::element::Drawable<DB, Unclipped> for FinePath {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        points: I,
        backend: &mut DB,
        _: (u32, u32),
    ) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
        backend.draw_path(points, &self.style)
    }
}

/// The parts of a polyline inside the rectangle `x` × `y` (Liang–Barsky on each segment).
fn clip(points: &[(f64, f64)], x: (f64, f64), y: (f64, f64)) -> Vec<Vec<(f64, f64)>> {
    let inside = |p: (f64, f64)| p.0 >= x.0 && p.0 <= x.1 && p.1 >= y.0 && p.1 <= y.1;
    if points.len() == 1 {
        return if inside(points[0]) {
            vec![points.to_vec()]
        } else {
            Vec::new()
        };
    }
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut current: Vec<(f64, f64)> = Vec::new();
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
        let mut visible = true;
        for (p, q) in [
            (-dx, a.0 - x.0),
            (dx, x.1 - a.0),
            (-dy, a.1 - y.0),
            (dy, y.1 - a.1),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    visible = false;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
        if !visible || t0 > t1 {
            if current.len() > 1 {
                out.push(std::mem::take(&mut current));
            }
            current.clear();
            continue;
        }
        let s = (a.0 + t0 * dx, a.1 + t0 * dy);
        let e = (a.0 + t1 * dx, a.1 + t1 * dy);
        if current.last() != Some(&s) {
            if current.len() > 1 {
                out.push(std::mem::take(&mut current));
            }
            current = vec![s];
        }
        current.push(e);
        if t1 < 1.0 {
            out.push(std::mem::take(&mut current));
        }
    }
    if current.len() > 1 {
        out.push(current);
    }
    out
}

/// A legend entry for a series drawn with [`curve`] (an empty series carrying the label).
pub(crate) fn legend_entry<'a, 'b, DB: DrawingBackend + 'a>(
    chart: &'b mut ChartContext<'a, DB, Cartesian2d<Axis, Axis>>,
) -> Result<&'b mut plotters::chart::SeriesAnno<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    chart.draw_series(std::iter::empty::<PathElement<(f64, f64)>>())
}

/// The SVG text with encoded coordinates written as decimals (two places, trailing zeros
/// trimmed).
fn decode_fine_svg(svg: &str) -> String {
    let mut out = String::with_capacity(svg.len());
    let mut rest = svg;
    while let Some(i) = rest.find(|c: char| c.is_ascii_digit() || c == '-') {
        out.push_str(&rest[..i]);
        rest = &rest[i..];
        let len = rest
            .char_indices()
            .skip(1)
            .find(|(_, c)| !c.is_ascii_digit())
            .map_or(rest.len(), |(j, _)| j);
        let token = &rest[..len];
        match token.parse::<i32>().ok().and_then(decode) {
            // only whole tokens: not part of a decimal or a name
            Some(v) if !out.ends_with(|c: char| c.is_ascii_alphanumeric() || c == '.') => {
                let t = format!("{v:.2}");
                let t = t.trim_end_matches('0').trim_end_matches('.');
                out.push_str(if t == "-0" { "0" } else { t });
            }
            _ => out.push_str(token),
        }
        rest = &rest[len..];
    }
    out.push_str(rest);
    out
}

/// A raster backend that draws encoded (sub-pixel) paths itself, anti-aliased; everything
/// else goes to the wrapped backend unchanged.
struct Smooth<DB>(DB);

impl<DB: DrawingBackend> Smooth<DB> {
    /// An anti-aliased polyline: each pixel's coverage by a stroke of the style's width around
    /// the path (its largest over the segments, so joints are not drawn twice), blended once.
    fn smooth_path(
        &mut self,
        pts: &[(f64, f64)],
        colour: BackendColor,
        width: f64,
    ) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
        let (w, h) = self.0.get_size();
        let r = (width / 2.0).max(0.5);
        let reach = r + 1.0;
        let fold = |f: fn(f64, f64) -> f64, init: f64, c: fn(&(f64, f64)) -> f64| {
            pts.iter().map(c).fold(init, f)
        };
        let lo_x = (fold(f64::min, f64::INFINITY, |p| p.0) - reach)
            .floor()
            .max(0.0);
        let hi_x = (fold(f64::max, f64::NEG_INFINITY, |p| p.0) + reach)
            .ceil()
            .min(f64::from(w) - 1.0);
        let lo_y = (fold(f64::min, f64::INFINITY, |p| p.1) - reach)
            .floor()
            .max(0.0);
        let hi_y = (fold(f64::max, f64::NEG_INFINITY, |p| p.1) + reach)
            .ceil()
            .min(f64::from(h) - 1.0);
        if !(lo_x <= hi_x && lo_y <= hi_y) {
            return Ok(());
        }
        let (bw, bh) = ((hi_x - lo_x) as usize + 1, (hi_y - lo_y) as usize + 1);
        let mut cover = vec![0f32; bw * bh];
        let segments: Vec<((f64, f64), (f64, f64))> = if pts.len() == 1 {
            vec![(pts[0], pts[0])]
        } else {
            pts.windows(2).map(|s| (s[0], s[1])).collect()
        };
        for (a, b) in segments {
            let sx0 = ((a.0.min(b.0) - reach).floor().max(lo_x) - lo_x) as usize;
            let sx1 = ((a.0.max(b.0) + reach).ceil().min(hi_x) - lo_x) as usize;
            let sy0 = ((a.1.min(b.1) - reach).floor().max(lo_y) - lo_y) as usize;
            let sy1 = ((a.1.max(b.1) + reach).ceil().min(hi_y) - lo_y) as usize;
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let len2 = dx * dx + dy * dy;
            for iy in sy0..=sy1 {
                for ix in sx0..=sx1 {
                    let (px, py) = (lo_x + ix as f64, lo_y + iy as f64);
                    let t = if len2 > 0.0 {
                        (((px - a.0) * dx + (py - a.1) * dy) / len2).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let d = (px - a.0 - t * dx).hypot(py - a.1 - t * dy);
                    let c = (r + 0.5 - d).clamp(0.0, 1.0) as f32;
                    let cell = &mut cover[iy * bw + ix];
                    if c > *cell {
                        *cell = c;
                    }
                }
            }
        }
        for iy in 0..bh {
            for ix in 0..bw {
                let c = cover[iy * bw + ix];
                if c > 0.0 {
                    self.0.draw_pixel(
                        ((lo_x as usize + ix) as i32, (lo_y as usize + iy) as i32),
                        BackendColor {
                            alpha: colour.alpha * f64::from(c),
                            rgb: colour.rgb,
                        },
                    )?;
                }
            }
        }
        Ok(())
    }
}

impl<DB: DrawingBackend> DrawingBackend for Smooth<DB> {
    type ErrorType = DB::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let path: Vec<BackendCoord> = path.into_iter().collect();
        let fine: Option<Vec<(f64, f64)>> = path
            .iter()
            .map(|&(x, y)| Some((decode(x)?, decode(y)?)))
            .collect();
        match fine {
            Some(pts) if !pts.is_empty() => {
                if style.color().alpha == 0.0 {
                    return Ok(());
                }
                self.smooth_path(&pts, style.color(), f64::from(style.stroke_width()))
            }
            _ => self.0.draw_path(path, style),
        }
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.fill_polygon(vert, style)
    }

    fn draw_text<TStyle: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &TStyle,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_text(text, style, pos)
    }

    fn estimate_text_size<TStyle: BackendTextStyle>(
        &self,
        text: &str,
        style: &TStyle,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        self.0.estimate_text_size(text, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.blit_bitmap(pos, size, src)
    }
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

/// Splits `area` into panels for `n` small charts, at most four: one, two side by side, or a
/// 2 × 2 grid (a fourth panel stays blank with three charts).
pub(crate) fn panels<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    n: usize,
) -> Vec<DrawingArea<DB, Shift>> {
    let rows = if n > 2 { 2 } else { 1 };
    let cols = if n > 1 { 2 } else { 1 };
    area.split_evenly((rows, cols))
}

/// A chart over two [`Axis`] (see [`panel_chart`]).
pub(crate) type PanelChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<Axis, Axis>>;

/// A small chart on one of [`panels`]: captioned, over `x` × `y` (each refused by [`axis`]
/// when it cannot be drawn), with its mesh drawn: the axis descriptions `desc` and tick labels
/// to the precision of each span.
pub(crate) fn panel_chart<'a, DB: DrawingBackend>(
    panel: &'a DrawingArea<DB, Shift>,
    caption: &str,
    x: (f64, f64),
    y: (f64, f64),
    desc: (&str, &str),
) -> Result<PanelChart<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    chart(panel, Some(caption), x, y, desc)
}

/// A chart over `x` × `y` (each refused by [`axis`] when it cannot be drawn) with its mesh
/// drawn: the axis descriptions `desc` and tick labels to the precision of each span. With a
/// caption it is a small panel (see [`panel_chart`]); without, the one chart of a figure, with
/// wider margins and larger axis descriptions.
pub(crate) fn chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: Option<&str>,
    x: (f64, f64),
    y: (f64, f64),
    desc: (&str, &str),
) -> Result<PanelChart<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut builder = ChartBuilder::on(area);
    let (margin, y_labels, desc_size) = match caption {
        Some(c) => {
            builder.caption(c, text(size::SUBTITLE));
            (10, 64, size::TICK)
        }
        None => (16, 70, size::AXIS),
    };
    let mut chart = builder
        .margin(margin)
        .x_label_area_size(48)
        .y_label_area_size(y_labels)
        .build_cartesian_2d(axis("x", x.0, x.1)?, axis("y", y.0, y.1)?)?;
    let (xd, yd) = (tick_decimals(x.1 - x.0), tick_decimals(y.1 - y.0));
    chart
        .configure_mesh()
        .x_desc(desc.0)
        .y_desc(desc.1)
        .x_label_formatter(&|v| tick(*v, xd))
        .y_label_formatter(&|v| tick(*v, yd))
        .label_style(text(size::TICK))
        .axis_desc_style(text(desc_size))
        .bold_line_style(colour::GREY.mix(0.25))
        .max_light_lines(0)
        .draw()?;
    Ok(chart)
}

/// The smallest and largest finite value of `values`, starting from `from` (`(∞, −∞)` for
/// none, `(0, 0)` to include zero).
pub(crate) fn finite_range(values: impl Iterator<Item = f64>, from: (f64, f64)) -> (f64, f64) {
    values
        .filter(|v| v.is_finite())
        .fold(from, |(lo, hi), v| (lo.min(v), hi.max(v)))
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

/// Points drawn along a smooth curve (see [`thin`]): drawn with sub-pixel precision
/// ([`curve`]), a few hundred points give a smooth line.
pub(crate) const CURVE_POINTS: usize = 300;

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

    #[test]
    fn fine_coordinates_round_trip_and_svg_decodes_only_them() {
        for px in [0.0, 12.34375, -3.5, 799.984375] {
            assert_eq!(decode(encode(px)), Some(px));
        }
        assert_eq!(decode(640), None);
        assert_eq!(decode(-1_000_000), None);
        let a = encode(12.5);
        let b = encode(300.0);
        let svg = format!(
            r#"<polyline stroke-width="3" points="{a},{b} 40,50 "/><text x="12">268435456</text>"#
        );
        let d = decode_fine_svg(&svg);
        assert!(d.contains(r#"points="12.5,300 40,50 ""#), "{d}");
        assert!(d.contains(r#"stroke-width="3""#), "{d}");
    }

    #[test]
    fn dashes_alternate_along_the_path() {
        let d = dashes(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)], 4.0, 2.0);
        // 20 px of path: on 0-4, off 4-6, on 6-10, off 10-12 (round the corner), on 12-16,
        // off 16-18, on 18-20
        assert_eq!(d.len(), 4);
        assert_eq!(d[0], vec![(0.0, 0.0), (4.0, 0.0)]);
        assert_eq!(d[1], vec![(6.0, 0.0), (10.0, 0.0)]);
        assert_eq!(d[2], vec![(10.0, 2.0), (10.0, 6.0)]);
        assert_eq!(d[3], vec![(10.0, 8.0), (10.0, 10.0)]);
    }

    #[test]
    fn a_nearly_flat_curve_is_drawn_without_steps() {
        // a line rising 3 px over 300 px: drawn anti-aliased, the ink's centre of mass in
        // every column follows the line to a fraction of a pixel (a whole-pixel line jumps by
        // one pixel at a time, off by up to half a pixel)
        let (w, h) = (320u32, 40u32);
        let mut rgb = vec![255u8; (w * h * 3) as usize];
        {
            let mut b = Smooth(BitMapBackend::with_buffer(&mut rgb, (w, h)));
            let path = [(10.0, 20.0), (310.0, 23.0)];
            b.draw_path(
                path.iter().map(|&(x, y)| (encode(x), encode(y))),
                &plotters::style::Color::stroke_width(&BLACK, 3),
            )
            .unwrap();
            b.present().unwrap();
        }
        let mut worst: f64 = 0.0;
        for x in 20..300usize {
            let (mut ink, mut moment) = (0.0, 0.0);
            for y in 0..h as usize {
                let v = 1.0 - f64::from(rgb[(y * w as usize + x) * 3]) / 255.0;
                ink += v;
                moment += v * y as f64;
            }
            let centre = moment / ink;
            let want = 20.0 + 3.0 * (x as f64 - 10.0) / 300.0;
            worst = worst.max((centre - want).abs());
        }
        assert!(worst < 0.15, "the stroke strays {worst} px from the line");
    }

    #[test]
    fn curves_are_clipped_to_the_plot() {
        let r = clip(
            &[(-10.0, 5.0), (5.0, 5.0), (20.0, 5.0)],
            (0.0, 10.0),
            (0.0, 10.0),
        );
        assert_eq!(r, vec![vec![(0.0, 5.0), (5.0, 5.0), (10.0, 5.0)]]);
        // leaving and coming back gives two pieces
        let r = clip(
            &[(1.0, 1.0), (1.0, 20.0), (2.0, 20.0), (2.0, 1.0)],
            (0.0, 10.0),
            (0.0, 10.0),
        );
        assert_eq!(
            r,
            vec![vec![(1.0, 1.0), (1.0, 10.0)], vec![(2.0, 10.0), (2.0, 1.0)]]
        );
        assert!(clip(&[(20.0, 20.0), (30.0, 30.0)], (0.0, 10.0), (0.0, 10.0)).is_empty());
    }
}
