//! A concrete model: entropy and metric coefficients for a system.
//!
//! A [`Model`] pairs a [`MetriplecticSystem`] (the known Π and H, and the
//! bases) with coefficient vectors ψ (entropy) and θ (metric), and evaluates
//! the identified dynamics ẋ = (Π + K)(∇H + ∇S).

use std::fmt;
use std::marker::PhantomData;

mod certificate;
pub(crate) mod classical;
mod display;
mod file;
mod gram;
pub(crate) mod known_parts;
mod score;
mod shift;

pub use gram::{CertificateCheck, GramCertificate, GramMatrix};
pub use score::Score;

pub(crate) use gram::{theta_from_gram, Layout};
pub(crate) use shift::{far_centre, Shift};

pub(crate) use certificate::check_metric;
pub(crate) use display::polynomial;

/// See [`Model::MAX_COEFFICIENT`].
pub(crate) const MAX_COEFFICIENT: f64 = 1e15;

/// How far a kept Gram certificate may be from proving its metric
/// ([`Model::with_certificate`]), relative to its scale.
pub(crate) const CERTIFICATE_TOLERANCE: f64 = 1e-6;

use crate::error::{check_finite, check_len, invalid, Error, Result};
use crate::system::{with_scratch, MetriplecticSystem};

/// Entropy and metric coefficients of a system `S`.
///
/// Evaluation methods check the state's length and return
/// [`Error::DimensionMismatch`] instead of panicking; they never allocate
/// beyond their result.
pub struct Model<S: MetriplecticSystem> {
    entropy: Vec<f64>,
    metric: Vec<f64>,
    /// The Gram matrices that prove the metric's bounds, when known.
    certificate: Option<GramCertificate>,
    system: PhantomData<S>,
}

// Manual impls: `S` itself need not be `Clone`/`PartialEq` for the model to be.
impl<S: MetriplecticSystem> Clone for Model<S> {
    fn clone(&self) -> Self {
        Self {
            entropy: self.entropy.clone(),
            metric: self.metric.clone(),
            certificate: self.certificate.clone(),
            system: PhantomData,
        }
    }
}

/// Models are equal when their coefficients are: the certificate is
/// evidence about the metric, not part of it.
impl<S: MetriplecticSystem> PartialEq for Model<S> {
    fn eq(&self, other: &Self) -> bool {
        self.entropy == other.entropy && self.metric == other.metric
    }
}

impl<S: MetriplecticSystem> fmt::Debug for Model<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Model")
            .field("system", &S::NAME)
            .field("entropy", &self.entropy)
            .field("metric", &self.metric)
            .finish()
    }
}

impl<S: MetriplecticSystem> Model<S> {
    /// The largest coefficient magnitude a model accepts, 1e15: beyond it
    /// the free energy and its rate overflow `f64` at ordinary states.
    pub const MAX_COEFFICIENT: f64 = MAX_COEFFICIENT;

