//! The embedded font: DejaVu Sans (Bitstream Vera licence, DejaVu changes in the public domain),
//! shipped by the `dejavu` crate and registered with plotters' `ab_glyph` text backend, so that
//! no system font library or installed font is needed and text metrics are the same everywhere.

use std::sync::OnceLock;

use plotters::style::FontStyle;

use crate::ReportError;

/// Font family every figure uses. The name doubles as the CSS `font-family` list written into the
/// SVG files, so a viewer without DejaVu Sans falls back to its own sans-serif face.
pub const FONT_FAMILY: &str = "DejaVu Sans, sans-serif";

static REGISTERED: OnceLock<bool> = OnceLock::new();

/// Registers the embedded font with plotters (once per process).
pub(crate) fn ensure_registered() -> Result<(), ReportError> {
    let ok = REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, dejavu::sans::regular())
            .is_ok()
            && plotters::style::register_font(FONT_FAMILY, FontStyle::Bold, dejavu::sans::bold())
                .is_ok()
    });
    if *ok {
        Ok(())
    } else {
        Err(ReportError::Font {
            family: FONT_FAMILY,
        })
    }
}
