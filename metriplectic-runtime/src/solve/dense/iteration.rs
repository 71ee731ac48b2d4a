//! The interior-point iteration: an infeasible path-following method with
//! Nesterov–Todd scaling and Mehrotra's predictor–corrector (on linear
//! programs also Gondzio's centrality correctors), organised like
//! Clarabel's `solve()` as named steps: residuals, termination, scaling,
//! predictor, centering, corrector, step length, update.

use std::time::Instant;

use nalgebra::DVector;

use super::cones::{
    cone_identity, jordan_divide, jordan_product, orthant_step_limit, shift_into_cones,
    shift_orthant, side_step_limit, slack_step_limit, SideScaling,
};
use super::newton::{reduced_row, Extra, Kkt, Newton};
use super::Reduced;
use crate::solve::{SolveStatus, SolverSettings};

/// Step to this fraction of the distance to the cone boundary.
const STEP_FRACTION: f64 = 0.99;
/// Stop after this many iterations without the merit (the largest of the
/// relative gap and the two relative residuals) falling below
/// `STALL_FACTOR` times its best value. Metric searches on a fast and a
/// slow mode (H's coefficients 0.5 and 500) crawl for 20 iterations or
/// more at steps of 1e-3 to 1e-1, a PSD slack near its boundary, while the
/// primal residual falls slowly, and then converge: 15 ended 95 of 100 of
/// them `InsufficientProgress` and the identification at field error
/// 2.2e-3; 25 lets them finish (`docs/method.md` §4).
const STALL_ITERATIONS: usize = 25;
const STALL_FACTOR: f64 = 0.9;
/// Gondzio's multiple centrality correctors (Colombo & Gondzio 2008): at
/// most `MAX_CORRECTORS` per iteration, each aiming `CORRECTOR_REACH`
/// beyond the current step lengths and kept only if it lengthens the
/// shorter of the two by `CORRECTOR_GAIN` times that reach; the products
/// sᵢzᵢ at the trial point are pulled into [β_min σμ, β_max σμ].
const MAX_CORRECTORS: usize = 3;
const CORRECTOR_REACH: f64 = 0.3;
const CORRECTOR_GAIN: f64 = 0.1;
const BETA_MIN: f64 = 0.1;
const BETA_MAX: f64 = 10.0;
/// Clarabel's reduced tolerances, for [`SolveStatus::AlmostSolved`].
const REDUCED_GAP: f64 = 5e-5;
const REDUCED_FEAS: f64 = 1e-4;

/// The iterate: y and the L1 epigraph variables e, the slacks s and the
/// multipliers z of the two L1 orthants (1, 2) and of the side cones (c).
#[derive(Clone)]
pub(super) struct Point {
    pub y: DVector<f64>,
    e: DVector<f64>,
    s1: DVector<f64>,
    s2: DVector<f64>,
    pub sc: DVector<f64>,
    z1: DVector<f64>,
    z2: DVector<f64>,
    zc: DVector<f64>,
}

impl Point {
    /// A non-finite point, returned when the method cannot even start.
    fn failed(p: &Reduced) -> Self {
        let (k, r, m) = (p.a.ncols(), p.t.len(), p.h.len());
        Point {
            y: DVector::from_element(k, f64::NAN),
            e: DVector::zeros(r),
            s1: DVector::zeros(r),
            s2: DVector::zeros(r),
            sc: DVector::zeros(m),
            z1: DVector::zeros(r),
            z2: DVector::zeros(r),
            zc: DVector::zeros(m),
        }
    }

    /// Every component, not only y's: the convergence tests take maxima
    /// with nalgebra's `amax`, which passes over NaN.
    fn is_finite(&self) -> bool {
        [
            &self.y, &self.e, &self.s1, &self.s2, &self.sc, &self.z1, &self.z2, &self.zc,
        ]
        .iter()
        .all(|v| v.iter().all(|x| x.is_finite()))
    }
}

