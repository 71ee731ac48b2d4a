//! A structure-preserving integrator: Gonzalez's midpoint discrete gradient
//! with a fixed step ([`Method::DiscreteGradient`](super::Method)).
//!
//! # The discrete gradient
//!
//! For a function F, states x, x′, x̄ = (x + x′)/2 and Δ = x′ − x,
//!
//! ```text
//! ∇̄F(x, x′) = ∇F(x̄) + [(F(x′) − F(x) − ∇F(x̄)·Δ) / |Δ|²] Δ      (∇F(x̄) if Δ = 0),
//! ```
//!
//! so that F(x′) − F(x) = ∇̄F(x, x′)·Δ exactly, and ∇̄F = ∇F(x̄) + O(|Δ|²).
//!
//! # The generalized form
//!
//! For a system that is not declared `classical;` one step of size h solves
//!
//! ```text
//! x′ = x + h (Π(x̄) + K(x̄)) ∇̄E(x, x′)
//! ```
//!
//! for x′. Then E(x′) − E(x) = ∇̄E·Δ = h ∇̄Eᵀ (Π + K) ∇̄E = h ∇̄Eᵀ K(x̄) ∇̄E ≥ 0
//! (Π is antisymmetric, K ⪰ 0): the free energy never decreases, **for every
//! step size h**, not only in the limit h → 0. The scheme is symmetric and
//! second order.
//!
//! # The classical form
//!
//! For a system declared `classical;` (`S::CLASSICAL` is `Some`: Π∇S ≡ 0
//! and K∇H ≡ 0) H and S get separate discrete gradients a = ∇̄H(x, x′) and
//! b = ∇̄S(x, x′), and the operators are projected (in the manner of
//! Öttinger's and Shang–Öttinger's GENERIC integrators): with
//! P = I − a aᵀ/|a|² and Q = I − b bᵀ/|b|² (the identity when the gradient
//! is zero),
//!
//! ```text
//! x′ = x + h ( Q Π(x̄) Q a + P K(x̄) P b ).
//! ```
//!
//! Then H(x′) − H(x) = aᵀΔ = 0 (Q Π Q is antisymmetric, and P a = 0) and
//! S(x′) − S(x) = bᵀΔ = h bᵀ P K P b ≥ 0 (Q b = 0, and P K P ⪰ 0): H is
//! conserved and S produced for every step size and **for every model**,
//! also one whose constraints hold only approximately (an identified model,
//! up to the solver's tolerances). For an exactly classical model
//! Π(x̄) b = Π(x̄)∇S(x̄) + O(h²) = O(h²) and K(x̄) a = O(h²), so the
//! projections change the step by O(h³) (as long as ∇H and ∇S stay away
//! from zero): the scheme is consistent with ẋ = Π∇H + K∇S, symmetric,
//! and second order. For an approximately classical model it integrates
//! that classical part, which differs from the model's vector field
//! (Π + K)(∇H + ∇S) by the constraint residual Π∇S + K∇H.
//!
//! # Solving the implicit equation
//!
//! The identities above hold for the *exact* solution of the implicit
//! equation x′ = Φ(x′), so it is solved to rounding. The guess is the
//! previous increments extrapolated (x itself for the first step, and again
//! if the iteration from the extrapolation fails). Each iteration moves x′
//! by J⁻¹(Φ(x′) − x′): J = I is the fixed-point iteration, which contracts
//! only while h/2 times the Lipschitz constant of the vector field is below
//! 1, no better than an explicit method's stability limit; J ≈ I − Φ′(x′)
//! by forward differences is simplified Newton. The iteration starts as a
//! fixed point and takes a Jacobian (n extra evaluations of Φ) whenever an
//! update falls by less than a factor 10⁴; the Jacobian is kept across
//! steps and refactored for a new step size. A Newton step that raises the
//! residual ‖Φ(x′) − x′‖ is halved (damped Newton), which lets the first
//! step from a stiff start converge where the full step diverges. Measured
//! on a quartic test flow (`newton_takes_steps_the_fixed_point_iteration_cannot`):
//! the fixed point alone needs 7.5 / 11.4 / 19.5 evaluations of Φ per step
//! at h = 0.01 / 0.05 / 0.2 and diverges at h = 0.5; with Newton 5.1 / 5.9 /
//! 7.0, and 8.7 at h = 0.5.
//!
//! It stops once the update stops decreasing and is at most 64 ulps of
//! the state, 64ε·max(‖x‖, ‖x′‖) (ε the machine epsilon), plus the rounding
//! of Φ itself (below), and accepts the iterate with the smallest update
//! if its residual ‖Φ(x′) − x′‖ is within that bound too, or a Jacobian
//! taken at that iterate confirms the update (a Jacobian from an earlier
//! iterate can make the update small where the residual is not);
//! at most 200 evaluations of Φ and 10 Jacobians per step. An iteration
//! that diverges, or stalls above that bound, is a
//! [`SimulationError::StepNotConverged`] naming the step: a smaller step
//! brings the guess closer and the equation nearer the identity. The
//! equation need not have a solution near x when h is far beyond the time
//! scale of the flow: the paper's 2-D system from |q| ≈ 1.5, where
//! |λ| ≈ 2000, needs h ≤ 0.01 for its first step.
//!
//! # Rounding
//!
//! F(x′) − F(x) − ∇F(x̄)·Δ is O(|Δ|³), while evaluating F rounds by up to
//! ρ(x) = (p + r)·ε·(|H(x)| + Σₖ|ψₖφₖ(x)|) (p entropy terms of degree ≤ r,
//! the bound [`simulate`](crate::simulate) uses). Near an equilibrium, where
//! |Δ| is tiny, the quotient by |Δ|² would turn that rounding into a
//! gradient of size ρ/|Δ| that jitters with every ulp of x′: the iteration
//! could not converge and the state would wander. The numerator is therefore
//! treated as zero when it is within the rounding bound
//! ½(ρ(x) + ρ(x′)) of its evaluation, kept in full beyond twice that, and
//! blended linearly in between (a continuous map). The identity then holds
//! up to ρ(x) + ρ(x′) instead of exactly, which is the rounding of E at both
//! ends that the free-energy check allows anyway.
//!
//! Where the correction is kept, its rounding, up to 2(ρ(x) + ρ(x′))/|Δ|,
//! and that of ∇F(x̄), (p + r)·ε times the magnitude of the gradient's
//! terms, pass through h(Π + K) into Φ: no iterate can have a smaller
//! update than that, so it is added to the stopping bound. The residual
//! left enters the free-energy tolerance of [`simulate`](crate::simulate)
//! as measured.
//!
//! # Steps and outputs
//!
//! Each interval between consecutive output times (or [t₀, t_end] for
//! [`OutputTimes::Steps`]) is divided into the fewest equal steps no longer
//! than h, so outputs are step ends and no interpolation is needed; output
//! times that are multiples of h from t₀ give steps of exactly h. With
//! `OutputTimes::Steps` every step is an output.

use nalgebra::{DMatrix, DVectorViewMut, Dyn, LU};

use super::dopri::{interval_offsets, IntegrationStats, OutputTimes};
use crate::error::{invalid, Num, Result, SimulationError};
use crate::model::Model;
use crate::system::{CertificateMode, MetriplecticSystem};

/// Largest number of iterations of one implicit equation.
const MAX_ITERATIONS: u32 = 200;

/// An iterate is accepted once its update is at most this many ulps of the
/// state and no longer falls: the map's own rounding (the discrete
/// gradient's quotient, the classical projections) leaves updates of a few
/// ulps that do not shrink further; measured up to 5.3 ulps on the
/// classical rigid body at |p| ≈ 1.2.
const ACCEPT_ULPS: f64 = 64.0;

/// An iteration whose update falls by less than this factor is too slow:
/// it gets a (new) Jacobian. Measured on the quartic test flow at
/// h = 0.01…0.5: 0.1 → 7.5–13.2 evaluations per step, 1e-2 → 6.3–11,
/// 1e-3 → 5.8–9.1, 1e-4 → 5.2–9.0, 1e-5 → 4.9–8.9 (a fresh Jacobian costs
/// n evaluations but gains about 8 digits per iteration).
const SLOW: f64 = 1e-4;

