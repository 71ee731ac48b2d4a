//! The per-iteration record of an identification run.

use std::io::Write;

use serde::{Deserialize, Serialize};

use super::cost::Cost;
use super::search::SearchReport;
use crate::solve::SolveStatus;

/// What became of one subproblem's result.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum StepOutcome {
    /// The result replaced the current model.
    Accepted,
    /// The solve succeeded but its cost on the batch was higher than the
    /// current model's; the current model was kept.
    RejectedWorse,
    /// The solve failed (status not usable, or non-finite coefficients);
    /// the current model was kept.
    RejectedFailed,
}

/// One subproblem of one iteration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepRecord {
    /// Solver status, iterations, timings and the candidate's recomputed cost.
    pub report: SearchReport,
    /// Whether the candidate was accepted.
    pub outcome: StepOutcome,
    /// Cost of the current model on the batch after this step.
    pub cost_after: Cost,
}

/// One iteration of the identifier.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IterationRecord {
    /// Iteration number, from 1.
    pub iteration: usize,
    /// Samples in this iteration's batch.
    pub batch_size: usize,
    /// Cost of the current model on this batch before the iteration.
    pub cost_before: Cost,
    /// The metric search (entropy fixed).
    pub metric: StepRecord,
    /// The entropy search (metric fixed).
    pub entropy: StepRecord,
    /// The joint step, if the scheme takes one.
    #[serde(default)]
    pub joint: Option<JointStepRecord>,
}

impl IterationRecord {
    /// Cost of the current model on this iteration's batch after the
    /// iteration's last step.
    pub fn cost_after(&self) -> Cost {
        self.joint
            .as_ref()
            .map_or(self.entropy.cost_after, |joint| joint.step.cost_after)
    }
}

/// The joint step of one iteration ([`IterationScheme::AlternatingThenJoint`](crate::IterationScheme::AlternatingThenJoint)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointStepRecord {
    /// Solve report and outcome, as for the other steps.
    pub step: StepRecord,
    /// Trust radius Δ the step was taken with.
    pub radius: f64,
    /// Batch cost the linearised model predicted for the step (`None` if
    /// the solver returned non-finite values).
    pub predicted: Option<Cost>,
    /// Actual decrease over predicted decrease, if the step was accepted
    /// and a decrease was predicted.
    pub ratio: Option<f64>,
}

/// The per-iteration history of an identification run.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct History {
    /// One record per iteration, in order.
    pub iterations: Vec<IterationRecord>,
}

impl History {
    /// Writes the history as CSV, one row per iteration, with a header.
    pub fn write_csv<W: Write>(&self, mut out: W) -> std::io::Result<()> {
        writeln!(
            out,
            "iteration,batch_size,cost_before_sum,cost_before_per_component,\
             metric_status,metric_outcome,metric_ipm_iterations,metric_assembly_s,metric_solver_s,\
             metric_candidate_per_component,metric_cost_after_sum,metric_cost_after_per_component,\
             entropy_status,entropy_outcome,entropy_ipm_iterations,entropy_assembly_s,entropy_solver_s,\
             entropy_candidate_per_component,entropy_cost_after_sum,entropy_cost_after_per_component,\
             joint_status,joint_outcome,joint_ipm_iterations,joint_assembly_s,joint_solver_s,\
             joint_candidate_per_component,joint_cost_after_sum,joint_cost_after_per_component,\
             joint_radius,joint_predicted_per_component,joint_ratio"
        )?;
        for r in &self.iterations {
            write!(
                out,
                "{},{},{},{}",
                r.iteration, r.batch_size, r.cost_before.sum, r.cost_before.per_component
            )?;
            for step in [
                Some(&r.metric),
                Some(&r.entropy),
                r.joint.as_ref().map(|j| &j.step),
            ] {
                let Some(step) = step else {
                    write!(out, ",,,,,,,,")?;
                    continue;
                };
                let candidate = step
                    .report
                    .cost
                    .map(|c| c.per_component.to_string())
                    .unwrap_or_default();
                write!(
                    out,
                    ",{},{:?},{},{},{},{},{},{}",
                    step.report.status,
                    step.outcome,
                    step.report.iterations,
                    step.report.assembly_seconds,
                    step.report.solver_seconds,
                    candidate,
                    step.cost_after.sum,
                    step.cost_after.per_component
                )?;
            }
            match &r.joint {
                Some(joint) => write!(
                    out,
                    ",{},{},{}",
                    joint.radius,
                    joint
                        .predicted
                        .map(|c| c.per_component.to_string())
                        .unwrap_or_default(),
                    joint.ratio.map(|c| c.to_string()).unwrap_or_default()
                )?,
                None => write!(out, ",,,")?,
            }
            writeln!(out)?;
        }
        Ok(())
    }

    /// Counts of each solver status over both subproblems: (metric, entropy).
    pub fn status_counts(&self) -> Vec<(SolveStatus, usize, usize)> {
        let mut counts: Vec<(SolveStatus, usize, usize)> = Vec::new();
        for r in &self.iterations {
            for (status, is_metric) in [
                (r.metric.report.status, true),
                (r.entropy.report.status, false),
            ] {
                let slot = match counts.iter().position(|c| c.0 == status) {
                    Some(i) => i,
                    None => {
                        counts.push((status, 0, 0));
                        counts.len() - 1
                    }
                };
                if is_metric {
                    counts[slot].1 += 1;
                } else {
                    counts[slot].2 += 1;
                }
            }
        }
        counts
    }

    /// Counts of each solver status of the joint steps (empty for the
    /// alternating scheme).
    pub fn joint_status_counts(&self) -> Vec<(SolveStatus, usize)> {
        let mut counts: Vec<(SolveStatus, usize)> = Vec::new();
        for joint in self.iterations.iter().filter_map(|r| r.joint.as_ref()) {
            let status = joint.step.report.status;
            match counts.iter_mut().find(|c| c.0 == status) {
                Some(slot) => slot.1 += 1,
                None => counts.push((status, 1)),
            }
        }
        counts
    }
}

/// Why [`identify`](crate::identify) stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum StopReason {
    /// The batch cost per component reached the tolerance.
    Converged,
    /// The iteration cap was reached.
    MaxIterations,
    /// The observer asked to stop.
    Interrupted,
    /// Consecutive iterations in which both solves failed; the best model
    /// reached before is returned.
    SolverFailures,
}