/// Runs the method on `p`: the final point, its status and the iterations taken.
pub(super) fn iterate(p: &Reduced, settings: &SolverSettings) -> (Point, SolveStatus, u32) {
    let start = Instant::now();
    // A's scaled rows while each Schur complement is formed.
    let mut buffer = Vec::new();
    let Some(mut x) = initial_point(p, &mut buffer) else {
        return (Point::failed(p), SolveStatus::NumericalError, 0);
    };
    let mut progress = Progress::default();
    // Without PSD cones the problem is a linear program, and the primal and
    // dual parts may take their own step lengths, as LP codes do: one
    // blocking component then no longer stalls both.
    let linear = p.segments.iter().all(|s| s.psd.is_none());
    for iteration in 0..=settings.max_iter {
        // Residuals and termination.
        let residuals = Residuals::new(p, &x);
        if settings.verbose {
            residuals.log(iteration);
        }
        if residuals.converged(
            settings.tol_gap_abs,
            settings.tol_gap_rel,
            settings.tol_feas,
        ) {
            return (x, SolveStatus::Solved, iteration);
        }
        progress.record(&residuals, &x);
        let limit = if progress.stalled() {
            // Without a strictly feasible point (e.g. the full SOS tables)
            // the iterates can stall near the optimum and then diverge.
            Some(SolveStatus::InsufficientProgress)
        } else if iteration == settings.max_iter {
            Some(SolveStatus::MaxIterations)
        } else if settings
            .time_limit
            .is_some_and(|limit| start.elapsed().as_secs_f64() > limit)
        {
            Some(SolveStatus::MaxTime)
        } else {
            None
        };
        if let Some(status) = limit {
            return progress.finish(x, status, iteration);
        }

        // Scaling and the Newton system.
        let Some(scaling) = SideScaling::new(&p.segments, &x.sc, &x.zc) else {
            return progress.finish(x, SolveStatus::NumericalError, iteration);
        };
        let Some(step) = Step::new(p, &x, &scaling, &mut buffer) else {
            return progress.finish(x, SolveStatus::NumericalError, iteration);
        };

        // Predictor, centering, corrector.
        let (affine, quadratic) = step.predictor(&residuals);
        let affine_steps = step.step_limits(&affine);
        let sigma = if linear {
            // Mehrotra's σ = (μ_aff / μ)³ with the affine step's own lengths.
            let limits = Steps {
                primal: affine_steps.primal.min(1.0),
                dual: affine_steps.dual.min(1.0),
            };
            let ratio = step.orthant_gap_after(&affine, limits) / residuals.gap;
            if ratio.is_finite() {
                ratio.clamp(0.0, 1.0).powi(3)
            } else {
                1.0
            }
        } else {
            (1.0 - affine_steps.common().primal.min(1.0)).powi(3)
        };
        let mu = residuals.gap / barrier_degree(p);
        let mut combined = step.corrector(&residuals, &affine, quadratic, sigma * mu);
        if linear {
            combined = step.centrality_correctors(combined, sigma * mu);
        }

        // Step length and update.
        let mut steps = step.step_limits(&combined).damped();
        if !linear {
            steps = steps.common();
        }
        let smallest = steps.primal.min(steps.dual);
        if smallest.is_nan() || smallest <= 1e-10 {
            return progress.finish(x, SolveStatus::InsufficientProgress, iteration);
        }
        if settings.verbose {
            eprintln!(
                "               sigma {sigma:.2e} affine step {:.2e}/{:.2e} step {:.2e}/{:.2e}",
                affine_steps.primal, affine_steps.dual, steps.primal, steps.dual
            );
        }
        step.update(&mut x, &combined, steps);
        if !x.is_finite() {
            return progress.finish(x, SolveStatus::NumericalError, iteration);
        }
    }
    (x, SolveStatus::MaxIterations, settings.max_iter)
}

/// ν: the barrier degree (one per orthant component, n per n×n PSD cone).
fn barrier_degree(p: &Reduced) -> f64 {
    (2 * p.t.len()) as f64
        + p.segments
            .iter()
            .map(|s| s.psd.unwrap_or(s.len) as f64)
            .sum::<f64>()
}

/// The best iterate that met the reduced tolerances, and how long the merit
/// has not improved.
#[derive(Default)]
struct Progress {
    best: Option<(f64, Point)>,
    best_merit: Option<f64>,
    stalled: usize,
}

impl Progress {
    fn record(&mut self, residuals: &Residuals, x: &Point) {
        let merit = residuals.merit();
        if residuals.converged(REDUCED_GAP, REDUCED_GAP, REDUCED_FEAS)
            && self.best.as_ref().is_none_or(|(m, _)| merit < *m)
        {
            self.best = Some((merit, x.clone()));
        }
        if merit < STALL_FACTOR * self.best_merit.unwrap_or(f64::INFINITY) {
            (self.best_merit, self.stalled) = (Some(merit), 0);
        } else {
            self.stalled += 1;
        }
    }

    fn stalled(&self) -> bool {
        self.stalled >= STALL_ITERATIONS
    }

    /// Stopping early: the best iterate that met the reduced tolerances, if
    /// any, as `AlmostSolved`; otherwise `x` with `status`.
    fn finish(self, x: Point, status: SolveStatus, iteration: u32) -> (Point, SolveStatus, u32) {
        match self.best {
            Some((_, point)) => (point, SolveStatus::AlmostSolved, iteration),
            None => (x, status, iteration),
        }
    }
}

/// The residuals r_x = Gᵀz + c, r_z = G x + s − h, the objectives and the
/// gap; and, from the same pass over A, Aᵀ of two parts of the Newton
/// right-hand sides' reduced rows ([`reduced_row`]) that depend only on
/// the current point: the predictor's whole right-hand side, and the
/// centring term of the corrector's per unit of σμ.
struct Residuals {
    rx_y: DVector<f64>,
    rx_e: DVector<f64>,
    rz1: DVector<f64>,
    rz2: DVector<f64>,
    rzc: DVector<f64>,
    primal_cost: f64,
    dual_cost: f64,
    gap: f64,
    primal_ok_at: f64,
    dual_ok_at: f64,
    /// The predictor's orthant part, formed in the residuals' pass.
    affine: OrthantPart,
    /// The corrector's centring part per unit of σμ: b_z = −1/z.
    centring: OrthantPart,
}

