//! Measured data against a model's trajectories, one panel per state
//! variable.

use std::path::Path;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::render::{self, Failure, Figure};
use super::ticks::{self, AxisTick, Ticked};
use super::{data, style, Labels, PlotError};

/// At most this many state variables (panels) per figure.
pub(crate) const MAX_PANELS: usize = 12;

/// Draws each state variable against time in its own panel, stacked
/// vertically with a shared time axis: `data` as markers, `model` as lines,
/// one colour per trajectory (data and model trajectory k share colour k),
/// and writes the figure to `path` (`.png` or `.svg`).
///
/// `data` and `model` hold one `(times, states)` pair per trajectory, with as
/// many states as times, each state a slice of `state_names.len()` numbers
/// (`Vec<Vec<f64>>`, `Vec<[f64; 2]>`, `Vec<&[f64]>` … all work). `model` is
/// either empty (data only) or holds one trajectory per data trajectory, in
/// the same order, e.g. the identified model simulated from each measured
/// trajectory's initial state over its time span; the two need not share
/// time stamps. Panel j is labelled `state_names[j]`; at most 12 panels.
///
/// The legend sits in a band of its own above the panels, so it never covers
/// the data: marker and line samples for "data" and "model", then the colour
/// of each trajectory by its index (0, 1, …; after 10 trajectories the
/// colours repeat and the legend says so). Data markers have a radius of 3
/// pixels (2 above 300 samples per trajectory). Each panel's value range
/// holds all data and model values with 5 % padding. Uses `labels.title` and
/// `labels.x` (the time axis, e.g. "t").
///
/// ```no_run
/// use metriplectic_runtime::{trajectory_overlay, Labels};
///
/// # fn main() -> metriplectic_runtime::Result<()> {
/// let times: Vec<f64> = (0..50).map(|k| 0.2 * k as f64).collect();
/// let measured: Vec<[f64; 2]> = times.iter().map(|t| [t.cos() + 0.01, -t.sin()]).collect();
/// let fitted: Vec<[f64; 2]> = times.iter().map(|t| [t.cos(), -t.sin()]).collect();
/// let labels = Labels { title: "held-out trajectory", x: "t", ..Labels::default() };
/// trajectory_overlay(
///     "overlay.png",
///     &[(times.clone(), measured)],
///     &[(times, fitted)],
///     &["q", "p"],
///     &labels,
/// )?;
/// # Ok(())
/// # }
/// ```
///
/// # Errors
/// [`PlotError::UnsupportedFormat`] for another extension,
/// [`PlotError::Empty`] for no data trajectories, no state names, or an
/// empty trajectory (e.g. "model trajectory 2"),
/// [`PlotError::InvalidArgument`] for more than 12 state names or a model
/// list whose length is neither 0 nor that of the data list,
/// [`PlotError::LengthMismatch`] for a trajectory whose times and states
/// differ in number,
/// [`PlotError::StateDimension`] for a state with the wrong number of
/// components (naming the trajectory and the sample),
/// [`PlotError::NonFinite`] for a NaN or infinite time or state (naming the
/// trajectory, the state variable and the sample), and the file errors of
/// [`phase_portrait_2d`](super::phase_portrait_2d).
pub fn trajectory_overlay<T, S, P>(
    path: impl AsRef<Path>,
    data: &[(T, S)],
    model: &[(T, S)],
    state_names: &[&str],
    labels: &Labels<'_>,
) -> crate::Result<()>
where
    T: AsRef<[f64]>,
    S: AsRef<[P]>,
    P: AsRef<[f64]>,
{
    let path = path.as_ref();
    render::check_format(path)?;
    if data.is_empty() {
        return Err(PlotError::Empty {
            what: "the list of data trajectories".to_owned(),
        }
        .into());
    }
    if state_names.is_empty() {
        return Err(PlotError::Empty {
            what: "the list of state names".to_owned(),
        }
        .into());
    }
    if state_names.len() > MAX_PANELS {
        return Err(PlotError::InvalidArgument {
            what: "state names".to_owned(),
            reason: format!(
                "{} given, but at most {MAX_PANELS} panels fit one figure; plot the variables in groups",
                state_names.len()
            ),
        }
        .into());
    }
    if !model.is_empty() && model.len() != data.len() {
        return Err(PlotError::InvalidArgument {
            what: "model trajectories".to_owned(),
            reason: format!(
                "{} given for {} data trajectories; pass one per data trajectory, in the same order, or none",
                model.len(),
                data.len()
            ),
        }
        .into());
    }
    let dim = state_names.len();
    let data = series("data", data, state_names)?;
    let model = series("model", model, state_names)?;

    let all = || data.iter().chain(&model);
    let (t0, t1) = data::bounds(all().flat_map(|s| s.times.iter().copied()));
    data::drawable_span("times", t0, t1)?;
    let time = padded(t0, t1, 0.0);
    let mut panels = Vec::with_capacity(dim);
    for (j, name) in state_names.iter().enumerate() {
        let (lo, hi) = data::bounds(all().flat_map(|s| s.states.iter().map(move |x| x[j])));
        data::drawable_span(&format!("state `{name}`"), lo, hi)?;
        let range = padded(lo, hi, 0.05);
        panels.push(Panel {
            name,
            range,
            ticks: ticks::number_ticks(range.0, range.1),
        });
    }
    let figure = Overlay {
        data,
        model,
        time,
        time_ticks: ticks::number_ticks(time.0, time.1),
        panels,
        labels,
    };
    render::render(path, &figure)?;
    Ok(())
}

