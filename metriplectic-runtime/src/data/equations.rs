//! What identification fits: equations linear in the model's unknown
//! coefficients. Each equation says that a weighted sum of the vector field
//! at sampled states equals a measured target (n components):
//!
//! ```text
//! Σ_j w_j f(x_j) = y.
//! ```
//!
//! Samples (x, ẋ) are the one-term case, f(xᵢ) = ẋᵢ ([`Dataset`](crate::Dataset));
//! the weak form's windows are quadratures of a test function
//! ([`WeakDataset`](crate::WeakDataset)). The searches assemble every
//! equation's rows from the system's per-sample blocks, so both kinds of
//! data run through the same subproblems and the same joint step.

use rayon::prelude::*;

use crate::error::{invalid, Error, Result};
use crate::system::MetriplecticSystem;

/// Data identification can fit: samples with derivatives ([`Dataset`](crate::Dataset))
/// or weak-form windows of trajectories ([`WeakDataset`](crate::WeakDataset)).
/// Sealed: the runtime implements it for these two types only.
pub trait IdentificationData: sealed::Sealed + Clone + std::fmt::Debug + Send + Sync {
    /// State dimension n.
    fn dim(&self) -> usize {
        self.equations().dim
    }

    /// Number of equations (each of n components): the samples of a
    /// [`Dataset`](crate::Dataset), the windows of a
    /// [`WeakDataset`](crate::WeakDataset). Minibatches draw equations.
    fn equation_count(&self) -> usize {
        self.equations().len()
    }

    /// The state variables' names in state order, when the data were built
    /// from named trajectories (`None` for data built from bare numbers,
    /// which are taken in the system's state order). Identification
    /// refuses named data whose names are not the system's, in its order.
    fn state_names(&self) -> Option<&[String]> {
        self.equations().names
    }

    /// For weak-form data, how far the equations' targets move between two
    /// neighbouring local polynomial degrees, and the two degrees (see
    /// [`WeakDataset::quadrature_spread`](crate::WeakDataset::quadrature_spread));
    /// `None` (the default) for pointwise data.
    fn quadrature_spread(&self) -> Option<(f64, usize, usize)> {
        None
    }
}

pub(crate) mod sealed {
    /// The crate-internal interface of [`IdentificationData`](super::IdentificationData).
    pub trait Sealed: Sized {
        /// The equations as a borrowed view.
        fn equations(&self) -> super::Equations<'_>;
        /// The equations at `indices`, in that order (repeats allowed),
        /// with only the samples they read.
        fn select(&self, indices: &[usize]) -> crate::Result<Self>;
        /// The equations of all `parts` (same dimension), in order, as one
        /// dataset; errors on no parts or differing dimensions.
        fn concat(parts: &[&Self]) -> crate::Result<Self>;
    }
}

/// A borrowed view of equations (crate-internal: the module is private).
#[derive(Debug, Clone, Copy)]
pub struct Equations<'a> {
    /// State dimension n.
    pub dim: usize,
    /// The sampled states, row-major.
    pub states: &'a [f64],
    /// The targets y, n per equation.
    pub targets: &'a [f64],
    /// The terms (sample, weight) of each equation; `None`: equation i is
    /// sample i with weight 1.
    pub terms: Option<Terms<'a>>,
    /// The state variables' names, when the data came from named
    /// trajectories.
    pub names: Option<&'a [String]>,
}

/// The terms of every equation: those of equation e are at
/// `offsets[e]..offsets[e + 1]` of `samples` and `weights`.
#[derive(Debug, Clone, Copy)]
pub struct Terms<'a> {
    pub offsets: &'a [usize],
    pub samples: &'a [usize],
    pub weights: &'a [f64],
}

impl<'a> Equations<'a> {
    /// Number of equations.
    pub fn len(&self) -> usize {
        self.targets.len() / self.dim.max(1)
    }

    /// Number of sampled states.
    pub fn sample_count(&self) -> usize {
        self.states.len() / self.dim.max(1)
    }