impl Residuals {
    fn new(p: &Reduced, x: &Point) -> Self {
        // Row i of the predictor's right-hand side needs only (A y)ᵢ and the
        // point (`affine_bz`), and the corrector's centring part only the
        // point, so Aᵀ of both comes from this pass; the corrector's other
        // part needs the predictor and comes from the predictor's pass.
        let (ay, [mut rx_y, affine_product, centring_product]) =
            p.a.mul_then_tr_mul_many(&x.y, |i, ay| {
                let (z1, z2) = (x.z1[i], x.z2[i]);
                let (d1, d2) = (z1 / x.s1[i], z2 / x.s2[i]);
                let (bz1, bz2) = affine_bz(ay, x.e[i], p.t[i]);
                [
                    z2 - z1,
                    reduced_row(d1, d2, -((-z1 - z2) + p.weight), bz1, bz2),
                    reduced_row(d1, d2, 0.0, -1.0 / z1, -1.0 / z2),
                ]
            });
        let r = ay.len();
        let (mut bz1, mut bz2) = (DVector::zeros(r), DVector::zeros(r));
        for i in 0..r {
            (bz1[i], bz2[i]) = affine_bz(ay[i], x.e[i], p.t[i]);
        }
        let affine = OrthantPart {
            z1: bz1,
            z2: bz2,
            product: affine_product,
        };
        let centring = OrthantPart {
            z1: x.z1.map(|z| -1.0 / z),
            z2: x.z2.map(|z| -1.0 / z),
            product: centring_product,
        };
        if p.g.nrows() > 0 {
            rx_y += p.side_rows.tr_mul(&p.g, &x.zc);
        }
        let rx_e = (-&x.z1 - &x.z2).add_scalar(p.weight);
        let rz1 = -&ay - &x.e + &x.s1 + &p.t;
        let rz2 = &ay - &x.e + &x.s2 - &p.t;
        let rzc = p.side_rows.mul(&p.g, &x.y) + &x.sc - &p.h;
        let primal_cost = p.weight * x.e.sum();
        let dual_cost = p.t.dot(&x.z1) - p.t.dot(&x.z2) - p.h.dot(&x.zc);
        let gap = x.s1.dot(&x.z1) + x.s2.dot(&x.z2) + x.sc.dot(&x.zc);
        let x_norm = x.y.amax().max(x.e.amax());
        let s_norm = x.s1.amax().max(x.s2.amax()).max(amax(&x.sc));
        let z_norm = x.z1.amax().max(x.z2.amax()).max(amax(&x.zc));
        let h_norm = p.t.amax().max(amax(&p.h));
        Self {
            rx_y,
            rx_e,
            rz1,
            rz2,
            rzc,
            primal_cost,
            dual_cost,
            gap,
            primal_ok_at: (h_norm + x_norm + s_norm).max(1.0),
            dual_ok_at: (p.weight + x_norm + z_norm).max(1.0),
            affine,
            centring,
        }
    }

    /// The corrector's orthant part for the centre σμ: the predictor's,
    /// plus the part the predictor determined, plus σμ times the centring
    /// part.
    fn corrector_part(&self, quadratic: &OrthantPart, centre: f64) -> OrthantPart {
        self.affine
            .plus_scaled(quadratic, 1.0)
            .plus_scaled(&self.centring, centre)
    }

    fn primal_infeasibility(&self) -> f64 {
        self.rz1.amax().max(self.rz2.amax()).max(amax(&self.rzc)) / self.primal_ok_at
    }

    fn dual_infeasibility(&self) -> f64 {
        self.rx_y.amax().max(self.rx_e.amax()) / self.dual_ok_at
    }

    /// The largest of the relative gap and the two relative residuals.
    fn merit(&self) -> f64 {
        let gap = (self.primal_cost - self.dual_cost).abs()
            / self.primal_cost.abs().min(self.dual_cost.abs()).max(1.0);
        gap.max(self.primal_infeasibility())
            .max(self.dual_infeasibility())
    }

    /// Clarabel's tests: absolute or relative gap, and both residuals.
    fn converged(&self, gap_abs: f64, gap_rel: f64, feas: f64) -> bool {
        let gap = (self.primal_cost - self.dual_cost).abs();
        let scale = self.primal_cost.abs().min(self.dual_cost.abs());
        (gap <= gap_abs || gap <= gap_rel * scale)
            && self.primal_infeasibility() <= feas
            && self.dual_infeasibility() <= feas
    }

    fn log(&self, iteration: u32) {
        eprintln!(
            "dense ipm {iteration:>3}: pcost {:+.8e} dcost {:+.8e} gap {:.2e} pres {:.2e} dres {:.2e}",
            self.primal_cost,
            self.dual_cost,
            self.gap,
            self.primal_infeasibility(),
            self.dual_infeasibility()
        );
    }
}

/// The predictor's b_z on the orthants: −r_z + s = (A y + e − t, −A y + e + t),
/// without the round trip through s.
fn affine_bz(ay: f64, e: f64, t: f64) -> (f64, f64) {
    (ay + e - t, -ay + e + t)
}

