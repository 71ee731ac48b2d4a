//! Equilibration: rescaling rows and variables before the interior-point
//! method sees the problem, so that data in any units (states or rates of
//! 1e-6 or 1e6, features spanning many orders of magnitude) give a
//! well-scaled problem, and mapping the result back.
//!
//! Modified Ruiz equilibration, as in Clarabel: a few passes that divide
//! every row group and every variable group by the square root of its
//! largest entry. What may be scaled independently is dictated by the
//! problem's structure:
//!
//! * the regression rows share one scale (the L1 objective Σ|t − Ac| may
//!   only be scaled as a whole), chosen once so that the targets' mean
//!   magnitude is 1: the absolute gap tolerance then means the same for
//!   data in any units;
//! * each equality row and each nonnegative row has its own scale;
//! * each PSD block has one scale (a positive multiple of a PSD matrix is
//!   PSD, a row-wise scaling is not);
//! * variables that a PSD block holds share one scale; every other
//!   variable has its own, the metric coefficients matched to Gram entries
//!   too (their columns grow as ρ^α with the states' size ρ, and the
//!   equality rows that tie them to the block are scaled one by one).
//!   The Gram entries themselves are put on one scale by the searches,
//!   which set up their certificates in the region's unit-scaled states
//!   (`model::gram::Layout`).

use nalgebra::DVector;

use super::Split;
use crate::solve::Regression;

/// Passes of the equilibration.
const PASSES: usize = 10;
/// Bounds of one pass's factor (Clarabel's defaults).
const FACTOR_RANGE: (f64, f64) = (1e-4, 1e4);

/// The scales of one problem: x = D x′, rows multiplied by their scale.
pub(super) struct Scaling {
    /// Variable scales D.
    pub columns: Vec<f64>,
    /// Scale of the regression rows (and targets).
    pub objective: f64,
    /// Scale of each side-cone row (uniform within a PSD segment).
    pub side: Vec<f64>,
}

impl Scaling {
    /// Computes the scaling of the problem, applies it to `split` in place
    /// and returns it with the scaled copy of `regression`.
    ///
    /// The regression rows are only ever scaled as a whole and by column,
    /// so their column norms follow from the unscaled ones and the scales:
    /// the passes work on k numbers, and the r × k block is read twice in
    /// all (once for its norms, once to write the scaled copy) instead of
    /// twice per pass.
    pub fn equilibrate(regression: &Regression, split: &mut Split) -> (Self, Regression) {
        let n_vars = split.e.ncols();
        let width = regression.width;
        let group = variable_groups(split, n_vars);
        let mut scaling = Self {
            columns: vec![1.0; n_vars],
            objective: 1.0,
            side: vec![1.0; split.g.nrows()],
        };
        // The objective's scale: its targets' mean magnitude becomes 1, so
        // that the absolute gap tolerance means the same for data in any
        // units (the columns then adapt to it).
        let mean = regression.target.iter().map(|t| t.abs()).sum::<f64>()
            / regression.target.len().max(1) as f64;
        if mean > 0.0 && mean.is_finite() {
            scaling.objective = 1.0 / mean;
        }
        let mut regression_norms = vec![0.0_f64; width];
        for row in regression.rows.chunks_exact(width.max(1)) {
            for (norm, a) in regression_norms.iter_mut().zip(row) {
                *norm = norm.max(a.abs());
            }
        }
        for _ in 0..PASSES {
            // Constraint rows.
            for i in 0..split.e.nrows() {
                let f = factor(split.e.row(i).amax());
                split.e.row_mut(i).scale_mut(f);
                split.f[i] *= f;
            }
            let mut side: Vec<f64> = (0..split.g.nrows())
                .map(|i| factor(split.g.row(i).amax()))
                .collect();
            for segment in split.segments.iter().filter(|s| s.psd.is_some()) {
                // One factor per PSD block: that of its largest row.
                let range = segment.range();
                let common = side[range.clone()]
                    .iter()
                    .copied()
                    .fold(f64::INFINITY, f64::min);
                side[range].fill(common);
            }
            for (i, f) in side.into_iter().enumerate() {
                split.g.row_mut(i).scale_mut(f);
                split.h[i] *= f;
                scaling.side[i] *= f;
            }

            // Variables, one factor per group.
            let mut group_norm = vec![0.0_f64; n_vars];
            for c in 0..n_vars {
                let regression_norm = regression_norms
                    .get(c)
                    .map_or(0.0, |norm| norm * scaling.objective * scaling.columns[c]);
                let norm = regression_norm
                    .max(split.e.column(c).amax())
                    .max(split.g.column(c).amax());
                group_norm[group[c]] = group_norm[group[c]].max(norm);
            }
            let factors: Vec<f64> = (0..n_vars).map(|c| factor(group_norm[group[c]])).collect();
            for (c, f) in factors.into_iter().enumerate() {
                split.e.column_mut(c).scale_mut(f);
                split.g.column_mut(c).scale_mut(f);
                scaling.columns[c] *= f;
            }
        }
        let row_scales: Vec<f64> = scaling.columns[..width]
            .iter()
            .map(|d| d * scaling.objective)
            .collect();
        let rows = regression
            .rows
            .chunks_exact(width.max(1))
            .flat_map(|row| row.iter().zip(&row_scales).map(|(a, d)| a * d))
            .collect();
        let target = regression
            .target
            .iter()
            .map(|t| t * scaling.objective)
            .collect();
        let scaled = Regression {
            width,
            rows,
            target,
        };
        (scaling, scaled)
    }

    /// x = D x′.
    pub fn unscale_variables(&self, scaled: &DVector<f64>) -> Vec<f64> {
        scaled
            .iter()
            .zip(&self.columns)
            .map(|(x, d)| x * d)
            .collect()
    }

    /// The slack of side rows `offset..` of the original problem from the
    /// scaled one.
    pub fn unscale_side(&self, scaled: &[f64], offset: usize) -> Vec<f64> {
        scaled
            .iter()
            .zip(&self.side[offset..])
            .map(|(s, r)| s / r)
            .collect()
    }
}

/// 1/√norm within the allowed range (1 for an empty row or column).
fn factor(norm: f64) -> f64 {
    if norm > 0.0 && norm.is_finite() {
        (1.0 / norm.sqrt()).clamp(FACTOR_RANGE.0, FACTOR_RANGE.1)
    } else {
        1.0
    }
}

/// The group of every variable: variables a PSD block holds share one; the
/// others are alone. (Variables an equality row ties to a block used to
/// join its group too; but each equality row has its own scale, so nothing
/// requires it, and it forced the metric coefficients of x^α, whose
/// columns grow as ρ^α with the states' size ρ, onto one scale.)
fn variable_groups(split: &Split, n_vars: usize) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..n_vars).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    fn join(parent: &mut [usize], a: usize, b: usize) {
        let (ra, rb) = (root(parent, a), root(parent, b));
        parent[ra.max(rb)] = ra.min(rb);
    }
    for segment in split.segments.iter().filter(|s| s.psd.is_some()) {
        let mut first = None;
        for i in segment.range() {
            for c in 0..n_vars {
                if split.g[(i, c)] != 0.0 {
                    match first {
                        None => first = Some(c),
                        Some(f) => join(&mut parent, f, c),
                    }
                }
            }
        }
    }
    (0..n_vars).map(|c| root(&mut parent, c)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factors_stay_in_range() {
        assert_eq!(factor(0.0), 1.0);
        assert_eq!(factor(f64::NAN), 1.0);
        assert_eq!(factor(4.0), 0.5);
        assert_eq!(factor(1e-20), 1e4);
    }
}
