//! The per-iteration record of an identification run.

use std::io::Write;

use serde::{Deserialize, Serialize};

use super::cost::Cost;
use super::search::SearchReport;
use crate::error::{Error, Result};
use crate::solve::SolveStatus;

/// What became of one subproblem's result.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum StepOutcome {
    /// The result replaced the current model.
    Accepted,
    /// The solve succeeded but its cost on the batch was not lower than the
    /// current model's; the current model was kept.
    RejectedWorse,
    /// The solve failed (status not usable, or non-finite coefficients);
    /// the current model was kept.
    RejectedFailed,
    /// Nothing was solved: the current model is already this subproblem's
    /// optimum on this batch. A metric search is skipped when the previous
    /// iteration, on the same full batch, ended with an accepted joint step
    /// whose metric the metric search refitted at the current entropy: the
    /// search would solve that very problem again. The report then has
    /// status `Solved`, 0 iterations, 0 seconds and the current cost.
    Skipped,
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
    /// Cost of the model after the iteration on the validation samples of a
    /// minibatch run (`None` without validation).
    #[serde(default)]
    pub validation_cost: Option<Cost>,
    /// `true` for the final full-batch iteration that polishes a minibatch
    /// run's best model.
    #[serde(default)]
    pub polish: bool,
    /// `true` for an iteration of a full-batch run's warm-up on the start's
    /// subsample ([`IdentifyConfig::warm_up`](crate::IdentifyConfig::warm_up)):
    /// its batch is that subsample and its costs are on it.
    #[serde(default)]
    pub warm_up: bool,
    /// `true` for an iteration after the run's restart from a larger
    /// metric ([`IdentifyConfig::restart_on_stagnation`](crate::IdentifyConfig::restart_on_stagnation)):
    /// the run had stagnated, and a trial from that metric scored at most
    /// 0.9 of it. Default `false`, also for records saved before it
    /// existed.
    #[serde(default)]
    pub restart: bool,
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
    #[serde(with = "super::json_float::optional", default)]
    pub ratio: Option<f64>,
    /// Whether the candidate is the second-order corrected step (taken when
    /// the linearised step gained less than the trust region's good ratio
    /// and the corrected one fits the batch better; its solve's times are in
    /// `step`). Default `false`, also for records saved before it existed.
    #[serde(default)]
    pub second_order: bool,
    /// Whether the candidate's metric is the metric search's refit at the
    /// step's entropy rather than the linearised step's own (taken when
    /// that gained less than the trust region's good ratio and the refit
    /// fits the batch better; its solve's times are in `step`). Default
    /// `false`, also for records saved before it existed.
    #[serde(default)]
    pub metric_refit: bool,
}

/// The per-iteration history of an identification run.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct History {
    /// One record per iteration, in order.
    pub iterations: Vec<IterationRecord>,
}

