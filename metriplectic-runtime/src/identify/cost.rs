//! The identification cost Σᵢ ‖ẋᵢ − f(xᵢ)‖₁ of a model on a dataset.
//!
//! Both subproblems minimise this same cost over one block of coefficients;
//! the solvers' own objective values are never trusted for decisions — the
//! cost is always recomputed from the returned coefficients with this module.

use serde::{Deserialize, Serialize};

use crate::data::{check_dataset, IdentificationData};
use crate::error::Result;
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// An L1 identification cost.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Cost {
    /// Σᵢ Σⱼ |ẋᵢⱼ − fⱼ(xᵢ)| over the samples and state components (in
    /// JSON a number, or `"inf"` / `"NaN"` when it overflowed).
    #[serde(with = "super::json_float::number")]
    pub sum: f64,
    /// `sum` divided by the number of residual components m·n: the mean
    /// absolute residual, the quantity the paper plots.
    #[serde(with = "super::json_float::number")]
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
pub fn model_cost<S: MetriplecticSystem>(
    model: &Model<S>,
    data: &impl IdentificationData,
) -> Result<Cost> {
    let residuals = model_residuals(model, data)?;
    // Summed equation by equation, as the cost has always been rounded.
    let sum = residuals
        .chunks(S::DIM)
        .map(|equation| equation.iter().map(|r| r.abs()).sum::<f64>())
        .sum();
    Ok(Cost::from_sum(sum, residuals.len()))
}

/// The residuals target − f of `model` on `data`, equation by equation and
/// component by component (the rows of the searches' regressions).
pub(crate) fn model_residuals<S: MetriplecticSystem>(
    model: &Model<S>,
    data: &impl IdentificationData,
) -> Result<Vec<f64>> {
    check_dataset::<S>(data)?;
    let equations = data.equations();
    let n = S::DIM;
    let mut residuals = Vec::with_capacity(equations.len() * n);
    let mut field = vec![0.0; n];
    let mut push = |target: &[f64], field: &[f64]| {
        residuals.extend(target.iter().zip(field).map(|(t, f)| t - f));
    };
    if equations.terms.is_none() {
        for e in 0..equations.len() {
            model.vector_field_unchecked(equations.state(e), &mut field);
            push(equations.target(e), &field);
        }
    } else {
        // Each sample's field once, then every equation's weighted sum.
        let mut fields = vec![0.0; equations.sample_count() * n];
        for (j, out) in fields.chunks_exact_mut(n).enumerate() {
            model.vector_field_unchecked(equations.state(j), out);
        }
        for e in 0..equations.len() {
            field.fill(0.0);
            for (j, w) in equations.terms_of(e) {
                field
                    .iter_mut()
                    .zip(&fields[j * n..(j + 1) * n])
                    .for_each(|(f, v)| *f += w * v);
            }
            push(equations.target(e), &field);
        }
    }
    Ok(residuals)
}

/// The data's scale for the relative tolerance: the mean |target| per
/// component (1 when every target is zero, so that the tolerance is then absolute).
pub(crate) fn data_scale(data: &impl IdentificationData) -> f64 {
    data.equations().scale()
}
