//! Text without system fonts: DejaVu Sans, embedded by the `dejavu` crate, registered with
//! plotters' `ab_glyph` renderer under the family `sans-serif` (what every figure asks for,
//! and what an SVG viewer falls back to). No fontconfig or freetype is involved, so figures
//! render the same on a machine with only the Rust toolchain.

use std::sync::OnceLock;

use plotters::style::{FontStyle, register_font};

use crate::error::PlotError;

/// The font family every figure uses.
pub const FAMILY: &str = "sans-serif";

/// Registers the embedded fonts once per process.
pub fn ensure_registered() -> Result<(), PlotError> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        [
            (FontStyle::Normal, dejavu::sans::regular()),
            (FontStyle::Bold, dejavu::sans::bold()),
            (FontStyle::Italic, dejavu::sans::oblique()),
            (FontStyle::Oblique, dejavu::sans::oblique()),
        ]
        .into_iter()
        .all(|(style, bytes)| register_font(FAMILY, style, bytes).is_ok())
    });
    if ok { Ok(()) } else { Err(PlotError::Usage("the embedded DejaVu Sans font could not be loaded".into())) }
}
