//! Publication figures of identified models (feature `plot`).
//!
//! Four figures, matching the paper's:
//!
//! | function | paper | what it shows |
//! | --- | --- | --- |
//! | [`phase_portrait_2d`] | Fig. 1 | planar trajectories, their start points (red dots) and a reference curve such as the zero set of E |
//! | [`trajectories_3d`] | Fig. 3 | spatial trajectories, their start points and a wireframe sphere such as the zero set of E |
//! | [`loss_curves`] | Figs. 2, 4 | one or more cost histories per iteration, log scale |
//! | [`free_energy_curves`] | — | −E(t) along simulated trajectories, log scale |
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
//! exactly 0, a free energy above its maximum 0) are drawn at a floor one
//! decade below the smallest positive value in the figure, and the figure
//! says so in a note under the title.
//!
//! ```no_run
//! use metriplectic_runtime::plot::{loss_curves, phase_portrait_2d, Labels};
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
mod phase;
mod render;
mod sphere;
mod style;

use std::path::PathBuf;

pub use curves::{free_energy_curves, loss_curves};
pub use phase::phase_portrait_2d;
pub use sphere::trajectories_3d;

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
    /// Caption above the figure; empty for none.
    pub title: &'a str,
    /// Name of the first (horizontal) axis.
    pub x: &'a str,
    /// Name of the second axis.
    pub y: &'a str,
    /// Name of the third axis (3-D figures only).
    pub z: &'a str,
    /// Legend entry of the reference curve or surface (e.g. "zero set of E").
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

/// Why a figure could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// The output path's extension is neither `.png` nor `.svg`.
    #[error("{}: unsupported figure format (use a .png or .svg file name)", path.display())]
    UnsupportedFormat {
        /// The rejected path.
        path: PathBuf,
    },
    /// There is nothing to draw.
    #[error("{what} is empty")]
    Empty {
        /// What was empty (e.g. "trajectory 3", "series `metric search`").
        what: String,
    },
    /// A state has the wrong number of components for the figure.
    #[error("trajectory {trajectory}, point {point}: expected {expected} components, got {found}")]
    PointDimension {
        /// Index of the trajectory.
        trajectory: usize,
        /// Index of the point within the trajectory.
        point: usize,
        /// Components the figure needs (2 or 3).
        expected: usize,
        /// Components the point has.
        found: usize,
    },
    /// A value is NaN or infinite.
    #[error("{what}: non-finite value {value} at index {index}")]
    NonFinite {
        /// Where (e.g. "trajectory 3", "zero set", "series `entropy search`").
        what: String,
        /// Index of the offending point or value.
        index: usize,
        /// The value itself.
        value: f64,
    },
    /// Two sequences that must pair up have different lengths.
    #[error("{what}: {left} times but {right} values")]
    LengthMismatch {
        /// Which curve.
        what: String,
        /// Length of the first sequence (times).
        left: usize,
        /// Length of the second sequence (values).
        right: usize,
    },
    /// A log-scale figure has no positive value to show.
    #[error("{what}: no positive value, nothing can be drawn on a log scale")]
    NoPositiveValues {
        /// The figure's data.
        what: String,
    },
    /// An argument is out of range.
    #[error("invalid {what}: {reason}")]
    InvalidArgument {
        /// The parameter.
        what: String,
        /// Why it was rejected and what is accepted.
        reason: String,
    },
    /// The embedded font could not be loaded (a build defect, not user error).
    #[error("the embedded figure font could not be loaded")]
    Font,
    /// plotters failed while drawing.
    #[error("{}: drawing failed: {message}", path.display())]
    Drawing {
        /// The figure being drawn.
        path: PathBuf,
        /// plotters' message.
        message: String,
    },
    /// PNG encoding failed.
    #[error("{}: PNG encoding failed: {message}", path.display())]
    Encoding {
        /// The figure being written.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
    /// The file could not be written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The figure being written.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}