/// Row i of the corrector's b_z that the predictor determines:
/// Δs̃ᵢΔz̃ᵢ/zᵢ with Δz̃ = w dz, Δs̃ = ξ − Δz̃ and 1/z = w/λ.
fn quadratic_bz(xi: f64, w: f64, lambda: f64, dz: f64) -> f64 {
    let dz_scaled = w * dz;
    (xi - dz_scaled) * dz_scaled * (w / lambda)
}

/// The orthants' part (b_z₁, b_z₂) of a Newton right-hand side, with Aᵀ of
/// its reduced rows ([`reduced_row`], with b_e where it has one) formed in
/// a pass over A the iteration makes anyway. The solve is then given both
/// and skips its own pass; the values must be the very ones that pass
/// used, since near the optimum D̃ reaches 1e9 and turns a last-bit
/// difference between two ways of forming b_z into a residual that costs
/// a refinement step.
struct OrthantPart {
    z1: DVector<f64>,
    z2: DVector<f64>,
    product: DVector<f64>,
}

impl OrthantPart {
    /// self + `scale` · other: the reduced rows are linear in b_z.
    fn plus_scaled(&self, other: &OrthantPart, scale: f64) -> OrthantPart {
        OrthantPart {
            z1: &self.z1 + &other.z1 * scale,
            z2: &self.z2 + &other.z2 * scale,
            product: &self.product + &other.product * scale,
        }
    }
}

fn amax(v: &DVector<f64>) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.amax()
    }
}

/// Step lengths for the primal (y, e, s) and dual (z) parts of a direction.
#[derive(Clone, Copy)]
struct Steps {
    primal: f64,
    dual: f64,
}

impl Steps {
    /// The common step min(primal, dual).
    fn common(self) -> Self {
        let alpha = self.primal.min(self.dual);
        Self {
            primal: alpha,
            dual: alpha,
        }
    }

    /// `STEP_FRACTION` of each limit, at most 1.
    fn damped(self) -> Self {
        Self {
            primal: (STEP_FRACTION * self.primal).min(1.0),
            dual: (STEP_FRACTION * self.dual).min(1.0),
        }
    }
}

/// A complementarity target d_s in the scaled space, per cone block.
struct Target {
    s1: DVector<f64>,
    s2: DVector<f64>,
    sc: DVector<f64>,
}

/// A direction in (y, e, s, z), with the scaled slack and multiplier
/// directions W⁻ᵀ ds and W dz the step length needs.
struct Direction {
    /// The side-cone slacks' direction, from the residual equation
    /// G dy + ds = −r_z (see [`slack_step_limit`]).
    sc: DVector<f64>,
    y: DVector<f64>,
    e: DVector<f64>,
    z1: DVector<f64>,
    z2: DVector<f64>,
    zc: DVector<f64>,
    s1_scaled: DVector<f64>,
    s2_scaled: DVector<f64>,
    sc_scaled: DVector<f64>,
    z1_scaled: DVector<f64>,
    z2_scaled: DVector<f64>,
    zc_scaled: DVector<f64>,
}

impl Direction {
    fn plus(&self, other: &Direction) -> Direction {
        Direction {
            sc: &self.sc + &other.sc,
            y: &self.y + &other.y,
            e: &self.e + &other.e,
            z1: &self.z1 + &other.z1,
            z2: &self.z2 + &other.z2,
            zc: &self.zc + &other.zc,
            s1_scaled: &self.s1_scaled + &other.s1_scaled,
            s2_scaled: &self.s2_scaled + &other.s2_scaled,
            sc_scaled: &self.sc_scaled + &other.sc_scaled,
            z1_scaled: &self.z1_scaled + &other.z1_scaled,
            z2_scaled: &self.z2_scaled + &other.z2_scaled,
            zc_scaled: &self.zc_scaled + &other.zc_scaled,
        }
    }
}

/// Everything one iteration's directions share: the scaling of every cone
/// and the factorised Newton system.
struct Step<'a> {
    problem: &'a Reduced,
    scaling: &'a SideScaling,
    newton: Newton<'a>,
    /// λ = √(s z) and w = √(s/z) of the two L1 orthants.
    lambda1: DVector<f64>,
    lambda2: DVector<f64>,
    w1: DVector<f64>,
    w2: DVector<f64>,
    /// λ of the side cones (diagonal on PSD blocks).
    lambda_c: DVector<f64>,
    /// The side-cone slacks at the current point.
    sc: DVector<f64>,
}

impl<'a> Step<'a> {
    fn new(
        p: &'a Reduced,
        x: &Point,
        scaling: &'a SideScaling,
        buffer: &mut Vec<f64>,
    ) -> Option<Self> {
        let d1 = x.z1.component_div(&x.s1);
        let d2 = x.z2.component_div(&x.s2);
        let newton = Newton::new(p, scaling, d1, d2, buffer)?;
        Some(Self {
            problem: p,
            scaling,
            newton,
            lambda1: x.s1.component_mul(&x.z1).map(f64::sqrt),
            lambda2: x.s2.component_mul(&x.z2).map(f64::sqrt),
            w1: x.s1.component_div(&x.z1).map(f64::sqrt),
            w2: x.s2.component_div(&x.z2).map(f64::sqrt),
            lambda_c: DVector::from_column_slice(&scaling.lambda),
            sc: x.sc.clone(),
        })
    }

