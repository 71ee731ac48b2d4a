//! The cubic smoothing spline in Reinsch's form, and the choice of its
//! smoothing parameter by generalized cross-validation.
//!
//! Notation (0-based): N samples, m = N − 2 interior knots, spacings hᵢ =
//! τᵢ₊₁ − τᵢ on normalised times τ ∈ [0, 1]. Column j of the N × m matrix Q
//! (interior knot j + 1) holds aⱼ = 1/hⱼ in row j, bⱼ = −1/hⱼ − 1/hⱼ₊₁ in
//! row j + 1 and cⱼ = 1/hⱼ₊₁ in row j + 2; R is tridiagonal with
//! Rⱼⱼ = (hⱼ + hⱼ₊₁)/3 and Rⱼ,ⱼ₊₁ = hⱼ₊₁/6.

use super::stencil::spacing_error;
use super::SmoothingSplineFit;
use crate::error::{invalid, Result};

/// Fewest samples the spline accepts: with 3 the cross-validation has a
/// single interior knot to judge by.
const MIN_SAMPLES: usize = 4;
/// The penalty γ of the modified cross-validation score
/// N·RSS/(N − γ tr A)² (Kim & Gu 2004; 1 is classical GCV). Classical
/// GCV has a second, spurious minimum at interpolation when two samples
/// nearly coincide (as log-uniform sampling makes likely), and chose it
/// for a few percent of noisy series; γ = 1.4 excludes it (tr A ≥ N/γ
/// scores +∞) and slightly favours smoothing, which derivatives need.
pub(super) const GCV_PENALTY: f64 = 1.4;
/// Search range of ρ = log₁₀(λ̃/λ₀), λ₀ = h̄³/9 with h̄ the mean spacing
/// (tr R / tr QᵀQ on a uniform grid): the smoother's bandwidth is about
/// 10^(ρ/4)/1.7 mean spacings. The low end goes 6 decades below the
/// same unit computed from the actual spacings, tr R / tr QᵀQ, which
/// clustered samples make much smaller; the high end, a bandwidth of
/// about the whole series (the least-squares line), is at most
/// [`RHO_HIGH`].
const RHO_LOW: f64 = -6.0;
const RHO_HIGH: f64 = 12.0;
/// Grid step (decades) and golden-section tolerance of the search.
const GRID_STEP: f64 = 0.5;
const RHO_TOLERANCE: f64 = 1e-3;

pub(super) fn check_len(len: usize) -> Result<()> {
    if len < MIN_SAMPLES {
        return Err(invalid(
            "cubic smoothing spline",
            format!(
                "needs at least {MIN_SAMPLES} samples per trajectory, but the trajectory has {len}"
            ),
        ));
    }
    Ok(())
}

pub(super) fn check_lambda(lambda: f64) -> Result<()> {
    if lambda.is_finite() && lambda >= 0.0 {
        Ok(())
    } else {
        Err(invalid(
            "smoothing-spline λ",
            format!("{lambda}: must be finite and ≥ 0 (or None to choose it by cross-validation)"),
        ))
    }
}