/// Jacobians computed at most per step.
const MAX_JACOBIANS: u32 = 10;

/// The smallest fraction of a Newton step damping tries.
const MIN_FRACTION: f64 = 1.0 / 1024.0;

/// The result of [`integrate`]: outputs and the free-energy tolerance of
/// each pair of consecutive outputs.
pub(super) struct Output {
    pub times: Vec<f64>,
    pub states: Vec<f64>,
    /// The end time and state of every step (row-major), for systems with
    /// an on-region certificate only (empty otherwise).
    pub step_times: Vec<f64>,
    pub step_states: Vec<f64>,
    pub stats: IntegrationStats,
    /// τₖ for outputs k and k + 1 (see [`simulate`](crate::simulate)).
    pub tolerances: Vec<f64>,
}

/// H, S and their rounding bounds at one state.
#[derive(Debug, Clone, Copy, Default)]
struct Energy {
    hamiltonian: f64,
    entropy: f64,
    /// (p + r)·ε·|H|.
    rounding_h: f64,
    /// (p + r)·ε·Σ|ψₖφₖ|.
    rounding_s: f64,
    /// |H| + Σ|ψₖφₖ|, the size of the terms E is summed from.
    size: f64,
}

impl Energy {
    /// E = H + S, evaluated exactly as [`Model::free_energy`] does.
    fn free_energy(&self) -> f64 {
        self.hamiltonian + self.entropy
    }

    fn rounding(&self) -> f64 {
        self.rounding_h + self.rounding_s
    }
}

/// Integrates `model` with the discrete-gradient scheme of step at most
/// `step` from `x0` over [t0, t_end], reporting at `output`. `x0`, the
/// interval and the outputs are already validated; `step` must be finite
/// and positive.
pub(super) fn integrate<S: MetriplecticSystem>(
    model: &Model<S>,
    x0: &[f64],
    (t0, t_end): (f64, f64),
    step: f64,
    max_steps: u32,
    output: &OutputTimes,
    factor: f64,
) -> Result<Output> {
    integrate_with(
        model,
        x0,
        (t0, t_end),
        step,
        max_steps,
        output,
        factor,
        MAX_JACOBIANS,
    )
}

/// [`integrate`] with at most `max_jacobians` Jacobians per step (0: the
/// fixed-point iteration alone, which the tests compare against).
#[allow(clippy::too_many_arguments)]
fn integrate_with<S: MetriplecticSystem>(
    model: &Model<S>,
    x0: &[f64],
    (t0, t_end): (f64, f64),
    step: f64,
    max_steps: u32,
    output: &OutputTimes,
    factor: f64,
    max_jacobians: u32,
) -> Result<Output> {
    let n = S::DIM;
    let span = t_end - t0;
    // Offsets from t0 of the outputs; with `Steps`, every step is one too.
    let landmarks: Vec<f64> = match output {
        OutputTimes::Steps => vec![0.0, span],
        OutputTimes::Interval(dt) => interval_offsets(span, *dt).collect(),
        OutputTimes::Times(times) => times.iter().map(|t| t - t0).collect(),
    };
    let every_step = matches!(output, OutputTimes::Steps);
    let mut total_steps: u64 = 0;
    let mut previous = 0.0;
    for &tau in &landmarks {
        total_steps = total_steps.saturating_add(steps_between(previous, tau, step));
        previous = tau;
    }
    if total_steps > u64::from(max_steps) {
        // A count past u64 (a step of 1e-300) is told by its size.
        let needed = if total_steps == u64::MAX {
            format!("about {:.1e}", span.abs() / step)
        } else {
            total_steps.to_string()
        };
        return Err(invalid(
            "discrete-gradient step",
            format!(
                "{} over [{}, {}] needs {needed} steps, more than \
                 `integrator.max_steps` = {max_steps} (raise it or take a larger step)",
                Num(step),
                Num(t0),
                Num(t_end)
            ),
        ));
    }
    // Every step's state is kept (the region checks read them), and with
    // `Steps` its output too: a count beyond memory aborted the process (a
    // probe: a step of 1e-8 over [0, 40] with `max_steps` u32::MAX).
    let per_step = if every_step { 3 * n + 4 } else { n + 1 };
    let kept = total_steps as f64 * per_step as f64;
    if kept > super::dopri::MAX_OUTPUT_VALUES {
        return Err(invalid(
            "discrete-gradient step",
            format!(
                "{} over [{}, {}] takes {total_steps} steps, and their {} states would be kept: \
                 more than the 10⁸ values (800 MB) a simulation keeps (take a larger step or a \
                 shorter interval)",
                Num(step),
                Num(t0),
                Num(t_end),
                n
            ),
        ));
    }

    let mut stepper = Stepper::new(model);
    stepper.max_jacobians = max_jacobians;
    // Refuse to start where the field is undefined, as DOPRI5 does.
    let mut field = vec![0.0; n];
    model.vector_field_unchecked(x0, &mut field);
    if let Some(index) = field.iter().position(|v| !v.is_finite()) {
        return Err(SimulationError::NonFinite {
            t: t0,
            what: "vector field",
            index,
        }
        .into());
    }

    let mut x = x0.to_vec();
    let mut x_next = vec![0.0; n];
    let mut energy = stepper.energy(&x);
    // The scheme is built on differences of E: where E's rounding unit is
    // below the smallest normal f64, E keeps too few digits to resolve
    // them, and the steps froze at x0 (states of 1e-160 in a quadratic E)
    // while reporting a free energy that never decreased. Where E's terms
    // vanish at x0 only (all of them are 0 at the origin) the first step
    // leaves it: judged at the explicit Euler guess too (a probe's start at
    // (0, 0), with ẋ = (0, −2) there, was refused).
    let terms = stepper.terms;
    let resolvable = |size: f64| size * terms * f64::EPSILON >= f64::MIN_POSITIVE;
    let euler: Vec<f64> = x.iter().zip(&field).map(|(x, f)| x + step * f).collect();
    if !resolvable(energy.size)
        && !resolvable(stepper.energy(&euler).size)
        && field.iter().any(|&v| v != 0.0)
    {
        return Err(invalid(
            "initial state",
            format!(
                "the terms of the free energy there add up to {}, below {:.1e}, where the \
                 last digits of E fall among f64's subnormal numbers and the \
                 discrete-gradient steps cannot resolve its change; rescale the state \
                 variables so that the state is of moderate size, or use DOPRI5",
                Num(energy.size),
                f64::MIN_POSITIVE / (stepper.terms * f64::EPSILON)
            ),
        ));
    }
    let mut guess = Guess::new(n);
    let mut times = Vec::new();
    let mut states = Vec::new();
    let mut tolerances = Vec::new();
    // Every step's state, kept only where it is needed: to say where an
    // on-region certificate's region was left between outputs.
    let track_steps = S::REGION_CERTIFICATE.is_some_and(|c| c.mode == CertificateMode::OnRegion);
    let (mut step_times, mut step_states) = (Vec::new(), Vec::new());
    // Tolerance accumulated since the last output.
    let mut pending = 0.0;
    let mut stats = IntegrationStats::default();
    let mut tau = 0.0;
    let mut step_index = 0usize;
    for &target in &landmarks {
        let count = steps_between(tau, target, step);
        let start = tau;
        for i in 1..=count {
            let next_tau = if i == count {
                target
            } else {
                start + (target - start) * (i as f64 / count as f64)
            };
            let h = next_tau - tau;
            let extrapolated = guess.predict(&x, h, &mut x_next);
            let mut solved = stepper.solve(&x, energy, h, &mut x_next, &mut stats);
            if solved.is_err() && extrapolated {
                // The extrapolation can overshoot where the flow turns
                // sharply: start again from x.
                x_next.copy_from_slice(&x);
                solved = stepper.solve(&x, energy, h, &mut x_next, &mut stats);
            }
            let solved =
                solved.map_err(|(update, iterations)| SimulationError::StepNotConverged {
                    step: step_index,
                    t: t0 + tau,
                    h,
                    update,
                    iterations,
                    state_norm: x.iter().map(|v| v * v).sum::<f64>().sqrt(),
                })?;
            if let Some(index) = x_next.iter().position(|v| !v.is_finite()) {
                return Err(SimulationError::NonFinite {
                    t: t0 + next_tau,
                    what: "state",
                    index,
                }
                .into());
            }
            pending += energy.rounding()
                + solved.energy.rounding()
                + factor
                    * solved.gradient_norm
                    * (solved.residual + ACCEPT_ULPS * f64::EPSILON * norm(&x).max(norm(&x_next)));
            guess.record(&x, &x_next, h);
            std::mem::swap(&mut x, &mut x_next);
            energy = solved.energy;
            tau = next_tau;
            step_index += 1;
            stats.accepted_steps += 1;
            if track_steps {
                step_times.push(t0 + tau);
                step_states.extend_from_slice(&x);
            }
            if every_step && i < count {
                push_output(
                    &mut times,
                    &mut states,
                    &mut tolerances,
                    &mut pending,
                    t0 + tau,
                    &x,
                );
            }
        }
        push_output(
            &mut times,
            &mut states,
            &mut tolerances,
            &mut pending,
            t0 + target,
            &x,
        );
    }
    Ok(Output {
        times,
        states,
        step_times,
        step_states,
        stats,
        tolerances,
    })
}

