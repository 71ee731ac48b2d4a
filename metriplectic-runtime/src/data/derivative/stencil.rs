//! Local derivative stencils on non-uniform times: the finite-difference
//! weights of the interpolating polynomial (Fornberg) and the
//! Savitzky–Golay weights of a local least-squares polynomial, each on a
//! window centred on the sample and slid inwards at the ends.

use nalgebra::DMatrix;

use super::DerivativeMethod;
use crate::error::{invalid, Error, Result};

/// First index and weights of the stencil or window used at sample `i`.
pub(super) fn stencil(
    times: &[f64],
    i: usize,
    method: &DerivativeMethod,
) -> Result<(usize, Vec<f64>)> {
    let width = method.width().unwrap_or(times.len());
    // Centre on i, then slide inwards at the ends to keep the width (and the order).
    let start = i.saturating_sub(width / 2).min(times.len() - width);
    let last = start + width - 1;
    // The weights are formed in u = (t − tᵢ)/scale ∈ [−1, 1] and divided by
    // the scale at the end: in raw times, products of differences
    // overflowed to ∞ at spacings near 1e51–1e155 and left weights of 0 or
    // of the wrong sign, and the Savitzky–Golay SVD panicked on NaN.
    let offsets: Vec<f64> = times[start..=last].iter().map(|t| t - times[i]).collect();
    let scale = offsets.iter().fold(0.0_f64, |m, d| m.max(d.abs()));
    if !scale.is_finite() {
        return Err(invalid(
            "time span",
            format!(
                "samples {start}..={last} (t = {:e} … {:e}) span more than floating point \
                 holds (their differences overflow); rescale the times",
                times[start], times[last]
            ),
        ));
    }
    let unit: Vec<f64> = offsets.iter().map(|d| d / scale).collect();
    let weights = match *method {
        DerivativeMethod::FiniteDifference { .. } => fornberg_first_derivative(0.0, &unit),
        DerivativeMethod::SavitzkyGolay { degree, .. } => {
            least_squares_first_derivative(&unit, degree)?
        }
        DerivativeMethod::SmoothingSpline { .. } => {
            return Err(invalid(
                "derivative method",
                "the smoothing spline has no local stencil".to_owned(),
            ))
        }
    };
    let weights: Vec<f64> = weights.iter().map(|w| w / scale).collect();
    if weights.iter().any(|w| !w.is_finite()) {
        // The weights scale like 1/spacing: a spacing near zero (or spread
        // over many orders of magnitude) overflows them.
        return Err(spacing_error(times, start, last));
    }
    Ok((start, weights))
}

/// The error for samples `first..=last` whose spacing is too small to
/// estimate a derivative from in floating point.
pub(super) fn spacing_error(times: &[f64], first: usize, last: usize) -> Error {
    let window = &times[first..=last];
    let smallest = window
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    invalid(
        "time spacing",
        format!(
            "samples {first}..={last} (t = {:e} … {:e}) are {smallest:e} apart at the closest, too \
             close to estimate a derivative in floating point; drop or merge near-duplicate times",
            window[0],
            window[window.len() - 1]
        ),
    )
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

/// Weights of the derivative at 0 of the least-squares polynomial of
/// `degree` through the samples at `points` (in [−1, 1], so that the
/// Vandermonde matrix stays well conditioned).
fn least_squares_first_derivative(points: &[f64], degree: usize) -> Result<Vec<f64>> {
    let vandermonde = DMatrix::from_fn(points.len(), degree + 1, |r, c| points[r].powi(c as i32));
    let pinv = vandermonde
        .svd(true, true)
        .pseudo_inverse(1e-12)
        .map_err(|reason| invalid("Savitzky–Golay fit", reason.to_owned()))?;
    // p(u) = Σ cₖ uᵏ, so p'(0) = c₁.
    Ok(pinv.row(1).iter().copied().collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::derivative::{differentiate, DerivativeMethod};

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

    /// A probe's FD2 at spacing 1e155 came back with the wrong sign, FD6 at
    /// 2e51 off by 130%, and Savitzky–Golay on times near ±f64::MAX
    /// panicked in the SVD: the weights are now formed on [−1, 1].
    #[test]
    fn huge_time_spacings_give_the_same_estimates_in_their_units() {
        let methods = [
            DerivativeMethod::FiniteDifference { order: 2 },
            DerivativeMethod::FiniteDifference { order: 6 },
            DerivativeMethod::SavitzkyGolay {
                window: 7,
                degree: 3,
            },
        ];
        let unit: Vec<f64> = (0..20).map(|k| k as f64).collect();
        let x: Vec<f64> = (0..20).map(|k| (0.3 * k as f64).sin()).collect();
        for method in &methods {
            let reference = differentiate(&unit, &x, method).unwrap();
            for h in [2e51, 1e78, 1e155, 1e200, 1e-200] {
                let t: Vec<f64> = unit.iter().map(|k| k * h).collect();
                let dx = differentiate(&t, &x, method).unwrap();
                for (d, r) in dx.iter().zip(&reference) {
                    assert!(
                        (d * h - r).abs() <= 1e-9 * (1.0 + r.abs()),
                        "{method:?}, h = {h:e}: {} vs {r}",
                        d * h
                    );
                }
            }
        }
        let t = [-1.7e308, 0.0, 1.7e308, 1.79e308];
        for method in [
            DerivativeMethod::SavitzkyGolay {
                window: 3,
                degree: 1,
            },
            DerivativeMethod::FiniteDifference { order: 2 },
        ] {
            let err = differentiate(&t, &[0.0, 1.0, 2.0, 3.0], &method)
                .unwrap_err()
                .to_string();
            assert!(err.contains("span more than floating point holds"), "{err}");
        }
    }
}
