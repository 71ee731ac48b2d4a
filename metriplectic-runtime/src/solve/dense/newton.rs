//! The Newton system of one interior-point iteration, reduced to the normal
//! equations on y: Aᵀ D̃ A + G̃ᵀ G̃ with G̃ = W⁻ᵀ G, factorised once per
//! iteration and solved for the predictor and the corrector.
//!
//! The side-cone block is written in the scaled space, as CVXOPT does: its
//! unknown is ũ = W dz and its rows are W⁻ᵀ(G dx) − ũ = W⁻ᵀ b_z, so the
//! block is −I. Near a face of a PSD cone the Nesterov–Todd scaling W is
//! ill-conditioned; in the unscaled form −WᵀW dz its residuals lost every
//! digit and iterative refinement could not converge, which stalled the
//! method at a relative gap of a few 1e-8.
//!
//! Forming the Schur complement squares the condition number of
//! M = [D̃^½ A; G̃]. Near an exact fit of an over-sized basis that loses
//! directions refinement needs; those solves are refined again with a
//! factor from Householder QRs of M itself (`docs/method.md` §4).

use std::sync::OnceLock;

use nalgebra::{DMatrix, DVector};

use crate::solve::linalg::Cholesky;

use super::cones::SideScaling;
use super::side_rows::ScaledSideRows;
use super::Reduced;

/// A right-hand side or solution of the KKT system: the x part (y, e) and
/// the z part (z₁, z₂, and the side cones' part in the scaled space: W⁻ᵀ b_z
/// in a right-hand side, ũ = W dz in a solution).
#[derive(Clone)]
pub(super) struct Kkt {
    pub y: DVector<f64>,
    pub e: DVector<f64>,
    pub z1: DVector<f64>,
    pub z2: DVector<f64>,
    pub zc: DVector<f64>,
}

/// Most iterative-refinement steps per solve.
const MAX_REFINEMENT: usize = 8;
/// Refinement stops at a KKT residual of `REFINEMENT_ABSOLUTE` plus
/// `REFINEMENT_RELATIVE` times the right-hand side (Clarabel's defaults; the
/// problem is equilibrated, so these are in units of the data).
const REFINEMENT_ABSOLUTE: f64 = 1e-12;
const REFINEMENT_RELATIVE: f64 = 1e-13;
/// The orthogonal factor takes over when refinement with the formed one
/// ends above the refinement tolerance plus this much of the right-hand side.
const ORTHOGONAL_FALLBACK: f64 = 1e-6;
/// Aᵀ w reads only w's non-zero rows when they are at most one in this many.
const SPARSE_FRACTION: usize = 16;
/// Most conjugate-gradient steps per Schur-complement solve.
const MAX_CG: usize = 50;
/// A Schur-complement solve stops at a residual this small relative to its
/// right-hand side.
const SCHUR_TOLERANCE: f64 = 1e-15;

impl Kkt {
    /// The largest |entry|.
    fn amax(&self) -> f64 {
        [&self.y, &self.e, &self.z1, &self.z2, &self.zc]
            .iter()
            .flat_map(|v| v.iter())
            .fold(0.0_f64, |m, v| m.max(v.abs()))
    }

    fn plus(&self, other: &Kkt) -> Kkt {
        Kkt {
            y: &self.y + &other.y,
            e: &self.e + &other.e,
            z1: &self.z1 + &other.z1,
            z2: &self.z2 + &other.z2,
            zc: &self.zc + &other.zc,
        }
    }

    fn minus(&self, other: &Kkt) -> Kkt {
        Kkt {
            y: &self.y - &other.y,
            e: &self.e - &other.e,
            z1: &self.z1 - &other.z1,
            z2: &self.z2 - &other.z2,
            zc: &self.zc - &other.zc,
        }
    }
}

/// Factorised reduced KKT system at one scaling.
pub(super) struct Newton<'a> {
    problem: &'a Reduced,
    /// G̃ = W⁻ᵀ G, the side-cone rows in the scaled space.
    scaled_g: ScaledSideRows<'a>,
    /// z/s of the two L1 orthants.
    d1: DVector<f64>,
    d2: DVector<f64>,
    /// D̃ = 4 d₁d₂/(d₁ + d₂), the L1 block's weight in the Schur complement.
    weights: DVector<f64>,
    schur: ScaledCholesky,
    /// The factor from a QR of [D̃^½ A; G̃], built on the first solve the
    /// formed Schur complement's factor cannot refine.
    orthogonal: OnceLock<Option<ScaledCholesky>>,
}