/// Fits one validated series (finite, strictly increasing times, at
/// least [`MIN_SAMPLES`], λ finite and ≥ 0 if given).
pub(super) fn fit(
    times: &[f64],
    values: &[f64],
    lambda: Option<f64>,
) -> Result<SmoothingSplineFit> {
    let n = times.len();
    let t0 = times[0];
    let span = times[n - 1] - t0;
    if !span.is_finite() {
        return Err(invalid(
            "times",
            format!(
                "from {t0:e} to {:e}: the span overflows floating point",
                times[n - 1]
            ),
        ));
    }
    // Centre on the midpoint and scale by the half range: both finite
    // for any finite values (a mean or a difference could overflow).
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    let centre = 0.5 * lo + 0.5 * hi;
    let scale = 0.5 * hi - 0.5 * lo;
    let scale = if scale > 0.0 { scale } else { 1.0 };
    let y: Vec<f64> = values.iter().map(|v| (v - centre) / scale).collect();
    let tau: Vec<f64> = times.iter().map(|t| (t - t0) / span).collect();
    // A spacing whose reciprocal (squared) overflows: blame the closest pair.
    let system = Reinsch::new(&tau, y).ok_or_else(|| {
        let closest = times
            .windows(2)
            .enumerate()
            .min_by(|a, b| (a.1[1] - a.1[0]).total_cmp(&(b.1[1] - b.1[0])))
            .map_or(0, |(i, _)| i);
        spacing_error(times, closest.saturating_sub(1), (closest + 2).min(n - 1))
    })?;
    let overflow = || {
        invalid(
            "cubic smoothing spline",
            format!(
                "the fit is not representable in floating point (values from {lo:e} to \
                 {hi:e}, times from {t0:e} to {:e}); rescale the data",
                times[n - 1]
            ),
        )
    };

    // λ̃ on normalised data: Σ(ỹ − f̃)² + λ̃ ∫ f̃''² dτ with λ̃ = λ / span³,
    // divided one factor at a time: span³ alone may underflow to 0 (0/0
    // for λ = 0) or overflow. An infinite λ̃ is the least-squares line.
    let normalised = match lambda {
        Some(lambda) => lambda / span / span / span,
        None => system.choose().ok_or_else(overflow)?,
    };
    let fit = system.evaluate(normalised).ok_or_else(overflow)?;
    let (values, derivatives) = fit.spline(&system, centre, scale, span);
    let degrees_of_freedom = n as f64 - fit.residual_dof();
    let gcv = fit.score(n).map(|score| scale * scale * score);
    let lambda = lambda.unwrap_or(normalised * span * span * span);
    let finite = values.iter().chain(&derivatives).all(|v| v.is_finite())
        && degrees_of_freedom.is_finite()
        && gcv.is_none_or(f64::is_finite);
    if !finite {
        return Err(overflow());
    }
    Ok(SmoothingSplineFit {
        lambda,
        degrees_of_freedom,
        gcv,
        values,
        derivatives,
    })
}

/// The banded matrices of one series on normalised times τ ∈ [0, 1] and
/// values ỹ.
struct Reinsch {
    /// Spacings hᵢ (N − 1).
    h: Vec<f64>,
    /// Normalised values ỹ (N).
    y: Vec<f64>,
    /// Q's three entries per column (m each): rows j, j + 1, j + 2.
    a: Vec<f64>,
    b: Vec<f64>,
    c: Vec<f64>,
    /// R's diagonal and first off-diagonal.
    r0: Vec<f64>,
    r1: Vec<f64>,
    /// QᵀQ's diagonal, first and second off-diagonals.
    p0: Vec<f64>,
    p1: Vec<f64>,
    p2: Vec<f64>,
    /// λ₀ = h̄³/9, the unit of the search.
    unit: f64,
    /// The low end of the search, ρ = log₁₀(λ̃/λ₀).
    rho_low: f64,
}

impl Reinsch {
    /// `None` if a spacing is too small for its reciprocal.
    fn new(tau: &[f64], y: Vec<f64>) -> Option<Self> {
        let h: Vec<f64> = tau.windows(2).map(|w| w[1] - w[0]).collect();
        let m = h.len() - 1;
        let inv: Vec<f64> = h.iter().map(|h| 1.0 / h).collect();
        if inv.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let a: Vec<f64> = inv[..m].to_vec();
        let c: Vec<f64> = inv[1..].to_vec();
        let b: Vec<f64> = a.iter().zip(&c).map(|(a, c)| -(a + c)).collect();
        let r0: Vec<f64> = h.windows(2).map(|w| (w[0] + w[1]) / 3.0).collect();
        let r1: Vec<f64> = h[1..].iter().map(|h| h / 6.0).collect();
        let p0: Vec<f64> = (0..m)
            .map(|j| a[j] * a[j] + b[j] * b[j] + c[j] * c[j])
            .collect();
        let p1 = (0..m)
            .map(|j| {
                if j + 1 < m {
                    b[j] * a[j + 1] + c[j] * b[j + 1]
                } else {
                    0.0
                }
            })
            .collect();
        let p2 = (0..m)
            .map(|j| if j + 2 < m { c[j] * a[j + 2] } else { 0.0 })
            .collect();
        // The unit from the actual spacings: about the smallest h³/9.
        let local = r0.iter().sum::<f64>() / p0.iter().sum::<f64>();
        if !(local > 0.0 && local.is_finite()) {
            return None;
        }
        // τ spans [0, 1]: the mean spacing is 1/(N − 1).
        let mean = 1.0 / h.len() as f64;
        let unit = mean * mean * mean / 9.0;
        let rho_low = RHO_LOW + (local / unit).log10().min(0.0);
        Some(Reinsch {
            h,
            y,
            a,
            b,
            c,
            r0,
            r1,
            p0,
            p1,
            p2,
            unit,
            rho_low,
        })
    }