/// The initial guess of each implicit equation, from the previous steps.
struct Guess {
    /// The last two increments x′ − x, newest first, and their step sizes
    /// (NaN before there is one).
    last: Vec<f64>,
    before: Vec<f64>,
    steps: (f64, f64),
}

impl Guess {
    fn new(n: usize) -> Self {
        Self {
            last: vec![0.0; n],
            before: vec![0.0; n],
            steps: (f64::NAN, f64::NAN),
        }
    }

    /// x + the predicted increment of a step of size `h` into `out`: the
    /// last two increments extrapolated linearly (local error O(h³)) after
    /// two steps of this size, the last one rescaled (O(h²)) after one, and
    /// no increment before the first step: an explicit Euler guess can land
    /// far outside where Newton converges on a stiff start. `false` if the
    /// guess is x itself.
    fn predict(&self, x: &[f64], h: f64, out: &mut [f64]) -> bool {
        let (last, before) = self.steps;
        if h == last && h == before {
            for (((o, xi), d), p) in out.iter_mut().zip(x).zip(&self.last).zip(&self.before) {
                *o = xi + (2.0 * d - p);
            }
        } else if last.is_finite() {
            let scale = h / last;
            for ((o, xi), d) in out.iter_mut().zip(x).zip(&self.last) {
                *o = xi + scale * d;
            }
        } else {
            out.copy_from_slice(x);
            return false;
        }
        true
    }

    /// Records the accepted step from `x` to `next`.
    fn record(&mut self, x: &[f64], next: &[f64], h: f64) {
        std::mem::swap(&mut self.last, &mut self.before);
        for ((d, a), b) in self.last.iter_mut().zip(next).zip(x) {
            *d = a - b;
        }
        self.steps = (h, self.steps.0);
    }
}

fn push_output(
    times: &mut Vec<f64>,
    states: &mut Vec<f64>,
    tolerances: &mut Vec<f64>,
    pending: &mut f64,
    t: f64,
    x: &[f64],
) {
    if !times.is_empty() {
        tolerances.push(*pending);
    }
    *pending = 0.0;
    times.push(t);
    states.extend_from_slice(x);
}

/// The fewest equal steps no longer than `step` from offset `from` to `to`
/// (0 if `to <= from`); exact multiples are not split by rounding.
fn steps_between(from: f64, to: f64, step: f64) -> u64 {
    if to <= from {
        0
    } else {
        ((to - from) / step * (1.0 - 1e-12)).ceil().max(1.0) as u64
    }
}

/// Where [`Stepper::restart`] moves the iterate.
#[derive(Debug, Clone, Copy)]
enum Restart {
    /// The iterate the last Newton step was taken from.
    Base,
    /// The iterate with the smallest update so far.
    Best,
}

/// An iterate of one step's implicit equation.
#[derive(Debug, Clone, Copy)]
struct Solved {
    /// H, S and their rounding at x′.
    energy: Energy,
    /// ‖∇̄E‖ (generalized) or ‖∇̄H‖ + ‖∇̄S‖ (classical) at (x, x′).
    gradient_norm: f64,
    /// ‖Φ(x′) − x′‖, the residual of the implicit equation.
    residual: f64,
    /// A bound on the rounding error of Φ(x′) (Frobenius norms).
    noise: f64,
}

/// Buffers of one integration.
struct Stepper<'a, S: MetriplecticSystem> {
    model: &'a Model<S>,
    classical: bool,
    /// p + r: the rounding bound's term count.
    terms: f64,
    features: Vec<f64>,
    midpoint: Vec<f64>,
    delta: Vec<f64>,
    /// ∇̄E (generalized) or ∇̄H (classical).
    gradient: Vec<f64>,
    /// ∇̄S (classical).
    gradient_s: Vec<f64>,
    poisson: Vec<f64>,
    metric: Vec<f64>,
    projected: Vec<f64>,
    product: Vec<f64>,
    /// The best iterate so far, the one the last update was taken from,
    /// Φ at the current one, Φ(y) − y and the update J⁻¹(Φ(y) − y).
    best: Vec<f64>,
    base: Vec<f64>,
    image: Vec<f64>,
    residual: Vec<f64>,
    update: Vec<f64>,
    /// Simplified Newton's Jacobian, once the fixed-point iteration was slow.
    newton: Option<Newton>,
    /// Jacobians allowed per step (0: the fixed-point iteration only).
    max_jacobians: u32,
    /// |ψ|, for the rounding bound of ∇S.
    absolute_psi: Vec<f64>,
    /// Rounding bounds of ∇H and ∇S near this step's midpoint.
    gradient_rounding: (f64, f64),
}

/// The Jacobian of simplified Newton and its factors.
struct Newton {
    /// G′ = Φ′/h (row-major), so that a new step size needs no new differences.
    derivative: Vec<f64>,
    /// LU factors of I − h G′ (nalgebra's, partial pivoting), for `step` = h.
    lu: Option<LU<f64, Dyn, Dyn>>,
    step: f64,
    /// The iterate G′ was taken at.
    at: Vec<f64>,
    base: Vec<f64>,
    shifted: Vec<f64>,
}

impl Newton {
    fn new(n: usize) -> Self {
        Self {
            derivative: vec![0.0; n * n],
            lu: None,
            step: f64::NAN,
            at: vec![f64::NAN; n],
            base: vec![0.0; n],
            shifted: vec![0.0; n],
        }
    }
}

impl<'a, S: MetriplecticSystem> Stepper<'a, S> {
    fn new(model: &'a Model<S>) -> Self {
        let n = S::DIM;
        Self {
            model,
            classical: S::CLASSICAL.is_some(),
            terms: (S::entropy_coefficient_count() + S::ENTROPY_DEGREE as usize) as f64,
            features: vec![0.0; S::entropy_coefficient_count()],
            midpoint: vec![0.0; n],
            delta: vec![0.0; n],
            gradient: vec![0.0; n],
            gradient_s: vec![0.0; n],
            poisson: vec![0.0; n * n],
            metric: vec![0.0; n * n],
            projected: vec![0.0; n],
            product: vec![0.0; n],
            best: vec![0.0; n],
            base: vec![0.0; n],
            image: vec![0.0; n],
            residual: vec![0.0; n],
            update: vec![0.0; n],
            newton: None,
            max_jacobians: MAX_JACOBIANS,
            absolute_psi: model
                .entropy_coefficients()
                .iter()
                .map(|c| c.abs())
                .collect(),
            gradient_rounding: (0.0, 0.0),
        }
    }