    /// The predictor's target d_s = −λ∘λ.
    fn affine_target(&self) -> Target {
        Target {
            s1: -self.lambda1.component_mul(&self.lambda1),
            s2: -self.lambda2.component_mul(&self.lambda2),
            sc: -jordan_product(&self.problem.segments, &self.lambda_c, &self.lambda_c),
        }
    }

    /// The corrector's target d_s = −λ∘λ − Δs̃∘Δz̃ + σμe.
    fn corrector_target(&self, affine: &Direction, target: f64) -> Target {
        let segments = &self.problem.segments;
        let m = self.problem.h.len();
        let lambda_sq_c = jordan_product(segments, &self.lambda_c, &self.lambda_c);
        Target {
            s1: (-self.lambda1.component_mul(&self.lambda1)
                - affine.s1_scaled.component_mul(&affine.z1_scaled))
            .add_scalar(target),
            s2: (-self.lambda2.component_mul(&self.lambda2)
                - affine.s2_scaled.component_mul(&affine.z2_scaled))
            .add_scalar(target),
            sc: -&lambda_sq_c - jordan_product(segments, &affine.sc_scaled, &affine.zc_scaled)
                + cone_identity(segments, m) * target,
        }
    }

    /// The predictor: the direction for the target −λ∘λ, and the part of
    /// the corrector's right-hand side it determines (b_z = Δs̃∘Δz̃ ⊘ z),
    /// with Aᵀ of its reduced rows formed in the pass that checks the
    /// predictor; `None` if a refinement step replaced that solution. The
    /// predictor's own product comes from the residuals' pass.
    fn predictor(&self, residuals: &Residuals) -> (Direction, Option<OrthantPart>) {
        let target = self.affine_target();
        let xi1 = target.s1.component_div(&self.lambda1);
        let xi2 = target.s2.component_div(&self.lambda2);
        let quadratic = |i: usize, dz1: f64, dz2: f64| {
            (
                quadratic_bz(xi1[i], self.w1[i], self.lambda1[i], dz1),
                quadratic_bz(xi2[i], self.w2[i], self.lambda2[i], dz2),
            )
        };
        let fused_row = |i: usize, dz1: f64, dz2: f64| {
            let (q1, q2) = quadratic(i, dz1, dz2);
            self.newton.reduced_row(i, 0.0, q1, q2)
        };
        let (direction, product) = self.direction_fused(
            residuals,
            &target,
            Some(&residuals.affine),
            Some(&fused_row),
        );
        let part = product.map(|product| {
            let r = direction.z1.len();
            let (mut z1, mut z2) = (DVector::zeros(r), DVector::zeros(r));
            for i in 0..r {
                (z1[i], z2[i]) = quadratic(i, direction.z1[i], direction.z2[i]);
            }
            OrthantPart { z1, z2, product }
        });
        (direction, part)
    }

    /// The corrector for the centre σμ after the predictor `affine`, whose
    /// part of the right-hand side is `quadratic`: the orthants' b_z is the
    /// predictor's, plus that part, plus σμ times the centring part, and so
    /// is Aᵀ of the reduced rows. Without `quadratic` the solve makes its
    /// own pass.
    fn corrector(
        &self,
        residuals: &Residuals,
        affine: &Direction,
        quadratic: Option<OrthantPart>,
        centre: f64,
    ) -> Direction {
        let target = self.corrector_target(affine, centre);
        let known = quadratic.map(|quadratic| residuals.corrector_part(&quadratic, centre));
        self.direction_fused(residuals, &target, known.as_ref(), None)
            .0
    }

    /// The Newton direction for a complementarity target: ξ = λ ⊘ d_s,
    /// bz = −r_z − Wᵀξ (on the side cones in the scaled space,
    /// W⁻ᵀbz = −W⁻ᵀr_z − ξ), and back ds = Wᵀ(ξ − W dz).
    #[cfg(test)]
    fn direction(&self, residuals: &Residuals, target: &Target) -> Direction {
        self.direction_fused(residuals, target, None, None).0
    }

    /// [`Step::direction`] with the passes over A it shares: `known`, the
    /// orthants' part of the right-hand side with its product, formed in an
    /// earlier pass (it equals the target's up to rounding); `extra`, a
    /// further weight per row formed in the solve's check pass, whose Aᵀ is
    /// returned ([`Newton::solve_fused`]).
    fn direction_fused(
        &self,
        residuals: &Residuals,
        target: &Target,
        known: Option<&OrthantPart>,
        extra: Option<&Extra<'_>>,
    ) -> (Direction, Option<DVector<f64>>) {
        let (mut rhs, xi) = self.right_hand_side(residuals, target);
        if let Some(known) = known {
            rhs.z1.copy_from(&known.z1);
            rhs.z2.copy_from(&known.z2);
        }
        let product = known.map(|known| &known.product);
        let (solution, fused) = self.newton.solve_fused(&rhs, product, extra);
        (self.assemble(solution, xi, -&residuals.rzc), fused)
    }