    fn m(&self) -> usize {
        self.r0.len()
    }

    /// Q's nonzero entries in row i, as (column, value).
    fn row(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let m = self.m();
        let own = (i < m).then(|| (i, self.a[i]));
        let previous = (i >= 1 && i - 1 < m).then(|| (i - 1, self.b[i - 1]));
        let second = (i >= 2 && i - 2 < m).then(|| (i - 2, self.c[i - 2]));
        own.into_iter().chain(previous).chain(second)
    }

    /// Qᵀv.
    fn qt(&self, v: &[f64]) -> Vec<f64> {
        (0..self.m())
            .map(|j| self.a[j] * v[j] + self.b[j] * v[j + 1] + self.c[j] * v[j + 2])
            .collect()
    }

    /// Qγ.
    fn q(&self, gamma: &[f64]) -> Vec<f64> {
        (0..self.y.len())
            .map(|i| self.row(i).map(|(j, v)| v * gamma[j]).sum())
            .collect()
    }

    /// The normalised λ̃ minimising the modified GCV score; `None` if no
    /// candidate gives a finite score.
    fn choose(&self) -> Option<f64> {
        let n = self.y.len();
        let low = self.rho_low;
        let high = (4.0 * (n as f64).log10() + 1.0).min(RHO_HIGH);
        let score = |rho: f64| {
            self.evaluate(self.unit * 10f64.powf(rho))
                .and_then(|fit| fit.score(n))
                .filter(|g| g.is_finite())
                .unwrap_or(f64::INFINITY)
        };
        let steps = ((high - low) / GRID_STEP).ceil() as usize;
        let (mut best_rho, mut best) = (low, f64::INFINITY);
        for k in 0..=steps {
            let rho = (low + k as f64 * GRID_STEP).min(high);
            let value = score(rho);
            // Strict: ties go to the smaller λ.
            if value < best {
                (best_rho, best) = (rho, value);
            }
        }
        if !best.is_finite() {
            return None;
        }
        // Golden section on the grid cell either side of the best point.
        let (mut lo, mut hi) = (
            (best_rho - GRID_STEP).max(low),
            (best_rho + GRID_STEP).min(high),
        );
        let ratio = 0.5 * (5f64.sqrt() - 1.0);
        let (mut x1, mut x2) = (hi - ratio * (hi - lo), lo + ratio * (hi - lo));
        let (mut f1, mut f2) = (score(x1), score(x2));
        while hi - lo > RHO_TOLERANCE {
            if f1 <= f2 {
                (hi, x2, f2) = (x2, x1, f1);
                x1 = hi - ratio * (hi - lo);
                f1 = score(x1);
            } else {
                (lo, x1, f1) = (x1, x2, f2);
                x2 = lo + ratio * (hi - lo);
                f2 = score(x2);
            }
        }
        let (rho, value) = if f1 <= f2 { (x1, f1) } else { (x2, f2) };
        let rho = if value < best { rho } else { best_rho };
        Some(self.unit * 10f64.powf(rho))
    }

