//! Monomial bases in graded lexicographic order and the SOS matching tables.
//!
//! Graded lexicographic: by total degree, then, within a degree, larger
//! exponents of earlier variables first. For x = (q, p) at degree ≤ 2:
//! `1, q, p, q², q p, p²`. Every basis the macro emits ("all monomials of
//! degree ≤ d") is a prefix of the same infinite sequence, so the entropy and
//! metric bases are slices of one list of monomials evaluated once.

use std::cmp::Ordering;
use std::collections::{BTreeMap, HashMap};

use crate::polynomial::{Exact, Rational};

/// The bases of a system with checked degrees.
#[derive(Debug)]
pub struct Bases {
    /// Entropy degree r.
    pub entropy_degree: u32,
    /// Metric degree s (even).
    pub metric_degree: u32,
    /// All monomials of degree ≤ max(r, s), graded lexicographic; the entropy
    /// basis is `[1..=entropy_len]`, the metric basis `[..metric_len]`.
    pub monomials: Vec<Vec<u32>>,
    /// Number of entropy monomials (degree 1..=r).
    pub entropy_len: usize,
    /// Number of metric monomials (degree 0..=s).
    pub metric_len: usize,
    /// The full SOS half-degree basis (degree ≤ s/2).
    pub sos_full: Vec<Vec<u32>>,
    /// Its matching table over the metric basis.
    pub sos_full_matching: Vec<Vec<(usize, usize)>>,
    /// The facially reduced matching table.
    pub sos_reduced_matching: Vec<Vec<(usize, usize)>>,
}

impl Bases {
    /// The bases of `nvars` variables with entropy degree `r` and metric
    /// degree `s`, whose sizes the caller has bounded.
    pub fn new(nvars: usize, r: u32, s: u32) -> Bases {
        let monomials = up_to_degree(nvars, r.max(s));
        let degree_at_most = |d: u32| {
            monomials
                .iter()
                .take_while(|e| e.iter().sum::<u32>() <= d)
                .count()
        };
        let entropy_len = degree_at_most(r).saturating_sub(1);
        let metric_len = degree_at_most(s);
        let sos_full = up_to_degree(nvars, s / 2);
        let sos_full_matching = matching_table(&sos_full, &monomials[..metric_len]);
        Bases {
            entropy_degree: r,
            metric_degree: s,
            entropy_len,
            metric_len,
            sos_full,
            sos_full_matching,
            sos_reduced_matching: reduced_matching(metric_len),
            monomials,
        }
    }
}

/// Compares two exponent vectors in graded lexicographic order.
pub fn graded_lex_cmp(a: &[u32], b: &[u32]) -> Ordering {
    let (da, db): (u32, u32) = (a.iter().sum(), b.iter().sum());
    // Within a degree, larger exponents of earlier variables come first.
    da.cmp(&db).then_with(|| b.cmp(a))
}

/// Number of monomials in `nvars` variables of total degree ≤ `degree`,
/// C(nvars + degree, degree); `None` on overflow.
pub fn count_up_to(nvars: usize, degree: u32) -> Option<u128> {
    let mut count: u128 = 1;
    for i in 1..=u128::from(degree) {
        // count * (nvars + i) / i stays exact at every step (binomial recursion).
        count = count.checked_mul(nvars as u128 + i)? / i;
    }
    Some(count)
}

/// All monomials of total degree ≤ `degree`, graded lexicographic, starting
/// with the constant monomial.
pub fn up_to_degree(nvars: usize, degree: u32) -> Vec<Vec<u32>> {
    let mut out = Vec::new();
    for d in 0..=degree {
        let mut current = vec![0; nvars];
        of_degree(&mut current, 0, d, &mut out);
    }
    out
}

/// Appends the monomials with exponents `current[..position]` fixed and total
/// degree `remaining` in the other variables, earlier variables' exponents
/// descending.
fn of_degree(current: &mut Vec<u32>, position: usize, remaining: u32, out: &mut Vec<Vec<u32>>) {
    if position + 1 >= current.len() {
        if let Some(last) = current.last_mut() {
            *last = remaining;
            out.push(current.clone());
        } else if remaining == 0 {
            out.push(Vec::new());
        }
        return;
    }
    for k in (0..=remaining).rev() {
        current[position] = k;
        of_degree(current, position + 1, remaining - k, out);
    }
    current[position] = 0;
}

