//! Simulation: integrate ẋ = (Π + K)(∇H + ∇S) for a [`Model`] with DOPRI5
//! (`dopri`) or a structure-preserving discrete gradient
//! (`discrete_gradient`), check that the free energy never decreases along
//! the way (`energy`), and synthesise identification data from a known
//! model (`synthesize`).
//!

mod discrete_gradient;
mod dopri;
mod energy;
mod synthesize;

pub use dopri::{integrate, Integration, IntegrationStats, IntegratorOptions, OutputTimes};
pub use energy::{free_energy_diagnostics, EnergyCheck, FreeEnergyReport, OutsideRegion};
pub use synthesize::{
    synthesize, InitialStates, Noise, Outliers, SampleTimes, SynthesisOptions, SyntheticData,
};

use energy::{check_energy, integrator_tolerances, outside_region};

use crate::data::Trajectory;
use crate::error::{invalid, Num, Result};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// Options of [`simulate`].
///
/// ```
/// use metriplectic_runtime::{Method, OutputTimes, SimulationOptions};
///
/// let options = SimulationOptions { output: OutputTimes::Interval(0.05), ..Default::default() };
/// assert_eq!(options.energy_tolerance_factor, 10.0);
/// assert_eq!(options.method, Method::Dopri5);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationOptions {
    /// The integration method; [`Method::Dopri5`] by default.
    pub method: Method,
    /// Error control of DOPRI5, and the step budget of both methods
    /// ([`IntegratorOptions::max_steps`]); the default
    /// [`IntegratorOptions::default`].
    pub integrator: IntegratorOptions,
    /// Output times; [`OutputTimes::Steps`] by default.
    pub output: OutputTimes,
    /// Safety factor of the free-energy monotonicity tolerance (see the
    /// [`simulate`] documentation); must be ≥ 0; 10 by default.
    pub energy_tolerance_factor: f64,
}

impl Default for SimulationOptions {
    fn default() -> Self {
        Self {
            method: Method::default(),
            integrator: IntegratorOptions::default(),
            output: OutputTimes::default(),
            energy_tolerance_factor: 10.0,
        }
    }
}

/// How [`simulate`] integrates.
///
/// ```
/// # use metriplectic_runtime::prelude::*;
/// # use metriplectic_runtime::{simulate, Method, SimulationOptions};
/// # metriplectic! {
/// #     pub struct Decay;
/// #     state (x, y);
/// #     poisson = [[0, 1], [-1, 0]];
/// #     hamiltonian = 0.5 * x^2 + 0.5 * y^2;
/// #     entropy degree 2;
/// #     metric degree 0;
/// #     reference { entropy = -(x^2 + y^2); metric = [[1, 0], [0, 1]]; }
/// # }
/// let model = Model::<Decay>::reference()?;
/// // A step far beyond what an explicit method could take on this flow:
/// // the free energy still never decreases.
/// let options = SimulationOptions {
///     method: Method::DiscreteGradient { step: 1.0 },
///     ..SimulationOptions::default()
/// };
/// let sim = simulate(&model, &[1.0, 0.0], 0.0, 20.0, &options)?;
/// assert_eq!(sim.trajectory.len(), 21);
/// assert!(sim.free_energy.windows(2).all(|e| e[1] >= e[0]));
/// # Ok::<(), metriplectic_runtime::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[non_exhaustive]
pub enum Method {
    /// Dormand–Prince 5(4) with adaptive steps and dense output (the
    /// default): fifth order, error per step controlled by
    /// [`SimulationOptions::integrator`]; the free energy is non-decreasing
    /// only up to that error.
    #[default]
    Dopri5,
    /// Gonzalez's midpoint discrete gradient with a fixed step: implicit,
    /// second order, and structure-preserving for every step size. For a
    /// generalized system E(x′) − E(x) = h ∇̄Eᵀ K ∇̄E ≥ 0 at every step; for
    /// a system declared `classical;` H is conserved and S never decreases
    /// (projected operators). Exact up to rounding: the free-energy check
    /// of [`simulate`] allows rounding only. `docs/method.md` §10 derives
    /// both forms. Implicit: each step is solved to rounding (fixed point,
    /// then damped simplified Newton); a step that cannot be solved is
    /// [`SimulationError::StepNotConverged`](crate::SimulationError::StepNotConverged).
    ///
    /// Each interval between outputs is divided into the fewest equal steps
    /// no longer than `step`, so outputs fall on step ends; with
    /// [`OutputTimes::Steps`] every step is an output. The run stops at the
    /// last output time. [`IntegratorOptions::max_steps`] bounds the number
    /// of steps (checked before integrating); DOPRI5's tolerances are not
    /// used.
    DiscreteGradient {
        /// The largest step size h (finite, > 0). No default: accuracy is
        /// O(h²), so choose it for the accuracy the run needs.
        step: f64,
    },
}

