//! Spatial trajectories around a sphere (the paper's Fig. 3).

use std::f64::consts::{PI, TAU};
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::render::{self, Failure, Figure};
use super::{data, style, Labels, PlotError};

/// Draws 3-D trajectories as thin lines in an oblique projection, their start
/// points as red dots and, when `sphere_radius` is given, a wireframe sphere
/// of that radius centred at the origin (e.g. the unit sphere, the zero set of
/// E for the rigid body), and writes the figure to `path` (`.png` or `.svg`).
///
/// Each point is a slice of exactly 3 numbers (x, y, z); z is drawn
/// vertically. The axes form a cube symmetric about the origin that holds
/// all points and the sphere. Uses `labels.title`, `.x`, `.y`, `.z` and
/// `.reference` (legend entry of the sphere).
///
/// # Errors
/// As [`phase_portrait_2d`](super::phase_portrait_2d) with 3 components per
/// point, and [`PlotError::InvalidArgument`] for a radius that is not finite
/// and positive.
pub fn trajectories_3d<T, P>(
    path: impl AsRef<Path>,
    trajectories: &[T],
    sphere_radius: Option<f64>,
    labels: &Labels<'_>,
) -> crate::Result<()>
where
    T: AsRef<[P]>,
    P: AsRef<[f64]>,
{
    let path = path.as_ref();
    render::check_format(path)?;
    if let Some(r) = sphere_radius {
        if !(r.is_finite() && r > 0.0) {
            return Err(PlotError::InvalidArgument {
                what: "sphere radius".to_owned(),
                reason: format!("{r} is not a finite positive number"),
            }
            .into());
        }
    }
    let trajectories: Vec<Vec<[f64; 3]>> = data::trajectories(trajectories, 3)?
        .into_iter()
        .map(|t| t.into_iter().map(|x| [x[0], x[1], x[2]]).collect())
        .collect();
    // The axes span the sphere too: its radius must be drawable as well.
    let largest = data::bounds(trajectories.iter().flatten().flatten().map(|v| v.abs()))
        .1
        .max(sphere_radius.unwrap_or(0.0));
    data::drawable_span("coordinates and sphere radius", -largest, largest)?;
    let figure = Trajectories3d {
        trajectories,
        sphere_radius,
        labels,
    };
    render::render(path, &figure)?;
    Ok(())
}

struct Trajectories3d<'a> {
    trajectories: Vec<Vec<[f64; 3]>>,
    sphere_radius: Option<f64>,
    labels: &'a Labels<'a>,
}

/// Parallels and meridians of the wireframe sphere.
const PARALLELS: usize = 9;
const MERIDIANS: usize = 12;
const SEGMENTS: usize = 96;

/// plotters' 3-D charts draw their second coordinate vertically and, with
/// the projection below, a (first, third) pair that reads left-handed. We want
/// z up in a right-handed frame, so state (x, y, z) is drawn at (y, z, x).
fn plotted([x, y, z]: [f64; 3]) -> (f64, f64, f64) {
    (y, z, x)
}

impl Trajectories3d<'_> {
    /// Half-width of the cube holding every point and the sphere.
    fn half_width(&self) -> f64 {
        let data = self
            .trajectories
            .iter()
            .flatten()
            .flat_map(|p| p.iter())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        data.max(self.sphere_radius.unwrap_or(0.0)).max(1e-12) * 1.05
    }

    /// Polylines of the wireframe sphere, in state coordinates.
    fn wireframe(radius: f64) -> Vec<Vec<[f64; 3]>> {
        let circle = |f: &dyn Fn(f64) -> [f64; 3]| -> Vec<[f64; 3]> {
            (0..=SEGMENTS)
                .map(|i| f(TAU * i as f64 / SEGMENTS as f64))
                .collect()
        };
        let mut lines = Vec::with_capacity(PARALLELS + MERIDIANS);
        for k in 1..=PARALLELS {
            let polar = PI * k as f64 / (PARALLELS + 1) as f64;
            let (z, rho) = (radius * polar.cos(), radius * polar.sin());
            lines.push(circle(&|t| [rho * t.cos(), rho * t.sin(), z]));
        }
        for k in 0..MERIDIANS {
            let azimuth = PI * k as f64 / MERIDIANS as f64;
            let (c, s) = (azimuth.cos(), azimuth.sin());
            lines.push(circle(&|t| {
                let (rho, z) = (radius * t.sin(), radius * t.cos());
                [rho * c, rho * s, z]
            }));
        }
        lines
    }
}

impl Figure for Trajectories3d<'_> {
    fn size(&self) -> (u32, u32) {
        (1100, 1100)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), Failure> {
        let h = self.half_width();
        let mut builder = ChartBuilder::on(root);
        builder.margin(20);
        if !self.labels.title.is_empty() {
            builder.caption(self.labels.title, style::title());
        }
        let mut chart = builder.build_cartesian_3d(-h..h, -h..h, -h..h)?;
        let ticks = style::numbers(2.0 * h);
        chart.with_projection(|mut pb| {
            pb.yaw = 0.65;
            pb.pitch = 0.35;
            pb.scale = 0.85;
            pb.into_matrix()
        });
        chart
            .configure_axes()
            .label_style(style::small())
            .light_grid_style(style::GRID.mix(0.5))
            .bold_grid_style(style::GRID)
            .max_light_lines(1)
            .x_formatter(&ticks)
            .y_formatter(&ticks)
            .z_formatter(&ticks)
            .draw()?;

        // Axis names beside the middle of the edges that carry the tick
        // labels for this projection (x: front right, y: front left, z: the
        // vertical edge on the left), pushed outwards past the tick labels.
        let names = [
            (self.labels.x, [0.0, 1.45 * h, -h]),
            (self.labels.y, [1.45 * h, 0.0, -h]),
            (self.labels.z, [h, -h, 1.2 * h]),
        ];
        chart.draw_series(
            names
                .iter()
                .map(|&(name, at)| Text::new(name.to_owned(), plotted(at), style::axis_name())),
        )?;

        if let Some(radius) = self.sphere_radius {
            let wire = style::REFERENCE.mix(0.35).stroke_width(1);
            for (k, line) in Self::wireframe(radius).into_iter().enumerate() {
                let series =
                    chart.draw_series(LineSeries::new(line.into_iter().map(plotted), wire))?;
                if k == 0 {
                    series.label(self.labels.reference).legend(|(x, y)| {
                        PathElement::new(
                            vec![(x, y), (x + style::LEGEND_LINE, y)],
                            style::REFERENCE.mix(0.5),
                        )
                    });
                }
            }
        }

        let line = style::TRAJECTORY.mix(0.6).stroke_width(1);
        for (k, trajectory) in self.trajectories.iter().enumerate() {
            let series = chart.draw_series(LineSeries::new(
                trajectory.iter().copied().map(plotted),
                line,
            ))?;
            if k == 0 {
                series.label("trajectories").legend(move |(x, y)| {
                    PathElement::new(
                        vec![(x, y), (x + style::LEGEND_LINE, y)],
                        style::TRAJECTORY.stroke_width(2),
                    )
                });
            }
        }
        chart
            .draw_series(
                self.trajectories
                    .iter()
                    .filter_map(|t| t.first())
                    .map(|&p| Circle::new(plotted(p), 4, style::START.filled())),
            )?
            .label("initial states")
            .legend(|(x, y)| {
                Circle::new((x + style::LEGEND_LINE / 2, y), 5, style::START.filled())
            });

        render::draw_legend(&mut chart)?;
        Ok(())
    }
}