    /// A model from entropy coefficients ψ (`S::entropy_coefficient_count()`)
    /// and metric coefficients θ (`S::metric_coefficient_count()`).
    ///
    /// Rejects wrong lengths, non-finite values, coefficients beyond
    /// ±[`MAX_COEFFICIENT`](Self::MAX_COEFFICIENT), and — the free energy must
    /// never decrease — a metric that is not positive semidefinite for every
    /// state: [`Error::MetricNotPositive`] names the negative eigenvalue (and
    /// a state where it occurs, for a state-dependent metric). A
    /// state-dependent metric is accepted with a sum-of-squares certificate
    /// K(x) = Z(x)ᵀ Q Z(x), Q ⪰ 0, which the constructor searches for;
    /// [`Error::MetricNotCertified`] if none is found.
    ///
    /// Both checks are numerical, with tolerances at the level of the
    /// solvers' accuracy: a constant metric's smallest eigenvalue may be
    /// −1e-10 of its largest entry, and a certificate's Gram matrix may need
    /// a shift s of up to 1e-8 of the metric's largest coefficient, so that
    /// a certified metric satisfies K(x) ⪰ −s‖Z(x)‖²I (with a region, in
    /// the states scaled by its extent ρ ≥ 1, `docs/method.md` §7). Far out that bound
    /// can exceed K itself (K₀₀ = 1 − 9e-9·q² certifies and is negative
    /// beyond |q| ≈ 1.05e4), so a certified metric is also probed where a
    /// single term of uᵀK(x)u dominates (the vertices of its Newton
    /// polytope, for u = e_j and e_j ± e_k), up to |x|^degree = 1e200, and
    /// refused with [`Error::MetricNotPositive`] at a state where uᵀK(x)u
    /// is negative beyond rounding. Negativity below the tolerance between
    /// those directions is not excluded; [`simulate`](crate::simulate)
    /// checks E along every trajectory.
    ///
    /// ```
    /// # use metriplectic_runtime::prelude::*;
    /// # metriplectic! {
    /// #     pub struct Decay;
    /// #     state (x, y);
    /// #     poisson = [[0, 1], [-1, 0]];
    /// #     hamiltonian = 0.5 * x^2 + 0.5 * y^2;
    /// #     entropy degree 2;
    /// #     metric degree 0;
    /// # }
    /// // K = [[1, 2], [2, 1]] has the eigenvalue −1: E would fall along (1, −1).
    /// let err = Model::<Decay>::new(vec![0.0; 5], vec![1.0, 2.0, 1.0]).unwrap_err();
    /// assert!(matches!(err, Error::MetricNotPositive { .. }));
    /// ```
    pub fn new(entropy: Vec<f64>, metric: Vec<f64>) -> Result<Self> {
        check_entropy::<S>("entropy coefficients", &entropy)?;
        check_metric_coefficients::<S>("metric coefficients", &metric)?;
        Ok(Self {
            entropy,
            metric,
            certificate: None,
            system: PhantomData,
        })
    }

    /// The Gram matrices that prove this model's metric bounds: kept from
    /// the metric search or joint step that produced the metric, and in
    /// model files; `None` (the default) for a model built from
    /// coefficients. Re-check it with [`GramCertificate::check`].
    pub fn certificate(&self) -> Option<&GramCertificate> {
        self.certificate.as_ref()
    }

    /// The model with `certificate` kept as the proof of its metric bounds.
    ///
    /// Errors if the certificate's Gram matrices do not fit the system's
    /// certificate blocks, or do not prove this metric: a coefficient
    /// identity off by more than 1e-6 or a Gram eigenvalue below −1e-6,
    /// both relative to the certificate's scale ([`GramCertificate::check`];
    /// the searches' certificates meet them by orders of magnitude, an
    /// edited or stale one does not). The model's metric is certified
    /// independently when it is built, so the certificate is the evidence
    /// kept with it, not what makes it safe.
    pub fn with_certificate(mut self, certificate: GramCertificate) -> Result<Self> {
        let check = certificate.check::<S>(&self.metric)?;
        if !check.holds(CERTIFICATE_TOLERANCE) {
            return Err(invalid(
                "Gram certificate",
                format!(
                    "it does not prove this metric: its coefficient identities are off by \
                     {:.1e} and its smallest Gram eigenvalue is {:.1e}, relative to its scale \
                     (accepted: within ±{CERTIFICATE_TOLERANCE:e}); in a model file, remove the \
                     `certificate` field to load the model without it",
                    check.identity_residual, check.smallest_eigenvalue
                ),
            ));
        }
        self.certificate = Some(certificate);
        Ok(self)
    }

    /// The model with `certificate` kept if it proves the metric
    /// ([`with_certificate`](Self::with_certificate)), else without one: a
    /// search's certificate is as accurate as its solve.
    pub(crate) fn with_certificate_if_it_holds(self, certificate: GramCertificate) -> Self {
        let check = certificate.check::<S>(&self.metric);
        if check.is_ok_and(|c| c.holds(CERTIFICATE_TOLERANCE)) {
            Self {
                certificate: Some(certificate),
                ..self
            }
        } else {
            self
        }
    }

