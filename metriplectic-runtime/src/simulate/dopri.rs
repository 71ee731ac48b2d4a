//! Integration of ẋ = f(t, x) with the Dormand–Prince 5(4) method of the
//! `ode_solvers` crate (Hairer's DOPRI5: embedded error estimate, PI
//! step-size controller, stiffness detection, 4th-order dense output).
//! Outputs can be the accepted steps, a fixed interval, or arbitrary times
//! (evaluated with the dense output, so they do not shorten the
//! integrator's steps).
//!
//! Failures are errors, never panics: step-size underflow, too many steps,
//! detected stiffness and non-finite values are reported as
//! [`SimulationError`] with the time where they happened.

use std::cell::Cell;

use ode_solvers::dop_shared::{IntegrationError, OutputType, System};
use ode_solvers::{continuous_output_model::ContinuousOutputModel, DVector, Dopri5};

use crate::error::{invalid, Num, Result, SimulationError};

/// Error control and budget of the integrator.
///
/// ```
/// use metriplectic_runtime::IntegratorOptions;
///
/// let options = IntegratorOptions { rtol: 1e-8, atol: 1e-10, ..IntegratorOptions::default() };
/// assert_eq!(options.max_steps, 100_000);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct IntegratorOptions {
    /// Relative tolerance of the local error estimate, in [1e-14, 1);
    /// 1e-6 by default.
    pub rtol: f64,
    /// Absolute tolerance of the local error estimate (> 0); 1e-9 by
    /// default. The free-energy check allows for this error, so an `atol`
    /// near the states' own size leaves it nothing to detect.
    pub atol: f64,
    /// Maximal number of step attempts (accepted and rejected); 100 000 by
    /// default. DOPRI5 keeps every accepted step, so a budget whose steps
    /// would hold more than 10⁸ values (about 6n + 56 per step for n
    /// states) is refused before the run.
    pub max_steps: u32,
    /// Largest step size; `None` (the default) means the whole interval.
    pub max_step: Option<f64>,
}

impl Default for IntegratorOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-6,
            atol: 1e-9,
            max_steps: 100_000,
            max_step: None,
        }
    }
}

/// Where the solution is reported. Default [`Steps`](Self::Steps).
///
/// ```
/// use metriplectic_runtime::OutputTimes;
///
/// let every_tenth = OutputTimes::Interval(0.1);
/// let chosen = OutputTimes::Times(vec![0.0, 0.01, 0.1, 1.0]);
/// # let _ = (every_tenth, chosen);
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub enum OutputTimes {
    /// The initial time and every accepted step (the default).
    #[default]
    Steps,
    /// t₀, t₀ + Δ, t₀ + 2Δ, … up to t_end (0 < Δ ≤ t_end − t₀; t_end
    /// itself only where it is a multiple of Δ), from the dense output.
    Interval(f64),
    /// These times (finite, strictly increasing, within [t₀, t_end]), from the
    /// dense output.
    Times(Vec<f64>),
}

/// Work done by the integrator.
///
/// ```
/// use metriplectic_runtime::{integrate, IntegratorOptions, OutputTimes};
///
/// let sol = integrate(|_t, x, dx| dx[0] = -x[0], &[1.0], 0.0, 1.0,
///                     &IntegratorOptions::default(), &OutputTimes::Steps).unwrap();
/// // DOPRI5 is FSAL: 6 evaluations per step plus the start-up ones.
/// assert!(sol.stats.evaluations >= 6 * sol.stats.accepted_steps);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct IntegrationStats {
    /// Vector field evaluations; for the discrete gradient
    /// ([`Method::DiscreteGradient`](crate::Method::DiscreteGradient)),
    /// evaluations of its step map (each about one vector field and one
    /// free energy), the Jacobians' included.
    pub evaluations: u32,
    /// Accepted steps (every step of the discrete gradient).
    pub accepted_steps: u32,
    /// Rejected steps (none for the discrete gradient, whose steps are fixed).
    pub rejected_steps: u32,
}

