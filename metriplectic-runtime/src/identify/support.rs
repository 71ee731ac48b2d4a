//! Restrictions on the coefficients a search may use: a support (which
//! coefficients are held at zero, for degree caps and sparse refits) and a
//! gauge (a normalisation that removes an exact symmetry of the fit).
//!
//! Both enter the convex programs as they are, so every restricted search
//! still returns a model with its free-energy certificate: dropped entropy
//! coefficients are columns left out of the regression, dropped metric
//! coefficients and the gauge are equality rows beside the SOS matching.

use serde::{Deserialize, Serialize};

use crate::error::{invalid, Num, Result};
use crate::identify::search::{certificate_free_metric, SosBasis};
use crate::system::{metric_pair_index, MetriplecticSystem};

/// Which coefficients the searches may use; the others are held at zero.
///
/// The default, [`Support::full`], uses every coefficient. The bases are
/// ordered by degree, so [`Support::degree_caps`] gives a lower-degree model
/// without recompiling the system.
///
/// ```
/// use metriplectic_runtime::prelude::*;
/// use metriplectic_runtime::Support;
/// # metriplectic! {
/// #     pub struct Decay;
/// #     state (x, y);
/// #     poisson = [[0, 1], [-1, 0]];
/// #     hamiltonian = 0.5 * x^2 + 0.5 * y^2;
/// #     entropy degree 4;
/// #     metric degree 0;
/// # }
/// // Entropy up to degree 2 of the declared 4: x, y, x², xy, y².
/// let support = Support::degree_caps::<Decay>(2, 0)?;
/// assert_eq!(support.free_entropy::<Decay>(), vec![0, 1, 2, 3, 4]);
/// # Ok::<(), metriplectic_runtime::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(from = "SupportFields")]
pub struct Support {
    /// Entropy coefficients held at zero (indices into
    /// `ENTROPY_EXPONENTS`), sorted. Default empty.
    entropy_zero: Vec<usize>,
    /// Metric coefficients held at zero (indices into θ), sorted. Default empty.
    metric_zero: Vec<usize>,
}

/// A support as written in a file: the lists may come unsorted or with
/// repeats, and the searches look indices up by binary search.
#[derive(Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
struct SupportFields {
    entropy_zero: Vec<usize>,
    metric_zero: Vec<usize>,
}

impl From<SupportFields> for Support {
    fn from(fields: SupportFields) -> Self {
        Self::full().with_zeros(&fields.entropy_zero, &fields.metric_zero)
    }
}

impl Support {
    /// Every coefficient free (the default).
    pub fn full() -> Self {
        Self::default()
    }

    /// The entropy and metric bases cut at degrees `entropy` and `metric`:
    /// coefficients of monomials of higher degree are held at zero.
    ///
    /// Errors unless 1 ≤ `entropy` ≤ the declared entropy degree and
    /// `metric` is even and ≤ the declared metric degree.
    pub fn degree_caps<S: MetriplecticSystem>(entropy: u32, metric: u32) -> Result<Self> {
        if entropy == 0 || entropy > S::ENTROPY_DEGREE {
            return Err(invalid(
                "entropy degree cap",
                format!(
                    "{entropy} is not between 1 and the declared entropy degree {} of `{}`",
                    S::ENTROPY_DEGREE,
                    S::NAME
                ),
            ));
        }
        if metric > S::METRIC_DEGREE {
            return Err(invalid(
                "metric degree cap",
                format!(
                    "{metric} exceeds the declared metric degree {} of `{}`",
                    S::METRIC_DEGREE,
                    S::NAME
                ),
            ));
        }
        // As in the declaration: a cap of odd degree is the even one below
        // it under another name.
        if metric % 2 == 1 {
            return Err(invalid(
                "metric degree cap",
                format!(
                    "{metric} is odd, but a metric's degree is even (K ⪰ 0 needs an even top \
                     degree); use {} or {}",
                    metric - 1,
                    metric + 1
                ),
            ));
        }
        let degree = |exponents: &[u32]| exponents.iter().sum::<u32>();
        let entropy_zero = S::ENTROPY_EXPONENTS
            .iter()
            .enumerate()
            .filter(|(_, e)| degree(e) > entropy)
            .map(|(k, _)| k)
            .collect();
        let basis = S::METRIC_EXPONENTS.len();
        let high: Vec<usize> = S::METRIC_EXPONENTS
            .iter()
            .enumerate()
            .filter(|(_, e)| degree(e) > metric)
            .map(|(a, _)| a)
            .collect();
        let metric_zero = (0..S::DIM * (S::DIM + 1) / 2)
            .flat_map(|pair| high.iter().map(move |a| pair * basis + a))
            .collect();
        Ok(Self {
            entropy_zero,
            metric_zero,
        })
    }

