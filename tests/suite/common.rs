//! Helpers the capability modules share: the paper systems and their
//! reference data (declared once in the root package), comparisons, and
//! scratch paths.

use std::path::{Path, PathBuf};

pub use metriplectic::systems::{
    linear2d_data, perturbed_reference_entropy, rigid_body_data, Linear2d, RigidBody,
};
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    synthesize, History, InitialStates, IterationScheme, SampleTimes, SynthesisOptions,
    SyntheticData, Validation,
};

/// The history with wall times zeroed: everything else about a run is
/// reproducible.
pub fn without_timings(history: &History) -> History {
    let mut history = history.clone();
    for record in &mut history.iterations {
        let joint = record.joint.as_mut().map(|j| &mut j.step);
        for step in [Some(&mut record.metric), Some(&mut record.entropy), joint]
            .into_iter()
            .flatten()
        {
            step.report.assembly_seconds = 0.0;
            step.report.solver_seconds = 0.0;
        }
    }
    history
}

/// θ of the constant metric K = c·I for system `S`.
pub fn identity_metric<S: MetriplecticSystem>(scale: f64) -> Vec<f64> {
    let unit = Model::<S>::with_identity_metric(vec![0.0; S::entropy_coefficient_count()])
        .expect("valid coefficients");
    unit.metric_coefficients()
        .iter()
        .map(|t| t * scale)
        .collect()
}

/// max |a − b|.
pub fn max_abs_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// The 2-D `states` with `model`'s exact ẋ.
pub fn exact_dataset<S: MetriplecticSystem>(model: &Model<S>, states: &[[f64; 2]]) -> Dataset {
    let derivatives: Vec<[f64; 2]> = states
        .iter()
        .map(|x| {
            let mut f = [0.0; 2];
            model.vector_field(x, &mut f).unwrap();
            f
        })
        .collect();
    Dataset::from_rows(2, states, &derivatives).unwrap()
}

/// Σ|f(x) − ẋ| / Σ|ẋ| of `model` on `data`.
pub fn relative_error<S: MetriplecticSystem>(model: &Model<S>, data: &Dataset) -> f64 {
    let mut f = vec![0.0; S::DIM];
    let (mut num, mut den) = (0.0, 0.0);
    for (x, xdot) in data.iter() {
        model.vector_field(x, &mut f).expect("dimension checked");
        num += f.iter().zip(xdot).map(|(a, b)| (a - b).abs()).sum::<f64>();
        den += xdot.iter().map(|v| v.abs()).sum::<f64>();
    }
    num / den
}

/// Position of the upper-triangle pair (j, k) among the n(n+1)/2 pairs of θ.
pub fn metric_pair_index(dim: usize, j: usize, k: usize) -> usize {
    let (j, k) = (j.min(k), j.max(k));
    j * dim - j * j.saturating_sub(1) / 2 + (k - j)
}

/// The paper's alternation on the full batch with no stopping rule but the
/// tolerance (no stagnation, validation or polish): the defaults the
/// identification tests were written for before the joint scheme became
/// the default.
pub fn alternation() -> IdentifyConfig {
    IdentifyConfig {
        batch_size: None,
        stagnation: None,
        validation: Validation::None,
        polish: false,
        scheme: IterationScheme::Alternating,
        ..IdentifyConfig::default()
    }
}

/// Synthetic data of the reference model of `S`: 40 trajectories of
/// duration 3 from the cube of half-width `half_width`, 30 log-uniform
/// samples each from t = 1e-3, 5 of them held out, seeded by `seed`.
pub fn reference_trajectories<S: MetriplecticSystem>(half_width: f64, seed: u64) -> SyntheticData {
    let truth = Model::<S>::reference().expect("reference declared");
    let options = SynthesisOptions {
        trajectories: 40,
        duration: 3.0,
        held_out_trajectories: 5,
        seed,
        ..SynthesisOptions::new(
            InitialStates::cube(S::DIM, half_width),
            SampleTimes::LogUniform {
                count: 30,
                first: 1e-3,
            },
        )
    };
    synthesize(&truth, &options).expect("a stable reference")
}

/// `target/tmp/<group>/<name>` with whatever an earlier run left there
/// removed and its parent created. Scratch files live in the build's
/// temporary directory, not the system's, so that they go with the build.
pub fn scratch_path(group: &str, name: &str) -> PathBuf {
    let path = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(group)
        .join(name);
    let _ = std::fs::remove_dir_all(&path);
    let _ = std::fs::remove_file(&path);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    path
}

/// A fresh, empty directory at [`scratch_path`]`(group, name)`.
pub fn scratch_dir(group: &str, name: &str) -> PathBuf {
    let dir = scratch_path(group, name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
