//! Writing a figure to a PNG or SVG file chosen by the path's extension.

use std::path::Path;

use plotters::coord::Shift;
use plotters::drawing::DrawingAreaErrorKind;
use plotters::prelude::*;

use super::{font, PlotError};

/// A figure that can draw itself onto any plotters backend.
pub(crate) trait Figure {
    /// Width and height in pixels (PNG) or user units (SVG).
    fn size(&self) -> (u32, u32);

    /// Draws the whole figure onto `root`, which is already filled white.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), Failure>;
}

/// A drawing failure inside plotters, reduced to its message.
///
/// plotters' error type is generic over the backend, so it is flattened here
/// and given the output path in [`render`].
#[derive(Debug)]
pub(crate) struct Failure(pub(crate) String);

impl<E: std::error::Error + Send + Sync> From<DrawingAreaErrorKind<E>> for Failure {
    fn from(err: DrawingAreaErrorKind<E>) -> Self {
        Failure(err.to_string())
    }
}

/// The output formats, chosen by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Png,
    Svg,
}

impl Format {
    fn of(path: &Path) -> Result<Self, PlotError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png") => Ok(Format::Png),
            Some("svg") => Ok(Format::Svg),
            _ => Err(PlotError::UnsupportedFormat {
                path: path.to_path_buf(),
            }),
        }
    }
}

/// Checks the path's extension before any work is done.
pub(crate) fn check_format(path: &Path) -> Result<(), PlotError> {
    Format::of(path).map(|_| ())
}

/// Draws `figure` and writes it to `path` as PNG or SVG.
pub(crate) fn render<F: Figure>(path: &Path, figure: &F) -> Result<(), PlotError> {
    font::ensure_registered()?;
    let drawing = |err: Failure| PlotError::Drawing {
        path: path.to_path_buf(),
        message: err.0,
    };
    let (width, height) = figure.size();
    match Format::of(path)? {
        Format::Png => {
            let mut rgb = vec![0u8; width as usize * height as usize * 3];
            {
                let root =
                    BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
                draw_on(&root, figure).map_err(drawing)?;
            }
            write_png(path, &rgb, width, height)
        }
        Format::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
                draw_on(&root, figure).map_err(drawing)?;
            }
            replace_atomically(path, svg.as_bytes())
        }
    }
}

/// Draws the series legend in the upper-right corner of the plotting area,
/// in the style every figure shares.
pub(crate) fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> Result<(), Failure> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font(super::style::small())
        .legend_area_size(super::style::LEGEND_AREA)
        .margin(12)
        .draw()?;
    Ok(())
}

fn draw_on<DB: DrawingBackend, F: Figure>(
    root: &DrawingArea<DB, Shift>,
    figure: &F,
) -> Result<(), Failure> {
    root.fill(&WHITE)?;
    figure.draw(root)?;
    root.present()?;
    Ok(())
}

/// Encodes 8-bit RGB pixels as PNG (the `png` crate is much lighter than
/// plotters' `image`-based encoder).
fn write_png(path: &Path, rgb: &[u8], width: u32, height: u32) -> Result<(), PlotError> {
    let mut out = Vec::new();
    let encoding = |err: png::EncodingError| PlotError::Encoding {
        path: path.to_path_buf(),
        message: err.to_string(),
    };
    {
        let mut encoder = png::Encoder::new(&mut out, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        // Figures are written once and kept: spend a little time on size.
        encoder.set_compression(png::Compression::Best);
        encoder.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
        let mut writer = encoder.write_header().map_err(encoding)?;
        writer.write_image_data(rgb).map_err(encoding)?;
        writer.finish().map_err(encoding)?;
    }
    replace_atomically(path, &out)
}

/// Writes `bytes` to a temporary file beside `path` and renames it over
/// `path`: a figure that fails half-way leaves the previous one whole.
fn replace_atomically(path: &Path, bytes: &[u8]) -> Result<(), PlotError> {
    crate::io::write_file(path, bytes, crate::io::WriteMode::Overwrite).map_err(|error| match error
    {
        crate::Error::Io { path, source } => PlotError::Io { path, source },
        // Its own reason, without a second "invalid …" in front.
        crate::Error::InvalidArgument { reason, .. } => PlotError::InvalidArgument {
            what: "figure path".to_owned(),
            reason,
        },
        other => PlotError::InvalidArgument {
            what: "figure path".to_owned(),
            reason: other.to_string(),
        },
    })
}
