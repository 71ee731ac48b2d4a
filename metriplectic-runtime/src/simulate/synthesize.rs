//! Synthetic identification data from a known model, reproducible by seed.

use rand::seq::index;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StandardNormal};

use super::{simulate, IntegratorOptions, OutputTimes, SimulationOptions};
use crate::data::{dataset_from_trajectories, Dataset, Trajectory};
use crate::error::{invalid, Result};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// Distribution of the initial states.
///
/// ```
/// use metriplectic_runtime::InitialStates;
///
/// let square = InitialStates::cube(2, 1.5); // uniform in [−1.5, 1.5]²
/// let ball = InitialStates::Ball { center: vec![0.0; 3], radius: 2.0 };
/// # let _ = (square, ball);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub enum InitialStates {
    /// Uniform in the box Πⱼ [lowerⱼ, upperⱼ] (each coordinate independent).
    Box {
        /// Lower corner.
        lower: Vec<f64>,
        /// Upper corner (each entry ≥ the lower one).
        upper: Vec<f64>,
    },
    /// Uniform in the ball ‖x − center‖ ≤ radius (direction from a normalised
    /// Gaussian, radius · U^(1/n) for the distance).
    Ball {
        /// Centre.
        center: Vec<f64>,
        /// Radius (> 0).
        radius: f64,
    },
}

impl InitialStates {
    /// The cube [−half_width, half_width]ⁿ.
    pub fn cube(dim: usize, half_width: f64) -> Self {
        Self::Box {
            lower: vec![-half_width; dim],
            upper: vec![half_width; dim],
        }
    }

    fn validate(&self, dim: usize) -> Result<()> {
        match self {
            Self::Box { lower, upper } => {
                crate::error::check_len("box lower corner", lower, dim)?;
                crate::error::check_len("box upper corner", upper, dim)?;
                crate::error::check_finite("box lower corner", lower)?;
                crate::error::check_finite("box upper corner", upper)?;
                if let Some(j) = (0..dim).find(|&j| upper[j] < lower[j]) {
                    return Err(invalid(
                        "initial-state box",
                        format!("coordinate {j}: upper {} < lower {}", upper[j], lower[j]),
                    ));
                }
            }
            Self::Ball { center, radius } => {
                crate::error::check_len("ball centre", center, dim)?;
                crate::error::check_finite("ball centre", center)?;
                if !(radius.is_finite() && *radius > 0.0) {
                    return Err(invalid(
                        "initial-state ball radius",
                        format!("{radius}: must be finite and > 0"),
                    ));
                }
            }
        }
        Ok(())
    }

    fn draw(&self, rng: &mut ChaCha8Rng) -> Vec<f64> {
        match self {
            Self::Box { lower, upper } => lower
                .iter()
                .zip(upper)
                .map(|(lo, hi)| lo + (hi - lo) * rng.random::<f64>())
                .collect(),
            Self::Ball { center, radius } => {
                let n = center.len();
                let mut direction: Vec<f64> = (0..n).map(|_| StandardNormal.sample(rng)).collect();
                let norm = direction.iter().map(|v| v * v).sum::<f64>().sqrt();
                let distance = radius * rng.random::<f64>().powf(1.0 / n as f64);
                // A zero Gaussian vector has probability 0; fall back to the centre.
                let scale = if norm > 0.0 { distance / norm } else { 0.0 };
                direction
                    .iter_mut()
                    .zip(center)
                    .for_each(|(d, c)| *d = c + *d * scale);
                direction
            }
        }
    }
}

/// When each trajectory is sampled (times from its start, t = 0).
///
/// ```
/// use metriplectic_runtime::SampleTimes;
///
/// let grid = SampleTimes::Uniform { interval: 0.01 };
/// let log = SampleTimes::LogUniform { count: 200, first: 1e-3 };
/// # let _ = (grid, log);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SampleTimes {
    /// 0, Δ, 2Δ, … up to the duration.
    Uniform {
        /// Sampling interval Δ (> 0; at most 10⁷ samples per trajectory).
        interval: f64,
    },
    /// `count` times drawn independently with log t uniform on
    /// [log `first`, log duration], sorted (distinct with probability 1).
    /// Dense early, sparse late: covers both the fast transient and the slow
    /// approach to the attractor.
    LogUniform {
        /// Samples per trajectory (1 to 10⁷).
        count: usize,
        /// Earliest possible time (0 < first < duration).
        first: f64,
    },
}