/// A simulated trajectory with its free energy.
///
/// ```
/// # use metriplectic_runtime::prelude::*;
/// # use metriplectic_runtime::{simulate, SimulationOptions};
/// # metriplectic! {
/// #     pub struct Decay;
/// #     state (x, y);
/// #     poisson = [[0, 1], [-1, 0]];
/// #     hamiltonian = 0.5 * x^2 + 0.5 * y^2;
/// #     entropy degree 2;
/// #     metric degree 0;
/// #     reference { entropy = -(x^2 + y^2); metric = [[1, 0], [0, 1]]; }
/// # }
/// let model = Model::<Decay>::reference().unwrap();
/// let sim = simulate(&model, &[1.0, 0.0], 0.0, 2.0, &SimulationOptions::default()).unwrap();
/// assert!(sim.energy.is_non_decreasing());
/// assert_eq!(sim.free_energy.len(), sim.trajectory.len());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Simulation {
    /// Times, states and the exact vector field ẋ = f(x) at each output.
    pub trajectory: Trajectory,
    /// E(x) at each output.
    pub free_energy: Vec<f64>,
    /// Monotonicity of E along the trajectory.
    pub energy: EnergyCheck,
    /// The outputs and integrator steps outside the region of the system's
    /// metric certificate, when it holds only there
    /// ([`CertificateMode::OnRegion`](crate::CertificateMode::OnRegion)):
    /// outside it the free energy is not certified to be non-decreasing.
    /// `None` (always, for systems without such a certificate) when every
    /// output and every step's end lies in the region.
    pub outside_region: Option<OutsideRegion>,
    /// Integrator statistics.
    pub stats: IntegrationStats,
}

/// Simulates `model` from each of `initial_states` (row-major, n per state)
/// over [t0, t_end], in parallel across cores (rayon's pool:
/// `RAYON_NUM_THREADS`), and returns one result per initial state, in
/// order. Each simulation is independent, so the results do not depend on
/// the thread count.
///
/// ```
/// # use metriplectic_runtime::prelude::*;
/// # use metriplectic_runtime::{simulate_many, SimulationOptions};
/// # metriplectic! {
/// #     pub struct Decay;
/// #     state (x, y);
/// #     poisson = [[0, 1], [-1, 0]];
/// #     hamiltonian = 0.5 * x^2 + 0.5 * y^2;
/// #     entropy degree 2;
/// #     metric degree 0;
/// #     reference { entropy = -(x^2 + y^2); metric = [[1, 0], [0, 1]]; }
/// # }
/// let model = Model::<Decay>::reference()?;
/// let runs = simulate_many(&model, &[1.0, 0.0, 0.0, 2.0], 0.0, 1.0, &SimulationOptions::default())?;
/// assert_eq!(runs.len(), 2);
/// assert!(runs.iter().all(|r| r.is_ok()));
/// # Ok::<(), metriplectic_runtime::Error>(())
/// ```
///
/// Errors (before simulating anything) if `initial_states` is not a whole
/// number of states; a simulation that fails is an `Err` in its slot.
pub fn simulate_many<S: MetriplecticSystem>(
    model: &Model<S>,
    initial_states: &[f64],
    t0: f64,
    t_end: f64,
    options: &SimulationOptions,
) -> Result<Vec<Result<Simulation>>> {
    use rayon::prelude::*;
    let n = S::DIM;
    if !initial_states.len().is_multiple_of(n) {
        return Err(invalid(
            "initial states",
            format!(
                "{} values are not a whole number of {n}-dimensional states",
                initial_states.len()
            ),
        ));
    }
    Ok(initial_states
        .par_chunks_exact(n)
        .map(|x0| simulate(model, x0, t0, t_end, options))
        .collect())
}

