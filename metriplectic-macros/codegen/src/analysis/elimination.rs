//! Exact sparse Gaussian elimination over the rationals: the reduced row
//! echelon form (RREF) of a system of linear equations and a basis of its
//! null space, for the classical form's identities.
//!
//! Rows are sparse maps from column to a non-zero coefficient. The echelon
//! form is kept fully reduced as rows arrive: every pivot row has leading
//! coefficient 1 and is zero in every other pivot column. Work is counted
//! against a budget, so that a huge system is an error, not a compile that
//! never ends.

use std::cmp::Ordering;
use std::collections::BTreeMap;

use crate::polynomial::{Overflow, Rational};

/// A sparse row: column → non-zero coefficient.
pub type Row = BTreeMap<usize, Rational>;

/// Why elimination stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failure {
    /// 128-bit rational arithmetic overflowed.
    Overflow,
    /// More than the budget's rational operations were needed.
    TooLarge,
}

impl From<Overflow> for Failure {
    fn from(_: Overflow) -> Self {
        Failure::Overflow
    }
}

/// A reduced row echelon form, built row by row.
#[derive(Debug, Clone)]
pub struct Echelon {
    /// Pivot column → its row (coefficient 1 there, 0 in other pivot columns).
    rows: BTreeMap<usize, Row>,
    /// Rational operations left.
    budget: u64,
}

impl Echelon {
    /// An empty system that may spend `budget` rational operations.
    pub fn new(budget: u64) -> Echelon {
        Echelon {
            rows: BTreeMap::new(),
            budget,
        }
    }

    fn spend(&mut self, operations: usize) -> Result<(), Failure> {
        let operations = u64::try_from(operations).unwrap_or(u64::MAX);
        self.budget = self
            .budget
            .checked_sub(operations)
            .ok_or(Failure::TooLarge)?;
        Ok(())
    }

    /// Adds an equation; the form stays fully reduced.
    pub fn insert(&mut self, row: Row) -> Result<(), Failure> {
        let mut row: Row = row.into_iter().filter(|(_, c)| !c.is_zero()).collect();
        // Clear every pivot column of the new row, left to right: a pivot
        // row only has entries right of its pivot, so no cleared column
        // fills in again.
        let mut from = 0;
        while let Some((column, factor)) = row
            .range(from..)
            .find(|(c, _)| self.rows.contains_key(c))
            .map(|(c, v)| (*c, *v))
        {
            let pivot = self.rows.get(&column).cloned().unwrap_or_default();
            self.spend(pivot.len())?;
            subtract(&mut row, factor, &pivot)?;
            from = column + 1;
        }
        let Some((&lead, &value)) = row.iter().next() else {
            return Ok(());
        };
        self.spend(row.len())?;
        let inverse = Rational::ONE.div(value)?.ok_or(Failure::Overflow)?;
        for coefficient in row.values_mut() {
            *coefficient = coefficient.mul(inverse)?;
        }
        // Clear the new pivot column from the older rows.
        let mut cost = 0;
        for other in self.rows.values_mut() {
            if let Some(&factor) = other.get(&lead) {
                cost += row.len();
                subtract(other, factor, &row)?;
            }
        }
        self.spend(cost)?;
        self.rows.insert(lead, row);
        Ok(())
    }

    /// Number of independent equations.
    pub fn rank(&self) -> usize {
        self.rows.len()
    }

    /// The rows in order of their pivot columns.
    pub fn rows(&self) -> impl Iterator<Item = &Row> + '_ {
        self.rows.values()
    }

    /// A basis of the null space among `columns` unknowns: one vector per
    /// free (non-pivot) column f, with 1 at f and −R[r][f] at the pivot of
    /// each row r, in order of f.
    pub fn null_space(&self, columns: usize) -> Result<Vec<Row>, Failure> {
        let mut vectors: BTreeMap<usize, Row> = (0..columns)
            .filter(|c| !self.rows.contains_key(c))
            .map(|c| (c, Row::from([(c, Rational::ONE)])))
            .collect();
        for (&pivot, row) in &self.rows {
            for (&column, &value) in row.range(pivot + 1..) {
                if let Some(vector) = vectors.get_mut(&column) {
                    vector.insert(pivot, value.neg()?);
                }
            }
        }
        Ok(vectors.into_values().collect())
    }
}

/// `row -= factor · pivot`, dropping zeros.
fn subtract(row: &mut Row, factor: Rational, pivot: &Row) -> Result<(), Failure> {
    for (&column, &value) in pivot {
        let delta = factor.mul(value)?;
        let updated = row
            .get(&column)
            .copied()
            .unwrap_or(Rational::ZERO)
            .sub(delta)?;
        if updated.is_zero() {
            row.remove(&column);
        } else {
            row.insert(column, updated);
        }
    }
    Ok(())
}

/// Compares |a| and |b|: exactly when the cross products fit in 128 bits,
/// else in floating point (only scale factors depend on it).
pub fn cmp_magnitude(a: Rational, b: Rational) -> Ordering {
    let left = a
        .numerator()
        .unsigned_abs()
        .checked_mul(b.denominator().unsigned_abs());
    let right = b
        .numerator()
        .unsigned_abs()
        .checked_mul(a.denominator().unsigned_abs());
    match (left, right) {
        (Some(l), Some(r)) => l.cmp(&r),
        _ => a
            .to_f64()
            .abs()
            .partial_cmp(&b.to_f64().abs())
            .unwrap_or(Ordering::Equal),
    }
}