    /// Factorises α R + β QᵀQ with β/α = λ̃ (≥ 0, possibly infinite)
    /// and max(α, β/λ₀) = 1, so that neither λ̃ → 0 nor λ̃ → ∞
    /// overflows; `None` if the factorisation breaks down.
    fn factor(&self, lambda: f64) -> Option<Factor> {
        let m = self.m();
        let (alpha, beta) = if lambda <= self.unit {
            (1.0, lambda)
        } else {
            (self.unit / lambda, self.unit)
        };
        // Banded LDLᵀ: L's first and second subdiagonals.
        let (mut d, mut l1, mut l2) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        for j in 0..m {
            let mut dj = alpha * self.r0[j] + beta * self.p0[j];
            if j >= 1 {
                dj -= l1[j - 1] * l1[j - 1] * d[j - 1];
            }
            if j >= 2 {
                dj -= l2[j - 2] * l2[j - 2] * d[j - 2];
            }
            if !(dj > 0.0 && dj.is_finite()) {
                return None;
            }
            d[j] = dj;
            if j + 1 < m {
                let mut e = alpha * self.r1[j] + beta * self.p1[j];
                if j >= 1 {
                    e -= l2[j - 1] * l1[j - 1] * d[j - 1];
                }
                l1[j] = e / dj;
            }
            if j + 2 < m {
                l2[j] = beta * self.p2[j] / dj;
            }
        }
        // Central band of S = (αR + βQᵀQ)⁻¹ (Hutchinson & de Hoog 1985):
        // s0[j] = Sⱼⱼ, s1[j] = Sⱼ,ⱼ₊₁, s2[j] = Sⱼ,ⱼ₊₂.
        let (mut s0, mut s1, mut s2) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        for j in (0..m).rev() {
            let l1j = if j + 1 < m { l1[j] } else { 0.0 };
            let l2j = if j + 2 < m { l2[j] } else { 0.0 };
            let next = if j + 1 < m { s0[j + 1] } else { 0.0 };
            let next_off = if j + 2 < m { s1[j + 1] } else { 0.0 };
            let after = if j + 2 < m { s0[j + 2] } else { 0.0 };
            s2[j] = -l1j * next_off - l2j * after;
            s1[j] = -l1j * next - l2j * next_off;
            s0[j] = 1.0 / d[j] - l1j * s1[j] - l2j * s2[j];
        }
        let band = |p: usize, q: usize| match p.abs_diff(q) {
            0 => s0[p],
            1 => s1[p.min(q)],
            _ => s2[p.min(q)],
        };
        // tr(Q S Qᵀ) = Σᵢ Σ_pq Q_ip S_pq Q_iq over the ≤ 3 entries of row i.
        let mut trace = 0.0;
        for i in 0..self.y.len() {
            for (p, vp) in self.row(i) {
                for (q, vq) in self.row(i) {
                    trace += vp * vq * band(p, q);
                }
            }
        }
        Some(Factor {
            alpha,
            beta,
            d,
            l1,
            l2,
            trace,
        })
    }

    /// The fit for λ̃; `None` if it is not representable.
    fn evaluate(&self, lambda: f64) -> Option<Evaluation> {
        let factor = self.factor(lambda)?;
        let gamma = factor.solve(self.qt(&self.y));
        let residual = self.q(&gamma);
        Some(Evaluation {
            factor,
            gamma,
            residual,
        })
    }
}

/// A factorisation of α R + β QᵀQ, and tr(Q (αR + βQᵀQ)⁻¹ Qᵀ).
struct Factor {
    alpha: f64,
    beta: f64,
    d: Vec<f64>,
    l1: Vec<f64>,
    l2: Vec<f64>,
    trace: f64,
}

impl Factor {
    /// (αR + βQᵀQ)⁻¹ rhs.
    fn solve(&self, mut x: Vec<f64>) -> Vec<f64> {
        let m = self.d.len();
        for j in 0..m {
            if j >= 1 {
                x[j] -= self.l1[j - 1] * x[j - 1];
            }
            if j >= 2 {
                x[j] -= self.l2[j - 2] * x[j - 2];
            }
        }
        for j in (0..m).rev() {
            x[j] /= self.d[j];
            if j + 1 < m {
                x[j] -= self.l1[j] * x[j + 1];
            }
            if j + 2 < m {
                x[j] -= self.l2[j] * x[j + 2];
            }
        }
        x
    }
}

/// The fit for one λ̃, in the scaled form of [`Reinsch::factor`].
struct Evaluation {
    factor: Factor,
    /// γ' = (αR + βQᵀQ)⁻¹ Qᵀỹ.
    gamma: Vec<f64>,
    /// Qγ': the residual ỹ − f is β·Qγ'.
    residual: Vec<f64>,
}

impl Evaluation {
    /// N − tr A = β · tr(Q (αR + βQᵀQ)⁻¹ Qᵀ).
    fn residual_dof(&self) -> f64 {
        self.factor.beta * self.factor.trace
    }

    /// The modified GCV score on normalised data, N·RSS/(N − γ tr A)²
    /// with γ = [`GCV_PENALTY`]; `None` where N − γ tr A ≤ 0 (too
    /// little smoothing to judge). RSS = β²‖Qγ'‖² and N − tr A =
    /// β·trace are formed without cancellation.
    fn score(&self, n: usize) -> Option<f64> {
        let n = n as f64;
        let beta = self.factor.beta;
        let rss = beta * beta * self.residual.iter().map(|v| v * v).sum::<f64>();
        let denominator = GCV_PENALTY * self.residual_dof() - (GCV_PENALTY - 1.0) * n;
        (denominator > 0.0).then(|| n * rss / (denominator * denominator))
    }

