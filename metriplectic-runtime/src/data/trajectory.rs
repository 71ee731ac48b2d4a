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
        Dataset::from_flat(self.dim(), self.states.clone(), derivatives)?
            .with_state_names(self.names.clone())
    }
}

/// All samples of several trajectories as one dataset (the same state
/// names in the same order, all with derivatives).
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
    check_same_names(trajectories)?;
    let named = |index: usize, traj: &Trajectory| {
        traj.to_dataset()
            .map_err(|err| in_series(err, &describe(index, traj)))
    };
    let mut data = named(0, first)?;
    for (index, traj) in rest.iter().enumerate() {
        data.extend(&named(index + 1, traj)?)?;
    }
    Ok(data)
}

/// Errors unless every trajectory names its state variables as the first
/// does, in the same order: data are positional, so `(p, q)` beside
/// `(q, p)` would mix the two variables silently.
pub(crate) fn check_same_names(trajectories: &[Trajectory]) -> Result<()> {
    let Some((first, rest)) = trajectories.split_first() else {
        return Ok(());
    };
    for (index, traj) in rest.iter().enumerate() {
        if traj.names != first.names {
            return Err(invalid(
                "trajectory state names",
                format!(
                    "trajectory {} has ({}), trajectory 0 has ({}); all must name the same \
                     variables in the same order",
                    index + 1,
                    traj.names.join(", "),
                    first.names.join(", ")
                ),
            ));
        }
    }
    Ok(())
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

/// How errors name the trajectory at `index` of a list: "trajectory 3", or
/// "trajectory 3 (id \"run7\")" when it has an identifier.
pub(crate) fn describe(index: usize, trajectory: &Trajectory) -> String {
    match trajectory.id() {
        Some(id) => format!("trajectory {index} (id {id:?})"),
        None => format!("trajectory {index}"),
    }
}

/// Says which trajectory or series (`series`) an invalid-argument error
/// concerns; other errors are returned as they are.
pub(crate) fn in_series(err: Error, series: &str) -> Error {
    match err {
        Error::InvalidArgument { what, reason } => Error::InvalidArgument {
            what: format!("{series}: {what}"),
            reason,
        },
        other => other,
    }
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
    fn trajectories_naming_their_variables_differently_are_not_mixed() {
        let a = Trajectory::new(names(), vec![0.0], vec![1.0, 2.0], Some(vec![0.0; 2])).unwrap();
        let swapped = vec!["p".to_owned(), "q".to_owned()];
        let b = Trajectory::new(swapped, vec![0.0], vec![2.0, 1.0], Some(vec![0.0; 2])).unwrap();
        let err = dataset_from_trajectories(&[a.clone(), b]).unwrap_err();
        assert!(
            err.to_string()
                .contains("trajectory 1 has (p, q), trajectory 0 has (q, p)"),
            "{err}"
        );
        assert_eq!(dataset_from_trajectories(&[a.clone(), a]).unwrap().len(), 2);
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
