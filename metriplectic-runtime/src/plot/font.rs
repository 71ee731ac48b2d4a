//! The font every figure uses, embedded so that plotting needs no system fonts.
//!
//! plotters' `ab_glyph` text renderer only knows fonts registered at run
//! time. We register a subset of DejaVu Sans (79 KB, see
//! `assets/fonts/README.md` for provenance and licence) once per process
//! under the family name [`FAMILY`].

use std::sync::OnceLock;

use plotters::style::{register_font, FontStyle};

use super::PlotError;

/// The family name figures ask for.
pub(crate) const FAMILY: &str = "sans-serif";

/// DejaVu Sans, subset to Latin, Greek and mathematical symbols.
static DEJAVU_SANS: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-subset.ttf");

/// Registers the embedded font with plotters (once; later calls are free).
pub(crate) fn ensure_registered() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok =
        *REGISTERED.get_or_init(|| register_font(FAMILY, FontStyle::Normal, DEJAVU_SANS).is_ok());
    if ok {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}