/// The row divided by its entry of largest magnitude (so max |c| = 1).
pub fn scale_to_unit(row: &Row) -> Result<Vec<(usize, Rational)>, Failure> {
    let Some(largest) = row.values().copied().max_by(|a, b| cmp_magnitude(*a, *b)) else {
        return Ok(Vec::new());
    };
    let magnitude = if largest.numerator() < 0 {
        largest.neg()?
    } else {
        largest
    };
    row.iter()
        .map(|(&c, &v)| Ok((c, v.div(magnitude)?.ok_or(Failure::Overflow)?)))
        .collect()
}

/// The row scaled to coprime integers with the sign of its last entry
/// positive (readable polynomials: `x^2 + y^2 + z^2`).
pub fn scale_to_integers(row: &Row) -> Result<Vec<(usize, Rational)>, Failure> {
    let lcm = row.values().try_fold(1i128, |l, r| {
        let d = r.denominator();
        let g = gcd(l, d).max(1);
        (l / g).checked_mul(d).ok_or(Failure::Overflow)
    })?;
    let mut scaled = Vec::with_capacity(row.len());
    for (&c, &v) in row {
        scaled.push((c, v.mul(Rational::integer(lcm))?));
    }
    let g = scaled
        .iter()
        .fold(0i128, |g, (_, r)| gcd(g, r.numerator()))
        .max(1);
    let negative = scaled.last().is_some_and(|(_, r)| r.numerator() < 0);
    let divisor = Rational::integer(if negative { -g } else { g });
    scaled
        .into_iter()
        .map(|(c, v)| Ok((c, v.div(divisor)?.ok_or(Failure::Overflow)?)))
        .collect()
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

    fn row(entries: &[(usize, i128)]) -> Row {
        entries
            .iter()
            .map(|&(c, v)| (c, Rational::integer(v)))
            .collect()
    }

    fn dot(a: &Row, b: &Row) -> Rational {
        a.iter().fold(Rational::ZERO, |sum, (c, v)| {
            let w = b.get(c).copied().unwrap_or(Rational::ZERO);
            sum.add(v.mul(w).unwrap()).unwrap()
        })
    }

    #[test]
    fn rank_and_null_space_of_a_small_system() {
        // x + y + z = 0, 2x + 2y + 2z = 0, y − z = 0: rank 2, null (−2, 1, 1).
        let mut echelon = Echelon::new(1000);
        for r in [
            row(&[(0, 1), (1, 1), (2, 1)]),
            row(&[(0, 2), (1, 2), (2, 2)]),
            row(&[(1, 1), (2, -1)]),
        ] {
            echelon.insert(r).unwrap();
        }
        assert_eq!(echelon.rank(), 2);
        let null = echelon.null_space(3).unwrap();
        assert_eq!(null.len(), 1);
        assert_eq!(
            scale_to_integers(&null[0])
                .unwrap()
                .iter()
                .map(|(c, v)| (*c, v.numerator()))
                .collect::<Vec<_>>(),
            vec![(0, -2), (1, 1), (2, 1)]
        );
    }

    #[test]
    fn budget_is_enforced() {
        let mut echelon = Echelon::new(3);
        echelon.insert(row(&[(0, 1), (1, 1)])).unwrap();
        assert_eq!(
            echelon.insert(row(&[(0, 1), (1, 2), (2, 3)])),
            Err(Failure::TooLarge)
        );
    }

    #[test]
    fn unit_scaling() {
        let scaled = scale_to_unit(&row(&[(0, 2), (3, -4)])).unwrap();
        assert_eq!(scaled[0].1, Rational::new(1, 2).unwrap().unwrap());
        assert_eq!(scaled[1].1, Rational::integer(-1));
    }

    proptest! {
        /// The null space is orthogonal to every equation, has dimension
        /// columns − rank, and the echelon rows are reduced.
        #[test]
        fn null_space_solves_the_system(
            rows in prop::collection::vec(prop::collection::vec(-3i128..=3, 5), 0..7),
        ) {
            let mut echelon = Echelon::new(1_000_000);
            let original: Vec<Row> = rows
                .iter()
                .map(|r| r.iter().enumerate().map(|(c, &v)| (c, Rational::integer(v))).collect())
                .collect();
            for r in &original {
                echelon.insert(r.clone()).unwrap();
            }
            let null = echelon.null_space(5).unwrap();
            prop_assert_eq!(null.len(), 5 - echelon.rank());
            for v in &null {
                for r in &original {
                    prop_assert!(dot(r, v).is_zero());
                }
            }
            let pivots: Vec<usize> = echelon.rows().map(|r| *r.keys().next().unwrap()).collect();
            for r in echelon.rows() {
                let lead = *r.keys().next().unwrap();
                prop_assert_eq!(r[&lead], Rational::ONE);
                for p in &pivots {
                    if *p != lead {
                        prop_assert!(!r.contains_key(p));
                    }
                }
            }
        }
    }
}