/// Additive Gaussian measurement noise (absolute standard deviations; 0 = none).
///
/// ```
/// use metriplectic_runtime::Noise;
/// let noise = Noise { state_std: 1e-3, derivative_std: 1e-2 };
/// # let _ = noise;
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Noise {
    /// σ of the noise added to every state component. Default 0.
    pub state_std: f64,
    /// σ of the noise added to every derivative component. Default 0.
    pub derivative_std: f64,
}

/// Gross outliers in the training derivatives.
///
/// Exactly `round(fraction · m)` of the m training samples, chosen uniformly
/// without replacement, get independent N(0, magnitude²) offsets added to
/// every component of ẋ. Held-out samples are never corrupted.
///
/// ```
/// use metriplectic_runtime::Outliers;
/// let outliers = Outliers { fraction: 0.05, magnitude: 10.0 };
/// # let _ = outliers;
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outliers {
    /// Fraction of training samples corrupted, in [0, 1].
    pub fraction: f64,
    /// Standard deviation of the offsets (> 0), e.g. 10× the typical |ẋ|.
    pub magnitude: f64,
}

/// What to synthesise.
///
/// ```
/// use metriplectic_runtime::{InitialStates, SampleTimes, SynthesisOptions};
///
/// let options = SynthesisOptions {
///     trajectories: 20,
///     duration: 5.0,
///     held_out_trajectories: 4,
///     seed: 7,
///     ..SynthesisOptions::new(InitialStates::cube(2, 1.5), SampleTimes::LogUniform { count: 50, first: 1e-3 })
/// };
/// assert_eq!(options.noise.state_std, 0.0);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SynthesisOptions {
    /// Number of trajectories (1 to 10⁶; at most 10⁸ samples in all).
    pub trajectories: usize,
    /// Duration of each trajectory (> 0).
    pub duration: f64,
    /// Initial-state distribution.
    pub initial: InitialStates,
    /// Sample times.
    pub times: SampleTimes,
    /// Measurement noise, on training and held-out samples alike.
    pub noise: Noise,
    /// Gross outliers in the training set.
    pub outliers: Option<Outliers>,
    /// Trajectories held out whole (fewer than `trajectories`).
    pub held_out_trajectories: usize,
    /// Integrator settings for the simulations.
    pub integrator: IntegratorOptions,
    /// Seed of all random draws.
    pub seed: u64,
}

impl SynthesisOptions {
    /// 10 trajectories of duration 1, no noise, no outliers, nothing held
    /// out, integrator tolerances rtol = 1e-9, atol = 1e-12, seed 0.
    pub fn new(initial: InitialStates, times: SampleTimes) -> Self {
        Self {
            trajectories: 10,
            duration: 1.0,
            initial,
            times,
            noise: Noise::default(),
            outliers: None,
            held_out_trajectories: 0,
            integrator: IntegratorOptions {
                rtol: 1e-9,
                atol: 1e-12,
                ..IntegratorOptions::default()
            },
            seed: 0,
        }
    }
}