    /// Values and derivatives at the samples in the data's units.
    fn spline(&self, system: &Reinsch, centre: f64, scale: f64, span: f64) -> (Vec<f64>, Vec<f64>) {
        let n = system.y.len();
        let beta = self.factor.beta;
        // Fitted values f̃ = ỹ − βQγ'.
        let fitted: Vec<f64> = system
            .y
            .iter()
            .zip(&self.residual)
            .map(|(y, r)| y - beta * r)
            .collect();
        // The second derivatives at the interior knots are γ = αγ', since
        // αR + βQᵀQ = α(R + λ̃QᵀQ); they vanish at the ends (a natural
        // spline), and everywhere as λ̃ → ∞ (α → 0): the line.
        let mut second = vec![0.0; n];
        for (s, g) in second[1..n - 1].iter_mut().zip(&self.gamma) {
            *s = self.factor.alpha * g;
        }
        let h = &system.h;
        let mut slope = Vec::with_capacity(n);
        for i in 0..n - 1 {
            slope.push(
                (fitted[i + 1] - fitted[i]) / h[i] - h[i] * (2.0 * second[i] + second[i + 1]) / 6.0,
            );
        }
        let last = n - 2;
        slope.push(
            (fitted[n - 1] - fitted[last]) / h[last]
                + h[last] * (second[last] + 2.0 * second[n - 1]) / 6.0,
        );
        let values = fitted.iter().map(|f| centre + scale * f).collect();
        let derivatives = slope.iter().map(|d| scale * d / span).collect();
        (values, derivatives)
    }
}

#[cfg(test)]
mod tests {
    use super::super::{differentiate, fit_smoothing_spline, DerivativeMethod};
    use super::*;
    use nalgebra::DMatrix;

    /// The fit's cross-validation score is N·RSS/(N − γ·trace)² of the
    /// fitted values `fitted` of `x`, or `None` where that denominator is
    /// not positive.
    fn assert_gcv_score(
        fit: &SmoothingSplineFit,
        x: &[f64],
        fitted: &[f64],
        trace: f64,
        lambda: f64,
    ) {
        let n = x.len() as f64;
        let denominator = n - GCV_PENALTY * trace;
        if denominator > 0.0 {
            let rss: f64 = x.iter().zip(fitted).map(|(a, b)| (a - b).powi(2)).sum();
            let score = n * rss / denominator.powi(2);
            let found = fit.gcv.unwrap();
            assert!(
                (found / score - 1.0).abs() < 1e-6,
                "λ = {lambda}: {found} vs {score}"
            );
        } else {
            assert_eq!(fit.gcv, None, "λ = {lambda}");
        }
    }

    /// A smooth signal at times `t` with a small fast ripple.
    fn wavy(t: &[f64]) -> Vec<f64> {
        t.iter()
            .enumerate()
            .map(|(k, t)| (1.3 * t).sin() + 0.05 * (7.1 * k as f64).cos())
            .collect()
    }

    fn jittered(n: usize) -> Vec<f64> {
        (0..n)
            .map(|k| 0.1 * (k as f64 + 0.35 * (2.3 * k as f64).sin()))
            .collect()
    }

    /// Dense reference: the smoothing spline's values g = (I + λ Q R⁻¹ Qᵀ)⁻¹ x
    /// (Green & Silverman 1994, §2.3) on the given times.
    fn dense_spline(t: &[f64], x: &[f64], lambda: f64) -> Vec<f64> {
        let n = t.len();
        let h: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        let q = DMatrix::from_fn(n, n - 2, |i, j| {
            if i == j {
                1.0 / h[j]
            } else if i == j + 1 {
                -1.0 / h[j] - 1.0 / h[j + 1]
            } else if i == j + 2 {
                1.0 / h[j + 1]
            } else {
                0.0
            }
        });
        let r = DMatrix::from_fn(n - 2, n - 2, |i, j| {
            if i == j {
                (h[i] + h[i + 1]) / 3.0
            } else if j == i + 1 {
                h[i + 1] / 6.0
            } else if i == j + 1 {
                h[j + 1] / 6.0
            } else {
                0.0
            }
        });
        let k = &q * r.try_inverse().unwrap() * q.transpose();
        let a = DMatrix::identity(n, n) + k * lambda;
        let g = a
            .lu()
            .solve(&nalgebra::DVector::from_column_slice(x))
            .unwrap();
        g.iter().copied().collect()
    }

