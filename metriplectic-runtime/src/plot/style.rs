//! Shared look of the figures: text sizes and colours.

use plotters::style::{IntoFont, RGBColor, TextStyle};

use super::font::FAMILY;

/// Title text.
pub(crate) fn title() -> TextStyle<'static> {
    (FAMILY, 34).into_font().into()
}

/// Axis names.
pub(crate) fn axis_name() -> TextStyle<'static> {
    (FAMILY, 28).into_font().into()
}

/// Tick labels, legend entries and notes.
pub(crate) fn small() -> TextStyle<'static> {
    (FAMILY, 22).into_font().into()
}

/// Trajectories.
pub(crate) const TRAJECTORY: RGBColor = RGBColor(31, 119, 180);
/// Start points.
pub(crate) const START: RGBColor = RGBColor(214, 39, 40);
/// Reference curve or surface.
pub(crate) const REFERENCE: RGBColor = RGBColor(0, 0, 0);
/// Light grid lines.
pub(crate) const GRID: RGBColor = RGBColor(225, 225, 225);

/// Distinguishable colours for a few named series (matplotlib's "tab10").
pub(crate) const SERIES: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
];

/// One colour per trajectory where each has its own (matplotlib's "tab10",
/// in order); they repeat after 10.
pub(crate) const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Width of the legend's sample column and the length of a sample line.
pub(crate) const LEGEND_AREA: u32 = 48;
/// Length of a legend's sample line (shorter than [`LEGEND_AREA`] so it clears the text).
pub(crate) const LEGEND_LINE: i32 = 36;

/// Tick labels without trailing zeros (`1`, `0.5`, `-1.5`, `250`) for an axis
/// spanning `span`, with enough decimals to tell ticks apart (plotters places
/// at most about 20 ticks per axis, at multiples of 1, 2 or 5 × 10ᵏ).
pub(crate) fn numbers(span: f64) -> impl Fn(&f64) -> String {
    let step = (span / 20.0).abs();
    let decimals = if step > 0.0 && step.is_finite() {
        (-step.log10().floor()).clamp(0.0, 15.0) as usize
    } else {
        4
    };
    move |v: &f64| {
        let text = format!("{v:.decimals$}");
        let text = if text.contains('.') {
            text.trim_end_matches('0').trim_end_matches('.')
        } else {
            &text
        };
        if text == "-0" {
            "0".to_owned()
        } else {
            text.to_owned()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_tidy() {
        let unit = numbers(3.5);
        assert_eq!(unit(&1.0), "1");
        assert_eq!(unit(&-1.5), "-1.5");
        assert_eq!(unit(&-1e-17), "0");
        let iterations = numbers(700.0);
        assert_eq!(iterations(&250.0), "250");
        assert_eq!(iterations(&100.0), "100");
        let fine = numbers(1e-3);
        assert_eq!(fine(&1e6), "1000000");
        assert_eq!(fine(&(1e6 + 5e-5)), "1000000.00005");
    }
}