    /// H, S and their rounding bounds at `x`; E = H + S bit for bit as
    /// [`Model::free_energy`] computes it.
    fn energy(&mut self, x: &[f64]) -> Energy {
        S::entropy_features(x, &mut self.features);
        let psi = self.model.entropy_coefficients();
        // The same sum, in the same order, as `MetriplecticSystem::entropy_value`.
        let entropy: f64 = self.features.iter().zip(psi).map(|(f, c)| f * c).sum();
        let magnitude: f64 = self
            .features
            .iter()
            .zip(psi)
            .map(|(f, c)| (f * c).abs())
            .sum();
        let hamiltonian = S::hamiltonian(x);
        Energy {
            hamiltonian,
            entropy,
            rounding_h: self.terms * f64::EPSILON * hamiltonian.abs(),
            rounding_s: self.terms * f64::EPSILON * magnitude,
            size: hamiltonian.abs() + magnitude,
        }
    }

    /// Solves x′ = Φ(x′) from the guess in `y`, leaving x′ in `y`; on
    /// failure the last update and the iteration count.
    ///
    /// Each iteration moves y by d = J⁻¹(Φ(y) − y): J = I is the
    /// fixed-point iteration, J ≈ I − Φ′(y) (finite differences, kept
    /// across steps) simplified Newton. The iteration starts with what the
    /// previous step used and computes a Jacobian whenever the update falls
    /// by less than [`SLOW`] per iteration.
    fn solve(
        &mut self,
        x: &[f64],
        at_x: Energy,
        h: f64,
        y: &mut [f64],
        stats: &mut IntegrationStats,
    ) -> std::result::Result<Solved, (f64, u32)> {
        let scale_x = norm(x);
        let tolerance = |y: &[f64], noise: f64| {
            ACCEPT_ULPS * f64::EPSILON * scale_x.max(norm(y)) + noise + f64::MIN_POSITIVE
        };
        self.estimate_gradient_rounding(x, y);
        if self.newton.as_ref().is_some_and(|newton| newton.step != h) {
            self.refactor(h);
        }
        // Φ depends on x: a Jacobian kept from the previous step was taken
        // for another equation, whatever iterate it was taken at.
        if let Some(newton) = self.newton.as_mut() {
            newton.at.fill(f64::NAN);
        }
        // The iterate with the smallest update so far.
        let mut best: Option<(f64, Solved)> = None;
        let mut previous = f64::INFINITY;
        let mut update = f64::NAN;
        let mut jacobians = 0;
        let mut converged = false;
        // The last iterate a step was taken from, its residual, and the
        // fraction of the step (in `self.update`) taken from it.
        let mut base_residual = f64::INFINITY;
        let mut fraction = 1.0;
        let mut iterations = 0;
        for iteration in 1..=MAX_ITERATIONS {
            iterations = iteration;
            let mut solved = self.map(x, at_x, h, y);
            stats.evaluations = stats.evaluations.saturating_add(1);
            for ((r, image), yj) in self.residual.iter_mut().zip(&self.image).zip(&*y) {
                *r = image - yj;
            }
            solved.residual = norm(&self.residual);
            // Damped Newton: a step that raised the residual (above rounding)
            // is retried from the iterate it was taken from, first with a
            // Jacobian taken there if its own was taken elsewhere (then it
            // may not point downhill at all), then halved.
            let worse = solved.residual.is_nan()
                || (solved.residual > base_residual
                    && solved.residual > tolerance(y, solved.noise));
            let fresh = self
                .newton
                .as_ref()
                .is_some_and(|newton| newton.lu.is_some() && newton.at == self.base);
            // A base exists only once this solve has taken a step; one
            // Jacobian stays in reserve to verify a solution.
            let have_base = base_residual.is_finite();
            if self.newton.is_some()
                && worse
                && have_base
                && !fresh
                && jacobians + 1 < self.max_jacobians
            {
                self.restart(Restart::Base, (x, at_x, h), y, stats);
                jacobians += 1;
                previous = f64::INFINITY;
                base_residual = f64::INFINITY;
                fraction = 1.0;
                continue;
            }
            if self.newton.is_some() && have_base && fraction > MIN_FRACTION && worse {
                fraction *= 0.5;
                for ((yj, b), d) in y.iter_mut().zip(&self.base).zip(&self.update) {
                    *yj = b + fraction * d;
                }
                continue;
            }
            self.direction();
            update = norm(&self.update);
            if !update.is_finite() {
                // Diverged: retry from the best iterate with a fresh Jacobian.
                match best {
                    Some(_) if jacobians < self.max_jacobians => {
                        self.restart(Restart::Best, (x, at_x, h), y, stats);
                        jacobians += 1;
                        previous = f64::INFINITY;
                        continue;
                    }
                    _ => return Err((update, iteration)),
                }
            }
            if best.is_none_or(|(smallest, _)| update < smallest) {
                self.best.copy_from_slice(y);
                best = Some((update, solved));
            }
            let tolerance = tolerance(y, solved.noise);
            // Converged: the update is at rounding level and no longer falls.
            if update <= tolerance && (update == 0.0 || update >= previous) {
                if self.verified(y, solved.residual, tolerance) {
                    converged = true;
                    break;
                }
                // A small update from a large residual: the Jacobian, taken
                // at another iterate, may be far larger than Φ′ here (a probe
                // accepted a residual of 6e16 this way, and E fell by 1e20).
                // Only a Jacobian at this iterate can say it is a solution.
                if jacobians >= self.max_jacobians {
                    // Report what is wrong: the residual, not the update.
                    update = solved.residual;
                    break;
                }
                self.jacobian(x, at_x, h, y, stats);
                jacobians += 1;
                self.direction();
                update = norm(&self.update);
                if update <= tolerance {
                    self.best.copy_from_slice(y);
                    best = Some((update, solved));
                    converged = true;
                    break;
                }
                previous = f64::INFINITY;
            }
            // Too slow (or growing): a Jacobian at this iterate, or, before
            // the step's first Jacobian, at the best iterate if this one ran
            // away from it (fixed-point steps on a stiff Φ are explicit Euler
            // steps: a probe's first two went from (2, 2) to (5.9, −190),
            // where Newton no longer found the root near the guess).
            if update > tolerance && update > SLOW * previous && jacobians < self.max_jacobians {
                if jacobians == 0
                    && jacobians + 1 < self.max_jacobians
                    && best.is_some_and(|(smallest, _)| smallest < update)
                {
                    self.restart(Restart::Best, (x, at_x, h), y, stats);
                    jacobians += 1;
                    previous = f64::INFINITY;
                    base_residual = f64::INFINITY;
                    fraction = 1.0;
                    continue;
                }
                self.jacobian(x, at_x, h, y, stats);
                jacobians += 1;
                self.direction();
                update = norm(&self.update);
                previous = f64::INFINITY;
            } else {
                previous = update;
            }
            self.base.copy_from_slice(y);
            base_residual = solved.residual;
            fraction = 1.0;
            for (yj, d) in y.iter_mut().zip(&self.update) {
                *yj += d;
            }
        }
        match best {
            // After the cap, the best iterate may still be at rounding level.
            Some((smallest, solved))
                if converged
                    || (smallest <= tolerance(&self.best, solved.noise)
                        && solved.residual <= tolerance(&self.best, solved.noise)) =>
            {
                y.copy_from_slice(&self.best);
                Ok(solved)
            }
            _ => Err((update, iterations)),
        }
    }

    /// Moves the iterate `y` back to the base or the best iterate and takes
    /// a Jacobian there (one more evaluation of Φ, counted).
    fn restart(
        &mut self,
        to: Restart,
        (x, at_x, h): (&[f64], Energy, f64),
        y: &mut [f64],
        stats: &mut IntegrationStats,
    ) {
        y.copy_from_slice(match to {
            Restart::Base => &self.base,
            Restart::Best => &self.best,
        });
        self.map(x, at_x, h, y);
        stats.evaluations = stats.evaluations.saturating_add(1);
        self.jacobian(x, at_x, h, y, stats);
    }