    /// The Newton right-hand side for a complementarity target, and the
    /// scaled targets ξ of the three cone blocks.
    fn right_hand_side(&self, residuals: &Residuals, target: &Target) -> (Kkt, [DVector<f64>; 3]) {
        let segments = &self.problem.segments;
        let xi1 = target.s1.component_div(&self.lambda1);
        let xi2 = target.s2.component_div(&self.lambda2);
        let xic = jordan_divide(segments, &self.scaling.lambda, &target.sc);
        let bz1 = -&residuals.rz1 - self.w1.component_mul(&xi1);
        let bz2 = -&residuals.rz2 - self.w2.component_mul(&xi2);
        let bzc = -self.scaling.apply_inverse_wt(segments, &residuals.rzc) - &xic;
        let rhs = Kkt {
            y: -&residuals.rx_y,
            e: -&residuals.rx_e,
            z1: bz1,
            z2: bz2,
            zc: bzc,
        };
        (rhs, [xi1, xi2, xic])
    }

    /// The direction from a Newton solution, the scaled targets ξ of the
    /// three cone blocks and the side slacks' part −r_z of ds.
    fn assemble(
        &self,
        solution: Kkt,
        [xi1, xi2, xic]: [DVector<f64>; 3],
        mut sc: DVector<f64>,
    ) -> Direction {
        let Kkt {
            y,
            e,
            z1,
            z2,
            zc: zc_scaled,
        } = solution;
        let z1_scaled = self.w1.component_mul(&z1);
        let z2_scaled = self.w2.component_mul(&z2);
        let zc = self
            .scaling
            .apply_inverse_w(&self.problem.segments, &zc_scaled);
        if self.problem.g.nrows() > 0 {
            sc -= self.problem.side_rows.mul(&self.problem.g, &y);
        }
        Direction {
            sc,
            s1_scaled: &xi1 - &z1_scaled,
            s2_scaled: &xi2 - &z2_scaled,
            sc_scaled: &xic - &zc_scaled,
            y,
            e,
            z1,
            z2,
            zc,
            z1_scaled,
            z2_scaled,
            zc_scaled,
        }
    }

    /// The change of the direction when the orthants' targets change by
    /// (t₁, t₂) and nothing else: the Newton system with no residual part.
    /// Only the orthant rows of the right-hand side are non-zero, usually a
    /// few dozen of them, so the solve skips most of one pass over A.
    fn target_change(&self, t1: &DVector<f64>, t2: &DVector<f64>) -> Direction {
        let (k, r, m) = (self.problem.a.ncols(), t1.len(), self.problem.h.len());
        let xi1 = t1.component_div(&self.lambda1);
        let xi2 = t2.component_div(&self.lambda2);
        let solution = self.newton.solve(&Kkt {
            y: DVector::zeros(k),
            e: DVector::zeros(r),
            z1: -self.w1.component_mul(&xi1),
            z2: -self.w2.component_mul(&xi2),
            zc: DVector::zeros(m),
        });
        self.assemble(solution, [xi1, xi2, DVector::zeros(m)], DVector::zeros(m))
    }

    /// Gondzio's multiple centrality correctors. The predictor–corrector
    /// step on a large L1 regression is cut short by a few dozen of its
    /// tens of thousands of orthant components, iteration after iteration,
    /// and the iteration count then grows with the number of samples.
    /// Each corrector aims at the point a step `CORRECTOR_REACH` longer
    /// would reach, asks there for the products sᵢzᵢ that left
    /// [β_min σμ, β_max σμ] to move back in, and is kept if the steps grow.
    /// Its right-hand side is zero except at those components.
    fn centrality_correctors(&self, mut d: Direction, centre: f64) -> Direction {
        let mut steps = self.step_limits(&d);
        let (low, high) = (BETA_MIN * centre, BETA_MAX * centre);
        // The shorter step bounds the progress of both halves.
        let length = |s: Steps| s.primal.min(s.dual).min(1.0);
        for _ in 0..MAX_CORRECTORS {
            if length(steps) >= 1.0 {
                break;
            }
            let trial = Steps {
                primal: (steps.primal + CORRECTOR_REACH).min(1.0),
                dual: (steps.dual + CORRECTOR_REACH).min(1.0),
            };
            let recentre = |lambda: &DVector<f64>, ds: &DVector<f64>, dz: &DVector<f64>| {
                DVector::from_iterator(
                    lambda.len(),
                    lambda
                        .as_slice()
                        .iter()
                        .zip(ds.as_slice())
                        .zip(dz.as_slice())
                        .map(|((l, ds), dz)| {
                            let product = (l + trial.primal * ds) * (l + trial.dual * dz);
                            if product < low {
                                low - product
                            } else if product > high {
                                // Capped, so that one far-off product does not
                                // dominate the correction.
                                (high - product).max(-high)
                            } else {
                                0.0
                            }
                        }),
                )
            };
            let t1 = recentre(&self.lambda1, &d.s1_scaled, &d.z1_scaled);
            let t2 = recentre(&self.lambda2, &d.s2_scaled, &d.z2_scaled);
            let candidate = d.plus(&self.target_change(&t1, &t2));
            let candidate_steps = self.step_limits(&candidate);
            if length(candidate_steps) < length(steps) + CORRECTOR_GAIN * CORRECTOR_REACH {
                break;
            }
            (d, steps) = (candidate, candidate_steps);
        }
        d
    }