/// The output of [`integrate`]: times and row-major states.
///
/// ```
/// use metriplectic_runtime::{integrate, IntegratorOptions, OutputTimes};
///
/// // ẋ = −x from x(0) = 1.
/// let sol = integrate(|_t, x, dx| dx[0] = -x[0], &[1.0], 0.0, 1.0,
///                     &IntegratorOptions::default(), &OutputTimes::Times(vec![1.0])).unwrap();
/// assert!((sol.states[0] - (-1.0f64).exp()).abs() < 1e-6);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Integration {
    /// Output times.
    pub times: Vec<f64>,
    /// States at the output times, row-major.
    pub states: Vec<f64>,
    /// The end time of every accepted step, in order (the last is t_end).
    pub step_times: Vec<f64>,
    /// The state at the end of every accepted step, row-major: the
    /// trajectory between the outputs, as far as the integrator saw it.
    pub step_states: Vec<f64>,
    /// Integrator statistics.
    pub stats: IntegrationStats,
}

/// Integrates ẋ = f(t, x) from `x0` over [t0, t_end] (t_end > t0) with
/// DOPRI5, reporting the solution at `output`.
///
/// `f(t, x, dx)` writes the derivative into `dx`. This is the code path
/// [`simulate`](crate::simulate) uses; it is public so that any ODE can be integrated and
/// checked with the same settings.
pub fn integrate<F>(
    f: F,
    x0: &[f64],
    t0: f64,
    t_end: f64,
    options: &IntegratorOptions,
    output: &OutputTimes,
) -> Result<Integration>
where
    F: Fn(f64, &[f64], &mut [f64]),
{
    validate(x0, t0, t_end, options, output)?;
    let n = x0.len();
    // Refuse to start from a point where the field is already undefined:
    // DOPRI5's initial step guess would turn NaN into an endless loop of rejections.
    let mut dx0 = vec![0.0; n];
    f(t0, x0, &mut dx0);
    if let Some(index) = dx0.iter().position(|v| !v.is_finite()) {
        return Err(SimulationError::NonFinite {
            t: t0,
            what: "vector field",
            index,
        }
        .into());
    }

    // ode_solvers compares times through `abs()` in its dense output, which is
    // only right for non-negative times: integrate in τ = t − t0 ∈ [0, T].
    let span = t_end - t0;
    let non_finite_field = Cell::new(None);
    let adapter = Adapter {
        f: &f,
        t0,
        non_finite: &non_finite_field,
    };
    let mut solver = Dopri5::from_param(
        adapter,
        0.0,
        span,
        span,
        DVector::from_column_slice(x0),
        options.rtol,
        options.atol,
        0.9,
        0.04,
        0.2,
        10.0,
        options.max_step.unwrap_or(span),
        0.0,
        options.max_steps,
        1000,
        OutputType::Continuous,
    );
    let mut dense = ContinuousOutputModel::default();
    let result = solver.integrate_with_continuous_output_model(&mut dense);
    // `solver` owns the adapter; read what it recorded through the accepted steps.
    let steps_t = solver.x_out().clone();
    let steps_x = solver.y_out().clone();
    let stats = match result {
        Ok(stats) => stats,
        Err(error) => {
            let failure = integration_failure(error, options.max_steps, &steps_x, t0);
            return Err(explain_with_field(failure, non_finite_field.get(), t0).into());
        }
    };
    if let Some((tau, index)) = steps_x
        .iter()
        .zip(&steps_t)
        .find_map(|(y, &tau)| y.iter().position(|v| !v.is_finite()).map(|i| (tau, i)))
    {
        return Err(SimulationError::NonFinite {
            t: t0 + tau,
            what: "state",
            index,
        }
        .into());
    }
    let stats = IntegrationStats {
        evaluations: stats.num_eval,
        accepted_steps: stats.accepted_steps,
        rejected_steps: stats.rejected_steps,
    };

    let mut times = Vec::new();
    let mut states = Vec::new();
    match output {
        OutputTimes::Steps => {
            times.push(t0);
            states.extend_from_slice(x0);
            for (tau, y) in steps_t.iter().zip(&steps_x) {
                times.push(t0 + tau);
                states.extend(y.iter());
            }
        }
        OutputTimes::Interval(dt) => {
            for tau in interval_offsets(span, *dt) {
                push_dense(&dense, tau, t0, x0, &mut times, &mut states)?;
            }
        }
        OutputTimes::Times(requested) => {
            for &t in requested {
                push_dense(&dense, t - t0, t0, x0, &mut times, &mut states)?;
            }
        }
    }
    Ok(Integration {
        times,
        states,
        step_times: steps_t.iter().map(|tau| t0 + tau).collect(),
        step_states: steps_x.iter().flat_map(|y| y.iter().copied()).collect(),
        stats,
    })
}

