//! Coefficients of a polynomial in centred coordinates y = x − c.
//!
//! States far from the origin against their spread (a temperature near
//! 300 K that varies by a few kelvin) make the monomials of x nearly
//! collinear: on T ∈ [298, 302] the columns T, T², T³ and T⁴ agree to a few
//! parts in 10⁴ after scaling, and a program over them loses every digit.
//! The programs therefore run on the coefficients of the same polynomial in
//! y = x − c, whose monomials are of the size of the spread, and convert
//! back by the binomial expansion of (y + c)^α, exact up to rounding.

use std::collections::HashMap;

/// The change of variables a(x) = V a(y) between the coefficients of a
/// polynomial in x and in y = x − c over one monomial basis closed under
/// lower powers, applied to vectors made of consecutive blocks of that
/// basis (one for the entropy, one per metric entry pair).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Shift {
    /// c, one coordinate per state variable.
    centre: Vec<f64>,
    /// Per coefficient α in x: the (γ, v) of aₓ,α = Σ_γ v·a_y,γ.
    backward: Vec<Vec<(usize, f64)>>,
    /// Per coefficient α in x: the (γ, v) it adds to, a_y,γ += v·aₓ,α.
    forward: Vec<Vec<(usize, f64)>>,
}

impl Shift {
    /// The change of variables for the basis `exponents` and centre
    /// `centre`; `None` if the basis is not closed under lower powers (the
    /// expansion would leave it). A basis without the constant (the
    /// entropy's) drops it: only the gradient of such a polynomial matters.
    pub fn new(exponents: &[&[u32]], centre: Vec<f64>) -> Option<Self> {
        let index: HashMap<&[u32], usize> =
            exponents.iter().enumerate().map(|(k, e)| (*e, k)).collect();
        let mut backward = vec![Vec::new(); exponents.len()];
        let mut forward = vec![Vec::new(); exponents.len()];
        for (alpha, e) in exponents.iter().enumerate() {
            if e.len() != centre.len() {
                return None;
            }
            for gamma in lower_powers(e) {
                let g = match index.get(gamma.as_slice()) {
                    Some(&g) => g,
                    None if gamma.iter().all(|&g| g == 0) => continue,
                    None => return None,
                };
                let expand = |sign: f64| {
                    e.iter()
                        .zip(&gamma)
                        .zip(&centre)
                        .map(|((&a, &g), &c)| binomial(a, g) * (sign * c).powi((a - g) as i32))
                        .product::<f64>()
                };
                // (y + c)^α = Σ_γ B(α, γ) c^(α−γ) y^γ.
                forward[alpha].push((g, expand(1.0)));
                // (x − c)^γ = Σ_α B(γ, α) (−c)^(γ−α) x^α, read the other way.
                backward[g].push((alpha, expand(-1.0)));
            }
        }
        Some(Self {
            centre,
            backward,
            forward,
        })
    }

    /// y = x − c into `y`.
    pub fn centred_state(&self, x: &[f64], y: &mut [f64]) {
        y.iter_mut()
            .zip(x.iter().zip(&self.centre))
            .for_each(|(y, (x, c))| *y = x - c);
    }

    /// The coefficients in y from those in x, block by block.
    pub fn to_centred(&self, coefficients: &[f64]) -> Vec<f64> {
        let m = self.forward.len().max(1);
        let mut centred = vec![0.0; coefficients.len()];
        for (block, out) in coefficients.chunks(m).zip(centred.chunks_mut(m)) {
            for (value, terms) in block.iter().zip(&self.forward) {
                for &(gamma, v) in terms {
                    out[gamma] += value * v;
                }
            }
        }
        centred
    }

    /// The coefficients in x from those in y, block by block.
    pub fn to_original(&self, centred: &[f64]) -> Vec<f64> {
        let m = self.backward.len().max(1);
        centred
            .chunks(m)
            .flat_map(|block| {
                self.backward
                    .iter()
                    .map(|terms| terms.iter().map(|&(gamma, v)| v * block[gamma]).sum())
            })
            .collect()
    }

    /// Rows (row, column, value) on coefficients in x, which occupy
    /// columns `offset..offset + count` in blocks of the basis, rewritten
    /// on the coefficients in y in the same columns; entries in other
    /// columns are kept.
    pub fn rows(
        &self,
        entries: Vec<(usize, usize, f64)>,
        offset: usize,
        count: usize,
    ) -> Vec<(usize, usize, f64)> {
        let m = self.backward.len().max(1);
        let mut rewritten = Vec::with_capacity(entries.len());
        for (row, column, value) in entries {
            match column.checked_sub(offset).filter(|&k| k < count) {
                Some(k) => {
                    let start = offset + k / m * m;
                    rewritten.extend(
                        self.backward[k % m]
                            .iter()
                            .map(|&(gamma, v)| (row, start + gamma, value * v)),
                    );
                }
                None => rewritten.push((row, column, value)),
            }
        }
        rewritten
    }
}

/// The centre of each interval [lowⱼ, highⱼ] that lies farther from zero
/// than its own width, 0 for the others; `None` if there is none.
pub(crate) fn far_centre(low: &[f64], high: &[f64]) -> Option<Vec<f64>> {
    let centre: Vec<f64> = low
        .iter()
        .zip(high)
        .map(|(&l, &h)| {
            let (width, distance) = (h - l, l.max(-h));
            if distance > width && distance.is_finite() {
                0.5 * (l + h)
            } else {
                0.0
            }
        })
        .collect();
    centre.iter().any(|&c| c != 0.0).then_some(centre)
}

