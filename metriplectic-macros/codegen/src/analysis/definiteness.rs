//! Exact positive semidefiniteness of a constant symmetric matrix.
//!
//! Symmetric elimination (LDLᵀ with diagonal pivoting) over the rationals:
//! pivot on a positive diagonal entry and take the Schur complement, until
//! a negative diagonal entry or a zero diagonal with a non-zero off-diagonal
//! entry shows the matrix indefinite, or nothing is left. Every step is
//! exact, so the verdict is a proof; an indefinite matrix comes with a
//! witness y (integer entries) and yᵀAy < 0, found by back-substitution
//! through the eliminated pivots.

use crate::polynomial::{Exact, Overflow, Rational};

/// The verdict on a symmetric matrix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Definiteness {
    /// yᵀAy ≥ 0 for every y.
    Semidefinite,
    /// yᵀAy = `value` < 0 for y = `witness`.
    Indefinite {
        /// The vector y, with coprime integer entries.
        witness: Vec<Rational>,
        /// yᵀAy.
        value: Rational,
    },
}

/// Decides whether the symmetric n×n matrix `a` (row-major) is positive
/// semidefinite, exactly. `Err` if 128-bit rational arithmetic overflowed.
pub fn semidefinite(a: &[Rational], n: usize) -> Exact<Definiteness> {
    if a.len() != n * n {
        return Err(Overflow);
    }
    // The simplest witnesses first, which read well: a unit vector on a
    // negative diagonal entry, or e_i ∓ e_j on a 2×2 block with
    // a_ii + a_jj < 2|a_ij|.
    for i in 0..n {
        if is_negative(a[i * n + i]) {
            return indefinite(a, n, unit(n, i, None));
        }
    }
    for i in 0..n {
        for j in i + 1..n {
            let off = a[i * n + j];
            let twice = off.add(off)?;
            let sum = a[i * n + i].add(a[j * n + j])?;
            let value = if is_negative(off) {
                sum.add(twice)?
            } else {
                sum.add(negate(twice)?)?
            };
            if is_negative(value) {
                return indefinite(a, n, unit(n, i, Some((j, off))));
            }
        }
    }
    eliminate(a, n)
}

fn eliminate(a: &[Rational], n: usize) -> Exact<Definiteness> {
    let mut m = a.to_vec();
    let mut active = vec![true; n];
    // (pivot, its row at the time it was eliminated), for back-substitution.
    let mut steps: Vec<(usize, Vec<Rational>)> = Vec::new();
    let z = loop {
        let remaining: Vec<usize> = (0..n).filter(|&i| active[i]).collect();
        if let Some(&i) = remaining.iter().find(|&&i| is_negative(m[i * n + i])) {
            break unit(n, i, None);
        }
        if let Some(&p) = remaining.iter().find(|&&p| !m[p * n + p].is_zero()) {
            let pivot = m[p * n + p];
            let row: Vec<Rational> = m[p * n..(p + 1) * n].to_vec();
            for &i in remaining.iter().filter(|&&i| i != p) {
                let factor = m[i * n + p].div(pivot)?.ok_or(Overflow)?;
                for &j in remaining.iter().filter(|&&j| j != p) {
                    m[i * n + j] = m[i * n + j].add(negate(factor.mul(row[j])?)?)?;
                }
            }
            active[p] = false;
            steps.push((p, row));
            continue;
        }
        // Every remaining diagonal entry is zero: semidefinite only if the
        // remaining block is zero.
        let pair = remaining.iter().find_map(|&i| {
            remaining
                .iter()
                .find(|&&j| j != i && !m[i * n + j].is_zero())
                .map(|&j| (i, j))
        });
        match pair {
            Some((i, j)) => break unit(n, i, Some((j, m[i * n + j]))),
            None => return Ok(Definiteness::Semidefinite),
        }
    };
    // y on the eliminated pivots makes each eliminated square vanish, so
    // yᵀAy equals the value of z on the Schur complement.
    let mut y = z;
    let mut known = active;
    for (p, row) in steps.iter().rev() {
        let mut sum = Rational::ZERO;
        for j in (0..n).filter(|&j| known[j] && j != *p) {
            sum = sum.add(row[j].mul(y[j])?)?;
        }
        y[*p] = negate(sum)?.div(row[*p])?.ok_or(Overflow)?;
        known[*p] = true;
    }
    indefinite(a, n, y)
}

/// e_i, or e_i − sign(a_ij) e_j for a pair.
fn unit(n: usize, i: usize, pair: Option<(usize, Rational)>) -> Vec<Rational> {
    let mut y = vec![Rational::ZERO; n];
    y[i] = Rational::ONE;
    if let Some((j, off)) = pair {
        y[j] = if is_negative(off) {
            Rational::ONE
        } else {
            Rational::integer(-1)
        };
    }
    y
}

/// The witness scaled to coprime integers, with its exact yᵀAy.
fn indefinite(a: &[Rational], n: usize, y: Vec<Rational>) -> Exact<Definiteness> {
    let lcm = y.iter().try_fold(1i128, |l, r| {
        let d = r.denominator();
        let g = gcd(l, d);
        (l / g).checked_mul(d).ok_or(Overflow)
    })?;
    let mut scaled = Vec::with_capacity(n);
    for r in &y {
        scaled.push(r.mul(Rational::integer(lcm))?);
    }
    let g = scaled
        .iter()
        .fold(0i128, |g, r| gcd(g, r.numerator()))
        .max(1);
    let witness: Vec<Rational> = scaled
        .iter()
        .map(|r| Rational::integer(r.numerator() / g))
        .collect();
    let mut value = Rational::ZERO;
    for i in 0..n {
        for j in 0..n {
            value = value.add(witness[i].mul(a[i * n + j])?.mul(witness[j])?)?;
        }
    }
    Ok(Definiteness::Indefinite { witness, value })
}