    /// Rounding bounds of ∇H and ∇S at the midpoint of `x` and the guess
    /// `y`: (p + r)·ε times ‖∇H‖ and ‖Σₖ|ψₖ||∇φₖ|‖ (∇S with |ψ| at |x̄|),
    /// the magnitudes of the terms the gradients sum.
    fn estimate_gradient_rounding(&mut self, x: &[f64], y: &[f64]) {
        for ((m, a), b) in self.midpoint.iter_mut().zip(x).zip(y) {
            *m = (0.5 * (a + b)).abs();
        }
        S::hamiltonian_gradient(&self.midpoint, &mut self.gradient);
        S::entropy_gradient(&self.midpoint, &self.absolute_psi, &mut self.gradient_s);
        let bound = self.terms * f64::EPSILON;
        self.gradient_rounding = (bound * norm(&self.gradient), bound * norm(&self.gradient_s));
    }

    /// Whether an update at rounding level from the iterate `y` with
    /// residual ‖Φ(y) − y‖ = `residual` shows that `y` solves the equation:
    /// the residual itself is at rounding level, or the Jacobian the update
    /// used was taken at `y` (a stiff Φ′ can keep the residual of the
    /// nearest floating-point state above the rounding of Φ).
    fn verified(&self, y: &[f64], residual: f64, tolerance: f64) -> bool {
        residual <= tolerance
            || self
                .newton
                .as_ref()
                .is_some_and(|newton| newton.lu.is_some() && newton.at == y)
    }

    /// The update J⁻¹(Φ(y) − y) from `self.residual` into `self.update`.
    fn direction(&mut self) {
        self.update.copy_from_slice(&self.residual);
        if let Some(lu) = self.newton.as_ref().and_then(|newton| newton.lu.as_ref()) {
            let n = self.update.len();
            // Non-singular by construction (`refactor` keeps only factors with normal pivots).
            lu.solve_mut(&mut DVectorViewMut::from_slice(&mut self.update, n));
        }
    }

    /// G′ = Φ′(y)/h by forward differences (Φ(y) is in `self.image`), and
    /// the factors of I − h G′; the fixed-point iteration if singular.
    fn jacobian(
        &mut self,
        x: &[f64],
        at_x: Energy,
        h: f64,
        y: &[f64],
        stats: &mut IntegrationStats,
    ) {
        let n = S::DIM;
        let mut newton = self.newton.take().unwrap_or_else(|| Newton::new(n));
        newton.base.copy_from_slice(&self.image);
        newton.at.copy_from_slice(y);
        newton.shifted.copy_from_slice(y);
        let scale = norm(x).max(norm(y));
        for (j, &original) in y.iter().enumerate() {
            let shifted = original + f64::EPSILON.sqrt() * original.abs().max(scale).max(1e-300);
            newton.shifted[j] = shifted;
            let delta = shifted - original;
            self.map(x, at_x, h, &newton.shifted);
            stats.evaluations = stats.evaluations.saturating_add(1);
            for i in 0..n {
                newton.derivative[i * n + j] = (self.image[i] - newton.base[i]) / (h * delta);
            }
            newton.shifted[j] = original;
        }
        self.image.copy_from_slice(&newton.base);
        self.newton = Some(newton);
        self.refactor(h);
    }

    /// Factors I − h G′ for step size `h`; drops Newton if it is singular.
    fn refactor(&mut self, h: f64) {
        let n = S::DIM;
        let Some(mut newton) = self.newton.take() else {
            return;
        };
        let matrix = DMatrix::from_fn(n, n, |i, j| {
            let identity = if i == j { 1.0 } else { 0.0 };
            identity - h * newton.derivative[i * n + j]
        });
        let lu = matrix.lu();
        // A zero, subnormal or non-finite pivot: fall back to the fixed point.
        if lu.u().diagonal().iter().all(|pivot| pivot.is_normal()) {
            newton.lu = Some(lu);
            newton.step = h;
            self.newton = Some(newton);
        }
    }

    /// Φ(y) into `self.image`; returns H and S at y and the discrete
    /// gradients' norm.
    fn map(&mut self, x: &[f64], at_x: Energy, h: f64, y: &[f64]) -> Solved {
        let n = S::DIM;
        for j in 0..n {
            self.midpoint[j] = 0.5 * (x[j] + y[j]);
            self.delta[j] = y[j] - x[j];
        }
        let at_y = self.energy(y);
        let theta = self.model.metric_coefficients();
        S::poisson(&self.midpoint, &mut self.poisson);
        S::metric_value(&self.midpoint, theta, &mut self.metric);
        let (gradient_norm, noise);
        if self.classical {
            S::hamiltonian_gradient(&self.midpoint, &mut self.gradient);
            S::entropy_gradient(
                &self.midpoint,
                self.model.entropy_coefficients(),
                &mut self.gradient_s,
            );
            let noise_a = self.gradient_rounding.0
                + discrete_gradient(
                    &mut self.gradient,
                    &self.delta,
                    at_y.hamiltonian - at_x.hamiltonian,
                    0.5 * (at_x.rounding_h + at_y.rounding_h),
                );
            let noise_b = self.gradient_rounding.1
                + discrete_gradient(
                    &mut self.gradient_s,
                    &self.delta,
                    at_y.entropy - at_x.entropy,
                    0.5 * (at_x.rounding_s + at_y.rounding_s),
                );
            let (a, b) = (&self.gradient, &self.gradient_s);
            let (norm_a, norm_b) = (norm(a), norm(b));
            gradient_norm = norm_a + norm_b;
            // Q Π Q a moves with a, and with b's direction through Q; P K P b likewise.
            let ratio = |u: f64, v: f64| if v > 0.0 { u / v } else { 0.0 };
            noise = h
                * (norm(&self.poisson) * (noise_a + 2.0 * ratio(norm_a, norm_b) * noise_b)
                    + norm(&self.metric) * (noise_b + 2.0 * ratio(norm_b, norm_a) * noise_a));
            // Q Π Q a.
            project(b, a, &mut self.projected);
            multiply(&self.poisson, &self.projected, &mut self.product);
            project(b, &self.product, &mut self.image);
            // + P K P b.
            project(a, b, &mut self.projected);
            multiply(&self.metric, &self.projected, &mut self.product);
            let image = &mut self.image;
            project(a, &self.product, &mut self.projected);
            for j in 0..n {
                image[j] = x[j] + h * (image[j] + self.projected[j]);
            }
        } else {
            self.model
                .free_energy_gradient_unchecked(&self.midpoint, &mut self.gradient);
            let gradient_noise = self.gradient_rounding.0
                + self.gradient_rounding.1
                + discrete_gradient(
                    &mut self.gradient,
                    &self.delta,
                    at_y.free_energy() - at_x.free_energy(),
                    0.5 * (at_x.rounding() + at_y.rounding()),
                );
            gradient_norm = norm(&self.gradient);
            for (p, k) in self.poisson.iter_mut().zip(&self.metric) {
                *p += k;
            }
            noise = h * norm(&self.poisson) * gradient_noise;
            multiply(&self.poisson, &self.gradient, &mut self.product);
            for ((image, xj), p) in self.image.iter_mut().zip(x).zip(&self.product) {
                *image = xj + h * p;
            }
        }
        Solved {
            energy: at_y,
            gradient_norm,
            residual: f64::NAN,
            noise,
        }
    }
}

/// Turns ∇F(x̄) in `gradient` into Gonzalez's ∇̄F(x, x′) for Δ = x′ − x and
/// `difference` = F(x′) − F(x): adds c·Δ with
/// c = (F(x′) − F(x) − ∇F(x̄)·Δ)/|Δ|², the numerator treated as zero within
/// `threshold` (half the rounding bound of the difference), kept beyond
/// twice it, and blended linearly in between (see the module
/// documentation). Returns a bound on the rounding error this term adds to
/// the gradient: the difference's rounding bound 2·`threshold` times the
/// blend's slope, over |Δ|.
fn discrete_gradient(gradient: &mut [f64], delta: &[f64], difference: f64, threshold: f64) -> f64 {
    let squared: f64 = delta.iter().map(|d| d * d).sum();
    if !(squared.is_normal()) {
        return 0.0;
    }
    let linear: f64 = gradient.iter().zip(delta).map(|(g, d)| g * d).sum();
    let numerator = difference - linear;
    let size = numerator.abs();
    let (kept, slope) = if size <= threshold {
        (0.0, 0.0)
    } else if size >= 2.0 * threshold {
        (numerator, 1.0)
    } else {
        (2.0 * (size - threshold) * numerator.signum(), 2.0)
    };
    let c = kept / squared;
    for (g, d) in gradient.iter_mut().zip(delta) {
        *g += c * d;
    }
    slope * 2.0 * threshold / squared.sqrt()
}

