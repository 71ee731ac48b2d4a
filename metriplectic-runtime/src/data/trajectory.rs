//! Sampled trajectories: time stamps, states and (optionally) time derivatives.
//!
//! A [`Trajectory`] is what a simulation produces and what a CSV file of
//! measurements holds: states x(tₖ) at strictly increasing times tₖ, with the
//! state variables named. Derivatives ẋ(tₖ) are present when they were
//! simulated or measured, and can otherwise be estimated with
//! [`estimate_derivatives`](crate::estimate_derivatives). [`Trajectory::to_dataset`] turns samples with
//! derivatives into identification data.

use super::Dataset;
use crate::error::{invalid, Error, Result};

/// States sampled at strictly increasing times, with named state variables
/// and optional time derivatives.
///
/// Storage is row-major like [`Dataset`]: sample k's state is
/// `states()[k*n..(k+1)*n]`. Construction guarantees at least one sample,
/// finite values, strictly increasing finite times and matching lengths.
///
/// ```
/// use metriplectic_runtime::Trajectory;
///
/// let traj = Trajectory::new(
///     vec!["q".into(), "p".into()],
///     vec![0.0, 0.5],
///     vec![1.0, 0.0, 0.9, -0.4],
///     None,
/// )
/// .unwrap();
/// assert_eq!(traj.len(), 2);
/// assert_eq!(traj.state(1), &[0.9, -0.4]);
/// assert!(traj.derivatives().is_none());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    id: Option<String>,
    names: Vec<String>,
    times: Vec<f64>,
    states: Vec<f64>,
    derivatives: Option<Vec<f64>>,
}

impl Trajectory {
    /// A trajectory from state names, times, row-major states and optional
    /// row-major derivatives.
    ///
    /// Errors name the offending sample: wrong buffer lengths, non-finite
    /// values, or times that do not strictly increase.
    pub fn new(
        names: Vec<String>,
        times: Vec<f64>,
        states: Vec<f64>,
        derivatives: Option<Vec<f64>>,
    ) -> Result<Self> {
        let dim = names.len();
        if dim == 0 {
            return Err(invalid(
                "trajectory state names",
                "at least one state variable is required".to_owned(),
            ));
        }
        if times.is_empty() {
            return Err(invalid(
                "trajectory",
                "at least one sample is required".to_owned(),
            ));
        }
        for (what, buffer) in std::iter::once(("states", &states))
            .chain(derivatives.as_ref().map(|d| ("derivatives", d)))
        {
            if buffer.len() != times.len() * dim {
                return Err(Error::DimensionMismatch {
                    what: format!(
                        "trajectory {what} ({} samples × {dim} variables)",
                        times.len()
                    ),
                    expected: times.len() * dim,
                    found: buffer.len(),
                });
            }
            if let Some(pos) = buffer.iter().position(|v| !v.is_finite()) {
                return Err(invalid(
                    &format!("trajectory {what}"),
                    format!(
                        "sample {}, variable `{}`: non-finite value {}",
                        pos / dim,
                        names[pos % dim],
                        buffer[pos]
                    ),
                ));
            }
        }
        crate::error::check_strictly_increasing("trajectory times", &times)?;
        Ok(Self {
            id: None,
            names,
            times,
            states,
            derivatives,
        })
    }

    /// The same trajectory labelled with an identifier (written to and read
    /// from the `trajectory` column of CSV files).
    pub fn with_id(mut self, id: impl Into<String>) -> Self {
        self.id = Some(id.into());
        self
    }

    /// The identifier, if any.
    pub fn id(&self) -> Option<&str> {
        self.id.as_deref()
    }

    /// Names of the state variables, in state order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// State dimension n.
    pub fn dim(&self) -> usize {
        self.names.len()
    }

    /// Number of samples (at least 1).
    pub fn len(&self) -> usize {
        self.times.len()
    }

    /// Always `false`: a trajectory holds at least one sample.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Time stamps, strictly increasing.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// All states, row-major.
    pub fn states(&self) -> &[f64] {
        &self.states
    }

    /// All derivatives, row-major, if present.
    pub fn derivatives(&self) -> Option<&[f64]> {
        self.derivatives.as_deref()
    }

    /// State of sample k. Panics if `k >= len()`, like slice indexing.
    pub fn state(&self, k: usize) -> &[f64] {
        let n = self.dim();
        &self.states[k * n..(k + 1) * n]
    }