/// The offsets τ = t − t0 of [`OutputTimes::Interval`]`(dt)` over [0, span]:
/// 0, Δ, 2Δ, … as k·Δ rather than repeated addition, so no drift over long
/// runs, and an offset within rounding of `span` is `span`.
pub(super) fn interval_offsets(span: f64, dt: f64) -> impl Iterator<Item = f64> {
    let count = (span / dt * (1.0 + 1e-12)).floor() as usize;
    (0..=count).map(move |k| (k as f64 * dt).min(span))
}

/// The ODE as `ode_solvers` sees it, in shifted time τ = t − t0.
struct Adapter<'a, F> {
    f: &'a F,
    t0: f64,
    /// First (τ, component) where the vector field was non-finite, if any.
    non_finite: &'a Cell<Option<(f64, usize)>>,
}

impl<F> System<f64, DVector<f64>> for Adapter<'_, F>
where
    F: Fn(f64, &[f64], &mut [f64]),
{
    fn system(&self, tau: f64, y: &DVector<f64>, dy: &mut DVector<f64>) {
        (self.f)(self.t0 + tau, y.as_slice(), dy.as_mut_slice());
        if self.non_finite.get().is_none() {
            if let Some(i) = dy.iter().position(|v| !v.is_finite()) {
                self.non_finite.set(Some((tau, i)));
            }
        }
    }

    fn solout(&mut self, _tau: f64, y: &DVector<f64>, _dy: &DVector<f64>) -> bool {
        // Stop at once on a non-finite accepted state; `integrate` reports it.
        y.iter().any(|v| !v.is_finite())
    }
}

fn integration_failure(
    error: IntegrationError,
    max_steps: u32,
    steps_x: &[DVector<f64>],
    t0: f64,
) -> SimulationError {
    // A non-finite last accepted state explains any later failure best.
    if let Some(index) = steps_x
        .last()
        .and_then(|y| y.iter().position(|v| !v.is_finite()))
    {
        let t = match error {
            IntegrationError::MaxNumStepReached { x, .. }
            | IntegrationError::StepSizeUnderflow { x }
            | IntegrationError::StiffnessDetected { x } => x,
        };
        return SimulationError::NonFinite {
            t: t0 + t,
            what: "state",
            index,
        };
    }
    match error {
        IntegrationError::MaxNumStepReached { x, .. } => SimulationError::TooManySteps {
            t: t0 + x,
            max_steps,
        },
        IntegrationError::StepSizeUnderflow { x } => {
            SimulationError::StepSizeUnderflow { t: t0 + x }
        }
        IntegrationError::StiffnessDetected { x } => SimulationError::Stiff { t: t0 + x },
    }
}

/// A step-size failure after the field went non-finite is explained by that.
fn explain_with_field(
    failure: SimulationError,
    non_finite_field: Option<(f64, usize)>,
    t0: f64,
) -> SimulationError {
    match (failure, non_finite_field) {
        (SimulationError::StepSizeUnderflow { .. }, Some((tau, index))) => {
            SimulationError::NonFinite {
                t: t0 + tau,
                what: "vector field",
                index,
            }
        }
        (failure, _) => failure,
    }
}

