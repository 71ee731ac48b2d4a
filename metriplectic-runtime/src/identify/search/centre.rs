//! The searches' rows in coordinates centred on the data or the region
//! (see [`Shift`]): the entropy's coefficients in y = x − c whenever the
//! data lie farther from the origin than their spread, the metric's when
//! the system's region does (its certificate is then set up in y too,
//! [`Layout`](crate::model::Layout)). Π, K and H are evaluated at x; only
//! the unknown bases are read at y.

use crate::data::IdentificationData;
use crate::error::Result;
use crate::model::{far_centre, Shift};
use crate::solve::Regression;
use crate::system::{metric_rows, MetriplecticSystem};

use super::check_sample_rows;

/// The entropy's centred coordinates on `data`, or `None` where they are
/// not needed or do not apply: every state variable's data reach within
/// their own spread of zero (where the monomials are as good as centred
/// ones), or only the coefficients `free` are searched (a support is
/// declared on the coefficients in x, which y would mix).
pub(crate) fn entropy_shift<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    free: &[usize],
) -> Option<Shift> {
    if free.len() < S::entropy_coefficient_count() {
        return None;
    }
    let states = data.equations().states;
    let n = S::DIM;
    if n == 0 || states.is_empty() {
        return None;
    }
    let mut low = vec![f64::INFINITY; n];
    let mut high = vec![f64::NEG_INFINITY; n];
    for x in states.chunks_exact(n) {
        for ((l, h), &v) in low.iter_mut().zip(high.iter_mut()).zip(x) {
            *l = l.min(v);
            *h = h.max(v);
        }
    }
    Shift::new(S::ENTROPY_EXPONENTS, far_centre(&low, &high)?)
}

/// The entropy search's rows M J_y(x)ᵀ and targets ẋ − M ∇H(x) of every
/// sample: J_y is the Jacobian of the monomials of y = x − c, that of the
/// monomials at the point y.
pub(crate) fn centred_entropy_regression<S: MetriplecticSystem>(
    shift: &Shift,
    data: &impl IdentificationData,
    metric: &[f64],
) -> Result<Regression> {
    let n = S::DIM;
    let p = S::entropy_coefficient_count();
    let (rows, target) = data.equations().assemble(
        p,
        || Scratch::new(n, p * n),
        |s, j, x, block, drift| {
            S::poisson(x, &mut s.operator);
            S::metric_value(x, metric, &mut s.matrix);
            s.operator
                .iter_mut()
                .zip(&s.matrix)
                .for_each(|(o, k)| *o += k);
            S::hamiltonian_gradient(x, &mut s.gradient);
            shift.centred_state(x, &mut s.y);
            S::entropy_jacobian(&s.y, &mut s.basis);
            for row in 0..n {
                let operator = &s.operator[row * n..(row + 1) * n];
                drift[row] = dot(operator, &s.gradient);
                for (k, out) in block[row * p..(row + 1) * p].iter_mut().enumerate() {
                    *out = dot(operator, &s.basis[k * n..(k + 1) * n]);
                }
            }
            check_sample_rows(j, x, block, drift)
        },
    )?;
    Ok(Regression {
        width: p,
        rows,
        target,
    })
}

/// The metric search's rows of θ_y ↦ K(y; θ_y) g and targets ẋ − Π g of
/// every sample, g = ∇H(x) + ∇S(x), the metric monomials read at y = x − c.
pub(crate) fn centred_metric_regression<S: MetriplecticSystem>(
    shift: &Shift,
    data: &impl IdentificationData,
    entropy: &[f64],
) -> Result<Regression> {
    let n = S::DIM;
    let m = S::METRIC_EXPONENTS.len();
    let width = S::metric_coefficient_count();
    let (rows, target) = data.equations().assemble(
        width,
        || Scratch::new(n, m),
        |s, j, x, block, drift| {
            S::entropy_gradient(x, entropy, &mut s.gradient);
            S::hamiltonian_gradient(x, &mut s.y);
            s.gradient.iter_mut().zip(&s.y).for_each(|(g, h)| *g += h);
            S::poisson(x, &mut s.operator);
            for (row, out) in drift.iter_mut().enumerate() {
                *out = dot(&s.operator[row * n..(row + 1) * n], &s.gradient);
            }
            shift.centred_state(x, &mut s.y);
            S::monomials(&s.y, &mut s.basis);
            metric_rows(&s.basis, &s.gradient, block);
            check_sample_rows(j, x, block, drift)
        },
    )?;
    Ok(Regression {
        width,
        rows,
        target,
    })
}

/// Per-worker buffers of the centred regressions.
struct Scratch {
    operator: Vec<f64>,
    matrix: Vec<f64>,
    gradient: Vec<f64>,
    y: Vec<f64>,
    /// The basis at y: the entropy's Jacobian or the metric's monomials.
    basis: Vec<f64>,
}

impl Scratch {
    fn new(n: usize, basis: usize) -> Self {
        Self {
            operator: vec![0.0; n * n],
            matrix: vec![0.0; n * n],
            gradient: vec![0.0; n],
            y: vec![0.0; n],
            basis: vec![0.0; basis],
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::search::{entropy_regression, metric_regression};
    use crate::test_system::{reference_data, Quadratic2d};

    /// The centred rows times the centred coefficients give the rows in x
    /// times the coefficients in x.
    #[test]
    fn centred_rows_fit_the_same_field() {
        let data = reference_data(20, 3);
        let shift = |exponents| Shift::new(exponents, vec![1.5, -0.5]).unwrap();
        let theta = Quadratic2d::REFERENCE_METRIC.unwrap();
        let psi = Quadratic2d::REFERENCE_ENTROPY.unwrap();
        let pairs = [
            (
                entropy_regression::<Quadratic2d>(&data, theta).unwrap(),
                centred_entropy_regression::<Quadratic2d>(
                    &shift(Quadratic2d::ENTROPY_EXPONENTS),
                    &data,
                    theta,
                )
                .unwrap(),
                psi.to_vec(),
                shift(Quadratic2d::ENTROPY_EXPONENTS).to_centred(psi),
            ),
            (
                metric_regression::<Quadratic2d>(&data, psi).unwrap(),
                centred_metric_regression::<Quadratic2d>(
                    &shift(Quadratic2d::METRIC_EXPONENTS),
                    &data,
                    psi,
                )
                .unwrap(),
                theta.to_vec(),
                shift(Quadratic2d::METRIC_EXPONENTS).to_centred(theta),
            ),
        ];
        for (plain, centred, x, y) in pairs {
            for (u, v) in plain.target.iter().zip(&centred.target) {
                assert!((u - v).abs() <= 1e-12 * (1.0 + u.abs()), "{u} vs {v}");
            }
            for (a, b) in plain
                .rows
                .chunks_exact(plain.width)
                .zip(centred.rows.chunks_exact(centred.width))
            {
                let (u, v): (f64, f64) = (
                    a.iter().zip(&x).map(|(r, c)| r * c).sum(),
                    b.iter().zip(&y).map(|(r, c)| r * c).sum(),
                );
                assert!((u - v).abs() <= 1e-12 * (1.0 + u.abs()), "{u} vs {v}");
            }
        }
    }
}
