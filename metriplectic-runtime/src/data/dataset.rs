//! Identification data: samples (xᵢ, ẋᵢ) of a system's state and its time
//! derivative.

use super::equations::{joined_names, sealed, Equations, IdentificationData};
use crate::error::{invalid, DatasetError, Error, Result};

/// Validated samples (xᵢ, ẋᵢ), i = 0..m, of an n-dimensional state.
///
/// Stored row-major: sample i's state is `states[i*n..(i+1)*n]`. Construction
/// guarantees at least one sample, matching lengths and finite values, so the
/// solvers never see malformed data.
///
/// Data built from trajectories (and by [`synthesize`](crate::synthesize))
/// carry their state names, which identification checks against the
/// system's; data built from bare numbers ([`from_flat`](Self::from_flat),
/// [`from_rows`](Self::from_rows)) are unnamed and taken in the system's
/// state order (name them with [`with_state_names`](Self::with_state_names)).
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    dim: usize,
    states: Vec<f64>,
    derivatives: Vec<f64>,
    names: Option<Vec<String>>,
}

impl Dataset {
    /// A dataset from flat row-major buffers of states and derivatives.
    pub fn from_flat(
        dim: usize,
        states: Vec<f64>,
        derivatives: Vec<f64>,
    ) -> Result<Self, DatasetError> {
        if dim == 0 {
            return Err(DatasetError::ZeroDimension);
        }
        for (what, buffer) in [("states", &states), ("derivatives", &derivatives)] {
            if buffer.len() % dim != 0 {
                return Err(DatasetError::RaggedBuffer {
                    what,
                    len: buffer.len(),
                    dim,
                });
            }
        }
        let count = states.len() / dim;
        if count != derivatives.len() / dim {
            return Err(DatasetError::CountMismatch {
                states: count,
                derivatives: derivatives.len() / dim,
            });
        }
        if count == 0 {
            return Err(DatasetError::Empty);
        }
        for (what, buffer) in [("state", &states), ("derivative", &derivatives)] {
            if let Some(pos) = buffer.iter().position(|v| !v.is_finite()) {
                return Err(DatasetError::NonFinite {
                    sample: pos / dim,
                    what,
                    column: pos % dim,
                    value: buffer[pos],
                });
            }
        }
        Ok(Self {
            dim,
            states,
            derivatives,
            names: None,
        })
    }

    /// The same samples with their state variables named, in state order
    /// (default: unnamed). Identification then refuses the data for a
    /// system whose [`STATE_NAMES`](crate::MetriplecticSystem::STATE_NAMES)
    /// differ, in name or order. Datasets built from trajectories are named
    /// by them.
    ///
    /// Errors if there are not `dim()` names or a name repeats.
    pub fn with_state_names(mut self, names: Vec<String>) -> Result<Self> {
        if names.len() != self.dim {
            return Err(Error::DimensionMismatch {
                what: "dataset state names".to_owned(),
                expected: self.dim,
                found: names.len(),
            });
        }
        if let Some(reason) = super::trajectory::repeated_name(&names) {
            return Err(invalid("dataset state names", reason));
        }
        self.names = Some(names);
        Ok(self)
    }

    /// A dataset from per-sample rows (each of length `dim`).
    pub fn from_rows<X, D>(
        dim: usize,
        states: &[X],
        derivatives: &[D],
    ) -> Result<Self, DatasetError>
    where
        X: AsRef<[f64]>,
        D: AsRef<[f64]>,
    {
        if states.len() != derivatives.len() {
            return Err(DatasetError::CountMismatch {
                states: states.len(),
                derivatives: derivatives.len(),
            });
        }
        // Grown as the rows are checked, not reserved from `dim` up front:
        // a wrong `dim` must be a width error, not a failed allocation.
        let mut flat_x = Vec::new();
        let mut flat_d = Vec::new();
        for (sample, (x, d)) in states.iter().zip(derivatives).enumerate() {
            for (what, row, flat) in [
                ("state", x.as_ref(), &mut flat_x),
                ("derivative", d.as_ref(), &mut flat_d),
            ] {
                if row.len() != dim {
                    return Err(DatasetError::WrongWidth {
                        sample,
                        what,
                        expected: dim,
                        found: row.len(),
                    });
                }
                flat.extend_from_slice(row);
            }
        }
        Self::from_flat(dim, flat_x, flat_d)
    }

    /// State dimension n.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Number of samples m (at least 1).
    pub fn len(&self) -> usize {
        self.states.len() / self.dim
    }

    /// Always `false`: a dataset holds at least one sample.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// State xᵢ. Panics if `i >= len()`, like slice indexing.
    pub fn state(&self, i: usize) -> &[f64] {
        &self.states[i * self.dim..(i + 1) * self.dim]
    }

    /// Derivative ẋᵢ. Panics if `i >= len()`, like slice indexing.
    pub fn derivative(&self, i: usize) -> &[f64] {
        &self.derivatives[i * self.dim..(i + 1) * self.dim]
    }

    /// All states, row-major.
    pub fn states(&self) -> &[f64] {
        &self.states
    }

    /// All derivatives, row-major.
    pub fn derivatives(&self) -> &[f64] {
        &self.derivatives
    }