    #[test]
    fn natural_spline_matches_the_dense_formula_and_its_trace() {
        let t = jittered(30);
        let x = wavy(&t);
        for lambda in [0.0, 1e-4, 1e-2, 1.0, 1e3] {
            let fit = fit(&t, &x, Some(lambda)).unwrap();
            let dense = dense_spline(&t, &x, lambda);
            // The dense formula's condition number grows like λ/h³ (10⁹ at
            // λ = 10³ here), so it is the less accurate of the two.
            let tolerance = 1e-12 * (1.0 + lambda * 1e4);
            for (a, b) in fit.values.iter().zip(&dense) {
                assert!((a - b).abs() < tolerance, "λ = {lambda}: {a} vs {b}");
            }
            // tr A from the impulse responses of the (linear) smoother.
            let trace: f64 = (0..t.len())
                .map(|k| {
                    let mut e = vec![0.0; t.len()];
                    e[k] = 1.0;
                    dense_spline(&t, &e, lambda)[k]
                })
                .sum();
            assert!(
                (fit.degrees_of_freedom - trace).abs() < 1e-8,
                "λ = {lambda}: {} vs {trace}",
                fit.degrees_of_freedom
            );
            assert_gcv_score(&fit, &x, &dense, trace, lambda);
        }
    }

    /// The smoother x ↦ f(t) is linear for a fixed λ: its trace from the
    /// impulse responses and the cross-validation score from the fitted
    /// values match what the fit reports.
    #[test]
    fn smoothing_spline_reports_its_trace_and_score() {
        let t = jittered(40);
        let x = wavy(&t);
        let n = t.len() as f64;
        for lambda in [0.0, 1e-4, 1e-2, 1.0, 1e3] {
            let fit = fit_smoothing_spline(&t, &x, Some(lambda)).unwrap();
            let trace: f64 = (0..t.len())
                .map(|k| {
                    let mut e = vec![0.0; t.len()];
                    e[k] = 1.0;
                    fit_smoothing_spline(&t, &e, Some(lambda)).unwrap().values[k]
                })
                .sum();
            assert!(
                (fit.degrees_of_freedom - trace).abs() < 1e-7 * n,
                "λ = {lambda}: {} vs {trace}",
                fit.degrees_of_freedom
            );
            assert_gcv_score(&fit, &x, &fit.values, fit.degrees_of_freedom, lambda);
            if lambda == 0.0 {
                assert!((fit.degrees_of_freedom - n).abs() < 1e-9);
            }
        }
        assert!(fit_smoothing_spline(&t, &x, Some(1e3))
            .unwrap()
            .gcv
            .is_some());
        // The chosen λ is a minimum of GCV: nudging it either way does not help.
        let chosen = fit_smoothing_spline(&t, &x, None).unwrap();
        let score = |lambda: f64| {
            fit_smoothing_spline(&t, &x, Some(lambda))
                .unwrap()
                .gcv
                .unwrap()
        };
        let best = chosen.gcv.unwrap();
        assert!(best <= score(chosen.lambda * 1.5) * (1.0 + 1e-9));
        assert!(best <= score(chosen.lambda / 1.5) * (1.0 + 1e-9));
        assert!(chosen.degrees_of_freedom > 2.0 && chosen.degrees_of_freedom < n);
    }

    #[test]
    fn smoothing_spline_handles_lines_constants_and_extreme_smoothing() {
        let t = jittered(12);
        let line: Vec<f64> = t.iter().map(|t| 3.0 - 2.0 * t).collect();
        for lambda in [
            None,
            Some(0.0),
            Some(1e-300),
            Some(1.0),
            Some(1e300),
            Some(f64::MAX),
        ] {
            let d = fit_smoothing_spline(&t, &line, lambda).unwrap().derivatives;
            assert!(
                d.iter().all(|d| (d + 2.0).abs() < 1e-9),
                "{lambda:?}: {d:?}"
            );
        }
        let constant = vec![7.5; 12];
        let fit = fit_smoothing_spline(&t, &constant, None).unwrap();
        assert!(
            fit.derivatives.iter().all(|d| *d == 0.0),
            "{:?}",
            fit.derivatives
        );
        assert!(fit.values.iter().all(|v| *v == 7.5));
        // Huge λ: the least-squares line through noisy data.
        let wiggly: Vec<f64> = t.iter().map(|t| t + 0.1 * (9.0 * t).sin()).collect();
        let d = fit_smoothing_spline(&t, &wiggly, Some(1e300))
            .unwrap()
            .derivatives;
        assert!(
            d.iter().all(|v| (v - d[0]).abs() < 1e-9 && v.is_finite()),
            "{d:?}"
        );
        // Huge offsets and scales change nothing but the units.
        let shifted: Vec<f64> = wiggly.iter().map(|v| 1e6 + 1e3 * v).collect();
        let a = fit_smoothing_spline(&t, &wiggly, None).unwrap();
        let b = fit_smoothing_spline(&t, &shifted, None).unwrap();
        for (a, b) in a.derivatives.iter().zip(&b.derivatives) {
            assert!((1e3 * a - b).abs() < 1e-6 * b.abs().max(1.0), "{a} vs {b}");
        }
    }