/// Synthetic data and how it was made.
///
/// ```
/// # use metriplectic_runtime::prelude::*;
/// # use metriplectic_runtime::{synthesize, InitialStates, SampleTimes, SynthesisOptions};
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
/// let options = SynthesisOptions {
///     trajectories: 4,
///     held_out_trajectories: 1,
///     ..SynthesisOptions::new(InitialStates::cube(2, 1.0), SampleTimes::Uniform { interval: 0.1 })
/// };
/// let data = synthesize(&model, &options).unwrap();
/// assert_eq!(data.train.len(), 3 * 11);
/// assert_eq!(data.held_out.unwrap().len(), 11);
/// assert!(data.measured.iter().all(|t| t.len() == 11 && t.derivatives().is_none()));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticData {
    /// Training samples (noisy and corrupted as requested), trajectory by
    /// trajectory in time order.
    pub train: Dataset,
    /// Held-out samples (noisy as requested, never corrupted), if any.
    pub held_out: Option<Dataset>,
    /// The clean simulated trajectories (exact states and vector field at the
    /// sample times), identified "0", "1", …; the last
    /// `held_out_trajectories` of them are the held-out ones.
    pub trajectories: Vec<Trajectory>,
    /// What an instrument would record of the same trajectories: the
    /// sampled states with the requested state noise (the very values in
    /// `train` and `held_out`), no derivatives, same ids and times. The input
    /// of the measured-data workflow (derivative estimation or the weak form).
    pub measured: Vec<Trajectory>,
    /// Number of leading trajectories in the training set.
    pub train_trajectories: usize,
    /// Indices of corrupted samples in `train`, ascending.
    pub outlier_samples: Vec<usize>,
}

/// Synthesises a dataset from `model` as described by `options`.
///
/// It draws initial states, simulates the model from each, samples
/// every trajectory at chosen times and records (x, ẋ) with ẋ the model's
/// **exact** vector field at the (noise-free) sampled state. Optionally it
/// adds measurement noise and gross outliers, and holds whole trajectories out
/// for validation.
///
/// # Randomness
///
/// All draws come from ChaCha8 seeded with [`SynthesisOptions::seed`], one
/// independent stream per purpose: stream 0 draws the initial states and the
/// sample times, stream 1 the noise, stream 2 the outliers. The same seed and
/// options give bit-identical data, and changing only the noise or outlier
/// settings keeps the same trajectories.
///
/// # Held-out split
///
/// The last [`held_out_trajectories`](SynthesisOptions::held_out_trajectories)
/// trajectories are held out whole. Splitting by trajectory rather than by
/// sample keeps held-out states from being time-neighbours of training states
/// on the same trajectory, so the held-out error measures generalisation to
/// new initial conditions. (All trajectories are i.i.d., so taking the last
/// ones is a random split.)
pub fn synthesize<S: MetriplecticSystem>(
    model: &Model<S>,
    options: &SynthesisOptions,
) -> Result<SyntheticData> {
    validate(options, S::DIM)?;
    let mut draws = stream(options.seed, 0);
    let mut trajectories = Vec::with_capacity(options.trajectories);
    for k in 0..options.trajectories {
        let x0 = options.initial.draw(&mut draws);
        let times = sample_times(&options.times, options.duration, &mut draws);
        let simulation_options = SimulationOptions {
            integrator: options.integrator.clone(),
            output: OutputTimes::Times(times),
            ..SimulationOptions::default()
        };
        let simulation =
            simulate(model, &x0, 0.0, options.duration, &simulation_options).map_err(|error| {
                invalid(
                    &format!("synthetic trajectory {k} from initial state {x0:?}"),
                    error.to_string(),
                )
            })?;
        // Data whose free energy falls between samples are not data of a
        // metriplectic system: the integration was too loose to trust.
        let energy = &simulation.energy;
        if let (false, Some(step)) = (energy.is_non_decreasing(), energy.worst_step) {
            return Err(invalid(
                &format!("synthetic trajectory {k} from initial state {x0:?}"),
                format!(
                    "the free energy fell by {:e} between samples {step} and {} ({} times the \
                     integration error allows, {} of {} sample pairs); tighten the integrator \
                     tolerances (rtol, atol)",
                    energy.largest_decrease,
                    step + 1,
                    energy.largest_decrease_ratio,
                    energy.violations,
                    energy.steps
                ),
            ));
        }
        trajectories.push(simulation.trajectory.with_id(k.to_string()));
    }

    let train_count = options.trajectories - options.held_out_trajectories;
    let mut noise = stream(options.seed, 1);
    let mut train = dataset_from_trajectories(&trajectories[..train_count])?;
    train = add_noise(train, &options.noise, &mut noise)?;
    let held_out = if train_count < trajectories.len() {
        let data = dataset_from_trajectories(&trajectories[train_count..])?;
        Some(add_noise(data, &options.noise, &mut noise)?)
    } else {
        None
    };

    let measured = measured_trajectories(&trajectories, &train, held_out.as_ref())?;

    let mut outlier_samples = Vec::new();
    if let Some(outliers) = options.outliers {
        let mut rng = stream(options.seed, 2);
        let m = train.len();
        let count = ((outliers.fraction * m as f64).round() as usize).min(m);
        outlier_samples = index::sample(&mut rng, m, count).into_vec();
        outlier_samples.sort_unstable();
        let offsets = Normal::new(0.0, outliers.magnitude)
            .map_err(|e| invalid("outlier magnitude", e.to_string()))?;
        let n = train.dim();
        let mut derivatives = train.derivatives().to_vec();
        for &i in &outlier_samples {
            for d in &mut derivatives[i * n..(i + 1) * n] {
                *d += offsets.sample(&mut rng);
            }
        }
        if derivatives.iter().any(|v| !v.is_finite()) {
            return Err(invalid(
                "outlier magnitude",
                format!(
                    "{:e} makes derivatives overflow to infinity; use a magnitude on the data's scale",
                    outliers.magnitude
                ),
            ));
        }
        train = Dataset::from_flat(n, train.states().to_vec(), derivatives)?;
    }

    // Named as the trajectories are (noise and outliers rebuilt the data
    // from bare numbers), so identification checks them against its system.
    let names: Vec<String> = S::STATE_NAMES.iter().map(|&name| name.to_owned()).collect();
    Ok(SyntheticData {
        train: train.with_state_names(names.clone())?,
        held_out: held_out
            .map(|data| data.with_state_names(names))
            .transpose()?,
        trajectories,
        measured,
        train_trajectories: train_count,
        outlier_samples,
    })
}

