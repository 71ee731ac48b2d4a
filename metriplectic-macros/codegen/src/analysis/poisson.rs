//! Π must be a Poisson tensor: skew-symmetric and satisfying the Jacobi
//! identity, both decided exactly.

use super::scope::exact;
use super::work::{product, MAX_TERM_PRODUCTS, SHOWN_TERMS};
use crate::diagnostics::Diagnostics;
use crate::parse::{Matrix, SpanRange};
use crate::polynomial::{Overflow, Polynomial, Rational};

/// Checks that Π is skew-symmetric, reporting every offending entry pair;
/// whether it is.
pub fn check_skew(
    poisson: &[Polynomial],
    matrix: &Matrix,
    names: &[String],
    diagnostics: &mut Diagnostics,
) -> bool {
    let n = names.len();
    let mut skew = true;
    for i in 0..n {
        let diagonal = &poisson[i * n + i];
        if !diagonal.is_zero() {
            skew = false;
            diagnostics.push(matrix.entry_span(i, i).error(format!(
                "Π must be skew-symmetric, so its diagonal is zero: Π[{i}][{i}] (row and column \
                 `{}`) is `{}`; write 0",
                names[i],
                diagonal.display_at_most(names, SHOWN_TERMS)
            )));
        }
        for j in i + 1..n {
            let upper = &poisson[i * n + j];
            let lower = &poisson[j * n + i];
            let span = matrix.entry_span(i, j).to(matrix.entry_span(j, i));
            let Some(sum) = exact(upper.add(lower), span, diagnostics) else {
                skew = false;
                continue;
            };
            if sum.is_zero() {
                continue;
            }
            skew = false;
            let Some(negated) = exact(upper.neg(), span, diagnostics) else {
                continue;
            };
            diagnostics.push(span.error(format!(
                "Π must be skew-symmetric, but Π[{i}][{j}] (row `{}`, column `{}`) is `{}` and \
                 Π[{j}][{i}] is `{}`; write Π[{j}][{i}] = `{}`",
                names[i],
                names[j],
                upper.display_at_most(names, SHOWN_TERMS),
                lower.display_at_most(names, SHOWN_TERMS),
                negated.display_at_most(names, SHOWN_TERMS)
            )));
        }
    }
    skew
}

/// The Jacobiator Σ_l (Π_il ∂_l Π_jk + Π_jl ∂_l Π_ki + Π_kl ∂_l Π_ij).
pub fn jacobiator(
    poisson: &[Polynomial],
    n: usize,
    (i, j, k): (usize, usize, usize),
    derivatives: &[Vec<Polynomial>],
) -> Result<Polynomial, Overflow> {
    // derivatives[l][a * n + b] = ∂_l Π_ab
    let mut sum = Polynomial::zero(n);
    for (l, d) in derivatives.iter().enumerate() {
        for (a, b, c) in [(i, j, k), (j, k, i), (k, i, j)] {
            let term = poisson[a * n + l].mul(&d[b * n + c])?;
            sum = sum.add(&term)?;
        }
    }
    Ok(sum)
}

/// Term products of every Jacobiator with i < j < k
/// (`derivatives[l][b * n + c]` = ∂_l Π_bc).
fn jacobi_work(poisson: &[Polynomial], derivatives: &[Vec<Polynomial>], n: usize) -> u64 {
    let mut work = 0_u64;
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                for (a, b, c) in [(i, j, k), (j, k, i), (k, i, j)] {
                    for (l, d) in derivatives.iter().enumerate() {
                        work = work.saturating_add(product(&poisson[a * n + l], &d[b * n + c]));
                    }
                }
            }
        }
    }
    work
}