/// Position of each monomial in a list.
pub fn index_of(basis: &[Vec<u32>]) -> HashMap<&[u32], usize> {
    basis
        .iter()
        .enumerate()
        .map(|(i, e)| (e.as_slice(), i))
        .collect()
}

/// The graded-lex parent of a non-constant monomial: itself divided by its
/// first variable. Returns (parent, variable index).
pub fn parent(exponents: &[u32]) -> Option<(Vec<u32>, usize)> {
    let j = exponents.iter().position(|&k| k > 0)?;
    let mut parent = exponents.to_vec();
    parent[j] -= 1;
    Some((parent, j))
}

/// SOS coefficient-matching table: for each `target` monomial α, the ordered
/// pairs (β, γ) of indices into `half` with β + γ = α.
pub fn matching_table(half: &[Vec<u32>], targets: &[Vec<u32>]) -> Vec<Vec<(usize, usize)>> {
    let target_index = index_of(targets);
    let mut table = vec![Vec::new(); targets.len()];
    for (b, beta) in half.iter().enumerate() {
        for (g, gamma) in half.iter().enumerate() {
            let sum: Vec<u32> = beta.iter().zip(gamma).map(|(x, y)| x + y).collect();
            if let Some(&a) = target_index.get(sum.as_slice()) {
                table[a].push((b, g));
            }
        }
    }
    table
}

/// The matching table of one S-procedure Gram block g(x)·Z(x)ᵀQZ(x), with
/// g = Σ cₜ x^eₜ given by its `multiplier` terms (the constant 1 for a plain
/// block): for each `target` monomial α, the ordered pairs (β, γ) of indices
/// into `half` with the coefficient of x^α in g(x)·x^β·x^γ, each pair at most
/// once per α (equal products summed, zero sums dropped), sorted by (β, γ).
///
/// The caller chooses `targets` to hold every product (all monomials up to
/// the largest degree of g times the degree of `half` squared); a product
/// outside them would be a bug of the caller and is left out.
pub fn block_matching(
    multiplier: &[(Rational, Vec<u32>)],
    half: &[Vec<u32>],
    targets: &[Vec<u32>],
) -> Exact<Vec<Vec<(usize, usize, Rational)>>> {
    let target_index = index_of(targets);
    let mut table: Vec<BTreeMap<(usize, usize), Rational>> = vec![BTreeMap::new(); targets.len()];
    for (b, beta) in half.iter().enumerate() {
        for (g, gamma) in half.iter().enumerate() {
            for (coefficient, e) in multiplier {
                let product: Vec<u32> = beta
                    .iter()
                    .zip(gamma)
                    .zip(e)
                    .map(|((x, y), z)| x + y + z)
                    .collect();
                if let Some(&a) = target_index.get(product.as_slice()) {
                    let entry = table[a].entry((b, g)).or_insert(Rational::ZERO);
                    *entry = entry.add(*coefficient)?;
                }
            }
        }
    }
    Ok(table
        .into_iter()
        .map(|pairs| {
            pairs
                .into_iter()
                .filter(|(_, c)| !c.is_zero())
                .map(|((b, g), c)| (b, g, c))
                .collect()
        })
        .collect())
}