fn push_dense(
    dense: &ContinuousOutputModel<f64, DVector<f64>>,
    tau: f64,
    t0: f64,
    x0: &[f64],
    times: &mut Vec<f64>,
    states: &mut Vec<f64>,
) -> Result<()> {
    times.push(t0 + tau);
    if tau <= 0.0 {
        // The dense output starts after the first step; t0 is the initial state.
        states.extend_from_slice(x0);
        return Ok(());
    }
    // The last step ends at x + (x_end − x), which may miss x_end by an ulp:
    // clamp outputs within rounding of the end onto the last breakpoint.
    let tau = match dense.evaluate(tau) {
        Some(_) => tau,
        None => {
            let end = dense.bounds().1;
            if tau > end && tau - end <= 1e-12 * tau.abs().max(1.0) {
                end
            } else {
                tau
            }
        }
    };
    let y = dense.evaluate(tau).ok_or_else(|| {
        invalid(
            "output time",
            format!("{} lies outside the integrated interval", t0 + tau),
        )
    })?;
    if let Some(index) = y.iter().position(|v| !v.is_finite()) {
        return Err(SimulationError::NonFinite {
            t: t0 + tau,
            what: "state",
            index,
        }
        .into());
    }
    states.extend(y.iter());
    Ok(())
}

fn validate(
    x0: &[f64],
    t0: f64,
    t_end: f64,
    options: &IntegratorOptions,
    output: &OutputTimes,
) -> Result<()> {
    validate_start(x0, t0, t_end)?;
    validate_tolerances(options)?;
    validate_output(x0.len(), t0, t_end, output)?;
    // ode_solvers keeps every accepted step (its dense output and the
    // states): a budget of steps beyond what memory can hold aborted the
    // process instead of returning an error (a probe: `max_step` 1e-8 with
    // `max_steps` u32::MAX).
    let per_step = DOPRI_VALUES_PER_STEP_PER_STATE * x0.len() as f64 + DOPRI_VALUES_PER_STEP;
    if f64::from(options.max_steps) * per_step > MAX_OUTPUT_VALUES {
        return Err(invalid(
            "max_steps",
            format!(
                "{} steps of {} states would be kept at about {per_step} values each, more than \
                 the 10⁸ values (800 MB) a simulation keeps; allow at most {} (the default is \
                 100 000), or use the discrete gradient",
                options.max_steps,
                x0.len(),
                (MAX_OUTPUT_VALUES / per_step).floor()
            ),
        ));
    }
    Ok(())
}

/// What ode_solvers keeps per accepted step of DOPRI5, in f64 values: five
/// dense-output vectors and the state (per state variable), and per step
/// the time and six vectors' allocations (about 540 bytes per step in 2-D).
const DOPRI_VALUES_PER_STEP_PER_STATE: f64 = 6.0;
/// See [`DOPRI_VALUES_PER_STEP_PER_STATE`].
const DOPRI_VALUES_PER_STEP: f64 = 56.0;

/// The initial state and the interval: what every integrator needs.
pub(super) fn validate_start(x0: &[f64], t0: f64, t_end: f64) -> Result<()> {
    if x0.is_empty() {
        return Err(invalid("initial state", "it is empty".to_owned()));
    }
    crate::error::check_finite("initial state", x0)?;
    if !(t0.is_finite() && t_end.is_finite() && t_end > t0) {
        return Err(invalid(
            "time interval",
            format!(
                "[{}, {}]: need finite t0 < t_end (only forward integration)",
                Num(t0),
                Num(t_end)
            ),
        ));
    }
    // Integrators step in τ = t − t0: a span beyond f64's range (e.g.
    // [−1e308, 1e308]) would make every step size infinite.
    if !(t_end - t0).is_finite() {
        return Err(invalid(
            "time interval",
            format!(
                "[{}, {}]: its length t_end − t0 overflows to infinity; integrate over a shorter \
                 interval",
                Num(t0),
                Num(t_end)
            ),
        ));
    }
    // Outputs are reported at t0 + τ: an interval only a few ulps of its
    // times long has no distinct times to report.
    let spacing = ulp(t0.abs().max(t_end.abs()));
    if (t_end - t0) < MIN_SPAN_ULPS * spacing {
        return Err(invalid(
            "time interval",
            format!(
                "[{}, {}] is shorter than {MIN_SPAN_ULPS} times the spacing {} of floating-point \
                 numbers there: too short to integrate over (shift the time origin, e.g. to t0 = 0, \
                 or lengthen the interval)",
                Num(t0),
                Num(t_end),
                Num(spacing)
            ),
        ));
    }
    Ok(())
}