    /// The largest steps along `d` that keep the slacks (primal) and the
    /// multipliers (dual) in their cones.
    fn step_limits(&self, d: &Direction) -> Steps {
        let limit = |pairs: [(&DVector<f64>, &DVector<f64>); 2]| {
            pairs
                .iter()
                .map(|(l, v)| orthant_step_limit(l.as_slice(), v.as_slice()))
                .fold(f64::INFINITY, f64::min)
        };
        let segments = &self.problem.segments;
        let lambda = self.lambda_c.as_slice();
        let slack_limit = slack_step_limit(segments, &self.sc, &d.sc)
            .unwrap_or_else(|| side_step_limit(segments, lambda, &d.sc_scaled));
        Steps {
            primal: limit([(&self.lambda1, &d.s1_scaled), (&self.lambda2, &d.s2_scaled)])
                .min(slack_limit),
            dual: limit([(&self.lambda1, &d.z1_scaled), (&self.lambda2, &d.z2_scaled)])
                .min(side_step_limit(segments, lambda, &d.zc_scaled)),
        }
    }

    /// The complementarity Σ sᵢzᵢ of the orthants after the steps `steps`
    /// along `d` (in the scaled space sᵢzᵢ = (λ + αₚ Δs̃)ᵢ (λ + α_d Δz̃)ᵢ).
    fn orthant_gap_after(&self, d: &Direction, steps: Steps) -> f64 {
        let pairs = [
            (&self.lambda1, &d.s1_scaled, &d.z1_scaled),
            (&self.lambda2, &d.s2_scaled, &d.z2_scaled),
            (&self.lambda_c, &d.sc_scaled, &d.zc_scaled),
        ];
        pairs
            .iter()
            .flat_map(|(l, ds, dz)| l.as_slice().iter().zip(ds.as_slice()).zip(dz.as_slice()))
            .map(|((l, ds), dz)| (l + steps.primal * ds) * (l + steps.dual * dz))
            .sum()
    }

    /// x ← x + α d; the L1 slacks mapped back from the scaled space
    /// (ds = w∘Δs̃, diagonal and exact), the side-cone slacks along `d.sc`.
    fn update(&self, x: &mut Point, d: &Direction, steps: Steps) {
        let (alpha, beta) = (steps.primal, steps.dual);
        x.y += &d.y * alpha;
        x.e += &d.e * alpha;
        x.s1 += self.w1.component_mul(&d.s1_scaled) * alpha;
        x.s2 += self.w2.component_mul(&d.s2_scaled) * alpha;
        x.sc += &d.sc * alpha;
        x.z1 += &d.z1 * beta;
        x.z2 += &d.z2 * beta;
        x.zc += &d.zc * beta;
    }
}

