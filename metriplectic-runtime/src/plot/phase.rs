//! Planar phase portraits (the paper's Fig. 1).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::render::{self, Failure, Figure};
use super::{data, style, Labels};

/// Draws planar trajectories as thin lines, their start points as red dots and
/// a reference curve (e.g. the zero set of E) as a thick black line, on axes
/// of equal scale, and writes the figure to `path` (`.png` or `.svg`).
///
/// `trajectories` holds one sequence of points per trajectory, each point a
/// slice of exactly 2 numbers (`Vec<Vec<f64>>`, `Vec<[f64; 2]>`, … all
/// work). `zero_set` is drawn as one polyline in the given order; pass an
/// empty slice to omit it. Uses `labels.title`, `.x`, `.y` and `.reference`.
///
/// # Errors
/// [`PlotError::UnsupportedFormat`](super::PlotError::UnsupportedFormat) for another extension,
/// [`PlotError::Empty`](super::PlotError::Empty) for no trajectories or an empty one,
/// [`PlotError::PointDimension`](super::PlotError::PointDimension) for a point that is not 2-D,
/// [`PlotError::NonFinite`](super::PlotError::NonFinite) for NaN or infinite coordinates, and
/// [`PlotError::Io`](super::PlotError::Io) / [`PlotError::Drawing`](super::PlotError::Drawing) / [`PlotError::Encoding`](super::PlotError::Encoding) when
/// the file cannot be made; all wrapped in [`crate::Error::Plot`].
pub fn phase_portrait_2d<T, P>(
    path: impl AsRef<Path>,
    trajectories: &[T],
    zero_set: &[(f64, f64)],
    labels: &Labels<'_>,
) -> crate::Result<()>
where
    T: AsRef<[P]>,
    P: AsRef<[f64]>,
{
    let path = path.as_ref();
    render::check_format(path)?;
    let trajectories: Vec<Vec<(f64, f64)>> = data::trajectories(trajectories, 2)?
        .into_iter()
        .map(|t| t.into_iter().map(|x| (x[0], x[1])).collect())
        .collect();
    data::finite_pairs("zero set", zero_set)?;
    let points = || trajectories.iter().flatten().chain(zero_set.iter());
    let (x0, x1) = data::bounds(points().map(|p| p.0));
    let (y0, y1) = data::bounds(points().map(|p| p.1));
    data::drawable_span("horizontal coordinates", x0, x1)?;
    data::drawable_span("vertical coordinates", y0, y1)?;
    let figure = PhasePortrait {
        trajectories,
        zero_set,
        labels,
    };
    render::render(path, &figure)?;
    Ok(())
}

struct PhasePortrait<'a> {
    trajectories: Vec<Vec<(f64, f64)>>,
    zero_set: &'a [(f64, f64)],
    labels: &'a Labels<'a>,
}

const MARGIN: u32 = 20;
const LEFT: u32 = 90;
const BOTTOM: u32 = 80;
const WIDTH: u32 = 1100;
const HEIGHT: u32 = 1150;

impl PhasePortrait<'_> {
    /// A window around all points with 4% padding, shaped like the plotting
    /// area (`width` × `height` pixels) so both axes have the same scale.
    fn window(&self, width: f64, height: f64) -> ((f64, f64), (f64, f64)) {
        let points = || {
            self.trajectories
                .iter()
                .flatten()
                .chain(self.zero_set.iter())
        };
        let (x0, x1) = data::bounds(points().map(|p| p.0));
        let (y0, y1) = data::bounds(points().map(|p| p.1));
        let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        // Data units per pixel: the larger of the two needs, so everything
        // fits; a single point still gets a window resolvable in f64.
        let least = 1e-9 * cx.abs().max(cy.abs()).max(1e-3) / width.max(height);
        let scale = ((x1 - x0) / width).max((y1 - y0) / height).max(least) * 1.08;
        let (hx, hy) = (0.5 * scale * width, 0.5 * scale * height);
        ((cx - hx, cx + hx), (cy - hy, cy + hy))
    }
}

impl Figure for PhasePortrait<'_> {
    fn size(&self) -> (u32, u32) {
        (WIDTH, HEIGHT)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), Failure> {
        // The title is drawn first so the plotting area's size is known
        // exactly and the axes can be given equal scales.
        let area = if self.labels.title.is_empty() {
            root.clone()
        } else {
            root.titled(self.labels.title, style::title())?
        };
        let (w, h) = area.dim_in_pixel();
        let plot_w = w.saturating_sub(LEFT + 2 * MARGIN).max(1);
        let plot_h = h.saturating_sub(BOTTOM + 2 * MARGIN).max(1);
        let ((x0, x1), (y0, y1)) = self.window(f64::from(plot_w), f64::from(plot_h));
        let (x_ticks, y_ticks) = (style::numbers(x1 - x0), style::numbers(y1 - y0));
        let mut chart = ChartBuilder::on(&area)
            .margin(MARGIN)
            .x_label_area_size(BOTTOM)
            .y_label_area_size(LEFT)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc(self.labels.x)
            .y_desc(self.labels.y)
            .axis_desc_style(style::axis_name())
            .label_style(style::small())
            .x_label_formatter(&x_ticks)
            .y_label_formatter(&y_ticks)
            .max_light_lines(1)
            .light_line_style(style::GRID.mix(0.5))
            .bold_line_style(style::GRID)
            .draw()?;

        let line = style::TRAJECTORY.mix(0.55).stroke_width(1);
        for (k, trajectory) in self.trajectories.iter().enumerate() {
            let series = chart.draw_series(LineSeries::new(trajectory.iter().copied(), line))?;
            if k == 0 {
                series.label("trajectories").legend(move |(x, y)| {
                    PathElement::new(
                        vec![(x, y), (x + style::LEGEND_LINE, y)],
                        style::TRAJECTORY.stroke_width(2),
                    )
                });
            }
        }
        if !self.zero_set.is_empty() {
            chart
                .draw_series(LineSeries::new(
                    self.zero_set.iter().copied(),
                    style::REFERENCE.stroke_width(4),
                ))?
                .label(self.labels.reference)
                .legend(|(x, y)| {
                    PathElement::new(
                        vec![(x, y), (x + style::LEGEND_LINE, y)],
                        style::REFERENCE.stroke_width(4),
                    )
                });
        }
        chart
            .draw_series(
                self.trajectories
                    .iter()
                    .filter_map(|t| t.first())
                    .map(|&p| Circle::new(p, 4, style::START.filled())),
            )?
            .label("initial states")
            .legend(|(x, y)| {
                Circle::new((x + style::LEGEND_LINE / 2, y), 5, style::START.filled())
            });

        render::draw_legend(&mut chart)?;
        Ok(())
    }
}
