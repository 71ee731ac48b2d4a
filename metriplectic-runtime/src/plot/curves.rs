//! Log-scale curves: cost histories (the paper's Figs. 2 and 4) and the free
//! energy along trajectories.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use plotters::coord::types::RangedCoordf64;

use super::data::{self, LogAxis};
use super::render::{self, Failure, Figure};
use super::ticks::{self, AxisTick, Ticked};
use super::{style, Labels, PlotError};

/// Draws one or more cost histories against the iteration number (1, 2, …)
/// on a logarithmic value axis, with a legend of the series names, and writes
/// the figure to `path` (`.png` or `.svg`).
///
/// The iteration axis is labelled at whole numbers only (see
/// [`integer_axis_ticks`](super::integer_axis_ticks)); the value axis at
/// least 3 times (see [`log_axis_ticks`](super::log_axis_ticks)).
///
/// `series` pairs a name with the value after each iteration, e.g.
/// `[("metric search", &metric[..]), ("entropy search", &entropy[..])]`;
/// series may differ in length; series of at most 50 values also get a
/// marker per value. Values ≤ 0 (a cost that reached exactly 0)
/// are drawn at a floor one decade below the smallest positive value in the
/// figure, marked by a dashed line, and a note in the corner says so. Uses
/// `labels.title`, `.x`, `.y`.
///
/// # Errors
/// [`PlotError::Empty`] for no series or an empty one,
/// [`PlotError::NonFinite`] for NaN or infinite values (naming the series),
/// [`PlotError::NoPositiveValues`] if no value is positive, and the file
/// errors of [`phase_portrait_2d`](super::phase_portrait_2d).
pub fn loss_curves(
    path: impl AsRef<Path>,
    series: &[(&str, &[f64])],
    labels: &Labels<'_>,
) -> crate::Result<()> {
    let path = path.as_ref();
    render::check_format(path)?;
    if series.is_empty() {
        return Err(PlotError::Empty {
            what: "the list of series".to_owned(),
        }
        .into());
    }
    for (name, values) in series {
        let what = format!("series `{name}`");
        if values.is_empty() {
            return Err(PlotError::Empty { what }.into());
        }
        data::finite(&what, values)?;
    }
    let lines = series
        .iter()
        .enumerate()
        .map(|(k, (name, values))| Line {
            name: Some(name),
            points: (1..).map(f64::from).zip(values.iter().copied()).collect(),
            style: style::SERIES[k % style::SERIES.len()].stroke_width(2),
        })
        .collect();
    render_curves(
        path,
        lines,
        labels,
        Notes {
            horizontal: Horizontal::Integers,
            zero: "values ≤ 0",
            convention: None,
        },
    )
}