    #[test]
    fn smoothing_spline_rejects_short_series_and_bad_lambda() {
        let t = [0.0, 1.0, 2.0];
        let err = differentiate(&t, &[0.0; 3], &DerivativeMethod::smoothing_spline()).unwrap_err();
        let message = err.to_string();
        assert!(
            message.contains("at least 4 samples") && message.contains("has 3"),
            "{message}"
        );
        let t = [0.0, 1.0, 2.0, 3.0];
        for lambda in [-1.0, f64::NAN, f64::INFINITY] {
            let method = DerivativeMethod::SmoothingSpline {
                lambda: Some(lambda),
            };
            let message = differentiate(&t, &[0.0; 4], &method)
                .unwrap_err()
                .to_string();
            assert!(message.contains("smoothing-spline λ"), "{message}");
        }
        // Times too close for the reciprocal spacing: blamed, not NaN.
        let t = [0.0, 1e-310, 1.0, 2.0, 3.0];
        let message = differentiate(
            &t,
            &[0.0, 0.0, 1.0, 2.0, 3.0],
            &DerivativeMethod::smoothing_spline(),
        )
        .unwrap_err()
        .to_string();
        assert!(
            message.contains("time spacing") && message.contains("samples 0..=2"),
            "{message}"
        );
    }

    /// λ = 0: the natural cubic interpolant. It goes through every sample,
    /// and on clean smooth data its derivative is accurate away from the
    /// ends (where the natural end condition f'' = 0 costs O(h·|f''|)).
    #[test]
    fn smoothing_spline_with_zero_lambda_interpolates() {
        let t = jittered(200);
        let x: Vec<f64> = t.iter().map(|t| t.sin() + 0.5 * (-t).exp()).collect();
        let fit = fit_smoothing_spline(&t, &x, Some(0.0)).unwrap();
        for (f, x) in fit.values.iter().zip(&x) {
            assert!((f - x).abs() < 1e-12, "{f} vs {x}");
        }
        let exact: Vec<f64> = t.iter().map(|t| t.cos() - 0.5 * (-t).exp()).collect();
        let error = |range: std::ops::Range<usize>| {
            range
                .map(|i| (fit.derivatives[i] - exact[i]).abs())
                .fold(0.0, f64::max)
        };
        // h ≈ 0.1: a cubic interpolant's derivative error is O(h³) inside.
        let interior = error(10..190);
        let overall = error(0..200);
        println!("λ = 0: max derivative error {interior:.1e} inside, {overall:.1e} overall");
        assert!(interior < 1e-4, "interior {interior}");
        assert!(overall < 2e-2, "overall {overall}");
    }

    /// λ → ∞: the least-squares line, whose slope is the derivative
    /// everywhere, whatever the data.
    #[test]
    fn smoothing_spline_with_huge_lambda_is_the_least_squares_line() {
        let t = jittered(60);
        let x: Vec<f64> = t
            .iter()
            .map(|t| 0.7 * t + (3.0 * t).sin() + 0.2 * t * t)
            .collect();
        let n = t.len() as f64;
        let (tm, xm) = (t.iter().sum::<f64>() / n, x.iter().sum::<f64>() / n);
        let slope = t
            .iter()
            .zip(&x)
            .map(|(t, x)| (t - tm) * (x - xm))
            .sum::<f64>()
            / t.iter().map(|t| (t - tm).powi(2)).sum::<f64>();
        for lambda in [1e12, 1e100, f64::MAX] {
            let fit = fit_smoothing_spline(&t, &x, Some(lambda)).unwrap();
            for d in &fit.derivatives {
                assert!(
                    (d - slope).abs() < 1e-6 * slope.abs(),
                    "λ = {lambda}: {d} vs {slope}"
                );
            }
            for (f, t) in fit.values.iter().zip(&t) {
                let line = xm + slope * (t - tm);
                assert!((f - line).abs() < 1e-6, "λ = {lambda}: {f} vs {line}");
            }
            assert!((fit.degrees_of_freedom - 2.0).abs() < 1e-6);
        }
    }

