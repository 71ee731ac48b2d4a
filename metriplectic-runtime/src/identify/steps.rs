//! One iteration on a batch: the metric search, the entropy search and the
//! joint step, each kept only when it lowers the batch cost (the paper's
//! Theorem 1); a joint step that gained little is corrected to second order
//! and its metric refitted.

use super::config::{IdentifyConfig, IterationScheme, TrustRegion};
use super::cost::{model_cost, Cost};
use super::history::{History, JointStepRecord, StepOutcome, StepRecord};
use super::search::joint::corrected_joint_step;
use super::search::{
    entropy_search, joint_step, metric_search, JointStep, SearchOptions, SearchReport,
};
use super::state::RunState;
use crate::data::IdentificationData;
use crate::error::Result;
use crate::model::Model;
use crate::solve::SolveStatus;
use crate::system::MetriplecticSystem;

/// The steps of one iteration on `batch` from `state.model` (and the trust
/// radius), accepted under Theorem 1's rule; updates the model and radius.
/// `metric_fitted`: the model's metric is already the metric search's
/// optimum at its entropy on this batch ([`metric_is_fitted`]), so that
/// search is skipped.
pub(super) fn iterate_on<S: MetriplecticSystem>(
    batch: &impl IdentificationData,
    config: &IdentifyConfig,
    state: &mut RunState<S>,
    metric_fitted: bool,
) -> Result<(Cost, StepRecord, StepRecord, Option<JointStepRecord>)> {
    let options = &config.search;
    let model = &mut state.model;
    let cost_before = model_cost(model, batch)?;

    let metric = if metric_fitted {
        StepRecord {
            report: SearchReport {
                status: SolveStatus::Solved,
                iterations: 0,
                assembly_seconds: 0.0,
                solver_seconds: 0.0,
                cost: Some(cost_before),
            },
            outcome: StepOutcome::Skipped,
            cost_after: cost_before,
        }
    } else {
        let search = metric_search::<S>(batch, model.entropy_coefficients(), options)?;
        decide(model, cost_before, search.report, |m| {
            *m = Model::new(m.entropy_coefficients().to_vec(), search.coefficients)?
                .with_certificate_if_it_holds(search.certificate);
            Ok(())
        })
    };
    let search = entropy_search::<S>(batch, model.metric_coefficients(), options)?;
    let entropy = decide(model, metric.cost_after, search.report, |m| {
        m.set_entropy_coefficients(search.coefficients)
    });

    let joint = match &config.scheme {
        IterationScheme::Alternating => None,
        IterationScheme::AlternatingThenJoint(trust) => {
            let current = entropy.cost_after;
            let radius = state.radius;
            let mut step = joint_step::<S>(batch, model, radius, options)?;
            let second_order =
                correct_step::<S>(batch, model, current, radius, &mut step, trust, options)?;
            let metric_refit = refit_metric::<S>(batch, current, &mut step, trust, options)?;
            let record = decide(model, current, step.report, |m| {
                *m = Model::new(step.entropy, step.metric)?
                    .with_certificate_if_it_holds(step.certificate);
                Ok(())
            });
            let ratio = match (record.outcome, step.predicted) {
                (StepOutcome::Accepted, Some(predicted)) if predicted.sum < current.sum => {
                    Some((current.sum - record.cost_after.sum) / (current.sum - predicted.sum))
                }
                _ => None,
            };
            state.radius = trust.update(radius, ratio);
            Some(JointStepRecord {
                step: record,
                radius,
                predicted: step.predicted,
                ratio,
                second_order,
                metric_refit,
            })
        }
    };
    Ok((cost_before, metric, entropy, joint))
}

/// Whether `step` gained less than `trust.good_ratio` of the decrease its
/// linearised model predicted from `current` (or is no valid model), the
/// case in which [`correct_step`] and [`refit_metric`] try to do better.
fn gained_little(step: &JointStep, current: Cost, trust: &TrustRegion) -> bool {
    let Some(predicted) = step.predicted.filter(|p| p.sum < current.sum) else {
        return false;
    };
    if !(step.report.status.is_usable() && step.entropy.iter().all(|c| c.is_finite())) {
        return false;
    }
    let own = step.report.cost.filter(Cost::is_finite).map(|c| c.sum);
    !own.is_some_and(|own| (current.sum - own) >= trust.good_ratio * (current.sum - predicted.sum))
}

/// The second-order correction of a joint step that gained little
/// ([`corrected_joint_step`]): the same program from `model` with radius
/// `radius`, its targets shifted by the bilinear term the linearisation
/// dropped, evaluated at the first candidate. The corrected candidate
/// replaces the first if its solve is usable and it fits the batch better;
/// the first one's prediction is kept (the trust region is judged by the
/// model it was given), the second solve's times are added to the
/// report. Returns whether it replaced it; never tried when
/// [`TrustRegion::second_order`] is off.
///
/// Near an exact fit the residuals that vanish at the solution lie on a
/// curved set; a linearised step leaves it by a second-order amount that
/// costs more than the step gains as soon as the step is long, so the
/// trust region shrinks and the run crawls along the set (the Maratos
/// effect of sequential linear programming). On a 2-D oscillator with
/// position-dependent friction the runs took 77–93 iterations with the
/// metric refit alone, each moving the same few coefficients by the same
/// small amount, and 11–15 with the correction (`docs/method.md` §3).
fn correct_step<S: MetriplecticSystem>(
    batch: &impl IdentificationData,
    model: &Model<S>,
    current: Cost,
    radius: f64,
    step: &mut JointStep,
    trust: &TrustRegion,
    options: &SearchOptions,
) -> Result<bool> {
    if !(trust.second_order && gained_little(step, current, trust)) {
        return Ok(false);
    }
    let Some(corrected) = corrected_joint_step::<S>(batch, model, radius, options, step)? else {
        return Ok(false);
    };
    let better = improves(&corrected.report, &corrected.entropy, step);
    step.report.assembly_seconds += corrected.report.assembly_seconds;
    step.report.solver_seconds += corrected.report.solver_seconds;
    if better.is_none() {
        return Ok(false);
    }
    let predicted = step.predicted;
    let report = SearchReport {
        assembly_seconds: step.report.assembly_seconds,
        solver_seconds: step.report.solver_seconds,
        ..corrected.report
    };
    *step = JointStep {
        predicted,
        report,
        ..corrected
    };
    Ok(true)
}