/// Draws the free energy along each trajectory relative to its own limit,
/// E_lim − E(t), on a logarithmic value axis, and writes the figure to
/// `path` (`.png` or `.svg`).
///
/// `curves` holds one `(times, free_energy)` pair per trajectory, of equal
/// lengths, in time order. E_lim is the limit of E along that trajectory
/// (E never decreases along a metriplectic trajectory), so E_lim − E(t) ≥ 0
/// decays towards 0 as the trajectory settles, whatever constant the free
/// energy is defined up to: adding a constant to a curve does not change its
/// line, and trajectories settling at different levels (e.g. on different
/// Casimir levels) are each measured from their own.
///
/// E_lim is estimated from the samples. While E still rises at the end (its
/// last two increments positive, above rounding, and slowing down: the
/// later one's rate per unit time below the earlier one's), the exponential
/// approach E_lim − c·e^(−rt) through the last three samples is
/// extrapolated (for evenly spaced samples, Aitken's Δ²), so an
/// exponential tail stays a straight line on the log axis; otherwise E_lim
/// is the largest sampled E, which a settled trajectory has reached to
/// rounding. (With the largest sample instead of the extrapolation, a
/// trajectory still settling would bend down to 0 at its last sample.) A note under the
/// figure states the convention; label the value axis accordingly (e.g.
/// `y: "E_lim − E"`). Where E equals E_lim the difference is 0, drawn at a
/// floor one decade below the smallest positive difference, marked by a
/// dashed line and a note, as in [`loss_curves`]. Uses `labels.title`,
/// `.x`, `.y`.
///
/// # Errors
/// [`PlotError::Empty`] for no curves or an empty one,
/// [`PlotError::LengthMismatch`] if times and values differ in length,
/// [`PlotError::NonFinite`] for NaN or infinite times or values (naming the
/// curve and index), [`PlotError::InvalidArgument`] for times that do not
/// increase,
/// [`PlotError::NoPositiveValues`] if E is constant along every curve (no
/// difference to show), and the file errors of
/// [`phase_portrait_2d`](super::phase_portrait_2d).
pub fn free_energy_curves<T, V>(
    path: impl AsRef<Path>,
    curves: &[(T, V)],
    labels: &Labels<'_>,
) -> crate::Result<()>
where
    T: AsRef<[f64]>,
    V: AsRef<[f64]>,
{
    let path = path.as_ref();
    render::check_format(path)?;
    if curves.is_empty() {
        return Err(PlotError::Empty {
            what: "the list of free-energy curves".to_owned(),
        }
        .into());
    }
    let line = style::TRAJECTORY.mix(0.5).stroke_width(1);
    let mut lines = Vec::with_capacity(curves.len());
    for (k, (times, values)) in curves.iter().enumerate() {
        let (times, values) = (times.as_ref(), values.as_ref());
        let what = format!("free-energy curve {k}");
        if times.len() != values.len() {
            return Err(PlotError::LengthMismatch {
                what,
                left: times.len(),
                right: values.len(),
            }
            .into());
        }
        if times.is_empty() {
            return Err(PlotError::Empty { what }.into());
        }
        data::finite(&format!("{what} (times)"), times)?;
        data::finite(&format!("{what} (values)"), values)?;
        data::increasing(&format!("{what} (times)"), times)?;
        let gaps = gaps_to_limit(times, values);
        data::finite(&format!("{what} (E_lim − E, overflowing)"), &gaps)?;
        lines.push(Line {
            name: None,
            points: times.iter().copied().zip(gaps).collect(),
            style: line,
        });
    }
    render_curves(
        path,
        lines,
        labels,
        Notes {
            horizontal: Horizontal::Numbers,
            zero: "E_lim − E = 0",
            convention: Some(
                "each curve: E_lim − E(t), E_lim = the limit of E along it (extrapolated, or its largest E)",
            ),
        },
    )
}

/// E_lim − E for each sample of one free-energy curve (finite, equal
/// lengths), E_lim its limit as estimated in [`free_energy_curves`]: ≥ 0.
/// Independent of a constant added to E (up to the rounding of E itself).
fn gaps_to_limit(times: &[f64], values: &[f64]) -> Vec<f64> {
    let limit = estimated_limit(times, values);
    values.iter().map(|e| limit - e).collect()
}

/// The limit of E along one trajectory: the exponential extrapolation of
/// its last three samples where that is meaningful, else its largest value.
fn estimated_limit(times: &[f64], values: &[f64]) -> f64 {
    let largest = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let n = values.len();
    if n < 3 {
        return largest;
    }
    let (t, e) = (&times[n - 3..], &values[n - 3..]);
    let (a, b) = (t[1] - t[0], t[2] - t[1]);
    let (d1, d2) = (e[1] - e[0], e[2] - e[1]);
    // Increments within ~1000 roundings of E are noise, not a trend.
    let resolved = d1 > 0.0 && d2 > 1e3 * f64::EPSILON * e[2].abs().max(e[1].abs());
    // Slowing down: the later increment's rate below the earlier one's.
    if !(resolved && a > 0.0 && b > 0.0 && d2 / b < d1 / a) {
        return largest;
    }
    // E = L − c·e^(−rt) through the three samples: d2/d1 = R(r) with
    // R(r) = (1 − e^(−rb)) / (e^(ra) − 1), which falls from b/a (r → 0) to
    // 0 (r → ∞). Solve for r by bisection on log r, with ra ≤ 700.
    let ratio = d2 / d1;
    let falls = |r: f64| (-(-r * b).exp_m1()) / (r * a).exp_m1();
    let (mut lo, mut hi) = ((1e-12 / a).ln(), (700.0 / a).ln());
    if falls(hi.exp()) >= ratio {
        return largest;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if falls(mid.exp()) > ratio {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // The remaining gap at the last sample: c·e^(−r t₃) = d2·e^(−rb)/(1 − e^(−rb)).
    let decay = (-hi.exp() * b).exp();
    let limit = e[2] + d2 * decay / (1.0 - decay);
    if limit.is_finite() && limit >= largest {
        limit
    } else {
        largest
    }
}

/// What the horizontal axis counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Horizontal {
    /// Whole numbers (iterations): integer ticks only.
    Integers,
    /// Real numbers (time): multiples of 1, 2 or 5 × 10ᵏ.
    Numbers,
}

/// The notes and axis conventions of one curves figure.
struct Notes {
    horizontal: Horizontal,
    /// What a value drawn at the floor means, e.g. "values ≤ 0".
    zero: &'static str,
    /// A note on what the curves show, under the figure on the left.
    convention: Option<&'static str>,
}

/// One polyline of a curves figure.
struct Line<'a> {
    /// Legend entry; `None` for unnamed lines.
    name: Option<&'a str>,
    /// (x, value) points; values may be ≤ 0 (drawn at the floor).
    points: Vec<(f64, f64)>,
    style: ShapeStyle,
}