    /// The support with the given entropy and metric coefficients held at
    /// zero as well (indices are checked when a search validates it).
    pub fn with_zeros(mut self, entropy: &[usize], metric: &[usize]) -> Self {
        self.entropy_zero.extend_from_slice(entropy);
        self.entropy_zero.sort_unstable();
        self.entropy_zero.dedup();
        self.metric_zero.extend_from_slice(metric);
        self.metric_zero.sort_unstable();
        self.metric_zero.dedup();
        self
    }

    /// Whether every coefficient is free.
    pub fn is_full(&self) -> bool {
        self.entropy_zero.is_empty() && self.metric_zero.is_empty()
    }

    /// Entropy coefficients held at zero, sorted.
    pub fn entropy_zeros(&self) -> &[usize] {
        &self.entropy_zero
    }

    /// Metric coefficients held at zero, sorted.
    pub fn metric_zeros(&self) -> &[usize] {
        &self.metric_zero
    }

    /// The free entropy coefficients of `S`, in order.
    pub fn free_entropy<S: MetriplecticSystem>(&self) -> Vec<usize> {
        (0..S::entropy_coefficient_count())
            .filter(|k| self.entropy_zero.binary_search(k).is_err())
            .collect()
    }

    /// The metric coefficients of `S` left free: those the certificate of
    /// the `sos` tables leaves free, less those held at zero.
    pub(crate) fn free_metric<S: MetriplecticSystem>(&self, sos: SosBasis) -> Vec<usize> {
        certificate_free_metric::<S>(sos)
            .into_iter()
            .filter(|t| self.metric_zero.binary_search(t).is_err())
            .collect()
    }

    /// Errors unless every index names a coefficient of `S` and at least
    /// one entropy coefficient stays free.
    pub fn validate<S: MetriplecticSystem>(&self) -> Result<()> {
        let p = S::entropy_coefficient_count();
        if let Some(&bad) = self.entropy_zero.iter().find(|&&k| k >= p) {
            return Err(invalid(
                "support",
                format!(
                    "entropy coefficient {bad} does not exist: `{}` has {p}",
                    S::NAME
                ),
            ));
        }
        let t = S::metric_coefficient_count();
        if let Some(&bad) = self.metric_zero.iter().find(|&&k| k >= t) {
            return Err(invalid(
                "support",
                format!(
                    "metric coefficient {bad} does not exist: `{}` has {t}",
                    S::NAME
                ),
            ));
        }
        if self.entropy_zero.len() == p {
            return Err(invalid(
                "support",
                "it holds every entropy coefficient at zero",
            ));
        }
        Ok(())
    }

    /// Sets the metric coefficients the support holds at zero to exactly
    /// zero: a search meets those equalities only to its solver's
    /// tolerance (a probe's came back as 2.9e-12).
    pub(crate) fn zero_held_metric(&self, metric: &mut [f64]) {
        for &k in &self.metric_zero {
            if let Some(value) = metric.get_mut(k) {
                *value = 0.0;
            }
        }
    }

