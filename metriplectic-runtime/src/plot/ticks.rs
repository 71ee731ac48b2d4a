//! Where the labelled ticks of an axis go, and what they say.
//!
//! plotters chooses tick positions itself; on a logarithmic axis spanning a
//! single decade it labelled one value only (its first power of ten is
//! computed as 10^⌈log₁₀ low⌉, which rounding can push a decade up), and on
//! an iteration axis it labelled 1.5, 2.5, …. Figures here compute their
//! ticks with these functions and hand them to plotters as fixed key points.

use std::ops::Range;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};

use super::style;
use super::PlotError;

/// A labelled tick of a figure's axis: where it goes and what it says.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisTick {
    /// Position on the axis, in data units.
    pub value: f64,
    /// The label drawn beside it, e.g. `10⁻³`, `2×10⁻³`, `0.82` or `250`.
    pub label: String,
}

/// At most this many labels per axis, so that they stay readable.
const MAX_LABELS: usize = 10;
/// At least this many labels on a logarithmic axis, when the range allows.
const MIN_LABELS: usize = 3;
/// Relative slack when deciding whether a tick lies within the range, so
/// that an end computed as 10^k in floating point keeps its tick.
const SLACK: f64 = 1e-9;

/// The labelled ticks of a logarithmic axis from `low` to `high`
/// (0 < `low` < `high`, both finite), in increasing order.
///
/// The axis gets at least 3 labels and at most 10:
///
/// - powers of ten (`10⁻³`, `10⁻²`, …) when at least 3 lie in the range,
///   every 1st, 2nd, 3rd, 5th, 10th, 20th … of them so that at most 10 remain;
/// - otherwise 1, 2 and 5 × 10ᵏ (`10⁻³`, `2×10⁻³`, `5×10⁻³`, `10⁻²`), or
///   1, 2, …, 9 × 10ᵏ if those are still fewer than 3;
/// - otherwise (a range narrower than from one such value to the next)
///   evenly spaced decimal ticks such as `0.82`, `0.84`, `0.86`.
///
/// ```
/// use metriplectic_runtime::log_axis_ticks;
///
/// let labels: Vec<String> = log_axis_ticks(1e-3, 1e-2)
///     .unwrap()
///     .into_iter()
///     .map(|t| t.label)
///     .collect();
/// assert_eq!(labels, ["10⁻³", "2×10⁻³", "5×10⁻³", "10⁻²"]);
/// ```
///
/// # Errors
/// [`PlotError::InvalidArgument`] naming the bounds if they are not finite,
/// not positive or not increasing.
pub fn log_axis_ticks(low: f64, high: f64) -> crate::Result<Vec<AxisTick>> {
    if !(low.is_finite() && high.is_finite() && low > 0.0 && high > low) {
        return Err(PlotError::InvalidArgument {
            what: "log axis range".to_owned(),
            reason: format!(
                "from {low:e} to {high:e}: the bounds must be finite, positive and increasing"
            ),
        }
        .into());
    }
    // Finite: near f64::MAX, 10³⁰⁹ is inf and high·(1 + SLACK) too.
    let inside = |v: f64| v.is_finite() && v >= low * (1.0 - SLACK) && v <= high * (1.0 + SLACK);
    let first = low.log10().floor() as i32 - 1;
    let last = high.log10().ceil() as i32 + 1;

    let powers: Vec<i32> = (first..=last).filter(|&e| inside(decimal(1, e))).collect();
    if powers.len() >= MIN_LABELS {
        let every = steps()
            .find(|&s| powers.iter().filter(|&&e| e.rem_euclid(s) == 0).count() <= MAX_LABELS)
            .unwrap_or(1);
        // The smallest step keeping ≤ 10 labels keeps at least 5 of ≥ 11
        // powers, and all of up to 10.
        return Ok(powers
            .into_iter()
            .filter(|&e| e.rem_euclid(every) == 0)
            .map(|e| power_tick(1, e))
            .collect());
    }
    for mantissas in [&[1, 2, 5][..], &[1, 2, 3, 4, 5, 6, 7, 8, 9][..]] {
        let ticks: Vec<AxisTick> = (first..=last)
            .flat_map(|e| mantissas.iter().map(move |&m| (m, e)))
            .filter(|&(m, e)| inside(decimal(m, e)))
            .map(|(m, e)| power_tick(m, e))
            .collect();
        if ticks.len() >= MIN_LABELS {
            return Ok(ticks);
        }
    }
    Ok(linear_ticks(low, high))
}