/// One validated trajectory: times and states of `dim` components.
struct Series {
    times: Vec<f64>,
    states: Vec<Vec<f64>>,
}

/// Checks and copies the trajectories of one list (`kind` is "data" or
/// "model").
fn series<T, S, P>(
    kind: &str,
    list: &[(T, S)],
    state_names: &[&str],
) -> Result<Vec<Series>, PlotError>
where
    T: AsRef<[f64]>,
    S: AsRef<[P]>,
    P: AsRef<[f64]>,
{
    let dim = state_names.len();
    list.iter()
        .enumerate()
        .map(|(k, (times, states))| {
            let (times, states) = (times.as_ref(), states.as_ref());
            let what = format!("{kind} trajectory {k}");
            if times.len() != states.len() {
                return Err(PlotError::LengthMismatch {
                    what,
                    left: times.len(),
                    right: states.len(),
                });
            }
            if times.is_empty() {
                return Err(PlotError::Empty { what });
            }
            data::finite(&format!("{what} (times)"), times)?;
            data::increasing(&format!("{what} (times)"), times)?;
            let states = states
                .iter()
                .enumerate()
                .map(|(i, state)| {
                    let x = state.as_ref();
                    if x.len() != dim {
                        return Err(PlotError::StateDimension {
                            what: what.clone(),
                            sample: i,
                            expected: dim,
                            found: x.len(),
                        });
                    }
                    if let Some(j) = x.iter().position(|v| !v.is_finite()) {
                        return Err(PlotError::NonFinite {
                            what: format!("{what}, state `{}`", state_names[j]),
                            index: i,
                            value: x[j],
                        });
                    }
                    Ok(x.to_vec())
                })
                .collect::<Result<_, _>>()?;
            Ok(Series {
                times: times.to_vec(),
                states,
            })
        })
        .collect()
}

/// `[lo, hi]` widened by `fraction` of its span on each side; a single value
/// gets a window of ±max(10⁻⁶|v|, 0.5).
fn padded(lo: f64, hi: f64, fraction: f64) -> (f64, f64) {
    if hi > lo {
        let pad = fraction * (hi - lo);
        (lo - pad, hi + pad)
    } else {
        let pad = (1e-6 * lo.abs()).max(0.5);
        (lo - pad, hi + pad)
    }
}

struct Panel<'a> {
    name: &'a str,
    range: (f64, f64),
    ticks: Vec<AxisTick>,
}

struct Overlay<'a> {
    data: Vec<Series>,
    model: Vec<Series>,
    time: (f64, f64),
    time_ticks: Vec<AxisTick>,
    panels: Vec<Panel<'a>>,
    labels: &'a Labels<'a>,
}

const WIDTH: u32 = 1400;
/// Height of one panel, of the legend band, and of the time axis below the
/// last panel.
const PANEL: u32 = 280;
const LEGEND_BAND: u32 = 56;
const TIME_AXIS: u32 = 50;
const TITLE: u32 = 60;
const LEFT: u32 = 130;
const MARGIN: u32 = 20;