/// (y + c)^α = Σ_γ weight·y^γ: every (γ, weight), or `None` if α and c
/// differ in length.
pub(crate) fn expansion(alpha: &[u32], centre: &[f64]) -> Option<Vec<(Vec<u32>, f64)>> {
    (alpha.len() == centre.len()).then(|| {
        lower_powers(alpha)
            .into_iter()
            .map(|gamma| {
                let weight = alpha
                    .iter()
                    .zip(&gamma)
                    .zip(centre)
                    .map(|((&a, &g), &c)| binomial(a, g) * c.powi((a - g) as i32))
                    .product();
                (gamma, weight)
            })
            .collect()
    })
}

/// Every exponent vector γ ≤ `exponent` componentwise.
fn lower_powers(exponent: &[u32]) -> Vec<Vec<u32>> {
    let mut all = vec![Vec::with_capacity(exponent.len())];
    for &a in exponent {
        all = all
            .into_iter()
            .flat_map(|prefix: Vec<u32>| {
                (0..=a).map(move |g| {
                    let mut next = prefix.clone();
                    next.push(g);
                    next
                })
            })
            .collect();
    }
    all
}

/// C(a, g) as f64.
fn binomial(a: u32, g: u32) -> f64 {
    (0..g).fold(1.0, |c, i| c * f64::from(a - i) / f64::from(i + 1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::system::MetriplecticSystem;
    use crate::test_system::Quadratic2d;

    /// The entropy (no constant) in x and in y = x − c has the same
    /// gradient, and the conversion goes both ways.
    #[test]
    fn the_expansion_keeps_the_gradient() {
        let centre = vec![300.0, -2.5];
        let shift = Shift::new(Quadratic2d::ENTROPY_EXPONENTS, centre.clone()).unwrap();
        let psi = [0.3, -1.2, 0.7, 0.25, -0.4];
        let centred = shift.to_centred(&psi);
        let back = shift.to_original(&centred);
        for (a, b) in back.iter().zip(&psi) {
            assert!((a - b).abs() <= 1e-9 * (1.0 + b.abs()), "{a} vs {b}");
        }
        let x = [301.5, -1.0];
        let mut y = [0.0; 2];
        shift.centred_state(&x, &mut y);
        let (mut gx, mut gy) = ([0.0; 2], [0.0; 2]);
        Quadratic2d::entropy_gradient(&x, &psi, &mut gx);
        Quadratic2d::entropy_gradient(&y, &centred, &mut gy);
        for (a, b) in gx.iter().zip(&gy) {
            assert!((a - b).abs() <= 1e-9 * (1.0 + a.abs()), "{a} vs {b}");
        }
    }

    /// The metric (constant included) takes the same values at x and y,
    /// for every entry pair.
    #[test]
    fn the_metric_takes_the_same_values() {
        let centre = vec![-7.0, 40.0];
        let shift = Shift::new(Quadratic2d::METRIC_EXPONENTS, centre).unwrap();
        let theta: Vec<f64> = (0..Quadratic2d::metric_coefficient_count())
            .map(|k| (k as f64 * 0.37).sin())
            .collect();
        let centred = shift.to_centred(&theta);
        let x = [-6.0, 41.5];
        let mut y = [0.0; 2];
        shift.centred_state(&x, &mut y);
        let (mut kx, mut ky) = ([0.0; 4], [0.0; 4]);
        Quadratic2d::metric_value(&x, &theta, &mut kx);
        Quadratic2d::metric_value(&y, &centred, &mut ky);
        for (a, b) in kx.iter().zip(&ky) {
            assert!((a - b).abs() <= 1e-9 * (1.0 + a.abs()), "{a} vs {b}");
        }
    }

    /// A row on coefficients in x, rewritten on y, takes the same value;
    /// entries outside the coefficients' columns are kept.
    #[test]
    fn rewritten_rows_take_the_same_values() {
        let shift = Shift::new(Quadratic2d::ENTROPY_EXPONENTS, vec![4.0, 1.0]).unwrap();
        let centred = [0.5, 2.0, -1.0, 0.125, 3.0];
        let psi = shift.to_original(&centred);
        let entries = vec![(0, 2 + 3, 1.0), (0, 2 + 1, -2.0), (1, 0, 7.0), (1, 7, 1.0)];
        let rewritten = shift.rows(entries, 2, 5);
        let value: f64 = rewritten
            .iter()
            .filter(|e| e.0 == 0)
            .map(|&(_, c, v)| v * centred[c - 2])
            .sum();
        assert!((value - (psi[3] - 2.0 * psi[1])).abs() < 1e-12);
        assert!(rewritten.contains(&(1, 0, 7.0)) && rewritten.contains(&(1, 7, 1.0)));
    }

    /// Only intervals farther from zero than their width are centred.
    #[test]
    fn only_intervals_far_from_zero_are_centred() {
        assert_eq!(
            far_centre(&[298.0, -1.0], &[302.0, 2.0]),
            Some(vec![300.0, 0.0])
        );
        assert_eq!(far_centre(&[-1.0, 1.0], &[2.0, 3.0]), None);
        assert_eq!(far_centre(&[-12.0], &[-10.0]), Some(vec![-11.0]));
        assert_eq!(far_centre(&[f64::NAN], &[1.0]), None);
    }

    #[test]
    fn a_basis_missing_a_lower_power_has_no_shift() {
        let exponents: &[&[u32]] = &[&[0, 0], &[2, 0]];
        assert!(Shift::new(exponents, vec![1.0, 0.0]).is_none());
    }
}
