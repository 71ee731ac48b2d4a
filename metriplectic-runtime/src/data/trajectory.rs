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
        if let Some(reason) = repeated_name(&names) {
            return Err(invalid("trajectory state names", reason));
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

    /// The time series of state variable `j` (a copy; states are
    /// row-major). Panics if `j >= dim()`, like slice indexing (it used to
    /// return a later variable's values instead).
    pub fn component(&self, j: usize) -> Vec<f64> {
        assert!(
            j < self.dim(),
            "state variable {j} does not exist: the trajectory has {}",
            self.dim()
        );
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

impl Dataset {
    /// The samples (x(tₖ), ẋ(tₖ)) of `trajectories` (same dimension): with
    /// `derivatives = None` their own (measured or simulated) derivatives,
    /// which every trajectory must carry; otherwise derivatives estimated
    /// from the states with that method (any present are ignored).
    ///
    /// For noisy states without derivatives, the weak form
    /// ([`WeakDataset::from_trajectories`](crate::WeakDataset::from_trajectories))
    /// needs no derivative estimate at all.
    ///
    /// ```
    /// use metriplectic_runtime::{Dataset, DerivativeMethod, Trajectory};
    ///
    /// let t: Vec<f64> = (0..30).map(|k| 0.1 * k as f64).collect();
    /// let x: Vec<f64> = t.iter().map(|t| (-t).exp()).collect();
    /// let traj = Trajectory::new(vec!["x".into()], t, x, None).unwrap();
    /// let method = DerivativeMethod::FiniteDifference { order: 4 };
    /// let data = Dataset::from_trajectories(&[traj], Some(&method)).unwrap();
    /// assert_eq!(data.len(), 30);
    /// assert!((data.derivative(10)[0] + (-1.0f64).exp()).abs() < 1e-4);
    /// ```
    pub fn from_trajectories(
        trajectories: &[Trajectory],
        derivatives: Option<&crate::DerivativeMethod>,
    ) -> Result<Dataset> {
        match derivatives {
            None => dataset_from_trajectories(trajectories),
            Some(method) => {
                let estimated = crate::estimate_all(trajectories, method)?;
                dataset_from_trajectories(&estimated)
            }
        }
    }
}

/// Splits trajectories at random into (training, validation) by whole
/// trajectories, `fraction` of them (rounded, at least one, and leaving at
/// least one) for validation, reproducibly for a `seed`.
///
/// Holding out whole trajectories keeps validation states from being time
/// neighbours of training states, so the validation error measures how the
/// model generalises to new initial conditions.
///
/// ```
/// use metriplectic_runtime::{split_by_trajectory, Trajectory};
///
/// let trajs: Vec<Trajectory> = (0..10)
///     .map(|k| Trajectory::new(vec!["x".into()], vec![0.0], vec![k as f64], None).unwrap())
///     .collect();
/// let (train, validation) = split_by_trajectory(&trajs, 0.2, 7).unwrap();
/// assert_eq!((train.len(), validation.len()), (8, 2));
/// ```
pub fn split_by_trajectory(
    trajectories: &[Trajectory],
    fraction: f64,
    seed: u64,
) -> Result<(Vec<Trajectory>, Vec<Trajectory>)> {
    use rand::SeedableRng;
    let count = trajectories.len();
    if count < 2 {
        return Err(invalid(
            "trajectories",
            format!("{count} trajectories cannot be split: at least two are needed"),
        ));
    }
    if !(fraction > 0.0 && fraction < 1.0) {
        return Err(invalid(
            "validation fraction",
            format!("{fraction} is not in (0, 1)"),
        ));
    }
    let held = ((fraction * count as f64).round() as usize).clamp(1, count - 1);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut order = rand::seq::index::sample(&mut rng, count, count).into_vec();
    let mut validation_indices = order.split_off(count - held);
    order.sort_unstable();
    validation_indices.sort_unstable();
    let pick = |indices: &[usize]| indices.iter().map(|&i| trajectories[i].clone()).collect();
    Ok((pick(&order), pick(&validation_indices)))
}

/// "`q` is both variable 0 and variable 1" for the first name that
/// repeats an earlier one; `None` if all differ.
pub(crate) fn repeated_name<T: AsRef<str>>(names: &[T]) -> Option<String> {
    names.iter().enumerate().find_map(|(k, name)| {
        let name = name.as_ref();
        names[..k]
            .iter()
            .position(|other| other.as_ref() == name)
            .map(|first| format!("`{name}` is both variable {first} and variable {k}"))
    })
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
        let twice = vec!["q".to_owned(), "q".to_owned()];
        let err = Trajectory::new(twice, vec![0.0], vec![0.0, 1.0], None).unwrap_err();
        assert!(
            err.to_string()
                .contains("`q` is both variable 0 and variable 1"),
            "{err}"
        );
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

    #[test]
    #[should_panic(expected = "state variable 2 does not exist")]
    fn a_component_beyond_the_state_is_not_a_later_variable() {
        let traj =
            Trajectory::new(names(), vec![0.0, 1.0], vec![1.0, 2.0, 3.0, 4.0], None).unwrap();
        let _ = traj.component(2);
    }
}