struct Curves<'a> {
    lines: Vec<Line<'a>>,
    x: (f64, f64),
    y: LogAxis,
    y_ticks: Vec<AxisTick>,
    x_ticks: Vec<AxisTick>,
    notes: Notes,
    labels: &'a Labels<'a>,
}

fn render_curves(
    path: &Path,
    lines: Vec<Line<'_>>,
    labels: &Labels<'_>,
    notes: Notes,
) -> crate::Result<()> {
    let points = || lines.iter().flat_map(|l| l.points.iter());
    let y = LogAxis::fit("the curves' values", points().map(|p| p.1))?;
    let (lo, hi) = data::bounds(points().map(|p| p.0));
    data::drawable_span("horizontal values", lo, hi)?;
    let x = if hi > lo {
        (lo, hi)
    } else {
        let pad = (1e-6 * lo.abs()).max(0.5);
        (lo - pad, hi + pad)
    };
    let y_ticks = ticks::log_axis_ticks(y.low, y.high)?;
    let x_ticks = match notes.horizontal {
        Horizontal::Integers => ticks::integer_axis_ticks(x.0, x.1)?,
        Horizontal::Numbers => ticks::number_ticks(x.0, x.1),
    };
    let figure = Curves {
        lines,
        x,
        y,
        y_ticks,
        x_ticks,
        notes,
        labels,
    };
    render::render(path, &figure)?;
    Ok(())
}

/// Lines with at most this many points also get a marker at each point.
const MARKED_UP_TO: usize = 50;

const WIDTH: u32 = 1400;
const HEIGHT: u32 = 850;
/// Height of the band under the chart that holds the notes, if any.
const NOTE_BAND: u32 = 40;