/// Checks the Jacobi identity exactly for a skew Π, reporting the first
/// violation (one is enough to show Π is not a Poisson tensor).
pub fn check_jacobi(
    poisson: &[Polynomial],
    matrix: &Matrix,
    names: &[String],
    diagnostics: &mut Diagnostics,
) {
    let n = names.len();
    let span = SpanRange::single(matrix.span);
    // The Jacobiator is quadratic in Π, so Π divided by one of its
    // coefficients c violates the identity exactly where Π does, by 1/c²
    // of it: coefficients such as 1e-20, whose products (1e-40) leave
    // 128-bit rationals, become ratios of order one (a probe's scaled
    // Nambu bracket was refused as an overflow).
    let unit = poisson
        .iter()
        .find_map(|p| p.terms().next().map(|(_, c)| c));
    let normalised = unit
        .and_then(|c| Rational::ONE.div(c).ok().flatten())
        .and_then(|inverse| {
            poisson
                .iter()
                .map(|p| p.scale(inverse))
                .collect::<Result<Vec<_>, _>>()
                .ok()
        });
    let (poisson, unit) = match (&normalised, unit) {
        (Some(normalised), Some(unit)) => (normalised.as_slice(), unit),
        _ => (poisson, Rational::ONE),
    };
    let overflow = |_: Overflow| {
        span.error(
            "checking the Jacobi identity exactly overflowed 128-bit rationals (in products of \
             Π's entries and their derivatives); write Π's coefficients with fewer digits, or \
             rescale the state variables",
        )
    };
    let derivatives = (0..n)
        .map(|l| {
            poisson
                .iter()
                .map(|p| p.derivative(l))
                .collect::<Result<Vec<_>, _>>()
        })
        .collect::<Result<Vec<_>, _>>();
    let Some(derivatives) = diagnostics.record(derivatives.map_err(overflow)) else {
        return;
    };
    let work = jacobi_work(poisson, &derivatives, n);
    if work > MAX_TERM_PRODUCTS {
        let largest = poisson
            .iter()
            .map(Polynomial::term_count)
            .max()
            .unwrap_or(0);
        diagnostics.push(span.error(format!(
            "checking the Jacobi identity exactly would take {work} products of terms, more \
             than the {MAX_TERM_PRODUCTS} supported (Π's largest entry has {largest} terms); \
             write Π with fewer terms"
        )));
        return;
    }
    // For skew Π the Jacobiator is totally antisymmetric: i < j < k suffices.
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let value = jacobiator(poisson, n, (i, j, k), &derivatives);
                let Some(value) = diagnostics.record(value.map_err(overflow)) else {
                    return;
                };
                if !value.is_zero() {
                    // The violation of Π itself, c² times the normalised one.
                    let shown = unit
                        .mul(unit)
                        .and_then(|square| value.scale(square))
                        .map(|value| format!("`{}`", value.display_at_most(names, SHOWN_TERMS)))
                        .unwrap_or_else(|_| {
                            format!(
                                "({})² × `{}`",
                                unit,
                                value.display_at_most(names, SHOWN_TERMS)
                            )
                        });
                    diagnostics.push(span.error(format!(
                        "Π is skew-symmetric but violates the Jacobi identity, so it is not a \
                         Poisson tensor: for (i, j, k) = ({}, {}, {}) (indices {i}, {j}, {k}), \
                         Σ_l (Π_il ∂_l Π_jk + Π_jl ∂_l Π_ki + Π_kl ∂_l Π_ij) = {shown}, not 0; \
                         use a Poisson tensor such as a constant skew matrix or a Lie–Poisson \
                         tensor (for so(3): [[0, -z, y], [z, 0, -x], [-y, x, 0]])",
                        names[i], names[j], names[k],
                    )));
                    return;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::scope::tests::poly;

    /// Π from text rows, then whether every Jacobiator vanishes.
    fn is_poisson(rows: &[&str], names: &[&str]) -> bool {
        let n = names.len();
        let entries: Vec<Polynomial> = rows.iter().map(|t| poly(t, names).unwrap()).collect();
        assert_eq!(entries.len(), n * n);
        let derivatives: Vec<Vec<Polynomial>> = (0..n)
            .map(|l| entries.iter().map(|p| p.derivative(l).unwrap()).collect())
            .collect();
        let mut ok = true;
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    ok &= jacobiator(&entries, n, (i, j, k), &derivatives)
                        .unwrap()
                        .is_zero();
                }
            }
        }
        ok
    }

    /// Coefficients whose products leave 128-bit rationals: a Nambu
    /// bracket scaled by 1e-20 is a Poisson tensor (it was refused as an
    /// overflow; a probe), and a scaled tensor that is not one is still
    /// refused, with its violation in Π's own units.
    #[test]
    fn tensors_with_tiny_coefficients_are_checked_exactly() {
        let expand = |poisson: proc_macro2::TokenStream| {
            crate::try_expand(quote::quote! {
                struct S; state (x, y, z); const s = 1e-20; poisson = #poisson;
                hamiltonian = x^2 + y^2 + z^2; entropy degree 2; metric degree 0;
            })
        };
        let nambu = quote::quote!([
            [0, s * z ^ 2, -s * x ^ 2],
            [-s * z ^ 2, 0, 2 * s * x * y],
            [s * x ^ 2, -2 * s * x * y, 0]
        ]);
        assert!(expand(nambu).is_ok());
        let so3 = quote::quote!([[0, -s * z, s * y], [s * z, 0, -s * x], [-s * y, s * x, 0]]);
        assert!(expand(so3).is_ok());
        let not_poisson = quote::quote!([[0, s, -s * x], [-s, 0, 0], [s * x, 0, 0]]);
        let messages = expand(not_poisson).expect_err("not Poisson").messages();
        assert!(
            messages[0].contains("violates the Jacobi identity")
                && messages[0].contains("× `-1`, not 0"),
            "{messages:?}"
        );
        let small = quote::quote!([[0, 1e-10, -1e-10 * x], [-1e-10, 0, 0], [1e-10 * x, 0, 0]]);
        let messages = crate::try_expand(quote::quote! {
            struct S; state (x, y, z); poisson = #small;
            hamiltonian = x^2; entropy degree 2; metric degree 0;
        })
        .expect_err("not Poisson")
        .messages();
        assert!(
            messages[0].contains("= `-0.00000000000000000001`, not 0"),
            "{messages:?}"
        );
    }

    #[test]
    fn jacobi_identity_on_known_tensors() {
        assert!(is_poisson(&["0", "1", "-1", "0"], &["q", "p"]));
        let canonical_4d = [
            "0", "0", "1", "0", //
            "0", "0", "0", "1", //
            "-1", "0", "0", "0", //
            "0", "-1", "0", "0",
        ];
        assert!(is_poisson(&canonical_4d, &["q1", "q2", "p1", "p2"]));
        let so3 = ["0", "-z", "y", "z", "0", "-x", "-y", "x", "0"];
        assert!(is_poisson(&so3, &["x", "y", "z"]));
        // Skew but not Poisson: Π_ij = ε_ijk v_k with v = (0, x, 1), v·curl v = 1.
        let not_poisson = ["0", "1", "-x", "-1", "0", "0", "x", "0", "0"];
        assert!(!is_poisson(&not_poisson, &["x", "y", "z"]));
        // [[0, z, 0], [-z, 0, x], [0, -x, 0]] looks suspicious but is Poisson:
        // v = (x, 0, z) is a gradient, so v·curl v = 0.
        let curl_free = ["0", "z", "0", "-z", "0", "x", "0", "-x", "0"];
        assert!(is_poisson(&curl_free, &["x", "y", "z"]));
    }
}