impl History {
    /// The column names of [`write_csv`](Self::write_csv), in order.
    pub const CSV_COLUMNS: &'static [&'static str] = &[
        "iteration",
        "polish",
        "batch_size",
        "cost_before_sum",
        "cost_before_per_component",
        "metric_status",
        "metric_outcome",
        "metric_ipm_iterations",
        "metric_assembly_s",
        "metric_solver_s",
        "metric_candidate_per_component",
        "metric_cost_after_sum",
        "metric_cost_after_per_component",
        "entropy_status",
        "entropy_outcome",
        "entropy_ipm_iterations",
        "entropy_assembly_s",
        "entropy_solver_s",
        "entropy_candidate_per_component",
        "entropy_cost_after_sum",
        "entropy_cost_after_per_component",
        "joint_status",
        "joint_outcome",
        "joint_ipm_iterations",
        "joint_assembly_s",
        "joint_solver_s",
        "joint_candidate_per_component",
        "joint_cost_after_sum",
        "joint_cost_after_per_component",
        "joint_radius",
        "joint_predicted_per_component",
        "joint_ratio",
        "joint_second_order",
        "joint_metric_refit",
        "validation_per_component",
        "warm_up",
        "restart",
    ];

    /// Writes the history as CSV, one row per iteration, with a header
    /// ([`CSV_COLUMNS`](Self::CSV_COLUMNS)); empty cells for steps an
    /// iteration did not take. Write errors are [`Error::Io`] with the path
    /// `<writer>`.
    ///
    /// ```
    /// use metriplectic_runtime::History;
    ///
    /// let mut text = Vec::new();
    /// History::default().write_csv(&mut text)?;
    /// assert!(String::from_utf8(text).unwrap().starts_with("iteration,polish,batch_size,"));
    /// # Ok::<(), metriplectic_runtime::Error>(())
    /// ```
    pub fn write_csv<W: Write>(&self, out: W) -> Result<()> {
        let mut writer = csv::Writer::from_writer(out);
        let io = |error: csv::Error| Error::Io {
            path: "<writer>".into(),
            source: error.into(),
        };
        writer.write_record(Self::CSV_COLUMNS).map_err(io)?;
        let number = |v: f64| v.to_string();
        for r in &self.iterations {
            let mut row = vec![
                r.iteration.to_string(),
                r.polish.to_string(),
                r.batch_size.to_string(),
                number(r.cost_before.sum),
                number(r.cost_before.per_component),
            ];
            for step in [
                Some(&r.metric),
                Some(&r.entropy),
                r.joint.as_ref().map(|j| &j.step),
            ] {
                match step {
                    None => row.extend(std::iter::repeat_n(String::new(), 8)),
                    Some(step) => row.extend([
                        step.report.status.to_string(),
                        format!("{:?}", step.outcome),
                        step.report.iterations.to_string(),
                        number(step.report.assembly_seconds),
                        number(step.report.solver_seconds),
                        step.report
                            .cost
                            .map(|c| number(c.per_component))
                            .unwrap_or_default(),
                        number(step.cost_after.sum),
                        number(step.cost_after.per_component),
                    ]),
                }
            }
            match &r.joint {
                Some(joint) => row.extend([
                    number(joint.radius),
                    joint
                        .predicted
                        .map(|c| number(c.per_component))
                        .unwrap_or_default(),
                    joint.ratio.map(number).unwrap_or_default(),
                    joint.second_order.to_string(),
                    joint.metric_refit.to_string(),
                ]),
                None => row.extend(std::iter::repeat_n(String::new(), 5)),
            }
            row.push(
                r.validation_cost
                    .map(|c| number(c.per_component))
                    .unwrap_or_default(),
            );
            row.push(r.warm_up.to_string());
            row.push(r.restart.to_string());
            writer.write_record(&row).map_err(io)?;
        }
        writer.flush().map_err(|source| Error::Io {
            path: "<writer>".into(),
            source,
        })
    }

    /// Counts of each solver status over both subproblems: (metric,
    /// entropy). Skipped steps ([`StepOutcome::Skipped`]) solved nothing
    /// and are not counted.
    pub fn status_counts(&self) -> Vec<(SolveStatus, usize, usize)> {
        let mut counts: Vec<(SolveStatus, usize, usize)> = Vec::new();
        for r in &self.iterations {
            for (step, is_metric) in [(&r.metric, true), (&r.entropy, false)] {
                if step.outcome == StepOutcome::Skipped {
                    continue;
                }
                let status = step.report.status;
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
    /// The cost per component reached the tolerance, relative to the
    /// scored samples' mean |ẋ|: the validation samples when there are any
    /// (all the data under the default [`Validation::AllData`]), otherwise
    /// the batch ([`IdentifyConfig::tolerance`]).
    ///
    /// [`Validation::AllData`]: crate::Validation::AllData
    /// [`IdentifyConfig::tolerance`]: crate::IdentifyConfig::tolerance
    Converged,
    /// The run stopped improving: its score did not improve for the
    /// configured window of iterations.
    Stagnated,
    /// The iteration cap was reached.
    MaxIterations,
    /// The observer asked to stop.
    Interrupted,
    /// Consecutive iterations in which both solves failed; the best model
    /// reached before is returned.
    SolverFailures,
}