    /// Errors if `entropy` or `metric` has a non-zero coefficient the
    /// support holds at zero (`what` names the model).
    pub fn check_model(&self, what: &str, entropy: &[f64], metric: &[f64]) -> Result<()> {
        for (zeros, values, block) in [
            (&self.entropy_zero, entropy, "entropy"),
            (&self.metric_zero, metric, "metric"),
        ] {
            if let Some(&k) = zeros
                .iter()
                .find(|&&k| values.get(k).is_some_and(|v| *v != 0.0))
            {
                return Err(invalid(
                    what,
                    format!(
                        "{block} coefficient {k} is {:e}, but the support holds it at zero",
                        values[k]
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// A normalisation of the metric, for fits with an exact symmetry.
///
/// When Π∇E = 0 on the data (the paper's SO(3) body), (cK, E/c) fits
/// exactly as well as (K, E) for every c > 0: the data fix K only up to
/// scale. A gauge picks one member of the family, so that runs from
/// different starts or data return comparable coefficients.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum Gauge {
    /// tr K(0) = Σⱼ θⱼⱼ,₀ equals the value (e.g. the state dimension n,
    /// the trace of the identity). For a constant metric this is tr K.
    MetricTrace(f64),
}

impl Gauge {
    /// The gauge's linear form on θ, as (index, weight) pairs, and its value.
    pub(crate) fn row<S: MetriplecticSystem>(self) -> (Vec<(usize, f64)>, f64) {
        match self {
            Self::MetricTrace(value) => {
                let basis = S::METRIC_EXPONENTS.len();
                let entries = (0..S::DIM)
                    .map(|j| (metric_pair_index(S::DIM, j, j) * basis, 1.0))
                    .collect();
                (entries, value)
            }
        }
    }

    /// The gauge's value at metric coefficients `theta`.
    pub(crate) fn value_at<S: MetriplecticSystem>(self, theta: &[f64]) -> f64 {
        self.row::<S>().0.iter().map(|&(t, w)| w * theta[t]).sum()
    }

    /// Errors unless metric coefficients `theta` meet the gauge to 1e-6 of
    /// its value (searches hold it to the solver's tolerance); `what`
    /// names them in the error.
    pub(crate) fn check_model<S: MetriplecticSystem>(
        self,
        what: &str,
        theta: &[f64],
    ) -> Result<()> {
        let (value, wanted) = (self.value_at::<S>(theta), self.row::<S>().1);
        if (value - wanted).abs() > 1e-6 * wanted {
            return Err(invalid(
                what,
                format!(
                    "the gauge fixes tr K(0) = {}, they give {}",
                    Num(wanted),
                    Num(value)
                ),
            ));
        }
        Ok(())
    }

    /// Errors unless the value is finite and positive (a metric with
    /// tr K(0) ≤ 0 is zero at the origin).
    pub fn validate(self) -> Result<()> {
        match self {
            Self::MetricTrace(value) if value.is_finite() && value > 0.0 => Ok(()),
            Self::MetricTrace(value) => Err(invalid(
                "gauge",
                format!(
                    "metric trace {} is not a finite positive number",
                    Num(value)
                ),
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_system::Quadratic2d;

    #[test]
    fn a_support_read_from_a_file_is_sorted_and_without_repeats() {
        let read: Support =
            serde_json::from_str(r#"{"entropy_zero": [4, 2, 4], "metric_zero": [1, 0]}"#).unwrap();
        assert_eq!(read.entropy_zeros(), &[2, 4]);
        assert_eq!(read.metric_zeros(), &[0, 1]);
        // Unsorted, coefficient 4 would have been missed by the binary
        // search and fitted although the file holds it at zero.
        assert_eq!(read.free_entropy::<Quadratic2d>(), vec![0, 1, 3]);
        assert_eq!(read, Support::full().with_zeros(&[2, 4], &[0, 1]));
        let round_trip: Support =
            serde_json::from_str(&serde_json::to_string(&read).unwrap()).unwrap();
        assert_eq!(round_trip, read);
        let empty: Support = serde_json::from_str("{}").unwrap();
        assert!(empty.is_full());
    }
}
