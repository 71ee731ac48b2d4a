//! The Newton system of one interior-point iteration, reduced to the normal
//! equations on y: Aᵀ D̃ A + Gᵀ (WᵀW)⁻¹ G, factorised once per iteration and
//! solved for the predictor and the corrector.

use nalgebra::{DMatrix, DVector};

use crate::solve::linalg::{gram, Cholesky};

use super::cones::SideScaling;
use super::Reduced;

/// A right-hand side or solution of the KKT system: the x part (y, e) and
/// the z part (z₁, z₂, z_c).
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
    scaling: &'a SideScaling,
    /// z/s of the two L1 orthants.
    d1: DVector<f64>,
    d2: DVector<f64>,
    schur: ScaledCholesky,
}

impl<'a> Newton<'a> {
    /// Forms and factorises Aᵀ D̃ A + Gᵀ (WᵀW)⁻¹ G, with D̃ = 4 d₁d₂/(d₁ + d₂).
    pub fn new(
        problem: &'a Reduced,
        scaling: &'a SideScaling,
        d1: DVector<f64>,
        d2: DVector<f64>,
    ) -> Option<Self> {
        let schur = schur_complement(problem, scaling, &d1, &d2);
        let schur = factorise(schur)?;
        Some(Self {
            problem,
            scaling,
            d1,
            d2,
            schur,
        })
    }

    /// Solves [0 Gᵀ; G −WᵀW][dx; dz] = [bx; bz] for x = (y, e), z = (z₁, z₂, z_c),
    /// with iterative refinement on the unreduced system (the reduction
    /// squares the condition number near the optimum): at least two steps,
    /// and more while each still halves the residual, up to
    /// `MAX_REFINEMENT` — near a face of the PSD cones (a rank-deficient
    /// Gram matrix at the optimum) two steps can leave the direction
    /// inaccurate enough to stall the method.
    pub fn solve(&self, rhs: &Kkt) -> Kkt {
        let mut solution = self.solve_reduced(rhs);
        let mut residual = rhs.minus(&self.apply(&solution));
        let mut size = residual.amax();
        for step in 0..MAX_REFINEMENT {
            let candidate = solution.plus(&self.solve_reduced(&residual));
            let next = rhs.minus(&self.apply(&candidate));
            let next_size = next.amax();
            // NaN compares false: a non-finite refinement is never "halved".
            let halved = next_size < 0.5 * size;
            if step < 2 || halved {
                (solution, residual, size) = (candidate, next, next_size);
            }
            if (step >= 1 && !halved) || size == 0.0 {
                break;
            }
        }
        solution
    }

    /// The unreduced KKT operator [0 Gᵀ; G −WᵀW] applied to (dx, dz).
    fn apply(&self, v: &Kkt) -> Kkt {
        let p = self.problem;
        let ay = &p.a * &v.y;
        let mut y = p.a.tr_mul(&(&v.z2 - &v.z1));
        if p.g.nrows() > 0 {
            y += p.g.tr_mul(&v.zc);
        }
        let wtw_zc = self
            .scaling
            .apply_wt(&p.segments, &self.scaling.apply_w(&p.segments, &v.zc));
        Kkt {
            y,
            e: -&v.z1 - &v.z2,
            z1: -&ay - &v.e - v.z1.component_div(&self.d1),
            z2: &ay - &v.e - v.z2.component_div(&self.d2),
            zc: &p.g * &v.y - wtw_zc,
        }
    }

    /// One solve through the Schur complement on y.
    fn solve_reduced(&self, b: &Kkt) -> Kkt {
        let p = self.problem;
        let d1b = self.d1.component_mul(&b.z1);
        let d2b = self.d2.component_mul(&b.z2);
        let dcb = self.scaling.apply_inverse_wtw(&p.segments, &b.zc);
        let sum = &self.d1 + &self.d2;
        let diff = &self.d1 - &self.d2;
        let rhs_e = &b.e - &d1b - &d2b;
        let ratio = diff.component_div(&sum);
        let mut rhs_y =
            &b.y + p.a.tr_mul(&(&d2b - &d1b)) - p.a.tr_mul(&ratio.component_mul(&rhs_e));
        if p.g.nrows() > 0 {
            rhs_y += p.g.tr_mul(&dcb);
        }
        let dy = self.schur.solve(&rhs_y);
        let ady = &p.a * &dy;
        let de = (&rhs_e - diff.component_mul(&ady)).component_div(&sum);
        // dz = (WᵀW)⁻¹ (G dx − bz) with G = [[−A, −I]; [A, −I]; [G_c, 0]].
        let z1 = self.d1.component_mul(&(-&ady - &de - &b.z1));
        let z2 = self.d2.component_mul(&(&ady - &de - &b.z2));
        let zc = if p.g.nrows() > 0 {
            self.scaling
                .apply_inverse_wtw(&p.segments, &(&p.g * &dy - &b.zc))
        } else {
            DVector::zeros(0)
        };
        Kkt {
            y: dy,
            e: de,
            z1,
            z2,
            zc,
        }
    }
}

/// Aᵀ D̃ A + Gᵀ (WᵀW)⁻¹ G, symmetrised.
fn schur_complement(
    problem: &Reduced,
    scaling: &SideScaling,
    d1: &DVector<f64>,
    d2: &DVector<f64>,
) -> DMatrix<f64> {
    let k = problem.a.ncols();
    let weights = DVector::from_iterator(
        d1.len(),
        d1.iter()
            .zip(d2.iter())
            .map(|(a, b)| (4.0 * a * b / (a + b)).sqrt()),
    );
    let mut scaled = problem.a.clone();
    for mut column in scaled.column_iter_mut() {
        column.component_mul_assign(&weights);
    }
    let mut schur = gram(&scaled);
    if problem.g.nrows() > 0 {
        let mut hg = DMatrix::zeros(problem.g.nrows(), k);
        for (j, column) in problem.g.column_iter().enumerate() {
            let mapped = scaling.apply_inverse_wtw(&problem.segments, &column.into_owned());
            hg.set_column(j, &mapped);
        }
        schur += problem.g.tr_mul(&hg);
    }
    (&schur + schur.transpose()) * 0.5
}

/// A Cholesky factorisation of D^{-1/2} M D^{-1/2}, D = diag(M): the
/// symmetric Jacobi scaling. Near a face of the PSD cones the Schur
/// complement's diagonal spans many orders of magnitude; scaled, its
/// factor is accurate enough for iterative refinement to converge.
struct ScaledCholesky {
    factor: Cholesky,
    /// D^{-1/2}.
    scale: DVector<f64>,
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
fn factorise(mut schur: DMatrix<f64>) -> Option<ScaledCholesky> {
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
    let mut shift = 0.0;
    for _ in 0..4 {
        let mut shifted = schur.clone();
        for i in 0..k {
            shifted[(i, i)] += shift;
        }
        if let Some(factor) = Cholesky::new(&shifted) {
            return Some(ScaledCholesky { factor, scale });
        }
        shift = if shift == 0.0 { 1e-13 } else { shift * 1e3 };
    }
    None
}