impl<'a> Newton<'a> {
    /// Forms and factorises Aᵀ D̃ A + G̃ᵀ G̃, with D̃ = 4 d₁d₂/(d₁ + d₂);
    /// `buffer` holds A's scaled rows while Aᵀ D̃ A is formed (see
    /// [`crate::solve::linalg::RowMajor::weighted_gram`]), then a copy of
    /// the Schur complement while it is factorised; it is reused across
    /// iterations so that neither takes fresh pages.
    pub fn new(
        problem: &'a Reduced,
        scaling: &SideScaling,
        d1: DVector<f64>,
        d2: DVector<f64>,
        buffer: &mut Vec<f64>,
    ) -> Option<Self> {
        let scaled_g =
            ScaledSideRows::new(&problem.side_rows, &problem.g, &problem.segments, scaling);
        let weights = DVector::from_iterator(
            d1.len(),
            d1.iter().zip(d2.iter()).map(|(a, b)| 4.0 * a * b / (a + b)),
        );
        let schur = schur_complement(problem, &scaled_g, &weights, buffer);
        let schur = factorise(schur, buffer)?;
        Some(Self {
            problem,
            scaled_g,
            d1,
            d2,
            weights,
            schur,
            orthogonal: OnceLock::new(),
        })
    }

    /// S v = Aᵀ D̃ A v + G̃ᵀ G̃ v, without forming S; A is read once, each
    /// slice multiplied by v and back while it is in the cache.
    fn schur_product(&self, v: &DVector<f64>) -> DVector<f64> {
        let p = self.problem;
        let (_, mut out) = p.a.mul_then_tr_mul(v, |i, av| self.weights[i] * av);
        if self.scaled_g.nrows() > 0 {
            out += self.scaled_g.tr_mul(&self.scaled_g.mul(v));
        }
        out
    }

    /// dy with S dy = b: conjugate gradients on S preconditioned by the
    /// factor of the formed S, from the factor's own solution `x` and its
    /// residual `r` = b − S x. When the data are fitted exactly, every L1
    /// residual is active and D̃ spans many orders of magnitude; the formed
    /// S then loses the directions only the side cones determine, and
    /// iterative refinement with its factor diverges, but as a
    /// preconditioner it still clusters the spectrum and CG converges in a
    /// few steps. Usually the factor's solution, or one CG step from it,
    /// is already at the product's rounding level; `None` when it is, so
    /// the caller keeps the products it formed with r.
    fn conjugate_gradients(
        &self,
        factor: &ScaledCholesky,
        mut x: DVector<f64>,
        mut r: DVector<f64>,
        floor: f64,
    ) -> Option<DVector<f64>> {
        // Below the rounding error of the product S x there is nothing to gain.
        let floor = floor.max(f64::EPSILON * factor.largest * x.amax());
        let mut best = (r.amax(), x.clone());
        if best.0 <= floor || best.0.is_nan() {
            return None;
        }
        let mut z = factor.solve(&r);
        let mut direction = z.clone();
        let mut rz = r.dot(&z);
        let mut since_best = 0;
        for _ in 0..MAX_CG {
            let q = self.schur_product(&direction);
            let curvature = direction.dot(&q);
            if !(curvature > 0.0 && rz > 0.0) {
                break;
            }
            let alpha = rz / curvature;
            x.axpy(alpha, &direction, 1.0);
            r.axpy(-alpha, &q, 1.0);
            let size = r.amax();
            if size < best.0 {
                best = (size, x.clone());
                since_best = 0;
            } else {
                since_best += 1;
            }
            if size <= floor || size.is_nan() || since_best >= 3 {
                break;
            }
            z = factor.solve(&r);
            let rz_next = r.dot(&z);
            direction = &z + &direction * (rz_next / rz);
            rz = rz_next;
        }
        Some(best.1)
    }