/// The clean trajectories with their states replaced by the noisy samples of
/// `train` and `held_out` (which hold them back to back, in order).
fn measured_trajectories(
    trajectories: &[Trajectory],
    train: &Dataset,
    held_out: Option<&Dataset>,
) -> Result<Vec<Trajectory>> {
    let mut states = train
        .states()
        .iter()
        .chain(held_out.map_or(&[][..], Dataset::states))
        .copied();
    trajectories
        .iter()
        .map(|clean| {
            let noisy: Vec<f64> = states.by_ref().take(clean.states().len()).collect();
            let mut measured =
                Trajectory::new(clean.names().to_vec(), clean.times().to_vec(), noisy, None)?;
            if let Some(id) = clean.id() {
                measured = measured.with_id(id);
            }
            Ok(measured)
        })
        .collect()
}

fn stream(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

fn sample_times(times: &SampleTimes, duration: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    match *times {
        SampleTimes::Uniform { interval } => {
            let count = (duration / interval * (1.0 + 1e-12)).floor() as usize;
            (0..=count)
                .map(|k| (k as f64 * interval).min(duration))
                .collect()
        }
        SampleTimes::LogUniform { count, first } => {
            let (lo, hi) = (first.ln(), duration.ln());
            let mut t: Vec<f64> = (0..count)
                .map(|_| {
                    (lo + (hi - lo) * rng.random::<f64>())
                        .exp()
                        .clamp(first, duration)
                })
                .collect();
            t.sort_by(f64::total_cmp);
            // Ties have probability ~0 but would break strictly increasing output times.
            t.dedup();
            t
        }
    }
}

fn add_noise(data: Dataset, noise: &Noise, rng: &mut ChaCha8Rng) -> Result<Dataset> {
    if noise.state_std == 0.0 && noise.derivative_std == 0.0 {
        return Ok(data);
    }
    let mut states = data.states().to_vec();
    let mut derivatives = data.derivatives().to_vec();
    for (values, std) in [
        (&mut states, noise.state_std),
        (&mut derivatives, noise.derivative_std),
    ] {
        if std > 0.0 {
            for v in values.iter_mut() {
                *v += std * <StandardNormal as Distribution<f64>>::sample(&StandardNormal, rng);
            }
        }
    }
    // Name the option, not only the sample it broke.
    for (values, what, std) in [
        (&states, "state noise σ", noise.state_std),
        (&derivatives, "derivative noise σ", noise.derivative_std),
    ] {
        if values.iter().any(|v| !v.is_finite()) {
            return Err(invalid(
                what,
                format!("{std:e} makes samples overflow to infinity; use a σ on the data's scale"),
            ));
        }
    }
    Ok(Dataset::from_flat(data.dim(), states, derivatives)?)
}

/// Most samples a synthesised trajectory may have.
const MAX_SAMPLES_PER_TRAJECTORY: usize = 10_000_000;

/// Most samples all synthesised trajectories together may have: beyond it
/// the allocation, not the options, would fail.
const MAX_SAMPLES: usize = 100_000_000;

/// Most trajectories synthesised: each is an integration and a few
/// allocations of its own, whatever its sample count.
const MAX_TRAJECTORIES: usize = 1_000_000;

fn validate(options: &SynthesisOptions, dim: usize) -> Result<()> {
    if !(1..=MAX_TRAJECTORIES).contains(&options.trajectories) {
        return Err(invalid(
            "number of trajectories",
            format!(
                "{} requested: must be between 1 and 10⁶",
                options.trajectories
            ),
        ));
    }
    if options.held_out_trajectories >= options.trajectories {
        return Err(invalid(
            "held-out trajectories",
            format!(
                "{} of {}: at least one trajectory must remain for training",
                options.held_out_trajectories, options.trajectories
            ),
        ));
    }
    if !(options.duration.is_finite() && options.duration > 0.0) {
        return Err(invalid(
            "duration",
            format!("{}: must be finite and > 0", options.duration),
        ));
    }
    options.initial.validate(dim)?;
    match options.times {
        SampleTimes::Uniform { interval } => {
            if !(interval.is_finite() && interval > 0.0) {
                return Err(invalid(
                    "sampling interval",
                    format!("{interval}: must be finite and > 0"),
                ));
            }
            if options.duration / interval > MAX_SAMPLES_PER_TRAJECTORY as f64 {
                return Err(invalid(
                    "sampling interval",
                    format!("{interval} gives more than 10⁷ samples per trajectory"),
                ));
            }
        }
        SampleTimes::LogUniform { count, first } => {
            if count == 0 || count > MAX_SAMPLES_PER_TRAJECTORY {
                return Err(invalid(
                    "log-uniform sample count",
                    format!("{count}: must be between 1 and 10⁷"),
                ));
            }
            if !(first.is_finite() && first > 0.0 && first < options.duration) {
                return Err(invalid(
                    "first log-uniform time",
                    format!("{first}: must lie in (0, duration = {})", options.duration),
                ));
            }
        }
    }
    let per_trajectory = match options.times {
        SampleTimes::Uniform { interval } => (options.duration / interval) as usize + 1,
        SampleTimes::LogUniform { count, .. } => count,
    };
    let total = options.trajectories.saturating_mul(per_trajectory);
    if total > MAX_SAMPLES {
        return Err(invalid(
            "number of trajectories",
            format!(
                "{} trajectories of {per_trajectory} samples are {total} samples; at most 10⁸ are synthesised",
                options.trajectories
            ),
        ));
    }
    for (what, std) in [
        ("state noise σ", options.noise.state_std),
        ("derivative noise σ", options.noise.derivative_std),
    ] {
        if !(std.is_finite() && std >= 0.0) {
            return Err(invalid(what, format!("{std}: must be finite and ≥ 0")));
        }
    }
    if let Some(outliers) = options.outliers {
        if !(0.0..=1.0).contains(&outliers.fraction) {
            return Err(invalid(
                "outlier fraction",
                format!("{}: must lie in [0, 1]", outliers.fraction),
            ));
        }
        if !(outliers.magnitude.is_finite() && outliers.magnitude > 0.0) {
            return Err(invalid(
                "outlier magnitude",
                format!("{}: must be finite and > 0", outliers.magnitude),
            ));
        }
    }
    Ok(())
}
