//! Log-scale curves: cost histories (the paper's Figs. 2 and 4) and the free
//! energy along trajectories.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::data::{self, LogAxis};
use super::render::{self, Failure, Figure};
use super::{style, Labels, PlotError};

/// Draws one or more cost histories against the iteration number (1, 2, …)
/// on a logarithmic value axis, with a legend of the series names, and writes
/// the figure to `path` (`.png` or `.svg`).
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
    render_curves(path, lines, labels)
}

/// Draws −E(t) for each trajectory on a logarithmic value axis and writes the
/// figure to `path` (`.png` or `.svg`).
///
/// `curves` holds one `(times, free_energy)` pair per trajectory, of equal
/// lengths; the figure shows `−free_energy`, which for the paper's systems
/// (maximum free energy 0 on the attracting set) decays towards 0. Values of
/// −E ≤ 0 are drawn at a floor as in [`loss_curves`]. Uses `labels.title`,
/// `.x`, `.y` (e.g. "time t" and "−E").
///
/// # Errors
/// [`PlotError::Empty`] for no curves or an empty one,
/// [`PlotError::LengthMismatch`] if times and values differ in length,
/// [`PlotError::NonFinite`] for NaN or infinite times or values,
/// [`PlotError::NoPositiveValues`] if −E is never positive, and the file
/// errors of [`phase_portrait_2d`](super::phase_portrait_2d).
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
        lines.push(Line {
            name: None,
            points: times.iter().zip(values).map(|(&t, &e)| (t, -e)).collect(),
            style: line,
        });
    }
    render_curves(path, lines, labels)
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
    labels: &'a Labels<'a>,
}

fn render_curves(path: &Path, lines: Vec<Line<'_>>, labels: &Labels<'_>) -> crate::Result<()> {
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
    let figure = Curves {
        lines,
        x,
        y,
        labels,
    };
    render::render(path, &figure)?;
    Ok(())
}

/// Lines with at most this many points also get a marker at each point.
const MARKED_UP_TO: usize = 50;

const WIDTH: u32 = 1400;
const HEIGHT: u32 = 850;

impl Figure for Curves<'_> {
    const SIZE: (u32, u32) = (WIDTH, HEIGHT);

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), Failure> {
        let mut builder = ChartBuilder::on(root);
        builder
            .margin(20)
            .margin_top(30)
            .margin_right(40)
            .x_label_area_size(80)
            .y_label_area_size(110);
        if !self.labels.title.is_empty() {
            builder.caption(self.labels.title, style::title());
        }
        let (x0, x1) = self.x;
        let x_ticks = style::numbers(x1 - x0);
        let mut chart =
            builder.build_cartesian_2d(x0..x1, (self.y.low..self.y.high).log_scale())?;
        chart
            .configure_mesh()
            .x_desc(self.labels.x)
            .y_desc(self.labels.y)
            .axis_desc_style(style::axis_name())
            .label_style(style::small())
            .x_label_formatter(&x_ticks)
            .y_label_formatter(&style::power_of_ten)
            .max_light_lines(1)
            .light_line_style(style::GRID.mix(0.5))
            .bold_line_style(style::GRID)
            .draw()?;

        if self.y.clamped {
            chart.draw_series(DashedLineSeries::new(
                [(x0, self.y.floor), (x1, self.y.floor)],
                8,
                6,
                BLACK.mix(0.5).stroke_width(1),
            ))?;
            let (w, h) = root.dim_in_pixel();
            let note = format!("values ≤ 0 drawn at {:.0e} (dashed)", self.y.floor);
            let anchored = style::small().pos(Pos::new(HPos::Right, VPos::Bottom));
            root.draw(&Text::new(note, (w as i32 - 20, h as i32 - 12), anchored))?;
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