/// `coneqp`'s starting point: least-squares primal and least-norm dual
/// solutions of the KKT system with W = I, shifted into the cones.
fn initial_point(p: &Reduced, buffer: &mut Vec<f64>) -> Option<Point> {
    let (k, r, m) = (p.a.ncols(), p.t.len(), p.h.len());
    let identity = SideScaling::identity(&p.segments, m);
    let ones = DVector::from_element(r, 1.0);
    let newton = Newton::new(p, &identity, ones.clone(), ones, buffer)?;
    let zero_r = DVector::zeros(r);
    // Primal: bz = h gives dz = G x − h = −s.
    let Kkt { y, e, z1, z2, zc } = newton.solve(&Kkt {
        y: DVector::zeros(k),
        e: zero_r.clone(),
        z1: -&p.t,
        z2: p.t.clone(),
        zc: p.h.clone(),
    });
    let mut s1 = -z1;
    let mut s2 = -z2;
    let mut sc = -zc;
    shift_orthant(&mut s1, &mut s2);
    shift_into_cones(&p.segments, &mut sc);
    // Dual: bx = −c gives G x = z with Gᵀ z = −c.
    let Kkt {
        mut z1,
        mut z2,
        mut zc,
        ..
    } = newton.solve(&Kkt {
        y: DVector::zeros(k),
        e: DVector::from_element(r, -p.weight),
        z1: zero_r.clone(),
        z2: zero_r,
        zc: DVector::zeros(m),
    });
    shift_orthant(&mut z1, &mut z2);
    shift_into_cones(&p.segments, &mut zc);
    Some(Point {
        y,
        e,
        s1,
        s2,
        sc,
        z1,
        z2,
        zc,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::dense::tests::{box_problem, random_regression, reduced};

    /// The predictor and the corrector take parts of their right-hand
    /// sides' products from passes the iteration makes anyway (the
    /// residuals' pass, the predictor's check): both must equal the
    /// directions solved from the whole right-hand side.
    #[test]
    fn fused_right_hand_sides_give_the_same_directions() {
        let p = reduced(&box_problem(random_regression(400, 6, 11), 10.0));
        let mut x = initial_point(&p, &mut Vec::new()).unwrap();
        // Away from the starting point, where the products are uneven.
        x.z1.iter_mut()
            .enumerate()
            .for_each(|(i, z)| *z *= 1.0 + (i % 7) as f64);
        x.s2.iter_mut()
            .enumerate()
            .for_each(|(i, s)| *s *= 1.0 + (i % 5) as f64 * 0.3);
        let residuals = Residuals::new(&p, &x);
        let scaling = SideScaling::new(&p.segments, &x.sc, &x.zc).unwrap();
        let step = Step::new(&p, &x, &scaling, &mut Vec::new()).unwrap();
        let (affine, quadratic) = step.predictor(&residuals);
        let plain = step.direction(&residuals, &step.affine_target());
        let centre = 0.3 * residuals.gap / barrier_degree(&p);
        // The parts formed in earlier passes are the right-hand sides' own
        // b_z, and their products Aᵀ of the reduced rows: a wrong one would
        // only cost refinement steps, so check them directly.
        let check = |part: &OrthantPart, target: &Target| {
            let (rhs, _) = step.right_hand_side(&residuals, target);
            let rows = DVector::from_fn(rhs.e.len(), |i, _| {
                step.newton.reduced_row(i, rhs.e[i], rhs.z1[i], rhs.z2[i])
            });
            let pairs = [
                (&part.z1, &rhs.z1),
                (&part.z2, &rhs.z2),
                (&part.product, &p.a.tr_mul(&rows)),
            ];
            for (got, want) in pairs {
                let error = (got - want).amax() / want.amax();
                assert!(error < 1e-10, "relative error {error}");
            }
        };
        check(&residuals.affine, &step.affine_target());
        let corrector_target = step.corrector_target(&affine, centre);
        let quadratic = quadratic.expect("the predictor's solve was refined");
        check(
            &residuals.corrector_part(&quadratic, centre),
            &corrector_target,
        );
        let quadratic = Some(quadratic);
        let corrector = step.corrector(&residuals, &affine, quadratic, centre);
        let plain_corrector = step.direction(&residuals, &corrector_target);
        for (a, b) in [(&affine, &plain), (&corrector, &plain_corrector)] {
            for (u, v) in [(&a.y, &b.y), (&a.e, &b.e), (&a.z1, &b.z1), (&a.z2, &b.z2)] {
                let scale = v.amax().max(1.0);
                assert!(
                    (u - v).amax() <= 1e-9 * scale,
                    "{} vs {}",
                    v.amax(),
                    (u - v).amax()
                );
            }
        }
        // The corrector differs from the predictor: the test would see a
        // missing part.
        assert!((&corrector.y - &affine.y).amax() > 1e-6);
    }

    /// A corrector is solved as the change of the direction when only the
    /// orthants' targets change, with a right-hand side that is zero but in
    /// a few rows (the sparse product with A): it must equal the difference
    /// of the two full directions.
    #[test]
    fn a_target_change_is_the_difference_of_two_directions() {
        let p = reduced(&box_problem(random_regression(400, 6, 11), 10.0));
        let x = initial_point(&p, &mut Vec::new()).unwrap();
        let residuals = Residuals::new(&p, &x);
        let scaling = SideScaling::new(&p.segments, &x.sc, &x.zc).unwrap();
        let step = Step::new(&p, &x, &scaling, &mut Vec::new()).unwrap();
        let target = step.affine_target();
        let before = step.direction(&residuals, &target);
        let sparse = |rows: &[usize]| {
            DVector::from_fn(400, |i, _| {
                if rows.contains(&i) {
                    0.3 + i as f64 * 1e-3
                } else {
                    0.0
                }
            })
        };
        let (t1, t2) = (sparse(&[3, 97, 250]), sparse(&[5, 97, 399]));
        let changed = Target {
            s1: &target.s1 + &t1,
            s2: &target.s2 + &t2,
            sc: target.sc.clone(),
        };
        let after = step.direction(&residuals, &changed);
        let sum = before.plus(&step.target_change(&t1, &t2));
        let pairs = [
            (&after.y, &sum.y),
            (&after.e, &sum.e),
            (&after.z1, &sum.z1),
            (&after.z2, &sum.z2),
            (&after.zc, &sum.zc),
            (&after.sc, &sum.sc),
            (&after.s1_scaled, &sum.s1_scaled),
            (&after.z2_scaled, &sum.z2_scaled),
        ];
        for (a, b) in pairs {
            let scale = a.amax().max(1.0);
            assert!(
                (a - b).amax() <= 1e-9 * scale,
                "{} vs {}",
                a.amax(),
                (a - b).amax()
            );
        }
        // The change is not negligible: the test would see a wrong one.
        assert!((&after.y - &before.y).amax() > 1e-6);
    }
}