    /// The reference model declared in the system's `reference { … }` section.
    pub fn reference() -> Result<Self> {
        match (S::REFERENCE_ENTROPY, S::REFERENCE_METRIC) {
            (Some(entropy), Some(metric)) => Self::new(entropy.to_vec(), metric.to_vec()),
            _ => Err(Error::NoReference { system: S::NAME }),
        }
    }

    /// The identity metric K = I with the given entropy coefficients.
    pub fn with_identity_metric(entropy: Vec<f64>) -> Result<Self> {
        Self::new(entropy, identity_metric::<S>(1.0))
    }

    /// Entropy coefficients ψ, in the order of `S::ENTROPY_EXPONENTS`.
    pub fn entropy_coefficients(&self) -> &[f64] {
        &self.entropy
    }

    /// Metric coefficients θ, laid out as documented on [`MetriplecticSystem`].
    pub fn metric_coefficients(&self) -> &[f64] {
        &self.metric
    }

    /// Replaces the entropy coefficients (same checks as [`Model::new`]).
    pub fn set_entropy_coefficients(&mut self, entropy: Vec<f64>) -> Result<()> {
        check_entropy::<S>("entropy coefficients", &entropy)?;
        self.entropy = entropy;
        Ok(())
    }

    /// Replaces the metric coefficients (same checks as [`Model::new`]); on
    /// error the model is unchanged.
    pub fn set_metric_coefficients(&mut self, metric: Vec<f64>) -> Result<()> {
        check_metric_coefficients::<S>("metric coefficients", &metric)?;
        self.metric = metric;
        self.certificate = None;
        Ok(())
    }

    /// Entropy S(x). Errors on a state of the wrong length, a non-finite
    /// state, or a value that overflows.
    pub fn entropy(&self, x: &[f64]) -> Result<f64> {
        check_state::<S>(x)?;
        finite_value("entropy", x, S::entropy_value(x, &self.entropy))
    }

    /// Free energy E(x) = H(x) + S(x) (errors as for [`entropy`](Self::entropy)).
    pub fn free_energy(&self, x: &[f64]) -> Result<f64> {
        check_state::<S>(x)?;
        finite_value(
            "free energy",
            x,
            S::hamiltonian(x) + S::entropy_value(x, &self.entropy),
        )
    }

    /// ∇E(x) = ∇H(x) + ∇S(x) into `grad` (length n).
    pub fn free_energy_gradient(&self, x: &[f64], grad: &mut [f64]) -> Result<()> {
        check_state::<S>(x)?;
        check_len("gradient output", grad, S::DIM)?;
        self.free_energy_gradient_unchecked(x, grad);
        finite_values("free-energy gradient", x, grad)
    }

    /// K(x) into `metric` (n × n, row-major).
    pub fn metric(&self, x: &[f64], metric: &mut [f64]) -> Result<()> {
        check_state::<S>(x)?;
        check_len("metric output", metric, S::DIM * S::DIM)?;
        S::metric_value(x, &self.metric, metric);
        finite_values("metric", x, metric)
    }

    /// The vector field f(x) = (Π(x) + K(x)) ∇E(x) into `xdot` (length n).
    pub fn vector_field(&self, x: &[f64], xdot: &mut [f64]) -> Result<()> {
        check_state::<S>(x)?;
        check_len("vector field output", xdot, S::DIM)?;
        self.vector_field_unchecked(x, xdot);
        finite_values("vector field", x, xdot)
    }

    /// dE/dt = ∇Eᵀ K ∇E at x: non-negative, since K(x) ⪰ 0.
    pub fn free_energy_rate(&self, x: &[f64]) -> Result<f64> {
        check_state::<S>(x)?;
        let n = S::DIM;
        let rate = with_scratch(n + n * n, |scratch| {
            let (grad, metric) = scratch.split_at_mut(n);
            self.free_energy_gradient_unchecked(x, grad);
            S::metric_value(x, &self.metric, metric);
            quadratic_form(metric, grad)
        });
        finite_value("free-energy rate", x, rate)
    }