    /// Solves [0 G̃ᵀ; G̃ −I][dx; dz̃] = [bx; bz̃] for x = (y, e), z̃ = (z₁, z₂, ũ)
    /// (the L1 orthants' blocks unscaled, −diag(s/z), the side cones' scaled),
    /// through the Schur complement on y, then iterative refinement on the
    /// unreduced system until the residual is small (`REFINEMENT_ABSOLUTE`,
    /// `REFINEMENT_RELATIVE`), while each step at least halves it (a step
    /// that does not improve it is discarded), up to `MAX_REFINEMENT`.
    /// Every solve is checked: the products the check needs come from the
    /// solve's own pass over A. When refinement with the formed Schur
    /// complement's factor ends above `ORTHOGONAL_FALLBACK` of the
    /// right-hand side, it goes on with the orthogonal factor (built once
    /// per Newton system), and the smaller residual's solution is returned.
    pub fn solve(&self, rhs: &Kkt) -> Kkt {
        self.solve_fused(rhs, None, None).0
    }

    /// [`Newton::solve`] sharing passes over A with the iteration.
    /// `known` is Aᵀ of the right-hand side's reduced rows
    /// ([`reduced_row`]), when the pass that formed the right-hand side
    /// already computed it. `extra`(i, dz₁ᵢ, dz₂ᵢ) is a further weight of row
    /// i, formed from the solution in the pass that checks it; Aᵀ of those
    /// weights is returned when that solution is the one returned (no
    /// refinement step was kept), since only then do they belong to it.
    pub fn solve_fused(
        &self,
        rhs: &Kkt,
        known: Option<&DVector<f64>>,
        extra: Option<&Extra<'_>>,
    ) -> (Kkt, Option<DVector<f64>>) {
        let scale = rhs.amax();
        let enough = REFINEMENT_ABSOLUTE + REFINEMENT_RELATIVE * scale;
        let (solution, products, floor, fused) =
            self.solve_reduced(&self.schur, rhs, None, known, extra);
        let refined = self.refine(&self.schur, rhs, (solution, products, floor), enough);
        let fused = fused.filter(|_| !refined.changed);
        // A Newton direction this close is good enough for the iteration;
        // the orthogonal factor is for solves the formed factor got wrong.
        let close = enough + ORTHOGONAL_FALLBACK * scale;
        if refined.size <= close || refined.size.is_nan() {
            return (refined.solution, fused);
        }
        let Some(orthogonal) = self
            .orthogonal
            .get_or_init(|| self.orthogonal_factor())
            .as_ref()
        else {
            return (refined.solution, fused);
        };
        let start = (
            refined.solution.clone(),
            refined.products.clone(),
            refined.floor,
        );
        let again = self.refine(orthogonal, rhs, start, enough);
        if again.size < refined.size {
            (again.solution, None)
        } else {
            (refined.solution, fused)
        }
    }

    /// Iterative refinement from `start` with the Schur solves of `factor`.
    fn refine(
        &self,
        factor: &ScaledCholesky,
        rhs: &Kkt,
        start: (Kkt, Products, f64),
        enough: f64,
    ) -> Refined {
        let (mut solution, mut products, floor) = start;
        let mut changed = false;
        let mut residual = rhs.minus(&self.apply(&solution, &products));
        let mut size = residual.amax();
        for _ in 0..MAX_REFINEMENT {
            if size <= enough || size.is_nan() {
                break;
            }
            let (correction, change, _, _) =
                self.solve_reduced(factor, &residual, Some(floor), None, None);
            let candidate = solution.plus(&correction);
            // The operator is linear, so the candidate's products are the sum.
            let candidate_products = products.plus(&change);
            let next = rhs.minus(&self.apply(&candidate, &candidate_products));
            let next_size = next.amax();
            // A non-finite step is never kept.
            if next_size >= size || next_size.is_nan() {
                break;
            }
            let halved = next_size < 0.5 * size;
            (solution, products, residual, size) = (candidate, candidate_products, next, next_size);
            changed = true;
            if !halved {
                break;
            }
        }
        Refined {
            solution,
            products,
            floor,
            size,
            changed,
        }
    }