fn is_negative(r: Rational) -> bool {
    r.numerator() < 0
}

fn negate(r: Rational) -> Exact<Rational> {
    r.mul(Rational::integer(-1))
}

fn gcd(a: i128, b: i128) -> i128 {
    let (mut a, mut b) = (a.unsigned_abs(), b.unsigned_abs());
    while b != 0 {
        (a, b) = (b, a % b);
    }
    i128::try_from(a).unwrap_or(i128::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn matrix(entries: &[i128]) -> Vec<Rational> {
        entries.iter().map(|&k| Rational::integer(k)).collect()
    }

    fn verdict(entries: &[i128]) -> Definiteness {
        let n = (entries.len() as f64).sqrt() as usize;
        semidefinite(&matrix(entries), n).unwrap()
    }

    fn ints(v: &[Rational]) -> Vec<i128> {
        v.iter().map(|r| r.numerator()).collect()
    }

    #[test]
    fn simple_witnesses() {
        assert_eq!(
            verdict(&[1, 2, 2, 1]),
            Definiteness::Indefinite {
                witness: matrix(&[1, -1]),
                value: Rational::integer(-2)
            }
        );
        assert_eq!(
            verdict(&[1, 0, 0, -3]),
            Definiteness::Indefinite {
                witness: matrix(&[0, 1]),
                value: Rational::integer(-3)
            }
        );
    }

    #[test]
    fn semidefinite_matrices() {
        assert_eq!(verdict(&[1, 0, 0, 1]), Definiteness::Semidefinite);
        assert_eq!(verdict(&[2]), Definiteness::Semidefinite);
        assert_eq!(verdict(&[0, 0, 0, 0]), Definiteness::Semidefinite);
        // Rank one: (1, 2)(1, 2)ᵀ.
        assert_eq!(verdict(&[1, 2, 2, 4]), Definiteness::Semidefinite);
        assert_eq!(verdict(&[1, 1, 1, 2]), Definiteness::Semidefinite);
        // Zero pivot with a zero row and column is fine.
        assert_eq!(
            verdict(&[0, 0, 0, 0, 1, 1, 0, 1, 1]),
            Definiteness::Semidefinite
        );
    }

    #[test]
    fn zero_pivot_with_off_diagonal_is_indefinite() {
        // [[0, 1], [1, 0]]: the pair witness (1, -1) gives -2.
        let Definiteness::Indefinite { value, .. } = verdict(&[0, 1, 1, 0]) else {
            panic!("indefinite");
        };
        assert!(value.numerator() < 0);
        // Zero diagonal entry hidden behind a positive pivot: 2×2 blocks are
        // all fine, elimination finds it.
        let m = [1, 1, 1, 1, 1, 2, 1, 2, 1];
        let Definiteness::Indefinite { witness, value } = verdict(&m) else {
            panic!("indefinite");
        };
        assert!(value.numerator() < 0, "{value}");
        let y = ints(&witness);
        let direct: i128 = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .map(|(i, j)| y[i] * m[i * 3 + j] * y[j])
            .sum();
        assert_eq!(Rational::integer(direct), value);
    }

    #[test]
    fn overflow_is_reported() {
        let big = i128::MAX / 3;
        let m = matrix(&[1, big, big, 1]);
        assert!(matches!(
            semidefinite(&m, 2),
            Err(Overflow) | Ok(Definiteness::Indefinite { .. })
        ));
        assert_eq!(semidefinite(&matrix(&[1, 2, 3]), 2), Err(Overflow));
    }

    proptest! {
        /// The verdict agrees with the sign of yᵀAy on the witness, and with
        /// Gram matrices BᵀB (always semidefinite) shifted by −c·I.
        #[test]
        fn verdicts_are_right(
            b in prop::collection::vec(-4i128..=4, 9),
            shift in 0i128..4,
        ) {
            let n = 3;
            let mut a = vec![0i128; 9];
            for i in 0..n {
                for j in 0..n {
                    a[i * n + j] = (0..n).map(|k| b[k * n + i] * b[k * n + j]).sum();
                }
            }
            prop_assert_eq!(verdict(&a), Definiteness::Semidefinite);
            for i in 0..n {
                a[i * n + i] -= shift;
            }
            let eigen_min_nonneg = {
                // Brute force over small integer vectors: a negative value proves indefinite.
                let mut found = false;
                for y0 in -6i128..=6 { for y1 in -6i128..=6 { for y2 in -6i128..=6 {
                    let y = [y0, y1, y2];
                    let v: i128 = (0..n).flat_map(|i| (0..n).map(move |j| (i, j)))
                        .map(|(i, j)| y[i] * a[i * n + j] * y[j]).sum();
                    found |= v < 0;
                }}}
                !found
            };
            match verdict(&a) {
                Definiteness::Semidefinite => prop_assert!(eigen_min_nonneg),
                Definiteness::Indefinite { witness, value } => {
                    let y = ints(&witness);
                    let v: i128 = (0..n).flat_map(|i| (0..n).map(move |j| (i, j)))
                        .map(|(i, j)| y[i] * a[i * n + j] * y[j]).sum();
                    prop_assert!(v < 0);
                    prop_assert_eq!(Rational::integer(v), value);
                }
            }
        }
    }
}
