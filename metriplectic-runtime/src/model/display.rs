//! A model printed as equations with the state names.

use std::fmt;

use super::Model;
use crate::system::{metric_pair_index, MetriplecticSystem};

/// Coefficients smaller than this fraction of the largest in their
/// polynomial are left out of the printed equations (they are kept in the
/// model).
const PRINT_THRESHOLD: f64 = 1e-10;

impl<S: MetriplecticSystem> fmt::Display for Model<S> {
    /// The entropy and the metric as polynomials in the state names, and the
    /// form of the dynamics; six significant digits unless a precision is
    /// given (`{:.10}`).
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
    /// #     reference { entropy = -(x^2 + y^2); metric = [[1, 0], [0, 1]]; }
    /// # }
    /// let text = Model::<Decay>::reference()?.to_string();
    /// assert!(text.contains("S(x, y) = -x^2 - y^2"), "{text}");
    /// assert!(text.contains("K(x, y) = [[1, 0], [0, 1]]"), "{text}");
    /// # Ok::<(), metriplectic_runtime::Error>(())
    /// ```
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let digits = f.precision().unwrap_or(6);
        let names = S::STATE_NAMES;
        let arguments = names.join(", ");
        writeln!(
            f,
            "S({arguments}) = {}",
            polynomial(
                names,
                S::ENTROPY_EXPONENTS,
                self.entropy_coefficients(),
                digits
            )
        )?;
        let n = S::DIM;
        let basis = S::METRIC_EXPONENTS.len();
        let rows: Vec<String> = (0..n)
            .map(|j| {
                let entries: Vec<String> = (0..n)
                    .map(|k| {
                        let pair = metric_pair_index(n, j, k);
                        polynomial(
                            names,
                            S::METRIC_EXPONENTS,
                            &self.metric_coefficients()[pair * basis..(pair + 1) * basis],
                            digits,
                        )
                    })
                    .collect();
                format!("[{}]", entries.join(", "))
            })
            .collect();
        writeln!(f, "K({arguments}) = [{}]", rows.join(", "))?;
        if S::CLASSICAL.is_some() {
            write!(
                f,
                "d({arguments})/dt = Π ∇H + K ∇S (classical form: Π∇S ≡ 0, K∇H ≡ 0), with Π \
                 and H of system `{}`",
                S::NAME
            )
        } else {
            write!(
                f,
                "d({arguments})/dt = (Π + K) ∇(H + S), with Π and H of system `{}`",
                S::NAME
            )
        }
    }
}

/// Σ cₖ x^αₖ as text, e.g. `-0.5 q^2 + 4 q^2 p^2`; `0` when every term is
/// negligible.
pub(crate) fn polynomial(
    names: &[&str],
    exponents: &[&[u32]],
    coefficients: &[f64],
    digits: usize,
) -> String {
    let largest = coefficients.iter().fold(0.0_f64, |m, c| m.max(c.abs()));
    let mut text = String::new();
    for (alpha, &c) in exponents.iter().zip(coefficients) {
        if c == 0.0 || c.abs() < PRINT_THRESHOLD * largest {
            continue;
        }
        let magnitude = number(c.abs(), digits);
        let monomial: Vec<String> = names
            .iter()
            .zip(alpha.iter())
            .filter(|(_, &power)| power > 0)
            .map(|(name, &power)| {
                if power == 1 {
                    (*name).to_owned()
                } else {
                    format!("{name}^{power}")
                }
            })
            .collect();
        let term = match (monomial.is_empty(), magnitude.as_str()) {
            (true, _) => magnitude,
            (false, "1") => monomial.join(" "),
            (false, _) => format!("{magnitude} {}", monomial.join(" ")),
        };
        if text.is_empty() {
            if c < 0.0 {
                text.push('-');
            }
        } else {
            text.push_str(if c < 0.0 { " - " } else { " + " });
        }
        text.push_str(&term);
    }
    if text.is_empty() {
        text.push('0');
    }
    text
}

/// A number with `digits` significant digits, without trailing zeros.
fn number(value: f64, digits: usize) -> String {
    let text = format!("{:.*e}", digits.saturating_sub(1), value);
    let Some((mantissa, exponent)) = text.split_once('e') else {
        return text;
    };
    let exponent: i32 = exponent.parse().unwrap_or(0);
    if (-4..=6).contains(&exponent) {
        let decimals = (digits as i32 - 1 - exponent).max(0) as usize;
        let plain = format!("{value:.decimals$}");
        let plain = if plain.contains('.') {
            plain.trim_end_matches('0').trim_end_matches('.').to_owned()
        } else {
            plain
        };
        plain
    } else {
        let mantissa = if mantissa.contains('.') {
            mantissa.trim_end_matches('0').trim_end_matches('.')
        } else {
            mantissa
        };
        format!("{mantissa}e{exponent}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_and_polynomials() {
        assert_eq!(number(0.5, 6), "0.5");
        assert_eq!(number(16.0, 6), "16");
        assert_eq!(number(1.0 / 3.0, 4), "0.3333");
        assert_eq!(number(1.5e-7, 6), "1.5e-7");
        assert_eq!(number(2.5e9, 6), "2.5e9");
        let text = polynomial(
            &["q", "p"],
            &[&[1, 0], &[0, 1], &[2, 1]],
            &[-0.5, 0.0, 4.0],
            6,
        );
        assert_eq!(text, "-0.5 q + 4 q^2 p");
        assert_eq!(polynomial(&["q"], &[&[1]], &[0.0], 6), "0");
        // A term far below the largest is not printed.
        let text = polynomial(&["q"], &[&[1], &[2]], &[1.0, 1e-13], 6);
        assert_eq!(text, "q");
    }
}