    /// The Jacobi-scaled factor of S from a QR of [D̃^½ A; G̃] (`None` if
    /// that is singular).
    fn orthogonal_factor(&self) -> Option<ScaledCholesky> {
        let p = self.problem;
        let scale = &self.schur.scale;
        let r = self.weights.len();
        let factor = Cholesky::from_rows(r + self.scaled_g.nrows(), p.a.ncols(), |i, row| {
            if i < r {
                let weight = self.weights[i].sqrt();
                for ((out, value), s) in row.iter_mut().zip(p.a.row(i)).zip(scale.iter()) {
                    *out = weight * value * s;
                }
            } else {
                self.scaled_g.write_row(i - r, row);
                for (out, s) in row.iter_mut().zip(scale.iter()) {
                    *out *= s;
                }
            }
        })?;
        Some(ScaledCholesky {
            factor,
            scale: scale.clone(),
            largest: self.schur.largest,
        })
    }

    /// The unreduced KKT operator applied to (dx, dz̃), given the products
    /// A dy and Aᵀ(dz₂ − dz₁).
    fn apply(&self, v: &Kkt, products: &Products) -> Kkt {
        let p = self.problem;
        let ay = &products.ay;
        let mut y = products.at_z.clone();
        let mut zc = DVector::zeros(0);
        if p.g.nrows() > 0 {
            y += self.scaled_g.tr_mul(&v.zc);
            zc = self.scaled_g.mul(&v.y) - &v.zc;
        }
        Kkt {
            y,
            e: -&v.z1 - &v.z2,
            z1: -ay - &v.e - v.z1.component_div(&self.d1),
            z2: ay - &v.e - v.z2.component_div(&self.d2),
            zc,
        }
    }

    /// One solve through the Schur complement on y, with the products
    /// A dy and Aᵀ(dz₂ − dz₁) of its solution. The first solve of a
    /// right-hand side uses the factor alone (`floor` `None`); its KKT
    /// residual then tells whether anything is left to refine, and each
    /// refinement step solves the Schur system by CG down to `floor`
    /// (`SCHUR_TOLERANCE` times the first right-hand side, returned),
    /// starting from the factor's solution, whose products come from the
    /// pass that forms CG's first residual.
    /// `known` and `extra` as in [`Newton::solve_fused`]; the last value
    /// is Aᵀ of `extra`'s weights.
    fn solve_reduced(
        &self,
        factor: &ScaledCholesky,
        b: &Kkt,
        floor: Option<f64>,
        known: Option<&DVector<f64>>,
        extra: Option<&Extra<'_>>,
    ) -> (Kkt, Products, f64, Option<DVector<f64>>) {
        let p = self.problem;
        let sum = &self.d1 + &self.d2;
        let diff = &self.d1 - &self.d2;
        let rhs_e = &b.e - self.d1.component_mul(&b.z1) - self.d2.component_mul(&b.z2);
        let product = match known {
            Some(product) => product.clone(),
            None => {
                let rows = DVector::from_fn(b.e.len(), |i, _| {
                    reduced_row(self.d1[i], self.d2[i], b.e[i], b.z1[i], b.z2[i])
                });
                // A corrector's right-hand side is non-zero in a few dozen rows.
                let nonzero = rows.iter().filter(|v| **v != 0.0).count();
                if nonzero * SPARSE_FRACTION <= rows.len() {
                    p.a.tr_mul_sparse(&rows)
                } else {
                    p.a.tr_mul(&rows)
                }
            }
        };
        let mut rhs_y = &b.y + product;
        if p.g.nrows() > 0 {
            rhs_y += self.scaled_g.tr_mul(&b.zc);
        }
        // Row by row: de from A dy, then dz = D (G dx − bz) on the orthants
        // with G = [[−A, −I]; [A, −I]]. The same formulas give Aᵀ(dz₂ − dz₁)
        // in the pass that forms A dy.
        let orthants = |i: usize, ady: f64| {
            let de = (rhs_e[i] - diff[i] * ady) / sum[i];
            let z1 = self.d1[i] * (-ady - de - b.z1[i]);
            let z2 = self.d2[i] * (ady - de - b.z2[i]);
            (de, z1, z2)
        };
        let products = |dy: &DVector<f64>| {
            p.a.mul_then_tr_mul(dy, |i, ady| {
                let (_, z1, z2) = orthants(i, ady);
                z2 - z1
            })
        };
        let dy = factor.solve(&rhs_y);
        let (dy, floor, ady, at_z, fused) = match (floor, extra) {
            (None, Some(extra)) => {
                let (ady, [at_z, fused]) = p.a.mul_then_tr_mul_many(&dy, |i, ady| {
                    let (_, z1, z2) = orthants(i, ady);
                    [z2 - z1, extra(i, z1, z2)]
                });
                let floor = SCHUR_TOLERANCE * rhs_y.amax();
                (dy, floor, ady, at_z, Some(fused))
            }
            (None, None) => {
                let (ady, at_z) = products(&dy);
                (dy, SCHUR_TOLERANCE * rhs_y.amax(), ady, at_z, None)
            }
            (Some(floor), _) => {
                // The pass that forms S dy for CG's first residual forms
                // the solution's products too; they are kept when CG stops
                // there, as it almost always does.
                let (ady, [schur_part, at_z]) = p.a.mul_then_tr_mul_many(&dy, |i, ady| {
                    let (_, z1, z2) = orthants(i, ady);
                    [self.weights[i] * ady, z2 - z1]
                });
                let mut product = schur_part;
                if self.scaled_g.nrows() > 0 {
                    product += self.scaled_g.tr_mul(&self.scaled_g.mul(&dy));
                }
                let residual = &rhs_y - product;
                match self.conjugate_gradients(factor, dy.clone(), residual, floor) {
                    None => (dy, floor, ady, at_z, None),
                    Some(dy) => {
                        let (ady, at_z) = products(&dy);
                        (dy, floor, ady, at_z, None)
                    }
                }
            }
        };
        let r = ady.len();
        let (mut de, mut z1, mut z2) = (DVector::zeros(r), DVector::zeros(r), DVector::zeros(r));
        for (i, &value) in ady.iter().enumerate() {
            (de[i], z1[i], z2[i]) = orthants(i, value);
        }
        // ũ = G̃ dy − bz̃ on the side cones.
        let zc = if p.g.nrows() > 0 {
            self.scaled_g.mul(&dy) - &b.zc
        } else {
            DVector::zeros(0)
        };
        let solution = Kkt {
            y: dy,
            e: de,
            z1,
            z2,
            zc,
        };
        (solution, Products { ay: ady, at_z }, floor, fused)
    }

