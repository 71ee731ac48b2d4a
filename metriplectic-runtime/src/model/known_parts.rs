//! The known parts of a system (H and Π) sampled at a few states, recorded
//! in model files and checkpoints: the coefficients of S and K mean nothing
//! for another H or Π, and a file names its system only by name, state and
//! bases, which stay the same when the user edits a constant of H (a
//! probe's model loaded into an `Osc` with another H and Π, and its free
//! energy and field changed without a word).

use serde::{Deserialize, Serialize};

use crate::system::MetriplecticSystem;

/// How many states H and Π are sampled at.
const STATES: usize = 3;

/// Two values agree when they differ by at most this fraction of the larger
/// magnitude (or of 1): the same code gives the same bits, and another
/// platform's rounding stays far below it.
const AGREEMENT: f64 = 1e-9;

/// H and Π (row-major) at `states`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct KnownParts {
    states: Vec<Vec<f64>>,
    hamiltonian: Vec<f64>,
    poisson: Vec<Vec<f64>>,
}

impl KnownParts {
    /// H and Π of `S` at fixed, irregular states in [−1.5, 1.5]ⁿ (no two
    /// coordinates equal, none zero, so that different polynomials of low
    /// degree differ there); `None` if a value there is not finite (a
    /// hand-written system may have a singularity; JSON has no NaN).
    pub(crate) fn of<S: MetriplecticSystem>() -> Option<Self> {
        let parts = Self::sampled::<S>();
        let finite = parts.hamiltonian.iter().all(|h| h.is_finite())
            && parts.poisson.iter().flatten().all(|p| p.is_finite());
        finite.then_some(parts)
    }

    fn sampled<S: MetriplecticSystem>() -> Self {
        let states: Vec<Vec<f64>> = (0..STATES)
            .map(|k| {
                (0..S::DIM)
                    .map(|j| 1.5 * (1.3 + 2.1 * j as f64 + 0.77 * k as f64).sin())
                    .collect()
            })
            .collect();
        Self::at::<S>(states)
    }

    /// H and Π of `S` at `states` (each of S::DIM values).
    fn at<S: MetriplecticSystem>(states: Vec<Vec<f64>>) -> Self {
        let hamiltonian = states.iter().map(|x| S::hamiltonian(x)).collect();
        let poisson = states
            .iter()
            .map(|x| {
                let mut value = vec![0.0; S::DIM * S::DIM];
                S::poisson(x, &mut value);
                value
            })
            .collect();
        Self {
            states,
            hamiltonian,
            poisson,
        }
    }

    /// `None` if these recorded values are `S`'s own; otherwise where they
    /// differ, in words ("H = 0.25 in the file, 0.875 in the system at
    /// (0.3, −0.7)"), or why the record cannot be `S`'s.
    pub(crate) fn difference<S: MetriplecticSystem>(&self) -> Option<String> {
        let well_formed = !self.states.is_empty()
            && self.states.len() == self.hamiltonian.len()
            && self.states.len() == self.poisson.len()
            && self.states.iter().all(|x| x.len() == S::DIM)
            && self.poisson.iter().all(|p| p.len() == S::DIM * S::DIM);
        if !well_formed {
            return Some(format!(
                "its record of H and Π is not of {} states of dimension {}",
                self.states.len(),
                S::DIM
            ));
        }
        let system = Self::at::<S>(self.states.clone());
        let agree = |a: f64, b: f64| (a - b).abs() <= AGREEMENT * a.abs().max(b.abs()).max(1.0);
        let state = |x: &[f64]| {
            let values: Vec<String> = x.iter().map(|v| format!("{v:.4}")).collect();
            format!("({})", values.join(", "))
        };
        for (k, x) in self.states.iter().enumerate() {
            let (file, own) = (self.hamiltonian[k], system.hamiltonian[k]);
            if !agree(file, own) {
                return Some(format!(
                    "another Hamiltonian: H = {file:e} in the file, {own:e} in the system at {}",
                    state(x)
                ));
            }
            let entries = self.poisson[k].iter().zip(&system.poisson[k]).enumerate();
            for (entry, (&file, &own)) in entries {
                if !agree(file, own) {
                    return Some(format!(
                        "another Poisson tensor: Π[{}][{}] = {file:e} in the file, {own:e} in the system at {}",
                        entry / S::DIM,
                        entry % S::DIM,
                        state(x)
                    ));
                }
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::KnownParts;
    use crate::test_system::Quadratic2d;

    #[test]
    fn a_system_agrees_with_its_own_record_and_an_edited_one_is_named() {
        let own = KnownParts::of::<Quadratic2d>().unwrap();
        assert_eq!(own.difference::<Quadratic2d>(), None);
        // The states are distinct and away from zero.
        assert!(own.states.iter().flatten().all(|v| v.abs() > 0.05));

        let mut edited = own.clone();
        edited.hamiltonian[1] *= 1.01;
        let text = edited.difference::<Quadratic2d>().unwrap();
        assert!(text.starts_with("another Hamiltonian: H = "), "{text}");

        let mut edited = own.clone();
        edited.poisson[2][1] += 0.5;
        let text = edited.difference::<Quadratic2d>().unwrap();
        assert!(
            text.starts_with("another Poisson tensor: Π[0][1]"),
            "{text}"
        );

        let mut truncated = own;
        truncated.states.pop();
        assert!(truncated
            .difference::<Quadratic2d>()
            .unwrap()
            .contains("is not of 2 states"));
    }
}
