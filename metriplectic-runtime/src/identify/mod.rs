//! The identification layer: the driver (the paper's Algorithms 1 and 2:
//! the public entry points and the result), where a run starts (`start`),
//! its warm-up on a subsample (`warm_up`), the iteration loop and its
//! stopping rules (`iterate`), one iteration's steps and their acceptance
//! (`steps`), the configuration, history, checkpoints and cost, and the
//! three convex searches in [`search`].

mod checkpoint;
mod config;
mod cost;
mod driver;
mod history;
mod iterate;
mod json_float;
mod restart;
pub(crate) mod search;
pub(crate) mod start;
mod state;
mod steps;
mod support;
mod warm_up;
mod warnings;

pub use checkpoint::CheckpointConfig;
pub use config::{IdentifyConfig, IterationScheme, Stagnation, TrustRegion, Validation};
pub use cost::{model_cost, Cost};
pub use driver::{
    identify, identify_resume, identify_resume_with_observer, identify_with_observer,
    Identification,
};
pub use history::{History, IterationRecord, JointStepRecord, StepOutcome, StepRecord, StopReason};
pub use search::{
    entropy_search, joint_step, metric_search, EntropySearch, JointStep, MetricSearch,
    SearchOptions, SearchReport, SosBasis,
};
pub use support::{Gauge, Support};
pub use warnings::{CoefficientBlock, IdentifyWarning, Subproblem};