/// The shortest interval, in spacings of the floating-point numbers at its
/// ends, that [`validate_start`] accepts.
const MIN_SPAN_ULPS: f64 = 1024.0;

/// The spacing of the floating-point numbers at `value` (≥ 0), at least the
/// smallest normal number.
fn ulp(value: f64) -> f64 {
    let value = value.max(f64::MIN_POSITIVE);
    f64::from_bits(value.to_bits() + 1) - value
}

/// DOPRI5's error control and budget.
fn validate_tolerances(options: &IntegratorOptions) -> Result<()> {
    for (what, value) in [("rtol", options.rtol), ("atol", options.atol)] {
        if !(value.is_finite() && value > 0.0) {
            return Err(invalid(
                what,
                format!("{}: must be finite and > 0", Num(value)),
            ));
        }
    }
    if options.rtol < 1e-14 {
        return Err(invalid(
            "rtol",
            format!(
                "{}: below 1e-14 no step can meet it in f64",
                Num(options.rtol)
            ),
        ));
    }
    // The free-energy check allows for the integration error, so an error
    // control this loose would let a falling E pass it.
    if options.rtol >= 1.0 {
        return Err(invalid(
            "rtol",
            format!(
                "{}: a relative error of 100% or more is no error control",
                Num(options.rtol)
            ),
        ));
    }
    if options.max_steps == 0 {
        return Err(invalid("max_steps", "must be at least 1".to_owned()));
    }
    if let Some(h) = options.max_step {
        if !(h.is_finite() && h > 0.0) {
            return Err(invalid(
                "max_step",
                format!("{}: must be finite and > 0", Num(h)),
            ));
        }
    }
    Ok(())
}

/// Most values a simulation's outputs may hold (time, state, ẋ, E and its
/// tolerance per output: 2n + 3 each), 800 MB of f64.
pub(super) const MAX_OUTPUT_VALUES: f64 = 1e8;