impl Overlay<'_> {
    fn marker_radius(&self) -> i32 {
        let most = self.data.iter().map(|s| s.times.len()).max().unwrap_or(0);
        if most > 300 {
            2
        } else {
            3
        }
    }

    /// The legend band: samples of the data marker and model line, then the
    /// trajectories' colours.
    fn draw_legend<DB: DrawingBackend>(
        &self,
        band: &DrawingArea<DB, Shift>,
    ) -> Result<(), Failure> {
        let text = style::small().pos(Pos::new(HPos::Left, VPos::Center));
        let (_, h) = band.dim_in_pixel();
        let y = h as i32 / 2;
        let mut x = (LEFT + MARGIN) as i32;
        let grey = RGBColor(90, 90, 90);
        let put =
            |band: &DrawingArea<DB, Shift>, label: &str, x: &mut i32| -> Result<(), Failure> {
                band.draw(&Text::new(label.to_owned(), (*x, y), text.clone()))?;
                let (w, _) = band.estimate_text_size(label, &style::small())?;
                *x += w as i32 + 28;
                Ok(())
            };
        band.draw(&Circle::new(
            (x + 6, y),
            self.marker_radius() + 1,
            grey.filled(),
        ))?;
        x += 20;
        put(band, "data", &mut x)?;
        if !self.model.is_empty() {
            band.draw(&PathElement::new(
                vec![(x, y), (x + style::LEGEND_LINE, y)],
                grey.stroke_width(3),
            ))?;
            x += style::LEGEND_LINE + 8;
            put(band, "model", &mut x)?;
        }
        x += 12;
        put(band, "trajectory:", &mut x)?;
        let shown = self.data.len().min(style::PALETTE.len());
        for k in 0..shown {
            let colour = style::PALETTE[k];
            band.draw(&Rectangle::new(
                [(x, y - 8), (x + 16, y + 8)],
                colour.filled(),
            ))?;
            x += 22;
            let label = k.to_string();
            band.draw(&Text::new(label.clone(), (x, y), text.clone()))?;
            let (w, _) = band.estimate_text_size(&label, &style::small())?;
            x += w as i32 + 16;
        }
        if self.data.len() > shown {
            put(
                band,
                &format!("… (colours repeat every {})", style::PALETTE.len()),
                &mut x,
            )?;
        }
        Ok(())
    }
}

impl Figure for Overlay<'_> {
    fn size(&self) -> (u32, u32) {
        let title = if self.labels.title.is_empty() {
            0
        } else {
            TITLE
        };
        let panels = PANEL * self.panels.len() as u32;
        (WIDTH, title + LEGEND_BAND + panels + TIME_AXIS + 2 * MARGIN)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), Failure> {
        let area = root.margin(MARGIN, MARGIN, MARGIN, MARGIN);
        let area = if self.labels.title.is_empty() {
            area
        } else {
            area.titled(self.labels.title, style::title())?
        };
        let (band, rest) = area.split_vertically(LEGEND_BAND);
        self.draw_legend(&band)?;

        let count = self.panels.len();
        let breaks: Vec<i32> = (1..count).map(|j| (j as u32 * PANEL) as i32).collect();
        let areas = rest.split_by_breakpoints([] as [i32; 0], breaks);
        let radius = self.marker_radius();
        let (t0, t1) = self.time;
        let time_label = |v: &f64| ticks::label_of(&self.time_ticks, *v);
        for (j, (panel, panel_area)) in self.panels.iter().zip(&areas).enumerate() {
            let last = j + 1 == count;
            let mut builder = ChartBuilder::on(panel_area);
            builder
                .margin_right(30)
                .margin_top(10)
                .margin_bottom(if last { 0 } else { 10 })
                .y_label_area_size(LEFT)
                .x_label_area_size(if last { TIME_AXIS + 40 } else { 30 });
            let x_range = Ticked::new(RangedCoordf64::from(t0..t1), &self.time_ticks, Vec::new());
            let (y0, y1) = panel.range;
            let y_range = Ticked::new(RangedCoordf64::from(y0..y1), &panel.ticks, Vec::new());
            let mut chart = builder.build_cartesian_2d(x_range, y_range)?;
            let value_label = |v: &f64| ticks::label_of(&panel.ticks, *v);
            let mut mesh = chart.configure_mesh();
            mesh.y_desc(panel.name)
                .axis_desc_style(style::axis_name())
                .label_style(style::small())
                .x_label_formatter(&time_label)
                .y_label_formatter(&value_label)
                .bold_line_style(style::GRID);
            if last {
                mesh.x_desc(self.labels.x);
            }
            mesh.draw()?;

            for (k, series) in self.data.iter().enumerate() {
                let colour = style::PALETTE[k % style::PALETTE.len()];
                chart.draw_series(
                    series
                        .times
                        .iter()
                        .zip(&series.states)
                        .map(|(&t, x)| Circle::new((t, x[j]), radius, colour.mix(0.75).filled())),
                )?;
            }
            for (k, series) in self.model.iter().enumerate() {
                let colour = style::PALETTE[k % style::PALETTE.len()];
                chart.draw_series(LineSeries::new(
                    series
                        .times
                        .iter()
                        .zip(&series.states)
                        .map(|(&t, x)| (t, x[j])),
                    colour.stroke_width(2),
                ))?;
            }
        }
        Ok(())
    }
}
