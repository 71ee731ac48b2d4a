//! The sum-of-squares certificate of the metric as conic constraints,
//! shared by the metric search and the joint step.
//!
//! With Z(x) = I ⊗ m(x) over the SOS basis m, the constraints are
//!
//! ```text
//! θⱼₖ,α                  = Σ_{(β,γ) ∈ matching[α]} Q₁[(j,β),(k,γ)],   Q₁ ⪰ 0,
//! η·[j=k]·[α=0] − θⱼₖ,α  = Σ_{(β,γ) ∈ matching[α]} Q₂[(j,β),(k,γ)],   Q₂ ⪰ 0,
//! ```
//!
//! so that K(x) = Z(x)ᵀ Q₁ Z(x) ⪰ 0 and ηI − K(x) = Z(x)ᵀ Q₂ Z(x) ⪰ 0.

use serde::{Deserialize, Serialize};

use crate::error::{invalid, Result};
use crate::solve::svec::{svec_index, svec_len, unsvec, SQRT_2};
use crate::solve::{Cone, ConstraintId, L1Problem, L1Solution};
use crate::system::{metric_pair_index, MetriplecticSystem, SosTables};

/// Which SOS coefficient-matching tables the metric search uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[non_exhaustive]
pub enum SosBasis {
    /// [`MetriplecticSystem::SOS_REDUCED`] (the default): facially reduced,
    /// strictly feasible.
    #[default]
    Reduced,
    /// [`MetriplecticSystem::SOS_FULL`]: the full half-degree basis. The
    /// two-sided program then has no strictly feasible point.
    Full,
}

impl SosBasis {
    /// The tables of system `S` this choice selects.
    pub fn tables<S: MetriplecticSystem>(self) -> SosTables {
        match self {
            Self::Reduced => S::SOS_REDUCED,
            Self::Full => S::SOS_FULL,
        }
    }
}

/// The certificate's constraint blocks in an [`L1Problem`].
pub(crate) struct SosConstraints {
    /// Side N = n·|m| of the Gram matrices.
    pub gram_size: usize,
    /// Q₁ (K = Zᵀ Q₁ Z) and Q₂ (ηI − K = Zᵀ Q₂ Z) as PSD blocks.
    lower: ConstraintId,
    upper: ConstraintId,
}

impl SosConstraints {
    /// Number of extra variables the Gram matrices take: svec Q₁ and svec Q₂.
    pub fn variables(gram_size: usize) -> usize {
        2 * svec_len(gram_size)
    }

    /// Q₁ (row-major) from its cone slack, which lies in the PSD cone, so
    /// that K = Zᵀ Q₁ Z ⪰ 0 holds up to rounding whatever the solver's
    /// feasibility tolerance.
    pub fn gram(&self, solution: &L1Solution) -> Vec<f64> {
        unsvec(self.gram_size, solution.slack(self.lower))
    }

    /// Q₂ (row-major), certifying ηI − K ⪰ 0.
    pub fn gram_upper(&self, solution: &L1Solution) -> Vec<f64> {
        unsvec(self.gram_size, solution.slack(self.upper))
    }
}

/// Errors unless the tables fit the system's metric basis.
pub(crate) fn check_tables<S: MetriplecticSystem>(tables: &SosTables) -> Result<()> {
    let what = format!("SOS tables of system `{}`", S::NAME);
    if tables.matching.len() != S::METRIC_EXPONENTS.len() {
        return Err(invalid(
            &what,
            format!(
                "{} matching lists for {} metric monomials",
                tables.matching.len(),
                S::METRIC_EXPONENTS.len()
            ),
        ));
    }
    let m = tables.exponents.len();
    if let Some(&(beta, gamma)) = tables
        .matching
        .iter()
        .flat_map(|pairs| pairs.iter())
        .find(|&&(b, g)| b as usize >= m || g as usize >= m)
    {
        return Err(invalid(
            &what,
            format!("pair ({beta}, {gamma}) indexes past the {m} SOS basis monomials"),
        ));
    }
    if constant_monomial::<S>().is_none() {
        return Err(invalid(&what, "the metric basis has no constant monomial"));
    }
    Ok(())
}

fn constant_monomial<S: MetriplecticSystem>() -> Option<usize> {
    S::METRIC_EXPONENTS
        .iter()
        .position(|e| e.iter().all(|&d| d == 0))
}