    /// Sampled state j.
    pub fn state(&self, j: usize) -> &'a [f64] {
        &self.states[j * self.dim..(j + 1) * self.dim]
    }

    /// The target of equation e.
    pub fn target(&self, e: usize) -> &'a [f64] {
        &self.targets[e * self.dim..(e + 1) * self.dim]
    }

    /// The terms (sample, weight) of equation e.
    pub fn terms_of(&self, e: usize) -> impl Iterator<Item = (usize, f64)> + 'a {
        let (range, terms) = match self.terms {
            None => (e..e + 1, None),
            Some(terms) => (terms.offsets[e]..terms.offsets[e + 1], Some(terms)),
        };
        range.map(move |k| match terms {
            None => (k, 1.0),
            Some(terms) => (terms.samples[k], terms.weights[k]),
        })
    }

    /// Mean |y| per component: the data's scale for relative tolerances
    /// (1 if every target is zero, so that a tolerance is then absolute).
    pub fn scale(&self) -> f64 {
        let mean =
            self.targets.iter().map(|v| v.abs()).sum::<f64>() / self.targets.len().max(1) as f64;
        if mean > 0.0 {
            mean
        } else {
            1.0
        }
    }

    /// The words a fingerprint hashes: dimension, states, targets, terms.
    pub fn words(&self) -> impl Iterator<Item = u64> + 'a {
        let terms = self.terms.into_iter().flat_map(|t| {
            t.offsets
                .iter()
                .chain(t.samples)
                .map(|&v| v as u64)
                .chain(t.weights.iter().map(|w| w.to_bits()))
        });
        std::iter::once(self.dim as u64)
            .chain(self.states.iter().map(|v| v.to_bits()))
            .chain(self.targets.iter().map(|v| v.to_bits()))
            .chain(terms)
    }

    /// Rows and targets of every equation, n rows each: Σ w·block(x) and
    /// y − Σ w·drift(x), from the per-sample block `block(scratch, j, x,
    /// rows, drift)` of width `width`. Each sample's block is computed once,
    /// in parallel across rayon's pool with one `scratch()` per worker;
    /// every block is computed alone, so the bits do not depend on the
    /// thread count. On failure the error of the first failing sample is
    /// returned.
    pub fn assemble<T>(
        &self,
        width: usize,
        scratch: impl Fn() -> T + Sync + Send,
        block: impl Fn(&mut T, usize, &[f64], &mut [f64], &mut [f64]) -> Result<()> + Sync + Send,
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let n = self.dim;
        let equations = self.len();
        let mut rows = vec![0.0; equations * n * width];
        let mut targets = self.targets.to_vec();
        // Per-sample blocks and drifts, in parallel; the first error by sample.
        let fill = |blocks: &mut [f64], drifts: &mut [f64]| -> Result<()> {
            let failure = blocks
                .par_chunks_mut((n * width).max(1))
                .zip(drifts.par_chunks_mut(n.max(1)))
                .enumerate()
                .map_init(&scratch, |scratch, (j, (out, drift))| {
                    block(scratch, j, self.state(j), out, drift)
                        .err()
                        .map(|error| (j, error))
                })
                .flatten()
                .min_by_key(|(j, _)| *j);
            failure.map_or(Ok(()), |(_, error)| Err(error))
        };
        match self.terms {
            None => {
                let mut drifts = vec![0.0; equations * n];
                fill(&mut rows, &mut drifts)?;
                targets.iter_mut().zip(&drifts).for_each(|(t, d)| *t -= d);
            }
            Some(_) => {
                let samples = self.sample_count();
                let mut blocks = vec![0.0; samples * n * width];
                let mut drifts = vec![0.0; samples * n];
                fill(&mut blocks, &mut drifts)?;
                rows.par_chunks_mut((n * width).max(1))
                    .zip(targets.par_chunks_mut(n.max(1)))
                    .enumerate()
                    .for_each(|(e, (out, target))| {
                        for (j, w) in self.terms_of(e) {
                            let source = &blocks[j * n * width..(j + 1) * n * width];
                            out.iter_mut().zip(source).for_each(|(o, s)| *o += w * s);
                            let source = &drifts[j * n..(j + 1) * n];
                            target.iter_mut().zip(source).for_each(|(t, d)| *t -= w * d);
                        }
                    });
            }
        }
        Ok((rows, targets))
    }
}

/// The state names of data joined from a part named `ours` (called
/// `first` in errors) and one named `theirs` (`part`): either's when only
/// one is named; an error about `what` when both are named and differ,
/// since data are positional.
pub(crate) fn joined_names(
    ours: &Option<Vec<String>>,
    theirs: &Option<Vec<String>>,
    what: &str,
    (first, part): (&str, &str),
) -> Result<Option<Vec<String>>> {
    match (ours, theirs) {
        (Some(ours), Some(theirs)) if ours != theirs => Err(invalid(
            what,
            format!(
                "{part} has state variables ({}), {first} has ({})",
                theirs.join(", "),
                ours.join(", ")
            ),
        )),
        _ => Ok(ours.clone().or_else(|| theirs.clone())),
    }
}

/// Errors unless `data` has the system's state dimension.
pub(crate) fn check_dataset<S: MetriplecticSystem>(data: &impl IdentificationData) -> Result<()> {
    if data.dim() != S::DIM {
        return Err(Error::DimensionMismatch {
            what: format!("dataset state dimension for system `{}`", S::NAME),
            expected: S::DIM,
            found: data.dim(),
        });
    }
    if let Some(names) = data.state_names() {
        if !names
            .iter()
            .map(String::as_str)
            .eq(S::STATE_NAMES.iter().copied())
        {
            return Err(invalid(
                "dataset state names",
                format!(
                    "the data's state variables are ({}), system `{}` has ({}); data are \
                     positional, so build them from trajectories with the system's names in \
                     its order",
                    names.join(", "),
                    S::NAME,
                    S::STATE_NAMES.join(", ")
                ),
            ));
        }
    }
    // Every cost is a sum of |residual|s of this size: one beyond f64
    // would be infinite, and an infinite cost compares as converged.
    let targets = data.equations().targets;
    if !targets.iter().map(|v| v.abs()).sum::<f64>().is_finite() {
        let largest = targets.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        return Err(invalid(
            "identification data",
            format!(
                "the targets' magnitudes add up beyond the range of f64 (largest {largest:e}); \
                 rescale the data (e.g. change units)"
            ),
        ));
    }
    Ok(())
}