/// The facially reduced SOS tables of the two-sided global certificate
/// 0 ⪯ K(x) ⪯ ηI: the basis is the constant monomial alone, and only the
/// constant metric monomial (index 0) is matched, by the Gram pair (0, 0).
/// Every other metric coefficient is forced to zero.
///
/// Why: the Gram matrices Q₁ of K and Q₂ of ηI − K satisfy
/// Z(x)ᵀ(Q₁ + Q₂)Z(x) = ηI, a constant. Going down from the highest degree,
/// the diagonal entry of Q₁ + Q₂ at each non-constant monomial β is the only
/// contribution to the coefficient of x^{2β} of maximal degree, so it is zero;
/// a PSD matrix with a zero diagonal entry has a zero row, and both Q₁ and Q₂
/// are PSD, so both lose that row.
pub fn reduced_matching(metric_len: usize) -> Vec<Vec<(usize, usize)>> {
    let mut table = vec![Vec::new(); metric_len];
    if let Some(first) = table.first_mut() {
        first.push((0, 0));
    }
    table
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn two_variables_degree_two() {
        let basis = up_to_degree(2, 2);
        assert_eq!(
            basis,
            vec![
                vec![0, 0],
                vec![1, 0],
                vec![0, 1],
                vec![2, 0],
                vec![1, 1],
                vec![0, 2]
            ]
        );
    }

    #[test]
    fn three_variables_degree_two_order() {
        let basis = up_to_degree(3, 2);
        let degree_two: Vec<_> = basis[4..].to_vec();
        assert_eq!(
            degree_two,
            vec![
                vec![2, 0, 0],
                vec![1, 1, 0],
                vec![1, 0, 1],
                vec![0, 2, 0],
                vec![0, 1, 1],
                vec![0, 0, 2]
            ]
        );
    }

    #[test]
    fn paper_basis_sizes() {
        // 2-D degree 8: 45 monomials, 44 without the constant.
        assert_eq!(up_to_degree(2, 8).len(), 45);
        // SO(3) degree 6: 84, 83 without the constant.
        assert_eq!(up_to_degree(3, 6).len(), 84);
        // The large test system: 6 states, degree 8.
        assert_eq!(count_up_to(6, 8), Some(3003));
        assert_eq!(count_up_to(3, 2), Some(10));
    }

    #[test]
    fn count_overflow_is_none() {
        assert_eq!(count_up_to(10_000, 200), None);
    }

    proptest! {
        #[test]
        fn enumeration_is_sorted_complete_and_counted(nvars in 1usize..5, degree in 0u32..7) {
            let basis = up_to_degree(nvars, degree);
            prop_assert_eq!(basis.len() as u128, count_up_to(nvars, degree).unwrap());
            for pair in basis.windows(2) {
                prop_assert_eq!(graded_lex_cmp(&pair[0], &pair[1]), Ordering::Less);
            }
            prop_assert!(basis.iter().all(|e| e.len() == nvars && e.iter().sum::<u32>() <= degree));
            // Prefix property: lower-degree bases are prefixes.
            if degree > 0 {
                let lower = up_to_degree(nvars, degree - 1);
                prop_assert_eq!(&basis[..lower.len()], &lower[..]);
            }
            // Parents are earlier in the list and one degree lower.
            let index = index_of(&basis);
            for (i, e) in basis.iter().enumerate().skip(1) {
                let (p, j) = parent(e).unwrap();
                prop_assert!(index[p.as_slice()] < i);
                prop_assert_eq!(p[j] + 1, e[j]);
            }
        }

        #[test]
        fn matching_tables_are_exact_and_complete(nvars in 1usize..4, half_degree in 0u32..4) {
            let half = up_to_degree(nvars, half_degree);
            let targets = up_to_degree(nvars, 2 * half_degree);
            let table = matching_table(&half, &targets);
            let mut total = 0;
            for (a, pairs) in table.iter().enumerate() {
                // Every metric monomial of degree ≤ s is covered by some pair.
                prop_assert!(!pairs.is_empty());
                for &(b, g) in pairs {
                    let sum: Vec<u32> = half[b].iter().zip(&half[g]).map(|(x, y)| x + y).collect();
                    prop_assert_eq!(&sum, &targets[a]);
                    // Ordered pairs: the transpose is listed too.
                    prop_assert!(pairs.contains(&(g, b)));
                }
                total += pairs.len();
            }
            // Every ordered Gram pair lands on exactly one metric monomial.
            prop_assert_eq!(total, half.len() * half.len());
        }
    }

    #[test]
    fn reduced_table_keeps_only_the_constant() {
        let table = reduced_matching(6);
        assert_eq!(table[0], vec![(0, 0)]);
        assert!(table[1..].iter().all(Vec::is_empty));
        assert!(reduced_matching(0).is_empty());
    }
}