/// (I − g gᵀ/|g|²) v into `out` (v itself if g = 0).
fn project(g: &[f64], v: &[f64], out: &mut [f64]) {
    let squared: f64 = g.iter().map(|a| a * a).sum();
    out.copy_from_slice(v);
    if squared.is_normal() {
        let c = g.iter().zip(v).map(|(a, b)| a * b).sum::<f64>() / squared;
        for (o, a) in out.iter_mut().zip(g) {
            *o -= c * a;
        }
    }
}

/// A v for a row-major square A into `out`.
fn multiply(a: &[f64], v: &[f64], out: &mut [f64]) {
    let n = v.len();
    for (j, o) in out.iter_mut().enumerate() {
        *o = a[j * n..(j + 1) * n]
            .iter()
            .zip(v)
            .map(|(m, w)| m * w)
            .sum();
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;
    use crate::simulate::{simulate, IntegratorOptions, Method, Simulation, SimulationOptions};
    use crate::{metriplectic, MetriplecticSystem};

    metriplectic! {
        /// A damped rotation with a quadratic free energy E = −(x² + y²)/2.
        struct Decay;
        state (x, y);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = 0.5 * x^2 + 0.5 * y^2;
        entropy degree 2;
        metric degree 0;
        reference { entropy = -(x^2 + y^2); metric = [[1, 0], [0, 1]]; }
    }

    metriplectic! {
        /// A quartic free energy E = −(x² + y²)/2 − x⁴/2 + x y³/5 − 3y⁴/10
        /// (negative definite quartic part) with an anisotropic metric, so
        /// that the discrete gradient differs from the midpoint gradient.
        struct Quartic;
        state (x, y);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = 0.5 * x^2 + 0.5 * y^2;
        entropy degree 4;
        metric degree 0;
        reference {
            entropy = -(x^2 + y^2) - 0.5 * x^4 + 0.2 * x * y^3 - 0.3 * y^4;
            metric = [[1, 0.3], [0.3, 0.5]];
        }
    }

    metriplectic! {
        /// A rigid body in the classical form: H = x²/2 + y²/4 + z²/8, the
        /// Casimir entropy S = −|p|², and K = |∇H|² I − ∇H ∇Hᵀ, so that
        /// K∇H ≡ 0: H is conserved while |p| relaxes towards the x axis.
        struct ClassicalBody;
        state (x, y, z);
        poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
        hamiltonian = 0.5 * x^2 + 0.25 * y^2 + 0.125 * z^2;
        entropy degree 2;
        metric degree 2;
        region ball(radius = 2);
        classical;
        reference {
            entropy = -(x^2 + y^2 + z^2);
            metric = [[0.25 * y^2 + 0.0625 * z^2, -0.5 * x * y, -0.25 * x * z],
                      [-0.5 * x * y, x^2 + 0.0625 * z^2, -0.125 * y * z],
                      [-0.25 * x * z, -0.125 * y * z, x^2 + 0.25 * y^2]];
        }
    }

    fn options(step: f64, output: OutputTimes) -> SimulationOptions {
        SimulationOptions {
            method: Method::DiscreteGradient { step },
            output,
            integrator: IntegratorOptions {
                max_steps: 1_000_000,
                ..IntegratorOptions::default()
            },
            ..SimulationOptions::default()
        }
    }

    fn run<S: MetriplecticSystem>(
        model: &Model<S>,
        x0: &[f64],
        t_end: f64,
        step: f64,
    ) -> Simulation {
        simulate(model, x0, 0.0, t_end, &options(step, OutputTimes::Steps)).unwrap()
    }

    /// A DOPRI5 solution at tolerances far below the discrete gradient's error.
    fn reference_solution<S: MetriplecticSystem>(
        model: &Model<S>,
        x0: &[f64],
        t_end: f64,
    ) -> Vec<f64> {
        let options = SimulationOptions {
            integrator: IntegratorOptions {
                rtol: 1e-13,
                atol: 1e-15,
                ..IntegratorOptions::default()
            },
            output: OutputTimes::Times(vec![t_end]),
            ..SimulationOptions::default()
        };
        simulate(model, x0, 0.0, t_end, &options)
            .unwrap()
            .trajectory
            .states()
            .to_vec()
    }

    fn last_state(sim: &Simulation) -> &[f64] {
        sim.trajectory.state(sim.trajectory.len() - 1)
    }

    /// The largest E(xₖ) − E(xₖ₊₁) in ulps of max(|E(xₖ)|, |E(xₖ₊₁)|).
    fn largest_decrease_in_ulps(energy: &[f64]) -> f64 {
        energy
            .windows(2)
            .map(|e| (e[0] - e[1]) / (f64::EPSILON * e[0].abs().max(e[1].abs())))
            .fold(f64::NEG_INFINITY, f64::max)
    }

    #[test]
    fn discrete_gradient_satisfies_the_difference_identity() {
        // F = x³ − 2xy² + y, ∇F = (3x² − 2y², 1 − 4xy).
        let f = |x: &[f64]| x[0].powi(3) - 2.0 * x[0] * x[1] * x[1] + x[1];
        let gradient = |x: &[f64]| {
            [
                3.0 * x[0] * x[0] - 2.0 * x[1] * x[1],
                1.0 - 4.0 * x[0] * x[1],
            ]
        };
        let (a, b) = ([0.3, -0.7], [0.9, 0.4]);
        let mid = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
        let delta = [b[0] - a[0], b[1] - a[1]];
        let mut g = gradient(&mid);
        discrete_gradient(&mut g, &delta, f(&b) - f(&a), 0.0);
        let identity = f(&b) - f(&a) - (g[0] * delta[0] + g[1] * delta[1]);
        assert!(identity.abs() < 4.0 * f64::EPSILON, "{identity}");
        // Second order: ∇̄F − ∇F(x̄) shrinks like |Δ|².
        let midpoint = gradient(&mid);
        assert!((g[0] - midpoint[0]).abs() > 1e-3);
        // Δ = 0: the gradient itself.
        let mut g = gradient(&a);
        discrete_gradient(&mut g, &[0.0, 0.0], 0.0, 0.0);
        assert_eq!(g, gradient(&a));
        // A numerator within the rounding bound is dropped, beyond twice it kept.
        let mut g = [0.0, 0.0];
        discrete_gradient(&mut g, &[1.0, 0.0], 1e-15, 2e-15);
        assert_eq!(g, [0.0, 0.0]);
        discrete_gradient(&mut g, &[1.0, 0.0], 1e-15, 4e-16);
        assert_eq!(g, [1e-15, 0.0]);
    }

    /// E never falls, step by step, even at steps far beyond explicit
    /// stability: explicit Euler at the same step makes E fall.
    #[test]
    fn free_energy_never_decreases_at_large_steps() {
        let decay = Model::<Decay>::reference().unwrap();
        let quartic = Model::<Quartic>::reference().unwrap();
        for step in [0.5, 1.0] {
            for x0 in [[1.0, 0.0], [-0.4, 0.9], [0.8, -0.8]] {
                let sims = [
                    ("Decay", run(&decay, &x0, 100.0, step)),
                    ("Quartic", run(&quartic, &x0, 100.0, step)),
                ];
                for (name, sim) in sims {
                    let ulps = largest_decrease_in_ulps(&sim.free_energy);
                    println!(
                        "{name} h = {step} from {x0:?}: largest decrease {ulps:.2} ulps, \
                         E {:.3e} → {:.3e}, {:?}",
                        sim.free_energy[0],
                        sim.free_energy.last().unwrap(),
                        sim.stats
                    );
                    assert_eq!(sim.trajectory.len(), (100.0 / step) as usize + 1);
                    assert!(ulps <= 4.0, "{name} h = {step} from {x0:?}: {ulps} ulps");
                    assert!(sim.energy.is_non_decreasing(), "{:?}", sim.energy);
                    // The flow reaches E's maximum at the origin.
                    assert!(sim.free_energy.last().unwrap().abs() < 1e-12);
                }
            }
        }
        // Explicit Euler on the quartic system at h = 1 lets E fall.
        let mut x = [0.8, -0.8];
        let mut falls = 0;
        for _ in 0..20 {
            let mut f = [0.0; 2];
            quartic.vector_field(&x, &mut f).unwrap();
            let next = [x[0] + f[0], x[1] + f[1]];
            match quartic.free_energy(&next) {
                Ok(e) if e >= quartic.free_energy(&x).unwrap() => x = next,
                // E fell, or overflowed on the way to −∞.
                _ => {
                    falls += 1;
                    break;
                }
            }
        }
        assert!(falls > 0, "explicit Euler kept E monotone at h = 1");
    }

    /// Halving h divides the error by 4, in both forms.
    #[test]
    fn second_order_convergence() {
        fn errors<S: MetriplecticSystem>(model: &Model<S>, x0: &[f64], t_end: f64) -> Vec<f64> {
            let exact = reference_solution(model, x0, t_end);
            [0.1, 0.05, 0.025, 0.0125]
                .iter()
                .map(|&h| {
                    let sim = run(model, x0, t_end, h);
                    norm(
                        &last_state(&sim)
                            .iter()
                            .zip(&exact)
                            .map(|(a, b)| a - b)
                            .collect::<Vec<_>>(),
                    )
                })
                .collect()
        }
        let quartic = Model::<Quartic>::reference().unwrap();
        let body = Model::<ClassicalBody>::reference().unwrap();
        for (name, errors) in [
            ("Quartic", errors(&quartic, &[0.9, -0.6], 2.0)),
            ("ClassicalBody", errors(&body, &[0.3, 1.0, 0.6], 4.0)),
        ] {
            let ratios: Vec<f64> = errors.windows(2).map(|e| e[0] / e[1]).collect();
            println!("{name}: errors {errors:?}, ratios {ratios:.3?}");
            assert!(
                errors[3] > 1e-11,
                "{name}: the error must be the scheme's, not the reference's"
            );
            for ratio in ratios {
                assert!((3.8..4.2).contains(&ratio), "{name}: ratio {ratio}");
            }
        }
    }

    /// The largest relative drift of H along `sim`, and S at every output.
    fn h_drift_and_entropy(model: &Model<ClassicalBody>, sim: &Simulation) -> (f64, Vec<f64>) {
        let h0 = ClassicalBody::hamiltonian(sim.trajectory.state(0));
        let mut drift = 0.0f64;
        let mut entropy = Vec::new();
        for k in 0..sim.trajectory.len() {
            let x = sim.trajectory.state(k);
            drift = drift.max((ClassicalBody::hamiltonian(x) - h0).abs() / h0.abs());
            entropy.push(model.entropy(x).unwrap());
        }
        (drift, entropy)
    }

    #[test]
    fn classical_form_conserves_h_and_produces_s() {
        let model = Model::<ClassicalBody>::reference().unwrap();
        let x0 = [0.3, 1.0, 0.6];
        let sim = run(&model, &x0, 500.0, 0.05);
        assert_eq!(sim.stats.accepted_steps, 10_000);
        let h0 = ClassicalBody::hamiltonian(&x0);
        let (drift, entropy) = h_drift_and_entropy(&model, &sim);
        let ulps = largest_decrease_in_ulps(&entropy);
        println!(
            "H drift {drift:.2e}, S {:.6} → {:.6}, largest S decrease {ulps:.2} ulps, {:?}",
            entropy[0],
            entropy.last().unwrap(),
            sim.stats
        );
        assert!(drift <= 1e-12, "H drifted by {drift:e}");
        assert!(ulps <= 4.0, "S fell by {ulps} ulps");
        assert!(sim.energy.is_non_decreasing(), "{:?}", sim.energy);
        // S is produced: |p| relaxes to the x axis at fixed H, |p|² = 2H.
        let end = last_state(&sim);
        assert!((entropy.last().unwrap() + 2.0 * h0).abs() < 1e-6, "{end:?}");
        // DOPRI5 at its default tolerances lets H drift far more.
        let dopri = simulate(&model, &x0, 0.0, 500.0, &SimulationOptions::default()).unwrap();
        let dopri_drift = (0..dopri.trajectory.len())
            .map(|k| (ClassicalBody::hamiltonian(dopri.trajectory.state(k)) - h0).abs() / h0)
            .fold(0.0, f64::max);
        println!("DOPRI5 H drift {dopri_drift:.2e}");
        assert!(dopri_drift > 1e3 * drift.max(1e-16));
    }

    /// The projections make H conserved and S non-decreasing for any
    /// model, not only an exactly classical one. A model of a classical
    /// system must meet the constraints to 1e-9 of its coefficients
    /// (`Model::new` refuses others), so this one breaks them by ~5e-10:
    /// Π∇S ≠ 0 (S has terms that are no Casimir) and K∇H ≠ 0 (K has
    /// 2e-10·diag(2, 0.5, 1) added, anisotropic so that P K P b differs
    /// from P K b). Without the projections H drifts by 8e-7 over
    /// the run.
    #[test]
    fn classical_form_conserves_h_for_any_model() {
        // ψ over x, y, z, x², xy, xz, y², yz, z²: −|p|² + ε(2x + 3xy).
        let off = 2e-10;
        let psi = vec![2.0 * off, 0.0, 0.0, -1.0, 3.0 * off, 0.0, -1.0, 0.0, -1.0];
        let mut theta = ClassicalBody::REFERENCE_METRIC.unwrap().to_vec();
        let basis = ClassicalBody::METRIC_EXPONENTS.len();
        for (j, added) in [2.0, 0.5, 1.0].into_iter().enumerate() {
            theta[crate::system::metric_pair_index(3, j, j) * basis] += added * off;
        }
        let model = Model::<ClassicalBody>::new(psi, theta).unwrap();
        let x0 = [0.3, 1.0, 0.6];
        // Off classical at x0: |Π∇S| and |K∇H| are O(ε).
        let (mut grad_s, mut grad_h, mut pi, mut k) = ([0.0; 3], [0.0; 3], [0.0; 9], [0.0; 9]);
        ClassicalBody::entropy_gradient(&x0, model.entropy_coefficients(), &mut grad_s);
        ClassicalBody::hamiltonian_gradient(&x0, &mut grad_h);
        ClassicalBody::poisson(&x0, &mut pi);
        model.metric(&x0, &mut k).unwrap();
        let (mut pi_s, mut k_h) = ([0.0; 3], [0.0; 3]);
        multiply(&pi, &grad_s, &mut pi_s);
        multiply(&k, &grad_h, &mut k_h);
        assert!(
            norm(&pi_s) > off / 4.0 && norm(&k_h) > off / 4.0,
            "{pi_s:?} {k_h:?}"
        );

        let sim = run(&model, &x0, 500.0, 0.05);
        let (drift, entropy) = h_drift_and_entropy(&model, &sim);
        let ulps = largest_decrease_in_ulps(&entropy);
        println!(
            "H drift {drift:.2e}, S {:.6} → {:.6}, largest S decrease {ulps:.2} ulps",
            entropy[0],
            entropy.last().unwrap()
        );
        assert!(drift <= 1e-12, "H drifted by {drift:e}");
        assert!(ulps <= 4.0, "S fell by {ulps} ulps");
        assert!(
            entropy.last().unwrap() - entropy[0] > 0.1,
            "S was not produced"
        );
        assert!(sim.energy.is_non_decreasing(), "{:?}", sim.energy);
    }

    #[test]
    fn outputs_land_on_step_ends() {
        let model = Model::<Quartic>::reference().unwrap();
        let x0 = [0.9, -0.6];
        // Output times that are multiples of h: the same steps as `Steps`.
        let steps = simulate(&model, &x0, 0.0, 1.0, &options(0.1, OutputTimes::Steps)).unwrap();
        let interval = simulate(
            &model,
            &x0,
            0.0,
            1.0,
            &options(0.1, OutputTimes::Interval(0.5)),
        )
        .unwrap();
        assert_eq!(steps.stats.accepted_steps, 10);
        assert_eq!(interval.stats.accepted_steps, 10);
        assert_eq!(interval.trajectory.times(), &[0.0, 0.5, 1.0]);
        for (k, j) in [(0, 0), (1, 5), (2, 10)] {
            assert_eq!(interval.trajectory.state(k), steps.trajectory.state(j));
        }
        // Other times: each interval in the fewest equal steps ≤ h.
        let times = vec![0.3, 0.35, 1.0];
        let sim = simulate(
            &model,
            &x0,
            0.0,
            1.0,
            &options(0.1, OutputTimes::Times(times.clone())),
        )
        .unwrap();
        assert_eq!(sim.trajectory.times(), &times[..]);
        assert_eq!(sim.stats.accepted_steps, 3 + 1 + 7);
        assert_eq!(sim.energy.steps, 2);
        // `Steps` with a span that is not a multiple: 4 equal steps of 0.25.
        let sim = simulate(&model, &x0, 0.0, 1.0, &options(0.3, OutputTimes::Steps)).unwrap();
        assert_eq!(sim.trajectory.times(), &[0.0, 0.25, 0.5, 0.75, 1.0]);
        // A shifted start: the same steps, the same states.
        let shifted = simulate(&model, &x0, -3.0, -2.0, &options(0.3, OutputTimes::Steps)).unwrap();
        assert_eq!(shifted.trajectory.states(), sim.trajectory.states());
    }

    /// A state whose free energy is subnormal is refused, not frozen: the
    /// steps froze at x0 from states of 1e-160 and the run reported no
    /// decrease of E. States of 1e-100 still scale exactly.
    #[test]
    fn states_too_small_for_the_free_energy_are_refused() {
        let model = Model::<Decay>::reference().unwrap();
        let reference = run(&model, &[0.3, 0.4], 1.0, 0.01);
        let small = run(&model, &[0.3e-100, 0.4e-100], 1.0, 0.01);
        for (a, b) in last_state(&reference).iter().zip(last_state(&small)) {
            assert!(
                (a - b * 1e100).abs() <= 1e-12 * a.abs().max(1e-3),
                "{a} {b}"
            );
        }
        let options = options(0.01, OutputTimes::Steps);
        let err = simulate(&model, &[0.3e-160, 0.4e-160], 0.0, 1.0, &options).unwrap_err();
        println!("{err}");
        assert!(err.to_string().contains("subnormal"), "{err}");
        // At a state where E's terms all vanish but the field does not, the
        // first step leaves it: integrated (a probe's start at the origin
        // was refused).
        let tilted = Model::<Decay>::new(
            vec![1.0, -1.0, -1.0, 0.0, -1.0],
            model.metric_coefficients().to_vec(),
        )
        .unwrap();
        let mut field = [0.0; 2];
        tilted.vector_field(&[0.0, 0.0], &mut field).unwrap();
        assert!(field.iter().any(|v| *v != 0.0), "{field:?}");
        let sim = simulate(&tilted, &[0.0, 0.0], 0.0, 1.0, &options).unwrap();
        assert!(sim.energy.is_non_decreasing(), "{:?}", sim.energy);
    }

    #[test]
    fn bad_steps_are_rejected() {
        let model = Model::<Decay>::reference().unwrap();
        for step in [0.0, -0.1, f64::NAN, f64::INFINITY] {
            let err = simulate(
                &model,
                &[1.0, 0.0],
                0.0,
                1.0,
                &options(step, OutputTimes::Steps),
            )
            .unwrap_err();
            assert!(
                matches!(&err, Error::InvalidArgument { what, .. } if what == "discrete-gradient step"),
                "{err}"
            );
        }
        let mut too_many = options(1e-3, OutputTimes::Steps);
        too_many.integrator.max_steps = 999;
        let err = simulate(&model, &[1.0, 0.0], 0.0, 1.0, &too_many).unwrap_err();
        assert!(err.to_string().contains("1000 steps"), "{err}");
        // A step so small that the count saturates is the same error.
        let tiny = options(1e-300, OutputTimes::Interval(0.25));
        let err = simulate(&model, &[1.0, 0.0], 0.0, 1.0, &tiny).unwrap_err();
        let text = err.to_string();
        assert!(text.contains("more than"), "{err}");
        // Told in the messages' number format, and by its size.
        assert!(
            text.contains("1e-300 over") && text.contains("about 1.0e300 steps"),
            "{err}"
        );
        // Steps within the budget whose states exceed memory are refused
        // before any is taken (a probe's run aborted allocating 2 GB).
        let mut huge = options(1e-8, OutputTimes::Interval(1.0));
        huge.integrator.max_steps = u32::MAX;
        let err = simulate(&model, &[1.0, 0.0], 0.0, 40.0, &huge).unwrap_err();
        assert!(
            err.to_string()
                .contains("more than the 10⁸ values (800 MB)"),
            "{err}"
        );
    }

    /// The fixed-point iteration contracts only while h·L < 2; beyond, the
    /// step is a typed error naming it (and Newton solves it).
    #[test]
    fn a_step_that_does_not_converge_is_a_typed_error() {
        let model = Model::<Decay>::reference().unwrap();
        let fixed_point = integrate_with(
            &model,
            &[1.0, 0.0],
            (0.0, 30.0),
            10.0,
            100,
            &OutputTimes::Steps,
            10.0,
            0,
        );
        let err = fixed_point.err().unwrap();
        println!("{err}");
        match &err {
            Error::Simulation(SimulationError::StepNotConverged {
                step, t, h, update, ..
            }) => {
                assert_eq!((*step, *t, *h), (0, 0.0, 10.0));
                assert!(update.is_nan() || *update > 1e-10, "{update}");
            }
            other => panic!("unexpected {other}"),
        }
        assert!(err.to_string().contains("smaller step"), "{err}");
        assert!(err.to_string().contains("at |x| = 1 "), "{err}");
        let newton = run(&model, &[1.0, 0.0], 30.0, 10.0);
        assert!(largest_decrease_in_ulps(&newton.free_energy) <= 4.0);
    }

    /// Work per step of the fixed-point iteration against simplified Newton
    /// on the stiffer quartic flow (printed; the counts are asserted loosely).
    #[test]
    fn newton_takes_steps_the_fixed_point_iteration_cannot() {
        let model = Model::<Quartic>::reference().unwrap();
        let x0 = [1.2, -1.0];
        for step in [0.01, 0.05, 0.2, 0.5] {
            let mut line = format!("h = {step}:");
            for (name, jacobians) in [("fixed point", 0), ("Newton", MAX_JACOBIANS)] {
                let result = integrate_with(
                    &model,
                    &x0,
                    (0.0, 10.0),
                    step,
                    1_000_000,
                    &OutputTimes::Steps,
                    10.0,
                    jacobians,
                );
                match result {
                    Ok(out) => {
                        line += &format!(
                            " {name} {:.2} evaluations per step;",
                            f64::from(out.stats.evaluations) / f64::from(out.stats.accepted_steps)
                        )
                    }
                    Err(err) => {
                        assert_eq!(jacobians, 0, "Newton failed: {err}");
                        line += &format!(" {name} fails;");
                    }
                }
            }
            println!("{line}");
        }
        let fixed_point = integrate_with(
            &model,
            &x0,
            (0.0, 10.0),
            0.5,
            1_000,
            &OutputTimes::Steps,
            10.0,
            0,
        );
        assert!(fixed_point.is_err(), "the fixed point converged at h = 0.5");
    }
}