impl Figure for Curves<'_> {
    fn size(&self) -> (u32, u32) {
        (WIDTH, HEIGHT)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), Failure> {
        // Notes get a band of their own, so they cannot run into the axis name.
        let (w, h) = root.dim_in_pixel();
        let has_notes = self.y.clamped || self.notes.convention.is_some();
        let band = if has_notes { NOTE_BAND } else { 0 };
        let (area, notes) = root.split_vertically(h.saturating_sub(band));
        let mut builder = ChartBuilder::on(&area);
        builder
            .margin(20)
            .margin_top(30)
            .margin_right(40)
            .x_label_area_size(80)
            .y_label_area_size(130);
        if !self.labels.title.is_empty() {
            builder.caption(self.labels.title, style::title());
        }
        let (x0, x1) = self.x;
        let x_range = Ticked::new(RangedCoordf64::from(x0..x1), &self.x_ticks, Vec::new());
        let log: LogCoord<f64> = (self.y.low..self.y.high).log_scale().into();
        let minor = ticks::log_minor_points(self.y.low, self.y.high);
        let y_range = Ticked::new(log, &self.y_ticks, minor);
        let mut chart = builder.build_cartesian_2d(x_range, y_range)?;
        let x_label = |v: &f64| ticks::label_of(&self.x_ticks, *v);
        let y_label = |v: &f64| ticks::label_of(&self.y_ticks, *v);
        chart
            .configure_mesh()
            .x_desc(self.labels.x)
            .y_desc(self.labels.y)
            .axis_desc_style(style::axis_name())
            .label_style(style::small())
            .x_label_formatter(&x_label)
            .y_label_formatter(&y_label)
            .light_line_style(style::GRID.mix(0.5))
            .bold_line_style(style::GRID)
            .draw()?;

        let middle = band as i32 / 2;
        if self.y.clamped {
            chart.draw_series(DashedLineSeries::new(
                [(x0, self.y.floor), (x1, self.y.floor)],
                8,
                6,
                BLACK.mix(0.5).stroke_width(1),
            ))?;
            let note = format!("{} drawn at {:.0e} (dashed)", self.notes.zero, self.y.floor);
            let anchored = style::small().pos(Pos::new(HPos::Right, VPos::Center));
            notes.draw(&Text::new(note, (w as i32 - 20, middle), anchored))?;
        }
        if let Some(convention) = self.notes.convention {
            let anchored = style::small().pos(Pos::new(HPos::Left, VPos::Center));
            notes.draw(&Text::new(convention, (20, middle), anchored))?;
        }

        let mut named = false;
        for line in &self.lines {
            let points = line.points.iter().map(|&(x, v)| (x, self.y.clamp(v)));
            // Short histories get markers, so a single value is still visible.
            if line.points.len() <= MARKED_UP_TO {
                let marker = line.style.filled();
                chart.draw_series(points.clone().map(|p| Circle::new(p, 4, marker)))?;
            }
            let series = chart.draw_series(LineSeries::new(points, line.style))?;
            if let Some(name) = line.name {
                named = true;
                let legend_style = line.style;
                series.label(name).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + style::LEGEND_LINE, y)], legend_style)
                });
            }
        }
        if named {
            render::draw_legend(&mut chart)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_energy_limit_is_extrapolated_while_settling() {
        let times: Vec<f64> = (0..=40).map(|i| 0.25 * f64::from(i)).collect();
        // An exponential approach to −7.5, still 10⁻³ away at the end.
        let settling: Vec<f64> = times.iter().map(|t| -7.5 - 22.0 * (-t).exp()).collect();
        let limit = estimated_limit(&times, &settling);
        assert!((limit + 7.5).abs() < 1e-12, "{limit}");
        let gaps = gaps_to_limit(&times, &settling);
        assert!(gaps.iter().all(|g| *g > 0.0), "{gaps:?}");
        // The log of the gap stays a straight line to the end.
        let slope = |i: usize| (gaps[i + 1] / gaps[i]).ln() / 0.25;
        assert!((slope(0) + 1.0).abs() < 1e-9 && (slope(39) + 1.0).abs() < 1e-6);

        // Settled to rounding: the largest value, with 0 at the samples
        // that reach it.
        let settled: Vec<f64> = times.iter().map(|t| 3.0 - (-8.0 * t).exp()).collect();
        assert_eq!(estimated_limit(&times, &settled), 3.0);
        // Uneven (log-uniform) times: still the exact limit.
        let uneven: Vec<f64> = (0..30).map(|i| 1e-2 * 1.25f64.powi(i)).collect();
        let energy: Vec<f64> = uneven
            .iter()
            .map(|t| 4.0 - 3.0 * (-0.7 * t).exp())
            .collect();
        let limit = estimated_limit(&uneven, &energy);
        assert!((limit - 4.0).abs() < 1e-9, "{limit}");
        // Falling at the end, speeding up per unit time, too few samples:
        // the largest value.
        let falling = [1.0, 2.0, 2.5, 2.4];
        assert_eq!(estimated_limit(&[0.0, 1.0, 2.0, 3.0], &falling), 2.5);
        let faster = [1.0, 2.0, 2.5, 2.75];
        assert_eq!(estimated_limit(&[0.0, 1.0, 2.0, 2.4], &faster), 2.75);
        assert_eq!(estimated_limit(&[0.0, 1.0], &[1.0, 2.0]), 2.0);
        // Growing increments (not converging yet): no extrapolation either.
        assert_eq!(estimated_limit(&[0.0, 1.0, 2.0], &[1.0, 2.0, 4.0]), 4.0);
    }
}
