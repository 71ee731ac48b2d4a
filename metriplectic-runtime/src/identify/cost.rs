//! The identification cost Σᵢ ‖ẋᵢ − f(xᵢ)‖₁ of a model on a dataset.
//!
//! Both subproblems minimise this same cost over one block of coefficients;
//! the solvers' own objective values are never trusted for decisions — the
//! cost is always recomputed from the returned coefficients with this module.

use serde::{Deserialize, Serialize};

use crate::data::Dataset;
use crate::error::{Error, Result};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// An L1 identification cost.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Cost {
    /// Σᵢ Σⱼ |ẋᵢⱼ − fⱼ(xᵢ)| over the samples and state components.
    pub sum: f64,
    /// `sum` divided by the number of residual components m·n: the mean
    /// absolute residual, the quantity the paper plots.
    pub per_component: f64,
}

impl Cost {
    /// A cost from its sum over `components` residual components.
    pub fn from_sum(sum: f64, components: usize) -> Self {
        Self {
            sum,
            per_component: sum / components.max(1) as f64,
        }
    }

    /// `true` if the sum is finite.
    pub fn is_finite(&self) -> bool {
        self.sum.is_finite()
    }
}

/// The cost of `model` on `data`. Errors if the data's dimension differs
/// from the system's.
pub fn model_cost<S: MetriplecticSystem>(model: &Model<S>, data: &Dataset) -> Result<Cost> {
    check_dataset::<S>(data)?;
    let mut xdot = vec![0.0; S::DIM];
    let mut sum = 0.0;
    for (x, measured) in data.iter() {
        model.vector_field_unchecked(x, &mut xdot);
        sum += measured
            .iter()
            .zip(&xdot)
            .map(|(m, f)| (m - f).abs())
            .sum::<f64>();
    }
    Ok(Cost::from_sum(sum, data.len() * S::DIM))
}

/// Errors unless `data` has the system's state dimension.
pub(crate) fn check_dataset<S: MetriplecticSystem>(data: &Dataset) -> Result<()> {
    if data.dim() == S::DIM {
        Ok(())
    } else {
        Err(Error::DimensionMismatch {
            what: format!("dataset state dimension for system `{}`", S::NAME),
            expected: S::DIM,
            found: data.dim(),
        })
    }
}