    /// Iterator over (xᵢ, ẋᵢ).
    pub fn iter(&self) -> impl ExactSizeIterator<Item = (&[f64], &[f64])> + '_ {
        self.states
            .chunks_exact(self.dim)
            .zip(self.derivatives.chunks_exact(self.dim))
    }

    /// The samples at `indices`, in that order (repeats allowed).
    ///
    /// Errors if `indices` is empty or names a sample past the end.
    pub fn select(&self, indices: &[usize]) -> Result<Self> {
        if let Some(&bad) = indices.iter().find(|&&i| i >= self.len()) {
            return Err(Error::InvalidArgument {
                what: "sample index".to_owned(),
                reason: format!(
                    "{bad} is out of range for a dataset of {} samples",
                    self.len()
                ),
            });
        }
        let mut states = Vec::with_capacity(indices.len() * self.dim);
        let mut derivatives = Vec::with_capacity(indices.len() * self.dim);
        for &i in indices {
            states.extend_from_slice(self.state(i));
            derivatives.extend_from_slice(self.derivative(i));
        }
        Ok(Self {
            names: self.names.clone(),
            ..Self::from_flat(self.dim, states, derivatives)?
        })
    }

    /// Appends the samples of `other` (same dimension; if both are named,
    /// the same names). Unnamed samples take this dataset's names.
    pub fn extend(&mut self, other: &Dataset) -> Result<()> {
        if other.dim != self.dim {
            return Err(Error::DimensionMismatch {
                what: "appended dataset".to_owned(),
                expected: self.dim,
                found: other.dim,
            });
        }
        self.names = joined_names(
            &self.names,
            &other.names,
            "appended dataset",
            ("this dataset", "it"),
        )?;
        self.states.extend_from_slice(&other.states);
        self.derivatives.extend_from_slice(&other.derivatives);
        Ok(())
    }
}

impl sealed::Sealed for Dataset {
    fn equations(&self) -> Equations<'_> {
        Equations {
            dim: self.dim,
            states: &self.states,
            targets: &self.derivatives,
            terms: None,
            names: self.names.as_deref(),
        }
    }

    fn select(&self, indices: &[usize]) -> Result<Self> {
        Dataset::select(self, indices)
    }

    fn concat(parts: &[&Self]) -> Result<Self> {
        let (first, rest) = parts.split_first().ok_or_else(|| Error::InvalidArgument {
            what: "datasets".to_owned(),
            reason: "at least one is required".to_owned(),
        })?;
        let mut all = (*first).clone();
        for part in rest {
            all.extend(part)?;
        }
        Ok(all)
    }
}

impl IdentificationData for Dataset {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_non_finite_with_sample_and_column() {
        let err = Dataset::from_flat(2, vec![0.0, 1.0, 2.0, f64::NAN], vec![0.0; 4]).unwrap_err();
        assert!(matches!(
            err,
            DatasetError::NonFinite {
                sample: 1,
                column: 1,
                what: "state",
                ..
            }
        ));
        let err =
            Dataset::from_flat(2, vec![0.0; 4], vec![0.0, f64::INFINITY, 0.0, 0.0]).unwrap_err();
        assert!(matches!(
            err,
            DatasetError::NonFinite {
                sample: 0,
                column: 1,
                what: "derivative",
                ..
            }
        ));
    }

    #[test]
    fn appending_keeps_names_and_refuses_other_ones() {
        let named = |names: [&str; 2]| {
            Dataset::from_flat(2, vec![1.0, 2.0], vec![0.0; 2])
                .unwrap()
                .with_state_names(names.map(str::to_owned).to_vec())
                .unwrap()
        };
        let unnamed = Dataset::from_flat(2, vec![3.0, 4.0], vec![0.0; 2]).unwrap();
        let mut data = unnamed.clone();
        data.extend(&named(["q", "p"])).unwrap();
        data.extend(&unnamed).unwrap();
        assert_eq!(data.len(), 3);
        assert_eq!(
            data.state_names(),
            Some(&["q".to_owned(), "p".to_owned()][..])
        );
        let err = data.extend(&named(["p", "q"])).unwrap_err();
        assert!(
            err.to_string()
                .contains("it has state variables (p, q), this dataset has (q, p)"),
            "{err}"
        );
    }

    #[test]
    fn rejects_empty_ragged_and_mismatched() {
        assert_eq!(
            Dataset::from_flat(2, vec![], vec![]),
            Err(DatasetError::Empty)
        );
        assert!(matches!(
            Dataset::from_flat(2, vec![0.0; 3], vec![0.0; 3]),
            Err(DatasetError::RaggedBuffer { what: "states", .. })
        ));
        assert!(matches!(
            Dataset::from_flat(2, vec![0.0; 4], vec![0.0; 2]),
            Err(DatasetError::CountMismatch {
                states: 2,
                derivatives: 1
            })
        ));
        let rows: Vec<Vec<f64>> = vec![vec![0.0, 1.0], vec![0.0]];
        assert!(matches!(
            Dataset::from_rows(2, &rows, &rows),
            Err(DatasetError::WrongWidth {
                sample: 1,
                what: "state",
                expected: 2,
                found: 1
            })
        ));
    }

    #[test]
    fn select_keeps_order_and_checks_range() {
        let data = Dataset::from_flat(1, vec![1.0, 2.0, 3.0], vec![4.0, 5.0, 6.0]).unwrap();
        let picked = data.select(&[2, 0, 2]).unwrap();
        assert_eq!(picked.states(), &[3.0, 1.0, 3.0]);
        assert_eq!(picked.derivatives(), &[6.0, 4.0, 6.0]);
        assert!(data.select(&[3]).is_err());
        assert!(data.select(&[]).is_err());
    }
}