/// Simulates `model` from `x0` over [t0, t_end] (t_end > t0) with
/// [`SimulationOptions::method`].
///
/// The trajectory carries the model's exact vector field at every output
/// state as its derivatives, and its state names are `S::STATE_NAMES`.
///
/// # Free-energy check
///
/// Along every simulated trajectory of a model with K ⪰ 0 the free energy
/// E = H + S must not decrease (dE/dt = ∇Eᵀ K ∇E ≥ 0). [`simulate`] reports
/// E at each output and an [`EnergyCheck`]: between consecutive outputs k and
/// k+1, a decrease counts as a violation only if it exceeds a tolerance τₖ.
///
/// With [`Method::Dopri5`],
///
/// ```text
/// τₖ = factor · (atol·√n + rtol·max(‖xₖ‖, ‖xₖ₊₁‖)) · max(‖∇E(xₖ)‖, ‖∇E(xₖ₊₁)‖),
/// ```
///
/// the first-order change of E caused by a state error of the size the
/// integrator controls (each component's local error is kept below
/// atol + rtol·|xᵢ|), plus the worst-case rounding error of evaluating E in
/// floating point at both ends, (p + r)·ε·(|H(x)| + Σₖ|ψₖ φₖ(x)|) with p
/// entropy terms of degree ≤ r (near the zero set ∇E → 0 and only rounding
/// is left). `factor` is [`SimulationOptions::energy_tolerance_factor`].
///
/// With [`Method::DiscreteGradient`] there is no truncation-error term:
/// each step satisfies E(x′) − E(x) = h ∇̄Eᵀ K ∇̄E ≥ 0 whatever h, once its
/// implicit equation x′ − x = h(Π + K)∇̄E is solved. What is left is
/// rounding: the discrete gradient's identity holds up to the rounding ρ of
/// E at both ends (the same bound as above), and the equation is solved to
/// a residual rⱼ = ‖Φ(x′) − x′‖ of a few ulps (measured at the accepted
/// x′), which shifts E by at most ‖∇̄E‖·rⱼ; 64ε·max(‖xⱼ‖, ‖xⱼ₊₁‖) more covers
/// the rounding of evaluating that residual. Summed over the steps j from
/// output k to k+1,
///
/// ```text
/// τₖ = Σⱼ [ ρ(xⱼ) + ρ(xⱼ₊₁) + factor · ‖∇̄E(xⱼ, xⱼ₊₁)‖ · (rⱼ + 64ε·max(‖xⱼ‖, ‖xⱼ₊₁‖)) ],
/// ```
///
/// with ‖∇̄H‖ + ‖∇̄S‖ in place of ‖∇̄E‖ for a classical system. A violation
/// here means the guarantee failed, not that the step was too long.
///
/// Both guarantees need K ⪰ 0 along the way. A system whose metric
/// certificate holds only on its region ([`CertificateMode::OnRegion`](crate::CertificateMode::OnRegion))
/// has it only there: [`Simulation::outside_region`] counts the outputs
/// and the integrator's steps outside, where a decrease of E is the
/// model's, not the integrator's. Steps count because the outputs alone can
/// all lie inside while the trajectory between them leaves the region.
pub fn simulate<S: MetriplecticSystem>(
    model: &Model<S>,
    x0: &[f64],
    t0: f64,
    t_end: f64,
    options: &SimulationOptions,
) -> Result<Simulation> {
    crate::error::check_len("initial state", x0, S::DIM)?;
    let factor = options.energy_tolerance_factor;
    if !(factor.is_finite() && factor >= 0.0) {
        return Err(invalid(
            "energy_tolerance_factor",
            format!("{}: must be finite and ≥ 0", Num(factor)),
        ));
    }
    // DOPRI5's tolerances τₖ come from its outputs; the discrete gradient's
    // from its steps.
    let (solution, step_tolerances) = match options.method {
        Method::Dopri5 => {
            let solution = integrate(
                |_t, x, dx| model.vector_field_unchecked(x, dx),
                x0,
                t0,
                t_end,
                &options.integrator,
                &options.output,
            )?;
            (solution, None)
        }
        Method::DiscreteGradient { step } => {
            if !(step.is_finite() && step > 0.0) {
                return Err(invalid(
                    "discrete-gradient step",
                    format!("{}: must be finite and > 0", Num(step)),
                ));
            }
            dopri::validate_start(x0, t0, t_end)?;
            dopri::validate_output(x0.len(), t0, t_end, &options.output)?;
            if options.integrator.max_steps == 0 {
                return Err(invalid("max_steps", "must be at least 1".to_owned()));
            }
            let output = discrete_gradient::integrate(
                model,
                x0,
                (t0, t_end),
                step,
                options.integrator.max_steps,
                &options.output,
                factor,
            )?;
            let solution = Integration {
                times: output.times,
                states: output.states,
                step_times: output.step_times,
                step_states: output.step_states,
                stats: output.stats,
            };
            (solution, Some(output.tolerances))
        }
    };
    // Steps far shorter than the spacing of the times (t0 = 1e16, steps of
    // 0.1) report equal times: say so instead of failing on the trajectory.
    if let Some(k) = solution.times.windows(2).position(|t| t[1] <= t[0]) {
        return Err(invalid(
            "time interval",
            format!(
                "outputs {k} and {} both fall at t = {}: the steps are shorter than the spacing \
                 of floating-point numbers at these times; shift the time origin (e.g. to t0 = 0)",
                k + 1,
                Num(solution.times[k])
            ),
        ));
    }
    let n = S::DIM;
    let count = solution.times.len();
    let mut derivatives = vec![0.0; count * n];
    let mut free_energy = Vec::with_capacity(count);
    for (k, x) in solution.states.chunks_exact(n).enumerate() {
        model.vector_field_unchecked(x, &mut derivatives[k * n..(k + 1) * n]);
        free_energy.push(model.free_energy(x)?);
    }
    let tolerances = match step_tolerances {
        Some(tolerances) => tolerances,
        None => dopri_tolerances(model, &solution.states, &options.integrator, factor),
    };
    let energy = check_energy(&free_energy, &tolerances);
    let outside_region = outside_region::<S>(
        (t0, x0),
        (&solution.times, &solution.states),
        (&solution.step_times, &solution.step_states),
    );
    let names = S::STATE_NAMES.iter().map(|s| (*s).to_owned()).collect();
    let trajectory = Trajectory::new(names, solution.times, solution.states, Some(derivatives))?;
    Ok(Simulation {
        trajectory,
        free_energy,
        energy,
        outside_region,
        stats: solution.stats,
    })
}

/// τₖ of DOPRI5's outputs (see [`simulate`]).
fn dopri_tolerances<S: MetriplecticSystem>(
    model: &Model<S>,
    states: &[f64],
    options: &IntegratorOptions,
    factor: f64,
) -> Vec<f64> {
    let n = S::DIM;
    let count = states.len() / n;
    let mut gradient_norms = Vec::with_capacity(count);
    let mut rounding = Vec::with_capacity(count);
    let mut grad = vec![0.0; n];
    let mut features = vec![0.0; S::entropy_coefficient_count()];
    let terms = (S::entropy_coefficient_count() + S::ENTROPY_DEGREE as usize) as f64;
    for x in states.chunks_exact(n) {
        model.free_energy_gradient_unchecked(x, &mut grad);
        gradient_norms.push(energy::norm(&grad));
        S::entropy_features(x, &mut features);
        let magnitude = S::hamiltonian(x).abs()
            + features
                .iter()
                .zip(model.entropy_coefficients())
                .map(|(f, c)| (f * c).abs())
                .sum::<f64>();
        rounding.push(terms * f64::EPSILON * magnitude);
    }
    integrator_tolerances(&gradient_norms, &rounding, states, n, options, factor)
}