    /// O(N) per λ: a million samples with a given λ, and GCV's search over
    /// 10⁵ samples, run in well under a second each (a dense O(N²) or
    /// O(N³) smoother could not), and stay accurate.
    #[test]
    fn smoothing_spline_handles_long_series() {
        for (n, lambda) in [(1_000_000, Some(1e-12)), (100_000, None)] {
            let t: Vec<f64> = (0..n)
                .map(|k| 1e-4 * (k as f64 + 0.3 * (1.7 * k as f64).sin()))
                .collect();
            let x: Vec<f64> = t.iter().map(|t| t.sin()).collect();
            let fit = fit_smoothing_spline(&t, &x, lambda).unwrap();
            let worst = fit
                .derivatives
                .iter()
                .zip(&t)
                .skip(100)
                .take(n - 200)
                .map(|(d, t)| (d - t.cos()).abs())
                .fold(0.0, f64::max);
            println!(
                "{n} samples, λ {lambda:?}: max interior derivative error {worst:.1e}, {:.1} degrees of freedom",
                fit.degrees_of_freedom
            );
            assert!(worst < 1e-5, "{n} samples: {worst}");
        }
    }

    #[test]
    fn smoothing_spline_rejects_bad_input_by_name() {
        let t = [0.0, 1.0, 2.0, 3.0, 4.0];
        let x = [0.0, 1.0, 0.0, 1.0, 0.0];
        let message = |t: &[f64], x: &[f64], lambda| {
            fit_smoothing_spline(t, x, lambda).unwrap_err().to_string()
        };
        let m = message(&t, &x[..4], None);
        assert!(
            m.contains("values to fit") && m.contains('5') && m.contains('4'),
            "{m}"
        );
        let m = message(&t, &[0.0, 1.0, f64::NAN, 1.0, 0.0], None);
        assert!(
            m.contains("values to fit") && m.contains("NaN") && m.contains('2'),
            "{m}"
        );
        let m = message(&[0.0, 1.0, 1.0, 2.0, 3.0], &x, None);
        assert!(
            m.contains("strictly increase") && m.contains("entry 2"),
            "{m}"
        );
        let m = message(&[0.0, 1.0, f64::INFINITY, 2.0, 3.0], &x, None);
        assert!(m.contains("times") && m.contains("inf"), "{m}");
        let m = message(&t[..3], &x[..3], Some(1.0));
        assert!(
            m.contains("at least 4 samples") && m.contains("has 3"),
            "{m}"
        );
        let m = message(&t, &x, Some(-0.5));
        assert!(
            m.contains("smoothing-spline λ") && m.contains("-0.5"),
            "{m}"
        );
        let m = message(&t, &x, Some(f64::NAN));
        assert!(m.contains("smoothing-spline λ") && m.contains("NaN"), "{m}");
        let m = message(&[-1e308, 0.0, 1.0, 1e308], &x[..4], None);
        assert!(m.contains("span overflows"), "{m}");
        // Values at the edge of the floating-point range: fitted, or refused
        // by name, never NaN or a panic.
        let huge = [1e308, -1e308, 1.5e308, -1.7e308, 1e308];
        match fit_smoothing_spline(&t, &huge, None) {
            Ok(fit) => assert!(fit.derivatives.iter().all(|d| d.is_finite())),
            Err(err) => assert!(err.to_string().contains("not representable"), "{err}"),
        }
        let m = message(&[0.0, 1e-300, 2e-300, 3e-300], &huge[..4], Some(0.0));
        assert!(m.contains("not representable"), "{m}");
        // Times spanning 5e-300 (span³ underflows) or 5e200 (it overflows):
        // λ = 0 still interpolates, and GCV still chooses.
        for scale in [1e-300, 1e200] {
            let t: Vec<f64> = (0..6).map(|k| scale * f64::from(k)).collect();
            let x = [1.0, 2.0, 4.0, 3.0, 5.0, 4.5];
            let fit = fit_smoothing_spline(&t, &x, Some(0.0)).unwrap();
            assert!(
                fit.values
                    .iter()
                    .zip(&x)
                    .all(|(f, x)| (f - x).abs() < 1e-12),
                "{fit:?}"
            );
            assert!(fit.derivatives.iter().all(|d| d.is_finite()), "{fit:?}");
            let chosen = fit_smoothing_spline(&t, &x, None).unwrap();
            assert!(
                chosen.derivatives.iter().all(|d| d.is_finite()),
                "{chosen:?}"
            );
        }
    }
}