/// The labelled ticks of an axis of whole numbers (iterations, counts) from
/// `low` to `high` (finite, `low` ≤ `high`): integers only, at multiples of
/// 1, 2, 5, 10, 20, … so that at most 10 remain. A range holding no integer
/// has no ticks.
///
/// ```
/// use metriplectic_runtime::integer_axis_ticks;
///
/// let values: Vec<f64> = integer_axis_ticks(1.0, 3.0).unwrap().iter().map(|t| t.value).collect();
/// assert_eq!(values, [1.0, 2.0, 3.0]);
/// let labels: Vec<String> = integer_axis_ticks(1.0, 700.0).unwrap().into_iter().map(|t| t.label).collect();
/// assert_eq!(labels, ["100", "200", "300", "400", "500", "600", "700"]);
/// ```
///
/// # Errors
/// [`PlotError::InvalidArgument`] naming the bounds if they are not finite or
/// `low > high`.
pub fn integer_axis_ticks(low: f64, high: f64) -> crate::Result<Vec<AxisTick>> {
    // Beyond 2⁵³ not every integer is representable; 1e15 leaves room.
    let limit = 1e15;
    if !(low.is_finite() && high.is_finite() && low <= high && low.abs().max(high.abs()) < limit) {
        return Err(PlotError::InvalidArgument {
            what: "integer axis range".to_owned(),
            reason: format!(
                "from {low:e} to {high:e}: the bounds must be finite, within ±1e15 and increasing"
            ),
        }
        .into());
    }
    let (first, last) = (low.ceil() as i64, high.floor() as i64);
    if first > last {
        return Ok(Vec::new());
    }
    // The steps of `steps`, continued to 5e15 (i32 ends at 5e8; a probe's
    // (0, 9e9) got the single tick 0).
    let step = [1i64, 2, 3, 5]
        .into_iter()
        .chain((1..=15).flat_map(|k| [1, 2, 5].map(|m| m * 10i64.pow(k))))
        .find(|&s| {
            let count = last.div_euclid(s) - (first - 1).div_euclid(s);
            count <= MAX_LABELS as i64
        })
        .unwrap_or(1);
    let start = first + (step - first.rem_euclid(step)) % step;
    Ok((0..)
        .map(|k| start + k * step)
        .take_while(|&v| v <= last)
        .map(|v| AxisTick {
            value: v as f64,
            label: v.to_string(),
        })
        .collect())
}

/// The steps 1, 2, 3, 5, 10, 20, 50, 100, 200, 500, … (3 only once: it keeps
/// every third decade of a log axis readable).
fn steps() -> impl Iterator<Item = i32> {
    [1, 2, 3, 5]
        .into_iter()
        .chain((1..9).flat_map(|k| [1, 2, 5].map(|m| m * 10i32.pow(k))))
}

/// m × 10ᵉ, correctly rounded (parsing is exact where powf is not).
fn decimal(m: i32, e: i32) -> f64 {
    format!("{m}e{e}").parse().unwrap_or(f64::NAN)
}

fn power_tick(m: i32, e: i32) -> AxisTick {
    let power = format!("10{}", superscript(e));
    AxisTick {
        value: decimal(m, e),
        label: if m == 1 {
            power
        } else {
            format!("{m}×{power}")
        },
    }
}

