//! End-to-end tests of the metriplectic toolkit, one module per capability:
//! find the test of a feature by its name.
//!
//! | module | capability |
//! | --- | --- |
//! | `macro_errors` | every invalid `metriplectic!` input is a spanned compile error (trybuild, `tests/ui/`) |
//! | `hygiene` | generated code means the same whatever the caller's scope holds |
//! | `generated_code` | the code `metriplectic!` generates, against hand-written formulas |
//! | `data_io` | trajectory CSV, datasets, synthesis |
//! | `derivatives` | derivative estimation from states |
//! | `simulation` | integration, free-energy checks |
//! | `entropy_search`, `metric_search` | the two convex subproblems on the paper systems |
//! | `solver_status` | solver statuses and the joint step on the paper systems |
//! | `identification` | Algorithms 1 and 2 and the joint scheme |
//! | `stop_reasons`, `stopping` | why a run stopped, and that it stops by itself once its model is final |
//! | `checkpoint_resume` | checkpoints and resuming a run |
//! | `determinism` | identical results for a seed |
//! | `degenerate_systems` | systems at the edges of the DSL |
//! | `hostile_input`, `solver_trouble` | bad data and failing solves |
//! | `reproduction`, `reproduction_interrupt` | the paper reproductions end to end |
//! | `from_csv` | identification from a trajectory CSV, the `from_csv` example's pipeline |
//! | `region_certificates` | state-dependent metrics certified on a region |
//! | `oversized_bases` | entropy bases larger than the truth needs |
//! | `poisson_structures` | Poisson tensors beyond the paper's: se(3)* (a rigid body in a fluid), log-canonical |
//! | `plot` | figures |
//! | `classical` | the classical (GENERIC) form: constraints imposed, checked and recorded |
//! | `start_scale` | the default start's choice of the metric's order of magnitude |
//! | `what_the_data_determine` | identifiability reports, the gauge, degree selection, sparse refits, bootstrap |

mod common;

mod badly_scaled_data;
mod checkpoint_resume;
mod classical;
mod data_io;
mod degenerate_systems;
mod derivatives;
mod determinism;
mod entropy_search;
mod from_csv;
mod generated_code;
mod hostile_input;
mod hygiene;
mod identification;
mod local_minima;
mod macro_errors;
mod metric_positivity;
mod metric_search;
mod model_files;
mod oversized_bases;
mod plot;
mod poisson_structures;
mod region_certificates;
mod reproduction;
mod reproduction_interrupt;
mod simulation;
mod solver_status;
mod solver_trouble;
mod start_scale;
mod stop_reasons;
mod stopping;
mod what_the_data_determine;