/// The cost of a replacement for `step` (its solve's `report` and the
/// coefficients it found) if the solve is usable, the coefficients finite
/// and the recomputed cost finite and lower than the step's own (any, if
/// the step's candidate had no finite cost).
fn improves(report: &SearchReport, coefficients: &[f64], step: &JointStep) -> Option<Cost> {
    let own = step.report.cost.filter(Cost::is_finite).map(|c| c.sum);
    let usable = report.status.is_usable() && coefficients.iter().all(|c| c.is_finite());
    report
        .cost
        .filter(|c| usable && c.is_finite() && own.is_none_or(|own| c.sum < own))
}

/// Variable projection for a joint step that gained little: when its
/// candidate (ψ + d, θ′) lowered the batch cost by less than
/// `trust.good_ratio` of the decrease the linearised model predicted (or
/// is not a valid model), the metric search refits θ at the step's
/// entropy ψ + d, and its metric replaces θ′ if it fits the batch better.
/// Returns whether it did; the refit's times are added to the step's
/// report, and its status replaces the step's when it is not `Solved`.
///
/// The cost is linear in θ for fixed ψ, so θ*(ψ) is one convex solve. Near
/// a curved valley of the bilinear cost the linearised step's θ′ is what
/// the dropped term (K(θ′) − K(θ))Jᵀd spoils, the trust region shrinks
/// until that term is negligible, and the run crawls: with a state-dependent
/// metric, `DragRigidBody` took 71 iterations (batch 1000), and a 2-D
/// oscillator with position-dependent friction did not converge in 100,
/// each step moving one entropy coefficient 1e-4 along its bound. With the
/// refit they took 12 and 77–93 (`docs/method.md` §3, "The joint step"),
/// and the friction system 11–15 with [`correct_step`] before the refit.
fn refit_metric<S: MetriplecticSystem>(
    batch: &impl IdentificationData,
    current: Cost,
    step: &mut JointStep,
    trust: &TrustRegion,
    options: &SearchOptions,
) -> Result<bool> {
    if !gained_little(step, current, trust) {
        return Ok(false);
    }
    let refit = metric_search::<S>(batch, &step.entropy, options)?;
    let better = improves(&refit.report, &refit.coefficients, step);
    step.report.assembly_seconds += refit.report.assembly_seconds;
    step.report.solver_seconds += refit.report.solver_seconds;
    let Some(cost) = better else {
        return Ok(false);
    };
    step.metric = refit.coefficients;
    step.certificate = refit.certificate;
    step.report.cost = Some(cost);
    if refit.report.status != SolveStatus::Solved {
        step.report.status = refit.report.status;
    }
    Ok(true)
}

/// Whether the current model's metric is the metric search's optimum at
/// its entropy on the coming batch: the batches are the full pool, and the
/// previous iteration of this phase (warm-up, restart or neither) ended with an
/// accepted joint step whose metric [`refit_metric`] fitted at the entropy
/// the model now has. The metric search would solve that same problem
/// again (the solves are deterministic), so it is skipped. Derived from the
/// history alone, so a resumed run decides as the uninterrupted one did.
pub(super) fn metric_is_fitted(
    config: &IdentifyConfig,
    history: &History,
    warm_up: bool,
    restart: bool,
) -> bool {
    config.batch_size.is_none()
        && history.iterations.last().is_some_and(|last| {
            last.warm_up == warm_up
                && last.restart == restart
                && !last.polish
                && last.joint.as_ref().is_some_and(|joint| {
                    joint.metric_refit && joint.step.outcome == StepOutcome::Accepted
                })
        })
}

/// Accepts a candidate if its solve is usable and its recomputed cost is
/// finite and lower than `current`; `apply` installs it.
fn decide<S: MetriplecticSystem>(
    model: &mut Model<S>,
    current: Cost,
    report: SearchReport,
    apply: impl FnOnce(&mut Model<S>) -> Result<()>,
) -> StepRecord {
    let outcome = match report.cost {
        Some(candidate) if report.status.is_usable() && candidate.is_finite() => {
            if candidate.sum < current.sum && apply(model).is_ok() {
                StepOutcome::Accepted
            } else if candidate.sum < current.sum {
                StepOutcome::RejectedFailed
            } else {
                StepOutcome::RejectedWorse
            }
        }
        _ => StepOutcome::RejectedFailed,
    };
    let cost_after = match (outcome, report.cost) {
        (StepOutcome::Accepted, Some(candidate)) => candidate,
        _ => current,
    };
    StepRecord {
        report,
        outcome,
        cost_after,
    }
}
