//! The data layer: identification samples ([`Dataset`]), sampled
//! trajectories ([`Trajectory`]), the trajectory CSV format, and derivative
//! estimation for trajectories measured without ẋ.

mod csv;
mod dataset;
mod derivative;
pub(crate) mod equations;
mod trajectory;
mod weak;

pub use csv::{
    read_trajectories, read_trajectories_from, write_trajectories, write_trajectories_to,
    MAX_CSV_BYTES,
};
pub use dataset::Dataset;
pub use derivative::{
    differentiate, estimate_all, estimate_derivatives, fit_smoothing_spline, DerivativeMethod,
    SmoothingSplineFit,
};
pub(crate) use equations::check_dataset;
pub use equations::IdentificationData;
pub use trajectory::{dataset_from_trajectories, split_by_trajectory, Trajectory};
pub use weak::{WeakDataset, WeakForm};