    /// ∇E without length checks: callers have checked `x` and `grad`.
    pub(crate) fn free_energy_gradient_unchecked(&self, x: &[f64], grad: &mut [f64]) {
        S::entropy_gradient(x, &self.entropy, grad);
        with_scratch(S::DIM, |grad_h| {
            S::hamiltonian_gradient(x, grad_h);
            grad.iter_mut().zip(&*grad_h).for_each(|(g, h)| *g += h);
        });
    }

    /// f(x) without length checks: callers have checked `x` and `xdot`.
    pub(crate) fn vector_field_unchecked(&self, x: &[f64], xdot: &mut [f64]) {
        let n = S::DIM;
        with_scratch(n + 2 * n * n, |scratch| {
            let (grad, matrices) = scratch.split_at_mut(n);
            let (operator, metric) = matrices.split_at_mut(n * n);
            self.free_energy_gradient_unchecked(x, grad);
            S::poisson(x, operator);
            S::metric_value(x, &self.metric, metric);
            operator.iter_mut().zip(&*metric).for_each(|(m, k)| *m += k);
            for (j, out) in xdot.iter_mut().enumerate() {
                *out = operator[j * n..(j + 1) * n]
                    .iter()
                    .zip(&*grad)
                    .map(|(m, g)| m * g)
                    .sum();
            }
        });
    }
}

/// θ of the constant metric K = c·I for system `S`.
pub(crate) fn identity_metric<S: MetriplecticSystem>(scale: f64) -> Vec<f64> {
    let n = S::DIM;
    let basis = S::METRIC_EXPONENTS.len();
    let mut theta = vec![0.0; S::metric_coefficient_count()];
    for j in 0..n {
        // The metric basis starts with the constant monomial.
        theta[crate::system::metric_pair_index(n, j, j) * basis] = scale;
    }
    theta
}

/// vᵀ A v for a row-major square `a`.
pub(crate) fn quadratic_form(a: &[f64], v: &[f64]) -> f64 {
    let n = v.len();
    (0..n)
        .map(|j| v[j] * (0..n).map(|k| a[j * n + k] * v[k]).sum::<f64>())
        .sum()
}

/// Length, finiteness and magnitude of entropy coefficients.
pub(crate) fn check_entropy<S: MetriplecticSystem>(what: &str, entropy: &[f64]) -> Result<()> {
    check_len(what, entropy, S::entropy_coefficient_count())?;
    check_magnitude::<S>(what, entropy)?;
    classical::check_entropy::<S>(what, entropy)
}

/// Length, finiteness and magnitude of metric coefficients, and K(x) ⪰ 0.
pub(crate) fn check_metric_coefficients<S: MetriplecticSystem>(
    what: &str,
    metric: &[f64],
) -> Result<()> {
    check_len(what, metric, S::metric_coefficient_count())?;
    check_magnitude::<S>(what, metric)?;
    classical::check_metric::<S>(what, metric)?;
    check_metric::<S>(what, metric)
}

fn check_magnitude<S: MetriplecticSystem>(what: &str, values: &[f64]) -> Result<()> {
    check_finite(what, values)?;
    let limit = Model::<S>::MAX_COEFFICIENT;
    match values.iter().position(|v| v.abs() > limit) {
        None => Ok(()),
        Some(index) => Err(crate::error::invalid(
            what,
            format!(
                "coefficient {index} is {:e}, beyond ±{limit:e}: the free energy and its rate \
                 would overflow",
                values[index]
            ),
        )),
    }
}

/// `value` unless it overflowed.
fn finite_value(what: &str, x: &[f64], value: f64) -> Result<f64> {
    finite_values(what, x, std::slice::from_ref(&value)).map(|()| value)
}

/// Ok unless an entry of `values`, computed at state `x`, overflowed.
fn finite_values(what: &str, x: &[f64], values: &[f64]) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(index) => Err(Error::NonFinite {
            what: format!("{what} at x = {x:?} (overflow)"),
            index,
            value: values[index],
        }),
    }
}

fn check_state<S: MetriplecticSystem>(x: &[f64]) -> Result<()> {
    check_len("state", x, S::DIM)?;
    check_finite("state", x)
}