/// Evenly spaced ticks at multiples of 1, 2 or 5 × 10ᵏ, at least 3 of them,
/// for a range too narrow for the log-axis ticks.
fn linear_ticks(low: f64, high: f64) -> Vec<AxisTick> {
    let span = high - low;
    // The largest step giving at least 3 ticks: span/2 at most.
    // Clamped: for adjacent subnormal bounds span/2 underflows to 0 and
    // log10 to −∞, whose cast is i32::MIN (and its decrement overflows).
    let mut exponent = (span / 2.0).log10().floor().clamp(-330.0, 330.0) as i32;
    loop {
        for m in [5, 2, 1] {
            let step = decimal(m, exponent);
            let first = (low / step - SLACK).ceil();
            let last = (high / step + SLACK).floor();
            if last - first + 1.0 >= MIN_LABELS as f64 {
                let format = style::numbers(20.0 * step);
                return (0..)
                    .map(|k| (first + f64::from(k)) * step)
                    .take((last - first) as usize + 1)
                    .map(|value| AxisTick {
                        value,
                        label: format(&value),
                    })
                    .collect();
            }
        }
        exponent -= 1;
        if exponent < -330 {
            return Vec::new();
        }
    }
}

/// Ticks of a linear axis from `low` to `high` at multiples of 1, 2 or 5 ×
/// 10ᵏ: the finest such step giving at most 10 ticks (plotters' own rule),
/// labelled without trailing zeros. Empty for an empty or non-finite range.
pub(crate) fn number_ticks(low: f64, high: f64) -> Vec<AxisTick> {
    let span = high - low;
    if !(span > 0.0 && span.is_finite()) {
        return Vec::new();
    }
    let finest = (span / MAX_LABELS as f64).log10().floor() as i32;
    for exponent in finest..finest + 4 {
        for m in [1, 2, 5] {
            let step = decimal(m, exponent);
            let (first, last) = ((low / step - SLACK).ceil(), (high / step + SLACK).floor());
            if last - first + 1.0 <= MAX_LABELS as f64 {
                let format = style::numbers(20.0 * step);
                return (0..=((last - first) as i64))
                    .map(|k| (first + k as f64) * step)
                    .map(|value| AxisTick {
                        value,
                        label: format(&value),
                    })
                    .collect();
            }
        }
    }
    Vec::new()
}

/// An integer exponent in superscript digits: −3 → ⁻³.
pub(crate) fn superscript(exponent: i32) -> String {
    exponent
        .to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            '9' => '⁹',
            other => other,
        })
        .collect()
}

/// Unlabelled minor ticks of a log axis (2, …, 9 × 10ᵏ) for the light grid,
/// when the axis spans at most 6 decades (beyond that they crowd).
pub(crate) fn log_minor_points(low: f64, high: f64) -> Vec<f64> {
    if !(low > 0.0 && high > low && (high / low).log10() <= 6.0 + SLACK) {
        return Vec::new();
    }
    let first = low.log10().floor() as i32;
    let last = high.log10().ceil() as i32;
    (first..=last)
        .flat_map(|e| (2..=9).map(move |m| decimal(m, e)))
        .filter(|&v| v > low && v < high)
        .collect()
}

/// A plotters axis (linear or logarithmic) whose grid lines go exactly at
/// given points: `bold` labelled, `light` not.
pub(crate) struct Ticked<R> {
    inner: R,
    bold: Vec<f64>,
    light: Vec<f64>,
}

impl<R: Ranged<ValueType = f64>> Ticked<R> {
    pub(crate) fn new(inner: R, ticks: &[AxisTick], light: Vec<f64>) -> Self {
        Ticked {
            inner,
            bold: ticks.iter().map(|t| t.value).collect(),
            light,
        }
    }
}

