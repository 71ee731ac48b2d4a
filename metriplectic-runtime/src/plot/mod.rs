//! Publication figures of identified models (feature `plot`).
//!
//! Four figures matching the paper's, and one for checking a model against
//! measurements:
//!
//! | function | paper | what it shows |
//! | --- | --- | --- |
//! | [`phase_portrait_2d`] | Fig. 1 | planar trajectories, their start points (red dots) and a reference curve such as the zero set of E |
//! | [`trajectories_3d`] | Fig. 3 | spatial trajectories, their start points and a wireframe sphere such as the zero set of E |
//! | [`loss_curves`] | Figs. 2, 4 | one or more cost histories per iteration, log scale |
//! | [`free_energy_curves`] | — | E_lim − E(t) along simulated trajectories, each relative to its own limit, log scale |
//! | [`trajectory_overlay`] | — | measured states (markers) against a model's trajectories (lines) over time, one panel per state variable |
//!
//! Every function takes plain data (slices of numbers), so it works with any
//! simulation or identifier output, and writes one file whose format is chosen
//! by the path's extension: `.png` (bitmap) or `.svg` (vector). Any other
//! extension is [`PlotError::UnsupportedFormat`]. Text is rendered with an
//! embedded subset of DejaVu Sans, so no system fonts, fontconfig or freetype
//! are needed.
//!
//! Data are validated before anything is drawn: an empty input, a point of the
//! wrong dimension, or a NaN/infinite value is an error naming the trajectory
//! or series and the index, never a panic and never a silently wrong figure.
//!
//! Log-scale figures cannot show values ≤ 0. Such values (a cost that reached
//! exactly 0, the free energy at its limit) are drawn at a floor one decade
//! below the smallest positive value in the figure, and the figure says so
//! in a note under the plot.
//!
//! Axis labels are placed by [`log_axis_ticks`] (at least 3 labels on a log
//! axis, even within one decade), [`integer_axis_ticks`] (iteration axes:
//! whole numbers only) and round numbers elsewhere; the first two are public
//! so that other figures can label their axes the same way.
//!
//! ```no_run
//! use metriplectic_runtime::{loss_curves, phase_portrait_2d, Labels};
//!
//! # fn main() -> metriplectic_runtime::Result<()> {
//! // One trajectory spiralling towards the figure eight (cos t, sin 2t).
//! let trajectory: Vec<[f64; 2]> = (0..500)
//!     .map(|i| {
//!         let t = 0.05 * i as f64;
//!         let r = 1.0 + (-0.3 * t).exp();
//!         [r * t.cos(), r * (2.0 * t).sin()]
//!     })
//!     .collect();
//! let eight: Vec<(f64, f64)> = (0..=400)
//!     .map(|i| {
//!         let t = std::f64::consts::TAU * i as f64 / 400.0;
//!         (t.cos(), (2.0 * t).sin())
//!     })
//!     .collect();
//! let labels = Labels {
//!     title: "2-D metriplectic system",
//!     x: "q",
//!     y: "p",
//!     reference: "zero set of E",
//!     ..Labels::default()
//! };
//! phase_portrait_2d("trajectories.png", &[trajectory], &eight, &labels)?;
//!
//! let metric = [1.0, 0.1, 1e-3, 1e-6];
//! let entropy = [0.5, 0.05, 1e-4, 0.0];
//! let labels = Labels { title: "loss", x: "iteration", y: "cost", ..Labels::default() };
//! loss_curves("loss.svg", &[("metric search", &metric[..]), ("entropy search", &entropy[..])], &labels)?;
//! # Ok(())
//! # }
//! ```

mod curves;
mod data;
mod font;
mod overlay;
mod phase;
mod render;
mod sphere;
mod style;
mod ticks;

pub use curves::{free_energy_curves, loss_curves};
pub use overlay::trajectory_overlay;
pub use phase::phase_portrait_2d;
pub use sphere::trajectories_3d;
pub use ticks::{integer_axis_ticks, log_axis_ticks, AxisTick};

pub use crate::error::PlotError;

/// Titles and axis names of a figure. Each figure uses the fields it needs:
///
/// - [`phase_portrait_2d`]: `title`, `x`, `y`, `reference` (legend entry of the curve);
/// - [`trajectories_3d`]: `title`, `x`, `y`, `z` (the three state components,
///   `z` drawn vertically), `reference` (legend entry of the sphere);
/// - [`loss_curves`], [`free_energy_curves`]: `title`, `x`, `y`.
///
/// Labels may use Unicode (Greek letters, −, ², subscripts, ∇, ≤ …).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Labels<'a> {
    /// Caption above the figure; empty for none (the default).
    pub title: &'a str,
    /// Name of the first (horizontal) axis. Default `"x"`.
    pub x: &'a str,
    /// Name of the second axis. Default `"y"`.
    pub y: &'a str,
    /// Name of the third axis (3-D figures only). Default `"z"`.
    pub z: &'a str,
    /// Legend entry of the reference curve or surface (e.g. "zero set of
    /// E"). Default `"E = 0"`.
    pub reference: &'a str,
}

impl Default for Labels<'_> {
    fn default() -> Self {
        Labels {
            title: "",
            x: "x",
            y: "y",
            z: "z",
            reference: "E = 0",
        }
    }
}