    /// [`reduced_row`] of row i with this system's weights.
    pub fn reduced_row(&self, i: usize, e: f64, z1: f64, z2: f64) -> f64 {
        reduced_row(self.d1[i], self.d2[i], e, z1, z2)
    }
}

/// A weight of row i formed from a solution's multiplier directions
/// (i, dz₁ᵢ, dz₂ᵢ), see [`Newton::solve_fused`].
pub(super) type Extra<'a> = dyn Fn(usize, f64, f64) -> f64 + Sync + 'a;

/// Row i of the L1 block's part of the Schur system's right-hand side:
/// eliminating de and dz₁, dz₂ from the right-hand side (b_e, b_z₁, b_z₂)
/// of that row leaves this weight, and the Schur right-hand side is
/// b_y + Aᵀ(weights) (+ the side cones' part). It is linear in
/// (b_e, b_z₁, b_z₂), so the iteration can form Aᵀ of a right-hand side's
/// parts in passes over A it makes anyway. `d1`, `d2` are z/s of the two
/// orthants.
pub(super) fn reduced_row(d1: f64, d2: f64, e: f64, z1: f64, z2: f64) -> f64 {
    // d₂b₂ − d₁b₁ − (d₁ − d₂)/(d₁ + d₂)·(b_e − d₁b₁ − d₂b₂), without the
    // cancellation of the d₁b₁ terms that form loses when d₁ ≫ d₂.
    let sum = d1 + d2;
    2.0 * d1 * d2 / sum * (z2 - z1) - (d1 - d2) / sum * e
}

/// The end of iterative refinement: the solution, its products, the Schur
/// solves' floor, the KKT residual's largest entry and whether refinement
/// changed the solution.
struct Refined {
    solution: Kkt,
    products: Products,
    floor: f64,
    size: f64,
    /// Whether a refinement step was kept.
    changed: bool,
}

/// The products with A of a Newton solution (dy, dz): A dy and
/// Aᵀ(dz₂ − dz₁), the two the KKT operator needs.
#[derive(Clone)]
struct Products {
    ay: DVector<f64>,
    at_z: DVector<f64>,
}

impl Products {
    fn plus(&self, other: &Products) -> Products {
        Products {
            ay: &self.ay + &other.ay,
            at_z: &self.at_z + &other.at_z,
        }
    }
}