impl<R: Ranged<ValueType = f64>> Ranged for Ticked<R> {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.light.clone()
        } else {
            self.bold.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.inner.range()
    }

    fn axis_pixel_range(&self, limit: (i32, i32)) -> Range<i32> {
        self.inner.axis_pixel_range(limit)
    }
}

/// The label of `value` among `ticks` (the nearest one), for plotters'
/// label formatters, which are handed the key points back.
pub(crate) fn label_of(ticks: &[AxisTick], value: f64) -> String {
    ticks
        .iter()
        .min_by(|a, b| (a.value - value).abs().total_cmp(&(b.value - value).abs()))
        .map(|t| t.label.clone())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(ticks: Vec<AxisTick>) -> Vec<String> {
        ticks.into_iter().map(|t| t.label).collect()
    }

    #[test]
    fn log_ticks_thin_out_many_decades() {
        let ticks = log_axis_ticks(1e-14, 1.0).unwrap();
        assert_eq!(
            labels(ticks),
            [
                "10⁻¹⁴",
                "10⁻¹²",
                "10⁻¹⁰",
                "10⁻⁸",
                "10⁻⁶",
                "10⁻⁴",
                "10⁻²",
                "10⁰"
            ]
        );
        let ticks = log_axis_ticks(1e-300, 1e300).unwrap();
        assert!(ticks.len() >= 3 && ticks.len() <= 10, "{ticks:?}");
        assert!(ticks.iter().all(|t| t.value.is_finite() && t.value > 0.0));
    }

    #[test]
    fn narrow_log_ranges_fall_back_to_decimals() {
        let ticks = log_axis_ticks(0.81, 0.89).unwrap();
        assert_eq!(labels(ticks), ["0.82", "0.84", "0.86", "0.88"]);
        assert!(log_axis_ticks(0.0, 1.0).is_err());
        assert!(log_axis_ticks(1.0, 1.0).is_err());
        assert!(log_axis_ticks(1.0, f64::INFINITY).is_err());
    }

    #[test]
    fn integer_ticks_never_fall_between_integers() {
        assert!(integer_axis_ticks(0.2, 0.8).unwrap().is_empty());
        assert_eq!(labels(integer_axis_ticks(0.5, 1.5).unwrap()), ["1"]);
        assert_eq!(
            labels(integer_axis_ticks(-3.0, 3.0).unwrap()),
            ["-3", "-2", "-1", "0", "1", "2", "3"]
        );
        let big = integer_axis_ticks(1.0, 1e12).unwrap();
        assert!(big.len() <= 10 && big.iter().all(|t| t.value.fract() == 0.0));
        // Every range up to the limit gets several ticks (a probe's
        // (0, 9e9) and (−9.9e14, 9.9e14) got only 0).
        for (low, high) in [(0.0, 9e9), (-9.9e14, 9.9e14), (0.0, 3e9), (7.0, 4e11)] {
            let ticks = integer_axis_ticks(low, high).unwrap();
            assert!(
                (4..=10).contains(&ticks.len()),
                "({low}, {high}): {ticks:?}"
            );
        }
        assert!(integer_axis_ticks(2.0, 1.0).is_err());
    }

    #[test]
    fn number_ticks_are_round() {
        assert_eq!(
            labels(number_ticks(0.0, 10.0)),
            ["0", "2", "4", "6", "8", "10"]
        );
        assert_eq!(
            labels(number_ticks(0.05, 0.35)),
            ["0.05", "0.1", "0.15", "0.2", "0.25", "0.3", "0.35"]
        );
        assert!(number_ticks(1.0, 1.0).is_empty());
    }

    #[test]
    fn minor_points_and_lookup() {
        let minor = log_minor_points(1e-3, 1e-1);
        assert_eq!(minor.len(), 16);
        assert!(log_minor_points(1e-14, 1.0).is_empty());
        let ticks = log_axis_ticks(1e-3, 1e-2).unwrap();
        assert_eq!(label_of(&ticks, 2e-3), "2×10⁻³");
    }
}
