//! Derivative estimation for trajectories measured without ẋ.
//!
//! Two families, both working on the actual (possibly non-uniform) time
//! stamps of each trajectory:
//!
//! * [`DerivativeMethod::FiniteDifference`] of order p ∈ {2, 4, 6}: the
//!   derivative of the interpolating polynomial through p + 1 neighbouring
//!   samples (weights by Fornberg's algorithm). In the interior the stencil
//!   is centred (p/2 samples on each side); near the ends it slides inwards and
//!   becomes one-sided, keeping p + 1 points and so the same order p. The
//!   error is O(hᵖ) for smooth data, but noise of size σ is amplified to
//!   roughly σ/h: use it for clean data.
//! * [`DerivativeMethod::SavitzkyGolay`]: a local least-squares polynomial of
//!   degree d over a window of w samples (odd w > d), differentiated at the
//!   sample — the Savitzky–Golay differentiator generalised to non-uniform
//!   times. Near the ends the window slides inwards (asymmetric window of the
//!   same size) instead of padding the data. Averaging over the window
//!   reduces noise at the cost of a bias O(h^d) (d odd: O(h^(d+1)) in the
//!   interior of uniform grids).
//!
//! Existing crates did not fit: `sci-rs`'s `savgol_filter_dyn` pads the ends
//! with the nearest value (biased derivatives at both ends), assumes uniform
//! sampling and panics on bad arguments; `savgol-rs` 0.1 assumes uniform
//! sampling and pins an older nalgebra. The fit here uses nalgebra's SVD.

use nalgebra::DMatrix;

use super::Trajectory;
use crate::error::{invalid, Error, Result};

/// How to estimate ẋ from sampled states.
///
/// ```
/// use metriplectic_runtime::{differentiate, DerivativeMethod};
///
/// let t: Vec<f64> = (0..50).map(|k| 0.02 * k as f64).collect();
/// let x: Vec<f64> = t.iter().map(|t| t.sin()).collect();
/// let dx = differentiate(&t, &x, &DerivativeMethod::FiniteDifference { order: 4 }).unwrap();
/// assert!(dx.iter().zip(&t).all(|(d, t)| (d - t.cos()).abs() < 1e-6));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DerivativeMethod {
    /// Finite differences of order 2, 4 or 6 (needs at least order + 1 samples).
    FiniteDifference {
        /// Order of accuracy p.
        order: usize,
    },
    /// Local least-squares polynomial (Savitzky–Golay) differentiator.
    SavitzkyGolay {
        /// Samples per window w: odd, > `degree`, at most the trajectory length.
        window: usize,
        /// Polynomial degree d ≥ 1.
        degree: usize,
    },
}