/// Aᵀ D̃ A + G̃ᵀ G̃, both Gram products (symmetric by construction).
fn schur_complement(
    problem: &Reduced,
    scaled_g: &ScaledSideRows,
    weights: &DVector<f64>,
    buffer: &mut Vec<f64>,
) -> DMatrix<f64> {
    let mut schur = match &problem.narrow {
        Some(narrow) => narrow.weighted_gram(weights, buffer),
        None => problem.a.weighted_gram(weights, buffer),
    };
    scaled_g.add_gram(&mut schur);
    schur
}

/// A Cholesky factorisation of D^{-1/2} M D^{-1/2}, D = diag(M): the
/// symmetric Jacobi scaling. Near a face of the PSD cones the Schur
/// complement's diagonal spans many orders of magnitude; scaled, its
/// factor is accurate enough for iterative refinement to converge.
struct ScaledCholesky {
    factor: Cholesky,
    /// D^{-1/2}.
    scale: DVector<f64>,
    /// The largest diagonal entry of M.
    largest: f64,
}

impl ScaledCholesky {
    fn solve(&self, b: &DVector<f64>) -> DVector<f64> {
        let scaled = b.component_mul(&self.scale);
        self.factor.solve(&scaled).component_mul(&self.scale)
    }
}

/// The Jacobi-scaled Cholesky of the Schur complement; on breakdown
/// retried with a small diagonal shift (a rank-deficient regression with
/// an unconstrained direction).
fn factorise(mut schur: DMatrix<f64>, saved: &mut Vec<f64>) -> Option<ScaledCholesky> {
    let k = schur.nrows();
    let largest = schur.diagonal().amax().max(f64::MIN_POSITIVE);
    // A zero diagonal entry (a column nothing constrains) is scaled as the
    // largest would be; the shift below then handles it.
    let scale = DVector::from_iterator(
        k,
        schur.diagonal().iter().map(|&d| {
            if d > 1e-300 {
                1.0 / d.sqrt()
            } else {
                1.0 / largest.sqrt()
            }
        }),
    );
    for j in 0..k {
        for i in 0..k {
            schur[(i, j)] *= scale[i] * scale[j];
        }
    }
    // The factor overwrites the matrix; the scaled matrix is kept in
    // `saved` for a retry. A fresh 7 MB copy per iteration (two, before)
    // cost 8 ms of page faults and copying at p = 923, q = 2000.
    if saved.len() < k * k {
        saved.resize(k * k, 0.0);
    }
    let saved = &mut saved[..k * k];
    saved.copy_from_slice(schur.as_slice());
    let mut shift = 0.0;
    for _ in 0..4 {
        for i in 0..k {
            schur[(i, i)] += shift;
        }
        match Cholesky::in_place(schur) {
            Ok(factor) => {
                return Some(ScaledCholesky {
                    factor,
                    scale,
                    largest,
                })
            }
            Err(back) => schur = back,
        }
        schur.as_mut_slice().copy_from_slice(saved);
        shift = if shift == 0.0 { 1e-13 } else { shift * 1e3 };
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rank-deficient Schur complement fails the first factorisation and
    /// is retried with a shift on the restored matrix: the factor must be
    /// that of the Jacobi-scaled input plus a multiple of I, on faer's
    /// unblocked (n = 3) and blocked (n = 150) paths.
    #[test]
    fn a_singular_schur_complement_is_factorised_with_a_shift() {
        for (n, rank) in [(3, 1), (150, 10)] {
            let b = DMatrix::from_fn(n, rank, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0);
            let m = &b * b.transpose();
            let factor = factorise(m.clone(), &mut Vec::new()).expect("a shift makes it definite");
            let scale = &factor.scale;
            let scaled = DMatrix::from_fn(n, n, |i, j| m[(i, j)] * scale[i] * scale[j]);
            let l = factor.factor.l();
            let difference = l * l.transpose() - &scaled;
            let shift = difference[(0, 0)];
            assert!(shift > 0.0 && shift <= 1e-7, "n = {n}: shift {shift}");
            for j in 0..n {
                for i in 0..n {
                    let expected = if i == j { shift } else { 0.0 };
                    assert!(
                        (difference[(i, j)] - expected).abs() < 1e-12,
                        "n = {n}: L Lᵀ − S̃ at ({i}, {j}) is {}",
                        difference[(i, j)]
                    );
                }
            }
        }
    }
}