    /// Derivative of sample k, if derivatives are present. Panics if
    /// `k >= len()`, like slice indexing.
    pub fn derivative(&self, k: usize) -> Option<&[f64]> {
        let n = self.dim();
        self.derivatives.as_ref().map(|d| &d[k * n..(k + 1) * n])
    }

    /// The time series of state variable `j` (a copy; states are row-major).
    pub fn component(&self, j: usize) -> Vec<f64> {
        self.states
            .iter()
            .skip(j)
            .step_by(self.dim())
            .copied()
            .collect()
    }

    /// Replaces (or sets) the derivatives, with the same checks as
    /// [`Trajectory::new`].
    pub fn with_derivatives(self, derivatives: Vec<f64>) -> Result<Self> {
        let id = self.id;
        let mut traj = Self::new(self.names, self.times, self.states, Some(derivatives))?;
        traj.id = id;
        Ok(traj)
    }

    /// The same trajectory without derivatives.
    pub fn without_derivatives(mut self) -> Self {
        self.derivatives = None;
        self
    }

    /// Checks that the state variables are `expected`, in that order.
    pub fn check_names(&self, expected: &[&str]) -> Result<()> {
        if self
            .names
            .iter()
            .map(String::as_str)
            .eq(expected.iter().copied())
        {
            Ok(())
        } else {
            Err(invalid(
                "trajectory state names",
                format!(
                    "expected ({}), found ({})",
                    expected.join(", "),
                    self.names.join(", ")
                ),
            ))
        }
    }

    /// The samples (x(tₖ), ẋ(tₖ)) as identification data.
    ///
    /// Errors if the trajectory has no derivatives (estimate them first with
    /// [`estimate_derivatives`](crate::estimate_derivatives)).
    pub fn to_dataset(&self) -> Result<Dataset> {
        let derivatives = self.derivatives.clone().ok_or_else(|| {
            invalid(
                "trajectory",
                "it has no derivatives; estimate them with `estimate_derivatives` first".to_owned(),
            )
        })?;
        Ok(Dataset::from_flat(
            self.dim(),
            self.states.clone(),
            derivatives,
        )?)
    }
}

/// All samples of several trajectories as one dataset (same dimension, all
/// with derivatives).
///
/// ```
/// use metriplectic_runtime::{dataset_from_trajectories, Trajectory};
///
/// let a = Trajectory::new(vec!["x".into()], vec![0.0], vec![1.0], Some(vec![-1.0])).unwrap();
/// let b = Trajectory::new(vec!["x".into()], vec![0.0], vec![2.0], Some(vec![-2.0])).unwrap();
/// let data = dataset_from_trajectories(&[a, b]).unwrap();
/// assert_eq!(data.len(), 2);
/// ```
pub fn dataset_from_trajectories(trajectories: &[Trajectory]) -> Result<Dataset> {
    let (first, rest) = trajectories.split_first().ok_or_else(|| {
        invalid(
            "trajectories",
            "at least one trajectory is required".to_owned(),
        )
    })?;
    let mut data = first.to_dataset()?;
    for traj in rest {
        data.extend(&traj.to_dataset()?)?;
    }
    Ok(data)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names() -> Vec<String> {
        vec!["q".into(), "p".into()]
    }

    #[test]
    fn rejects_bad_construction() {
        let err = Trajectory::new(names(), vec![0.0, 0.0], vec![0.0; 4], None).unwrap_err();
        assert!(err.to_string().contains("strictly increase"), "{err}");
        let err = Trajectory::new(names(), vec![0.0, 1.0], vec![0.0; 3], None).unwrap_err();
        assert!(matches!(
            err,
            Error::DimensionMismatch {
                expected: 4,
                found: 3,
                ..
            }
        ));
        let err = Trajectory::new(names(), vec![0.0], vec![0.0, f64::NAN], None).unwrap_err();
        assert!(err.to_string().contains("variable `p`"), "{err}");
        let err = Trajectory::new(names(), vec![], vec![], None).unwrap_err();
        assert!(err.to_string().contains("at least one sample"), "{err}");
    }

    #[test]
    fn components_and_dataset() {
        let traj = Trajectory::new(
            names(),
            vec![0.0, 1.0],
            vec![1.0, 2.0, 3.0, 4.0],
            Some(vec![5.0, 6.0, 7.0, 8.0]),
        )
        .unwrap();
        assert_eq!(traj.component(1), vec![2.0, 4.0]);
        let data = traj.to_dataset().unwrap();
        assert_eq!(data.derivative(1), &[7.0, 8.0]);
        assert!(traj.without_derivatives().to_dataset().is_err());
    }
}