/// Adds the matching equalities and the two PSD cones to `problem`, with θ
/// in the variables from `theta_column` and `[svec Q₁ | svec Q₂]` from
/// `gram_column`.
pub(crate) fn add_sos_constraints<S: MetriplecticSystem>(
    problem: &mut L1Problem,
    tables: &SosTables,
    eta: f64,
    theta_column: usize,
    gram_column: usize,
) -> Result<SosConstraints> {
    let n = S::DIM;
    let basis = S::METRIC_EXPONENTS.len();
    let m = tables.exponents.len();
    let size = n * m;
    let theta_len = S::metric_coefficient_count();
    let svec_size = svec_len(size);
    let q1 = gram_column;
    let q2 = gram_column + svec_size;
    let constant = constant_monomial::<S>().unwrap_or(0);

    // Rows 2t: θ_t − Σ Q₁ = 0 ; rows 2t+1: θ_t + Σ Q₂ = η[j=k][α=0].
    let mut entries = Vec::new();
    let mut rhs = vec![0.0; 2 * theta_len];
    for j in 0..n {
        for k in j..n {
            let pair = metric_pair_index(n, j, k);
            for (alpha, pairs) in tables.matching.iter().enumerate() {
                let t = pair * basis + alpha;
                entries.push((2 * t, theta_column + t, 1.0));
                entries.push((2 * t + 1, theta_column + t, 1.0));
                for &(beta, gamma) in pairs.iter() {
                    let a = j * m + beta as usize;
                    let b = k * m + gamma as usize;
                    // svec stores √2·Q_ab off the diagonal.
                    let weight = if a == b { 1.0 } else { 1.0 / SQRT_2 };
                    let index = svec_index(a, b);
                    entries.push((2 * t, q1 + index, -weight));
                    entries.push((2 * t + 1, q2 + index, weight));
                }
                if j == k && alpha == constant {
                    rhs[2 * t + 1] = eta;
                }
            }
        }
    }
    problem.constrain(Cone::Zero(2 * theta_len), entries, rhs)?;
    let mut psd = |offset: usize| {
        problem.constrain(
            Cone::Psd(size),
            (0..svec_size).map(|i| (i, offset + i, -1.0)).collect(),
            vec![0.0; svec_size],
        )
    };
    let lower = psd(q1)?;
    let upper = psd(q2)?;
    Ok(SosConstraints {
        gram_size: size,
        lower,
        upper,
    })
}

/// θⱼₖ,α = Σ_{(β,γ) ∈ matching[α]} Q[(j,β),(k,γ)] for a row-major Gram matrix Q.
pub(crate) fn theta_from_gram<S: MetriplecticSystem>(tables: &SosTables, gram: &[f64]) -> Vec<f64> {
    let n = S::DIM;
    let basis = S::METRIC_EXPONENTS.len();
    let m = tables.exponents.len();
    let size = n * m;
    let mut theta = vec![0.0; S::metric_coefficient_count()];
    for j in 0..n {
        for k in j..n {
            let pair = metric_pair_index(n, j, k);
            for (alpha, pairs) in tables.matching.iter().enumerate() {
                theta[pair * basis + alpha] = pairs
                    .iter()
                    .map(|&(beta, gamma)| {
                        gram[(j * m + beta as usize) * size + k * m + gamma as usize]
                    })
                    .sum();
            }
        }
    }
    theta
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_system::Quadratic2d;

    #[test]
    fn theta_from_gram_matches_the_sos_form() {
        // K(x) = Z(x)ᵀ Q Z(x) for a random symmetric Q over the full basis.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let size = 6;
        let mut q = vec![0.0; size * size];
        for a in 0..size {
            for b in a..size {
                let v: f64 = rng.random_range(-1.0..1.0);
                q[a * size + b] = v;
                q[b * size + a] = v;
            }
        }
        let tables = Quadratic2d::SOS_FULL;
        let theta = theta_from_gram::<Quadratic2d>(&tables, &q);
        let x = [0.7, -1.3];
        let z = [1.0, x[0], x[1]];
        let mut k = [0.0; 4];
        Quadratic2d::metric_value(&x, &theta, &mut k);
        for j in 0..2 {
            for l in 0..2 {
                let direct: f64 = (0..3)
                    .flat_map(|b| (0..3).map(move |g| (b, g)))
                    .map(|(b, g)| z[b] * q[(j * 3 + b) * size + l * 3 + g] * z[g])
                    .sum();
                assert!((direct - k[j * 2 + l]).abs() < 1e-12);
            }
        }
    }
}