impl DerivativeMethod {
    /// Checks the arguments against a series of `len` samples.
    pub fn validate(&self, len: usize) -> Result<()> {
        match *self {
            Self::FiniteDifference { order } => {
                if !matches!(order, 2 | 4 | 6) {
                    return Err(invalid(
                        "finite-difference order",
                        format!("{order}: supported orders are 2, 4 and 6"),
                    ));
                }
                if len < order + 1 {
                    return Err(invalid(
                        "finite-difference order",
                        format!(
                            "order {order} needs at least {} samples per trajectory, got {len}",
                            order + 1
                        ),
                    ));
                }
            }
            Self::SavitzkyGolay { window, degree } => {
                if degree == 0 {
                    return Err(invalid(
                        "Savitzky–Golay degree",
                        "0: a constant has no derivative; use degree ≥ 1".to_owned(),
                    ));
                }
                if window % 2 == 0 {
                    return Err(invalid(
                        "Savitzky–Golay window",
                        format!("{window}: must be odd so that the window centres on a sample"),
                    ));
                }
                if window <= degree {
                    return Err(invalid(
                        "Savitzky–Golay window",
                        format!(
                            "{window} samples cannot determine a degree-{degree} polynomial; need more than {degree}"
                        ),
                    ));
                }
                if window > len {
                    return Err(invalid(
                        "Savitzky–Golay window",
                        format!("{window} samples, but the trajectory has only {len}"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Samples per stencil or window.
    fn width(&self) -> usize {
        match *self {
            Self::FiniteDifference { order } => order + 1,
            Self::SavitzkyGolay { window, .. } => window,
        }
    }
}

/// Derivative estimates of one series `values` sampled at `times`
/// (finite, strictly increasing).
pub fn differentiate(times: &[f64], values: &[f64], method: &DerivativeMethod) -> Result<Vec<f64>> {
    if values.len() != times.len() {
        return Err(Error::DimensionMismatch {
            what: "values to differentiate".to_owned(),
            expected: times.len(),
            found: values.len(),
        });
    }
    crate::error::check_finite("values to differentiate", values)?;
    crate::error::check_strictly_increasing("times", times)?;
    method.validate(times.len())?;
    (0..times.len())
        .map(|i| {
            let (start, weights) = stencil(times, i, method)?;
            Ok(weights
                .iter()
                .zip(&values[start..])
                .map(|(w, v)| w * v)
                .sum())
        })
        .collect()
}

/// The trajectory with its derivatives replaced by estimates from its states.
///
/// ```
/// use metriplectic_runtime::{estimate_derivatives, DerivativeMethod, Trajectory};
///
/// let t: Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
/// let x: Vec<f64> = t.iter().flat_map(|t| [t.cos(), -t.sin()]).collect();
/// let traj = Trajectory::new(vec!["q".into(), "p".into()], t, x, None).unwrap();
/// let method = DerivativeMethod::SavitzkyGolay { window: 9, degree: 3 };
/// let traj = estimate_derivatives(&traj, &method).unwrap();
/// let d = traj.derivative(20).unwrap();
/// assert!((d[0] + (1.0f64).sin()).abs() < 1e-4);
/// ```
pub fn estimate_derivatives(
    trajectory: &Trajectory,
    method: &DerivativeMethod,
) -> Result<Trajectory> {
    let times = trajectory.times();
    method.validate(times.len())?;
    let n = trajectory.dim();
    let mut derivatives = vec![0.0; times.len() * n];
    for i in 0..times.len() {
        let (start, weights) = stencil(times, i, method)?;
        let out = &mut derivatives[i * n..(i + 1) * n];
        for (k, w) in weights.iter().enumerate() {
            for (o, x) in out.iter_mut().zip(trajectory.state(start + k)) {
                *o += w * x;
            }
        }
    }
    trajectory.clone().with_derivatives(derivatives)
}

/// Estimated derivatives for several trajectories (see [`estimate_derivatives`]).
pub fn estimate_all(
    trajectories: &[Trajectory],
    method: &DerivativeMethod,
) -> Result<Vec<Trajectory>> {
    trajectories
        .iter()
        .map(|t| estimate_derivatives(t, method))
        .collect()
}

/// First index and weights of the stencil or window used at sample `i`.
fn stencil(times: &[f64], i: usize, method: &DerivativeMethod) -> Result<(usize, Vec<f64>)> {
    let width = method.width();
    // Centre on i, then slide inwards at the ends to keep the width (and the order).
    let start = i.saturating_sub(width / 2).min(times.len() - width);
    let window = &times[start..start + width];
    let weights = match *method {
        DerivativeMethod::FiniteDifference { .. } => fornberg_first_derivative(times[i], window),
        DerivativeMethod::SavitzkyGolay { degree, .. } => {
            least_squares_first_derivative(times[i], window, degree)?
        }
    };
    if weights.iter().any(|w| !w.is_finite()) {
        // The weights scale like 1/spacing: a spacing near zero (or spread
        // over many orders of magnitude) overflows them.
        let smallest = window
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min);
        return Err(invalid(
            "time spacing",
            format!(
                "samples {start}..={} (t = {:e} … {:e}) are {smallest:e} apart at the closest, too \
                 close to estimate a derivative in floating point; drop or merge near-duplicate times",
                start + window.len() - 1,
                window[0],
                window[window.len() - 1]
            ),
        ));
    }
    Ok((start, weights))
}

/// Weights of the first derivative at `z` of the polynomial interpolating
/// the samples at `points` (Fornberg 1988, "Generation of finite difference
/// formulas on arbitrarily spaced grids").
fn fornberg_first_derivative(z: f64, points: &[f64]) -> Vec<f64> {
    let m = 1; // derivative order
    let count = points.len();
    // c[j][k]: weight of sample j for the k-th derivative.
    let mut c = vec![[0.0f64; 2]; count];
    c[0][0] = 1.0;
    let mut c1 = 1.0;
    let mut c4 = points[0] - z;
    for i in 1..count {
        let mn = i.min(m);
        let mut c2 = 1.0;
        let c5 = c4;
        c4 = points[i] - z;
        for j in 0..i {
            let c3 = points[i] - points[j];
            c2 *= c3;
            if j == i - 1 {
                for k in (1..=mn).rev() {
                    c[i][k] = c1 * (k as f64 * c[i - 1][k - 1] - c5 * c[i - 1][k]) / c2;
                }
                c[i][0] = -c1 * c5 * c[i - 1][0] / c2;
            }
            for k in (1..=mn).rev() {
                c[j][k] = (c4 * c[j][k] - k as f64 * c[j][k - 1]) / c3;
            }
            c[j][0] = c4 * c[j][0] / c3;
        }
        c1 = c2;
    }
    c.iter().map(|w| w[1]).collect()
}

/// Weights of the derivative at `z` of the least-squares polynomial of
/// `degree` through the samples at `points`.
fn least_squares_first_derivative(z: f64, points: &[f64], degree: usize) -> Result<Vec<f64>> {
    // Scale the abscissae to [-1, 1] so the Vandermonde matrix stays well conditioned.
    let scale = points.iter().map(|t| (t - z).abs()).fold(0.0, f64::max);
    let vandermonde = DMatrix::from_fn(points.len(), degree + 1, |r, c| {
        ((points[r] - z) / scale).powi(c as i32)
    });
    let pinv = vandermonde
        .svd(true, true)
        .pseudo_inverse(1e-12)
        .map_err(|reason| invalid("Savitzky–Golay fit", reason.to_owned()))?;
    // p(u) = Σ cₖ uᵏ with u = (t − z)/scale, so p'(z) = c₁ / scale.
    Ok(pinv.row(1).iter().map(|w| w / scale).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fornberg_reproduces_textbook_weights() {
        let w = fornberg_first_derivative(0.0, &[-1.0, 0.0, 1.0]);
        assert_eq!(w, vec![-0.5, 0.0, 0.5]);
        let w = fornberg_first_derivative(0.0, &[0.0, 1.0, 2.0]);
        let expected = [-1.5, 2.0, -0.5];
        assert!(
            w.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-14),
            "{w:?}"
        );
        let w = fornberg_first_derivative(0.0, &[-2.0, -1.0, 0.0, 1.0, 2.0]);
        let expected = [1.0 / 12.0, -2.0 / 3.0, 0.0, 2.0 / 3.0, -1.0 / 12.0];
        assert!(
            w.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-14),
            "{w:?}"
        );
    }

    #[test]
    fn exact_on_polynomials_of_the_order() {
        // Non-uniform times: order-p stencils differentiate degree-p polynomials exactly.
        let t: Vec<f64> = (0..12).map(|k| (k as f64 * 0.3).powf(1.3)).collect();
        for order in [2usize, 4, 6] {
            let x: Vec<f64> = t.iter().map(|t| t.powi(order as i32) - 2.0 * t).collect();
            let method = DerivativeMethod::FiniteDifference { order };
            let dx = differentiate(&t, &x, &method).unwrap();
            for (d, t) in dx.iter().zip(&t) {
                let exact = order as f64 * t.powi(order as i32 - 1) - 2.0;
                assert!(
                    (d - exact).abs() < 1e-8 * (1.0 + exact.abs()),
                    "order {order}: {d} vs {exact}"
                );
            }
        }
        let x: Vec<f64> = t.iter().map(|t| 1.0 + t - t.powi(3)).collect();
        let method = DerivativeMethod::SavitzkyGolay {
            window: 7,
            degree: 3,
        };
        let dx = differentiate(&t, &x, &method).unwrap();
        for (d, t) in dx.iter().zip(&t) {
            let exact = 1.0 - 3.0 * t * t;
            assert!(
                (d - exact).abs() < 1e-9 * (1.0 + exact.abs()),
                "{d} vs {exact}"
            );
        }
    }

    #[test]
    fn validates_arguments() {
        let t = [0.0, 1.0, 2.0, 3.0];
        let x = [0.0; 4];
        let msg = |m: DerivativeMethod| differentiate(&t, &x, &m).unwrap_err().to_string();
        assert!(msg(DerivativeMethod::FiniteDifference { order: 3 })
            .contains("supported orders are 2, 4 and 6"));
        assert!(msg(DerivativeMethod::FiniteDifference { order: 4 }).contains("at least 5 samples"));
        assert!(msg(DerivativeMethod::SavitzkyGolay {
            window: 4,
            degree: 2
        })
        .contains("must be odd"));
        assert!(msg(DerivativeMethod::SavitzkyGolay {
            window: 3,
            degree: 3
        })
        .contains("cannot determine"));
        assert!(msg(DerivativeMethod::SavitzkyGolay {
            window: 5,
            degree: 2
        })
        .contains("only 4"));
        assert!(msg(DerivativeMethod::SavitzkyGolay {
            window: 3,
            degree: 0
        })
        .contains("degree ≥ 1"));
        let err = differentiate(
            &[0.0, 0.0, 1.0],
            &[0.0; 3],
            &DerivativeMethod::FiniteDifference { order: 2 },
        );
        assert!(err.unwrap_err().to_string().contains("strictly increase"));
    }
}