/// The output times within [t0, t_end] (`t0 < t_end` already checked), and
/// no more of them than `MAX_OUTPUT_VALUES` can hold for `dim` states.
pub(super) fn validate_output(dim: usize, t0: f64, t_end: f64, output: &OutputTimes) -> Result<()> {
    let per_output = 2.0 * dim as f64 + 3.0;
    match output {
        OutputTimes::Steps => {}
        OutputTimes::Interval(dt) => {
            if !(dt.is_finite() && *dt > 0.0) {
                return Err(invalid(
                    "output interval",
                    format!("{}: must be finite and > 0", Num(*dt)),
                ));
            }
            // Only t0 would be output, and the energy check would compare
            // nothing (a probe's Interval(5) over [0, 1]).
            if *dt > t_end - t0 {
                return Err(invalid(
                    "output interval",
                    format!(
                        "{} is longer than the interval [{}, {}]: only t0 would be output; use \
                         OutputTimes::Times(vec![t_end]) or OutputTimes::Steps for the end state",
                        Num(*dt),
                        Num(t0),
                        Num(t_end)
                    ),
                ));
            }
            let outputs = (t_end - t0) / dt;
            if outputs * per_output > MAX_OUTPUT_VALUES {
                return Err(invalid(
                    "output interval",
                    format!(
                        "{} over [{}, {}] asks for {outputs:.3e} outputs of {per_output} \
                         values each, more than the 10⁸ values (800 MB) a simulation keeps",
                        Num(*dt),
                        Num(t0),
                        Num(t_end)
                    ),
                ));
            }
        }
        OutputTimes::Times(times) => {
            if times.is_empty() {
                return Err(invalid("output times", "the list is empty".to_owned()));
            }
            if let Some(k) = times
                .iter()
                .position(|t| !(t.is_finite() && *t >= t0 && *t <= t_end))
            {
                return Err(invalid(
                    "output times",
                    format!(
                        "time {k} ({}) is not within [{}, {}]",
                        Num(times[k]),
                        Num(t0),
                        Num(t_end)
                    ),
                ));
            }
            crate::error::check_strictly_increasing("output times", times)?;
        }
    }
    Ok(())
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;

    #[test]
    fn exponential_decay_at_requested_tolerance() {
        for &rtol in &[1e-4, 1e-7, 1e-10] {
            let options = IntegratorOptions {
                rtol,
                atol: rtol * 1e-3,
                ..Default::default()
            };
            let sol = integrate(
                |_t, x, dx| dx[0] = -x[0],
                &[1.0],
                0.0,
                5.0,
                &options,
                &OutputTimes::Interval(0.5),
            )
            .unwrap();
            assert_eq!(sol.times.len(), 11);
            let worst = sol
                .times
                .iter()
                .zip(&sol.states)
                .map(|(t, x)| ((x - (-t).exp()) / (-t).exp()).abs())
                .fold(0.0, f64::max);
            assert!(worst < 10.0 * rtol, "rtol {rtol}: relative error {worst}");
        }
    }

    /// A probe's interval [1e16, 1e16 + 4] failed on a trajectory "time 1
    /// (10000000000000000) does not come after time 0", and [0, 5e-324]
    /// as a step-size underflow; both are intervals too short for their
    /// times, and numbers print in exponent form, not as hundreds of digits.
    #[test]
    fn intervals_too_short_for_their_times_say_so() {
        let field = |_t: f64, x: &[f64], dx: &mut [f64]| dx[0] = -x[0];
        for (t0, t_end, shown) in [
            (1e16, 1e16 + 4.0, "[1e16, 1.0000000000000004e16]"),
            (0.0, 5e-324, "[0, 5e-324]"),
        ] {
            let err = integrate(
                field,
                &[1.0],
                t0,
                t_end,
                &IntegratorOptions::default(),
                &OutputTimes::Steps,
            )
            .unwrap_err()
            .to_string();
            assert!(err.contains(shown), "{err}");
            assert!(err.contains("too short to integrate over"), "{err}");
        }
        // A probe's [−1e308, 1e308] ended "stiff": its length is infinite.
        let err = integrate(
            field,
            &[1.0],
            -1e308,
            1e308,
            &IntegratorOptions::default(),
            &OutputTimes::Steps,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("overflows to infinity"), "{err}");
        // Long enough in ulps: integrated, from the same time origin.
        let sol = integrate(
            field,
            &[1.0],
            1e9,
            1e9 + 1.0,
            &IntegratorOptions::default(),
            &OutputTimes::Interval(0.25),
        )
        .unwrap();
        assert_eq!(sol.times.len(), 5);
        // An output interval longer than the interval outputs t0 alone.
        let err = validate_output(1, 0.0, 1.0, &OutputTimes::Interval(5.0))
            .unwrap_err()
            .to_string();
        assert!(err.contains("only t0 would be output"), "{err}");
        let err = validate_tolerances(&IntegratorOptions {
            rtol: 1e-16,
            ..IntegratorOptions::default()
        })
        .unwrap_err()
        .to_string();
        assert!(err.contains("1e-16: below 1e-14"), "{err}");
        assert_eq!(Num(1e300).to_string(), "1e300");
        assert_eq!(Num(0.25).to_string(), "0.25");
        assert_eq!(Num(-1500.0).to_string(), "-1500");
    }

    #[test]
    fn blow_up_is_an_error_not_a_panic() {
        // ẋ = x² from 1 blows up at t = 1.
        let err = integrate(
            |_t, x, dx| dx[0] = x[0] * x[0],
            &[1.0],
            0.0,
            2.0,
            &IntegratorOptions::default(),
            &OutputTimes::Steps,
        )
        .unwrap_err();
        match err {
            Error::Simulation(
                SimulationError::StepSizeUnderflow { t }
                | SimulationError::TooManySteps { t, .. }
                | SimulationError::NonFinite { t, .. },
            ) => assert!((t - 1.0).abs() < 1e-2, "stopped at {t}"),
            other => panic!("unexpected {other}"),
        }
    }

    #[test]
    fn non_finite_field_at_start_is_reported() {
        let err = integrate(
            |_t, _x, dx| dx[0] = f64::NAN,
            &[1.0],
            0.0,
            1.0,
            &IntegratorOptions::default(),
            &OutputTimes::Steps,
        )
        .unwrap_err();
        assert!(
            matches!(
                err,
                Error::Simulation(SimulationError::NonFinite {
                    what: "vector field",
                    index: 0,
                    ..
                })
            ),
            "{err}"
        );
    }

    #[test]
    fn step_budget_is_enforced() {
        let options = IntegratorOptions {
            max_steps: 10,
            rtol: 1e-10,
            atol: 1e-12,
            ..Default::default()
        };
        let err = integrate(
            |_t, x, dx| {
                dx[0] = x[1];
                dx[1] = -x[0];
            },
            &[1.0, 0.0],
            0.0,
            100.0,
            &options,
            &OutputTimes::Steps,
        )
        .unwrap_err();
        assert!(
            matches!(
                err,
                Error::Simulation(SimulationError::TooManySteps { max_steps: 10, .. })
            ),
            "{err}"
        );
    }

    #[test]
    fn rejects_bad_options() {
        let f = |_t: f64, x: &[f64], dx: &mut [f64]| dx[0] = -x[0];
        let run = |t0: f64, t1: f64, opt: IntegratorOptions, out: OutputTimes| {
            integrate(f, &[1.0], t0, t1, &opt, &out)
                .unwrap_err()
                .to_string()
        };
        let d = IntegratorOptions::default;
        assert!(run(1.0, 0.0, d(), OutputTimes::Steps).contains("t0 < t_end"));
        let o = IntegratorOptions { rtol: 0.0, ..d() };
        assert!(run(0.0, 1.0, o, OutputTimes::Steps).contains("rtol"));
        let o = IntegratorOptions { rtol: 1.0, ..d() };
        assert!(run(0.0, 1.0, o, OutputTimes::Steps).contains("no error control"));
        assert!(run(0.0, 1.0, d(), OutputTimes::Interval(-1.0)).contains("output interval"));
        let out = OutputTimes::Times(vec![0.5, 0.2]);
        assert!(run(0.0, 1.0, d(), out).contains("strictly increase"));
        let out = OutputTimes::Times(vec![0.5, 2.0]);
        assert!(run(0.0, 1.0, d(), out).contains("not within"));
        // Every accepted step is kept: a budget beyond memory is refused
        // (a probe's run aborted instead), the default is not.
        let o = IntegratorOptions {
            max_steps: u32::MAX,
            ..d()
        };
        let message = run(0.0, 1.0, o, OutputTimes::Steps);
        assert!(
            message.contains("more than the 10⁸ values (800 MB)"),
            "{message}"
        );
        integrate(f, &[1.0; 64], 0.0, 1.0, &d(), &OutputTimes::Steps).unwrap();
    }

    #[test]
    fn negative_start_time_and_outputs() {
        // Time shifting: results must not depend on t0's sign.
        let sol = integrate(
            |t, _x, dx| dx[0] = 2.0 * t,
            &[4.0],
            -2.0,
            1.0,
            &IntegratorOptions::default(),
            &OutputTimes::Times(vec![-2.0, -1.0, 0.0, 1.0]),
        )
        .unwrap();
        for (t, x) in sol.times.iter().zip(&sol.states) {
            assert!((x - t * t).abs() < 1e-9, "x({t}) = {x}");
        }
    }
}
